// The mark against a hostile review: invisible vertices and outliers added to desynchronize the
// histogram, margins that give the strength away, embeddings whose written file does not carry
// the mark, and batch manifests that would give one buyer another's copy.

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>

#include "meshmark/carrier/variant.h"
#include "meshmark/io/io.h"
#include "meshmark/mark/decode.h"
#include "meshmark/mark/embed.h"
#include "meshmark/protocol/coding.h"
#include "meshmark/protocol/detect.h"
#include "meshmark/protocol/key.h"
#include "meshmark/protocol/watermark.h"
#include "test_data.h"

namespace meshmark {
namespace {

struct Marked {
  Mesh mesh;
  std::uint64_t id = 0;
};

// spot.obj (2,930 vertices) marked with a coded ID under a key, VRS.
Marked marked_spot(const IdCode& code, const Key& key, std::uint64_t id) {
  Marked m;
  m.id = id;
  m.mesh = read_mesh(test::data_mesh("spot.obj"));
  EmbedOptions o;
  o.variant = parse_variant("VRS");
  const EmbedResult r = embed(m.mesh.V, m.mesh.F, id_bins(code, id, key), o);
  EXPECT_EQ(r.status, EmbedStatus::Embedded) << r.message;
  m.mesh.V = r.V;
  return m;
}

// Appends a vertex at p and a face (a, b, the new vertex).
void add_vertex(Mesh& mesh, const Eigen::Vector3d& p, int a, int b) {
  const Eigen::Index n = mesh.V.rows();
  mesh.V.conservativeResize(n + 1, 3);
  mesh.V.row(n) = p.transpose();
  mesh.F.conservativeResize(mesh.F.rows() + 1, 3);
  mesh.F.row(mesh.F.rows() - 1) << a, b, static_cast<int>(n);
}

ExtractOptions volume_center() {
  ExtractOptions o;
  o.center = CenterKind::Volume;
  return o;
}

TEST(MarkHardening, AVertexOnlyACollapsedFaceUsesDoesNotCount) {
  MESHMARK_REQUIRE(test::data_mesh("spot.obj"), "spot.obj");
  const IdCode code;
  const Key key = key_from_passphrase("hardening");
  Marked m = marked_spot(code, key, 4242);
  // At the center of mass, used by the face (n, n, 0): invisible, yet before the carrier
  // ignored collapsed faces it became the nearest vertex and moved every bin.
  const Eigen::Vector3d center = m.mesh.V.colwise().mean().transpose();
  add_vertex(m.mesh, center, 0, 0);
  m.mesh.F(m.mesh.F.rows() - 1, 0) = static_cast<int>(m.mesh.V.rows() - 1);
  const std::vector<std::uint8_t> carrier = carrier_vertices(m.mesh.V, m.mesh.F);
  EXPECT_EQ(carrier.back(), 0);
  EXPECT_EQ(std::count(carrier.begin(), carrier.end(), 1), m.mesh.V.rows() - 1);
  const IdReading r = read_id(m.mesh.V, m.mesh.F, volume_center(), code, key);
  ASSERT_TRUE(r.id.valid) << r.id.message;
  EXPECT_EQ(r.id.id, m.id);
  EXPECT_EQ(r.id.corrected, 0);
  EXPECT_EQ(r.skip_nearest + r.skip_farthest, 0);  // the normal reading already works
}

TEST(MarkHardening, FlatInvisibleTrianglesDoNotCount) {
  MESHMARK_REQUIRE(test::data_mesh("spot.obj"), "spot.obj");
  const IdCode code;
  const Key key = key_from_passphrase("hardening");
  Marked m = marked_spot(code, key, 31337);
  // Two triangles of three distinct collinear corners near the center: zero area, invisible.
  const Eigen::Vector3d c = m.mesh.V.colwise().mean().transpose();
  const Eigen::Vector3d d(1e-3, 2e-3, -1e-3);
  for (int t = 0; t < 2; ++t) {
    const Eigen::Index n = m.mesh.V.rows();
    m.mesh.V.conservativeResize(n + 3, 3);
    for (int k = 0; k < 3; ++k) m.mesh.V.row(n + k) = (c + (t + 1) * k * d).transpose();
    m.mesh.F.conservativeResize(m.mesh.F.rows() + 1, 3);
    m.mesh.F.row(m.mesh.F.rows() - 1) << static_cast<int>(n), static_cast<int>(n + 1),
        static_cast<int>(n + 2);
  }
  const std::vector<std::uint8_t> carrier = carrier_vertices(m.mesh.V, m.mesh.F);
  EXPECT_EQ(std::count(carrier.end() - 6, carrier.end(), 1), 0);
  const IdReading r = read_id(m.mesh.V, m.mesh.F, volume_center(), code, key);
  ASSERT_TRUE(r.id.valid) << r.id.message;
  EXPECT_EQ(r.id.id, m.id);
  EXPECT_EQ(r.readings, 1);
}

TEST(MarkHardening, UpToThreeOutliersAtEachEndAreLeftOutAndFourAreNot) {
  MESHMARK_REQUIRE(test::data_mesh("spot.obj"), "spot.obj");
  const IdCode code;
  const Key key = key_from_passphrase("hardening");
  const Marked m = marked_spot(code, key, 77);
  const Eigen::Vector3d lo = m.mesh.V.colwise().minCoeff(), hi = m.mesh.V.colwise().maxCoeff();
  const Eigen::Vector3d mid = 0.5 * (lo + hi), size = hi - lo;
  for (int far = 0; far <= 4; ++far)
    for (int near = 0; near <= 3; ++near) {
      if (far + near == 0) continue;
      Mesh attacked = m.mesh;
      // Each outlier with a real triangle (positive area) on two existing vertices.
      for (int k = 0; k < far; ++k)
        add_vertex(attacked, mid + (2.0 + k) * Eigen::Vector3d(size.x(), -size.y(), 0.5 * size.z()),
                   2 * k, 2 * k + 1);
      const Eigen::Vector3d center = m.mesh.V.colwise().mean().transpose();
      for (int k = 0; k < near; ++k)
        add_vertex(attacked, center + 1e-4 * (k + 1) * size, 10 + 2 * k, 11 + 2 * k);
      const IdReading r = read_id(attacked.V, attacked.F, volume_center(), code, key);
      SCOPED_TRACE(::testing::Message() << far << " far, " << near << " near");
      if (r.id.valid) EXPECT_EQ(r.id.id, m.id);  // never another ID
      if (far <= 3) {
        ASSERT_TRUE(r.id.valid) << r.id.message;
        EXPECT_EQ(r.skip_farthest, far);
        EXPECT_GE(r.skip_nearest, near > 0 ? 1 : 0);
        EXPECT_LE(r.id.corrected, code.retry_rule().errors);
      } else {
        EXPECT_FALSE(r.id.valid);  // beyond what the re-readings undo: no ID, not a wrong one
      }
      EXPECT_LE(r.readings, 1 + code.retries());
    }
}

TEST(MarkHardening, KeyedStrengthsHideTheStrength) {
  MESHMARK_REQUIRE(test::data_mesh("spot.obj"), "spot.obj");
  const Mesh spot = read_mesh(test::data_mesh("spot.obj"));
  const Key key = key_from_passphrase("hardening");
  const std::vector<double> alpha = keyed_strengths(key, 64, 0.05, 0.5);
  ASSERT_EQ(alpha.size(), 64u);
  EXPECT_EQ(alpha, keyed_strengths(key, 64, 0.05, 0.5));
  EXPECT_NE(alpha, keyed_strengths(key_from_passphrase("other"), 64, 0.05, 0.5));
  for (const double a : alpha) {
    EXPECT_GE(a, 0.05);
    EXPECT_LT(a, 0.075);
  }
  EXPECT_GT(
      *std::max_element(alpha.begin(), alpha.end()) - *std::min_element(alpha.begin(), alpha.end()),
      0.02);  // 64 uniform draws over [0.05, 0.075) span most of it
  // Embedded with those strengths, the margins read blind are spread over the same range
  // (each at least its strength), where a uniform strength puts them all at 0.05.
  const IdCode code;
  const BitLayout layout = mark_layout(key, 64, true);
  EmbedOptions o;
  o.strengths.assign(64, 0.05);
  for (int j = 0; j < 64; ++j) o.strengths[layout.bin_of[j]] = alpha[j];
  const Payload bins = id_bins(code, 9, key);
  const EmbedResult r = embed(spot.V, spot.F, bins, o);
  ASSERT_EQ(r.status, EmbedStatus::Embedded) << r.message;
  const ExtractResult x = extract(r.V, spot.F);
  const auto [least, most] = std::minmax_element(x.margins.begin(), x.margins.end());
  EXPECT_GE(*least, 0.05 - 1e-6);
  EXPECT_GT(*most - *least, 0.02);
  for (int j = 0; j < 64; ++j) EXPECT_GE(x.margins[layout.bin_of[j]], alpha[j] - 1e-6) << j;
  // What a reader without the key sees: with a uniform strength most bins sit exactly at it
  // (the cheapest optimum); with keyed strengths hardly any two bins share a margin.
  auto at_smallest = [](const std::vector<double>& margins) {
    const double least = *std::min_element(margins.begin(), margins.end());
    return std::count_if(margins.begin(), margins.end(),
                         [&](double m) { return m < least + 1e-4; });
  };
  const EmbedResult uniform = embed(spot.V, spot.F, bins);
  const ExtractResult u = extract(uniform.V, spot.F);
  EXPECT_GE(at_smallest(u.margins), 32);
  EXPECT_LE(at_smallest(x.margins), 3);
  RecordProperty("uniform_at_smallest", static_cast<int>(at_smallest(u.margins)));
  RecordProperty("keyed_at_smallest", static_cast<int>(at_smallest(x.margins)));
}

TEST(MarkHardening, NothingIsWrittenWhenTheFileWouldNotCarryTheMark) {
  const std::string horse = test::closed_binary_ply();
  MESHMARK_REQUIRE(horse, "bunny00.off");
  const std::string dir = test::scratch_dir();
  // Far below the precision of horse.ply's float32 coordinates, and below the solver's own
  // tolerance: both used to report success.
  for (const char* strength : {"1e-14", "1e-8"}) {
    const std::string out = dir + "/o" + strength + ".ply";
    const test::CliRun e = test::run_cli("embed " + horse + " " + out +
                                         " --payload 123456789abcdef0 --strength " + strength);
    EXPECT_EQ(e.code, 4) << e.out;
    EXPECT_FALSE(std::filesystem::exists(out)) << strength;
  }
  // At the default strength it is written, and the file read back decodes every bit.
  const std::string out = dir + "/ok.ply";
  const test::CliRun ok =
      test::run_cli("embed " + horse + " " + out + " --payload 123456789abcdef0");
  ASSERT_EQ(ok.code, 0) << ok.out;
  const Mesh back = read_mesh(out);
  EXPECT_EQ(extract(back.V, back.F).word(), payload_from_hex("123456789abcdef0", 64));
}

TEST(MarkHardening, BatchRefusesSharedOutputsAndReportsBadLinesPerLine) {
  const std::string spot = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(spot, "spot.obj");
  const std::string dir = test::scratch_dir();
  const std::string manifest = dir + "/jobs.txt";
  std::ofstream(manifest) << spot << " " << dir << "/a.obj 00000000000000ff\n"
                          << spot << " " << dir << "/a.obj 000000000000ff00\n"  // same OUT
                          << spot << " " << dir << "/b.obj\n"                   // malformed
                          << spot << " " << spot << " 0000000000ff0000\n"       // OUT = an input
                          << spot << " " << dir << "/c.obj 00000000ff000000\n";
  const test::CliRun r = test::run_cli("embed --batch " + manifest);
  EXPECT_EQ(r.code, 4) << r.out;
  EXPECT_FALSE(std::filesystem::exists(dir + "/a.obj")) << "a buyer got a shared output";
  EXPECT_FALSE(std::filesystem::exists(dir + "/b.obj"));
  EXPECT_NE(r.out.find("jobs.txt:1: FAILED"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("jobs.txt:2: FAILED"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("jobs.txt:3: FAILED"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("jobs.txt:4: FAILED"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("jobs.txt:5: ok"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("1 of 5 copies"), std::string::npos) << r.out;
  const Mesh c = read_mesh(dir + "/c.obj");
  EXPECT_EQ(extract(c.V, c.F).word(), payload_from_hex("00000000ff000000", 64));
}

}  // namespace
}  // namespace meshmark

namespace meshmark {
namespace {

TEST(MarkHardening, CommandLineRefusesAmbiguousKeysAndPayloads) {
  const std::string spot = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(spot, "spot.obj");
  const std::string out = test::scratch_dir() + "/x.obj";
  // An empty passphrase used to mean "no key": the canonical public layout, silently.
  test::CliRun r = test::run_cli("embed " + spot + " " + out + " --id 5 --key ''");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("empty"), std::string::npos) << r.out;
  r = test::run_cli("extract " + spot + " --coded --key ''");
  EXPECT_EQ(r.code, 1) << r.out;
  r = test::run_cli("embed " + spot + " " + out + " --id 5 --payload 00");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("--payload excludes --id"), std::string::npos) << r.out;
  r = test::run_cli("embed " + spot + " " + out + " --id 5 --key a --key-file /dev/null");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("--key excludes --key-file"), std::string::npos) << r.out;
  r = test::run_cli("embed " + spot + " " + out + " --id 5 --strength 0.04 --fidelity paper");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("--strength excludes --fidelity"), std::string::npos) << r.out;
  // Enum options take only their names (any case), checked before anything runs.
  r = test::run_cli("embed " + spot + " " + out + " --payload 00 --bits 8 --solver nonsense");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("--solver"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("one of: native, ipopt"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("->"), std::string::npos) << r.out;  // names, not the enum's integers
  r = test::run_cli("extract " + spot + " --bits 8 --method cho-median");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("one of: qp, cho-mean, cho-variance"), std::string::npos) << r.out;
  r = test::run_cli("extract " + spot + " --bits 8 --method CHO-MEAN --variant srs");
  EXPECT_EQ(r.code, 0) << r.out;  // names in any case
  r = test::run_cli("attack noise:0 " + spot + " " + out + " --format obj --encoding utf8");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("binary_little_endian"), std::string::npos) << r.out;
  r = test::run_cli("attack noise:0 " + spot + " " + out + " --format fbx");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("3mf"), std::string::npos) << r.out;
  r = test::run_cli("embed " + spot + " " + out + " --payload 00 --bits 8 --x-step lu");
  EXPECT_EQ(r.code, 1) << r.out;
  r = test::run_cli("calibrate " + spot + " --bin-offset-rule sometimes --no-cache");
  EXPECT_EQ(r.code, 1) << r.out;
  r = test::run_cli("detect " + spot + " --expect 5 --expect-payload 00");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("excludes"), std::string::npos) << r.out;
  r = test::run_cli("extract " + spot + " --bits 100000");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_LT(r.out.size(), 2000u);
  EXPECT_FALSE(std::filesystem::exists(out));
}

}  // namespace
}  // namespace meshmark

