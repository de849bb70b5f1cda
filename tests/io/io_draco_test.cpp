// Draco (.drc): files made by Google's own draco_encoder from real meshes. Counts and positions
// are checked against draco_decoder's PLY output, the settings against the encoder's command
// line and the header bytes, the attributes of a watermarked copy against the original decoded
// by Draco itself.

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <random>

#include <draco/compression/decode.h>

#include "io/draco_codec.h"
#include "meshmark/core/error.h"
#include "meshmark/io/io.h"
#include "test_data.h"

using namespace meshmark;
using namespace meshmark::test;

namespace {

constexpr const char* kPayload = "0123456789abcdef";

bool have_draco_tools() {
  return std::system(
             "command -v draco_encoder >/dev/null 2>&1 && "
             "command -v draco_decoder >/dev/null 2>&1") == 0;
}

#define REQUIRE_DRACO_TOOLS()                                                          \
  do {                                                                                 \
    if (!have_draco_tools())                                                           \
      GTEST_SKIP() << "skipped: draco_encoder/draco_decoder (Debian draco-tools) are " \
                      "not installed";                                                 \
  } while (0)

// Runs draco_encoder on a real mesh; returns the output path.
std::string draco_encode(const std::string& in, const std::string& out, const std::string& args) {
  const std::string cmd = "draco_encoder -i '" + in + "' -o '" + out + "' " + args + " >/dev/null";
  EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd;
  return out;
}

// draco_decoder's own reading of a .drc, as a PLY file read by meshmark's PLY reader.
Mesh draco_decoder_reading(const std::string& drc) {
  const std::string ply = drc + ".decoded.ply";
  const std::string cmd = "draco_decoder -i '" + drc + "' -o '" + ply + "' >/dev/null";
  EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd;
  return read_mesh(ply);
}

// The distinct referenced positions of V, sorted (bit-identical rows counted once).
std::vector<std::array<double, 3>> distinct_positions(const Eigen::MatrixX3d& V,
                                                      const Eigen::MatrixX3i& F) {
  std::vector<std::array<double, 3>> rows;
  const std::vector<std::uint8_t> used = referenced_vertices(F, V.rows());
  for (Eigen::Index i = 0; i < V.rows(); ++i)
    if (used[i]) rows.push_back({V(i, 0) + 0.0, V(i, 1) + 0.0, V(i, 2) + 0.0});
  std::sort(rows.begin(), rows.end());
  rows.erase(std::unique(rows.begin(), rows.end()), rows.end());
  return rows;
}

std::unique_ptr<draco::Mesh> draco_decode(const std::string& path) {
  const std::string bytes = read_file(path);
  draco::DecoderBuffer buffer;
  buffer.Init(bytes.data(), bytes.size());
  draco::Decoder decoder;
  auto mesh = decoder.DecodeMeshFromBuffer(&buffer);
  EXPECT_TRUE(mesh.ok()) << path;
  return mesh.ok() ? std::move(mesh).value() : nullptr;
}

// The values an attribute holds at every face corner, sorted: the multiset Draco's point
// reordering cannot change.
std::vector<std::vector<double>> corner_values(const draco::Mesh& mesh, int att_id) {
  const draco::PointAttribute& att = *mesh.attribute(att_id);
  std::vector<std::vector<double>> out;
  for (std::uint32_t f = 0; f < mesh.num_faces(); ++f)
    for (int c = 0; c < 3; ++c) {
      std::vector<double> v(att.num_components());
      att.ConvertValue<double>(att.mapped_index(mesh.face(draco::FaceIndex(f))[c]),
                               att.num_components(), v.data());
      out.push_back(std::move(v));
    }
  std::sort(out.begin(), out.end());
  return out;
}

// A real mesh as draco_encoder takes it: PLY as is, OBJ as is (its texture coordinates then
// become a TEX_COORD attribute).
struct Source {
  std::string file;
  const char* args;  // draco_encoder options besides -qp
};

}  // namespace

TEST(DracoRead, CountsAndPositionsMatchDracoDecoder) {
  REQUIRE_DRACO_TOOLS();
  const std::string dir = scratch_dir();
  for (const auto& [in, qp] : {std::pair{data_mesh("spot.obj"), 14},
                               {closed_binary_ply(), 11},
                               {data_mesh("bunny.ply"), 14}}) {
    MESHMARK_REQUIRE(in, "a mesh of data/meshes or bunny00.off");
    const std::string file = std::filesystem::path(in).filename().string();
    SCOPED_TRACE(std::string(file) + " -qp " + std::to_string(qp));
    const std::string drc =
        draco_encode(in, dir + "/" + file + ".drc", "-qp " + std::to_string(qp));
    const Mesh theirs = draco_decoder_reading(drc);
    const auto start = std::chrono::steady_clock::now();
    const Mesh ours = read_mesh(drc);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::cout << "  " << file << " -qp " << qp << ": " << std::filesystem::file_size(drc)
              << " bytes, " << ours.V.rows() << " vertices read in " << seconds << " s\n";
    // Draco splits vertices at seams; both sides count bit-identical positions once.
    const auto expected = distinct_positions(theirs.V, theirs.F);
    EXPECT_EQ(static_cast<std::size_t>(ours.V.rows()), expected.size());
    EXPECT_EQ(ours.F.rows(), theirs.F.rows());
    EXPECT_EQ(distinct_positions(ours.V, ours.F), expected);  // both the same float32 values
  }
}

