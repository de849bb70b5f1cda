// glTF 2.0 reading (.gltf and .glb): the triangle primitives of the default scene in world space.
// The JSON is parsed with nlohmann::json (tinygltf 2.7, Debian's, refuses EXT_meshopt_compression's
// fallback buffers); buffers, views and accessors are checked here before any byte is read.

#include <nlohmann/json.hpp>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <map>
#include <set>
#include <tuple>

#include <fmt/format.h>
#include <meshoptimizer.h>

#include "io/gltf_internal.h"
#include "io/io_formats.h"
#include "meshmark/core/error.h"

namespace meshmark::detail {

std::size_t gltf_component_size(int component) {
  switch (component) {
    case kGltfByte:
    case kGltfUnsignedByte:
      return 1;
    case kGltfShort:
    case kGltfUnsignedShort:
      return 2;
    case kGltfUnsignedInt:
    case kGltfFloat:
      return 4;
    default:
      return 0;
  }
}

double gltf_component_value(const char* data, int component, bool normalized) {
  switch (component) {
    case kGltfByte: {
      const double v = static_cast<std::int8_t>(*data);
      return normalized ? std::max(v / 127.0, -1.0) : v;
    }
    case kGltfUnsignedByte: {
      const double v = static_cast<std::uint8_t>(*data);
      return normalized ? v / 255.0 : v;
    }
    case kGltfShort: {
      std::int16_t s;
      std::memcpy(&s, data, 2);
      return normalized ? std::max(s / 32767.0, -1.0) : s;
    }
    case kGltfUnsignedShort: {
      std::uint16_t s;
      std::memcpy(&s, data, 2);
      return normalized ? s / 65535.0 : s;
    }
    case kGltfUnsignedInt: {
      std::uint32_t u;
      std::memcpy(&u, data, 4);
      return u;
    }
    default: {
      float f;
      std::memcpy(&f, data, 4);
      return f;
    }
  }
}

bool gltf_store_component(char* data, int component, bool normalized, double value) {
  if (!std::isfinite(value)) return false;
  auto integer = [&](double scale, double lo, double hi, auto tag) {
    const double q = std::clamp(std::nearbyint(normalized ? value * scale : value), lo, hi);
    const auto v = static_cast<decltype(tag)>(q);
    std::memcpy(data, &v, sizeof v);
    return true;
  };
  switch (component) {
    case kGltfByte:
      return integer(127.0, -127, 127, std::int8_t{});
    case kGltfUnsignedByte:
      return integer(255.0, 0, 255, std::uint8_t{});
    case kGltfShort:
      return integer(32767.0, -32767, 32767, std::int16_t{});
    case kGltfUnsignedShort:
      return integer(65535.0, 0, 65535, std::uint16_t{});
    case kGltfFloat: {
      const auto f = static_cast<float>(value);
      if (!std::isfinite(f)) return false;
      std::memcpy(data, &f, 4);
      return true;
    }
    default:
      return false;
  }
}

std::string base64_encode(std::string_view bytes) {
  static constexpr char kDigits[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const auto n = static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[i])) << 16 |
                   static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[i + 1])) << 8 |
                   static_cast<unsigned char>(bytes[i + 2]);
    for (int s = 18; s >= 0; s -= 6) out += kDigits[n >> s & 63];
  }
  if (i < bytes.size()) {
    std::uint32_t n = static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[i])) << 16;
    if (i + 1 < bytes.size())
      n |= static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[i + 1])) << 8;
    out += kDigits[n >> 18 & 63];
    out += kDigits[n >> 12 & 63];
    out += i + 1 < bytes.size() ? kDigits[n >> 6 & 63] : '=';
    out += '=';
  }
  return out;
}

namespace {

using Json = nlohmann::json;

constexpr std::uint32_t kGlbMagic = 0x46546C67;  // "glTF"
constexpr std::uint32_t kChunkJson = 0x4E4F534A;
constexpr std::uint32_t kChunkBin = 0x004E4942;
// Decoded meshopt data may be this many times its compressed size (plus 1 MiB), no more: the
// codec cannot compress further, so a larger declared size is a lie meant to exhaust memory.
constexpr std::size_t kMeshoptMaxRatio = 256;

std::uint32_t u32(const std::string& b, std::size_t at) {
  std::uint32_t v;
  std::memcpy(&v, b.data() + at, 4);
  return v;
}

// Decodes base64 (standard alphabet, padding optional); false on any other character.
bool base64_decode(std::string_view text, std::string& out) {
  auto digit = [](char c) -> int {
    if (c >= 'A' && c <= 'Z') return c - 'A';
    if (c >= 'a' && c <= 'z') return c - 'a' + 26;
    if (c >= '0' && c <= '9') return c - '0' + 52;
    if (c == '+') return 62;
    if (c == '/') return 63;
    return -1;
  };
  while (!text.empty() && text.back() == '=') text.remove_suffix(1);
  out.clear();
  out.reserve(text.size() * 3 / 4);
  std::uint32_t acc = 0;
  int bits = 0;
  for (const char c : text) {
    const int d = digit(c);
    if (d < 0) return false;
    acc = acc << 6 | static_cast<std::uint32_t>(d);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out += static_cast<char>(acc >> bits & 0xFF);
    }
  }
  return true;
}

