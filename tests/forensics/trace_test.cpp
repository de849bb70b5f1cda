// Tracing a leak with the original and the issued copies: registration recovers a known
// similarity, resampling gives back an unattacked copy, and trace names the right buyer after
// real processing or nobody, never an innocent.

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <fstream>

#include "meshmark/attacks/attack.h"
#include "meshmark/carrier/variant.h"
#include "meshmark/forensics/registry.h"
#include "meshmark/forensics/trace.h"
#include "meshmark/io/io.h"
#include "meshmark/mark/embed.h"
#include "meshmark/protocol/watermark.h"
#include "test_data.h"

namespace meshmark {
namespace {

// p -> s R p + t, with R a rotation of `degrees` about an oblique axis.
Mesh transformed(const Mesh& m, double degrees, double s, const Eigen::Vector3d& t) {
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(degrees * M_PI / 180, Eigen::Vector3d(1, 2, -0.5).normalized())
          .toRotationMatrix();
  Mesh out = m;
  out.V = (s * m.V * R.transpose()).rowwise() + t.transpose();
  return out;
}

TEST(Trace, RegistrationRecoversAKnownSimilarityWithAndWithoutCropping) {
  for (const std::string& name : {"spot.obj", "bunny.ply"}) {
    const std::string path = test::data_mesh(name);
    MESHMARK_REQUIRE(path, name);
    const Mesh original = read_mesh(path);
    for (const bool crop : {false, true}) {
      SCOPED_TRACE(name + (crop ? " cropped 30 %" : ""));
      const Mesh part =
          crop ? apply_attack_chain(original, parse_attack_chain("crop:0.3"), 4) : original;
      const double degrees = 73, scale = 1.7;
      const Eigen::Vector3d t(0.3, -2.0, 5.0);
      const Mesh leak = transformed(part, degrees, scale, t);
      const RegistrationResult r = register_similarity(leak.V, leak.F, original.V, original.F);
      ASSERT_EQ(r.status, RegistrationStatus::Registered) << r.message;
      // The registration composed with the known transform is the identity.
      const Eigen::Matrix3d R =
          Eigen::AngleAxisd(degrees * M_PI / 180, Eigen::Vector3d(1, 2, -0.5).normalized())
              .toRotationMatrix();
      const Eigen::Matrix3d back = r.transform.rotation * R;
      const double angle = Eigen::AngleAxisd(back).angle() * 180 / M_PI;
      EXPECT_LT(angle, 0.01) << "degrees";
      EXPECT_NEAR(r.transform.scale * scale, 1.0, 1e-4);
      RecordProperty((crop ? "angle_error_cropped_" : "angle_error_") + name,
                     std::to_string(angle));
    }
  }
}

// Whether r registered the leak made by moving a part of the original by `degrees` about the
// axis of transformed() and `scale`: composed with that transform it is the identity within
// 0.05 degrees and 1e-3 of scale.
bool undoes(const RegistrationResult& r, double degrees, double scale) {
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(degrees * M_PI / 180, Eigen::Vector3d(1, 2, -0.5).normalized())
          .toRotationMatrix();
  const double angle = Eigen::AngleAxisd(r.transform.rotation * R).angle() * 180 / M_PI;
  return r.status == RegistrationStatus::Registered && angle < 0.05 &&
         std::abs(r.transform.scale * scale - 1) < 1e-3;
}

// A half of the original (cropping to 50 %) after a similarity: its spread and principal axes
// are not the original's, so the four matchings of the axes at the spreads' scale may all miss.
// Faces the part kept are matched to the original's by shape then: all 24 register (21 with the
// other matchings of the axes alone, 15 before them).
TEST(Trace, RegistrationFindsAHalfOfTheOriginalAfterASimilarity) {
  const std::string path = test::cgal_mesh("bunny00.off");
  MESHMARK_REQUIRE(path, "libcgal-demo's bunny00.off");
  const Mesh original = read_mesh(path);
  int right = 0, cases = 0;
  for (const std::uint64_t seed : {1, 2, 3, 4})
    for (const double degrees : {40.0, 110.0, 200.0})
      for (const double scale : {0.6, 1.8}) {
        const Mesh half = apply_attack_chain(original, parse_attack_chain("crop:0.5"), seed);
        const Mesh leak = transformed(half, degrees, scale, Eigen::Vector3d(0.3, -2.0, 5.0));
        const RegistrationResult r = register_similarity(leak.V, leak.F, original.V, original.F);
        const bool ok = undoes(r, degrees, scale);
        right += ok, ++cases;
        EXPECT_TRUE(ok) << "seed " << seed << ", " << degrees << " degrees, scale " << scale << ": "
                        << r.message;
      }
  RecordProperty("registered", fmt::format("{} of {}", right, cases));
}

// The same with a marked copy of armadillo, whose vertices the mark moved (so its faces match
// the original's only roughly) and whose halves have median edges 3 to 7 % off the whole's
// (the scale the edges give is a start, not the answer). In the trace campaign
// (trace-all-fingerprint.json), 8 of 20 such leaks were not registered before faces were
// matched, 4 of them armadillo's.
TEST(Trace, RegistrationFindsAHalfOfAMarkedCopyAfterASimilarity) {
  const std::string path = test::cgal_mesh("armadillo.off");
  MESHMARK_REQUIRE(path, "libcgal-demo's armadillo.off");
  const Mesh original = read_mesh(path);
  EmbedOptions o;
  o.variant = parse_variant("VRS");
  const EmbedResult e =
      embed(original.V, original.F, id_bins(IdCode(), 11, key_from_passphrase("shop")), o);
  ASSERT_EQ(e.status, EmbedStatus::Embedded);
  Mesh copy = original;
  copy.V = e.V;
  for (const std::uint64_t seed : {1, 2, 3})
    for (const double degrees : {40.0, 200.0})
      for (const double scale : {0.6, 1.8}) {
        const Mesh half = apply_attack_chain(copy, parse_attack_chain("crop:0.5"), seed);
        const Mesh leak = transformed(half, degrees, scale, Eigen::Vector3d(0.3, -2.0, 5.0));
        const RegistrationResult r = register_similarity(leak.V, leak.F, original.V, original.F);
        EXPECT_TRUE(undoes(r, degrees, scale)) << "seed " << seed << ", " << degrees
                                               << " degrees, scale " << scale << ": " << r.message;
      }
}

// A copy smoothed (Laplacian 10, Taubin 10) then moved by a similarity keeps the original's
// faces, so registration fits vertex to vertex; fitted to the original's own vertices, the fit
// took the shrinking for a scale and a shift (ChineseDragon-10kv: a similarity then Laplacian
// 10 named nobody in 4 of 4 campaign trials). Fitted to the original smoothed as the leak was,
// the known transform is recovered within 0.05 degrees and 1e-3 of scale.
TEST(Trace, RegistrationOfASmoothedCopyAfterASimilarityUndoesTheSimilarity) {
  const std::string path = test::cgal_mesh("ChineseDragon-10kv.off");
  MESHMARK_REQUIRE(path, "libcgal-demo's ChineseDragon-10kv.off");
  const Mesh original = read_mesh(path);
  for (const char* smoothing : {"smooth:10", "taubin:10"})
    for (const double degrees : {40.0, 200.0})
      for (const double scale : {0.6, 1.8}) {
        const Mesh smoothed = apply_attack_chain(original, parse_attack_chain(smoothing), 1);
        const Mesh leak = transformed(smoothed, degrees, scale, Eigen::Vector3d(0.3, -2.0, 5.0));
        const RegistrationResult r = register_similarity(leak.V, leak.F, original.V, original.F);
        EXPECT_TRUE(undoes(r, degrees, scale))
            << smoothing << ", " << degrees << " degrees, scale " << scale << ": " << r.message;
      }
}

TEST(Trace, ResamplingAnUnattackedCopyGivesBackItsVertices) {
  const std::string path = test::closed_binary_ply();
  MESHMARK_REQUIRE(path, "bunny00.off");
  const Mesh original = read_mesh(path);
  const Key key = key_from_passphrase("shop");
  const IdCode code;
  for (const char* variant : {"DRS", "VRS"}) {
    EmbedOptions o;
    o.variant = parse_variant(variant);
    const EmbedResult e = embed(original.V, original.F, id_bins(code, 7, key), o);
    ASSERT_EQ(e.status, EmbedStatus::Embedded);
    const std::vector<std::uint8_t> carrier = carrier_vertices(original.V, original.F);
    const Eigen::Vector3d center =
        center_of_mass(original.V, original.F, carrier, o.variant.center).point;
    const double diagonal = bounding_box_diagonal(original.V, carrier);
    const Resampled r =
        resample_at_original(e.V, original.F, original.V, original.F, center, 0.005 * diagonal);
    EXPECT_EQ(r.fraction, 1.0);
    double worst = 0;
    for (Eigen::Index i = 0; i < original.V.rows(); ++i)
      if (carrier[i]) worst = std::max(worst, (r.point.row(i) - e.V.row(i)).norm());
    EXPECT_LT(worst, 1e-9 * diagonal) << variant;
  }
}

struct Shop {
  Mesh original, marked;
  // The key these cases were first measured under (the passphrase's key before Argon2id).
  // Under other keys the averages of two consecutive IDs can fall short of naming anyone
  // (p = 5.6e-6 after correction, nobody named, under key_from_passphrase of the same text):
  // how far averaging defeats the code depends on the key (docs/forensics.md, collusion).
  Key key = key_from_passphrase_v1("the shop's key");
  std::vector<IssuedCopy> issued;
  std::uint64_t leaker = 1500;
};

// The copy of `original` carrying `id` under `key`, as the shop issues it (VRS, 64 bits,
// strength 0.05, spread 0.25).
Mesh issued_copy(const Mesh& original, std::uint64_t id, const Key& key) {
  EmbedOptions o;
  o.variant = parse_variant("VRS");
  o.strengths = mark_strengths(key, 64, true, o.strength, 0.25);
  const EmbedResult e = embed(original.V, original.F, id_bins(IdCode(), id, key), o);
  EXPECT_EQ(e.status, EmbedStatus::Embedded);
  Mesh copy = original;
  copy.V = e.V;
  return copy;
}

// horse, VRS: 1,000 copies issued to consecutive IDs 1000..1999 (records only; the copy of
// 1500 is embedded for real).
const Shop& shop() {
  static const Shop s = [] {
    Shop s;
    s.original = read_mesh(test::closed_binary_ply());
    s.marked = issued_copy(s.original, s.leaker, s.key);
    for (std::uint64_t id = 1000; id < 2000; ++id) {
      IssuedCopy c;
      c.id = id;
      c.buyer = "buyer " + std::to_string(id);
      c.variant = "VRS";
      c.strength = 0.05;
      c.strength_spread = 0.25;
      c.key_fingerprint = key_fingerprint(s.key);
      s.issued.push_back(c);
    }
    return s;
  }();
  return s;
}

// trace names the shop's leaker, and nobody else, below the default threshold.
void expect_leaker_named_alone(const Shop& s, const Mesh& leak) {
  const TraceResult r = trace(leak, s.original, s.issued, s.key);
  ASSERT_EQ(r.status, TraceStatus::Named) << r.message;
  ASSERT_EQ(r.named.size(), 1u) << r.message;
  EXPECT_EQ(r.named[0].copy.id, s.leaker);
  EXPECT_LT(r.named[0].corrected_p, 1e-6);
}

TEST(Trace, NamesTheLeakerAfterRealProcessingAndNeverAnInnocent) {
  MESHMARK_REQUIRE(test::closed_binary_ply(), "bunny00.off");
  const Shop& s = shop();
  // Each of these defeats the blind decoder on the horse (tested below), and trace names the
  // buyer after every one.
  const std::vector<std::string> named_after = {"simplify:0.3", "loop:1",       "sqrt3:1",
                                                "taubin:10",    "quant:8",      "crop:0.5",
                                                "remesh:1",     "qsimplify:0.3"};
  int blind_lost = 0;
  for (const std::string& attack : named_after) {
    SCOPED_TRACE(attack);
    const Mesh leak = apply_attack_chain(s.marked, parse_attack_chain(attack), 7);
    expect_leaker_named_alone(s, leak);
    const IdReading blind =
        read_id(leak.V, leak.F, ExtractOptions{64, CenterKind::Volume}, IdCode(), s.key);
    blind_lost += !(blind.id.valid && blind.id.id == s.leaker);
  }
  EXPECT_GE(blind_lost, 4) << "the blind decoder was expected to fail on most of these";
  RecordProperty("blind_decoder_lost", blind_lost);
}

// A random similarity (rotation, translation, scale up to 2) before or after real processing,
// and chains of two kinds of processing: the leaker is still named, alone.
TEST(Trace, NamesTheLeakerAfterASimilarityAndChainsOfTwo) {
  MESHMARK_REQUIRE(test::closed_binary_ply(), "bunny00.off");
  const Shop& s = shop();
  for (const std::string attack :
       {"similarity:2,simplify:0.3", "smooth:10,similarity:2", "similarity:2,crop:0.5",
        "simplify:0.5,noise:0.001", "remesh:1,quant:10", "crop:0.3,noise:0.001",
        "crop:0.3,smooth:5", "taubin:10,simplify:0.5"}) {
    SCOPED_TRACE(attack);
    expect_leaker_named_alone(s, apply_attack_chain(s.marked, parse_attack_chain(attack), 11));
  }
}

// A row reserved and never completed (its issue was interrupted after the copy was written)
// is still a candidate: its buyer is named, with a warning that says the row is reserved.
TEST(Trace, AReservedRowIsNamedWithAWarning) {
  MESHMARK_REQUIRE(test::closed_binary_ply(), "bunny00.off");
  const Shop& s = shop();
  std::vector<IssuedCopy> issued = s.issued;
  for (IssuedCopy& c : issued)
    if (c.id == s.leaker) c.state = "reserved";
  const TraceResult r = trace(s.marked, s.original, issued, s.key);
  ASSERT_EQ(r.named.size(), 1u) << r.message;
  EXPECT_EQ(r.named[0].copy.id, s.leaker);
  bool warned = false;
  for (const std::string& w : r.warnings) warned |= w.find("is reserved, not completed") != w.npos;
  EXPECT_TRUE(warned);
}

// The per-bit evidence of an unprocessed copy: every bit measured, read as the leaker's
// codeword bit, and the measured shift nearer to that bit's expected shift.
TEST(Trace, PerBitEvidenceOfAnUnprocessedCopyIsTheCodeword) {
  MESHMARK_REQUIRE(test::closed_binary_ply(), "bunny00.off");
  const Shop& s = shop();
  const TraceResult r = trace(s.marked, s.original, s.issued, s.key);
  const Payload codeword = IdCode().encode(s.leaker, s.key);
  ASSERT_EQ(r.bits.size(), codeword.bits.size());
  for (std::size_t j = 0; j < r.bits.size(); ++j) {
    const BitEvidence& e = r.bits[j];
    EXPECT_GT(e.vertices, 0) << j;
    EXPECT_EQ(e.bit, codeword.bits[j]) << j;
    const double to_one = std::abs(e.shift - e.if_one), to_zero = std::abs(e.shift - e.if_zero);
    EXPECT_EQ(to_one < to_zero, codeword.bits[j] == 1) << j;
  }
}

// Averages of two copies (consecutive IDs, and two far apart): both colluders named, or one,
// never an innocent, also after processing.
TEST(Trace, AveragesOfTwoCopiesNameColludersOnly) {
  MESHMARK_REQUIRE(test::closed_binary_ply(), "bunny00.off");
  const Shop& s = shop();
  int both = 0;
  for (const std::uint64_t other : {s.leaker + 1, std::uint64_t{1017}}) {
    Mesh average = s.original;
    average.V = 0.5 * (s.marked.V + issued_copy(s.original, other, s.key).V);
    for (const std::string attack : {"", "simplify:0.5", "noise:0.001"}) {
      SCOPED_TRACE(std::to_string(other) + " " + attack);
      const Mesh leak =
          attack.empty() ? average : apply_attack_chain(average, parse_attack_chain(attack), 5);
      const TraceResult r = trace(leak, s.original, s.issued, s.key);
      EXPECT_EQ(r.status, TraceStatus::Named) << r.message;
      for (const CandidateScore& c : r.named)
        EXPECT_TRUE(c.copy.id == s.leaker || c.copy.id == other) << c.copy.id;
      both += r.named.size() == 2;
    }
  }
  RecordProperty("both_colluders_named", both);
  EXPECT_GE(both, 3) << "of 6 averages";
}

// Cho's marks against the same shop: 1,000 consecutive IDs under one key, the leaker's copy
// alone names the leaker alone, and an average with the next ID's copy names no innocent.
TEST(Trace, ChoMarksNameNoInnocentAmongConsecutiveIdsAloneOrAveraged) {
  MESHMARK_REQUIRE(test::closed_binary_ply(), "bunny00.off");
  const Shop& s = shop();
  for (const Method method : {Method::ChoMean, Method::ChoVariance}) {
    SCOPED_TRACE(method_name(method));
    auto copy_of = [&](std::uint64_t id) {
      EmbedOptions o;
      o.method = method;
      o.strengths = mark_strengths(s.key, 64, true, o.strength, 0.25);
      const EmbedResult e = embed(s.original.V, s.original.F, id_bins(IdCode(), id, s.key), o);
      EXPECT_EQ(e.status, EmbedStatus::Embedded) << e.message;
      return e.V;
    };
    std::vector<IssuedCopy> issued = s.issued;
    for (IssuedCopy& c : issued) c.variant = "DRS", c.method = method_name(method);
    Mesh leak = s.original;
    leak.V = copy_of(s.leaker);
    TraceResult r = trace(leak, s.original, issued, s.key);
    ASSERT_EQ(r.named.size(), 1u) << r.message;
    EXPECT_EQ(r.named[0].copy.id, s.leaker);
    leak.V = 0.5 * (leak.V + copy_of(s.leaker + 1));
    r = trace(leak, s.original, issued, s.key);
    for (const CandidateScore& c : r.named)
      EXPECT_TRUE(c.copy.id == s.leaker || c.copy.id == s.leaker + 1) << c.copy.id;
    std::printf("%s: the average names %zu of the two colluders\n", method_name(method),
                r.named.size());
  }
}

// The p-value model against 10^5 innocent scores: readings from ten leaks (processed copies of
// the leaker, an average of two, the unmarked original, a copy under another key), each scored
// against 10,000 consecutive innocent IDs 0..10,001 around the leaker's (not the leakers'). Given a
// reading, an innocent's codeword is independent of it, so the share of innocents with
// p <= x must not exceed x (within 5 binomial standard deviations), and, the three readings'
// Bonferroni factor and the discreteness aside, should not be far below it (at least x / 10).
// No innocent is named.
TEST(Trace, InnocentScoresFollowThePValueModel) {
  MESHMARK_REQUIRE(test::closed_binary_ply(), "bunny00.off");
  const Shop& s = shop();
  const Mesh second = issued_copy(s.original, s.leaker + 1, s.key);
  const Mesh foreign = issued_copy(s.original, s.leaker, key_from_passphrase("other"));
  std::vector<Mesh> leaks;
  for (const std::string attack :
       {"simplify:0.3", "remesh:1", "smooth:10", "noise:0.003", "crop:0.5", "loop:1", "quant:7"})
    leaks.push_back(apply_attack_chain(s.marked, parse_attack_chain(attack), 13));
  leaks.push_back(s.original);
  leaks.push_back(s.original), leaks.back().V = 0.5 * (s.marked.V + second.V);
  leaks.push_back(s.original), leaks.back().V = foreign.V;
  std::vector<IssuedCopy> innocents;
  for (std::uint64_t id = 0; id < 10002; ++id) {
    if (id == s.leaker || id == s.leaker + 1) continue;
    IssuedCopy c = s.issued.front();
    c.id = id;
    innocents.push_back(c);
  }
  ASSERT_EQ(innocents.size(), 10000u);
  const std::vector<double> levels = {1e-1, 1e-2, 1e-3, 1e-4};
  std::vector<std::size_t> below(levels.size(), 0);
  std::size_t scores = 0;
  double smallest = 1;
  TraceOptions every;
  every.ranking = 0;  // every candidate in the ranking
  for (const Mesh& leak : leaks) {
    const TraceResult r = trace(leak, s.original, innocents, s.key, every);
    EXPECT_EQ(r.status, TraceStatus::NoBuyer) << r.message;
    for (const CandidateScore& c : r.ranking) {
      ++scores;
      smallest = std::min(smallest, c.p_value);
      for (std::size_t k = 0; k < levels.size(); ++k) below[k] += c.p_value <= levels[k];
    }
  }
  ASSERT_EQ(scores, 100000u);
  for (std::size_t k = 0; k < levels.size(); ++k) {
    const double expected = levels[k] * static_cast<double>(scores);
    SCOPED_TRACE(levels[k]);
    EXPECT_LE(static_cast<double>(below[k]), expected + 5 * std::sqrt(expected) + 1);
    if (levels[k] >= 1e-3) EXPECT_GE(static_cast<double>(below[k]), expected / 10);
    RecordProperty("innocents_below_" + std::to_string(k), static_cast<int>(below[k]));
  }
  EXPECT_GT(smallest * 10000, 1e-6) << "an innocent would have been named";
}

// A bounded ranking is the head of the full one (same candidates, same order), keeps every
// named buyer and the copy whose file the leak is, and every candidate's score for plots.
TEST(Trace, ABoundedRankingIsTheHeadOfTheFullOne) {
  MESHMARK_REQUIRE(test::closed_binary_ply(), "bunny00.off");
  const Shop& s = shop();
  std::vector<IssuedCopy> issued = s.issued;
  TraceOptions every, few;
  every.ranking = 0;
  few.ranking = 3;
  few.leaked_hash = "the leak's bytes";
  const TraceResult all = trace(s.marked, s.original, issued, s.key, every);
  ASSERT_EQ(all.ranking.size(), issued.size());
  const std::uint64_t far = all.ranking[500].copy.id;  // a copy far down the ranking
  for (IssuedCopy& c : issued)
    if (c.id == far) c.output_hash = "the leak's bytes";
  const TraceResult head = trace(s.marked, s.original, issued, s.key, few);
  ASSERT_EQ(head.status, TraceStatus::Named);
  EXPECT_EQ(head.named.size(), all.named.size());
  // The message counts every candidate, not the ranking's few.
  EXPECT_NE(head.message.find("for " + std::to_string(issued.size()) + " candidates"),
            std::string::npos)
      << head.message;
  EXPECT_EQ(head.log_scores.size(), issued.size());
  EXPECT_EQ(all.log_scores.size(), issued.size());
  // The three best, then the copy of the leak's bytes (kept for its file), as in the full one.
  ASSERT_EQ(head.ranking.size(), 4u);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(head.ranking[i].copy.id, all.ranking[i].copy.id) << i;
    EXPECT_EQ(head.ranking[i].p_value, all.ranking[i].p_value) << i;
  }
  EXPECT_EQ(head.ranking[3].copy.id, far);
  EXPECT_EQ(head.ranking[3].p_value, all.ranking[500].p_value);
  // The ranking is sorted, and the scores are the full ranking's, as -log10.
  for (std::size_t i = 1; i < all.ranking.size(); ++i)
    EXPECT_LE(all.ranking[i - 1].p_value, all.ranking[i].p_value);
  std::vector<float> want;
  for (const CandidateScore& c : all.ranking)
    want.push_back(static_cast<float>(-std::log10(std::max(c.corrected_p, 1e-300))));
  std::vector<float> got = head.log_scores;
  std::sort(want.begin(), want.end()), std::sort(got.begin(), got.end());
  EXPECT_EQ(got, want);
}

// trace_issued reads the registry on another thread and measures the group of the first row it
// finds meanwhile, keeping that reading only when the group is the first one (in GroupKey order)
// and measuring again otherwise: whichever group the first row found is in, the result is the
// in-memory trace of the registry's list, every score and every bit's evidence bit for bit.
// The registries hold the shop's copies (VRS) and 100 DRS copies at another strength, recorded
// before them, after them, or not at all; the leak is resampled (simplified), so each group's
// measurement depends on its center.
TEST(Trace, ARegistryReadBesideTheMeasurementTracesAsItsList) {
  MESHMARK_REQUIRE(test::closed_binary_ply(), "bunny00.off");
  const Shop& s = shop();
  const Mesh leak = apply_attack_chain(s.marked, parse_attack_chain("simplify:0.5"), 5);
  std::vector<IssuedCopy> drs;
  for (std::uint64_t id = 3000; id < 3100; ++id) {
    IssuedCopy c = s.issued.front();
    c.id = id, c.buyer = "drs buyer " + std::to_string(id);
    c.variant = "DRS", c.strength = 0.04;
    drs.push_back(c);
  }
  const std::string geometry = geometry_hash(s.original.V, s.original.F);
  for (const std::string order : {"drs first", "vrs first", "vrs alone"}) {
    SCOPED_TRACE(order);
    std::vector<IssuedCopy> rows;
    if (order == "drs first") rows = drs;
    rows.insert(rows.end(), s.issued.begin(), s.issued.end());
    if (order == "vrs first") rows.insert(rows.end(), drs.begin(), drs.end());
    for (IssuedCopy& c : rows) {
      c.original_hash = "the original's file";
      c.original_geometry = geometry;
      c.output_path = "/shop/" + std::to_string(c.id) + ".ply";
      c.output_hash = "copy " + std::to_string(c.id);
    }
    const std::string db = test::scratch_dir() + "/guess.db";
    std::filesystem::remove(db);
    Registry(db).record(rows, s.key);
    const TraceResult got = trace_issued(leak, s.original, "the original's file", db, s.key);
    const TraceResult want = trace(leak, s.original, Registry(db, true).list(), s.key);
    ASSERT_EQ(got.status, TraceStatus::Named) << got.message;
    EXPECT_EQ(got.message, want.message);
    EXPECT_EQ(got.candidates, rows.size());
    EXPECT_EQ(got.processing, want.processing);
    EXPECT_EQ(got.measured_fraction, want.measured_fraction);
    EXPECT_EQ(got.attenuation, want.attenuation);
    ASSERT_EQ(got.bits.size(), want.bits.size());
    for (std::size_t j = 0; j < got.bits.size(); ++j) {
      EXPECT_EQ(got.bits[j].shift, want.bits[j].shift) << j;
      EXPECT_EQ(got.bits[j].bit, want.bits[j].bit) << j;
    }
    ASSERT_EQ(got.ranking.size(), want.ranking.size());
    for (std::size_t i = 0; i < got.ranking.size(); ++i) {
      EXPECT_EQ(got.ranking[i].copy.row, want.ranking[i].copy.row) << i;
      EXPECT_EQ(got.ranking[i].p_value, want.ranking[i].p_value) << i;
    }
    EXPECT_EQ(got.log_scores, want.log_scores);
    // The DRS group reads against its own center: the first group's evidence is DRS's when
    // there are DRS copies (a guess that is not the first group is not kept).
    const TraceResult vrs_only = trace(leak, s.original, s.issued, s.key);
    if (order == "vrs alone")
      EXPECT_EQ(got.bits[0].shift, vrs_only.bits[0].shift);
    else
      EXPECT_NE(got.bits[0].shift, vrs_only.bits[0].shift);
  }
}

TEST(Trace, NamesNobodyForAnUnmarkedMeshAnotherKeyOrAnotherLeak) {
  MESHMARK_REQUIRE(test::closed_binary_ply(), "bunny00.off");
  const Shop& s = shop();
  // The original itself (never issued), and a copy under another key, against the 1,000.
  TraceResult r = trace(s.original, s.original, s.issued, s.key);
  EXPECT_EQ(r.status, TraceStatus::NoBuyer) << r.message;
  const Key other = key_from_passphrase("another shop");
  r = trace(issued_copy(s.original, 1500, other), s.original, s.issued, s.key);
  EXPECT_EQ(r.status, TraceStatus::NoBuyer) << r.message;
  for (const CandidateScore& c : r.ranking) EXPECT_GT(c.corrected_p, 1e-6);
  // Candidates under another key are not candidates.
  r = trace(s.marked, s.original, s.issued, other);
  EXPECT_EQ(r.status, TraceStatus::NoCandidates);
}

// Leaks too small to register (a triangle, a few faces of a copy), and a leak of another mesh:
// no crash, nobody named; a registration that shrinks the leak onto a patch is a failure.
TEST(Trace, TinyLeaksAndOtherMeshesNameNobody) {
  MESHMARK_REQUIRE(test::closed_binary_ply(), "bunny00.off");
  const Shop& s = shop();
  for (const Eigen::Index faces : {1, 2, 5}) {
    Mesh tiny = s.marked;
    tiny.F = s.marked.F.topRows(faces);
    const TraceResult r = trace(tiny, s.original, s.issued, s.key);
    EXPECT_NE(r.status, TraceStatus::Named) << faces << " faces: " << r.message;
  }
  const std::string spot = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(spot, "spot.obj");
  const TraceResult r = trace(read_mesh(spot), s.original, s.issued, s.key);
  EXPECT_NE(r.status, TraceStatus::Named) << r.message;
  if (r.registration.status == RegistrationStatus::Registered) {
    const Eigen::MatrixX3d moved = r.registration.transform.apply(read_mesh(spot).V);
    const double span = (moved.colwise().maxCoeff() - moved.colwise().minCoeff()).norm();
    const double diagonal =
        (s.original.V.colwise().maxCoeff() - s.original.V.colwise().minCoeff()).norm();
    EXPECT_GE(span, 0.02 * diagonal) << "a collapsed registration was reported as registered";
  }
}

TEST(Trace, CommandLineNamesTheBuyerFromTheRegistry) {
  const std::string spot = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(spot, "spot.obj");
  const std::string dir = test::scratch_dir();
  const std::string db = dir + "/shop.db";
  std::filesystem::remove(db);
  std::ofstream manifest(dir + "/m.txt");
  for (int i = 0; i < 6; ++i)
    manifest << spot << " " << dir << "/c" << i << ".obj id:" << 40 + 37 * i << " buyer" << i
             << "\n";
  manifest.close();
  test::CliRun r = test::run_cli("embed --batch " + dir + "/m.txt --key studio --registry " + db +
                                 " --variant VRS");
  ASSERT_EQ(r.code, 0) << r.out;
  r = test::run_cli("attack simplify:0.7 " + dir + "/c3.obj " + dir + "/leak.obj");
  ASSERT_EQ(r.code, 0) << r.out;
  r = test::run_cli("trace " + dir + "/leak.obj --original " + spot + " --registry " + db +
                    " --key studio --json");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("\"buyer\": \"buyer3\""), std::string::npos) << r.out;
  r = test::run_cli("trace " + spot + " --original " + spot + " --registry " + db +
                    " --key studio");
  EXPECT_EQ(r.code, 6) << r.out;
  EXPECT_NE(r.out.find("no buyer"), std::string::npos) << r.out;
  // A mistyped registry is unreadable input, not an empty list, and is not created.
  r = test::run_cli("trace " + dir + "/leak.obj --original " + spot + " --registry " + dir +
                    "/typo.db --key studio");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("typo.db: no such registry"), std::string::npos) << r.out;
  EXPECT_FALSE(std::filesystem::exists(dir + "/typo.db"));
  // A threshold loose enough to name innocents is refused.
  r = test::run_cli("trace " + dir + "/leak.obj --original " + spot + " --registry " + db +
                    " --key studio --threshold 0.5");
  EXPECT_EQ(r.code, 1) << r.out;
}

