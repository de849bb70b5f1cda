// The SQLite store of the registry: one file, write-ahead log, a busy timeout and write
// transactions taken immediately (BEGIN IMMEDIATE), so processes on one machine can record at
// once; the schema version in SQLite's user_version.

#include <fmt/format.h>
#include <sqlite3.h>

#include <algorithm>
#include <cctype>
#include <cstring>

#include "forensics/registry_backend.h"
#include "meshmark/core/error.h"

namespace meshmark::detail {

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
  Statement(Statement&& other) noexcept : s_(other.s_) { other.s_ = nullptr; }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;
  Statement& operator=(Statement&&) = delete;
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
  // The row's copy, columns as SELECT row, kRegistryColumns lists them.
  IssuedCopy copy() {
    IssuedCopy c;
    c.row = sqlite3_column_int64(s_, 0);
    c.original_hash = text(1);
    c.original_path = text(2);
    c.buyer = text(3);
    c.id = static_cast<std::uint64_t>(sqlite3_column_int64(s_, 4));
    c.id_bits = sqlite3_column_int(s_, 5);
    c.bits = sqlite3_column_int(s_, 6);
    c.variant = text(7);
    c.strength = sqlite3_column_double(s_, 8);
    c.strength_spread = sqlite3_column_double(s_, 9);
    c.bin_offset = sqlite3_column_double(s_, 10);
    c.key_fingerprint = text(11);
    c.mark_format = sqlite3_column_int(s_, 12);
    c.method = text(16);
    c.issued_at = text(13);
    c.output_path = text(14);
    c.output_hash = text(15);
    c.original_geometry = text(17);
    c.mac = text(18);
    c.key_derivation = text(19);
    c.state = text(20);
    c.spaced_index = static_cast<std::uint64_t>(sqlite3_column_int64(s_, 21));
    return c;
  }

 private:
  sqlite3_stmt* s_ = nullptr;
};

// A file: URI for path (percent-encoding what a URI must not hold as it is).
std::string file_uri(const std::string& path, const char* query) {
  std::string uri = "file:";
  for (const unsigned char c : path) {
    if (std::isalnum(c) || std::strchr("/-_.~", c))
      uri += static_cast<char>(c);
    else
      uri += fmt::format("%{:02X}", c);
  }
  return uri + "?" + query;
}

class SqliteRegistry final : public RegistryBackend {
 public:
  SqliteRegistry(const std::string& path, bool read_only) : path_(path), read_only_(read_only) {
    const int opened =
        read_only
            ? sqlite3_open_v2(file_uri(path, "mode=ro").c_str(), &db_,
                              SQLITE_OPEN_READONLY | SQLITE_OPEN_URI | SQLITE_OPEN_FULLMUTEX,
                              nullptr)
            : sqlite3_open_v2(path.c_str(), &db_,
                              SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_FULLMUTEX,
                              nullptr);
    if (opened != SQLITE_OK) {
      const std::string message = db_ ? sqlite3_errmsg(db_) : "out of memory";
      sqlite3_close(db_);
      throw IOError(fmt::format("{}: cannot open the registry: {}", path, message));
    }
    if (read_only) {
      try {
        sqlite3_busy_timeout(db_, 30000);
        open_read_only();
      } catch (...) {
        sqlite3_close(db_);
        throw;
      }
      return;
    }
    try {
      sqlite3_busy_timeout(db_, 30000);
      exec("PRAGMA journal_mode = WAL");
      exec("PRAGMA synchronous = NORMAL");
      transaction([&] {
        const int version = schema_version();
        if (version > kRegistrySchemaVersion)
          throw IOError(fmt::format(
              "{}: the registry has schema version {}, newer than this meshmark's {}: use a "
              "newer meshmark",
              path, version, kRegistrySchemaVersion));
        if (version == 0) {
          // A new file, or an SQLite file that is not a registry: only an empty one is taken.
          Statement tables(db_, path_, "SELECT count(*) FROM sqlite_master");
          sqlite3_step(tables.get());
          if (sqlite3_column_int(tables.get(), 0) != 0)
            throw IOError(
                fmt::format("{}: an SQLite database that is not a meshmark registry", path));
          exec(registry_schema_v1(false).c_str());
          exec("PRAGMA user_version = 1");
        }
        // Migrations from version v to v + 1, each in this transaction.
        if (schema_version() == 1) {
          exec(kRegistryMigrationV2);
          exec("PRAGMA user_version = 2");
        }
        if (schema_version() == 2) {
          exec(kRegistryMigrationV3);
          exec("PRAGMA user_version = 3");
        }
        if (schema_version() == 3) {
          exec(kRegistryMigrationV4);
          exec("PRAGMA user_version = 4");
        }
        if (schema_version() == 4) {
          exec(registry_migration_v5(false).c_str());
          exec("PRAGMA user_version = 5");
        }
      });
    } catch (...) {
      sqlite3_close(db_);
      throw;
    }
  }
  ~SqliteRegistry() override {
    insert_.reset();  // statements first: sqlite3_close refuses a connection that has some
    sqlite3_close(db_);
  }

