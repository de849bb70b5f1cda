// OBJ: "v x y z [w | r g b]" vertices and "f" faces with v, v/vt, v//vn or v/vt/vn corners,
// 1-based or negative (relative) indices. Every other statement (vt, vn, g, o, s, usemtl,
// mtllib, l, comments) is kept by the file image and ignored here.

#include <cmath>

#include <fmt/format.h>

#include "core/text_scan.h"
#include "io/io_formats.h"

namespace meshmark::detail {

namespace {

void parse_vertex(const std::vector<Token>& tokens, const std::string& name, std::size_t line,
                  Parsed& parsed) {
  const auto i = static_cast<std::int32_t>(parsed.xyz.size() / 3);
  if (tokens.size() < 4)
    fail(name, line,
         fmt::format("vertex {}: expected 3 coordinates, found {}", i + 1, tokens.size() - 1));
  for (int a = 0; a < 3; ++a) {
    const Token& t = tokens[a + 1];
    double x = 0;
    if (!parse_double(t.text, x))
      fail(name, line, fmt::format("vertex {}: expected a number, found {}", i + 1, quote(t.text)));
    if (!std::isfinite(x))
      fail(name, line, fmt::format("vertex {}: coordinate {} is not finite", i + 1, quote(t.text)));
    parsed.xyz.push_back(x);
    if (t.text.size() > kMaxCoordinateText)
      fail(name, line,
           fmt::format("vertex {}: a coordinate of {} characters (at most {})", i + 1,
                       t.text.size(), kMaxCoordinateText));
    if (parsed.keep_slots)
      parsed.slots.push_back({t.offset, t.text.size(), i, static_cast<std::uint8_t>(a)});
  }
}

// Resolves the vertex part of each corner; positive indices are checked once all vertices
// are known (OBJ allows them to point forward), relative ones at once.
void parse_face(const std::vector<Token>& tokens, const std::string& name, std::size_t line,
                Parsed& parsed, std::vector<int>& face) {
  const auto nv = static_cast<std::int64_t>(parsed.xyz.size() / 3);
  face.clear();
  for (std::size_t c = 1; c < tokens.size(); ++c) {
    std::string_view corner = tokens[c].text;
    const auto slash = corner.find('/');
    std::int64_t idx = 0;
    if (!parse_int(corner.substr(0, slash), idx) || idx == 0)
      fail(name, line,
           fmt::format("face {}: expected a vertex index, found {}", parsed.faces.size() + 1,
                       quote(corner)));
    if (idx < 0) {
      idx += nv;
      if (idx < 0)
        fail(name, line,
             fmt::format("face {}: relative index {} points before the first vertex",
                         parsed.faces.size() + 1, quote(corner)));
    } else {
      idx -= 1;
    }
    if (idx > std::numeric_limits<int>::max())
      fail(name, line,
           fmt::format("face {}: vertex index {} is out of range", parsed.faces.size() + 1,
                       quote(corner)));
    face.push_back(static_cast<int>(idx));
  }
  if (face.size() < 3)
    fail(name, line,
         fmt::format("face {}: {} vertices; a face needs at least 3", parsed.faces.size() + 1,
                     face.size()));
  parsed.faces.push_back(face.data(), face.size());
}

}  // namespace

Mesh read_obj(const std::string& bytes, std::string* image_bytes, const std::string& name,
              const ReadOptions& options) {
  LineScanner lines(bytes);
  std::vector<Token> tokens;
  std::vector<int> face;
  std::vector<std::uint32_t> face_line;
  Parsed parsed;
  parsed.keep_slots = options.keep_image;
  std::string_view line;
  while (lines.next(line)) {
    tokenize(line, lines.line_offset(), tokens);
    if (tokens.empty()) continue;
    const std::string_view key = tokens[0].text;
    if (key == "v") {
      parse_vertex(tokens, name, lines.line_number(), parsed);
    } else if (key == "f") {
      parse_face(tokens, name, lines.line_number(), parsed, face);
      face_line.push_back(static_cast<std::uint32_t>(lines.line_number()));
    }
  }
  const auto nv = static_cast<int>(parsed.xyz.size() / 3);
  for (std::size_t k = 0; k < parsed.faces.size(); ++k)
    for (auto c = parsed.faces.offsets[k]; c < parsed.faces.offsets[k + 1]; ++c)
      if (parsed.faces.indices[c] >= nv)
        fail(name, face_line[k],
             fmt::format("face {}: vertex index {} is out of range [1, {}]", k + 1,
                         parsed.faces.indices[c] + 1, nv));
  return assemble(std::move(parsed), image_bytes, FileFormat::Obj, Encoding::Ascii, name, options);
}

std::string write_obj(const Mesh& mesh) {
  std::string out = "# written by meshmark\n";
  const FaceView faces(mesh);
  out.reserve(static_cast<std::size_t>(mesh.V.rows()) * 40 + faces.corners() * 8);
  for (Eigen::Index i = 0; i < mesh.V.rows(); ++i) {
    out += "v ";
    append_position(out, mesh.V, i);
    out += '\n';
  }
  for (std::size_t k = 0; k < faces.size(); ++k) {
    out += 'f';
    for (std::size_t c = 0; c < faces.size_of(k); ++c) {
      out += ' ';
      out += std::to_string(faces.corner(k, c) + 1);
    }
    out += '\n';
  }
  return out;
}

}  // namespace meshmark::detail
