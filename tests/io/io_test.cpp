// Round trips for every format and encoding, and the promise that a watermark changes vertex
// positions and nothing else, checked against independent readings of the files' layouts.

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <filesystem>
#include <optional>
#include <set>
#include <sstream>
#include <tuple>

#include <fmt/format.h>

#include "io/file_image.h"
#include "meshmark/core/error.h"
#include "meshmark/core/random.h"
#include "meshmark/io/io.h"
#include "test_data.h"

using namespace meshmark;
using namespace meshmark::test;

namespace {

Mesh sphere_with_a_quad() {
  Mesh m = bumpy_sphere(6, 9, 3);
  const int quad[] = {0, 1, 10, 9};  // an extra polygon: faces keep polygons, F triangulates
  Polygons faces = file_faces(m);
  faces.push_back(quad, 4);
  set_faces(m, std::move(faces));
  return m;
}

// Moves every k-th vertex by a small random offset; returns the new positions.
Eigen::MatrixX3d moved(const Eigen::MatrixX3d& V, int k, std::uint64_t seed) {
  Random rng(seed);
  Eigen::MatrixX3d W = V;
  const double diag = bounding_box_diagonal(V);
  for (Eigen::Index i = 0; i < V.rows(); i += k)
    for (int a = 0; a < 3; ++a) W(i, a) += 1e-4 * diag * rng.uniform(-1, 1);
  return W;
}

float load_float(const std::string& bytes, std::size_t offset, bool big_endian = false) {
  char tmp[4];
  std::memcpy(tmp, bytes.data() + offset, 4);
  if (big_endian) std::reverse(tmp, tmp + 4);
  float f;
  std::memcpy(&f, tmp, 4);
  return f;
}

}  // namespace

TEST(IoRoundTrip, EveryFormatAndEncodingFromScratch) {
  const Mesh m = sphere_with_a_quad();
  struct Case {
    FileFormat format;
    Encoding encoding;
    bool single;
  };
  const Case cases[] = {{FileFormat::Off, Encoding::Ascii, false},
                        {FileFormat::Obj, Encoding::Ascii, false},
                        {FileFormat::Ply, Encoding::Ascii, false},
                        {FileFormat::Ply, Encoding::BinaryLittleEndian, false},
                        {FileFormat::Ply, Encoding::BinaryBigEndian, false},
                        {FileFormat::Ply, Encoding::BinaryLittleEndian, true},
                        {FileFormat::Ply, Encoding::BinaryBigEndian, true}};
  for (const Case& c : cases) {
    WriteOptions wo;
    wo.encoding = c.encoding;
    wo.single_precision = c.single;
    const Mesh back =
        read_mesh_from_bytes(write_mesh_to_bytes(m, c.format, wo), c.format, "roundtrip");
    SCOPED_TRACE(std::string(format_name(c.format)) + " " + encoding_name(c.encoding) +
                 (c.single ? " float32" : ""));
    EXPECT_EQ(back.encoding, c.encoding);
    ASSERT_EQ(back.V.rows(), m.V.rows());
    const Eigen::MatrixX3d expected =
        c.single ? Eigen::MatrixX3d(m.V.cast<float>().cast<double>()) : m.V;
    EXPECT_EQ(back.V, expected);  // shortest round-trip text and binary doubles are exact
    EXPECT_EQ(file_faces(back), file_faces(m));
  }
}

TEST(IoRoundTrip, StlAsciiAndBinaryWeldBackToTheSameTriangles) {
  const Mesh m = bumpy_sphere(7, 11, 5);
  for (Encoding enc : {Encoding::Ascii, Encoding::BinaryLittleEndian}) {
    WriteOptions wo;
    wo.encoding = enc;
    const Mesh back = read_mesh_from_bytes(write_mesh_to_bytes(m, FileFormat::Stl, wo),
                                           FileFormat::Stl, "rt.stl");
    ASSERT_EQ(back.V.rows(), m.V.rows()) << "distinct positions weld back to one vertex each";
    ASSERT_EQ(back.F.rows(), m.F.rows());
    const double tol = enc == Encoding::Ascii ? 0.0 : 1e-6;
    for (Eigen::Index t = 0; t < m.F.rows(); ++t)
      for (int c = 0; c < 3; ++c)
        EXPECT_LE((back.V.row(back.F(t, c)) - m.V.row(m.F(t, c))).cwiseAbs().maxCoeff(), tol);
  }
}