std::string percent_decode(std::string_view uri) {
  std::string out;
  for (std::size_t i = 0; i < uri.size(); ++i) {
    if (uri[i] == '%' && i + 2 < uri.size() &&
        std::isxdigit(static_cast<unsigned char>(uri[i + 1])) &&
        std::isxdigit(static_cast<unsigned char>(uri[i + 2]))) {
      out += static_cast<char>(std::stoi(std::string(uri.substr(i + 1, 2)), nullptr, 16));
      i += 2;
    } else {
      out += uri[i];
    }
  }
  return out;
}

struct Reader {
  const std::string& name;
  const ReadOptions& options;
  Json doc;
  GltfImage& img;
  std::vector<std::string>& notes;

  [[noreturn]] void fail(const std::string& message) const { detail::fail(name, 0, message); }

  bool uses(const char* extension) const {
    for (const Json& e : array("extensionsUsed"))
      if (e.is_string() && e.get<std::string>() == extension) return true;
    return false;
  }
  const Json& array(const char* key) const {
    static const Json empty = Json::array();
    const auto it = doc.find(key);
    if (it == doc.end()) return empty;
    if (!it->is_array()) fail(fmt::format("'{}' is not an array", key));
    return *it;
  }
  // An unsigned integer member, or def when absent (required when def is negative).
  std::size_t size(const Json& object, const char* key, std::string_view where,
                   std::int64_t def = -1) const {
    const auto it = object.find(key);
    if (it == object.end()) {
      if (def < 0) fail(fmt::format("{}: '{}' is missing", where, key));
      return static_cast<std::size_t>(def);
    }
    if (!it->is_number_unsigned() && !(it->is_number_integer() && it->get<std::int64_t>() >= 0))
      fail(fmt::format("{}: '{}' is not a non-negative integer", where, key));
    const auto v = it->get<std::uint64_t>();
    if (v > (std::uint64_t{1} << 40))
      fail(fmt::format("{}: '{}' = {} is too large", where, key, v));
    return static_cast<std::size_t>(v);
  }
  int index(const Json& object, const char* key, std::string_view where, std::size_t count) const {
    const std::size_t i = size(object, key, where);
    if (i >= count)
      fail(fmt::format("{}: '{}' = {} names no element ({} exist)", where, key, i, count));
    return static_cast<int>(i);
  }

  void read_buffers(std::string_view bytes, bool binary, std::size_t bin_offset,
                    std::size_t bin_length) {
    const Json& buffers = array("buffers");
    img.buffers.resize(buffers.size());
    for (std::size_t i = 0; i < buffers.size(); ++i) {
      const Json& b = buffers[i];
      const std::string where = fmt::format("buffers[{}]", i);
      if (!b.is_object()) fail(where + " is not an object");
      const std::size_t length = size(b, "byteLength", where);
      GltfBuffer& out = img.buffers[i];
      const auto uri = b.find("uri");
      if (uri == b.end()) {
        const auto ext = b.find("extensions");
        if (binary && i == 0 && bin_length > 0) {
          if (length > bin_length || bin_length - length > 3)
            fail(fmt::format("{}: byteLength {} does not match the BIN chunk ({} bytes)", where,
                             length, bin_length));
          out.kind = GltfBuffer::Kind::GlbBin;
          out.data = bytes.substr(bin_offset, length);
          img.bin_chunk_padding = bin_length - length;
        } else if (ext != b.end() && ext->is_object() && ext->contains("EXT_meshopt_compression")) {
          out.kind = GltfBuffer::Kind::Fallback;
        } else {
          fail(where + " has no uri and no data");
        }
        continue;
      }
      if (!uri->is_string()) fail(where + ": 'uri' is not a string");
      out.uri = uri->get<std::string>();
      if (out.uri.starts_with("data:")) {
        const std::size_t comma = out.uri.find(',');
        if (comma == std::string::npos ||
            out.uri.substr(0, comma).find(";base64") == std::string::npos)
          fail(where + ": a data URI that is not base64");
        out.kind = GltfBuffer::Kind::DataUri;
        if (!base64_decode(std::string_view(out.uri).substr(comma + 1), out.own))
          fail(where + ": the data URI is not valid base64");
      } else {
        out.kind = GltfBuffer::Kind::External;
        out.own = external(percent_decode(out.uri), where);
        out.path = (std::filesystem::path(name).parent_path() / percent_decode(out.uri)).string();
      }
      if (out.own.size() < length)
        fail(fmt::format("{}: {} bytes where byteLength says {}", where, out.own.size(), length));
      out.own.resize(length);
      out.data = out.own;
    }
  }

  // An external buffer: a relative path below the file's folder, a regular file.
  std::string external(const std::string& uri, const std::string& where) const {
    const std::filesystem::path p(uri);
    if (uri.empty() || p.is_absolute() || uri.find(':') != std::string::npos ||
        uri.find('\0') != std::string::npos ||
        std::any_of(p.begin(), p.end(), [](const std::filesystem::path& c) { return c == ".."; }))
      fail(fmt::format("{}: uri '{}' is not a relative path below the file's folder", where, uri));
    if (options.resources) {
      const auto it = options.resources->find(uri);
      if (it != options.resources->end()) return it->second;
    }
    // Resolved with every symbolic link followed, the file must still lie below the folder:
    // a link planted beside an asset (buf.bin -> /etc/passwd) is not read into its copies.
    const std::filesystem::path folder = std::filesystem::path(name).parent_path();
    const std::filesystem::path path = folder / p;
    std::error_code ec, found;
    const std::filesystem::path base =
        std::filesystem::canonical(folder.empty() ? "." : folder, ec);
    const std::filesystem::path target = std::filesystem::canonical(path, found);
    if (!ec && !found) {
      const std::filesystem::path below = target.lexically_relative(base);
      if (below.empty() || *below.begin() == "..")
        fail(fmt::format("{}: uri '{}' leads out of the file's folder through a symbolic link",
                         where, uri));
    }
    try {
      return read_file(found ? path.string() : target.string(), std::size_t{1} << 32,
                       "glTF buffer");
    } catch (const IOError& e) {
      fail(fmt::format("{} (uri '{}'): {}", where, uri, e.what()));
    }
  }

