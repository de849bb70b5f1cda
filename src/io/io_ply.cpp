// PLY: ascii, binary_little_endian and binary_big_endian; any elements and properties. The
// vertex element gives x, y, z; the face element (list vertex_indices or vertex_index) gives
// polygons; the tristrips element (list vertex_indices, -1 restarts a strip) gives triangles.
// Everything else is carried by the file image.

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>

#include <fmt/format.h>

#include "core/text_scan.h"
#include "io/io_formats.h"
#include "meshmark/core/error.h"

namespace meshmark::detail {

namespace {

struct Property {
  std::string name;
  bool is_list = false;
  SlotType type = SlotType::Float32;      // item type for lists
  SlotType count_type = SlotType::UInt8;  // lists only
};

struct Element {
  std::string name;
  std::int64_t count = 0;
  std::vector<Property> properties;
  std::size_t line = 0;
};

struct Header {
  Encoding encoding = Encoding::Ascii;
  std::vector<Element> elements;
  std::size_t body_offset = 0;
  std::size_t body_line = 0;  // line number of the first body line (ascii)
};

std::optional<SlotType> type_from_name(std::string_view s) {
  if (s == "char" || s == "int8") return SlotType::Int8;
  if (s == "uchar" || s == "uint8") return SlotType::UInt8;
  if (s == "short" || s == "int16") return SlotType::Int16;
  if (s == "ushort" || s == "uint16") return SlotType::UInt16;
  if (s == "int" || s == "int32") return SlotType::Int32;
  if (s == "uint" || s == "uint32") return SlotType::UInt32;
  if (s == "float" || s == "float32") return SlotType::Float32;
  if (s == "double" || s == "float64") return SlotType::Float64;
  return std::nullopt;
}

SlotType parse_type(const Token& t, const std::string& name, std::size_t line) {
  auto type = type_from_name(t.text);
  if (!type) fail(name, line, fmt::format("unknown property type {}", quote(t.text)));
  return *type;
}

Header parse_header(const std::string& bytes, const std::string& name) {
  LineScanner lines(bytes);
  std::vector<Token> tokens;
  std::string_view line;
  if (!lines.next(line) || line != "ply")
    fail(name, 1, "not a PLY file (the first line must be 'ply')");
  Header header;
  bool have_format = false;
  while (true) {
    if (!lines.next(line)) fail(name, lines.line_number(), "the header has no end_header line");
    const std::size_t ln = lines.line_number();
    tokenize(line, lines.line_offset(), tokens);
    if (tokens.empty()) continue;
    const std::string_view key = tokens[0].text;
    if (key == "end_header") break;
    if (key == "comment" || key == "obj_info") continue;
    if (key == "format") {
      if (tokens.size() < 2) fail(name, ln, "format line without a format");
      const std::string_view f = tokens[1].text;
      const auto& encodings = EnumTable<Encoding>::values;  // PLY's own names, exact case
      const auto* e = std::find_if(std::begin(encodings), std::end(encodings),
                                   [&](const NamedValue<Encoding>& v) { return f == v.name; });
      if (e == std::end(encodings)) fail(name, ln, fmt::format("unknown format {}", quote(f)));
      header.encoding = e->value;
      have_format = true;
    } else if (key == "element") {
      std::int64_t count = 0;
      if (tokens.size() < 3 || !parse_int(tokens[2].text, count) || count < 0)
        fail(name, ln, "expected 'element NAME COUNT'");
      header.elements.push_back({std::string(tokens[1].text), count, {}, ln});
    } else if (key == "property") {
      if (header.elements.empty()) fail(name, ln, "property before any element");
      Property p;
      if (tokens.size() >= 5 && tokens[1].text == "list") {
        p.is_list = true;
        p.count_type = parse_type(tokens[2], name, ln);
        p.type = parse_type(tokens[3], name, ln);
        if (p.count_type == SlotType::Float32 || p.count_type == SlotType::Float64)
          fail(name, ln, "a list count must have an integer type");
        p.name = tokens[4].text;
      } else if (tokens.size() >= 3 && tokens[1].text != "list") {
        p.type = parse_type(tokens[1], name, ln);
        p.name = tokens[2].text;
      } else {
        fail(name, ln, "malformed property line");
      }
      header.elements.back().properties.push_back(std::move(p));
    } else {
      fail(name, ln, fmt::format("unknown header keyword {}", quote(key)));
    }
  }
  if (!have_format) fail(name, lines.line_number(), "the header has no format line");
  header.body_offset = lines.position();
  header.body_line = lines.line_number() + 1;
  return header;
}

// What the reader extracts from one element.
enum class Role { Other, Vertex, Face, Strips };

struct ElementPlan {
  Role role = Role::Other;
  int axis_of[64];      // per property: 0..2 for x y z, -1 otherwise (properties beyond 64: other)
  int list_index = -1;  // property holding the indices (faces, strips)
};

ElementPlan plan_element(const Element& e, const std::string& name) {
  ElementPlan plan;
  std::fill(std::begin(plan.axis_of), std::end(plan.axis_of), -1);
  if (e.name == "vertex") {
    plan.role = Role::Vertex;
    int found = 0;
    for (std::size_t k = 0; k < e.properties.size() && k < 64; ++k) {
      const auto& p = e.properties[k];
      const int axis = p.name == "x" ? 0 : p.name == "y" ? 1 : p.name == "z" ? 2 : -1;
      if (axis >= 0 && !p.is_list) {
        plan.axis_of[k] = axis;
        found |= 1 << axis;
      }
    }
    if (found != 7) fail(name, e.line, "the vertex element lacks an x, y or z property");
  } else if (e.name == "face" || e.name == "tristrips") {
    for (std::size_t k = 0; k < e.properties.size(); ++k)
      if (e.properties[k].is_list &&
          (e.properties[k].name == "vertex_indices" || e.properties[k].name == "vertex_index"))
        plan.list_index = static_cast<int>(k);
    if (plan.list_index < 0)
      fail(name, e.line, fmt::format("the {} element has no vertex_indices list", e.name));
    plan.role = e.name == "face" ? Role::Face : Role::Strips;
  }
  return plan;
}

// Adds the triangles of one strip (-1 separated runs) to faces; skips zero-area stitching
// triangles that repeat a vertex.
void unroll_strips(const std::vector<std::int64_t>& strip, Polygons& faces) {
  std::size_t start = 0;
  for (std::size_t k = 0; k <= strip.size(); ++k) {
    if (k < strip.size() && strip[k] >= 0) continue;
    for (std::size_t j = start + 2; j < k; ++j) {
      int t[3] = {static_cast<int>(strip[j - 2]), static_cast<int>(strip[j - 1]),
                  static_cast<int>(strip[j])};
      if ((j - start) % 2 == 1) std::swap(t[0], t[1]);
      if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) continue;
      faces.push_back(t, 3);
    }
    start = k + 1;
  }
}

// Appends the index list of face or strip `record` after checking the indices.
void add_indices(const std::vector<std::int64_t>& list, Role role, std::int64_t nv,
                 const Element& e, std::int64_t record, const std::string& name, std::size_t line,
                 Parsed& parsed) {
  for (std::int64_t idx : list) {
    if ((idx < 0 && !(role == Role::Strips && idx == -1)) || idx >= nv)
      fail(name, line,
           fmt::format("{} {}: vertex index {} is out of range [0, {})", e.name, record, idx, nv));
  }
  if (role == Role::Face && list.size() < 3)
    fail(name, line,
         fmt::format("{} {}: {} vertices; a face needs at least 3", e.name, record, list.size()));
  if (role == Role::Strips) {
    unroll_strips(list, parsed.faces);
  } else {
    std::vector<int> face(list.begin(), list.end());
    parsed.faces.push_back(face.data(), face.size());
  }
}

// ----- ascii body -----

class AsciiTokens {
 public:
  AsciiTokens(std::string_view text, std::size_t start, std::size_t first_line)
      : lines_(text, start), first_line_(first_line) {}
  bool next(Token& t) {
    while (k_ >= buf_.size()) {
      std::string_view line;
      if (!lines_.next(line)) return false;
      tokenize(line, lines_.line_offset(), buf_);
      k_ = 0;
    }
    t = buf_[k_++];
    return true;
  }
  std::size_t line() const { return first_line_ + lines_.line_number() - 1; }