TEST(DracoRead, RecoversTheEncodersSettings) {
  REQUIRE_DRACO_TOOLS();
  const std::string dir = scratch_dir();
  const std::string spot = data_mesh("spot.obj"), horse = closed_binary_ply();
  MESHMARK_REQUIRE(spot, "spot.obj");
  MESHMARK_REQUIRE(horse, "bunny00.off");
  for (const int qp : {14, 11, 8, 0}) {
    const std::string drc = draco_encode(spot, dir + "/spot" + std::to_string(qp) + ".drc",
                                         "-qp " + std::to_string(qp) + " -qt 12");
    const detail::DracoMesh d = detail::decode_draco(read_file(drc), drc);
    EXPECT_EQ(d.position_bits, qp);
    const draco::Mesh& m = *d.mesh;
    const int uv = m.GetNamedAttributeId(draco::GeometryAttribute::TEX_COORD);
    ASSERT_GE(uv, 0);
    EXPECT_EQ(d.attribute_bits[uv], 12);
  }
  const std::string drc = draco_encode(horse, dir + "/horse.drc", "-qp 11 -qn 9");
  const detail::DracoMesh d = detail::decode_draco(read_file(drc), drc);
  const int normal = d.mesh->GetNamedAttributeId(draco::GeometryAttribute::NORMAL);
  ASSERT_GE(normal, 0);
  EXPECT_EQ(d.attribute_bits[normal], 9);
  EXPECT_EQ(d.position_bits, 11);
}

// Embeds with the command line into a copy, extracts it, and checks that the copy keeps the
// header's method bytes, every attribute's type, unique id and quantization, and every
// non-position attribute's values at the face corners.
TEST(DracoWriteBack, MarkSurvivesAndOnlyPositionsChange) {
  REQUIRE_DRACO_TOOLS();
  const std::string dir = scratch_dir();
  const Source sources[] = {
      {data_mesh("spot.obj"), "-qt 12 -cl 7"},   // texture coordinates, valence
      {closed_binary_ply(), "-qn 9 -cl 5"},      // normals, standard edgebreaker
      {data_mesh("spot.obj"), "-qt 10 -cl 0"}};  // sequential
  int k = 0;
  for (const Source& s : sources) {
    const std::string& in = s.file;
    MESHMARK_REQUIRE(in, "spot.obj or bunny00.off");
    SCOPED_TRACE(s.file + " " + s.args);
    const std::string a =
        draco_encode(in, dir + "/a" + std::to_string(k) + ".drc", std::string("-qp 14 ") + s.args);
    const std::string b = dir + "/b" + std::to_string(k++) + ".drc";
    const CliRun e = run_cli("embed " + a + " " + b + " --payload " + kPayload);
    ASSERT_EQ(e.code, 0) << e.out;
    const CliRun x = run_cli("extract " + b + " --expect " + kPayload);
    EXPECT_EQ(x.code, 0) << x.out;
    // Counts as read, and the header: geometry type, method, edgebreaker submethod (byte 11
    // when there is no metadata, as draco_encoder writes none here).
    const Mesh ma = read_mesh(a), mb = read_mesh(b);
    EXPECT_EQ(ma.V.rows(), mb.V.rows());
    EXPECT_EQ(ma.F.rows(), mb.F.rows());
    const std::string ha = read_file(a), hb = read_file(b);
    EXPECT_EQ(ha.substr(7, 2), hb.substr(7, 2));
    if (ha[8] == 1) EXPECT_EQ(ha[11], hb[11]);
    const auto da = draco_decode(a), db = draco_decode(b);
    ASSERT_TRUE(da && db);
    ASSERT_EQ(da->num_attributes(), db->num_attributes());
    const detail::DracoMesh qa = detail::decode_draco(ha, a), qb = detail::decode_draco(hb, b);
    EXPECT_EQ(qa.attribute_bits, qb.attribute_bits);
    for (int i = 0; i < da->num_attributes(); ++i) {
      const draco::PointAttribute &x1 = *da->attribute(i), &x2 = *db->attribute(i);
      EXPECT_EQ(x1.attribute_type(), x2.attribute_type());
      EXPECT_EQ(x1.data_type(), x2.data_type());
      EXPECT_EQ(x1.num_components(), x2.num_components());
      EXPECT_EQ(x1.unique_id(), x2.unique_id());
      if (x1.attribute_type() != draco::GeometryAttribute::POSITION)
        EXPECT_EQ(corner_values(*da, i), corner_values(*db, i)) << "attribute " << i;
    }
  }
}

