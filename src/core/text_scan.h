#pragma once
// Internal: line and token scanning over a text buffer, with byte offsets and line numbers,
// and strict number parsing. Shared by the OFF, OBJ, PLY (ascii) and STL (ascii) readers.

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace meshmark::detail {

/// A whitespace-separated token and where it starts in the whole buffer.
struct Token {
  std::string_view text;
  std::size_t offset = 0;
};

/// Length of the UTF-8 byte-order mark that starts text (3), or 0 when there is none.
std::size_t bom_length(std::string_view text);

/// Iterates the lines of a buffer (terminated by \n, \r\n or \r), 1-based line numbers.
/// Scanning from the start of the buffer (start 0) skips a leading UTF-8 byte-order mark, so
/// that every text format accepts one; offsets stay offsets into the whole buffer.
class LineScanner {
 public:
  explicit LineScanner(std::string_view text, std::size_t start = 0)
      : text_(text), pos_(start == 0 ? bom_length(text) : start) {}
  /// Next line without its terminator; false at the end of the buffer.
  bool next(std::string_view& line);
  /// Number of the line last returned by next().
  std::size_t line_number() const { return line_; }
  /// Offset of the first byte of the line last returned by next().
  std::size_t line_offset() const { return line_start_; }
  /// Offset just past the line last returned (its terminator included).
  std::size_t position() const { return pos_; }

 private:
  std::string_view text_;
  std::size_t pos_ = 0;
  std::size_t line_ = 0;
  std::size_t line_start_ = 0;
};

/// Splits line (which starts at base_offset in the buffer) into tokens; a '#' that starts a
/// token ends the line when strip_comments is set.
void tokenize(std::string_view line, std::size_t base_offset, std::vector<Token>& out,
              bool strip_comments = false);

/// Parses the whole token as a double (decimal or scientific, optional sign). False when the
/// token is not a number. NaN and infinities parse (check std::isfinite separately).
bool parse_double(std::string_view token, double& value);

/// Parses the whole token as a signed integer. False when it is not one or overflows.
bool parse_int(std::string_view token, std::int64_t& value);

/// Shortest text that reads back to exactly this double.
std::string format_double(double value);

/// Appends format_double(value) to out.
void append_double(std::string& out, double value);

/// Quotes a token for an error message, cut to a readable length (the error escapes what a
/// terminal would act on: see printable() in error.h).
std::string quote(std::string_view token);

}  // namespace meshmark::detail