 private:
  LineScanner lines_;
  std::vector<Token> buf_;
  std::size_t k_ = 0;
  std::size_t first_line_;
};

void read_ascii_body(const std::string& bytes, const Header& header, std::int64_t nv,
                     const std::string& name, Parsed& parsed) {
  AsciiTokens tokens(bytes, header.body_offset, header.body_line);
  Token t;
  std::vector<std::int64_t> list;
  for (const Element& e : header.elements) {
    const ElementPlan plan = plan_element(e, name);
    for (std::int64_t r = 0; r < e.count; ++r) {
      for (std::size_t k = 0; k < e.properties.size(); ++k) {
        const Property& p = e.properties[k];
        auto need = [&](const char* what) {
          if (!tokens.next(t))
            fail(name, tokens.line(),
                 fmt::format("the file ends inside {} {} ({} of property '{}')", e.name, r, what,
                             p.name));
        };
        std::int64_t n = 1;
        if (p.is_list) {
          need("the count");
          if (!parse_int(t.text, n) || n < 0)
            fail(name, tokens.line(),
                 fmt::format("{} {}: expected a list count, found {}", e.name, r, quote(t.text)));
        }
        list.clear();
        for (std::int64_t j = 0; j < n; ++j) {
          need("a value");
          double x = 0;
          if (!parse_double(t.text, x))
            fail(name, tokens.line(),
                 fmt::format("{} {}: property '{}': expected a number, found {}", e.name, r, p.name,
                             quote(t.text)));
          const int axis = plan.role == Role::Vertex && k < 64 ? plan.axis_of[k] : -1;
          if (axis >= 0) {
            if (!std::isfinite(x))
              fail(name, tokens.line(),
                   fmt::format("vertex {}: coordinate {} is not finite", r, quote(t.text)));
            parsed.xyz[3 * r + axis] = x;
            if (t.text.size() > kMaxCoordinateText)
              fail(name, tokens.line(),
                   fmt::format("vertex {}: a coordinate of {} characters (at most {})", r,
                               t.text.size(), kMaxCoordinateText));
            if (parsed.keep_slots)
              parsed.slots.push_back({t.offset, t.text.size(), static_cast<std::int32_t>(r),
                                      static_cast<std::uint8_t>(axis)});
          } else if (static_cast<int>(k) == plan.list_index) {
            if (x != std::floor(x) || std::abs(x) > 2e9)
              fail(name, tokens.line(),
                   fmt::format("{} {}: {} is not a vertex index", e.name, r, quote(t.text)));
            list.push_back(static_cast<std::int64_t>(x));
          }
        }
        if (static_cast<int>(k) == plan.list_index)
          add_indices(list, plan.role, nv, e, r, name, tokens.line(), parsed);
      }
    }
  }
}

// ----- binary body -----

void read_binary_body(const std::string& bytes, const Header& header, std::int64_t nv,
                      const std::string& name, Parsed& parsed) {
  const bool big = header.encoding == Encoding::BinaryBigEndian;
  std::size_t pos = header.body_offset;
  std::vector<std::int64_t> list;
  for (const Element& e : header.elements) {
    const ElementPlan plan = plan_element(e, name);
    const std::size_t element_start = pos;
    // Every record takes at least this many bytes: check the count before reading.
    std::size_t min_size = 0;
    for (const Property& p : e.properties)
      min_size += static_cast<std::size_t>(slot_type_size(p.is_list ? p.count_type : p.type));
    const std::size_t left = bytes.size() - pos;
    if (min_size > 0 && static_cast<std::uint64_t>(e.count) > left / min_size)
      fail(
          name, 0,
          fmt::format("element '{}' declares {} records but only {} bytes remain (truncated file?)",
                      e.name, e.count, left));
    if (plan.role == Role::Vertex && parsed.regular_allowed) {
      // Fixed-size records: their layout instead of a slot per coordinate.
      RegularLayout layout;
      layout.first = pos, layout.big_endian = big, layout.vertices = e.count;
      for (std::size_t k = 0; k < e.properties.size(); ++k) {
        const int axis = k < 64 ? plan.axis_of[k] : -1;
        if (axis >= 0) {
          layout.offset[static_cast<std::size_t>(axis)] = static_cast<std::uint32_t>(layout.stride);
          layout.type[static_cast<std::size_t>(axis)] = e.properties[k].type;
        }
        layout.stride += static_cast<std::uint64_t>(slot_type_size(e.properties[k].type));
      }
      parsed.regular = layout;
    }
    if (plan.role == Role::Face) {
      // Room for the triangles (most files' faces), no more than the bytes left can hold (a
      // face takes at least 4: a count and three indices), so a lying count reserves little.
      const std::size_t faces = std::min(static_cast<std::size_t>(e.count), left / 4);
      parsed.faces.offsets.reserve(parsed.faces.offsets.size() + faces);
      parsed.faces.indices.reserve(parsed.faces.indices.size() + 3 * faces);
    }
    for (std::int64_t r = 0; r < e.count; ++r) {
      for (std::size_t k = 0; k < e.properties.size(); ++k) {
        const Property& p = e.properties[k];
        std::int64_t n = 1;
        if (p.is_list) {
          const auto cs = static_cast<std::size_t>(slot_type_size(p.count_type));
          if (bytes.size() - pos < cs)
            fail(name, 0,
                 fmt::format("the file ends inside {} {} (property '{}')", e.name, r, p.name));
          n = static_cast<std::int64_t>(read_scalar(bytes.data() + pos, p.count_type, big));
          pos += cs;
          if (n < 0) fail(name, 0, fmt::format("{} {}: negative list count {}", e.name, r, n));
        }
        const auto size = static_cast<std::size_t>(slot_type_size(p.type));
        if (static_cast<std::uint64_t>(n) > (bytes.size() - pos) / size)
          fail(name, 0,
               fmt::format("the file ends inside {} {} (property '{}')", e.name, r, p.name));
        const int axis = plan.role == Role::Vertex && k < 64 ? plan.axis_of[k] : -1;
        if (axis >= 0) {
          const double x = read_scalar(bytes.data() + pos, p.type, big);
          if (!std::isfinite(x))
            fail(name, 0, fmt::format("vertex {}: coordinate {} is not finite", r, "xyz"[axis]));
          parsed.xyz[3 * r + axis] = x;
          if (parsed.keep_slots && !parsed.regular)
            parsed.slots.push_back({pos, static_cast<std::uint64_t>(size),
                                    static_cast<std::int32_t>(r), static_cast<std::uint8_t>(axis),
                                    p.type, big});
        } else if (static_cast<int>(k) == plan.list_index) {
          list.resize(static_cast<std::size_t>(n));
          for (std::int64_t j = 0; j < n; ++j)
            list[j] =
                static_cast<std::int64_t>(read_scalar(bytes.data() + pos + j * size, p.type, big));
          add_indices(list, plan.role, nv, e, r, name, 0, parsed);
        }
        pos += static_cast<std::size_t>(n) * size;
      }
    }
    // Plain records (x, y and z alone; one index list alone), which the mesh may encode again:
    // the image need not hold them (assemble checks that it does, byte for byte).
    ElidedSection section;
    section.at = element_start, section.length = pos - element_start, section.records = e.count;
    section.big_endian = big;
    if (parsed.keep_slots && plan.role == Role::Vertex && parsed.regular &&
        parsed.regular->first == element_start && e.properties.size() == 3) {
      section.kind = ElidedSection::Kind::Positions;
      parsed.elidable.push_back(section);
    } else if (parsed.keep_slots && plan.role == Role::Face && e.properties.size() == 1) {
      section.kind = ElidedSection::Kind::Faces;
      section.count_type = e.properties[0].count_type;
      section.index_type = e.properties[0].type;
      parsed.elidable.push_back(section);
    }
  }
}

}  // namespace

