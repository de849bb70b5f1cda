#pragma once
/// \file mesh.h
/// The mesh meshmark works on: positions and triangles as plain matrices (libigl style), the
/// polygons the file had, and an opaque image of the source file so that writing back keeps
/// everything the file carried besides positions.

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>
#include "meshmark/core/enum_names.h"

namespace meshmark {

/// The mesh file formats meshmark reads and writes.
/// glTF 2.0 as JSON (.gltf, buffers embedded or beside it) or binary (.glb); Draco (.drc); 3MF.
enum class FileFormat { Off, Obj, Ply, Stl, Gltf, Glb, Draco, ThreeMf };

/// The names of FileFormat's values (format_name).
template <>
struct EnumTable<FileFormat> {
  static constexpr const char* what = "format";
  static constexpr NamedValue<FileFormat> values[] = {
      {FileFormat::Off, "off"},   {FileFormat::Obj, "obj"},    {FileFormat::Ply, "ply"},
      {FileFormat::Stl, "stl"},   {FileFormat::Gltf, "gltf"},  {FileFormat::Glb, "glb"},
      {FileFormat::Draco, "drc"}, {FileFormat::ThreeMf, "3mf"}};
};

/// How a file stores its numbers. OFF and OBJ are always ascii.
enum class Encoding { Ascii, BinaryLittleEndian, BinaryBigEndian };

/// The names of Encoding's values (encoding_name).
template <>
struct EnumTable<Encoding> {
  static constexpr const char* what = "encoding";
  static constexpr NamedValue<Encoding> values[] = {
      {Encoding::Ascii, "ascii"},
      {Encoding::BinaryLittleEndian, "binary_little_endian"},
      {Encoding::BinaryBigEndian, "binary_big_endian"}};
};

/// Faces of any size in compressed rows: face k holds indices[offsets[k] .. offsets[k+1]).
struct Polygons {
  std::vector<std::int64_t> offsets{0};  ///< size() + 1 entries, offsets[0] == 0
  std::vector<int> indices;              ///< 0-based vertex indices
  /// Number of faces.
  std::size_t size() const { return offsets.size() - 1; }
  /// Appends one face.
  void push_back(const int* first, std::size_t count);
  bool operator==(const Polygons&) const = default;
};

/// The bytes of the file a mesh was read from and where its coordinates sit in them
/// (defined in the io module; opaque here).
struct FileImage;

/// A triangle mesh as meshmark computes on it, plus what its file carried.
struct Mesh {
  Eigen::MatrixX3d V;  ///< #V x 3 positions
  Eigen::MatrixX3i F;  ///< #F x 3 triangles (polygons fan-triangulated), 0-based
  /// The faces as the file gave them (polygons, strips unrolled) when they are not exactly F's
  /// rows; empty when they are (a file of triangles: F alone holds them, and a mesh keeps no
  /// second copy, 20 bytes a face). FaceView reads them either way; set_faces fills both.
  Polygons faces;
  FileFormat format = FileFormat::Obj;  ///< format of the source file
  Encoding encoding = Encoding::Ascii;  ///< encoding of the source file
  std::string source_path;              ///< the path it was read from, if any
  /// Image of the source file: while V keeps its row count and faces are unchanged, a write
  /// in the same format substitutes the positions and keeps every other byte. Operations that
  /// change connectivity reset it.
  std::shared_ptr<const FileImage> image;
  /// What the reader noticed that the caller should hear, one sentence each (glTF: skinned or
  /// morphed meshes, non-uniform scales, instanced meshes, skipped point or line primitives).
  std::vector<std::string> notes;
};

/// The preconditions every function taking a mesh states, checked where the library is entered
/// (embed, extract, the metrics, the attacks, write_mesh): every coordinate of V (#V x 3)
/// finite, every index of F (#F x 3) in [0, #V). `what` names the mesh in the message ("the
/// mesh", "the original", ...). O(#V + #F).
/// \throw InvalidArgumentError naming the first offending element, e.g. "the mesh: face 12 has
///        vertex index 900 but the mesh has 500 vertices" or "the mesh: vertex 3 has a
///        non-finite coordinate (nan, 0, 1)".
void validate_mesh(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                   std::string_view what = "the mesh");

/// validate_mesh(mesh.V, mesh.F, what), and every index of mesh.faces (the polygons a write
/// gives back, when they are not F's rows) in [0, #V), with consistent offsets.
/// \throw InvalidArgumentError as validate_mesh.
void validate_mesh(const Mesh& mesh, std::string_view what = "the mesh");

/// Fan-triangulates polygons: a face (v0, v1, ..., vk) gives (v0, vi, vi+1). Faces with fewer
/// than three vertices give no triangle. Returns #T x 3.
Eigen::MatrixX3i triangulate(const Polygons& faces);

/// Polygons holding exactly the rows of F.
Polygons polygons_from_triangles(const Eigen::MatrixX3i& F);

/// Sets mesh.F to faces fan-triangulated (triangulate) and keeps faces in mesh.faces only when
/// they are not exactly F's rows (some face is not a triangle); otherwise mesh.faces is empty.
void set_faces(Mesh& mesh, Polygons faces);

/// The faces a write gives back, without copying them: Mesh::faces, or F's rows when faces is
/// empty. Valid while the mesh is alive and unchanged.
class FaceView {
 public:
  /// A view of mesh's faces.
  explicit FaceView(const Mesh& mesh)
      : polygons_(mesh.faces.size() > 0 ? &mesh.faces : nullptr), F_(&mesh.F) {}
  /// The number of faces.
  std::size_t size() const {
    return polygons_ ? polygons_->size() : static_cast<std::size_t>(F_->rows());
  }
  /// The number of corners over all faces (3 a triangle).
  std::size_t corners() const { return polygons_ ? polygons_->indices.size() : 3 * size(); }
  /// The number of corners of face k (k < size()).
  std::size_t size_of(std::size_t k) const {
    return polygons_ ? static_cast<std::size_t>(polygons_->offsets[k + 1] - polygons_->offsets[k])
                     : 3;
  }
  /// Corner c of face k, a 0-based vertex index (c < size_of(k)).
  int corner(std::size_t k, std::size_t c) const {
    return polygons_ ? polygons_->indices[static_cast<std::size_t>(polygons_->offsets[k]) + c]
                     : (*F_)(static_cast<Eigen::Index>(k), static_cast<Eigen::Index>(c));
  }

