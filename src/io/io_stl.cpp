// STL, ascii and binary. STL stores every triangle's corners separately: the reader gives
// each corner a vertex and assemble() welds identical positions (exactly, or within
// ReadOptions::weld_tolerance) into shared vertices; the file image writes the triangles back
// unwelded, in their original order.

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <numeric>
#include <unordered_map>

#include <fmt/format.h>

#include "core/text_scan.h"
#include "io/io_formats.h"
#include "meshmark/core/error.h"

namespace meshmark::detail {

namespace {

struct Corners {
  std::vector<double> xyz;            // 3 per corner
  std::vector<std::uint64_t> offset;  // 3 per corner: where each coordinate is stored
  std::vector<std::uint16_t> length;  // 3 per corner (text token length; 4 for binary)
};

struct Key {
  double x, y, z;
  bool operator==(const Key& o) const { return x == o.x && y == o.y && z == o.z; }
};
struct KeyHash {
  std::size_t operator()(const Key& k) const {
    auto h = [](double d) {
      if (d == 0) d = 0;  // -0.0 and +0.0 weld
      std::uint64_t u;
      std::memcpy(&u, &d, sizeof u);
      return u;
    };
    std::uint64_t v = h(k.x) * 0x9E3779B97F4A7C15ull;
    v ^= h(k.y) + 0x7F4A7C159E3779B9ull + (v << 6) + (v >> 2);
    v ^= h(k.z) + 0x94D049BB133111EBull + (v << 6) + (v >> 2);
    v ^= v >> 31;  // the low bits index the table: fold the high ones in
    v *= 0xBF58476D1CE4E5B9ull;
    v ^= v >> 29;
    return static_cast<std::size_t>(v);
  }
};

int find_root(std::vector<int>& parent, int i) {
  while (parent[i] != i) i = parent[i] = parent[parent[i]];
  return i;
}

// The grid cell of coordinate x for cells of size tolerance. Where x / tolerance is too large
// for the cells to be told apart (beyond 2^52 no two distinct doubles are within the tolerance
// along this axis), the coordinate's bits stand for the cell: only equal values share one.
// Cells only gather candidates; the exact distance decides.
std::int64_t cell(double x, double tolerance) {
  const double q = std::floor(x / tolerance);
  if (std::abs(q) < 0x1p52) return static_cast<std::int64_t>(q);
  std::int64_t bits;
  std::memcpy(&bits, &x, sizeof bits);
  return bits;
}

// Maps every corner to a vertex: first exact welding, then (tolerance > 0) union of the
// unique points closer than the tolerance, found through a hash grid of that cell size.
std::vector<int> weld(const std::vector<double>& xyz, double tolerance,
                      std::vector<int>& first_corner) {
  const std::size_t nc = xyz.size() / 3;
  // Exact duplicates through an open-addressing table of corner numbers (linear probing, at
  // most half full): a million corners in tens of milliseconds, where std::unordered_map's
  // node per entry took several times longer.
  std::size_t slots = 16;
  while (slots < 2 * nc) slots *= 2;
  std::vector<int> table(slots, -1);
  std::vector<int> unique_of(nc);
  std::vector<int> unique_corner;
  const KeyHash hash;
  // Table slots hashed first, and each prefetched 16 corners ahead of its lookup: the lookups
  // of a million corners are cache misses, this overlaps them.
  constexpr std::size_t kAhead = 16;
  std::vector<std::size_t> slot_of(nc);
  for (std::size_t c = 0; c < nc; ++c)
    slot_of[c] = hash(Key{xyz[3 * c], xyz[3 * c + 1], xyz[3 * c + 2]}) & (slots - 1);
  unique_corner.reserve(nc);
  for (std::size_t c = 0; c < nc; ++c) {
    if (c + kAhead < nc) __builtin_prefetch(&table[slot_of[c + kAhead]]);
    const Key key{xyz[3 * c], xyz[3 * c + 1], xyz[3 * c + 2]};
    std::size_t s = slot_of[c];
    while (true) {
      const int u = table[s];
      if (u < 0) {
        table[s] = static_cast<int>(unique_corner.size());
        unique_of[c] = table[s];
        unique_corner.push_back(static_cast<int>(c));
        break;
      }
      const double* q =
          &xyz[3 * static_cast<std::size_t>(unique_corner[static_cast<std::size_t>(u)])];
      if (Key{q[0], q[1], q[2]} == key) {
        unique_of[c] = u;
        break;
      }
      s = (s + 1) & (slots - 1);
    }
  }
  const auto nu = static_cast<int>(unique_corner.size());
  std::vector<int> parent(nu);
  std::iota(parent.begin(), parent.end(), 0);
  if (tolerance > 0) {
    struct CellHash {
      std::size_t operator()(const std::array<std::int64_t, 3>& c) const {
        // Unsigned arithmetic: wraps instead of overflowing on huge cell indices.
        return static_cast<std::size_t>(static_cast<std::uint64_t>(c[0]) * 73856093u ^
                                        static_cast<std::uint64_t>(c[1]) * 19349663u ^
                                        static_cast<std::uint64_t>(c[2]) * 83492791u);
      }
    };
    std::unordered_map<std::array<std::int64_t, 3>, std::vector<int>, CellHash> grid;
    auto cell_of = [&](int u) {
      const double* p = &xyz[3 * unique_corner[u]];
      return std::array<std::int64_t, 3>{cell(p[0], tolerance), cell(p[1], tolerance),
                                         cell(p[2], tolerance)};
    };
    for (int u = 0; u < nu; ++u) grid[cell_of(u)].push_back(u);
    for (int u = 0; u < nu; ++u) {
      const auto c = cell_of(u);
      const double* p = &xyz[3 * unique_corner[u]];
      for (int dx = -1; dx <= 1; ++dx)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dz = -1; dz <= 1; ++dz) {
            auto it = grid.find({c[0] + dx, c[1] + dy, c[2] + dz});
            if (it == grid.end()) continue;
            for (int w : it->second) {
              if (w <= u) continue;
              const double* q = &xyz[3 * unique_corner[w]];
              const double d2 = (p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) +
                                (p[2] - q[2]) * (p[2] - q[2]);
              if (d2 <= tolerance * tolerance) {
                const int a = find_root(parent, u), b = find_root(parent, w);
                parent[std::max(a, b)] = std::min(a, b);
              }
            }
          }
    }
  }
  // Number the clusters in order of their first corner.
  std::vector<int> vertex_of_root(nu, -1);
  std::vector<int> corner_vertex(nc);
  first_corner.clear();
  for (std::size_t c = 0; c < nc; ++c) {
    const int root = find_root(parent, unique_of[c]);
    if (vertex_of_root[root] < 0) {
      vertex_of_root[root] = static_cast<int>(first_corner.size());
      first_corner.push_back(static_cast<int>(c));
    }
    corner_vertex[c] = vertex_of_root[root];
  }
  return corner_vertex;
}

void check_finite(const double* p, std::size_t triangle, const std::string& name,
                  std::size_t line) {
  for (int a = 0; a < 3; ++a)
    if (!std::isfinite(p[a]))
      fail(name, line, fmt::format("triangle {}: coordinate {} is not finite", triangle, "xyz"[a]));
}

Corners read_binary_corners(const std::string& bytes, const std::string& name) {
  std::uint32_t n = 0;
  std::memcpy(&n, bytes.data() + 80, 4);  // little endian on every platform we build for
  const std::uint64_t expected = 84 + 50ull * n;
  if (expected != bytes.size())
    fail(name, 0,
         fmt::format("binary STL declares {} triangles ({} bytes) but the file has {} bytes", n,
                     expected, bytes.size()));
  Corners corners;
  corners.xyz.resize(9ull * n);
  corners.offset.resize(9ull * n);
  corners.length.assign(9ull * n, 4);
  for (std::uint32_t t = 0; t < n; ++t) {
    for (int k = 0; k < 9; ++k) {
      const std::size_t off = 84 + 50ull * t + 12 + 4ull * k;
      float f;
      std::memcpy(&f, bytes.data() + off, 4);
      corners.xyz[9ull * t + k] = f;
      corners.offset[9ull * t + k] = off;
    }
    check_finite(&corners.xyz[9ull * t], t, name, 0);
    check_finite(&corners.xyz[9ull * t + 3], t, name, 0);
    check_finite(&corners.xyz[9ull * t + 6], t, name, 0);
  }
  return corners;
}

Corners read_ascii_corners(const std::string& bytes, const std::string& name) {
  LineScanner lines(bytes);
  std::vector<Token> tokens;
  std::string_view line;
  Corners corners;
  int in_facet = -1;  // corners seen in the open facet, -1 outside a facet
  std::size_t facets = 0;
  while (lines.next(line)) {
    tokenize(line, lines.line_offset(), tokens);
    if (tokens.empty()) continue;
    const std::string_view key = tokens[0].text;
    const std::size_t ln = lines.line_number();
    if (key == "solid" || key == "endsolid" || key == "outer" || key == "endloop") continue;
    if (key == "facet") {
      if (in_facet >= 0) fail(name, ln, fmt::format("facet {} is not closed by endfacet", facets));
      in_facet = 0;
    } else if (key == "vertex") {
      if (in_facet < 0) fail(name, ln, "vertex outside a facet");
      if (in_facet == 3) fail(name, ln, fmt::format("facet {} has more than 3 vertices", facets));
      if (tokens.size() < 4)
        fail(name, ln, fmt::format("facet {}: vertex needs 3 coordinates", facets));
      for (int a = 1; a <= 3; ++a) {
        double x = 0;
        if (!parse_double(tokens[a].text, x))
          fail(name, ln,
               fmt::format("facet {}: expected a number, found {}", facets, quote(tokens[a].text)));
        if (!std::isfinite(x))
          fail(name, ln,
               fmt::format("facet {}: coordinate {} is not finite", facets, quote(tokens[a].text)));
        if (tokens[a].text.size() > kMaxCoordinateText)
          fail(name, ln,
               fmt::format("facet {}: a coordinate of {} characters (at most {})", facets,
                           tokens[a].text.size(), kMaxCoordinateText));
        corners.xyz.push_back(x);
        corners.offset.push_back(tokens[a].offset);
        corners.length.push_back(static_cast<std::uint16_t>(tokens[a].text.size()));
      }
      ++in_facet;
    } else if (key == "endfacet") {
      if (in_facet != 3)
        fail(name, ln,
             fmt::format("facet {} has {} vertices, not 3", facets, std::max(in_facet, 0)));
      in_facet = -1;
      ++facets;
    } else {
      fail(name, ln, fmt::format("unknown keyword {}", quote(key)));
    }
  }
  if (in_facet >= 0)
    fail(name, lines.line_number(), fmt::format("the file ends inside facet {}", facets));
  return corners;
}

bool looks_ascii(const std::string& bytes) {
  std::size_t i = bom_length(bytes);
  while (i < bytes.size() && std::isspace(static_cast<unsigned char>(bytes[i]))) ++i;
  return bytes.compare(i, 5, "solid") == 0;
}

}  // namespace