TEST(Trace, ChoMarksAreIssuedReadDetectedAndTracedByEveryCommand) {
  const std::string spot = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(spot, "spot.obj");
  for (const std::string method : {"cho-mean", "cho-variance"}) {
    SCOPED_TRACE(method);
    const std::string dir = test::scratch_dir();
    const std::string db = dir + "/shop.db";
    std::filesystem::remove(db);
    std::ofstream manifest(dir + "/m.txt");
    for (int i = 0; i < 4; ++i)  // consecutive IDs: 240 to 243
      manifest << spot << " " << dir << "/c" << i << ".obj id:" << 240 + i << " buyer" << i << "\n";
    manifest.close();
    test::CliRun r = test::run_cli("embed --batch " + dir + "/m.txt --key studio --registry " + db +
                                   " --method " + method);
    ASSERT_EQ(r.code, 0) << r.out;
    r = test::run_cli("registry list " + db + " --format json");
    EXPECT_EQ(r.code, 0) << r.out;
    EXPECT_NE(r.out.find("\"method\": \"" + method + "\""), std::string::npos) << r.out;
    // Blind: the ID reads back with the method's statistic, and detect confirms it alone.
    const std::string copy = dir + "/c2.obj";
    r = test::run_cli("extract " + copy + " --coded --key studio --method " + method);
    EXPECT_EQ(r.code, 0) << r.out;
    EXPECT_NE(r.out.find("id 242 "), std::string::npos) << r.out;
    r = test::run_cli("detect " + copy + " --expect 242 --key studio --method " + method);
    EXPECT_EQ(r.code, 0) << r.out;
    for (const char* neighbour : {"241", "243"}) {  // the issued IDs either side: not detected
      r = test::run_cli("detect " + copy + " --expect " + neighbour + " --key studio --method " +
                        method);
      EXPECT_EQ(r.code, 6) << neighbour << ": " << r.out;
    }
    // Traced with the original after a similarity and mild noise: the registry knows the method.
    r = test::run_cli("attack similarity,noise:0.0005 " + copy + " " + dir + "/leak.obj");
    ASSERT_EQ(r.code, 0) << r.out;
    r = test::run_cli("trace " + dir + "/leak.obj --original " + spot + " --registry " + db +
                      " --key studio");
    EXPECT_EQ(r.code, 0) << r.out;
    EXPECT_NE(r.out.find("one buyer named: 'buyer2'"), std::string::npos) << r.out;
    r = test::run_cli("trace " + spot + " --original " + spot + " --registry " + db +
                      " --key studio");
    EXPECT_EQ(r.code, 6) << r.out;
  }
  // A scheme Cho's methods do not have is refused.
  const test::CliRun r = test::run_cli("embed " + spot +
                                       " /tmp/never.obj --payload 1 --bits 8 "
                                       "--method cho-mean --variant VRL");
  EXPECT_EQ(r.code, 1) << r.out;
}

}  // namespace
}  // namespace meshmark