 private:
  const Polygons* polygons_;
  const Eigen::MatrixX3i* F_;
};

/// The faces a write gives back (FaceView), copied into polygons.
Polygons file_faces(const Mesh& mesh);

/// A mesh made of V and F alone (faces empty: they are F's rows; no file image).
Mesh make_mesh(Eigen::MatrixX3d V, Eigen::MatrixX3i F);

/// 1 for every vertex that some triangle of F references, 0 otherwise (size nv).
/// Unreferenced vertices carry no bit and do not enter any center.
std::vector<std::uint8_t> referenced_vertices(const Eigen::MatrixX3i& F, Eigen::Index nv);

/// Length of the diagonal of the axis-aligned bounding box of the referenced vertices
/// (all vertices when mask is empty). 0 for an empty set.
double bounding_box_diagonal(const Eigen::MatrixX3d& V, const std::vector<std::uint8_t>& mask = {});

/// The one-ring of every vertex (neighbors through an edge of F), in compressed rows:
/// neighbors of i are indices[offsets[i] .. offsets[i+1]), sorted, without repetition.
struct Adjacency {
  std::vector<int> offsets;
  std::vector<int> indices;
  int degree(int i) const { return offsets[i + 1] - offsets[i]; }
};

/// Builds the vertex adjacency of F over nv vertices (isolated vertices have degree 0).
Adjacency vertex_adjacency(const Eigen::MatrixX3i& F, Eigen::Index nv);

/// Unit vertex normals: the normalized sum of the (area-weighted) face normals around each
/// vertex; zero where that sum vanishes (isolated vertices, cancelling faces). #V x 3.
Eigen::MatrixX3d vertex_normals(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F);

/// Unit face normals (zero for degenerate faces). #F x 3.
Eigen::MatrixX3d face_normals(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F);

/// Values of a vertex mask that counts each position once (carrier_vertices in histogram.h):
/// 0 outside the set; kCounted for the first (smallest-index) vertex at its position, the one
/// that counts in histograms and the discrete center; kTwin for a later vertex at the position
/// of a counted one (an unwelded seam or corner, or a duplicate): it moves with its position but
/// never counts again. A plain 0/1 mask (referenced_vertices) counts every vertex.
inline constexpr std::uint8_t kCounted = 1;
inline constexpr std::uint8_t kTwin = 2;  ///< see kCounted

/// For every vertex with mask[i] != 0, the smallest index j with mask[j] != 0 at a
/// bit-identical position (i itself when none is smaller); -1 where mask[i] == 0. -0.0 equals
/// +0.0. One hash table over the positions: O(#V) expected, no sort. mask: size #V.
std::vector<int> first_at_same_position(const Eigen::MatrixX3d& V,
                                        const std::vector<std::uint8_t>& mask);

/// Groups of referenced vertices at bit-identical positions (unwelded seams, duplicates):
/// group_of[i] is the group of vertex i (-1 for unreferenced), members are listed per group in
/// compressed rows. Groups are numbered in order of their first vertex.
struct PositionGroups {
  std::vector<int> group_of;    ///< size nv
  std::vector<int> offsets{0};  ///< size count() + 1
  std::vector<int> members;     ///< vertex indices, grouped
  int count() const { return static_cast<int>(offsets.size()) - 1; }
};

/// Computes PositionGroups over the vertices with referenced[i] != 0. -0.0 equals +0.0.
PositionGroups group_identical_positions(const Eigen::MatrixX3d& V,
                                         const std::vector<std::uint8_t>& referenced);

}  // namespace meshmark
