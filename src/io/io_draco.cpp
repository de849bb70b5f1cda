// Draco (.drc) meshes. A Draco file stores one point per distinct combination of corner
// attributes (a position on a texture seam is several points): the reader welds bit-identical
// positions (and closer ones with ReadOptions::weld_tolerance) into one vertex, as for STL.
// Writing back re-encodes the decoded mesh with each point moved by its vertex's displacement
// and every other attribute, quantization, method and unique id kept (draco_codec.h); writing
// from scratch stores positions and triangles, edgebreaker, positions quantized to 14 bits.

#include <fmt/format.h>

#include "io/draco_codec.h"
#include "io/io_formats.h"
#include "meshmark/core/error.h"

namespace meshmark::detail {

namespace {

/// What a write back needs: the decoded mesh and the vertex of every point.
struct DracoImage : FormatImage {
  DracoMesh decoded;
  std::vector<int> vertex_of_point;
};

/// Quantization bits of positions written from scratch: a step of 2^-14 of the bounding box's
/// largest side (about 6e-5 of it), fine enough to carry a mark (see write_draco's doc).
constexpr int kScratchPositionBits = 14;

}  // namespace

Mesh read_draco(const std::string& bytes, const std::string& name, const ReadOptions& options) {
  auto image = std::make_shared<DracoImage>();
  image->decoded = decode_draco(bytes, name);
  const DracoMesh& d = image->decoded;
  Parsed parsed;
  parsed.xyz = d.positions;
  parsed.faces = triangles_of_corners(std::vector<int>(d.triangles.begin(), d.triangles.end()));
  Mesh mesh =
      assemble_welded(std::move(parsed), FileFormat::Draco, name, options, image->vertex_of_point);
  attach_image(mesh, std::move(image), options);
  return mesh;
}

std::string write_draco(const Mesh& mesh, const WriteOptions& options) {
  const auto* image =
      mesh.image ? dynamic_cast<const DracoImage*>(mesh.image->extra.get()) : nullptr;
  if (options.keep_source && image &&
      image_applies(mesh, FileFormat::Draco, Encoding::BinaryLittleEndian)) {
    std::vector<double> positions = point_displacements(mesh, image->vertex_of_point);
    for (std::size_t k = 0; k < positions.size(); ++k) positions[k] += image->decoded.positions[k];
    return encode_draco(image->decoded, positions);
  }
  std::vector<double> positions(3 * static_cast<std::size_t>(mesh.V.rows()));
  for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    for (int a = 0; a < 3; ++a) positions[3 * i + a] = mesh.V(i, a);
  std::vector<std::uint32_t> triangles(3 * static_cast<std::size_t>(mesh.F.rows()));
  for (Eigen::Index t = 0; t < mesh.F.rows(); ++t)
    for (int c = 0; c < 3; ++c) triangles[3 * t + c] = static_cast<std::uint32_t>(mesh.F(t, c));
  return encode_new_draco(positions, triangles, kScratchPositionBits);
}

}  // namespace meshmark::detail
