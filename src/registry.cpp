#include "meshmark/registry.h"

#include <fmt/format.h>
#include <sodium.h>

#include <ctime>
#include <filesystem>
#include <set>
#include <tuple>

#include "meshmark/error.h"
#include "registry_backend.h"

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

Identity identity(const IssuedCopy& c) {
  return {c.original_hash, c.key_fingerprint, c.id};
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

Registry::Registry(const std::string& location) : impl_(std::make_unique<Impl>()) {
  impl_->location = location;
  impl_->store = is_postgres(location) ? detail::open_postgres_registry(location)
                                       : detail::open_sqlite_registry(location);
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

std::vector<IssuedCopy> Registry::list(const RegistryQuery& query) const {
  return impl_->store->list(query);
}

std::vector<IssuedCopy> read_registry(const std::string& where, const RegistryQuery& query) {
  if (where.find("://") == std::string::npos && !std::filesystem::exists(where))
    throw IOError(fmt::format("{}: no such registry", where));
  return Registry(where).list(query);
}

}  // namespace meshmark
