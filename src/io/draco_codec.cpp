// Draco decoding and re-encoding (see draco_codec.h). Draco does not say how a file was
// encoded; what it can be made to say is recovered here: the quantization bits of every
// attribute from a second decode that skips the attribute transforms (each attribute then
// carries its transform's parameters), the encoding method from the header, and the
// edgebreaker submethod from the byte that starts the connectivity data.

#include "io/draco_codec.h"

#include <cmath>
#include <cstring>
#include <limits>

#include <draco/attributes/attribute_octahedron_transform.h>
#include <draco/attributes/attribute_quantization_transform.h>
#include <draco/compression/decode.h>
#include <draco/compression/expert_encode.h>
#include <draco/metadata/metadata_decoder.h>
#include <fmt/format.h>

#include "core/component.h"
#include "meshmark/core/error.h"

namespace meshmark::detail {

namespace {

constexpr std::size_t kHeaderSize = 11;  // "DRACO", version 2 bytes, type, method, flags 2 bytes

[[noreturn]] void fail_draco(const std::string& name, const std::string& message) {
  throw InvalidInputError(name, 0, message);
}

// The edgebreaker submethod: the first byte after the header and the metadata; -1 when it
// cannot be read (old bitstreams, unreadable metadata).
int edgebreaker_submethod(std::string_view bytes, int major, int minor, std::uint16_t flags) {
  if (major < 2) return -1;
  draco::DecoderBuffer buffer;
  buffer.Init(bytes.data() + kHeaderSize, bytes.size() - kHeaderSize,
              DRACO_BITSTREAM_VERSION(major, minor));
  if (flags & METADATA_FLAG_MASK) {
    draco::MetadataDecoder metadata_decoder;
    draco::GeometryMetadata metadata;
    if (!metadata_decoder.DecodeGeometryMetadata(&buffer, &metadata)) return -1;
  }
  std::uint8_t type = 0;
  if (!buffer.Decode(&type)) return -1;
  return type == draco::MESH_EDGEBREAKER_STANDARD_ENCODING ||
                 type == draco::MESH_EDGEBREAKER_VALENCE_ENCODING
             ? type
             : -1;
}

std::unique_ptr<draco::Mesh> decode_mesh(std::string_view bytes, const std::string& name,
                                         bool skip_transforms) {
  draco::DecoderBuffer buffer;
  buffer.Init(bytes.data(), bytes.size());
  draco::Decoder decoder;
  if (skip_transforms)
    for (const auto type : {draco::GeometryAttribute::POSITION, draco::GeometryAttribute::NORMAL,
                            draco::GeometryAttribute::COLOR, draco::GeometryAttribute::TEX_COORD,
                            draco::GeometryAttribute::GENERIC})
      decoder.SetSkipAttributeTransform(type);
  auto decoded = decoder.DecodeMeshFromBuffer(&buffer);
  if (!decoded.ok())
    fail_draco(name, fmt::format("the Draco decoder refuses the data: {}",
                                 decoded.status().error_msg_string()));
  return std::move(decoded).value();
}

// The quantization bits of every attribute of a mesh decoded without its transforms.
std::vector<int> quantization_bits(const draco::Mesh& raw) {
  std::vector<int> bits(static_cast<std::size_t>(raw.num_attributes()), 0);
  for (int i = 0; i < raw.num_attributes(); ++i) {
    const draco::PointAttribute& att = *raw.attribute(i);
    const draco::AttributeTransformData* data = att.GetAttributeTransformData();
    if (!data) continue;
    if (data->transform_type() == draco::ATTRIBUTE_QUANTIZATION_TRANSFORM) {
      draco::AttributeQuantizationTransform q;
      if (q.InitFromAttribute(att)) bits[i] = q.quantization_bits();
    } else if (data->transform_type() == draco::ATTRIBUTE_OCTAHEDRON_TRANSFORM) {
      draco::AttributeOctahedronTransform o;
      if (o.InitFromAttribute(att)) bits[i] = o.quantization_bits();
    }
  }
  return bits;
}

// Positions (3 per point) and triangles of a decoded mesh, checked.
void extract_geometry(const draco::Mesh& mesh, const std::string& name, DracoMesh& out) {
  const int pos_id = mesh.GetNamedAttributeId(draco::GeometryAttribute::POSITION);
  if (pos_id < 0) fail_draco(name, "the Draco mesh has no POSITION attribute");
  const draco::PointAttribute& pos = *mesh.attribute(pos_id);
  if (pos.num_components() != 3)
    fail_draco(name, fmt::format("the POSITION attribute has {} components, not 3",
                                 static_cast<int>(pos.num_components())));
  out.attribute_id_of_position = static_cast<int>(pos.unique_id());
  const std::uint32_t np = mesh.num_points();
  out.positions.resize(3ull * np);
  for (std::uint32_t p = 0; p < np; ++p) {
    double* xyz = &out.positions[3ull * p];
    if (!pos.ConvertValue<double>(pos.mapped_index(draco::PointIndex(p)), 3, xyz))
      fail_draco(name, fmt::format("point {}: the position cannot be read", p));
    for (int a = 0; a < 3; ++a)
      if (!std::isfinite(xyz[a]))
        fail_draco(name, fmt::format("point {}: coordinate {} is not finite", p, "xyz"[a]));
  }
  out.triangles.resize(3ull * mesh.num_faces());
  for (std::uint32_t f = 0; f < mesh.num_faces(); ++f) {
    const draco::Mesh::Face& face = mesh.face(draco::FaceIndex(f));
    for (int c = 0; c < 3; ++c) {
      const std::uint32_t p = face[c].value();
      if (p >= np)
        fail_draco(name, fmt::format("face {}: point index {} is out of range [0, {})", f, p, np));
      out.triangles[3ull * f + c] = p;
    }
  }
}

void check_float32(const std::vector<double>& positions) {
  constexpr double kMax = std::numeric_limits<float>::max();
  for (std::size_t k = 0; k < positions.size(); ++k)
    if (!(std::abs(positions[k]) <= kMax))
      throw InvalidArgumentError(
          fmt::format("point {}: coordinate {} = {} is not a finite float32, which Draco stores",
                      k / 3, "xyz"[k % 3], positions[k]));
}

std::string encode(draco::ExpertEncoder& encoder) {
  encoder.SetSpeedOptions(kDracoSpeed, kDracoSpeed);
  draco::EncoderBuffer out;
  const draco::Status status = encoder.EncodeToBuffer(&out);
  if (!status.ok())
    throw Error(fmt::format("the Draco encoder failed: {}", status.error_msg_string()));
  return std::string(out.data(), out.size());
}

DracoMesh decode(std::string_view bytes, const std::string& name) {
  // The header: "DRACO", version, geometry type (1: triangular mesh), method, flags.
  if (bytes.size() < kHeaderSize || bytes.substr(0, 5) != "DRACO")
    fail_draco(name, "not a Draco file (it does not start with 'DRACO' and an 11-byte header)");
  DracoMesh out;
  out.version_major = static_cast<std::uint8_t>(bytes[5]);
  out.version_minor = static_cast<std::uint8_t>(bytes[6]);
  if (bytes[7] != draco::TRIANGULAR_MESH)
    fail_draco(name, bytes[7] == draco::POINT_CLOUD
                         ? "a Draco point cloud, not a mesh"
                         : fmt::format("unknown Draco geometry type {}",
                                       static_cast<int>(static_cast<std::uint8_t>(bytes[7]))));
  out.encoding_method = static_cast<std::uint8_t>(bytes[8]);
  std::uint16_t flags = 0;
  std::memcpy(&flags, bytes.data() + 9, 2);  // little endian on every platform we build for
  // Decode twice: with the transforms (the values) and without (their parameters).
  std::unique_ptr<draco::Mesh> mesh = decode_mesh(bytes, name, false);
  out.attribute_bits = quantization_bits(*decode_mesh(bytes, name, true));
  if (out.attribute_bits.size() != static_cast<std::size_t>(mesh->num_attributes()))
    fail_draco(name, "the two Draco decodes disagree on the attributes");
  extract_geometry(*mesh, name, out);
  out.position_bits =
      out.attribute_bits[mesh->GetNamedAttributeId(draco::GeometryAttribute::POSITION)];
  if (out.encoding_method == draco::MESH_EDGEBREAKER_ENCODING)
    out.edgebreaker_submethod =
        edgebreaker_submethod(bytes, out.version_major, out.version_minor, flags);
  out.mesh = std::move(mesh);
  return out;
}

std::string encode(const DracoMesh& mesh, const std::vector<double>& new_positions) {
  if (!mesh.mesh || new_positions.size() != 3ull * mesh.mesh->num_points())
    throw InvalidArgumentError(fmt::format("{} new coordinates for a Draco mesh of {} points",
                                           new_positions.size(),
                                           mesh.mesh ? mesh.mesh->num_points() : 0));
  check_float32(new_positions);
  draco::Mesh copy;
  copy.Copy(*mesh.mesh);
  draco::PointAttribute& pos =
      *copy.attribute(copy.GetNamedAttributeId(draco::GeometryAttribute::POSITION));
  for (std::uint32_t p = 0; p < copy.num_points(); ++p) {
    const draco::Status status = pos.ConvertAndSetAttributeValue(
        pos.mapped_index(draco::PointIndex(p)), 3, &new_positions[3ull * p]);
    if (!status.ok())
      throw Error(fmt::format("point {}: Draco cannot store the position: {}", p,
                              status.error_msg_string()));
  }
  draco::ExpertEncoder encoder(copy);
  encoder.SetEncodingMethod(mesh.encoding_method);
  // The option MeshEdgeBreakerEncoder reads (SetEncodingSubmethod sets another one).
  if (mesh.encoding_method == draco::MESH_EDGEBREAKER_ENCODING && mesh.edgebreaker_submethod >= 0)
    encoder.options().SetGlobalInt("edgebreaker_method", mesh.edgebreaker_submethod);
  for (std::size_t i = 0; i < mesh.attribute_bits.size(); ++i)
    if (mesh.attribute_bits[i] > 0)
      encoder.SetAttributeQuantization(static_cast<int>(i), mesh.attribute_bits[i]);
  return encode(encoder);
}

std::string encode_new(const std::vector<double>& positions,
                       const std::vector<std::uint32_t>& triangles, int position_bits) {
  if (positions.size() % 3 != 0 || triangles.size() % 3 != 0 || position_bits < 0 ||
      position_bits > 30)
    throw InvalidArgumentError(fmt::format(
        "a Draco mesh needs 3 coordinates per point, 3 indices per face and 0-30 position "
        "bits ({} coordinates, {} indices, {} bits)",
        positions.size(), triangles.size(), position_bits));
  check_float32(positions);
  const auto np = static_cast<std::uint32_t>(positions.size() / 3);
  for (std::size_t k = 0; k < triangles.size(); ++k)
    if (triangles[k] >= np)
      throw InvalidArgumentError(
          fmt::format("face {}: index {} out of range [0, {})", k / 3, triangles[k], np));
  draco::Mesh mesh;
  mesh.set_num_points(np);
  draco::GeometryAttribute ga;
  ga.Init(draco::GeometryAttribute::POSITION, nullptr, 3, draco::DT_FLOAT32, false,
          sizeof(float) * 3, 0);
  const int id = mesh.AddAttribute(ga, true, np);
  for (std::uint32_t p = 0; p < np; ++p) {
    const float xyz[3] = {static_cast<float>(positions[3ull * p]),
                          static_cast<float>(positions[3ull * p + 1]),
                          static_cast<float>(positions[3ull * p + 2])};
    mesh.attribute(id)->SetAttributeValue(draco::AttributeValueIndex(p), xyz);
  }
  for (std::size_t f = 0; f < triangles.size() / 3; ++f)
    mesh.AddFace({draco::PointIndex(triangles[3 * f]), draco::PointIndex(triangles[3 * f + 1]),
                  draco::PointIndex(triangles[3 * f + 2])});
  draco::ExpertEncoder encoder(mesh);
  encoder.SetEncodingMethod(draco::MESH_EDGEBREAKER_ENCODING);
  if (position_bits > 0) encoder.SetAttributeQuantization(id, position_bits);
  return encode(encoder);
}

}  // namespace

// The draco component: the core's Draco entry points (io_draco.cpp) call these.
const DracoCodec kDracoCodec{&decode, &encode, &encode_new};
MESHMARK_COMPONENT(draco, draco_codec_slot(), kDracoCodec)

}  // namespace meshmark::detail
