#include "meshmark/error.h"

#include <fmt/format.h>

namespace meshmark {

namespace {
std::string compose(const std::string& file, std::size_t line, const std::string& message) {
  if (line > 0) return fmt::format("{}:{}: {}", file, line, message);
  return fmt::format("{}: {}", file, message);
}
}  // namespace

InvalidInputError::InvalidInputError(std::string file, std::size_t line, const std::string& message)
    : Error(compose(file, line, message)), file_(std::move(file)), line_(line), detail_(message) {}

}  // namespace meshmark