  void read_views() {
    const Json& views = array("bufferViews");
    img.views.resize(views.size());
    for (std::size_t i = 0; i < views.size(); ++i) {
      const Json& v = views[i];
      const std::string where = fmt::format("bufferViews[{}]", i);
      if (!v.is_object()) fail(where + " is not an object");
      GltfView& out = img.views[i];
      out.buffer = index(v, "buffer", where, img.buffers.size());
      out.offset = size(v, "byteOffset", where, 0);
      out.length = size(v, "byteLength", where);
      out.stride = size(v, "byteStride", where, 0);
      const GltfBuffer& b = img.buffers[static_cast<std::size_t>(out.buffer)];
      const std::size_t declared =
          size(doc["buffers"][static_cast<std::size_t>(out.buffer)], "byteLength", "buffers");
      if (out.offset > declared || out.length > declared - out.offset)
        fail(fmt::format("{}: bytes {}..{} lie outside buffer {} ({} bytes)", where, out.offset,
                         out.offset + out.length, out.buffer, declared));
      if (out.stride != 0 && (out.stride < 4 || out.stride > 252))
        fail(fmt::format("{}: byteStride {} is outside [4, 252]", where, out.stride));
      const auto ext = v.find("extensions");
      if (ext != v.end() && ext->is_object() && ext->contains("EXT_meshopt_compression")) {
        read_meshopt((*ext)["EXT_meshopt_compression"], where, out);
      } else if (b.kind == GltfBuffer::Kind::Fallback) {
        fail(
            fmt::format("{}: its buffer {} holds no data (a meshopt fallback) and the view is "
                        "not compressed",
                        where, out.buffer));
      }
    }
  }

  void read_meshopt(const Json& e, const std::string& where, GltfView& out) const {
    const std::string w = where + ".EXT_meshopt_compression";
    if (!e.is_object()) fail(w + " is not an object");
    GltfMeshopt& m = out.meshopt;
    m.buffer = index(e, "buffer", w, img.buffers.size());
    m.offset = size(e, "byteOffset", w, 0);
    m.length = size(e, "byteLength", w);
    m.stride = size(e, "byteStride", w);
    m.count = size(e, "count", w);
    m.mode = e.value("mode", std::string());
    m.filter = e.value("filter", std::string("NONE"));
    const std::string_view src = img.buffers[static_cast<std::size_t>(m.buffer)].data;
    if (img.buffers[static_cast<std::size_t>(m.buffer)].kind == GltfBuffer::Kind::Fallback)
      fail(w + ": the compressed data is in a fallback buffer");
    if (m.offset > src.size() || m.length > src.size() - m.offset)
      fail(fmt::format("{}: bytes {}..{} lie outside buffer {}", w, m.offset, m.offset + m.length,
                       m.buffer));
    if (m.stride == 0 || m.stride > 256 || m.count > (std::size_t{1} << 32) / m.stride ||
        m.count * m.stride > out.length)
      fail(fmt::format("{}: {} elements of {} bytes do not fit the view's {} bytes", w, m.count,
                       m.stride, out.length));
    if (m.count * m.stride > kMeshoptMaxRatio * m.length + (std::size_t{1} << 20))
      fail(fmt::format("{}: {} bytes cannot decode into {}", w, m.length, m.count * m.stride));
    out.compressed = true;
    out.decoded.assign(out.length, '\0');
    auto* dst = reinterpret_cast<unsigned char*>(out.decoded.data());
    const auto* data = reinterpret_cast<const unsigned char*>(src.data() + m.offset);
    int rc = -1;
    if (m.mode == "ATTRIBUTES") {
      if (m.stride % 4 != 0)
        fail(fmt::format("{}: byteStride {} is not a multiple of 4", w, m.stride));
      rc = meshopt_decodeVertexBuffer(dst, m.count, m.stride, data, m.length);
    } else if (m.mode == "TRIANGLES" || m.mode == "INDICES") {
      if (m.stride != 2 && m.stride != 4)
        fail(fmt::format("{}: index byteStride {} is not 2 or 4", w, m.stride));
      if (m.mode == "TRIANGLES" && m.count % 3 != 0)
        fail(fmt::format("{}: {} indices is not a whole number of triangles", w, m.count));
      rc = m.mode == "TRIANGLES"
               ? meshopt_decodeIndexBuffer(dst, m.count, m.stride, data, m.length)
               : meshopt_decodeIndexSequence(dst, m.count, m.stride, data, m.length);
    } else {
      fail(fmt::format("{}: unknown mode '{}'", w, m.mode));
    }
    if (rc != 0)
      fail(fmt::format("{}: the compressed data does not decode (meshopt error {})", w, rc));
    if (m.filter == "OCTAHEDRAL" || m.filter == "QUATERNION" || m.filter == "EXPONENTIAL") {
      if (m.mode != "ATTRIBUTES") fail(w + ": a filter on indices");
      const bool ok =
          m.filter == "EXPONENTIAL" ? m.stride % 4 == 0 : (m.stride == 4 || m.stride == 8);
      if (!ok)
        fail(fmt::format("{}: byteStride {} does not suit the {} filter", w, m.stride, m.filter));
      if (m.filter == "OCTAHEDRAL") meshopt_decodeFilterOct(dst, m.count, m.stride);
      if (m.filter == "QUATERNION") meshopt_decodeFilterQuat(dst, m.count, m.stride);
      if (m.filter == "EXPONENTIAL") meshopt_decodeFilterExp(dst, m.count, m.stride);
    } else if (m.filter != "NONE") {
      fail(fmt::format("{}: unknown filter '{}'", w, m.filter));
    }
  }