  // Read-only: the schema as it is. Columns an older version lacks read as its migration
  // would fill them.
  void open_read_only() {
    const int version = schema_version();
    if (version == 0)
      throw IOError(
          fmt::format("{}: not a meshmark registry (an empty file, or another "
                      "SQLite database)",
                      path_));
    if (version > kRegistrySchemaVersion)
      throw IOError(fmt::format(
          "{}: the registry has schema version {}, newer than this meshmark's {}: use a newer "
          "meshmark",
          path_, version, kRegistrySchemaVersion));
    std::string columns = kRegistryColumns;
    const auto replace = [&](const std::string& column, const std::string& as) {
      columns.replace(columns.find(column), column.size(), as + " AS " + column);
    };
    if (version < 5) replace("spaced_index", "0"), spaced_column_ = false;
    if (version < 4)
      replace("mac", "''"), replace("key_derivation", "''"), replace("state", "'issued'"),
          state_column_ = false;
    if (version < 3) replace("original_geometry", "''");
    if (version < 2) replace("method", "'qp'");
    columns_ = columns;
  }

  int schema_version() override {
    Statement s(db_, path_, "PRAGMA user_version");
    return sqlite3_step(s.get()) == SQLITE_ROW ? sqlite3_column_int(s.get(), 0) : 0;
  }

  void transaction(const std::function<void()>& body) override {
    exec("BEGIN IMMEDIATE");
    try {
      body();
      exec("COMMIT");
    } catch (...) {
      sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
      throw;
    }
  }

  bool find(const IssuedCopy& c, IssuedCopy& recorded) override {
    Statement q(db_, path_,
                fmt::format("SELECT row, {} FROM copies WHERE (original_hash = ?1 OR "
                            "(?4 <> '' AND original_geometry = ?4)) AND key_fingerprint = ?2 "
                            "AND id = ?3 ORDER BY row LIMIT 1",
                            columns_));
    q.bind(1, c.original_hash);
    q.bind(4, c.original_geometry);
    q.bind(2, c.key_fingerprint);
    q.bind(3, static_cast<std::int64_t>(c.id));
    if (sqlite3_step(q.get()) != SQLITE_ROW) return false;
    recorded = q.copy();
    return true;
  }

  std::int64_t insert(const IssuedCopy& c) override {
    if (read_only_) throw IOError(fmt::format("{}: the registry is open read-only", path_));
    if (!insert_)
      insert_ = std::make_unique<Statement>(
          db_, path_,
          fmt::format("INSERT INTO copies ({}) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, "
                      "?11, ?12, ?13, ?14, ?15, ?16, ?17, ?18, ?19, ?20, ?21)",
                      kRegistryColumns));
    Statement& s = *insert_;
    sqlite3_reset(s.get());
    s.bind(1, c.original_hash);
    s.bind(2, c.original_path);
    s.bind(3, c.buyer);
    s.bind(4, static_cast<std::int64_t>(c.id));
    s.bind(5, c.id_bits);
    s.bind(6, c.bits);
    s.bind(7, c.variant);
    s.bind(8, c.strength);
    s.bind(9, c.strength_spread);
    s.bind(10, c.bin_offset);
    s.bind(11, c.key_fingerprint);
    s.bind(12, c.mark_format);
    s.bind(13, c.issued_at);
    s.bind(14, c.output_path);
    s.bind(15, c.output_hash);
    s.bind(16, c.method);
    s.bind(17, c.original_geometry);
    s.bind(18, c.mac);
    s.bind(19, c.key_derivation);
    s.bind(20, c.state);
    s.bind(21, static_cast<std::int64_t>(c.spaced_index));
    if (sqlite3_step(s.get()) != SQLITE_DONE) fail(db_, path_, "cannot record a copy");
    return sqlite3_last_insert_rowid(db_);
  }

