#pragma once
// Internal: Draco mesh decoding, and re-encoding with new positions and every other attribute
// and setting kept. Used by the .drc reader and writer (io_draco.cpp) and by glTF's
// KHR_draco_mesh_compression (io_gltf.cpp). Draco's headers stay in draco_codec.cpp, the draco
// component; the core holds only the dispatch (io_draco.cpp).

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace draco {
class Mesh;
}

namespace meshmark::detail {

/// Draco's speed setting (0 best compression .. 10 fastest) used by every encode: the bitstream
/// does not record the one a file was made with; 3 is draco_encoder's default (-cl 7).
inline constexpr int kDracoSpeed = 3;

/// A decoded Draco mesh kept whole so it can be encoded back with new positions.
struct DracoMesh {
  std::vector<double> positions;         ///< 3 per point, as decoded (dequantized)
  std::vector<std::uint32_t> triangles;  ///< 3 per face, point indices
  int position_bits = 0;  ///< the POSITION quantization bits in the file (0: not quantized)
  int attribute_id_of_position = -1;  ///< unique id of the POSITION attribute
  /// Per attribute (draco's attribute index): the quantization bits in the file, 0 for none
  /// (octahedral normals give their bits too).
  std::vector<int> attribute_bits;
  int encoding_method = 1;         ///< draco's MESH_SEQUENTIAL_ENCODING 0, MESH_EDGEBREAKER 1
  int edgebreaker_submethod = -1;  ///< MESH_EDGEBREAKER_STANDARD 0, _VALENCE 2; -1 unknown
  int version_major = 0, version_minor = 0;  ///< the bitstream version in the header
  std::shared_ptr<const draco::Mesh> mesh;   ///< every attribute and the metadata, as decoded
};

/// Decodes Draco bytes (a mesh, not a point cloud). name is for messages.
/// \throw InvalidInputError(name, 0, ...) naming the problem: not Draco, a point cloud, a
///        decoder error (truncated, corrupt), no POSITION attribute or not 3 components,
///        a non-finite position, a face index out of range.
DracoMesh decode_draco(std::string_view bytes, const std::string& name);

/// Encodes `mesh` again with positions replaced by new_positions (3 per point, same point order
/// as decoded): every other attribute, the quantization bits of every attribute, the encoding
/// method and edgebreaker submethod, the attribute unique ids and the metadata kept; speed
/// kDracoSpeed. Draco reorders points and may drop degenerate faces: decode the result again.
/// \throw InvalidArgumentError when new_positions has the wrong size or a value that is not a
///        finite float32; Error when Draco fails to encode.
std::string encode_draco(const DracoMesh& mesh, const std::vector<double>& new_positions);

/// Encodes a mesh from scratch: positions (3 per point, finite float32 values) and triangles
/// (3 per face) only, edgebreaker, positions quantized to position_bits (1-30; 0 stores
/// float32 positions unquantized), speed kDracoSpeed.
/// \throw InvalidArgumentError on a bad argument; Error when Draco fails to encode.
std::string encode_new_draco(const std::vector<double>& positions,
                             const std::vector<std::uint32_t>& triangles, int position_bits);

/// The draco component's entry points (draco_codec.cpp), which the three functions above call;
/// without the component they throw MissingComponentError.
struct DracoCodec {
  DracoMesh (*decode)(std::string_view bytes, const std::string& name);
  std::string (*encode)(const DracoMesh& mesh, const std::vector<double>& new_positions);
  std::string (*encode_new)(const std::vector<double>& positions,
                            const std::vector<std::uint32_t>& triangles, int position_bits);
};
/// The core's slot for them (core/component.h).
const DracoCodec*& draco_codec_slot();

}  // namespace meshmark::detail