  std::string_view view_bytes(const GltfView& v) const {
    return v.compressed ? std::string_view(v.decoded)
                        : img.buffers[static_cast<std::size_t>(v.buffer)].data;
  }
  std::size_t view_start(const GltfView& v) const { return v.compressed ? 0 : v.offset; }

  // Checks accessor a for `type` and returns where its elements are.
  struct Access {
    const char* data = nullptr;  // element 0
    std::size_t stride = 0, count = 0;
    int component = 0, view = -1;
    std::size_t offset = 0;  // of element 0 in the view's bytes
    bool normalized = false;
  };
  Access accessor(int a, const char* type, int components) const {
    const Json& acc = doc["accessors"][static_cast<std::size_t>(a)];
    const std::string where = fmt::format("accessors[{}]", a);
    if (!acc.is_object()) fail(where + " is not an object");
    if (acc.contains("sparse")) fail(where + ": sparse accessors are not supported");
    if (!acc.contains("bufferView"))
      fail(where + ": no bufferView (all zeros); it cannot carry a mesh");
    Access out;
    out.view = index(acc, "bufferView", where, img.views.size());
    out.offset = size(acc, "byteOffset", where, 0);
    out.count = size(acc, "count", where);
    out.component = static_cast<int>(size(acc, "componentType", where));
    out.normalized = acc.value("normalized", false);
    if (acc.value("type", std::string()) != type)
      fail(fmt::format("{}: type '{}' where {} is needed", where, acc.value("type", std::string()),
                       type));
    const std::size_t csize = gltf_component_size(out.component);
    if (csize == 0) fail(fmt::format("{}: unknown componentType {}", where, out.component));
    const GltfView& v = img.views[static_cast<std::size_t>(out.view)];
    const std::size_t element = csize * static_cast<std::size_t>(components);
    out.stride = v.stride ? v.stride : element;
    if (out.stride < element)
      fail(fmt::format("{}: bufferViews[{}]'s byteStride {} is shorter than an element ({} bytes)",
                       where, out.view, out.stride, element));
    if (out.normalized && (out.component == kGltfFloat || out.component == kGltfUnsignedInt))
      fail(fmt::format("{}: 'normalized' on componentType {}", where, out.component));
    if (out.count == 0) fail(where + ": count is 0");
    if (out.offset > v.length || element > v.length - out.offset ||
        (out.count - 1) > (v.length - out.offset - element) / out.stride)
      fail(
          fmt::format("{}: {} elements of {} bytes every {} from byte {} overrun bufferView {} ({} "
                      "bytes)",
                      where, out.count, element, out.stride, out.offset, out.view, v.length));
    out.data = view_bytes(v).data() + view_start(v) + out.offset;
    return out;
  }

  static Eigen::Matrix4d local_transform(const Json& node, const Reader& r, std::size_t n) {
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    auto numbers = [&](const char* key, std::size_t count) -> std::vector<double> {
      const auto it = node.find(key);
      if (it == node.end()) return {};
      if (!it->is_array() || it->size() != count)
        r.fail(fmt::format("nodes[{}]: '{}' is not an array of {} numbers", n, key, count));
      std::vector<double> out;
      for (const Json& x : *it) {
        if (!x.is_number()) r.fail(fmt::format("nodes[{}]: '{}' holds a non-number", n, key));
        out.push_back(x.get<double>());
        if (!std::isfinite(out.back()))
          r.fail(fmt::format("nodes[{}]: '{}' is not finite", n, key));
      }
      return out;
    };
    const std::vector<double> matrix = numbers("matrix", 16);
    const std::vector<double> t = numbers("translation", 3), q = numbers("rotation", 4),
                              s = numbers("scale", 3);
    if (!matrix.empty()) {
      if (!t.empty() || !q.empty() || !s.empty())
        r.fail(fmt::format("nodes[{}]: both 'matrix' and translation/rotation/scale", n));
      for (int c = 0; c < 4; ++c)
        for (int row = 0; row < 4; ++row)
          m(row, c) = matrix[4 * static_cast<std::size_t>(c) + static_cast<std::size_t>(row)];
      if (m.row(3) != Eigen::RowVector4d(0, 0, 0, 1))
        r.fail(fmt::format("nodes[{}]: 'matrix' is not affine (its last row is not 0 0 0 1)", n));
      return m;
    }
    if (!q.empty() && std::abs(std::hypot(q[0], q[1], q[2]) * std::hypot(q[0], q[1], q[2]) +
                               q[3] * q[3] - 1) > 1e-3)
      r.fail(fmt::format("nodes[{}]: 'rotation' is not a unit quaternion", n));
    Eigen::Matrix3d rs = Eigen::Matrix3d::Identity();
    if (!q.empty()) rs = Eigen::Quaterniond(q[3], q[0], q[1], q[2]).normalized().toRotationMatrix();
    if (!s.empty()) rs = rs * Eigen::Vector3d(s[0], s[1], s[2]).asDiagonal();
    m.topLeftCorner<3, 3>() = rs;
    if (!t.empty()) m.topRightCorner<3, 1>() = Eigen::Vector3d(t[0], t[1], t[2]);
    return m;
  }
};

}  // namespace