void weld_vertices(Parsed& parsed, double tolerance) {
  const std::size_t nv = parsed.xyz.size() / 3;
  std::vector<std::uint8_t> used(nv, 0);
  for (const int i : parsed.faces.indices) used[static_cast<std::size_t>(i)] = 1;
  const bool all_used = std::all_of(used.begin(), used.end(), [](std::uint8_t u) { return u; });
  // The referenced vertices' positions (all of them, for STL's corners) go to weld().
  std::vector<double> referenced;
  if (!all_used)
    for (std::size_t i = 0; i < nv; ++i)
      if (used[i]) referenced.insert(referenced.end(), &parsed.xyz[3 * i], &parsed.xyz[3 * i + 3]);
  std::vector<int> first;
  const std::vector<int> cluster = weld(all_used ? parsed.xyz : referenced, tolerance, first);
  // New numbers in order of first appearance: a cluster takes its first member's position;
  // unreferenced vertices stay as they are.
  std::vector<double> xyz;
  auto add = [&](std::size_t i) {
    xyz.insert(xyz.end(), &parsed.xyz[3 * i], &parsed.xyz[3 * i + 3]);
    return static_cast<int>(xyz.size() / 3 - 1);
  };
  std::vector<int> number_of_cluster(first.size(), -1), new_index(nv);
  std::size_t r = 0;
  for (std::size_t i = 0; i < nv; ++i) {
    if (!used[i]) {
      new_index[i] = add(i);
      continue;
    }
    int& number = number_of_cluster[static_cast<std::size_t>(cluster[r++])];
    if (number < 0) number = add(i);
    new_index[i] = number;
  }
  for (int& i : parsed.faces.indices) i = new_index[static_cast<std::size_t>(i)];
  for (CoordSlot& slot : parsed.slots)
    slot.vertex = new_index[static_cast<std::size_t>(slot.vertex)];
  parsed.xyz = std::move(xyz);
}