TEST(IoFaithful, UnchangedMeshesWriteBackByteForByte) {
  const std::vector<std::string> files = {
      data_mesh("spot.obj"),        data_mesh("spider.obj"),  data_mesh("spider.obj"),
      data_mesh("bunny.ply"),       closed_binary_ply(),      tristrip_ply(),
      data_mesh("featuretype.STL"), cgal_mesh("fandisk.off"), cgal_mesh("pig.stl")};
  for (const std::string& f : files) {
    MESHMARK_REQUIRE(f, "a mesh of data/meshes or libcgal-demo");
    SCOPED_TRACE(f);
    const Mesh m = read_mesh(f);
    EXPECT_EQ(write_mesh_to_bytes(m, m.format), read_file(f));
  }
}

// Without an image (ReadOptions::keep_image false, how trace and embed's check read), the
// readers skip recording where each coordinate sits; what they read is the same mesh.
TEST(IoRead, WithoutAnImageTheSameMeshIsRead) {
  const std::vector<std::string> files = {data_mesh("spot.obj"),    data_mesh("bunny.ply"),
                                          closed_binary_ply(),      tristrip_ply(),
                                          cgal_mesh("fandisk.off"), data_mesh("featuretype.STL")};
  for (const std::string& f : files) {
    MESHMARK_REQUIRE(f, "a mesh of data/meshes or libcgal-demo");
    SCOPED_TRACE(f);
    for (const double weld : {0.0, 1e-3}) {
      ReadOptions with, without;
      with.weld_tolerance = without.weld_tolerance = weld;
      without.keep_image = false;
      const Mesh a = read_mesh(f, with), b = read_mesh(f, without);
      ASSERT_NE(a.image, nullptr);
      EXPECT_EQ(b.image, nullptr);
      EXPECT_TRUE(a.V == b.V);
      EXPECT_TRUE(a.F == b.F);
      EXPECT_EQ(file_faces(a), file_faces(b));
      // Read where the bytes are (read_mesh_from_buffer, embed's check of its output): the
      // same mesh, and the bytes left as they were.
      const std::string bytes = read_file(f);
      const std::string before = bytes;
      const Mesh c = read_mesh_from_buffer(bytes, format_from_path(f), f, with);
      EXPECT_EQ(c.image, nullptr);
      EXPECT_TRUE(a.V == c.V);
      EXPECT_TRUE(a.F == c.F);
      EXPECT_EQ(file_faces(a), file_faces(c));
      EXPECT_EQ(bytes, before);
    }
  }
}

TEST(IoFaithful, ObjChangesOnlyVertexCoordinates) {
  for (const std::string name : {"spot.obj", "spider.obj"}) {
    const std::string path = data_mesh(name);
    MESHMARK_REQUIRE(path, name);
    SCOPED_TRACE(name);
    Mesh m = read_mesh(path);
    const Eigen::MatrixX3d V0 = m.V;
    m.V = moved(m.V, 3, 11);
    const std::string out = write_mesh_to_bytes(m, FileFormat::Obj);
    const auto a = split_lines(read_file(path)), b = split_lines(out);
    ASSERT_EQ(a.size(), b.size());
    Eigen::Index v = 0;
    for (std::size_t k = 0; k < a.size(); ++k) {
      const auto wa = words(a[k]), wb = words(b[k]);
      if (wa.empty() || wa[0] != "v") {
        EXPECT_EQ(a[k], b[k]) << "line " << k + 1;  // vt, vn, f, g, usemtl, comments: untouched
        continue;
      }
      ASSERT_EQ(wa.size(), wb.size());
      for (std::size_t t = 4; t < wa.size(); ++t) EXPECT_EQ(wa[t], wb[t]);
      const bool vertex_moved = m.V.row(v) != V0.row(v);
      if (!vertex_moved) EXPECT_EQ(a[k], b[k]);
      for (int c = 0; c < 3; ++c) EXPECT_EQ(std::strtod(wb[1 + c].c_str(), nullptr), m.V(v, c));
      ++v;
    }
    EXPECT_EQ(v, m.V.rows());
    const Mesh back = read_mesh_from_bytes(out, FileFormat::Obj, "back.obj");
    EXPECT_EQ(back.V, m.V);
    EXPECT_EQ(file_faces(back), file_faces(m));
  }
}

