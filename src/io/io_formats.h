#pragma once
// Internal: the per-format readers and writers behind io.h's dispatcher, and what they share.

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "io/file_image.h"
#include "meshmark/io/io.h"

namespace meshmark::detail {

/// The readers of OFF, OBJ, PLY and STL parse bytes where they are. image_bytes: the string
/// bytes refers to, moved into the mesh's image once parsed when options.keep_image (it must
/// then not be null); null when no image is kept, and bytes are left as they were.
Mesh read_off(const std::string& bytes, std::string* image_bytes, const std::string& name,
              const ReadOptions& options);
Mesh read_obj(const std::string& bytes, std::string* image_bytes, const std::string& name,
              const ReadOptions& options);
Mesh read_ply(const std::string& bytes, std::string* image_bytes, const std::string& name,
              const ReadOptions& options);
Mesh read_stl(const std::string& bytes, std::string* image_bytes, const std::string& name,
              const ReadOptions& options);

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

/// Draco mesh (.drc): positions (dequantized, as double) and triangles; points at bit-identical
/// positions (Draco splits vertices at attribute seams) welded into one vertex, and closer ones
/// with options.weld_tolerance. \throw InvalidInputError(name, 0, ...) for what decode_draco
/// refuses (not Draco, a point cloud, corrupt or truncated data, no POSITION, a non-finite
/// coordinate) and for no faces.
Mesh read_draco(const std::string& bytes, const std::string& name, const ReadOptions& options);
/// Draco written back (the image applies): every point moved by its vertex's displacement and
/// encoded again with the source's quantization bits per attribute, method, edgebreaker
/// submethod, attribute unique ids, metadata and every other attribute (encode_draco; the
/// speed the bitstream does not record is draco_encoder's default). From scratch: positions
/// and triangles only, edgebreaker, positions quantized to 14 bits (a grid step of 1/16383 of
/// the bounding box's largest side), speed 3. Draco reorders points either way, and
/// quantization moves every vertex by up to half a step: embed re-reads what it would write
/// and refuses a file that does not carry the mark.
/// \throw InvalidArgumentError for a coordinate that is not a finite float32.
std::string write_draco(const Mesh& mesh, const WriteOptions& options);
/// 3MF package: every mesh object of the build, once per placement (build items and
/// components objects, nested up to 32 deep), in world space through the composed transforms
/// (a mirroring transform reverses the triangles' order to keep them outward); bit-identical
/// positions welded into one vertex (also across objects), closer ones with
/// options.weld_tolerance. Units are not converted. Objects outside the build, beam lattices
/// and slices are not read. \throw InvalidInputError(name, 0, ...) with lib3mf's message for a
/// package lib3mf refuses (not a zip, no model part, malformed XML, an index out of range),
/// and for a non-finite coordinate or no mesh object in the build.
Mesh read_3mf(std::string bytes, const std::string& name, const ReadOptions& options);
/// 3MF written back (the image applies): lib3mf reads the source package again, each mesh
/// object's vertices move by the mean over its placements of its points' displacements taken
/// back to object space (a singular placement that moved refuses), and lib3mf writes the
/// package. lib3mf 1.8 keeps what it reads: metadata, base materials, colors, build items and
/// their transforms, components, UUIDs (these checked by the tests), texture coordinates,
/// textures and thumbnails; it drops attachments of relationship types it was not told of (a
/// slicer's settings, custom parts) and XML of namespaces it does not know, rewrites the XML
/// in its own layout and writes every coordinate with 6 digits after the decimal point,
/// truncated (unmoved vertices too: a package lib3mf did not write changes its coordinates'
/// text). From scratch: one mesh object, one build item, unit millimeter.
/// \throw InvalidArgumentError for a coordinate that is not a finite float32 (3MF's vertex
/// type in lib3mf); Error when lib3mf fails to write.
std::string write_3mf(const Mesh& mesh, const WriteOptions& options);
/// The 3mf component's entry points (io_3mf.cpp), which read_3mf and write_3mf call; without
/// the component they throw MissingComponentError.
struct ThreeMfCodec {
  Mesh (*read)(std::string bytes, const std::string& name, const ReadOptions& options);
  std::string (*write)(const Mesh& mesh, const WriteOptions& options);
};
/// The core's slot for them (core/component.h).
const ThreeMfCodec*& three_mf_codec_slot();

/// The files a glTF mesh's source read besides itself (its external buffers); empty for
/// other meshes.
std::vector<std::string> gltf_source_files(const Mesh& mesh);

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
  /// Whether the OFF, OBJ and PLY readers record slots: not when no image is kept
  /// (ReadOptions::keep_image false), which saves 16 bytes a coordinate while reading.
  bool keep_slots = true;
  /// Whether the binary PLY reader may record its vertices' layout instead of slots (its
  /// records have no list and each axis once; no welding to come), and the layout it recorded.
  bool regular_allowed = false;
  std::optional<RegularLayout> regular;
  /// Sections the mesh may encode again byte for byte (binary PLY's plain vertex and face
  /// records), offsets into the file; assemble leaves out of the image those that do.
  std::vector<ElidedSection> elidable;
};

/// Triangles from their corners' vertex indices, three by three (a count that is not a multiple
/// of 3 leaves the last one or two out).
Polygons triangles_of_corners(std::vector<int> corners);

/// Welds the referenced vertices closer than tolerance (bit-identical ones, -0.0 and +0.0
/// alike, when it is 0) into one vertex, at the position of its first member; unreferenced
/// vertices stay apart. Vertices are renumbered in order of first appearance and the faces and
/// slots follow; a slot keeps its stored value, so a write patches it by the displacement of
/// its vertex (see patch_image). Defined in io_stl.cpp, STL's reader being its first user.
void weld_vertices(Parsed& parsed, double tolerance);

/// Builds the Mesh: V from xyz (welded first: for STL, glTF, Draco and 3MF always, whose files
/// split vertices at every seam; for OFF, OBJ and PLY when options.weld_tolerance > 0), F by
/// triangulation, the image when asked (with the format's own record `extra`, and the file's
/// bytes moved from image_bytes when not null). Throws InvalidInputError when there are no
/// faces or no triangles.
Mesh assemble(Parsed parsed, std::string* image_bytes, FileFormat format, Encoding encoding,
              const std::string& name, const ReadOptions& options,
              std::shared_ptr<const FormatImage> extra = nullptr);

/// For formats whose writers keep their own record instead of byte slots (Draco, 3MF, glTF):
/// welds parsed's vertices (bit-identical ones always, -0.0 and +0.0 alike; closer than
/// options.weld_tolerance when it is > 0) and builds the Mesh as assemble does, without an
/// image (parsed.slots are ignored). vertex_of_point receives the mesh vertex of every vertex
/// of parsed, in order. Encoding: BinaryLittleEndian.
Mesh assemble_welded(Parsed parsed, FileFormat format, const std::string& name,
                     const ReadOptions& options, std::vector<int>& vertex_of_point);

/// Gives mesh an image of its format with extra (and no bytes or slots), when
/// options.keep_image: image_applies() then tells a writer whether extra still fits.
void attach_image(Mesh& mesh, std::shared_ptr<const FormatImage> extra, const ReadOptions& options);

/// How far each point's vertex has moved since the read: 3 per point, mesh.V(v) - image.V(v)
/// for v = vertex_of_point[p]. Precondition: image_applies for the mesh's image.
std::vector<double> point_displacements(const Mesh& mesh, const std::vector<int>& vertex_of_point);

}  // namespace meshmark::detail
