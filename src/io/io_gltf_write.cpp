// glTF 2.0 writing: positions patched into the source's own buffers (every other byte kept but
// the accessors' min/max and, for re-encoded meshopt data, byte offsets and lengths), or a new
// file with positions and triangles alone.

#include <nlohmann/json.hpp>

#include <Eigen/LU>
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <set>

#include <fmt/format.h>
#include <meshoptimizer.h>

#include "io/gltf_internal.h"
#include "io/io_formats.h"
#include "io/json_spans.h"
#include "meshmark/core/error.h"

namespace meshmark::detail {

namespace {

std::size_t round4(std::size_t n) {
  return (n + 3) / 4 * 4;
}

// A file name as a URI path segment: bytes other than letters, digits and -._~ as %XX.
std::string percent_encode(std::string_view name) {
  std::string out;
  for (const char c : name) {
    const auto u = static_cast<unsigned char>(c);
    if (std::isalnum(u) || c == '-' || c == '.' || c == '_' || c == '~')
      out += c;
    else
      out += fmt::format("%{:02X}", u);
  }
  return out;
}

void put_u32(std::string& out, std::uint32_t v) {
  char b[4];
  std::memcpy(b, &v, 4);
  out.append(b, 4);
}

// Shortest text that reads back as the same float (min/max of float accessors must equal the
// data as stored) or as the same integer.
std::string number_text(double v, int component) {
  char buf[64];
  const auto r = component == kGltfFloat
                     ? std::to_chars(buf, buf + sizeof buf, static_cast<float>(v))
                     : std::to_chars(buf, buf + sizeof buf, static_cast<long long>(v));
  return std::string(buf, r.ptr);
}

std::string glb(std::string json, const std::string& bin, std::size_t bin_padding) {
  json.append(round4(json.size()) - json.size(), ' ');
  const std::size_t bin_chunk = bin.empty() ? 0 : round4(bin.size() + bin_padding);
  std::string out;
  out.reserve(28 + json.size() + bin_chunk);
  put_u32(out, 0x46546C67);
  put_u32(out, 2);
  put_u32(out,
          static_cast<std::uint32_t>(12 + 8 + json.size() + (bin.empty() ? 0 : 8 + bin_chunk)));
  put_u32(out, static_cast<std::uint32_t>(json.size()));
  put_u32(out, 0x4E4F534A);
  out += json;
  if (!bin.empty()) {
    put_u32(out, static_cast<std::uint32_t>(bin_chunk));
    put_u32(out, 0x004E4942);
    out += bin;
    out.append(bin_chunk - bin.size(), '\0');
  }
  return out;
}

// A file with the positions and triangles alone: float32 positions, uint32 indices, one node.
std::string write_new(const Mesh& mesh, FileFormat format) {
  std::string bin;
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    for (int c = 0; c < 3; ++c) {
      const auto f = static_cast<float>(mesh.V(i, c));
      if (!std::isfinite(f))
        throw InvalidArgumentError(
            fmt::format("{}: vertex {} does not fit in float32, which glTF stores",
                        mesh.source_path.empty() ? "the mesh" : mesh.source_path, i));
      bin.append(reinterpret_cast<const char*>(&f), 4);
      lo[c] = std::min(lo[c], static_cast<double>(f));
      hi[c] = std::max(hi[c], static_cast<double>(f));
    }
  const std::size_t index_offset = bin.size();
  for (Eigen::Index t = 0; t < mesh.F.rows(); ++t)
    for (int c = 0; c < 3; ++c) put_u32(bin, static_cast<std::uint32_t>(mesh.F(t, c)));
  using Json = nlohmann::ordered_json;
  Json doc;
  doc["asset"] = {{"version", "2.0"}, {"generator", "meshmark"}};
  doc["scene"] = 0;
  doc["scenes"] = Json::array({{{"nodes", {0}}}});
  doc["nodes"] = Json::array({{{"mesh", 0}}});
  doc["meshes"] = Json::array(
      {{{"primitives",
         Json::array({{{"attributes", {{"POSITION", 0}}}, {"indices", 1}, {"mode", 4}}})}}});
  Json min = Json::array(), max = Json::array();
  for (int c = 0; c < 3; ++c) {
    min.push_back(static_cast<float>(mesh.V.rows() ? lo[c] : 0));
    max.push_back(static_cast<float>(mesh.V.rows() ? hi[c] : 0));
  }
  doc["accessors"] = Json::array({{{"bufferView", 0},
                                   {"componentType", kGltfFloat},
                                   {"count", mesh.V.rows()},
                                   {"type", "VEC3"},
                                   {"min", min},
                                   {"max", max}},
                                  {{"bufferView", 1},
                                   {"componentType", kGltfUnsignedInt},
                                   {"count", 3 * mesh.F.rows()},
                                   {"type", "SCALAR"}}});
  doc["bufferViews"] = Json::array(
      {{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", index_offset}, {"target", 34962}},
       {{"buffer", 0},
        {"byteOffset", index_offset},
        {"byteLength", bin.size() - index_offset},
        {"target", 34963}}});
  Json buffer = {{"byteLength", bin.size()}};
  if (format == FileFormat::Gltf)
    buffer["uri"] = "data:application/octet-stream;base64," + base64_encode(bin);
  doc["buffers"] = Json::array({buffer});
  const std::string json = doc.dump();
  return format == FileFormat::Glb ? glb(json, bin, 0) : json;
}

struct Patch {
  const Mesh& mesh;
  const FileImage& image;
  const GltfImage& g;
  std::vector<std::string> buffers;        // patched copies
  std::vector<std::string> views;          // patched decoded bytes of compressed views
  std::vector<std::uint8_t> view_changed;  // compressed views to re-encode
  std::vector<std::uint8_t> accessor_changed;
  bool float_positions = false;
  struct Converted {
    int accessor, buffer;
    std::string floats;  // count x 3 float32, local
    double lo[3], hi[3];
  };
  std::vector<Converted> converted;                  // quantized accessors stored as float32
  std::vector<std::vector<double>> draco_positions;  // per Draco primitive, local, 3 per point
  std::vector<std::uint8_t> draco_changed;

  std::string& view_data(int v) {
    const GltfView& view = g.views[static_cast<std::size_t>(v)];
    return view.compressed ? views[static_cast<std::size_t>(v)]
                           : buffers[static_cast<std::size_t>(view.buffer)];
  }
  std::size_t view_start(int v) const {
    const GltfView& view = g.views[static_cast<std::size_t>(v)];
    return view.compressed ? 0 : view.offset;
  }

  std::string where() const { return mesh.source_path.empty() ? "the mesh" : mesh.source_path; }

  // The world position file vertex f must take (homogeneous, in w): its position as read moved
  // by the displacement of the mesh vertex it was welded into. False when that did not move.
  bool world_now(std::size_t f, Eigen::Vector4d& w) const {
    const Eigen::Index row = image.slots[f].vertex;
    bool moved = false;
    w = Eigen::Vector4d(0, 0, 0, 1);
    for (int c = 0; c < 3; ++c) {
      const double now = mesh.V(row, c), then = image.V(row, c);
      const bool same = now == then && std::signbit(now) == std::signbit(then);
      const double original =
          g.world_as_read.empty() ? then : g.world_as_read[3 * f + static_cast<std::size_t>(c)];
      w[c] = same ? original : original + (now - then);
      moved |= !same;
    }
    return moved;
  }

  void positions() {
    for (const GltfInstance& inst : g.instances) {
      const Eigen::Matrix4d inverse = inst.world.inverse();
      const std::size_t csize = gltf_component_size(inst.component);
      char* base = inst.draco >= 0
                       ? nullptr
                       : view_data(inst.view).data() + view_start(inst.view) + inst.offset;
      if (float_positions && inst.draco < 0 && inst.component != kGltfFloat) {
        to_float(inst, inverse, base);
        continue;
      }
      for (std::size_t k = 0; k < inst.count; ++k) {
        const std::size_t f = inst.first + k;
        Eigen::Vector4d w;
        const bool moved = world_now(f, w);
        if (!moved) continue;
        const Eigen::Vector4d local = inverse * w;
        if (inst.draco >= 0) {
          const auto d = static_cast<std::size_t>(inst.draco);
          for (int c = 0; c < 3; ++c)
            draco_positions[d][3 * k + static_cast<std::size_t>(c)] = local[c];
          draco_changed[d] = 1;
          continue;
        }
        for (int c = 0; c < 3; ++c)
          if (!gltf_store_component(base + k * inst.stride + static_cast<std::size_t>(c) * csize,
                                    inst.component, inst.normalized, local[c]))
            throw InvalidArgumentError(fmt::format(
                "{}: vertex {} of accessors[{}] moves to {} in its local frame, which its "
                "component type {}{} cannot store",
                where(), k, inst.accessor, local[c], inst.component,
                inst.normalized ? " (normalized)" : ""));
        accessor_changed[static_cast<std::size_t>(inst.accessor)] = 1;
        if (g.views[static_cast<std::size_t>(inst.view)].compressed)
          view_changed[static_cast<std::size_t>(inst.view)] = 1;
      }
    }
  }

  // A quantized instance stored as float32: moved vertices at their new local position, the
  // others at their exact dequantized value.
  void to_float(const GltfInstance& inst, const Eigen::Matrix4d& inverse, const char* base) {
    const GltfView& view = g.views[static_cast<std::size_t>(inst.view)];
    Converted c{inst.accessor, view.compressed ? view.meshopt.buffer : view.buffer, {}, {}, {}};
    for (int a = 0; a < 3; ++a) {
      c.lo[a] = std::numeric_limits<double>::infinity();
      c.hi[a] = -c.lo[a];
    }
    const std::size_t csize = gltf_component_size(inst.component);
    c.floats.reserve(12 * inst.count);
    for (std::size_t k = 0; k < inst.count; ++k) {
      Eigen::Vector4d local(0, 0, 0, 1);
      for (int a = 0; a < 3; ++a)
        local[a] =
            gltf_component_value(base + k * inst.stride + static_cast<std::size_t>(a) * csize,
                                 inst.component, inst.normalized);
      Eigen::Vector4d w;
      const bool moved = world_now(inst.first + k, w);
      if (moved) local = inverse * w;
      for (int a = 0; a < 3; ++a) {
        const auto f = static_cast<float>(local[a]);
        if (!std::isfinite(f))
          throw InvalidArgumentError(fmt::format(
              "{}: vertex {} of accessors[{}] does not fit in float32", where(), k, inst.accessor));
        c.floats.append(reinterpret_cast<const char*>(&f), 4);
        c.lo[a] = std::min(c.lo[a], static_cast<double>(f));
        c.hi[a] = std::max(c.hi[a], static_cast<double>(f));
      }
    }
    converted.push_back(std::move(c));
  }

  // Appends the float32 views and points the converted accessors at them.
  void append_floats(const std::unordered_map<std::string, JsonSpan>& spans,
                     std::vector<JsonEdit>& edits) {
    if (converted.empty()) return;
    const nlohmann::json doc = nlohmann::json::parse(g.json);
    std::string views_text;
    std::set<int> grown;
    for (std::size_t i = 0; i < converted.size(); ++i) {
      const Converted& c = converted[i];
      std::string& buffer = buffers[static_cast<std::size_t>(c.buffer)];
      buffer.append(round4(buffer.size()) - buffer.size(), '\0');
      views_text +=
          fmt::format(",{{\"buffer\":{},\"byteOffset\":{},\"byteLength\":{},\"target\":34962}}",
                      c.buffer, buffer.size(), c.floats.size());
      buffer += c.floats;
      grown.insert(c.buffer);
      nlohmann::ordered_json acc = nlohmann::ordered_json::parse(
          doc["accessors"][static_cast<std::size_t>(c.accessor)].dump());
      acc["bufferView"] = g.views.size() + i;
      acc.erase("byteOffset");
      acc.erase("normalized");
      acc["componentType"] = kGltfFloat;
      acc["min"] = {static_cast<float>(c.lo[0]), static_cast<float>(c.lo[1]),
                    static_cast<float>(c.lo[2])};
      acc["max"] = {static_cast<float>(c.hi[0]), static_cast<float>(c.hi[1]),
                    static_cast<float>(c.hi[2])};
      edits.push_back({spans.at(fmt::format("/accessors/{}", c.accessor)), acc.dump()});
    }
    const JsonSpan list = spans.at("/bufferViews");
    edits.push_back({{list.end - 1, list.end - 1}, views_text});
    for (const int b : grown) {
      const JsonSpan length = spans.at(fmt::format("/buffers/{}/byteLength", b));
      std::erase_if(edits, [&](const JsonEdit& e) { return e.span.begin == length.begin; });
      edits.push_back({length, std::to_string(buffers[static_cast<std::size_t>(b)].size())});
    }
    // KHR_mesh_quantization stays declared while some vertex attribute is still not float.
    std::set<int> now_float;
    for (const Converted& c : converted) now_float.insert(c.accessor);
    bool needed = false;
    for (const auto& m : doc.value("meshes", nlohmann::json::array()))
      for (const auto& p : m.value("primitives", nlohmann::json::array())) {
        std::vector<nlohmann::json> sets = {p.value("attributes", nlohmann::json::object())};
        for (const auto& t : p.value("targets", nlohmann::json::array())) sets.push_back(t);
        for (const auto& set : sets)
          for (const auto& [name, a] : set.items())
            if (a.is_number_unsigned() && !now_float.count(a.get<int>()) &&
                doc["accessors"][a.get<std::size_t>()].value("componentType", kGltfFloat) !=
                    kGltfFloat)
              needed = true;
      }
    if (!needed)
      for (const char* list_name : {"extensionsUsed", "extensionsRequired"})
        drop_extension(doc, spans, edits, list_name);
  }

  // Removes KHR_mesh_quantization from the root list `key`, or the whole member when it was
  // the list's only entry (an empty extensionsRequired is not allowed).
  void drop_extension(const nlohmann::json& doc,
                      const std::unordered_map<std::string, JsonSpan>& spans,
                      std::vector<JsonEdit>& edits, const char* key) const {
    const auto it = spans.find(std::string("/") + key);
    if (it == spans.end() || !doc.contains(key)) return;
    nlohmann::json rest = nlohmann::json::array();
    for (const auto& e : doc[key])
      if (e != "KHR_mesh_quantization") rest.push_back(e);
    if (rest.size() == doc[key].size()) return;
    if (!rest.empty()) {
      edits.push_back({it->second, rest.dump()});
      return;
    }
    // The member "key": [...] and one comma beside it.
    const std::string quoted = std::string("\"") + key + "\"";
    std::size_t begin = g.json.rfind(quoted, it->second.begin);
    std::size_t end = it->second.end;
    std::size_t after = end;
    while (after < g.json.size() && std::isspace(static_cast<unsigned char>(g.json[after])))
      ++after;
    if (after < g.json.size() && g.json[after] == ',') {
      end = after + 1;
    } else {
      std::size_t before = begin;
      while (before > 0 && std::isspace(static_cast<unsigned char>(g.json[before - 1]))) --before;
      if (before > 0 && g.json[before - 1] == ',') begin = before - 1;
    }
    edits.push_back({{begin, end}, ""});
  }

  // min and max of every changed POSITION accessor, as the JSON holds them.
  void bounds(const std::unordered_map<std::string, JsonSpan>& spans,
              std::vector<JsonEdit>& edits) {
    for (const GltfInstance& inst : g.instances) {
      const auto a = static_cast<std::size_t>(inst.accessor);
      if (!accessor_changed[a]) continue;
      accessor_changed[a] = 0;  // once per accessor
      const std::size_t csize = gltf_component_size(inst.component);
      const char* base = view_data(inst.view).data() + view_start(inst.view) + inst.offset;
      double lo[3], hi[3];
      for (int c = 0; c < 3; ++c) {
        lo[c] = std::numeric_limits<double>::infinity();
        hi[c] = -lo[c];
      }
      for (std::size_t k = 0; k < inst.count; ++k)
        for (int c = 0; c < 3; ++c) {
          // Raw component values: glTF's min/max of normalized integers are the integers.
          const double v = gltf_component_value(
              base + k * inst.stride + static_cast<std::size_t>(c) * csize, inst.component, false);
          lo[c] = std::min(lo[c], v);
          hi[c] = std::max(hi[c], v);
        }
      for (const auto& [key, values] : {std::pair{"min", lo}, std::pair{"max", hi}}) {
        const auto it = spans.find(fmt::format("/accessors/{}/{}", a, key));
        if (it == spans.end()) continue;
        edits.push_back(
            {it->second, fmt::format("[{},{},{}]", number_text(values[0], inst.component),
                                     number_text(values[1], inst.component),
                                     number_text(values[2], inst.component))});
      }
    }
  }

  using Spans = std::unordered_map<std::string, JsonSpan>;

  // New bytes for a buffer view: where the old ones were, and the JSON member of its length.
  struct Replacement {
    int buffer;
    std::size_t offset, length;
    std::string bytes;
    std::string length_pointer;
  };

  // An edit of the JSON member at `pointer`; one that is absent is an error unless
  // may_be_absent (an absent byteOffset stays 0).
  void edit(const Spans& spans, std::vector<JsonEdit>& edits, const std::string& pointer,
            const std::string& value, bool may_be_absent) const {
    const auto it = spans.find(pointer);
    if (it == spans.end()) {
      if (may_be_absent) return;
      throw InvalidArgumentError(fmt::format("{}: cannot place {} in the JSON", where(), pointer));
    }
    edits.push_back({it->second, value});
  }

  // Re-encodes changed meshopt views and Draco primitives, puts the new bytes where the old
  // were, and moves what follows them in their buffers (by the change of the 4-byte-aligned
  // lengths, so every view keeps its alignment and its place relative to its neighbours).
  void recompress(const Spans& spans, std::vector<JsonEdit>& edits) {
    std::vector<Replacement> replacements = meshopt_replacements();
    add_draco_replacements(spans, edits, replacements);
    if (!replacements.empty()) splice(std::move(replacements), spans, edits);
  }

  // The changed meshopt views encoded again (unfiltered attributes only).
  std::vector<Replacement> meshopt_replacements() const {
    std::vector<Replacement> replacements;
    for (std::size_t v = 0; v < g.views.size(); ++v) {
      if (!view_changed[v]) continue;
      const GltfMeshopt& m = g.views[v].meshopt;
      if (m.mode != "ATTRIBUTES" || m.filter != "NONE")
        throw InvalidArgumentError(fmt::format(
            "{}: bufferViews[{}] is meshopt-compressed with filter {}; meshmark re-encodes "
            "unfiltered attributes only",
            where(), v, m.filter));
      meshopt_encodeVertexVersion(0);
      std::string out(meshopt_encodeVertexBufferBound(m.count, m.stride), '\0');
      const std::size_t n =
          meshopt_encodeVertexBuffer(reinterpret_cast<unsigned char*>(out.data()), out.size(),
                                     views[v].data(), m.count, m.stride);
      if (n == 0) throw InvalidArgumentError(fmt::format("{}: meshopt encoding failed", where()));
      out.resize(n);
      replacements.push_back(
          {m.buffer, m.offset, m.length, std::move(out),
           fmt::format("/bufferViews/{}/extensions/EXT_meshopt_compression/byteLength", v)});
    }
    return replacements;
  }

  // The changed Draco primitives encoded again, and the accessors' counts, min and max set to
  // what a reader will decode from them.
  void add_draco_replacements(const Spans& spans, std::vector<JsonEdit>& edits,
                              std::vector<Replacement>& replacements) const {
    for (std::size_t d = 0; d < g.dracos.size(); ++d) {
      if (!draco_changed[d]) continue;
      const GltfDraco& dm = g.dracos[d];
      std::string out = encode_draco(dm.mesh, draco_positions[d]);
      // What a reader will decode: its points and triangles set the accessors' counts, its
      // positions the POSITION accessor's min and max.
      const DracoMesh back = decode_draco(out, where());
      const std::size_t points = back.positions.size() / 3;
      for (const int a : dm.attribute_accessors)
        if (g.accessor_counts[static_cast<std::size_t>(a)] != points)
          edit(spans, edits, fmt::format("/accessors/{}/count", a), std::to_string(points), false);
      if (dm.indices_accessor >= 0 &&
          g.accessor_counts[static_cast<std::size_t>(dm.indices_accessor)] != back.triangles.size())
        edit(spans, edits, fmt::format("/accessors/{}/count", dm.indices_accessor),
             std::to_string(back.triangles.size()), false);
      double lo[3], hi[3];
      for (int c = 0; c < 3; ++c) {
        lo[c] = std::numeric_limits<double>::infinity();
        hi[c] = -lo[c];
      }
      for (std::size_t k = 0; k < points; ++k)
        for (int c = 0; c < 3; ++c) {
          lo[c] = std::min(lo[c], back.positions[3 * k + static_cast<std::size_t>(c)]);
          hi[c] = std::max(hi[c], back.positions[3 * k + static_cast<std::size_t>(c)]);
        }
      for (const auto& [key, values] : {std::pair{"min", lo}, std::pair{"max", hi}})
        edit(spans, edits, fmt::format("/accessors/{}/{}", dm.position_accessor, key),
             fmt::format("[{},{},{}]", number_text(values[0], kGltfFloat),
                         number_text(values[1], kGltfFloat), number_text(values[2], kGltfFloat)),
             true);
      const GltfView& view = g.views[static_cast<std::size_t>(dm.view)];
      replacements.push_back({view.buffer, view.offset, view.length, std::move(out),
                              fmt::format("/bufferViews/{}/byteLength", dm.view)});
    }
  }

  // Puts each replacement's bytes in its buffer (padded to 4 bytes), moves what follows, and
  // edits the lengths and offsets that changed.
  void splice(std::vector<Replacement> replacements, const Spans& spans,
              std::vector<JsonEdit>& edits) {
    std::sort(replacements.begin(), replacements.end(),
              [](const Replacement& x, const Replacement& y) {
                return std::pair(x.buffer, x.offset) < std::pair(y.buffer, y.offset);
              });
    struct Shift {
      int buffer;
      std::size_t at;  // offsets at or past this (in the source) move by delta
      std::int64_t delta;
    };
    std::vector<Shift> shifts;
    auto moved = [&](int buffer, std::size_t offset) {
      std::int64_t o = static_cast<std::int64_t>(offset);
      for (const Shift& sh : shifts)
        if (sh.buffer == buffer && offset >= sh.at) o += sh.delta;
      return static_cast<std::size_t>(o);
    };
    for (Replacement& r : replacements) {
      std::string& buffer = buffers[static_cast<std::size_t>(r.buffer)];
      const std::size_t at = moved(r.buffer, r.offset);
      const std::size_t old_span = std::min(round4(r.length), buffer.size() - at);
      const std::size_t n = r.bytes.size();
      r.bytes.append(round4(n) - n, '\0');
      buffer.replace(at, old_span, r.bytes);
      shifts.push_back(
          {r.buffer, r.offset + r.length,
           static_cast<std::int64_t>(r.bytes.size()) - static_cast<std::int64_t>(old_span)});
      edit(spans, edits, r.length_pointer, std::to_string(n), false);
    }
    for (std::size_t v = 0; v < g.views.size(); ++v) {
      const GltfView& view = g.views[v];
      if (view.compressed) {
        const GltfMeshopt& m = view.meshopt;
        if (moved(m.buffer, m.offset) != m.offset)
          edit(spans, edits,
               fmt::format("/bufferViews/{}/extensions/EXT_meshopt_compression/byteOffset", v),
               std::to_string(moved(m.buffer, m.offset)), m.offset == 0);
      }
      if (g.buffers[static_cast<std::size_t>(view.buffer)].kind != GltfBuffer::Kind::Fallback &&
          moved(view.buffer, view.offset) != view.offset)
        edit(spans, edits, fmt::format("/bufferViews/{}/byteOffset", v),
             std::to_string(moved(view.buffer, view.offset)), view.offset == 0);
    }
    for (std::size_t b = 0; b < g.buffers.size(); ++b)
      if (buffers[b].size() != g.buffers[b].data.size())
        edit(spans, edits, fmt::format("/buffers/{}/byteLength", b),
             std::to_string(buffers[b].size()), false);
  }
};

}  // namespace

std::string write_gltf(const Mesh& mesh, FileFormat format, const WriteOptions& options,
                       const std::string& resource_stem,
                       std::map<std::string, std::string>* resources) {
  const FileImage* image = mesh.image.get();
  const auto* g = image ? dynamic_cast<const GltfImage*>(image->extra.get()) : nullptr;
  const bool applies =
      options.keep_source && g && image->format == format && same_connectivity(*image, mesh);
  if (!applies) return write_new(mesh, format);

  Patch p{mesh, *image, *g, {}, {}, {}, {}, false, {}, {}, {}};
  for (const GltfBuffer& b : g->buffers) p.buffers.emplace_back(b.data);
  for (const GltfView& v : g->views) p.views.push_back(v.decoded);
  p.view_changed.assign(g->views.size(), 0);
  p.float_positions = options.float_positions;
  for (const GltfDraco& d : g->dracos) p.draco_positions.push_back(d.mesh.positions);
  p.draco_changed.assign(g->dracos.size(), 0);
  p.accessor_changed.assign(g->accessor_counts.size(), 0);
  p.positions();
  const auto spans = json_spans(g->json, 5);
  std::vector<JsonEdit> edits;
  p.bounds(spans, edits);
  p.recompress(spans, edits);
  p.append_floats(spans, edits);

  if (format == FileFormat::Glb) {
    const bool same_layout =
        edits.empty() || std::all_of(p.buffers.begin(), p.buffers.end(),
                                     [&, b = std::size_t{0}](const std::string& s) mutable {
                                       return s.size() == g->buffers[b++].data.size();
                                     });
    std::string json = apply_json_edits(g->json, edits);
    const bool has_bin = !g->buffers.empty() && g->buffers[0].kind == GltfBuffer::Kind::GlbBin;
    // A JSON no longer than the source's is padded with spaces to its length (allowed after
    // the JSON text), so every byte after it stays in place.
    if (same_layout && json.size() <= g->json.size() && has_bin) {
      json.append(g->json.size() - json.size(), ' ');
      // The file as it was, with the JSON's and BIN chunk's bytes patched in place.
      std::string out = g->file;
      std::memcpy(out.data() + 20, json.data(), json.size());
      std::memcpy(out.data() + 28 + g->json.size(), p.buffers[0].data(), p.buffers[0].size());
      return out;
    }
    // The JSON changed length: a new container (padding bytes past the data are zeros).
    return glb(json, has_bin ? p.buffers[0] : std::string(), 0);
  }
  // .gltf: buffers as data URIs (patched) or files beside the output.
  for (std::size_t b = 0; b < g->buffers.size(); ++b) {
    const GltfBuffer& buffer = g->buffers[b];
    if (buffer.kind == GltfBuffer::Kind::Fallback) continue;
    const auto it = spans.find(fmt::format("/buffers/{}/uri", b));
    if (it == spans.end()) continue;
    std::string uri;
    if (buffer.kind == GltfBuffer::Kind::DataUri) {
      if (p.buffers[b] == buffer.data) continue;
      uri = buffer.uri.substr(0, buffer.uri.find(',') + 1) + base64_encode(p.buffers[b]);
    } else if (resources) {
      const std::string file = g->buffers.size() == 1 ? resource_stem + ".bin"
                                                      : fmt::format("{}_{}.bin", resource_stem, b);
      (*resources)[file] = p.buffers[b];
      uri = percent_encode(file);
    } else {
      uri = "data:application/octet-stream;base64," + base64_encode(p.buffers[b]);
    }
    edits.push_back({it->second, nlohmann::json(uri).dump()});
  }
  return apply_json_edits(g->json, edits);
}

std::vector<std::string> gltf_source_files(const Mesh& mesh) {
  std::vector<std::string> out;
  const auto* g = mesh.image ? dynamic_cast<const GltfImage*>(mesh.image->extra.get()) : nullptr;
  if (g)
    for (const GltfBuffer& b : g->buffers)
      if (b.kind == GltfBuffer::Kind::External) out.push_back(b.path);
  return out;
}

}  // namespace meshmark::detail