TEST(IoFaithful, BinaryPlyChangesOnlyVertexCoordinateBytes) {
  const std::string path = closed_binary_ply();
  MESHMARK_REQUIRE(path, "bunny00.off");
  const std::string original = read_file(path);
  // Independent reading of the layout: a vertex element first, scalar float properties only.
  const std::size_t body = original.find("end_header\n") + std::strlen("end_header\n");
  std::istringstream header(original.substr(0, body));
  std::vector<std::string> props;
  std::size_t nv = 0;
  bool in_vertex = false;
  for (std::string line; std::getline(header, line);) {
    const auto w = words(line);
    if (w.size() == 3 && w[0] == "element") {
      in_vertex = w[1] == "vertex";
      if (in_vertex)
        nv = std::stoul(w[2]);
      else
        break;  // the vertex element's properties are all we need
    } else if (in_vertex && w.size() == 3 && w[0] == "property") {
      ASSERT_EQ(w[1], "float") << "this test expects float vertex properties";
      props.push_back(w[2]);
    }
  }
  const std::size_t record = 4 * props.size();
  std::size_t axis_offset[3];
  for (int a = 0; a < 3; ++a)
    axis_offset[a] =
        4 * (std::find(props.begin(), props.end(), std::string(1, "xyz"[a])) - props.begin());

  Mesh m = read_mesh(path);
  ASSERT_EQ(static_cast<std::size_t>(m.V.rows()), nv);
  m.V = moved(m.V, 2, 5);
  const std::string out = write_mesh_to_bytes(m, FileFormat::Ply);
  ASSERT_EQ(out.size(), original.size());
  std::vector<char> is_coordinate(original.size(), 0);
  for (std::size_t i = 0; i < nv; ++i)
    for (int a = 0; a < 3; ++a) {
      const std::size_t off = body + i * record + axis_offset[a];
      std::fill(is_coordinate.begin() + off, is_coordinate.begin() + off + 4, 1);
      EXPECT_EQ(load_float(out, off), static_cast<float>(m.V(i, a)));
    }
  std::size_t differing = 0;
  for (std::size_t k = 0; k < out.size(); ++k)
    if (!is_coordinate[k]) differing += out[k] != original[k];
  EXPECT_EQ(differing, 0u) << "bytes outside x, y, z changed (normals, faces, header)";
}

