#pragma once
// Internal: where the values of a JSON text sit, so that a writer can replace a few of them and
// keep every other byte (glTF's min/max and byte offsets, say).

#include <cstddef>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

namespace meshmark::detail {

/// A value's bytes in the text: [begin, end).
struct JsonSpan {
  std::size_t begin = 0;
  std::size_t end = 0;
};

/// The span of every value down to max_depth, by JSON pointer ("" for the root, "/accessors/0/min"
/// for a member of an element; '~' and '/' in names escaped as RFC 6901 says).
/// \pre text is valid JSON (parse it first): this scanner checks little.
/// \throw InvalidArgumentError when the text ends inside a value.
std::unordered_map<std::string, JsonSpan> json_spans(std::string_view text, int max_depth);

/// One replacement of a span by new text.
struct JsonEdit {
  JsonSpan span;
  std::string text;
};

/// text with every edit applied (edits must not overlap; any order).
/// \throw InvalidArgumentError when two edits overlap or one reaches past the text.
std::string apply_json_edits(std::string_view text, std::vector<JsonEdit> edits);

}  // namespace meshmark::detail