Mesh read_ply(const std::string& bytes, std::string* image_bytes, const std::string& name,
              const ReadOptions& options) {
  const Header header = parse_header(bytes, name);
  std::int64_t nv = -1;
  for (const Element& e : header.elements)
    if (e.name == "vertex") nv = e.count;
  if (nv < 0) fail(name, 0, "the header declares no vertex element");
  // Even the most compact vertex record takes 3 bytes: reject impossible counts up front.
  if (nv > static_cast<std::int64_t>(bytes.size()))
    fail(name, 0, fmt::format("{} vertices cannot fit in a file of {} bytes", nv, bytes.size()));
  Parsed parsed;
  parsed.keep_slots = options.keep_image;
  parsed.xyz.assign(static_cast<std::size_t>(nv) * 3, 0.0);
  // A binary file's vertex records of a fixed size (no list, each axis once), read without
  // welding: their layout is kept instead of a slot per coordinate.
  if (parsed.keep_slots && header.encoding != Encoding::Ascii && options.weld_tolerance == 0) {
    int vertex_elements = 0;
    bool fixed = true;
    for (const Element& e : header.elements) {
      if (e.name != "vertex") continue;
      ++vertex_elements;
      std::array<int, 3> seen{};
      for (const Property& p : e.properties) {
        fixed = fixed && !p.is_list;
        const int axis = p.name == "x" ? 0 : p.name == "y" ? 1 : p.name == "z" ? 2 : -1;
        if (axis >= 0) ++seen[static_cast<std::size_t>(axis)];
      }
      fixed = fixed && e.properties.size() <= 64 && seen == std::array<int, 3>{1, 1, 1};
    }
    parsed.regular_allowed = fixed && vertex_elements == 1;
  }
  if (parsed.keep_slots && !parsed.regular_allowed)
    parsed.slots.reserve(static_cast<std::size_t>(nv) * 3);
  if (header.encoding == Encoding::Ascii)
    read_ascii_body(bytes, header, nv, name, parsed);
  else
    read_binary_body(bytes, header, nv, name, parsed);
  return assemble(std::move(parsed), image_bytes, FileFormat::Ply, header.encoding, name, options);
}

