// 3MF: not implemented yet.
#include "io_formats.h"
#include "meshmark/error.h"

namespace meshmark::detail {

Mesh read_3mf(std::string, const std::string& name, const ReadOptions&) {
  throw InvalidInputError(name, 0, "3MF files are not supported yet");
}

std::string write_3mf(const Mesh&, const WriteOptions&) {
  throw InvalidArgumentError("writing 3MF files is not supported yet");
}

}  // namespace meshmark::detail
