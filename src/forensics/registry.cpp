#include "meshmark/forensics/registry.h"

#include <fmt/format.h>
#include <sodium.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <map>
#include <optional>
#include <regex>
#include <set>
#include <tuple>

#include "core/component.h"
#include "forensics/registry_backend.h"
#include "meshmark/core/error.h"
#include "meshmark/forensics/spacing.h"

namespace meshmark {

namespace {

std::string hex(const unsigned char* data, std::size_t size) {
  std::string out;
  for (std::size_t i = 0; i < size; ++i) out += fmt::format("{:02x}", data[i]);
  return out;
}

std::string now_utc() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return text;
}

// A buyer's identity among the copies of one original under one key: the ID, whatever the
// code's length (two copies with one ID and different bits would name two buyers by one ID).
using Identity = std::tuple<std::string, std::string, std::uint64_t>;

// The original by its geometry when known (copies recorded by schema 3 and later), else by
// its file.
Identity identity(const IssuedCopy& c) {
  return {c.original_geometry.empty() ? "file " + c.original_hash : "shape " + c.original_geometry,
          c.key_fingerprint, c.id};
}

bool is_postgres(const std::string& location) {
  return location.rfind("postgresql://", 0) == 0 || location.rfind("postgres://", 0) == 0;
}

}  // namespace

std::string key_fingerprint(const Key& key) {
  const Key k = derive_key(key, "fingerprint");
  return hex(k.bytes.data(), 16);
}

std::string normalized_path(const std::string& path) {
  std::error_code ec;
  const std::filesystem::path absolute = std::filesystem::absolute(path, ec);
  return ec ? path : absolute.lexically_normal().string();
}

std::string content_hash(const std::string& bytes) {
  if (sodium_init() < 0) throw Error("libsodium could not be initialized");
  unsigned char digest[32];
  crypto_generichash(digest, sizeof digest, reinterpret_cast<const unsigned char*>(bytes.data()),
                     bytes.size(), nullptr, 0);
  return hex(digest, sizeof digest);
}

std::string geometry_hash(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F) {
  if (sodium_init() < 0) throw Error("libsodium could not be initialized");
  // The referenced positions, rounded to float32 (+0 for -0), as sortable triples.
  using Point = std::array<float, 3>;
  std::vector<std::uint8_t> used(static_cast<std::size_t>(V.rows()), 0);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c)
      if (F(f, c) >= 0 && F(f, c) < V.rows()) used[F(f, c)] = 1;
  std::vector<std::pair<Point, Eigen::Index>> points;
  for (Eigen::Index i = 0; i < V.rows(); ++i)
    if (used[i]) {
      Point p{};
      for (int a = 0; a < 3; ++a) p[a] = static_cast<float>(V(i, a)) + 0.0f;  // -0 + 0 = +0
      points.emplace_back(p, i);
    }
  std::sort(points.begin(), points.end());
  std::vector<std::int64_t> rank(static_cast<std::size_t>(V.rows()), -1);
  std::vector<Point> unique;
  for (const auto& [p, i] : points) {
    if (unique.empty() || unique.back() != p) unique.push_back(p);
    rank[i] = static_cast<std::int64_t>(unique.size()) - 1;
  }
  std::vector<std::array<std::uint32_t, 3>> faces;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    std::array<std::uint32_t, 3> t{};
    bool valid = true;
    for (int c = 0; c < 3; ++c) {
      valid = valid && F(f, c) >= 0 && F(f, c) < V.rows();
      t[c] = valid ? static_cast<std::uint32_t>(rank[F(f, c)]) : 0;
    }
    if (!valid || t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) continue;
    std::rotate(t.begin(), std::min_element(t.begin(), t.end()), t.end());
    faces.push_back(t);
  }
  std::sort(faces.begin(), faces.end());
  faces.erase(std::unique(faces.begin(), faces.end()), faces.end());
  // Hashed as: the personalization, the counts, then little-endian floats and indices.
  crypto_generichash_state state;
  crypto_generichash_init(&state, nullptr, 0, 32);
  const auto put = [&](const void* data, std::size_t size) {
    crypto_generichash_update(&state, static_cast<const unsigned char*>(data), size);
  };
  const auto put_u64 = [&](std::uint64_t v) {
    unsigned char b[8];
    for (int k = 0; k < 8; ++k) b[k] = static_cast<unsigned char>(v >> (8 * k));
    put(b, 8);
  };
  const auto put_u32 = [&](std::uint32_t v) {
    unsigned char b[4];
    for (int k = 0; k < 4; ++k) b[k] = static_cast<unsigned char>(v >> (8 * k));
    put(b, 4);
  };
  static constexpr char kPersonal[] = "meshmark geometry 1";
  put(kPersonal, sizeof kPersonal - 1);
  put_u64(unique.size());
  for (const Point& p : unique)
    for (const float x : p) {
      std::uint32_t bits = 0;
      std::memcpy(&bits, &x, 4);
      put_u32(bits);
    }
  put_u64(faces.size());
  for (const auto& t : faces)
    for (const std::uint32_t i : t) put_u32(i);
  unsigned char digest[32];
  crypto_generichash_final(&state, digest, sizeof digest);
  return hex(digest, sizeof digest);
}