// A binary PLY's fixed-size vertex records are written back through their layout (no slot per
// coordinate): in both byte orders, in single and double precision, with an extra property
// between the coordinates, every moved coordinate reads back as moved and every other byte of
// the file is unchanged; read with welding (slots then), the same bytes.
TEST(IoFaithful, BinaryPlyInEitherByteOrderWritesMovedVerticesBack) {
  const Mesh sphere = bumpy_sphere(8, 12, 3);
  for (const bool big : {false, true})
    for (const bool single : {false, true}) {
      SCOPED_TRACE(std::string(big ? "big" : "little") + (single ? " float" : " double"));
      const char* type = single ? "float" : "double";
      std::string file = fmt::format(
          "ply\nformat binary_{}_endian 1.0\nelement vertex {}\nproperty {} x\nproperty uchar "
          "flag\nproperty {} y\nproperty {} z\nelement face {}\nproperty list uchar int "
          "vertex_indices\nend_header\n",
          big ? "big" : "little", sphere.V.rows(), type, type, type, sphere.F.rows());
      const auto put = [&](const void* data, std::size_t n) {
        std::string b(static_cast<const char*>(data), n);
        if (big) std::reverse(b.begin(), b.end());
        file += b;
      };
      for (Eigen::Index i = 0; i < sphere.V.rows(); ++i)
        for (int a = 0; a < 3; ++a) {
          if (single) {
            const auto f = static_cast<float>(sphere.V(i, a));
            put(&f, 4);
          } else {
            put(&sphere.V(i, a), 8);
          }
          if (a == 0) file += static_cast<char>(i % 7);  // the flag between x and y
        }
      for (Eigen::Index t = 0; t < sphere.F.rows(); ++t) {
        file += '\3';
        for (int c = 0; c < 3; ++c) put(&sphere.F(t, c), 4);
      }
      for (const double weld : {0.0, 1e-12}) {
        ReadOptions ro;
        ro.weld_tolerance = weld;
        Mesh m = read_mesh_from_bytes(file, FileFormat::Ply, "layout.ply", ro);
        ASSERT_EQ(m.V.rows(), sphere.V.rows());
        m.V = moved(m.V, 3, 7);
        if (single) m.V = m.V.cast<float>().cast<double>();
        const std::string out = write_mesh_to_bytes(m, FileFormat::Ply);
        ASSERT_EQ(out.size(), file.size());
        const Mesh back = read_mesh_from_bytes(out, FileFormat::Ply, "back.ply");
        EXPECT_EQ(back.V, m.V);
        // Only coordinate bytes may differ: the flags, the header and the faces are kept.
        const std::size_t body = file.find("end_header\n") + 11, size = single ? 4 : 8;
        std::size_t differing = 0;
        for (std::size_t k = 0; k < out.size(); ++k) {
          const bool vertex_part = k >= body && k < body + sphere.V.rows() * (3 * size + 1);
          const std::size_t in_record = (k - body) % (3 * size + 1);
          const bool coordinate = vertex_part && in_record != size;  // the flag's byte
          if (!coordinate) differing += out[k] != file[k];
        }
        EXPECT_EQ(differing, 0u) << "weld " << weld;
      }
    }
}