  bool complete(const IssuedCopy& c) override {
    if (read_only_) throw IOError(fmt::format("{}: the registry is open read-only", path_));
    Statement s(db_, path_,
                "UPDATE copies SET strength = ?1, bin_offset = ?2, issued_at = ?3, "
                "output_path = ?4, output_hash = ?5, mac = ?6, state = ?7, mark_format = ?9 "
                "WHERE row = ?8 AND state = 'reserved'");
    s.bind(1, c.strength);
    s.bind(2, c.bin_offset);
    s.bind(3, c.issued_at);
    s.bind(4, c.output_path);
    s.bind(5, c.output_hash);
    s.bind(6, c.mac);
    s.bind(7, c.state);
    s.bind(8, c.row);
    s.bind(9, c.mark_format);
    if (sqlite3_step(s.get()) != SQLITE_DONE) fail(db_, path_, "cannot complete a copy's row");
    return sqlite3_changes(db_) == 1;
  }

  void release(std::int64_t row) override {
    if (read_only_) throw IOError(fmt::format("{}: the registry is open read-only", path_));
    Statement s(db_, path_, "DELETE FROM copies WHERE row = ?1 AND state = 'reserved'");
    s.bind(1, row);
    if (sqlite3_step(s.get()) != SQLITE_DONE) fail(db_, path_, "cannot release a reserved row");
  }

  std::uint64_t last_spaced_index(const IssuedCopy& c) override {
    if (!spaced_column_) return 0;  // read-only, before schema 5: no copy is spaced
    std::uint64_t last = 0;
    for (const bool by_shape : {false, true}) {
      if (by_shape && c.original_geometry.empty()) continue;
      Statement q(
          db_, path_,
          "SELECT max(spaced_index) FROM copies WHERE " + spacing_group_where(by_shape, '?'));
      q.bind(1, by_shape ? c.original_geometry : c.original_hash);
      q.bind(2, c.key_fingerprint);
      q.bind(3, c.bits);
      q.bind(4, c.id_bits);
      if (sqlite3_step(q.get()) != SQLITE_ROW) fail(db_, path_, "cannot read the spacing index");
      last = std::max(last, static_cast<std::uint64_t>(sqlite3_column_int64(q.get(), 0)));
    }
    return last;
  }

  std::string integrity_check() override {
    Statement q(db_, path_, "PRAGMA integrity_check");
    std::string found;
    int rc = 0;
    while ((rc = sqlite3_step(q.get())) == SQLITE_ROW)
      found += (found.empty() ? "" : "\n") + q.text(0);
    if (rc != SQLITE_DONE) return found + (found.empty() ? "" : "\n") + sqlite3_errmsg(db_);
    return found.empty() ? "ok" : found;
  }

  std::vector<IssuedCopy> list(const RegistryQuery& query) override {
    Statement q = select("row, " + columns_, query);
    std::vector<IssuedCopy> out;
    int rc = 0;
    while ((rc = sqlite3_step(q.get())) == SQLITE_ROW) out.push_back(q.copy());
    if (rc != SQLITE_DONE) fail(db_, path_, "cannot list the copies");
    return out;
  }

  std::vector<CandidateRow> candidates(
      const RegistryQuery& query, const std::string& output_hash,
      const std::function<void(const CandidateRow&)>& first_found) override {
    // From the columns as list() reads them (an older schema's defaults included); SQLite
    // flattens the subquery, so only these columns are read. A registry mostly of this
    // original's copies (a popular asset) is read in one pass over the table, in row order:
    // three times faster than through the indexes and a sort (10^6 rows: 0.5 s against 1.5 s).
    // A few copies among many others are found through the indexes, and sorted here.
    const auto table = [&](bool not_indexed) {
      return "(SELECT row, " + columns_ + " FROM copies" + (not_indexed ? " NOT INDEXED)" : ")");
    };
    bool scan = false;
    std::vector<CandidateRow> out;
    if (query.original_geometry && query.key_fingerprint) {
      Statement n(db_, path_,
                  fmt::format("SELECT count(*), (SELECT max(row) FROM copies) FROM {} WHERE "
                              "original_geometry = ?1 AND key_fingerprint = ?2",
                              table(false)));
      n.bind(1, *query.original_geometry);
      n.bind(2, *query.key_fingerprint);
      if (sqlite3_step(n.get()) != SQLITE_ROW) fail(db_, path_, "cannot count the copies");
      const std::int64_t copies = sqlite3_column_int64(n.get(), 0);
      scan = 4 * copies >= sqlite3_column_int64(n.get(), 1);
      out.reserve(static_cast<std::size_t>(copies));  // most of them, if not all
    }
    Statement q = select(
        "row, id, id_bits, bits, variant, strength, strength_spread, method, mark_format, "
        "output_hash = ?9",
        query, table(scan), scan);
    q.bind(9, output_hash);
    int rc = 0;
    while ((rc = sqlite3_step(q.get())) == SQLITE_ROW) {
      CandidateRow c;
      sqlite3_stmt* s = q.get();
      c.row = sqlite3_column_int64(s, 0);
      c.id = static_cast<std::uint64_t>(sqlite3_column_int64(s, 1));
      c.id_bits = sqlite3_column_int(s, 2);
      c.bits = sqlite3_column_int(s, 3);
      c.variant = q.text(4);
      c.strength = sqlite3_column_double(s, 5);
      c.strength_spread = sqlite3_column_double(s, 6);
      c.method = q.text(7);
      c.mark_format = sqlite3_column_int(s, 8);
      c.same_bytes = sqlite3_column_int(s, 9) != 0;
      if (out.empty() && first_found) first_found(c);
      out.push_back(std::move(c));
    }
    if (rc != SQLITE_DONE) fail(db_, path_, "cannot list the copies");
    if (!scan)
      std::sort(out.begin(), out.end(),
                [](const CandidateRow& a, const CandidateRow& b) { return a.row < b.row; });
    return out;
  }