namespace {

// Where the GLB container keeps its chunks: the JSON text and buffer 0 (the BIN chunk).
struct GlbChunks {
  std::string json;
  std::size_t bin_offset = 0, bin_length = 0;
};

// The chunks of a GLB file (header, JSON chunk, optional BIN chunk), each checked to fit.
GlbChunks read_glb_chunks(const std::string& bytes, const std::string& name) {
  GlbChunks out;
  if (bytes.size() < 20 || u32(bytes, 0) != kGlbMagic)
    fail(name, 0, "not a GLB file (no 'glTF' magic and header)");
  if (u32(bytes, 4) != 2)
    fail(name, 0, fmt::format("GLB version {} (only 2 is read)", u32(bytes, 4)));
  if (u32(bytes, 8) != bytes.size())
    fail(name, 0,
         fmt::format("the header says {} bytes, the file has {}", u32(bytes, 8), bytes.size()));
  const std::size_t json_length = u32(bytes, 12);
  if (u32(bytes, 16) != kChunkJson || json_length > bytes.size() - 20)
    fail(name, 0, "the first chunk is not a JSON chunk that fits in the file");
  out.json = bytes.substr(20, json_length);
  const std::size_t at = 20 + json_length;
  if (at < bytes.size()) {
    if (bytes.size() - at < 8) fail(name, 0, "a truncated chunk header after the JSON chunk");
    out.bin_length = u32(bytes, at);
    if (u32(bytes, at + 4) != kChunkBin || out.bin_length > bytes.size() - at - 8)
      fail(name, 0, "the second chunk is not a BIN chunk that fits in the file");
    out.bin_offset = at + 8;
  }
  return out;
}

// The document's JSON parsed and checked to be glTF 2.0 whose required extensions are read.
void parse_document(Reader& r) {
  const std::string& name = r.name;
  try {
    r.doc = Json::parse(r.img.json);
  } catch (const Json::exception& e) {  // malformed, or a number beyond double's range
    fail(name, 0, fmt::format("the JSON does not parse: {}", e.what()));
  }
  if (!r.doc.is_object()) fail(name, 0, "the JSON is not an object");
  const auto asset = r.doc.find("asset");
  if (asset == r.doc.end() || !asset->is_object() ||
      asset->value("version", std::string()) != "2.0")
    fail(name, 0, "not glTF 2.0 (asset.version must be \"2.0\")");
  for (const Json& ext : r.array("extensionsRequired")) {
    const std::string e = ext.is_string() ? ext.get<std::string>() : std::string("?");
    if (e != "KHR_mesh_quantization" && e != "EXT_meshopt_compression" &&
        e != "KHR_draco_mesh_compression" && e != "KHR_materials_variants" &&
        !e.starts_with("KHR_materials_") && !e.starts_with("KHR_texture_") &&
        e != "EXT_texture_webp")
      fail(name, 0, fmt::format("required extension '{}' is not supported", e));
  }
}

// Gathers the triangles of the default scene into one vertex list. Each POSITION accessor (or
// Draco view) is read once, in the frame of the first node that draws it: a scene drawing one
// mesh a thousand times is not a thousand times larger, and a marked copy moves the stored
// vertices every instance shares. Each primitive (positions, indices, mode) is read once too.
class SceneGatherer {
 public:
  explicit SceneGatherer(Reader& r)
      : r_(r),
        name_(r.name),
        img_(r.img),
        accessors_(r.array("accessors")),
        meshes_(r.array("meshes")),
        nodes_(r.array("nodes")),
        seen_(nodes_.size(), 0) {}

  // Every node tree of the default scene, or every mesh untransformed when there is no scene.
  void gather() {
    const Json& scenes = r_.array("scenes");
    if (scenes.empty()) {
      for (std::size_t m = 0; m < meshes_.size(); ++m) add_mesh(-1, Eigen::Matrix4d::Identity(), m);
      return;
    }
    const std::size_t s =
        r_.doc.contains("scene")
            ? static_cast<std::size_t>(r_.index(r_.doc, "scene", "the root", scenes.size()))
            : 0;
    const Json& scene = scenes[s];
    if (!scene.is_object()) fail(name_, 0, fmt::format("scenes[{}] is not an object", s));
    if (!scene.contains("nodes")) return;
    if (!scene["nodes"].is_array())
      fail(name_, 0, fmt::format("scenes[{}].nodes is not an array", s));
    for (const Json& n : scene["nodes"]) {
      if (!n.is_number_unsigned() || n.get<std::size_t>() >= nodes_.size())
        fail(name_, 0, fmt::format("scenes[{}]: a node index names no node", s));
      visit(n.get<std::size_t>(), Eigen::Matrix4d::Identity(), 0);
    }
  }