Mesh read_stl(const std::string& bytes, std::string* image_bytes, const std::string& name,
              const ReadOptions& options) {
  // A binary file's size is 84 + 50 n; some binary headers start with "solid" too.
  bool binary = false;
  if (bytes.size() >= 84) {
    std::uint32_t n = 0;
    std::memcpy(&n, bytes.data() + 80, 4);
    binary = 84 + 50ull * n == bytes.size() || !looks_ascii(bytes);
  } else if (!looks_ascii(bytes)) {
    fail(name, 0,
         fmt::format("too short for a binary STL ({} bytes) and not ascii STL", bytes.size()));
  }
  Corners corners = binary ? read_binary_corners(bytes, name) : read_ascii_corners(bytes, name);
  // Every corner a vertex of its own; assemble() welds them.
  Parsed parsed;
  parsed.xyz = std::move(corners.xyz);
  std::vector<int> corner(parsed.xyz.size() / 3);
  std::iota(corner.begin(), corner.end(), 0);
  parsed.faces = triangles_of_corners(std::move(corner));
  parsed.slots.resize(parsed.xyz.size());
  for (std::size_t k = 0; k < parsed.xyz.size(); ++k)
    parsed.slots[k] = {corners.offset[k],
                       corners.length[k],
                       static_cast<std::int32_t>(k / 3),
                       static_cast<std::uint8_t>(k % 3),
                       binary ? SlotType::Float32 : SlotType::Text,
                       false};
  const Encoding encoding = binary ? Encoding::BinaryLittleEndian : Encoding::Ascii;
  return assemble(std::move(parsed), image_bytes, FileFormat::Stl, encoding, name, options);
}

