#include "io/file_image.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>

#include <fmt/format.h>

#include "core/text_scan.h"
#include "meshmark/core/error.h"

namespace meshmark::detail {

int slot_type_size(SlotType type) {
  switch (type) {
    case SlotType::Int8:
    case SlotType::UInt8:
      return 1;
    case SlotType::Int16:
    case SlotType::UInt16:
      return 2;
    case SlotType::Int32:
    case SlotType::UInt32:
    case SlotType::Float32:
      return 4;
    case SlotType::Float64:
      return 8;
    case SlotType::Text:
      return 0;
  }
  return 0;
}

namespace {

template <class T>
T load(const char* data, bool big_endian) {
  T v;
  char tmp[sizeof(T)];
  std::memcpy(tmp, data, sizeof(T));
  if (big_endian != (std::endian::native == std::endian::big)) std::reverse(tmp, tmp + sizeof(T));
  std::memcpy(&v, tmp, sizeof(T));
  return v;
}

template <class T>
void store(char* data, bool big_endian, T v) {
  char tmp[sizeof(T)];
  std::memcpy(tmp, &v, sizeof(T));
  if (big_endian != (std::endian::native == std::endian::big)) std::reverse(tmp, tmp + sizeof(T));
  std::memcpy(data, tmp, sizeof(T));
}

template <class T>
T to_integer(double value) {
  const double lo = static_cast<double>(std::numeric_limits<T>::min());
  const double hi = static_cast<double>(std::numeric_limits<T>::max());
  return static_cast<T>(std::clamp(std::nearbyint(value), lo, hi));
}

}  // namespace

double read_scalar(const char* data, SlotType type, bool big_endian) {
  switch (type) {
    case SlotType::Int8:
      return load<std::int8_t>(data, big_endian);
    case SlotType::UInt8:
      return load<std::uint8_t>(data, big_endian);
    case SlotType::Int16:
      return load<std::int16_t>(data, big_endian);
    case SlotType::UInt16:
      return load<std::uint16_t>(data, big_endian);
    case SlotType::Int32:
      return load<std::int32_t>(data, big_endian);
    case SlotType::UInt32:
      return load<std::uint32_t>(data, big_endian);
    case SlotType::Float32:
      return load<float>(data, big_endian);
    case SlotType::Float64:
      return load<double>(data, big_endian);
    case SlotType::Text:
      break;
  }
  return 0;
}

void write_scalar(char* data, SlotType type, bool big_endian, double value) {
  switch (type) {
    case SlotType::Int8:
      return store(data, big_endian, to_integer<std::int8_t>(value));
    case SlotType::UInt8:
      return store(data, big_endian, to_integer<std::uint8_t>(value));
    case SlotType::Int16:
      return store(data, big_endian, to_integer<std::int16_t>(value));
    case SlotType::UInt16:
      return store(data, big_endian, to_integer<std::uint16_t>(value));
    case SlotType::Int32:
      return store(data, big_endian, to_integer<std::int32_t>(value));
    case SlotType::UInt32:
      return store(data, big_endian, to_integer<std::uint32_t>(value));
    case SlotType::Float32:
      return store(data, big_endian, static_cast<float>(value));
    case SlotType::Float64:
      return store(data, big_endian, value);
    case SlotType::Text:
      break;
  }
}

double slot_value(const std::string& bytes, const CoordSlot& slot) {
  const std::uint64_t offset = slot.offset;
  const std::uint64_t length = slot.type == SlotType::Text
                                   ? std::uint64_t{slot.length}
                                   : static_cast<std::uint64_t>(slot_type_size(slot.type));
  if (offset > bytes.size() || length > bytes.size() - offset)
    throw InvalidArgumentError(fmt::format(
        "a stored coordinate at byte {} (length {}) lies outside the file image of {} bytes",
        offset, length, bytes.size()));
  if (slot.type != SlotType::Text)
    return read_scalar(bytes.data() + offset, slot.type, slot.big_endian);
  double value = 0;
  if (!parse_double(std::string_view(bytes).substr(offset, length), value))
    throw InvalidArgumentError(
        fmt::format("the stored coordinate at byte {} is no longer a number", offset));
  return value;
}

std::uint64_t face_hash(const FaceView& faces) {
  std::uint64_t h = 0x243F6A8885A308D3ULL;
  const auto mix = [&h](std::uint64_t v) {
    h = (h ^ v) * 0x9E3779B97F4A7C15ULL;
    h ^= h >> 29;
  };
  for (std::size_t k = 0; k < faces.size(); ++k) {
    const std::size_t n = faces.size_of(k);
    mix(n);
    for (std::size_t c = 0; c < n; ++c) mix(static_cast<std::uint32_t>(faces.corner(k, c)));
  }
  return h;
}

void record_connectivity(FileImage& image, const Mesh& mesh) {
  const FaceView faces(mesh);
  image.vertices = mesh.V.rows();
  image.face_count = faces.size();
  image.face_index_count = faces.corners();
  image.face_hash = face_hash(faces);
}

bool same_connectivity(const FileImage& image, const Mesh& mesh) {
  const FaceView faces(mesh);
  return image.vertices == mesh.V.rows() && image.face_count == faces.size() &&
         image.face_index_count == faces.corners() && image.face_hash == face_hash(faces);
}

bool image_applies(const Mesh& mesh, FileFormat format, Encoding encoding) {
  const FileImage* image = mesh.image.get();
  return image && image->format == format && image->encoding == encoding &&
         same_connectivity(*image, mesh);
}

namespace {
// The value a slot must hold for the vertex positions V; source holds the file's bytes in their
// original layout.
bool new_value(const FileImage& image, const std::string& source, const CoordSlot& slot,
               const Eigen::MatrixX3d& V, double& value) {
  const double now = V(slot.vertex, slot.axis);
  const auto same = [now](double then) {
    return now == then && std::signbit(now) == std::signbit(then);
  };
  if (image.V.size() == 0) {  // each slot holds its vertex's value as read (FileImage::V)
    const double original = slot_value(source, slot);
    value = now;
    return !same(original);
  }
  const double then = image.V(slot.vertex, slot.axis);
  if (same(then)) return false;
  const double original = slot_value(source, slot);
  value = original == then ? now : original + (now - then);
  return true;
}

// Writes value as type at data; throws when the type cannot hold it (a face of more corners
// than its count's type holds, a vertex index beyond its type).
void store_exact(char* data, SlotType type, bool big_endian, double value, const char* what,
                 std::size_t k) {
  write_scalar(data, type, big_endian, value);
  if (read_scalar(data, type, big_endian) != value)
    throw InvalidArgumentError(fmt::format(
        "face {}: its {} {} does not fit the type the source file stores it in", k, what, value));
}

// Appends records [begin, end) of section s, encoded from V and faces, to out.
void encode_records(const FileImage& image, const ElidedSection& s, const Eigen::MatrixX3d& V,
                    const FaceView& faces, std::int64_t begin, std::int64_t end, std::string& out) {
  char record[32];
  if (s.kind == ElidedSection::Kind::Positions) {
    const RegularLayout& r = *image.regular;
    for (std::int64_t i = begin; i < end; ++i) {
      for (std::size_t a = 0; a < 3; ++a)
        write_scalar(record + r.offset[a], r.type[a], r.big_endian,
                     V(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(a)));
      out.append(record, static_cast<std::size_t>(r.stride));
    }
    return;
  }
  const auto count_size = static_cast<std::size_t>(slot_type_size(s.count_type));
  const auto index_size = static_cast<std::size_t>(slot_type_size(s.index_type));
  for (std::int64_t f = begin; f < end; ++f) {
    const auto k = static_cast<std::size_t>(f);
    const std::size_t n = faces.size_of(k);
    store_exact(record, s.count_type, s.big_endian, static_cast<double>(n), "corner count", k);
    out.append(record, count_size);
    for (std::size_t c = 0; c < n; ++c) {
      store_exact(record, s.index_type, s.big_endian, faces.corner(k, c), "vertex index", k);
      out.append(record, index_size);
    }
  }
}

// Whether section s can be encoded from the mesh at all (its layout known, its record count the
// mesh's).
bool encodable(const FileImage& image, const ElidedSection& s, const Eigen::MatrixX3d& V,
               const FaceView& faces) {
  if (s.kind == ElidedSection::Kind::Positions)
    return image.regular && image.regular->stride <= 32 && image.regular->vertices == s.records &&
           V.rows() == s.records;
  return slot_type_size(s.count_type) > 0 && slot_type_size(s.index_type) > 0 &&
         faces.size() == static_cast<std::size_t>(s.records);
}
}  // namespace

std::string patch_image(const FileImage& image, const Mesh& mesh) {
  const Eigen::MatrixX3d& V = mesh.V;
  double value = 0;
  if (image.encoding != Encoding::Ascii) {
    std::string out;
    bool positions_encoded = false;
    if (image.elided.empty()) {
      out = image.bytes;
    } else {
      const FaceView faces(mesh);
      std::uint64_t total = image.bytes.size();
      for (const ElidedSection& s : image.elided) total += s.length;
      out.reserve(total);
      std::uint64_t pos = 0;
      for (const ElidedSection& s : image.elided) {
        if (!encodable(image, s, V, faces) || s.at < pos || s.at > image.bytes.size())
          throw InvalidArgumentError(
              "the mesh no longer has the vertices or faces its source file's image was read with");
        out.append(image.bytes, pos, s.at - pos);
        pos = s.at;
        encode_records(image, s, V, faces, 0, s.records, out);
        positions_encoded = positions_encoded || s.kind == ElidedSection::Kind::Positions;
      }
      out.append(image.bytes, pos, std::string::npos);
    }
    if (const std::optional<RegularLayout>& r = image.regular; r && !positions_encoded) {
      if (r->vertices > V.rows())
        throw InvalidArgumentError("the file image has more vertices than the mesh");
      for (std::int64_t i = 0; i < r->vertices; ++i)
        for (int a = 0; a < 3; ++a) {
          const std::uint64_t at =
              r->first + static_cast<std::uint64_t>(i) * r->stride + r->offset[a];
          const CoordSlot slot{at,
                               static_cast<std::uint64_t>(slot_type_size(r->type[a])),
                               static_cast<std::int32_t>(i),
                               static_cast<std::uint8_t>(a),
                               r->type[a],
                               r->big_endian};
          if (new_value(image, out, slot, V, value))
            write_scalar(out.data() + slot.offset, slot.type, slot.big_endian, value);
        }
    }
    for (const CoordSlot& slot : image.slots)
      if (new_value(image, out, slot, V, value))
        write_scalar(out.data() + slot.offset, slot.type, slot.big_endian, value);
    return out;
  }
  std::string out;
  out.reserve(image.bytes.size() + image.bytes.size() / 4);
  std::size_t pos = 0;
  for (const CoordSlot& slot : image.slots) {
    if (!new_value(image, image.bytes, slot, V, value)) continue;
    out.append(image.bytes, pos, slot.offset - pos);
    append_double(out, value);
    pos = slot.offset + slot.length;
  }
  out.append(image.bytes, pos, std::string::npos);
  return out;
}

void elide_sections(FileImage& image, const Mesh& mesh,
                    const std::vector<ElidedSection>& candidates) {
  if (candidates.empty() || !image.elided.empty()) return;
  const FaceView faces(mesh);
  std::vector<ElidedSection> kept;
  std::string block;
  constexpr std::int64_t kBlock = 4096;  // records encoded and compared at a time
  std::uint64_t end_of_last = 0;
  for (const ElidedSection& s : candidates) {
    if (s.at < end_of_last || s.at > image.bytes.size() || s.length > image.bytes.size() - s.at ||
        !encodable(image, s, mesh.V, faces))
      continue;
    bool same = true;
    std::uint64_t pos = s.at;
    const std::uint64_t end = s.at + s.length;
    for (std::int64_t b = 0; b < s.records && same; b += kBlock) {
      block.clear();
      try {
        encode_records(image, s, mesh.V, faces, b, std::min(s.records, b + kBlock), block);
      } catch (const InvalidArgumentError&) {
        same = false;
        break;
      }
      same = block.size() <= end - pos &&
             std::memcmp(block.data(), image.bytes.data() + pos, block.size()) == 0;
      pos += block.size();
    }
    if (!same || pos != end) continue;
    kept.push_back(s);
    end_of_last = end;
  }
  if (kept.empty()) return;
  std::uint64_t removed = 0;
  for (const ElidedSection& s : kept) removed += s.length;
  std::string rest;
  rest.reserve(image.bytes.size() - removed);
  std::uint64_t pos = 0;
  removed = 0;
  for (ElidedSection& s : kept) {
    rest.append(image.bytes, pos, s.at - pos);
    pos = s.at + s.length;
    s.at -= removed;
    removed += s.length;
  }
  rest.append(image.bytes, pos, std::string::npos);
  image.bytes = std::move(rest);
  image.elided = std::move(kept);
}

}  // namespace meshmark::detail
