#include "meshmark/core/error.h"

#include <fmt/format.h>

namespace meshmark {

namespace {

std::string compose(const std::string& file, std::size_t line, const std::string& message) {
  if (line > 0) return fmt::format("{}:{}: {}", file, line, message);
  return fmt::format("{}: {}", file, message);
}

// Length of the valid UTF-8 sequence at text[i] (2 to 4) and its code point, or 0 when the
// bytes there are not one (overlong forms and surrogates included).
std::size_t utf8_sequence(std::string_view text, std::size_t i, char32_t& code) {
  const auto b0 = static_cast<unsigned char>(text[i]);
  std::size_t n = 0;
  char32_t min = 0;
  if (b0 >= 0xC2 && b0 <= 0xDF) {
    n = 2, code = b0 & 0x1F, min = 0x80;
  } else if (b0 >= 0xE0 && b0 <= 0xEF) {
    n = 3, code = b0 & 0x0F, min = 0x800;
  } else if (b0 >= 0xF0 && b0 <= 0xF4) {
    n = 4, code = b0 & 0x07, min = 0x10000;
  } else {
    return 0;
  }
  if (text.size() - i < n) return 0;
  for (std::size_t k = 1; k < n; ++k) {
    const auto b = static_cast<unsigned char>(text[i + k]);
    if ((b & 0xC0) != 0x80) return 0;
    code = (code << 6) | (b & 0x3F);
  }
  if (code < min || code > 0x10FFFF || (code >= 0xD800 && code <= 0xDFFF)) return 0;
  return n;
}

// Code points a terminal acts on or that reorder the text around them: C1 controls, the
// bidirectional marks, embeddings, overrides and isolates, and the line and paragraph
// separators.
bool is_control(char32_t c) {
  return (c >= 0x80 && c <= 0x9F) || c == 0x061C || c == 0x200E || c == 0x200F ||
         (c >= 0x2028 && c <= 0x202E) || (c >= 0x2066 && c <= 0x2069);
}

void append_escaped(std::string& out, std::string_view bytes) {
  for (const char ch : bytes) out += fmt::format("\\x{:02x}", static_cast<unsigned char>(ch));
}

}  // namespace

std::string printable(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  std::size_t i = 0;
  while (i < text.size()) {
    const auto b = static_cast<unsigned char>(text[i]);
    if (b >= 0x20 && b < 0x7F) {
      out += text[i++];
    } else if (b < 0x80) {
      append_escaped(out, text.substr(i++, 1));
    } else {
      char32_t code = 0;
      const std::size_t n = utf8_sequence(text, i, code);
      if (n == 0) {
        append_escaped(out, text.substr(i++, 1));
      } else {
        if (is_control(code))
          append_escaped(out, text.substr(i, n));
        else
          out.append(text, i, n);
        i += n;
      }
    }
  }
  return out;
}

Error::Error(const std::string& message) : std::runtime_error(printable(message)) {}

Error::Error(const char* message) : Error(std::string(message)) {}

InvalidInputError::InvalidInputError(std::string file, std::size_t line, const std::string& message)
    : Error(compose(file, line, message)), file_(std::move(file)), line_(line), detail_(message) {}

MissingComponentError::MissingComponentError(std::string component, const std::string& message)
    : InvalidArgumentError(message), component_(std::move(component)) {}

}  // namespace meshmark