std::string write_stl(const Mesh& mesh, Encoding encoding) {
  const Eigen::MatrixX3i& F = mesh.F;
  auto normal = [&](Eigen::Index t) {
    const Eigen::RowVector3d a = mesh.V.row(F(t, 0)), b = mesh.V.row(F(t, 1)),
                             c = mesh.V.row(F(t, 2));
    const Eigen::RowVector3d n = (b - a).cross(c - a);
    const double len = n.norm();
    return len > 0 ? Eigen::RowVector3d(n / len) : Eigen::RowVector3d::Zero();
  };
  if (encoding == Encoding::Ascii) {
    std::string out = "solid meshmark\n";
    for (Eigen::Index t = 0; t < F.rows(); ++t) {
      const Eigen::RowVector3d n = normal(t);
      out += "facet normal ";
      out += fmt::format("{} {} {}", n.x(), n.y(), n.z());
      out += "\n outer loop\n";
      for (int c = 0; c < 3; ++c) {
        out += "  vertex ";
        append_position(out, mesh.V, F(t, c));
        out += '\n';
      }
      out += " endloop\nendfacet\n";
    }
    out += "endsolid meshmark\n";
    return out;
  }
  std::string out(84 + 50 * static_cast<std::size_t>(F.rows()), '\0');
  std::memcpy(out.data(), "binary STL written by meshmark", 30);
  const auto n = static_cast<std::uint32_t>(F.rows());
  std::memcpy(out.data() + 80, &n, 4);
  for (Eigen::Index t = 0; t < F.rows(); ++t) {
    char* rec = out.data() + 84 + 50 * t;
    const Eigen::RowVector3d nn = normal(t);
    for (int a = 0; a < 3; ++a) write_scalar(rec + 4 * a, SlotType::Float32, false, nn(a));
    for (int c = 0; c < 3; ++c)
      for (int a = 0; a < 3; ++a)
        write_scalar(rec + 12 + 12 * c + 4 * a, SlotType::Float32, false, mesh.V(F(t, c), a));
  }
  return out;
}

}  // namespace meshmark::detail