  std::vector<IssuedCopy> rows(const std::vector<std::int64_t>& rows) override {
    Statement q(db_, path_, "SELECT row, " + columns_ + " FROM copies WHERE row = ?1");
    std::vector<IssuedCopy> out;
    for (const std::int64_t row : rows) {
      sqlite3_reset(q.get());
      q.bind(1, row);
      const int rc = sqlite3_step(q.get());
      if (rc == SQLITE_ROW)
        out.push_back(q.copy());
      else if (rc != SQLITE_DONE)
        fail(db_, path_, "cannot read a copy");
    }
    return out;
  }

 private:
  // SELECT what FROM from WHERE query's conditions, ORDER BY row when ordered, bound (?1 to ?8).
  Statement select(const std::string& what, const RegistryQuery& query,
                   const std::string& from = "copies", bool ordered = true) {
    std::string where = "1";
    if (query.original_hash && query.original_geometry)
      where += " AND (original_hash = ?1 OR original_geometry = ?5)";
    else if (query.original_hash)
      where += " AND original_hash = ?1";
    else if (query.original_geometry)
      where += " AND original_geometry = ?5";
    if (query.buyer) where += " AND buyer = ?2";
    if (query.key_fingerprint) where += " AND key_fingerprint = ?3";
    if (query.id) where += " AND id = ?4";
    if (query.bits) where += " AND bits = ?6";
    if (query.id_bits) where += " AND id_bits = ?7";
    if (query.state && state_column_)
      where += " AND state = ?8";
    else if (query.state && *query.state != "issued")
      where += " AND 0";  // before schema 4 every copy reads "issued"
    if (query.spaced && spaced_column_)
      where += *query.spaced ? " AND spaced_index > 0" : " AND spaced_index = 0";
    else if (query.spaced && *query.spaced)
      where += " AND 0";  // before schema 5 every copy reads spaced_index 0
    Statement q(db_, path_,
                fmt::format("SELECT {} FROM {} WHERE {}{}", what, from, where,
                            ordered ? " ORDER BY row" : ""));
    if (query.original_hash) q.bind(1, *query.original_hash);
    if (query.buyer) q.bind(2, *query.buyer);
    if (query.key_fingerprint) q.bind(3, *query.key_fingerprint);
    if (query.id) q.bind(4, static_cast<std::int64_t>(*query.id));
    if (query.original_geometry) q.bind(5, *query.original_geometry);
    if (query.bits) q.bind(6, *query.bits);
    if (query.id_bits) q.bind(7, *query.id_bits);
    if (query.state && state_column_) q.bind(8, *query.state);
    return q;
  }

  void exec(const char* sql) {
    char* message = nullptr;
    if (sqlite3_exec(db_, sql, nullptr, nullptr, &message) != SQLITE_OK) {
      const std::string text = message ? message : "unknown error";
      sqlite3_free(message);
      throw IOError(fmt::format("{}: registry: {}", path_, text));
    }
  }

  std::string path_;
  bool read_only_ = false;
  std::string columns_ = kRegistryColumns;  // what SELECT lists (read-only: the schema's)
  bool spaced_column_ = true;               // the schema has spaced_index (version 5 on)
  bool state_column_ = true;                // the schema has state (version 4 on)
  sqlite3* db_ = nullptr;
  std::unique_ptr<Statement> insert_;
};

}  // namespace

std::unique_ptr<RegistryBackend> open_sqlite_registry(const std::string& path, bool read_only) {
  return std::make_unique<SqliteRegistry>(path, read_only);
}

}  // namespace meshmark::detail
