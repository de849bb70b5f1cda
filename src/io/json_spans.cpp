#include "io/json_spans.h"

#include <algorithm>

#include <fmt/format.h>

#include "meshmark/core/error.h"

namespace meshmark::detail {

namespace {

struct Scanner {
  std::string_view text;
  int max_depth = 0;
  std::size_t pos = 0;
  std::unordered_map<std::string, JsonSpan>* out = nullptr;

  [[noreturn]] void truncated() const {
    throw InvalidArgumentError(fmt::format("JSON text ends inside a value (byte {})", pos));
  }
  void skip_space() {
    while (pos < text.size() &&
           (text[pos] == ' ' || text[pos] == '\t' || text[pos] == '\n' || text[pos] == '\r'))
      ++pos;
  }
  char peek() {
    skip_space();
    if (pos >= text.size()) truncated();
    return text[pos];
  }
  // Skips a string starting at pos (at the quote); returns its raw contents.
  std::string_view string() {
    const std::size_t start = ++pos;
    while (pos < text.size() && text[pos] != '"') pos += text[pos] == '\\' ? 2 : 1;
    if (pos >= text.size()) truncated();
    return text.substr(start, pos++ - start);
  }
  void value(const std::string& pointer, int depth) {
    const std::size_t begin = (peek(), pos);
    const char c = text[pos];
    if (c == '{') {
      ++pos;
      if (peek() == '}') {
        ++pos;
      } else {
        while (true) {
          if (peek() != '"') truncated();
          const std::string_view name = string();
          if (peek() != ':') truncated();
          ++pos;
          value(depth < max_depth ? pointer + "/" + escaped(name) : std::string(), depth + 1);
          if (peek() == ',') {
            ++pos;
            continue;
          }
          if (text[pos] != '}') truncated();
          ++pos;
          break;
        }
      }
    } else if (c == '[') {
      ++pos;
      if (peek() == ']') {
        ++pos;
      } else {
        for (std::size_t k = 0;; ++k) {
          value(depth < max_depth ? pointer + "/" + std::to_string(k) : std::string(), depth + 1);
          if (peek() == ',') {
            ++pos;
            continue;
          }
          if (text[pos] != ']') truncated();
          ++pos;
          break;
        }
      }
    } else if (c == '"') {
      string();
    } else {
      while (pos < text.size() && text[pos] != ',' && text[pos] != '}' && text[pos] != ']' &&
             text[pos] != ' ' && text[pos] != '\n' && text[pos] != '\r' && text[pos] != '\t')
        ++pos;
    }
    if (depth <= max_depth) (*out)[pointer] = {begin, pos};
  }
  static std::string escaped(std::string_view name) {
    std::string s;
    for (const char ch : name) {
      if (ch == '~')
        s += "~0";
      else if (ch == '/')
        s += "~1";
      else
        s += ch;
    }
    return s;
  }
};

}  // namespace

std::unordered_map<std::string, JsonSpan> json_spans(std::string_view text, int max_depth) {
  std::unordered_map<std::string, JsonSpan> out;
  // A UTF-8 byte-order mark before the JSON text is not part of any value.
  const std::size_t start = text.starts_with("\xEF\xBB\xBF") ? 3 : 0;
  Scanner scanner{text, max_depth, start, &out};
  scanner.value("", 0);
  return out;
}

std::string apply_json_edits(std::string_view text, std::vector<JsonEdit> edits) {
  std::sort(edits.begin(), edits.end(),
            [](const JsonEdit& a, const JsonEdit& b) { return a.span.begin < b.span.begin; });
  std::string out;
  out.reserve(text.size());
  std::size_t at = 0;
  for (const JsonEdit& e : edits) {
    if (e.span.begin < at || e.span.end < e.span.begin || e.span.end > text.size())
      throw InvalidArgumentError("overlapping or out-of-range JSON edits");
    out.append(text.substr(at, e.span.begin - at));
    out += e.text;
    at = e.span.end;
  }
  out.append(text.substr(at));
  return out;
}

}  // namespace meshmark::detail