// A binary PLY of plain records (x, y and z alone; one index list alone) keeps its header and
// other elements in the image, not its vertex and face records, and writes the same bytes as a
// file built from the moved positions, in both byte orders and precisions and with several
// count and index types; records that do not encode again exactly (a float index stored as
// -0.0) are kept as read.
TEST(IoFaithful, PlainBinaryPlyRecordsAreNotHeldAndWriteTheSameBytes) {
  const Mesh sphere = bumpy_sphere(8, 12, 3);
  struct Case {
    bool big, single;
    const char* count_type;
    const char* index_type;
    bool faces_first, minus_zero;
  };
  const Case cases[] = {{false, false, "uchar", "int", false, false},
                        {true, true, "uchar", "int", false, false},
                        {false, true, "ushort", "uint", true, false},
                        {true, false, "int", "short", false, false},
                        {false, true, "uchar", "float", false, true}};
  Eigen::Index zero_face = 0;  // the first face with vertex 0: its index 0 stored as -0.0
  while (zero_face < sphere.F.rows() && (sphere.F.row(zero_face).array() != 0).all()) ++zero_face;
  ASSERT_LT(zero_face, sphere.F.rows());
  for (const Case& c : cases) {
    SCOPED_TRACE(fmt::format("{} {} {} {}{}", c.big ? "big" : "little",
                             c.single ? "float" : "double", c.count_type, c.index_type,
                             c.minus_zero ? " -0.0" : ""));
    const std::size_t scalar = c.single ? 4 : 8;
    const auto type_size = [](std::string_view t) -> std::size_t {
      return t == "uchar" ? 1 : t == "ushort" || t == "short" ? 2 : 4;
    };
    // Builds the file independently of the reader and writer.
    const auto build = [&](const Eigen::MatrixX3d& V) {
      std::string body_v, body_f;
      const auto put = [&](std::string& to, const void* data, std::size_t n) {
        std::string b(static_cast<const char*>(data), n);
        if (c.big) std::reverse(b.begin(), b.end());
        to += b;
      };
      const auto put_int = [&](std::string& to, std::string_view t, long value,
                               bool negative_zero) {
        if (t == "uchar") {
          to += static_cast<char>(value);
        } else if (t == "ushort" || t == "short") {
          const auto v = static_cast<std::uint16_t>(value);
          put(to, &v, 2);
        } else if (t == "float") {
          const float v = negative_zero ? -0.0F : static_cast<float>(value);
          put(to, &v, 4);
        } else {
          const auto v = static_cast<std::uint32_t>(value);
          put(to, &v, 4);
        }
      };
      for (Eigen::Index i = 0; i < V.rows(); ++i)
        for (int a = 0; a < 3; ++a) {
          if (c.single) {
            const auto f = static_cast<float>(V(i, a));
            put(body_v, &f, 4);
          } else {
            put(body_v, &V(i, a), 8);
          }
        }
      for (Eigen::Index t = 0; t < sphere.F.rows(); ++t) {
        put_int(body_f, c.count_type, 3, false);
        for (int k = 0; k < 3; ++k)
          put_int(body_f, c.index_type, sphere.F(t, k),
                  c.minus_zero && t == zero_face && sphere.F(t, k) == 0);
      }
      const char* type = c.single ? "float" : "double";
      const std::string vertex_header =
          fmt::format("element vertex {}\nproperty {} x\nproperty {} y\nproperty {} z\n", V.rows(),
                      type, type, type);
      const std::string face_header =
          fmt::format("element face {}\nproperty list {} {} vertex_indices\n", sphere.F.rows(),
                      c.count_type, c.index_type);
      const std::string other = "element material 2\nproperty uchar red\n";
      return fmt::format("ply\nformat binary_{}_endian 1.0\n{}{}{}end_header\n{}{}\x07\x09",
                         c.big ? "big" : "little", c.faces_first ? face_header : vertex_header,
                         c.faces_first ? vertex_header : face_header, other,
                         c.faces_first ? body_f : body_v, c.faces_first ? body_v : body_f);
    };
    Eigen::MatrixX3d V0 = sphere.V;
    if (c.single) V0 = V0.cast<float>().cast<double>();
    const std::string file = build(V0);
    Mesh m = read_mesh_from_bytes(file, FileFormat::Ply, "plain.ply");
    ASSERT_TRUE(m.image);
    const std::size_t vertex_bytes = static_cast<std::size_t>(sphere.V.rows()) * 3 * scalar;
    const std::size_t face_bytes = static_cast<std::size_t>(sphere.F.rows()) *
                                   (type_size(c.count_type) + 3 * type_size(c.index_type));
    const std::size_t held = file.size() - vertex_bytes - (c.minus_zero ? 0 : face_bytes);
    EXPECT_EQ(m.image->bytes.size(), held);
    EXPECT_EQ(m.image->elided.size(), c.minus_zero ? 1U : 2U);
    m.V = moved(m.V, 3, 7);
    if (c.single) m.V = m.V.cast<float>().cast<double>();
    const std::string out = write_mesh_to_bytes(m, FileFormat::Ply);
    EXPECT_TRUE(out == build(m.V))
        << "the written file differs from one built from the moved positions";
    const Mesh back = read_mesh_from_bytes(out, FileFormat::Ply, "back.ply");
    EXPECT_EQ(back.V, m.V);
    EXPECT_EQ(back.F, sphere.F);
    // Unmoved, the same file byte for byte.
    m.V = V0;
    EXPECT_TRUE(write_mesh_to_bytes(m, FileFormat::Ply) == file);
  }
}

