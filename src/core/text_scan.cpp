#include "core/text_scan.h"

#include <charconv>

namespace meshmark::detail {

std::size_t bom_length(std::string_view text) {
  return text.starts_with("\xEF\xBB\xBF") ? 3 : 0;
}

bool LineScanner::next(std::string_view& line) {
  if (pos_ >= text_.size()) return false;
  line_start_ = pos_;
  std::size_t end = pos_;
  while (end < text_.size() && text_[end] != '\n' && text_[end] != '\r') ++end;
  line = text_.substr(pos_, end - pos_);
  pos_ = end;
  if (pos_ < text_.size() && text_[pos_] == '\r') {
    ++pos_;
    if (pos_ < text_.size() && text_[pos_] == '\n') ++pos_;
  } else if (pos_ < text_.size()) {
    ++pos_;  // '\n'
  }
  ++line_;
  return true;
}

namespace {
bool is_space(char c) {
  return c == ' ' || c == '\t' || c == '\f' || c == '\v' || c == '\0';
}
}  // namespace

void tokenize(std::string_view line, std::size_t base_offset, std::vector<Token>& out,
              bool strip_comments) {
  out.clear();
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && is_space(line[i])) ++i;
    if (i >= line.size()) break;
    if (strip_comments && line[i] == '#') break;
    std::size_t j = i;
    while (j < line.size() && !is_space(line[j])) ++j;
    out.push_back({line.substr(i, j - i), base_offset + i});
    i = j;
  }
}

bool parse_double(std::string_view token, double& value) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  if (token.empty()) return false;
  const char* end = token.data() + token.size();
  auto [ptr, ec] = std::from_chars(token.data(), end, value);
  if (ec == std::errc::result_out_of_range) {
    // Denormal underflow reads as zero-ish; overflow as not finite. from_chars leaves value
    // unchanged on range errors, so decide here.
    return false;
  }
  return ec == std::errc() && ptr == end;
}

bool parse_int(std::string_view token, std::int64_t& value) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  if (token.empty()) return false;
  const char* end = token.data() + token.size();
  auto [ptr, ec] = std::from_chars(token.data(), end, value);
  return ec == std::errc() && ptr == end;
}

void append_double(std::string& out, double value) {
  char buf[40];
  auto [ptr, ec] = std::to_chars(buf, buf + sizeof buf, value);
  out.append(buf, ptr);
}

std::string format_double(double value) {
  std::string s;
  append_double(s, value);
  return s;
}

std::string quote(std::string_view token) {
  constexpr std::size_t kMax = 40;
  std::string s = "'";
  s.append(token.substr(0, kMax));
  if (token.size() > kMax) s += "...";
  s += "'";
  return s;
}

}  // namespace meshmark::detail
