#pragma once
// Internal: the per-format readers and writers behind io.h's dispatcher, and what they share.

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "file_image.h"
#include "meshmark/io.h"

namespace meshmark::detail {

Mesh read_off(std::string bytes, const std::string& name, const ReadOptions& options);
Mesh read_obj(std::string bytes, const std::string& name, const ReadOptions& options);
Mesh read_ply(std::string bytes, const std::string& name, const ReadOptions& options);
Mesh read_stl(std::string bytes, const std::string& name, const ReadOptions& options);

/// glTF 2.0 (format Gltf or Glb; io_gltf.cpp), Draco (io_draco.cpp) and 3MF (io_3mf.cpp). Their
/// writers use the mesh's image when it applies (FileImage::extra holds what they need) and
/// write from scratch otherwise.
Mesh read_gltf(std::string bytes, FileFormat format, const std::string& name,
               const ReadOptions& options);
/// resources: where a .gltf's external buffers go, named after resource_stem (the output's
/// file name without extension); null: they are embedded as data URIs.
std::string write_gltf(const Mesh& mesh, FileFormat format, const WriteOptions& options,
                       const std::string& resource_stem,
                       std::map<std::string, std::string>* resources);
Mesh read_draco(std::string bytes, const std::string& name, const ReadOptions& options);
std::string write_draco(const Mesh& mesh, const WriteOptions& options);
Mesh read_3mf(std::string bytes, const std::string& name, const ReadOptions& options);
std::string write_3mf(const Mesh& mesh, const WriteOptions& options);

/// Writers from scratch (no file image): positions and polygons only.
std::string write_off(const Mesh& mesh);
std::string write_obj(const Mesh& mesh);
std::string write_ply(const Mesh& mesh, Encoding encoding, bool single_precision,
                      const Eigen::Matrix<std::uint8_t, Eigen::Dynamic, 3>* colors = nullptr);
std::string write_stl(const Mesh& mesh, Encoding encoding);

/// Appends "x y z" of vertex i (shortest round-trip text, single spaces, no newline).
void append_position(std::string& out, const Eigen::MatrixX3d& V, Eigen::Index i);

/// Throws InvalidInputError(name, line, message).
[[noreturn]] void fail(const std::string& name, std::size_t line, const std::string& message);

/// What a reader found, before it becomes a Mesh.
struct Parsed {
  std::vector<double> xyz;  ///< 3 per vertex
  Polygons faces;
  std::vector<CoordSlot> slots;
};

/// Welds the referenced vertices closer than tolerance (bit-identical ones, -0.0 and +0.0
/// alike, when it is 0) into one vertex, at the position of its first member; unreferenced
/// vertices stay apart. Vertices are renumbered in order of first appearance and the faces and
/// slots follow; a slot keeps its stored value, so a write patches it by the displacement of
/// its vertex (see patch_image). Defined in io_stl.cpp, STL's reader being its first user.
void weld_vertices(Parsed& parsed, double tolerance);

/// Builds the Mesh: V from xyz (welded first: for STL, glTF, Draco and 3MF always, whose files
/// split vertices at every seam; for OFF, OBJ and PLY when options.weld_tolerance > 0), F by
/// triangulation, the image when asked (with the format's own record `extra`). Throws
/// InvalidInputError when there are no faces or no triangles.
Mesh assemble(Parsed parsed, std::string bytes, FileFormat format, Encoding encoding,
              const std::string& name, const ReadOptions& options,
              std::shared_ptr<const FormatImage> extra = nullptr);

}  // namespace meshmark::detail
