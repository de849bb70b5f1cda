// Draco (.drc): not implemented yet.
#include "io_formats.h"
#include "meshmark/error.h"

namespace meshmark::detail {

Mesh read_draco(std::string, const std::string& name, const ReadOptions&) {
  throw InvalidInputError(name, 0, "Draco files are not supported yet");
}

std::string write_draco(const Mesh&, const WriteOptions&) {
  throw InvalidArgumentError("writing Draco files is not supported yet");
}

}  // namespace meshmark::detail