std::string row_mac(const Key& key, const IssuedCopy& c) {
  const Key k = derive_key(key, "registry row");
  crypto_generichash_state state;
  crypto_generichash_init(&state, k.bytes.data(), k.bytes.size(), 32);
  // Each field as text (integers in decimal, reals as %.17g), after its length in 4 bytes,
  // little-endian: no two rows encode alike.
  const auto put = [&](const std::string& field) {
    unsigned char size[4];
    for (int b = 0; b < 4; ++b) size[b] = static_cast<unsigned char>(field.size() >> (8 * b));
    crypto_generichash_update(&state, size, 4);
    crypto_generichash_update(&state, reinterpret_cast<const unsigned char*>(field.data()),
                              field.size());
  };
  const auto real = [](double x) { return fmt::format("{:.17g}", x); };
  put("meshmark registry row 1");
  for (const std::string& field :
       {c.original_hash, c.original_path, c.buyer, std::to_string(c.id), std::to_string(c.id_bits),
        std::to_string(c.bits), c.variant, real(c.strength), real(c.strength_spread),
        real(c.bin_offset), c.key_fingerprint, std::to_string(c.mark_format), c.issued_at,
        c.output_path, c.output_hash, c.method, c.original_geometry, c.key_derivation, c.state})
    put(field);
  unsigned char digest[32];
  crypto_generichash_final(&state, digest, sizeof digest);
  return hex(digest, sizeof digest);
}

RowAuth check_row(const Key& key, const IssuedCopy& c) {
  if (c.key_fingerprint != key_fingerprint(key)) return RowAuth::OtherKey;
  if (c.mac.empty()) return RowAuth::Unauthenticated;
  const std::string expected = row_mac(key, c);
  return expected.size() == c.mac.size() &&
                 sodium_memcmp(expected.data(), c.mac.data(), expected.size()) == 0
             ? RowAuth::Authentic
             : RowAuth::Edited;
}

std::string registry_display_name(const std::string& where) {
  if (!is_postgres(where)) return where;
  static const std::regex user_password("(://[^:/@?#]*):[^@/?#]*@");
  static const std::regex parameter("([?&]password=)[^&#]*", std::regex::icase);
  return std::regex_replace(std::regex_replace(where, user_password, "$1:***@"), parameter,
                            "$1***");
}

bool same_copy(const IssuedCopy& recorded, const IssuedCopy& wanted) {
  return recorded.original_hash == wanted.original_hash &&
         recorded.key_fingerprint == wanted.key_fingerprint && recorded.id == wanted.id &&
         recorded.id_bits == wanted.id_bits && recorded.bits == wanted.bits &&
         recorded.buyer == wanted.buyer && recorded.variant == wanted.variant &&
         recorded.strength == wanted.strength &&
         recorded.strength_spread == wanted.strength_spread &&
         recorded.bin_offset == wanted.bin_offset && recorded.mark_format == wanted.mark_format &&
         recorded.method == wanted.method && recorded.output_path == wanted.output_path;
}

struct Registry::Impl {
  std::string location;
  std::unique_ptr<detail::RegistryBackend> store;
};

namespace detail {

const PostgresConnector*& postgres_connector_slot() {
  static const PostgresConnector* connector = nullptr;
  return connector;
}

std::unique_ptr<RegistryBackend> open_postgres_registry(const std::string& uri) {
  return require_component(postgres_connector_slot(), "postgres",
                           "a registry at a postgresql:// address")
      .open(uri);
}

}  // namespace detail

Registry::Registry(const std::string& location, bool read_only) : impl_(std::make_unique<Impl>()) {
  if (read_only && !is_postgres(location) && !std::filesystem::exists(location))
    throw IOError(fmt::format("{}: no such registry", location));
  impl_->location = registry_display_name(location);  // for messages: no password
  impl_->store = is_postgres(location) ? detail::open_postgres_registry(location)
                                       : detail::open_sqlite_registry(location, read_only);
}