  // Notes on instancing and skipped primitives; refuses a scene without triangles.
  void finish(std::vector<std::string>& notes) const {
    std::size_t instanced = 0, most = 0;
    int example = -1;
    for (const auto& [a, users] : nodes_of_accessor_)
      if (users.size() > 1) {
        ++instanced;
        if (users.size() > most) most = users.size(), example = a;
      }
    if (instanced > 0)
      notes.push_back(
          fmt::format("{} position accessors are drawn by several nodes (instanced; "
                      "accessors[{}] by {}): each is read and marked once, in the "
                      "frame of the first node drawing it",
                      instanced, example, most));
    if (skipped_primitives_ > 0)
      notes.push_back(fmt::format("{} point or line primitives skipped", skipped_primitives_));
    if (parsed_.faces.size() == 0)
      fail(name_, 0,
           fmt::format("no triangle primitive in the default scene ({} point or line "
                       "primitives)",
                       skipped_primitives_));
  }

  Parsed& parsed() { return parsed_; }

 private:
  // A node and its children, parents before children; every node at most once.
  void visit(std::size_t n, const Eigen::Matrix4d& parent, int depth) {
    const std::string where = fmt::format("nodes[{}]", n);
    if (seen_[n]) fail(name_, 0, where + " is reached twice (the node graph is not a forest)");
    if (depth > 256) fail(name_, 0, where + ": node tree deeper than 256");
    seen_[n] = 1;
    const Json& node = nodes_[n];
    if (!node.is_object()) fail(name_, 0, where + " is not an object");
    const Eigen::Matrix4d world = parent * Reader::local_transform(node, r_, n);
    if (node.contains("mesh")) {
      const int m = r_.index(node, "mesh", where, meshes_.size());
      add_mesh(static_cast<int>(n), mesh_transform(node, world, where),
               static_cast<std::size_t>(m));
    }
    if (node.contains("children")) {
      if (!node["children"].is_array()) fail(name_, 0, where + ": 'children' is not an array");
      for (const Json& c : node["children"]) {
        if (!c.is_number_unsigned() || c.get<std::size_t>() >= nodes_.size())
          fail(name_, 0, where + ": a child index names no node");
        visit(c.get<std::size_t>(), world, depth + 1);
      }
    }
  }

  // The transform a node's mesh is read in: its world transform, or the identity when skinned
  // (glTF draws a skinned mesh in its bind pose); refused when singular, noted when it scales
  // non-uniformly.
  Eigen::Matrix4d mesh_transform(const Json& node, const Eigen::Matrix4d& world,
                                 const std::string& where) {
    Eigen::Matrix4d used = world;
    if (node.contains("skin")) {
      used.setIdentity();
      r_.notes.push_back(
          fmt::format("{} is skinned: its mesh is read in its bind pose (mesh "
                      "space), as glTF ignores a skinned node's transform",
                      where));
    }
    const Eigen::Matrix3d lin = used.topLeftCorner<3, 3>();
    const Eigen::Vector3d sv = Eigen::JacobiSVD<Eigen::Matrix3d>(lin).singularValues();
    if (!(sv[2] > 1e-12 * std::max(sv[0], 1e-300)) || !used.allFinite())
      fail(name_, 0, where + ": its transform is singular; positions cannot be written back");
    if (sv[0] > sv[2] * (1 + 1e-6))
      r_.notes.push_back(
          fmt::format("{} scales non-uniformly ({:.6g} to {:.6g}): the mark is "
                      "embedded in world space and written back through the "
                      "inverse transform",
                      where, sv[2], sv[0]));
    return used;
  }

  void add_mesh(int n, const Eigen::Matrix4d& world, std::size_t m) {
    const Json& mesh = meshes_[m];
    const auto prims = mesh.find("primitives");
    if (!mesh.is_object() || prims == mesh.end() || !prims->is_array())
      fail(name_, 0, fmt::format("meshes[{}] has no primitives array", m));
    for (std::size_t p = 0; p < prims->size(); ++p)
      add_primitive(n, world, (*prims)[p], fmt::format("meshes[{}].primitives[{}]", m, p));
  }

  // File vertex f at world position w: its coordinates, and a slot per axis for the writer.
  void add_vertex(std::size_t f, const Eigen::Vector4d& w) {
    for (int c = 0; c < 3; ++c) parsed_.xyz.push_back(w[c]);
    CoordSlot slot;  // only to learn f's row once welded
    slot.offset = f;
    slot.vertex = static_cast<std::int32_t>(f);
    parsed_.slots.push_back(slot);
  }

  void add_primitive(int n, const Eigen::Matrix4d& world, const Json& prim,
                     const std::string& where) {
    if (!prim.is_object()) fail(name_, 0, where + " is not an object");
    const std::size_t mode = r_.size(prim, "mode", where, 4);
    if (mode < 4 || mode > 6) {
      ++skipped_primitives_;
      return;
    }
    const auto attrs = prim.find("attributes");
    if (attrs == prim.end() || !attrs->is_object() || !attrs->contains("POSITION"))
      fail(name_, 0, where + ": no POSITION attribute");
    const int a = r_.index(*attrs, "POSITION", where + ".attributes", accessors_.size());
    if (prim.contains("targets"))
      r_.notes.push_back(
          fmt::format("{} has morph targets: they keep their displacements, the mark "
                      "is in the base shape",
                      where));
    const auto ext = prim.find("extensions");
    if (ext != prim.end() && ext->is_object() && ext->contains("KHR_draco_mesh_compression")) {
      add_draco(n, world, prim, (*ext)["KHR_draco_mesh_compression"], a, mode, where);
      return;
    }
    nodes_of_accessor_[a].insert(n);
    const int indices =
        prim.contains("indices") ? r_.index(prim, "indices", where, accessors_.size()) : -1;
    if (!primitives_read_.insert({a, indices, mode}).second) return;
    auto [it, fresh] = instance_of_.try_emplace(a, img_.instances.size());
    if (fresh) img_.instances.push_back(read_positions(n, world, a));
    const GltfInstance& inst = img_.instances[it->second];
    add_triangles(inst.first, primitive_indices(prim, inst.count, where), mode, where);
  }