// Faces changed with their counts kept (a triangle turned over) are written as changed, in
// every format that writes through an image: the image no longer applies (its face hash), where
// it used to write the faces as read.
TEST(IoFaithful, FacesChangedWithTheirCountsKeptAreWrittenAsChanged) {
  const Mesh sphere = bumpy_sphere(8, 12, 3);
  struct Case {
    FileFormat format;
    std::optional<Encoding> encoding;
  };
  const Case cases[] = {{FileFormat::Off, std::nullopt},
                        {FileFormat::Obj, std::nullopt},
                        {FileFormat::Ply, Encoding::Ascii},
                        {FileFormat::Ply, Encoding::BinaryLittleEndian},
                        {FileFormat::Glb, std::nullopt}};
  for (const Case& c : cases) {
    SCOPED_TRACE(
        fmt::format("{} {}", format_name(c.format), c.encoding ? encoding_name(*c.encoding) : ""));
    WriteOptions wo;
    wo.encoding = c.encoding;
    const std::string file = write_mesh_to_bytes(sphere, c.format, wo);
    Mesh m = read_mesh_from_bytes(file, c.format, "turned");
    ASSERT_TRUE(m.image);
    ASSERT_EQ(m.F.rows(), sphere.F.rows());
    ASSERT_TRUE(m.faces.size() == 0) << "a file of triangles keeps them in F alone";
    std::swap(m.F(0, 1), m.F(0, 2));  // turned over: the same counts
    const Mesh back = read_mesh_from_bytes(write_mesh_to_bytes(m, c.format, wo), c.format, "back");
    ASSERT_EQ(back.F.rows(), m.F.rows());
    for (int k = 0; k < 3; ++k)
      EXPECT_EQ(back.V.row(back.F(0, k)), m.V.row(m.F(0, k))) << "corner " << k;
    // Unchanged, the file comes back byte for byte.
    std::swap(m.F(0, 1), m.F(0, 2));
    EXPECT_TRUE(write_mesh_to_bytes(m, c.format, wo) == file);
  }
}

TEST(IoFaithful, AsciiPlyKeepsOtherPropertiesAndElements) {
  const std::string path = data_mesh("bunny.ply");
  MESHMARK_REQUIRE(path, "bunny.ply");
  Mesh m = read_mesh(path);
  EXPECT_EQ(m.V.rows(), 8171);
  EXPECT_EQ(FaceView(m).size(), 16301u);
  m.V = moved(m.V, 4, 9);
  const std::string out = write_mesh_to_bytes(m, FileFormat::Ply);
  const auto a = split_lines(read_file(path)), b = split_lines(out);
  ASSERT_EQ(a.size(), b.size());
  const std::size_t first = std::find(a.begin(), a.end(), "end_header") - a.begin() + 1;
  for (std::size_t k = 0; k < a.size(); ++k) {
    const bool vertex_line = k >= first && k < first + static_cast<std::size_t>(m.V.rows());
    if (!vertex_line) {
      EXPECT_EQ(a[k], b[k]);
      continue;
    }
    const auto wa = words(a[k]), wb = words(b[k]);
    ASSERT_EQ(wa.size(), wb.size());
    for (std::size_t t = 3; t < wa.size(); ++t) EXPECT_EQ(wa[t], wb[t]);  // confidence, intensity
    for (int c = 0; c < 3; ++c) EXPECT_EQ(std::strtod(wb[c].c_str(), nullptr), m.V(k - first, c));
  }
}

TEST(IoFaithful, TriangleStripsReadAsTrianglesAndArePreserved) {
  const std::string path = tristrip_ply(), off = cgal_mesh("bunny00.off");
  MESHMARK_REQUIRE(path, "bunny00.off");
  Mesh m = read_mesh(path);
  const Mesh source = read_mesh(off);
  EXPECT_EQ(m.V.rows(), source.V.rows());
  // Independent count: a closed genus-0 triangle mesh has F = 2V - 4 faces.
  EXPECT_EQ(m.F.rows(), 2 * m.V.rows() - 4);
  // The strips decode to the source's triangles with their orientation (each triangle rotated
  // to start at its smallest index, compared as sorted lists).
  auto oriented = [](const Eigen::MatrixX3i& F) {
    std::vector<std::array<int, 3>> t;
    for (Eigen::Index f = 0; f < F.rows(); ++f) {
      int r = 0;
      for (int c = 1; c < 3; ++c)
        if (F(f, c) < F(f, r)) r = c;
      t.push_back({F(f, r), F(f, (r + 1) % 3), F(f, (r + 2) % 3)});
    }
    std::sort(t.begin(), t.end());
    return t;
  };
  EXPECT_EQ(oriented(m.F), oriented(source.F));
  m.V.array() += 0.25;
  const Mesh back = read_mesh_from_bytes(write_mesh_to_bytes(m, FileFormat::Ply), FileFormat::Ply,
                                         "tristrips-moved.ply");
  EXPECT_EQ(back.F, m.F);
  EXPECT_LE((back.V - m.V.cast<float>().cast<double>()).cwiseAbs().maxCoeff(), 0.0);
}