Registry::~Registry() = default;

int Registry::schema_version() const {
  return impl_->store->schema_version();
}

std::vector<IssuedCopy> Registry::conflicts(const std::vector<IssuedCopy>& copies) const {
  std::vector<IssuedCopy> out;
  std::set<Identity> seen;
  for (const IssuedCopy& c : copies) {
    if (!seen.insert(identity(c)).second) {
      out.push_back(c);
      out.back().row = 0;
      continue;
    }
    IssuedCopy recorded;
    if (impl_->store->find(c, recorded)) out.push_back(recorded);
  }
  return out;
}

std::vector<IssuedCopy> Registry::record(std::vector<IssuedCopy> copies) {
  for (IssuedCopy& c : copies) c.spaced_index = 0;  // only the key places an ID in the span
  return insert(std::move(copies));
}

std::vector<IssuedCopy> Registry::insert(std::vector<IssuedCopy> copies) {
  const std::string stamp = now_utc();
  impl_->store->transaction([&] {
    const std::vector<IssuedCopy> taken = conflicts(copies);
    if (!taken.empty()) {
      std::string list;
      for (std::size_t i = 0; i < taken.size() && i < 10; ++i)
        list +=
            fmt::format("{}ID {} ({})", i ? "; " : "", taken[i].id,
                        taken[i].row ? fmt::format("issued to '{}' on {}, row {}", taken[i].buyer,
                                                   taken[i].issued_at, taken[i].row)
                                     : std::string("twice in this batch"));
      throw InvalidArgumentError(fmt::format(
          "{}: {} ID(s) already issued from this original under this key: {}{}; nothing "
          "recorded",
          impl_->location, taken.size(), list, taken.size() > 10 ? "; ..." : ""));
    }
    for (IssuedCopy& c : copies) {
      if (c.issued_at.empty()) c.issued_at = stamp;
      c.row = impl_->store->insert(c);
    }
  });
  return copies;
}

namespace {

// IssuedCopy::spaced_index of copies under one key, with one SpacedIds per code (bits, ID length).
class SpanIndex {
 public:
  explicit SpanIndex(const Key& key) : key_(key) {}
  std::uint64_t operator()(const IssuedCopy& c) {
    auto it = spans_.find({c.bits, c.id_bits});
    if (it == spans_.end()) {
      std::optional<SpacedIds> span;
      try {
        IdCodeOptions o;
        o.bits = c.bits, o.id_bits = c.id_bits;
        span.emplace(IdCode(o), key_);
      } catch (const InvalidArgumentError&) {
        // no code of these bits and ID length: its copies lie outside every span
      }
      it = spans_.emplace(std::make_pair(c.bits, c.id_bits), std::move(span)).first;
    }
    if (!it->second) return 0;
    try {
      return it->second->index_of(c.id);
    } catch (const InvalidArgumentError&) {
      return 0;  // an ID too long for its code
    }
  }

 private:
  const Key& key_;
  std::map<std::pair<int, int>, std::optional<SpacedIds>> spans_;
};

}  // namespace

std::vector<IssuedCopy> Registry::record(std::vector<IssuedCopy> copies, const Key& key) {
  const std::string fingerprint = key_fingerprint(key);
  const std::string stamp = now_utc();
  for (IssuedCopy& c : copies) {
    if (c.key_fingerprint != fingerprint)
      throw InvalidArgumentError(fmt::format(
          "{}: the copy for '{}' names key {}, not the key it is recorded with ({}); nothing "
          "recorded",
          registry_display_name(impl_->location), c.buyer, c.key_fingerprint, fingerprint));
    if (c.issued_at.empty()) c.issued_at = stamp;
    c.mac = row_mac(key, c);
  }
  SpanIndex spans(key);
  for (IssuedCopy& c : copies) c.spaced_index = spans(c);
  return insert(std::move(copies));
}

std::vector<IssuedCopy> Registry::reserve(std::vector<IssuedCopy> copies, const Key& key) {
  for (IssuedCopy& c : copies) c.state = "reserved", c.output_hash.clear();
  return record(std::move(copies), key);
}

std::vector<IssuedCopy> Registry::complete(std::vector<IssuedCopy> copies, const Key& key) {
  const std::string stamp = now_utc();
  for (IssuedCopy& c : copies) {
    c.state = "issued", c.issued_at = stamp;
    c.mac = row_mac(key, c);
  }
  impl_->store->transaction([&] {
    for (const IssuedCopy& c : copies)
      if (!impl_->store->complete(c))
        throw IOError(fmt::format(
            "{}: row {} ('{}', ID {}) is no longer reserved: another issue completed or removed "
            "it; nothing completed",
            registry_display_name(impl_->location), c.row, c.buyer, c.id));
  });
  return copies;
}