// Quantization moves every vertex to a grid; the embed refuses to write a file that does not
// carry the mark. At 14 and 11 bits the mark survives; at 8 bits the command either writes a
// file that carries it or writes nothing and says why.
TEST(DracoWriteBack, MarkAtFourteenElevenAndEightBits) {
  REQUIRE_DRACO_TOOLS();
  const std::string dir = scratch_dir();
  const std::string in = closed_binary_ply();
  MESHMARK_REQUIRE(in, "bunny00.off");
  for (const int qp : {14, 11, 8}) {
    SCOPED_TRACE("-qp " + std::to_string(qp));
    const std::string a =
        draco_encode(in, dir + "/a" + std::to_string(qp) + ".drc", "-qp " + std::to_string(qp));
    const std::string b = dir + "/b" + std::to_string(qp) + ".drc";
    const CliRun e = run_cli("embed " + a + " " + b + " --payload " + kPayload);
    if (qp >= 11) ASSERT_EQ(e.code, 0) << e.out;
    if (e.code != 0) {
      EXPECT_NE(e.out.find("does not carry the mark"), std::string::npos) << e.out;
      EXPECT_FALSE(std::filesystem::exists(b));
      continue;
    }
    const CliRun x = run_cli("extract " + b + " --expect " + kPayload);
    EXPECT_EQ(x.code, 0) << x.out;
  }
}

TEST(DracoWrite, FromScratchDecodesWithDracoDecoder) {
  REQUIRE_DRACO_TOOLS();
  const std::string in = data_mesh("spot.obj");
  MESHMARK_REQUIRE(in, "spot.obj");
  const std::string dir = scratch_dir();
  const Mesh source = read_mesh(in);
  write_mesh(dir + "/spot.drc", source);
  const Mesh theirs = draco_decoder_reading(dir + "/spot.drc");
  EXPECT_EQ(theirs.F.rows(), source.F.rows());
  EXPECT_EQ(distinct_positions(theirs.V, theirs.F).size(),
            distinct_positions(source.V, source.F).size());
  // 14 bits over the largest side of the box: every coordinate within half a step of the source.
  const Eigen::RowVector3d lo = source.V.colwise().minCoeff(), hi = source.V.colwise().maxCoeff();
  const double half_step = 0.5 * (hi - lo).maxCoeff() / ((1 << 14) - 1) * (1 + 1e-6);
  EXPECT_LE((theirs.V.colwise().minCoeff() - lo).cwiseAbs().maxCoeff(), half_step);
  EXPECT_LE((theirs.V.colwise().maxCoeff() - hi).cwiseAbs().maxCoeff(), half_step);
  EXPECT_EQ(detail::decode_draco(read_file(dir + "/spot.drc"), "spot.drc").position_bits, 14);
  // Another format's mesh written to Draco and back carries a mark.
  const CliRun e = run_cli("embed " + in + " " + dir + "/w.drc --payload " + kPayload);
  ASSERT_EQ(e.code, 0) << e.out;
  EXPECT_EQ(run_cli("extract " + dir + "/w.drc --expect " + kPayload).code, 0);
}

TEST(DracoRead, MalformedFilesThrowNamingTheFile) {
  REQUIRE_DRACO_TOOLS();
  const std::string in = data_mesh("bunny.ply");
  MESHMARK_REQUIRE(in, "bunny.ply");
  const std::string dir = scratch_dir();
  const std::string good = read_file(draco_encode(in, dir + "/good.drc", "-qp 11"));
  draco_encode(in, dir + "/cloud.drc", "-point_cloud");
  std::mt19937 rng(7);
  std::string noise(4096, '\0'), headed = good.substr(0, 11);
  for (char& c : noise) c = static_cast<char>(rng());
  headed += noise;
  const std::map<std::string, std::string> cases = {
      {"truncated.drc", good.substr(0, good.size() / 2)},
      {"noise.drc", noise},
      {"header-then-noise.drc", headed},
      {"empty.drc", ""},
      {"cloud.drc", read_file(dir + "/cloud.drc")}};
  for (const auto& [file, bytes] : cases) {
    SCOPED_TRACE(file);
    const std::string path = dir + "/" + file;
    std::ofstream(path, std::ios::binary) << bytes;
    expect_invalid_input(path);
  }
}