  // The instance of POSITION accessor a, drawn by node n: its vertices added in world space.
  GltfInstance read_positions(int n, const Eigen::Matrix4d& world, int a) {
    const Reader::Access acc = r_.accessor(a, "VEC3", 3);
    if (acc.component == kGltfUnsignedInt ||
        (acc.component != kGltfFloat && !r_.uses("KHR_mesh_quantization")))
      fail(name_, 0,
           fmt::format("accessors[{}]: POSITION of componentType {} (integers need "
                       "KHR_mesh_quantization; unsigned int is never allowed)",
                       a, acc.component));
    GltfInstance inst;
    inst.node = n;
    inst.accessor = a;
    inst.view = acc.view;
    inst.stride = acc.stride;
    inst.count = acc.count;
    inst.component = acc.component;
    inst.normalized = acc.normalized;
    inst.world = world;
    inst.first = parsed_.xyz.size() / 3;
    inst.offset = acc.offset;
    const std::size_t csize = gltf_component_size(acc.component);
    parsed_.xyz.reserve(parsed_.xyz.size() + 3 * acc.count);
    parsed_.slots.reserve(parsed_.slots.size() + acc.count);
    for (std::size_t k = 0; k < acc.count; ++k) {
      const char* e = acc.data + k * acc.stride;
      const Eigen::Vector4d p(gltf_component_value(e, acc.component, acc.normalized),
                              gltf_component_value(e + csize, acc.component, acc.normalized),
                              gltf_component_value(e + 2 * csize, acc.component, acc.normalized),
                              1.0);
      if (!p.allFinite())
        fail(name_, 0, fmt::format("accessors[{}]: element {} is not finite", a, k));
      add_vertex(inst.first + k, world * p);
    }
    return inst;
  }

  // The primitive's vertex indices (its indices accessor, checked against the instance's
  // `count` vertices, or 0 .. count - 1 without one).
  std::vector<std::uint32_t> primitive_indices(const Json& prim, std::size_t count,
                                               const std::string& where) {
    std::vector<std::uint32_t> idx;
    if (!prim.contains("indices")) {
      idx.resize(count);
      for (std::size_t k = 0; k < count; ++k) idx[k] = static_cast<std::uint32_t>(k);
      return idx;
    }
    const int ia = r_.index(prim, "indices", where, accessors_.size());
    const Reader::Access acc = r_.accessor(ia, "SCALAR", 1);
    if (acc.component != kGltfUnsignedByte && acc.component != kGltfUnsignedShort &&
        acc.component != kGltfUnsignedInt)
      fail(name_, 0, fmt::format("accessors[{}]: indices of componentType {}", ia, acc.component));
    idx.resize(acc.count);
    for (std::size_t k = 0; k < acc.count; ++k) {
      const double v = gltf_component_value(acc.data + k * acc.stride, acc.component, false);
      if (v >= static_cast<double>(count))
        fail(name_, 0,
             fmt::format("accessors[{}]: index {} at element {} is out of range (the "
                         "primitive has {} vertices)",
                         ia, v, k, count));
      idx[k] = static_cast<std::uint32_t>(v);
    }
    return idx;
  }

  // The triangles of a list (mode 4), strip (5) or fan (6) of indices from vertex `first`.
  void add_triangles(std::size_t first, const std::vector<std::uint32_t>& idx, std::size_t mode,
                     const std::string& where) {
    auto triangle = [&](std::uint32_t a0, std::uint32_t a1, std::uint32_t a2) {
      const int t[3] = {static_cast<int>(first + a0), static_cast<int>(first + a1),
                        static_cast<int>(first + a2)};
      parsed_.faces.push_back(t, 3);
    };
    if (mode == 4) {
      if (idx.size() % 3 != 0)
        fail(name_, 0,
             fmt::format("{}: {} indices is not a whole number of triangles", where, idx.size()));
      for (std::size_t k = 0; k + 2 < idx.size(); k += 3) triangle(idx[k], idx[k + 1], idx[k + 2]);
    } else if (mode == 5) {
      for (std::size_t k = 0; k + 2 < idx.size(); ++k)
        k % 2 ? triangle(idx[k + 1], idx[k], idx[k + 2]) : triangle(idx[k], idx[k + 1], idx[k + 2]);
    } else {
      for (std::size_t k = 1; k + 1 < idx.size(); ++k) triangle(idx[0], idx[k], idx[k + 1]);
    }
  }

