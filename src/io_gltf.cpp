// glTF: not implemented yet.
#include "io_formats.h"
#include "meshmark/error.h"

namespace meshmark::detail {

Mesh read_gltf(std::string, FileFormat, const std::string& name, const ReadOptions&) {
  throw InvalidInputError(name, 0, "glTF files are not supported yet");
}

std::string write_gltf(const Mesh&, FileFormat, const WriteOptions&) {
  throw InvalidArgumentError("writing glTF files is not supported yet");
}

}  // namespace meshmark::detail
