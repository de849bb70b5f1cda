#pragma once
// Internal: what the glTF reader (io_gltf.cpp) records for its writer (io_gltf_write.cpp).

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "io/draco_codec.h"
#include "io/file_image.h"

namespace meshmark::detail {

/// glTF component types (the numbers the format uses).
enum GltfComponent : int {
  kGltfByte = 5120,
  kGltfUnsignedByte = 5121,
  kGltfShort = 5122,
  kGltfUnsignedShort = 5123,
  kGltfUnsignedInt = 5125,
  kGltfFloat = 5126
};

/// One buffer as the file stores it.
struct GltfBuffer {
  enum class Kind { GlbBin, DataUri, External, Fallback } kind = Kind::GlbBin;
  std::string own;        ///< the decoded or loaded bytes (DataUri, External)
  std::string_view data;  ///< its bytes: own, or in GltfImage::file (GlbBin); Fallback: empty
  std::string uri;        ///< as written in the JSON (External, DataUri)
  std::string path;       ///< External: the file it was read from
};

/// EXT_meshopt_compression on a buffer view: where the compressed bytes are and how to decode.
struct GltfMeshopt {
  int buffer = -1;
  std::size_t offset = 0, length = 0, stride = 0, count = 0;
  std::string mode;    ///< ATTRIBUTES, TRIANGLES or INDICES
  std::string filter;  ///< NONE, OCTAHEDRAL, QUATERNION or EXPONENTIAL
};

/// One buffer view, with its bytes (a copy when they were decoded from meshopt data).
struct GltfView {
  int buffer = -1;
  std::size_t offset = 0, length = 0, stride = 0;
  bool compressed = false;  ///< EXT_meshopt_compression
  GltfMeshopt meshopt;
  std::string decoded;  ///< the decoded bytes when compressed
};

/// One POSITION accessor as one node draws it: its file vertices are
/// [first, first + count) in the reader's numbering, at world = transform * dequantized.
struct GltfInstance {
  int node = -1, mesh = -1, accessor = -1, view = -1;
  std::size_t offset = 0;  ///< byte offset of element 0 in the view's bytes
  std::size_t stride = 0;  ///< bytes from one element to the next
  std::size_t count = 0;
  int component = kGltfFloat;
  bool normalized = false;
  Eigen::Matrix4d world = Eigen::Matrix4d::Identity();
  std::size_t first = 0;
  int draco = -1;  ///< KHR_draco_mesh_compression: index in GltfImage::dracos (view unused)
};

/// A KHR_draco_mesh_compression primitive's data: its buffer view, decoded, and the accessors
/// that describe it (their counts follow the decoded points and triangles).
struct GltfDraco {
  int view = -1;
  int position_accessor = -1, indices_accessor = -1;
  std::vector<int> attribute_accessors;
  DracoMesh mesh;
};

/// What a glTF writer needs besides FileImage's V and slots (one slot per file vertex: its
/// offset the file vertex, its vertex the mesh row it was welded into).
struct GltfImage : FormatImage {
  bool binary = false;                ///< GLB
  std::string file;                   ///< the whole source file (FileImage::bytes stays empty)
  std::string json;                   ///< the JSON text
  std::size_t bin_chunk_padding = 0;  ///< GLB: bytes of the BIN chunk past buffer 0's length
  std::vector<GltfBuffer> buffers;
  std::vector<GltfView> views;
  std::vector<GltfInstance> instances;
  std::vector<GltfDraco> dracos;
  std::vector<std::size_t> accessor_counts;  ///< elements of every accessor (for min/max)
  /// World positions of the file vertices as read, 3 each, kept only when a weld tolerance
  /// merged distinct positions (otherwise a file vertex sits exactly at its row's position).
  std::vector<double> world_as_read;
};

/// The value of one stored component as glTF defines it (normalized integers mapped to
/// [0, 1] or [-1, 1]).
double gltf_component_value(const char* data, int component, bool normalized);

/// Stores value (in the same sense) at data, integers rounded to nearest and clamped to the
/// type's range (a vertex at the edge of a quantization grid cannot move outside it; the
/// caller's read-back decides whether the mark survived); false when the value is not finite
/// or overflows float32 (nothing is stored then).
bool gltf_store_component(char* data, int component, bool normalized, double value);

/// Size in bytes of a component type (0 for an unknown one).
std::size_t gltf_component_size(int component);

/// Base64 (RFC 4648, with padding).
std::string base64_encode(std::string_view bytes);

}  // namespace meshmark::detail