TEST(IoFaithful, BinaryStlWritesCornersBackUnweldedInOrder) {
  const std::string path = data_mesh("featuretype.STL");
  MESHMARK_REQUIRE(path, "featuretype.STL");
  const std::string original = read_file(path);
  std::uint32_t nt = 0;
  std::memcpy(&nt, original.data() + 80, 4);
  ReadOptions ro;
  ro.weld_tolerance = 1e-5;
  Mesh m = read_mesh(path, ro);
  EXPECT_EQ(m.F.rows(), static_cast<Eigen::Index>(nt));
  EXPECT_EQ(read_mesh(path).V.rows(), 2010) << "the manifest's welded vertex count (exact weld)";
  EXPECT_LT(m.V.rows(), 2010) << "a tolerance weld joins the near-identical corners too";
  const Eigen::RowVector3d d(0.125, -0.5, 2.0);  // the same displacement for every vertex
  m.V.rowwise() += d;
  const std::string out = write_mesh_to_bytes(m, FileFormat::Stl);
  ASSERT_EQ(out.size(), original.size());
  EXPECT_EQ(out.substr(0, 84), original.substr(0, 84));
  for (std::uint32_t t = 0; t < nt; ++t) {
    const std::size_t rec = 84 + 50ull * t;
    EXPECT_EQ(out.substr(rec, 12), original.substr(rec, 12)) << "normal of triangle " << t;
    EXPECT_EQ(out.substr(rec + 48, 2), original.substr(rec + 48, 2))
        << "attribute of triangle " << t;
    for (int k = 0; k < 9; ++k) {
      const float before = load_float(original, rec + 12 + 4 * k);
      EXPECT_EQ(load_float(out, rec + 12 + 4 * k), static_cast<float>(before + d(k % 3)));
    }
  }
}

TEST(IoFaithful, ExactWeldCountsDistinctCornerPositions) {
  const std::string path = cgal_mesh("pig.stl");
  MESHMARK_REQUIRE(path, "libcgal-demo pig.stl");
  const std::string bytes = read_file(path);
  const Mesh m = read_mesh(path);
  // Independent: read the corners by the binary layout (84-byte header, 50 bytes a triangle,
  // corners after the normal) and count distinct positions.
  std::set<std::tuple<float, float, float>> distinct;
  std::uint32_t nt = 0;
  std::memcpy(&nt, bytes.data() + 80, 4);
  ASSERT_EQ(bytes.size(), 84 + 50ull * nt) << "pig.stl is expected to be binary";
  for (std::uint32_t t = 0; t < nt; ++t)
    for (int c = 0; c < 3; ++c) {
      const std::size_t off = 84 + 50ull * t + 12 + 12 * c;
      distinct.insert({load_float(bytes, off) + 0.0f, load_float(bytes, off + 4) + 0.0f,
                       load_float(bytes, off + 8) + 0.0f});
    }
  EXPECT_EQ(static_cast<std::size_t>(m.V.rows()), distinct.size());
}

TEST(IoFaithful, FormatConversionKeepsPositionsAndPolygons) {
  const std::string path = data_mesh("spot.obj");
  MESHMARK_REQUIRE(path, "spot.obj");
  const Mesh m = read_mesh(path);
  for (FileFormat f : {FileFormat::Off, FileFormat::Ply}) {
    const Mesh back = read_mesh_from_bytes(write_mesh_to_bytes(m, f), f, "converted");
    EXPECT_EQ(back.V, m.V);
    EXPECT_EQ(file_faces(back), file_faces(m));
  }
}

TEST(IoAtomicWrite, FailsCleanlyAndLeavesNoTemporaryFiles) {
  const std::string dir = scratch_dir();
  const Mesh m = bumpy_sphere(4, 5, 1);
  EXPECT_THROW(write_mesh(dir + "/missing/sub/out.obj", m), IOError);
  write_mesh(dir + "/out.obj", m);
  write_mesh(dir + "/out.obj", m);  // replaces
  std::size_t entries = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    ++entries;
    EXPECT_EQ(e.path().filename(), "out.obj");
  }
  EXPECT_EQ(entries, 1u);
  EXPECT_THROW(write_mesh(dir + "/out.xyz", m), InvalidArgumentError);
}
