#include "meshmark/registry.h"

#include <fmt/format.h>
#include <sodium.h>
#include <sqlite3.h>

#include <ctime>
#include <set>
#include <tuple>

#include "meshmark/error.h"

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

// The columns after row, in this order everywhere.
constexpr const char* kColumns =
    "original_hash, original_path, buyer, id, id_bits, bits, variant, strength, "
    "strength_spread, bin_offset, key_fingerprint, mark_format, issued_at, output_path, "
    "output_hash";

constexpr const char* kSchemaV1 = R"sql(
CREATE TABLE copies (
  row INTEGER PRIMARY KEY,
  original_hash TEXT NOT NULL,
  original_path TEXT NOT NULL,
  buyer TEXT NOT NULL,
  id INTEGER NOT NULL,
  id_bits INTEGER NOT NULL,
  bits INTEGER NOT NULL,
  variant TEXT NOT NULL,
  strength REAL NOT NULL,
  strength_spread REAL NOT NULL,
  bin_offset REAL NOT NULL,
  key_fingerprint TEXT NOT NULL,
  mark_format INTEGER NOT NULL,
  issued_at TEXT NOT NULL,
  output_path TEXT NOT NULL,
  output_hash TEXT NOT NULL,
  UNIQUE (original_hash, key_fingerprint, bits, id_bits, id)
);
CREATE INDEX copies_by_buyer ON copies (buyer);
)sql";

using Identity = std::tuple<std::string, std::string, int, int, std::uint64_t>;

Identity identity(const IssuedCopy& c) {
  return {c.original_hash, c.key_fingerprint, c.bits, c.id_bits, c.id};
}

}  // namespace

std::string key_fingerprint(const Key& key) {
  const Key k = derive_key(key, "fingerprint");
  return hex(k.bytes.data(), 16);
}

std::string content_hash(const std::string& bytes) {
  if (sodium_init() < 0) throw Error("libsodium could not be initialized");
  unsigned char digest[32];
  crypto_generichash(digest, sizeof digest, reinterpret_cast<const unsigned char*>(bytes.data()),
                     bytes.size(), nullptr, 0);
  return hex(digest, sizeof digest);
}

namespace {

[[noreturn]] void fail(sqlite3* db, const std::string& path, const std::string& what) {
  throw IOError(fmt::format("{}: registry: {}: {}", path, what, sqlite3_errmsg(db)));
}

// A prepared statement, finalized on scope exit.
class Statement {
 public:
  Statement(sqlite3* db, const std::string& path, const std::string& sql) {
    if (sqlite3_prepare_v2(db, sql.c_str(), -1, &s_, nullptr) != SQLITE_OK)
      fail(db, path, "cannot prepare a statement");
  }
  ~Statement() { sqlite3_finalize(s_); }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;
  sqlite3_stmt* get() { return s_; }
  void bind(int i, const std::string& v) {
    sqlite3_bind_text(s_, i, v.c_str(), static_cast<int>(v.size()), SQLITE_TRANSIENT);
  }
  void bind(int i, double v) { sqlite3_bind_double(s_, i, v); }
  void bind(int i, std::int64_t v) { sqlite3_bind_int64(s_, i, v); }
  void bind(int i, int v) { sqlite3_bind_int(s_, i, v); }
  std::string text(int i) {
    const unsigned char* t = sqlite3_column_text(s_, i);
    return t ? reinterpret_cast<const char*>(t) : "";
  }

 private:
  sqlite3_stmt* s_ = nullptr;
};

}  // namespace

struct Registry::Impl {
  sqlite3* db = nullptr;
  std::string path;

  [[noreturn]] void fail(const std::string& what) const { meshmark::fail(db, path, what); }
  void exec(const char* sql) const {
    char* message = nullptr;
    if (sqlite3_exec(db, sql, nullptr, nullptr, &message) != SQLITE_OK) {
      const std::string text = message ? message : "unknown error";
      sqlite3_free(message);
      throw IOError(fmt::format("{}: registry: {}", path, text));
    }
  }
  int user_version() const {
    sqlite3_stmt* s = nullptr;
    if (sqlite3_prepare_v2(db, "PRAGMA user_version", -1, &s, nullptr) != SQLITE_OK)
      fail("cannot read the schema version");
    int v = 0;
    if (sqlite3_step(s) == SQLITE_ROW) v = sqlite3_column_int(s, 0);
    sqlite3_finalize(s);
    return v;
  }
};

Registry::Registry(const std::string& path) : impl_(std::make_unique<Impl>()) {
  impl_->path = path;
  if (sqlite3_open_v2(path.c_str(), &impl_->db,
                      SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_FULLMUTEX,
                      nullptr) != SQLITE_OK) {
    const std::string message = impl_->db ? sqlite3_errmsg(impl_->db) : "out of memory";
    sqlite3_close(impl_->db);
    throw IOError(fmt::format("{}: cannot open the registry: {}", path, message));
  }
  try {
    sqlite3_busy_timeout(impl_->db, 30000);
    impl_->exec("PRAGMA journal_mode = WAL");
    impl_->exec("PRAGMA synchronous = NORMAL");
    impl_->exec("BEGIN IMMEDIATE");
    try {
      const int version = impl_->user_version();
      if (version > kRegistrySchemaVersion)
        throw IOError(fmt::format(
            "{}: the registry has schema version {}, newer than this meshmark's {}: use a "
            "newer meshmark",
            path, version, kRegistrySchemaVersion));
      if (version == 0) {
        // A new file, or an SQLite file that is not a registry: only an empty one is taken.
        Statement tables(impl_->db, impl_->path, "SELECT count(*) FROM sqlite_master");
        sqlite3_step(tables.get());
        if (sqlite3_column_int(tables.get(), 0) != 0)
          throw IOError(
              fmt::format("{}: an SQLite database that is not a meshmark registry", path));
        impl_->exec(kSchemaV1);
        impl_->exec(fmt::format("PRAGMA user_version = {}", kRegistrySchemaVersion).c_str());
      }
      // Migrations from version v to v + 1 go here, each in this transaction.
      impl_->exec("COMMIT");
    } catch (...) {
      sqlite3_exec(impl_->db, "ROLLBACK", nullptr, nullptr, nullptr);
      throw;
    }
  } catch (...) {
    sqlite3_close(impl_->db);
    impl_->db = nullptr;
    throw;
  }
}

