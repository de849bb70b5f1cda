// Malformed files: each gets a typed error naming the file, the line or element, and what is
// wrong; never a crash. Defective but valid meshes (unreferenced, duplicate vertices,
// degenerate faces) read fine.

#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>

#include "meshmark/core/error.h"
#include "meshmark/io/io.h"
#include "test_data.h"

using namespace meshmark;

namespace {

struct Bad {
  const char* label;
  FileFormat format;
  std::string bytes;
  std::size_t line;          // expected line (0: no line)
  const char* must_mention;  // a word the message must contain
};

std::string binary_stl(std::uint32_t declared, std::uint32_t actual, float poison = 0) {
  std::string s(84 + 50ull * actual, '\0');
  std::memcpy(s.data() + 80, &declared, 4);
  if (poison != 0) std::memcpy(s.data() + 84 + 12, &poison, 4);
  return s;
}

std::string binary_ply_header(int nv, int nf) {
  return "ply\nformat binary_little_endian 1.0\nelement vertex " + std::to_string(nv) +
         "\nproperty float x\nproperty float y\nproperty float z\nelement face " +
         std::to_string(nf) + "\nproperty list uchar int vertex_indices\nend_header\n";
}

std::vector<Bad> cases() {
  const std::string ply_ascii =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
  float nan = std::numeric_limits<float>::quiet_NaN();
  std::string ply_nan = binary_ply_header(3, 1) + std::string(36, '\0');
  std::memcpy(ply_nan.data() + ply_nan.size() - 36 + 4, &nan, 4);
  ply_nan += std::string("\x03\0\0\0\0\x01\0\0\0\x02\0\0\0", 13);
  // A coordinate longer than a write-back slot can hold (65,535 characters).
  const std::string longx = "0." + std::string(70000, '0') + "1e70000";  // 0.1
  return {
      {"off coordinate too long", FileFormat::Off,
       "OFF\n3 1 0\n0 0 0\n" + longx + " 0 0\n0 1 0\n3 0 1 2\n", 4, "70009 characters"},
      {"obj coordinate too long", FileFormat::Obj,
       "v 0 0 0\nv 1 " + longx + " 0\nv 0 1 0\nf 1 2 3\n", 2, "70009 characters"},
      {"ply ascii coordinate too long", FileFormat::Ply,
       ply_ascii + "0 0 0\n1 0 0\n0 " + longx + " 0\n3 0 1 2\n", 12, "70009 characters"},
      {"stl ascii coordinate too long", FileFormat::Stl,
       "solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 " + longx + "\n", 4,
       "70009 characters"},
      {"off truncated vertices", FileFormat::Off, "OFF\n4 1 0\n0 0 0\n1 0 0\n", 4,
       "ends after 2 of 4 vertices"},
      {"off wrong face count", FileFormat::Off, "OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", 6,
       "1 of 2 faces"},
      {"off index out of range", FileFormat::Off, "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", 6,
       "out of range"},
      {"off nan", FileFormat::Off, "OFF\n3 1 0\n0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n", 4, "not finite"},
      {"off infinity", FileFormat::Off, "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 -inf\n3 0 1 2\n", 5,
       "not finite"},
      {"off non-numeric", FileFormat::Off, "OFF\n3 1 0\n0 0 0\n1 0 zero\n0 1 0\n3 0 1 2\n", 4,
       "expected a number"},
      {"off no faces", FileFormat::Off, "OFF\n3 0 0\n0 0 0\n1 0 0\n0 1 0\n", 0, "no faces"},
      {"off bad header", FileFormat::Off, "PLY\n3 0 0\n", 1, "OFF header"},
      {"off absurd count", FileFormat::Off, "OFF\n999999999999 1 0\n", 2, "cannot fit"},
      {"off empty", FileFormat::Off, "", 0, "empty"},
      {"obj index out of range", FileFormat::Obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\n# c\nf 1 2 4\n", 5,
       "out of range"},
      {"obj zero index", FileFormat::Obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", 4,
       "vertex index"},
      {"obj relative before first", FileFormat::Obj, "v 0 0 0\nv 1 0 0\nf -1 -2 -3\n", 3,
       "before the first"},
      {"obj short vertex", FileFormat::Obj, "v 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", 1,
       "3 coordinates"},
      {"obj nan", FileFormat::Obj, "v 0 0 0\nv 1 0 NaN\nv 0 1 0\nf 1 2 3\n", 2, "not finite"},
      {"obj non-numeric", FileFormat::Obj, "v 0 0 0\nv 1 0 x1\nv 0 1 0\nf 1 2 3\n", 2,
       "expected a number"},
      {"obj no faces", FileFormat::Obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\n", 0, "no faces"},
      {"obj garbage face", FileFormat::Obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 b 3\n", 4,
       "vertex index"},
      {"obj truncated last face", FileFormat::Obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 2 3", 5,
       "at least 3"},
      {"off two-vertex face", FileFormat::Off, "OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n3 0 1 2\n",
       6, "at least 3"},
      {"ply ascii two-vertex face", FileFormat::Ply, ply_ascii + "0 0 0\n1 0 0\n0 1 0\n2 0 1\n", 13,
       "at least 3"},
      {"ply no end_header", FileFormat::Ply, "ply\nformat ascii 1.0\nelement vertex 3\n", 3,
       "end_header"},
      {"ply ascii truncated", FileFormat::Ply, ply_ascii + "0 0 0\n1 0 0\n", 11,
       "ends inside vertex 2"},
      {"ply ascii out of range", FileFormat::Ply, ply_ascii + "0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n", 13,
       "out of range"},
      {"ply ascii non-numeric", FileFormat::Ply, ply_ascii + "0 0 0\n1 zz 0\n0 1 0\n3 0 1 2\n", 11,
       "expected a number"},
      {"ply missing z", FileFormat::Ply,
       "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n0 "
       "0\n",
       3, "x, y or z"},
      {"ply unknown type", FileFormat::Ply,
       "ply\nformat ascii 1.0\nelement vertex 1\nproperty quux x\nend_header\n", 4,
       "unknown property type"},
      {"ply binary truncated", FileFormat::Ply, binary_ply_header(3, 1) + std::string(20, '\0'), 0,
       "remain"},
      {"ply binary huge count", FileFormat::Ply,
       binary_ply_header(2000000000, 1) + std::string(100, '\0'), 0, "cannot fit"},
      {"ply binary nan", FileFormat::Ply, ply_nan, 0, "not finite"},
      {"ply not ply", FileFormat::Ply, "solid x\n", 1, "not a PLY"},
      {"stl binary wrong count", FileFormat::Stl, binary_stl(5, 3), 0, "declares 5 triangles"},
      {"stl binary nan", FileFormat::Stl, binary_stl(2, 2, nan), 0, "not finite"},
      {"stl ascii four corners", FileFormat::Stl,
       "solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nvertex "
       "1 1 0\nendloop\nendfacet\nendsolid\n",
       7, "more than 3"},
      {"stl ascii truncated", FileFormat::Stl,
       "solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n", 4, "ends inside facet"},
      {"stl ascii non-numeric", FileFormat::Stl,
       "solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 O 0\n", 4, "expected a number"},
      {"stl ascii no faces", FileFormat::Stl, "solid s\nendsolid s\n", 0, "no faces"},
  };
}

}  // namespace

TEST(IoMalformed, EveryCaseGetsATypedErrorNamingFileLineAndProblem) {
  for (const Bad& c : cases()) {
    SCOPED_TRACE(c.label);
    const std::string name = std::string("bad/") + c.label;
    try {
      (void)read_mesh_from_bytes(c.bytes, c.format, name);
      ADD_FAILURE() << "no error for " << c.label;
    } catch (const InvalidInputError& e) {
      EXPECT_EQ(e.file(), name);
      EXPECT_EQ(e.line(), c.line) << e.what();
      EXPECT_NE(std::string(e.what()).find(c.must_mention), std::string::npos) << e.what();
      EXPECT_EQ(std::string(e.what()).rfind(name, 0), 0u)
          << "the message starts with the file name";
    }
  }
}

TEST(IoMalformed, EveryTruncationOfRealFilesFailsCleanly) {
  // Cut real files at many points: each prefix either reads or throws InvalidInputError.
  for (const std::string& path :
       {test::data_mesh("spot.obj"), test::closed_binary_ply(), test::data_mesh("bunny.ply"),
        test::data_mesh("featuretype.STL")}) {
    MESHMARK_REQUIRE(path, "a real mesh");
    const std::string bytes = read_file(path);
    const FileFormat f = format_from_path(path);
    for (int k = 1; k < 40; ++k) {
      const std::size_t cut = bytes.size() * k / 40;
      try {
        (void)read_mesh_from_bytes(bytes.substr(0, cut), f, path);
      } catch (const InvalidInputError&) {
      }
    }
  }
}

TEST(IoMalformed, MissingFilesAndDirectoriesAreIOErrors) {
  EXPECT_THROW(read_mesh("/nonexistent/mesh.obj"), IOError);
  const std::string dir = test::scratch_dir() + "/looks-like.obj";
  std::filesystem::create_directories(dir);
  EXPECT_THROW(read_mesh(dir), IOError);
  EXPECT_THROW(read_mesh("mesh.unknown"), InvalidArgumentError);
}

TEST(IoDefects, UnreferencedDuplicateAndDegenerateAreNormalInput) {
  const std::string obj =
      "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nv 9 9 9\nv 1 0 0\n"   // vertex 5 unreferenced; 6
                                                                 // duplicates 2
      "f 1 2 3\nf 1 3 4\nf 1 4 2\nf 2 4 3\nf 1 1 2\nf 6 3 4\n";  // a degenerate face
  const Mesh m = read_mesh_from_bytes(obj, FileFormat::Obj, "defects.obj");
  EXPECT_EQ(m.V.rows(), 6);
  EXPECT_EQ(FaceView(m).size(), 6u);
  EXPECT_EQ(m.F.rows(), 6);
  const auto used = referenced_vertices(m.F, m.V.rows());
  EXPECT_EQ(used[4], 0);
}