  // A Draco-compressed primitive: its points in world space, its triangles.
  void add_draco(int n, const Eigen::Matrix4d& world, const Json& prim, const Json& ext, int a,
                 std::size_t mode, const std::string& where) {
    const std::string w = where + ".extensions.KHR_draco_mesh_compression";
    if (!ext.is_object()) fail(name_, 0, w + " is not an object");
    if (mode != 4) fail(name_, 0, w + ": Draco primitives must be triangles (mode 4)");
    const int v = r_.index(ext, "bufferView", w, img_.views.size());
    const auto ids = ext.find("attributes");
    if (ids == ext.end() || !ids->is_object() || !ids->contains("POSITION"))
      fail(name_, 0, w + ": no POSITION attribute id");
    auto [found, fresh_view] = draco_of_view_.try_emplace(v, static_cast<int>(img_.dracos.size()));
    if (fresh_view) img_.dracos.push_back(decode_view(v, prim, (*ids)["POSITION"], a, w, where));
    nodes_of_accessor_[a].insert(n);
    if (!primitives_read_.insert({-1 - v, -1, mode}).second) return;
    auto [it, fresh] = instance_of_.try_emplace(-1 - v, img_.instances.size());
    const GltfDraco& d = img_.dracos[static_cast<std::size_t>(found->second)];
    if (fresh) {
      GltfInstance inst;
      inst.node = n;
      inst.accessor = a;
      inst.count = d.mesh.positions.size() / 3;
      inst.world = world;
      inst.first = parsed_.xyz.size() / 3;
      inst.draco = found->second;
      for (std::size_t k = 0; k < inst.count; ++k)
        add_vertex(inst.first + k,
                   world * Eigen::Vector4d(d.mesh.positions[3 * k], d.mesh.positions[3 * k + 1],
                                           d.mesh.positions[3 * k + 2], 1.0));
      img_.instances.push_back(inst);
    }
    const GltfInstance& inst = img_.instances[it->second];
    for (std::size_t t = 0; t + 2 < d.mesh.triangles.size(); t += 3) {
      const int tri[3] = {static_cast<int>(inst.first + d.mesh.triangles[t]),
                          static_cast<int>(inst.first + d.mesh.triangles[t + 1]),
                          static_cast<int>(inst.first + d.mesh.triangles[t + 2])};
      parsed_.faces.push_back(tri, 3);
    }
  }

  // Buffer view v decoded as Draco, its POSITION attribute id checked against the JSON's.
  GltfDraco decode_view(int v, const Json& prim, const Json& position_id, int a,
                        const std::string& w, const std::string& where) {
    GltfDraco d;
    d.view = v;
    const GltfView& view = img_.views[static_cast<std::size_t>(v)];
    d.mesh = decode_draco(r_.view_bytes(view).substr(r_.view_start(view), view.length),
                          name_ + " (" + w + ")");
    if (position_id != d.mesh.attribute_id_of_position)
      fail(name_, 0,
           fmt::format("{}: POSITION is attribute {} in the JSON, {} in the Draco data", w,
                       position_id.dump(), d.mesh.attribute_id_of_position));
    d.position_accessor = a;
    for (const auto& [key, acc] : prim["attributes"].items())
      d.attribute_accessors.push_back(
          r_.index(prim["attributes"], key.c_str(), where, accessors_.size()));
    if (prim.contains("indices"))
      d.indices_accessor = r_.index(prim, "indices", where, accessors_.size());
    return d;
  }

  Reader& r_;
  const std::string& name_;
  GltfImage& img_;
  const Json& accessors_;
  const Json& meshes_;
  const Json& nodes_;
  std::vector<std::uint8_t> seen_;
  Parsed parsed_;
  std::map<int, std::size_t> instance_of_;  // accessor, or -1 - Draco view -> instance
  std::map<int, std::set<int>> nodes_of_accessor_;
  std::set<std::tuple<int, int, std::size_t>> primitives_read_;
  std::map<int, int> draco_of_view_;
  std::size_t skipped_primitives_ = 0;
};

Mesh read_gltf_document(std::string bytes, FileFormat format, const std::string& name,
                        const ReadOptions& options) {
  auto image = std::make_shared<GltfImage>();
  GltfImage& img = *image;
  img.binary = format == FileFormat::Glb;
  GlbChunks chunks;
  if (img.binary)
    chunks = read_glb_chunks(bytes, name);
  else
    chunks.json = bytes;
  img.json = std::move(chunks.json);
  img.file = std::move(bytes);  // buffer 0 of a GLB is read in place
  std::vector<std::string> notes;
  Reader r{name, options, Json(), img, notes};
  parse_document(r);
  r.read_buffers(img.file, img.binary, chunks.bin_offset, chunks.bin_length);
  r.read_views();
  const Json& accessors = r.array("accessors");
  img.accessor_counts.assign(accessors.size(), 0);
  for (std::size_t a = 0; a < accessors.size(); ++a)
    if (accessors[a].is_object())
      img.accessor_counts[a] = r.size(accessors[a], "count", fmt::format("accessors[{}]", a), 0);

  SceneGatherer scene(r);
  scene.gather();
  scene.finish(notes);
  if (options.weld_tolerance > 0) img.world_as_read = scene.parsed().xyz;
  Mesh mesh = assemble(std::move(scene.parsed()), nullptr, format, Encoding::BinaryLittleEndian,
                       name, options, std::move(image));
  mesh.notes = std::move(notes);
  return mesh;
}

}  // namespace

Mesh read_gltf(std::string bytes, FileFormat format, const std::string& name,
               const ReadOptions& options) {
  try {
    return read_gltf_document(std::move(bytes), format, name, options);
  } catch (const nlohmann::json::exception& e) {
    // A member of the wrong type that a check above did not catch first.
    fail(name, 0, fmt::format("a JSON member has the wrong type: {}", e.what()));
  }
}

}  // namespace meshmark::detail
