// OFF: "OFF" header (with the C, N, ST prefixes of colored, normal and textured variants),
// counts, one vertex per line, one face per line ("n i0 ... in-1", extra values ignored).

#include <cmath>

#include <fmt/format.h>

#include "core/text_scan.h"
#include "io/io_formats.h"

namespace meshmark::detail {

namespace {

// True for OFF, COFF, NOFF, CNOFF, STOFF, STCOFF, ...: 3D variants whose first three vertex
// values are x y z. Sets `unsupported` for 4OFF, nOFF and binary variants.
bool off_keyword(std::string_view word, bool& unsupported) {
  if (word.size() < 3 || word.substr(word.size() - 3) != "OFF") return false;
  std::string_view prefix = word.substr(0, word.size() - 3);
  if (prefix.starts_with("ST")) prefix.remove_prefix(2);
  if (prefix.starts_with("C")) prefix.remove_prefix(1);
  if (prefix.starts_with("N")) prefix.remove_prefix(1);
  unsupported = prefix == "4" || prefix == "n" || prefix == "4n";
  return prefix.empty() || unsupported;
}

// Next line with at least one token (comments stripped); false at the end of the file.
bool next_tokens(LineScanner& lines, std::vector<Token>& tokens) {
  std::string_view line;
  while (lines.next(line)) {
    tokenize(line, lines.line_offset(), tokens, true);
    if (!tokens.empty()) return true;
  }
  return false;
}

std::int64_t count_value(const Token& t, const std::string& name, std::size_t line,
                         const char* what) {
  std::int64_t n = 0;
  if (!parse_int(t.text, n) || n < 0)
    fail(name, line, fmt::format("expected the {} count, found {}", what, quote(t.text)));
  return n;
}

}  // namespace

Mesh read_off(const std::string& bytes, std::string* image_bytes, const std::string& name,
              const ReadOptions& options) {
  LineScanner lines(bytes);
  std::vector<Token> tokens;
  if (!next_tokens(lines, tokens)) fail(name, 0, "the file is empty");
  bool unsupported = false;
  if (!off_keyword(tokens[0].text, unsupported))
    fail(name, lines.line_number(),
         fmt::format("expected an OFF header, found {}", quote(tokens[0].text)));
  if (unsupported)
    fail(name, lines.line_number(),
         fmt::format("{} (not 3D) is not supported", quote(tokens[0].text)));
  if (tokens.size() > 1 && tokens[1].text == "BINARY")
    fail(name, lines.line_number(), "binary OFF is not supported");
  // Counts on the header line itself or on the next line.
  std::vector<Token> counts(tokens.begin() + 1, tokens.end());
  if (counts.empty()) {
    if (!next_tokens(lines, counts))
      fail(name, lines.line_number(), "the file ends before the counts");
  }
  if (counts.size() < 2) fail(name, lines.line_number(), "expected vertex and face counts");
  const std::int64_t nv = count_value(counts[0], name, lines.line_number(), "vertex");
  const std::int64_t nf = count_value(counts[1], name, lines.line_number(), "face");
  // Every vertex and face takes at least 2 bytes: reject absurd counts before allocating.
  if (nv > static_cast<std::int64_t>(bytes.size()) || nf > static_cast<std::int64_t>(bytes.size()))
    fail(name, lines.line_number(),
         fmt::format("counts {} vertices, {} faces cannot fit in a file of {} bytes", nv, nf,
                     bytes.size()));
  Parsed parsed;
  parsed.keep_slots = options.keep_image;
  parsed.xyz.reserve(static_cast<std::size_t>(nv) * 3);
  if (parsed.keep_slots) parsed.slots.reserve(static_cast<std::size_t>(nv) * 3);
  for (std::int64_t i = 0; i < nv; ++i) {
    if (!next_tokens(lines, tokens))
      fail(name, lines.line_number(), fmt::format("the file ends after {} of {} vertices", i, nv));
    if (tokens.size() < 3)
      fail(name, lines.line_number(),
           fmt::format("vertex {}: expected 3 coordinates, found {}", i, tokens.size()));
    for (int a = 0; a < 3; ++a) {
      double x = 0;
      if (!parse_double(tokens[a].text, x))
        fail(name, lines.line_number(),
             fmt::format("vertex {}: expected a number, found {}", i, quote(tokens[a].text)));
      if (!std::isfinite(x))
        fail(name, lines.line_number(),
             fmt::format("vertex {}: coordinate {} is not finite", i, quote(tokens[a].text)));
      parsed.xyz.push_back(x);
      if (tokens[a].text.size() > kMaxCoordinateText)
        fail(name, lines.line_number(),
             fmt::format("vertex {}: a coordinate of {} characters (at most {})", i,
                         tokens[a].text.size(), kMaxCoordinateText));
      if (parsed.keep_slots)
        parsed.slots.push_back({tokens[a].offset, tokens[a].text.size(),
                                static_cast<std::int32_t>(i), static_cast<std::uint8_t>(a)});
    }
  }
  std::vector<int> face;
  for (std::int64_t k = 0; k < nf; ++k) {
    if (!next_tokens(lines, tokens))
      fail(name, lines.line_number(), fmt::format("the file ends after {} of {} faces", k, nf));
    std::int64_t n = 0;
    if (!parse_int(tokens[0].text, n) || n < 0)
      fail(name, lines.line_number(),
           fmt::format("face {}: expected a vertex count, found {}", k, quote(tokens[0].text)));
    if (n < 3)
      fail(name, lines.line_number(),
           fmt::format("face {}: {} vertices; a face needs at least 3", k, n));
    if (static_cast<std::int64_t>(tokens.size()) < n + 1)
      fail(name, lines.line_number(),
           fmt::format("face {}: expected {} indices, found {}", k, n, tokens.size() - 1));
    face.clear();
    for (std::int64_t c = 0; c < n; ++c) {
      std::int64_t idx = 0;
      if (!parse_int(tokens[c + 1].text, idx))
        fail(name, lines.line_number(),
             fmt::format("face {}: expected a vertex index, found {}", k,
                         quote(tokens[c + 1].text)));
      if (idx < 0 || idx >= nv)
        fail(name, lines.line_number(),
             fmt::format("face {}: vertex index {} is out of range [0, {})", k, idx, nv));
      face.push_back(static_cast<int>(idx));
    }
    parsed.faces.push_back(face.data(), face.size());
  }
  return assemble(std::move(parsed), image_bytes, FileFormat::Off, Encoding::Ascii, name, options);
}

std::string write_off(const Mesh& mesh) {
  const FaceView faces(mesh);
  std::string out = fmt::format("OFF\n{} {} 0\n", mesh.V.rows(), faces.size());
  for (Eigen::Index i = 0; i < mesh.V.rows(); ++i) {
    append_position(out, mesh.V, i);
    out += '\n';
  }
  for (std::size_t k = 0; k < faces.size(); ++k) {
    out += std::to_string(faces.size_of(k));
    for (std::size_t c = 0; c < faces.size_of(k); ++c) {
      out += ' ';
      out += std::to_string(faces.corner(k, c));
    }
    out += '\n';
  }
  return out;
}

}  // namespace meshmark::detail
