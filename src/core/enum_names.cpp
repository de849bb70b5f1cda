// The non-template parts of enum_names.h: case-blind comparison and the refusal message.

#include "meshmark/core/enum_names.h"

#include <fmt/format.h>

#include "meshmark/core/error.h"

namespace meshmark::detail {

bool same_name(std::string_view a, std::string_view b) {
  auto lower = [](char c) { return c >= 'A' && c <= 'Z' ? static_cast<char>(c - 'A' + 'a') : c; };
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (lower(a[i]) != lower(b[i])) return false;
  return true;
}

void throw_unknown_name(std::string_view what, std::string_view name,
                        const std::vector<std::string_view>& names) {
  throw InvalidArgumentError(
      fmt::format("unknown {} '{}' (one of: {})", what, name, fmt::join(names, ", ")));
}

}  // namespace meshmark::detail