namespace meshmark {
namespace {

// Two IDs whose codewords under key are exactly min_distance apart (searched from 0).
std::pair<std::uint64_t, std::uint64_t> closest_pair(const IdCode& code, const Key& key) {
  std::vector<Payload> words;
  for (std::uint64_t id = 0; id < 3000; ++id) {
    words.push_back(code.encode(id, key));
    for (std::uint64_t other = 0; other < id; ++other) {
      int d = 0;
      for (int j = 0; j < code.bits(); ++j) d += words[id].bits[j] != words[other].bits[j];
      if (d == code.min_distance()) return {other, id};
    }
  }
  return {0, 0};
}

TEST(MarkHardening, ACleanCopyNeverConfirmsTheBuyerWhoseCodewordIsNearest) {
  MESHMARK_REQUIRE(test::data_mesh("spot.obj"), "spot.obj");
  const IdCode code;
  const Key key = key_from_passphrase("neighbours");
  const auto [a, b] = closest_pair(code, key);
  ASSERT_NE(a, b) << "no pair at the minimum distance among 3,000 IDs";
  const Marked m = marked_spot(code, key, a);
  ExtractOptions xo = volume_center();
  const MarkReading reading = read_mark(m.mesh.V, m.mesh.F, xo, mark_layout(key, 64, true));
  const CodewordNull null(code, reading.bits, key);
  // The innocent b matches in 64 - 12 = 52 bits: its p-value alone is below 1e-6 (the exact
  // probability that a random codeword is that close), which is why the decoder's answer
  // is consulted.
  const DetectResult alone = detect_id(reading.bits, code.encode(b, key), null);
  EXPECT_EQ(alone.matches, 52);
  const IdDecodeResult decoded = code.decode(reading.bits, reading.margins, key);
  ASSERT_TRUE(decoded.valid);
  EXPECT_EQ(decoded.id, a);
  const DetectResult guarded = detect_id(reading.bits, code.encode(b, key), null, {}, &decoded, b);
  EXPECT_FALSE(guarded.detected);
  EXPECT_TRUE(guarded.decodes_to_other);
  EXPECT_EQ(guarded.other_id, a);
  const DetectResult present = detect_id(reading.bits, code.encode(a, key), null, {}, &decoded, a);
  EXPECT_TRUE(present.detected);
  // And a registry never issues b once a is issued from the same original under that key.
  const std::string dir = test::scratch_dir();
  const std::string db = dir + "/r.db", spot = test::data_mesh("spot.obj");
  std::filesystem::remove(db);
  test::CliRun r = test::run_cli("embed " + spot + " " + dir + "/a.obj --id " + std::to_string(a) +
                                 " --key neighbours --registry " + db);
  ASSERT_EQ(r.code, 0) << r.out;
  r = test::run_cli("embed " + spot + " " + dir + "/b.obj --id " + std::to_string(b) +
                    " --key neighbours --registry " + db);
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("12 bits from that of ID " + std::to_string(a)), std::string::npos) << r.out;
  EXPECT_FALSE(std::filesystem::exists(dir + "/b.obj"));
}

}  // namespace
}  // namespace meshmark