void Registry::release(const std::vector<IssuedCopy>& copies) {
  impl_->store->transaction([&] {
    for (const IssuedCopy& c : copies)
      if (c.row) impl_->store->release(c.row);
  });
}

std::string Registry::integrity_check() const {
  return impl_->store->integrity_check();
}

std::vector<IssuedCopy> Registry::list(const RegistryQuery& query) const {
  return impl_->store->list(query);
}

std::vector<CandidateRow> Registry::candidates(
    const RegistryQuery& query, const std::string& output_hash,
    const std::function<void(const CandidateRow&)>& first_found) const {
  return impl_->store->candidates(query, output_hash, first_found);
}

std::vector<IssuedCopy> Registry::rows(const std::vector<std::int64_t>& rows) const {
  std::vector<IssuedCopy> found = impl_->store->rows(rows);
  for (std::size_t i = 0; i < rows.size(); ++i)
    if (i >= found.size() || found[i].row != rows[i])
      throw IOError(
          fmt::format("{}: row {} is no longer in the registry (deleted while it was read)",
                      impl_->location, rows[i]));
  return found;
}

bool same_scoring(const CandidateRow& candidate, const IssuedCopy& row) {
  return candidate.row == row.row && candidate.id == row.id && candidate.id_bits == row.id_bits &&
         candidate.bits == row.bits && candidate.variant == row.variant &&
         candidate.strength == row.strength && candidate.strength_spread == row.strength_spread &&
         candidate.method == row.method && candidate.mark_format == row.mark_format;
}

std::uint64_t Registry::last_spaced_index(const IssuedCopy& c) const {
  return impl_->store->last_spaced_index(c);
}

std::vector<IssuedCopy> read_registry(const std::string& where, const RegistryQuery& query) {
  return Registry(where, true).list(query);
}

RegistryCheck verify_registry(const std::string& where, const Key& key) {
  const Registry registry(where, true);
  RegistryCheck check;
  check.integrity = registry.integrity_check();
  SpanIndex spans(key);
  for (const IssuedCopy& c : registry.list()) {
    ++check.rows;
    RowAuth auth = check_row(key, c);
    // spaced_index is derived, not in the MAC: a nonzero one the key does not give was
    // edited (it would exempt the row from the spacing checks of later IDs).
    if (auth != RowAuth::OtherKey && c.spaced_index != 0 && c.spaced_index != spans(c))
      auth = RowAuth::Edited;
    if (auth != RowAuth::OtherKey && c.state == "reserved") check.reserved.push_back(c);
    switch (auth) {
      case RowAuth::Authentic:
        ++check.authentic;
        break;
      case RowAuth::Edited:
        check.edited.push_back(c);
        break;
      case RowAuth::Unauthenticated:
        check.unauthenticated.push_back(c);
        break;
      case RowAuth::OtherKey:
        ++check.other_key;
        break;
    }
  }
  return check;
}

PassphraseKey passphrase_key_in(const std::string& where, std::string_view passphrase) {
  Key current = key_from_passphrase(passphrase), earlier = key_from_passphrase_v1(passphrase);
  const std::string current_fp = key_fingerprint(current), earlier_fp = key_fingerprint(earlier);
  PassphraseKey out;
  RegistryQuery query;
  query.key_fingerprint = current_fp;
  out.copies = read_registry(where, query).size();
  query.key_fingerprint = earlier_fp;
  out.earlier_copies = read_registry(where, query).size();
  const std::string shown = registry_display_name(where);
  if (out.copies == 0 && out.earlier_copies > 0) {
    std::swap(out.copies, out.earlier_copies);
    out.key = std::move(earlier);
    out.note = fmt::format(
        "{}: the {} copies issued under this passphrase were issued before registry schema 4, "
        "under its earlier key (one BLAKE2b of the passphrase, fast to guess): they are read "
        "with that key; issue new copies under a key file (meshmark keygen)",
        shown, out.copies);
    return out;
  }
  out.key = std::move(current);
  if (out.earlier_copies > 0)
    out.note = fmt::format(
        "{}: {} copies were issued under this passphrase's earlier key (before registry schema "
        "4) and are not candidates here: give --legacy-passphrase to read them",
        shown, out.earlier_copies);
  return out;
}

}  // namespace meshmark
