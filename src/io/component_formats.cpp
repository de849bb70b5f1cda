// The core's side of the draco and 3mf components: their entry points, called through the
// slots the components fill (core/component.h), or MissingComponentError without them.

#include "core/component.h"
#include "io/draco_codec.h"
#include "io/io_formats.h"

namespace meshmark::detail {

const DracoCodec*& draco_codec_slot() {
  static const DracoCodec* codec = nullptr;
  return codec;
}

const ThreeMfCodec*& three_mf_codec_slot() {
  static const ThreeMfCodec* codec = nullptr;
  return codec;
}

DracoMesh decode_draco(std::string_view bytes, const std::string& name) {
  return require_component(draco_codec_slot(), "draco", "reading Draco data (" + name + ")")
      .decode(bytes, name);
}

std::string encode_draco(const DracoMesh& mesh, const std::vector<double>& new_positions) {
  return require_component(draco_codec_slot(), "draco", "writing Draco data")
      .encode(mesh, new_positions);
}

std::string encode_new_draco(const std::vector<double>& positions,
                             const std::vector<std::uint32_t>& triangles, int position_bits) {
  return require_component(draco_codec_slot(), "draco", "writing Draco data")
      .encode_new(positions, triangles, position_bits);
}

Mesh read_3mf(std::string bytes, const std::string& name, const ReadOptions& options) {
  return require_component(three_mf_codec_slot(), "3mf", "reading a 3MF file (" + name + ")")
      .read(std::move(bytes), name, options);
}

std::string write_3mf(const Mesh& mesh, const WriteOptions& options) {
  return require_component(three_mf_codec_slot(), "3mf", "writing a 3MF file").write(mesh, options);
}

}  // namespace meshmark::detail