Registry::~Registry() {
  if (impl_ && impl_->db) sqlite3_close(impl_->db);
}

int Registry::schema_version() const {
  return impl_->user_version();
}

std::vector<IssuedCopy> Registry::conflicts(const std::vector<IssuedCopy>& copies) const {
  std::vector<IssuedCopy> out;
  std::set<Identity> seen;
  Statement q(impl_->db, impl_->path,
              fmt::format("SELECT row, {} FROM copies WHERE original_hash = ?1 AND "
                          "key_fingerprint = ?2 AND bits = ?3 AND id_bits = ?4 AND id = ?5",
                          kColumns));
  for (const IssuedCopy& c : copies) {
    if (!seen.insert(identity(c)).second) {
      out.push_back(c);
      out.back().row = 0;
      continue;
    }
    sqlite3_reset(q.get());
    q.bind(1, c.original_hash);
    q.bind(2, c.key_fingerprint);
    q.bind(3, c.bits);
    q.bind(4, c.id_bits);
    q.bind(5, static_cast<std::int64_t>(c.id));
    if (sqlite3_step(q.get()) == SQLITE_ROW) {
      IssuedCopy taken = c;
      taken.row = sqlite3_column_int64(q.get(), 0);
      taken.buyer = q.text(3);
      taken.issued_at = q.text(13);
      taken.output_path = q.text(14);
      out.push_back(taken);
    }
  }
  return out;
}

std::vector<IssuedCopy> Registry::record(std::vector<IssuedCopy> copies) {
  const std::string stamp = now_utc();
  impl_->exec("BEGIN IMMEDIATE");
  try {
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
          impl_->path, taken.size(), list, taken.size() > 10 ? "; ..." : ""));
    }
    Statement insert(impl_->db, impl_->path,
                     fmt::format("INSERT INTO copies ({}) VALUES (?1, ?2, ?3, ?4, ?5, "
                                 "?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15)",
                                 kColumns));
    for (IssuedCopy& c : copies) {
      if (c.issued_at.empty()) c.issued_at = stamp;
      sqlite3_reset(insert.get());
      insert.bind(1, c.original_hash);
      insert.bind(2, c.original_path);
      insert.bind(3, c.buyer);
      insert.bind(4, static_cast<std::int64_t>(c.id));
      insert.bind(5, c.id_bits);
      insert.bind(6, c.bits);
      insert.bind(7, c.variant);
      insert.bind(8, c.strength);
      insert.bind(9, c.strength_spread);
      insert.bind(10, c.bin_offset);
      insert.bind(11, c.key_fingerprint);
      insert.bind(12, c.mark_format);
      insert.bind(13, c.issued_at);
      insert.bind(14, c.output_path);
      insert.bind(15, c.output_hash);
      if (sqlite3_step(insert.get()) != SQLITE_DONE) impl_->fail("cannot record a copy");
      c.row = sqlite3_last_insert_rowid(impl_->db);
    }
    impl_->exec("COMMIT");
  } catch (...) {
    sqlite3_exec(impl_->db, "ROLLBACK", nullptr, nullptr, nullptr);
    throw;
  }
  return copies;
}

std::vector<IssuedCopy> Registry::list(const RegistryQuery& query) const {
  std::string where = "1";
  if (query.original_hash) where += " AND original_hash = ?1";
  if (query.buyer) where += " AND buyer = ?2";
  if (query.key_fingerprint) where += " AND key_fingerprint = ?3";
  if (query.id) where += " AND id = ?4";
  Statement q(impl_->db, impl_->path,
              fmt::format("SELECT row, {} FROM copies WHERE {} ORDER BY row", kColumns, where));
  if (query.original_hash) q.bind(1, *query.original_hash);
  if (query.buyer) q.bind(2, *query.buyer);
  if (query.key_fingerprint) q.bind(3, *query.key_fingerprint);
  if (query.id) q.bind(4, static_cast<std::int64_t>(*query.id));
  std::vector<IssuedCopy> out;
  int rc = 0;
  while ((rc = sqlite3_step(q.get())) == SQLITE_ROW) {
    IssuedCopy c;
    c.row = sqlite3_column_int64(q.get(), 0);
    c.original_hash = q.text(1);
    c.original_path = q.text(2);
    c.buyer = q.text(3);
    c.id = static_cast<std::uint64_t>(sqlite3_column_int64(q.get(), 4));
    c.id_bits = sqlite3_column_int(q.get(), 5);
    c.bits = sqlite3_column_int(q.get(), 6);
    c.variant = q.text(7);
    c.strength = sqlite3_column_double(q.get(), 8);
    c.strength_spread = sqlite3_column_double(q.get(), 9);
    c.bin_offset = sqlite3_column_double(q.get(), 10);
    c.key_fingerprint = q.text(11);
    c.mark_format = sqlite3_column_int(q.get(), 12);
    c.issued_at = q.text(13);
    c.output_path = q.text(14);
    c.output_hash = q.text(15);
    out.push_back(std::move(c));
  }
  if (rc != SQLITE_DONE) impl_->fail("cannot list the copies");
  return out;
}

}  // namespace meshmark