std::string write_ply(const Mesh& mesh, Encoding encoding, bool single_precision,
                      const Eigen::Matrix<std::uint8_t, Eigen::Dynamic, 3>* colors) {
  const char* scalar = single_precision ? "float" : "double";
  const FaceView faces(mesh);
  std::string out = fmt::format(
      "ply\nformat {} 1.0\ncomment written by meshmark\nelement vertex {}\nproperty {} x\n"
      "property {} y\nproperty {} z\n{}element face {}\nproperty list uchar int vertex_indices\n"
      "end_header\n",
      encoding_name(encoding), mesh.V.rows(), scalar, scalar, scalar,
      colors ? "property uchar red\nproperty uchar green\nproperty uchar blue\n" : "",
      faces.size());
  if (encoding == Encoding::Ascii) {
    for (Eigen::Index i = 0; i < mesh.V.rows(); ++i) {
      if (single_precision) {
        out += fmt::format("{} {} {}", static_cast<float>(mesh.V(i, 0)),
                           static_cast<float>(mesh.V(i, 1)), static_cast<float>(mesh.V(i, 2)));
      } else {
        append_position(out, mesh.V, i);
      }
      if (colors)
        out += fmt::format(" {} {} {}", int{(*colors)(i, 0)}, int{(*colors)(i, 1)},
                           int{(*colors)(i, 2)});
      out += '\n';
    }
    for (std::size_t k = 0; k < faces.size(); ++k) {
      out += std::to_string(faces.size_of(k));
      for (std::size_t c = 0; c < faces.size_of(k); ++c)
        out += ' ' + std::to_string(faces.corner(k, c));
      out += '\n';
    }
    return out;
  }
  const bool big = encoding == Encoding::BinaryBigEndian;
  const SlotType type = single_precision ? SlotType::Float32 : SlotType::Float64;
  const int size = slot_type_size(type);
  std::size_t pos = out.size();
  const std::size_t color_bytes = colors ? 3 : 0;
  out.resize(pos + static_cast<std::size_t>(mesh.V.rows()) * (3 * size + color_bytes));
  for (Eigen::Index i = 0; i < mesh.V.rows(); ++i) {
    for (int a = 0; a < 3; ++a, pos += size)
      write_scalar(out.data() + pos, type, big, mesh.V(i, a));
    for (std::size_t a = 0; a < color_bytes; ++a) out[pos++] = static_cast<char>((*colors)(i, a));
  }
  for (std::size_t k = 0; k < faces.size(); ++k) {
    const std::size_t n = faces.size_of(k);
    if (n > 255)
      throw InvalidArgumentError(
          fmt::format("face {} has {} vertices; PLY uchar counts allow 255", k, n));
    out.resize(out.size() + 1 + n * 4);
    write_scalar(out.data() + pos, SlotType::UInt8, big, static_cast<double>(n));
    pos += 1;
    for (std::size_t c = 0; c < n; ++c, pos += 4)
      write_scalar(out.data() + pos, SlotType::Int32, big, faces.corner(k, c));
  }
  return out;
}

}  // namespace meshmark::detail
