#pragma once
// Internal: the image of a source file that lets a write change positions and nothing else.

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "meshmark/core/mesh.h"

namespace meshmark {

/// How one coordinate is stored in the file.
enum class SlotType : std::uint8_t {
  Text,
  Int8,
  UInt8,
  Int16,
  UInt16,
  Int32,
  UInt32,
  Float32,
  Float64
};

/// One stored coordinate: where it is, how it is stored, and which vertex and axis it holds.
/// 16 bytes; the value stored is read again from the bytes when needed (slot_value).
struct CoordSlot {
  std::uint64_t offset : 48 = 0;  ///< byte offset in the source file (below 2^48)
  std::uint64_t length : 16 = 0;  ///< byte length (text token length, or the binary type's size)
  std::int32_t vertex = 0;        ///< the vertex (row of V) it belongs to
  std::uint8_t axis = 0;          ///< 0, 1, 2 for x, y, z
  SlotType type = SlotType::Text;
  bool big_endian = false;
};
/// The longest text coordinate a slot holds (characters); the readers refuse longer ones.
inline constexpr std::size_t kMaxCoordinateText = 65535;
static_assert(sizeof(CoordSlot) == 16, "a stored coordinate costs 16 bytes");

/// Where a binary file stores every vertex's coordinates at a fixed stride, in place of a slot per
/// coordinate (binary PLY whose vertex records have no list, read without welding): coordinate
/// a of vertex i at first + i * stride + offset[a], of type[a].
struct RegularLayout {
  std::uint64_t first = 0;                ///< byte offset of vertex 0's record in the source file
  std::uint64_t stride = 0;               ///< bytes a record
  std::array<std::uint32_t, 3> offset{};  ///< of x, y, z within a record
  std::array<SlotType, 3> type{};
  bool big_endian = false;
  std::int64_t vertices = 0;  ///< records
};

/// A section of a binary source file that the mesh encodes again byte for byte, and that
/// FileImage::bytes therefore leaves out (checked when the file is read): binary PLY vertex
/// records of x, y and z alone (encoded from V in the RegularLayout), and face records of one
/// index list alone (encoded from the faces a write gives back, FaceView). A write puts it back.
struct ElidedSection {
  enum class Kind : std::uint8_t { Positions, Faces };
  Kind kind = Kind::Faces;
  std::uint64_t at = 0;                   ///< where it goes back in FileImage::bytes (byte offset)
  std::uint64_t length = 0;               ///< its length in the source file (bytes)
  std::int64_t records = 0;               ///< vertices or faces it holds
  SlotType count_type = SlotType::UInt8;  ///< Faces: a record's corner count
  SlotType index_type = SlotType::Int32;  ///< Faces: each corner's vertex index
  bool big_endian = false;
};

/// What a format's writer keeps beside the bytes (glTF, Draco, 3MF define their own).
struct FormatImage {
  virtual ~FormatImage() = default;
};

struct FileImage {
  FileFormat format = FileFormat::Obj;
  Encoding encoding = Encoding::Ascii;
  std::string bytes;  ///< the source file, without its elided sections
  /// Sections left out of bytes (in increasing offset order), encoded again from the mesh
  /// when a copy is written: a binary PLY of plain vertex and face records keeps its header
  /// alone (about 50 bytes a vertex not held).
  std::vector<ElidedSection> elided;
  std::vector<CoordSlot> slots;  ///< in increasing offset order
  /// Instead of slots, where every vertex's coordinates sit at a fixed stride (none, 0 bytes
  /// a coordinate, where slots would take 16).
  std::optional<RegularLayout> regular;
  Eigen::Index vertices = 0;  ///< the mesh's vertices as read (rows of V)
  /// Positions as read, where a stored coordinate may differ from its vertex's (welded files,
  /// and the formats whose writers move file vertices: glTF, 3MF, Draco). Empty for OFF, OBJ
  /// and PLY read without welding: each slot then holds its vertex's value as read, and
  /// slot_value gives it back (24 bytes a vertex not held).
  Eigen::MatrixX3d V;
  std::size_t face_count = 0;  ///< faces as read, to detect changed connectivity
  std::size_t face_index_count = 0;
  std::uint64_t face_hash = 0;               ///< of the faces as read (detail::face_hash)
  std::shared_ptr<const FormatImage> extra;  ///< the format's own record, if any
};

namespace detail {

/// Size in bytes of a binary slot type.
int slot_type_size(SlotType type);

/// Reads a binary scalar of the given type at data (endianness as given) as a double.
double read_scalar(const char* data, SlotType type, bool big_endian);

/// The value a slot holds in bytes: its binary scalar, or its text token parsed as the readers
/// parse it (parse_double). \throw InvalidArgumentError when the slot lies outside bytes or its
/// token is not a number (the bytes are not those the slot was read from).
double slot_value(const std::string& bytes, const CoordSlot& slot);

/// Writes value, converted to type (integers rounded and clamped), at data.
void write_scalar(char* data, SlotType type, bool big_endian, double value);

/// A 64-bit hash of the faces (each face's corner count and corners, in order): faces changed
/// with their counts kept (a triangle turned over) do not write through the image.
std::uint64_t face_hash(const FaceView& faces);

/// Records the mesh's vertex and face counts and face_hash in image, as read.
void record_connectivity(FileImage& image, const Mesh& mesh);

/// True when the mesh still has the vertex count and the faces its image was read with.
bool same_connectivity(const FileImage& image, const Mesh& mesh);

/// True when a mesh can be written through its image: same format and encoding, same vertex
/// count and faces (same_connectivity).
bool image_applies(const Mesh& mesh, FileFormat format, Encoding encoding);

/// The source file's bytes with every coordinate whose vertex moved replaced by its position in
/// mesh.V; other bytes as read (elided sections encoded again from the mesh). A slot whose
/// stored value differs from the vertex's value as read (a tolerance-welded STL corner) is
/// written as stored value + displacement.
std::string patch_image(const FileImage& image, const Mesh& mesh);

/// Leaves each candidate section out of image.bytes when the mesh, as read, encodes it again
/// byte for byte (candidates in increasing offset order, FileImage::bytes still the whole
/// file, each `at` an offset into it; afterwards each kept section's `at` is where it goes
/// back in the shortened bytes). The bytes left are reallocated, so the memory is returned.
/// A candidate that does not encode exactly stays in bytes.
void elide_sections(FileImage& image, const Mesh& mesh,
                    const std::vector<ElidedSection>& candidates);

}  // namespace detail
}  // namespace meshmark
