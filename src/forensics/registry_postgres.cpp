// The PostgreSQL store of the registry, for issuing on several machines: the same table as the
// SQLite store; a batch is one transaction that first locks the table against other writers
// (SHARE ROW EXCLUSIVE: readers go on), so checking for taken IDs and inserting are atomic
// across machines; the schema version in a table of its own.

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <libpq-fe.h>

#include <cstdlib>
#include <regex>

#include "core/component.h"
#include "forensics/registry_backend.h"
#include "meshmark/core/error.h"

namespace meshmark::detail {

namespace {

std::string redacted(const std::string& uri) {
  return registry_display_name(uri);
}

// A result, cleared on scope exit.
class Result {
 public:
  explicit Result(PGresult* r) : r_(r) {}
  ~Result() { PQclear(r_); }
  Result(Result&& other) noexcept : r_(other.r_) { other.r_ = nullptr; }
  Result(const Result&) = delete;
  Result& operator=(const Result&) = delete;
  PGresult* get() const { return r_; }
  int rows() const { return PQntuples(r_); }
  std::string text(int row, int col) const { return PQgetvalue(r_, row, col); }
  IssuedCopy copy(int row) const {  // columns as SELECT row, kRegistryColumns lists them
    IssuedCopy c;
    c.row = std::strtoll(PQgetvalue(r_, row, 0), nullptr, 10);
    c.original_hash = text(row, 1);
    c.original_path = text(row, 2);
    c.buyer = text(row, 3);
    c.id = std::strtoull(PQgetvalue(r_, row, 4), nullptr, 10);
    c.id_bits = std::atoi(PQgetvalue(r_, row, 5));
    c.bits = std::atoi(PQgetvalue(r_, row, 6));
    c.variant = text(row, 7);
    c.strength = std::strtod(PQgetvalue(r_, row, 8), nullptr);
    c.strength_spread = std::strtod(PQgetvalue(r_, row, 9), nullptr);
    c.bin_offset = std::strtod(PQgetvalue(r_, row, 10), nullptr);
    c.key_fingerprint = text(row, 11);
    c.mark_format = std::atoi(PQgetvalue(r_, row, 12));
    c.method = text(row, 16);
    c.issued_at = text(row, 13);
    c.output_path = text(row, 14);
    c.output_hash = text(row, 15);
    c.original_geometry = text(row, 17);
    c.mac = text(row, 18);
    c.key_derivation = text(row, 19);
    c.state = text(row, 20);
    c.spaced_index = std::strtoull(PQgetvalue(r_, row, 21), nullptr, 10);
    return c;
  }

 private:
  PGresult* r_;
};

class PostgresRegistry final : public RegistryBackend {
 public:
  explicit PostgresRegistry(const std::string& uri) : name_(redacted(uri)) {
    conn_ = PQconnectdb(uri.c_str());
    if (PQstatus(conn_) != CONNECTION_OK) {
      const std::string message = PQerrorMessage(conn_);
      PQfinish(conn_);
      throw IOError(fmt::format("{}: cannot connect to the registry: {}", name_, message));
    }
    try {
      run("SET client_min_messages = warning");
      transaction([&] {
        run("SELECT pg_advisory_xact_lock(7270201)");  // one schema creator at a time
        const Result t =
            run("SELECT to_regclass('meshmark_schema') IS NOT NULL, "
                "to_regclass('copies') IS NOT NULL");
        const bool versioned = t.text(0, 0) == "t", has_copies = t.text(0, 1) == "t";
        if (!versioned && has_copies)
          throw IOError(fmt::format(
              "{}: this database has a table 'copies' that is not a meshmark registry's", name_));
        if (!versioned) {
          run("CREATE TABLE meshmark_schema (version INTEGER NOT NULL)");
          run(registry_schema_v1(true));
          run("INSERT INTO meshmark_schema VALUES (1)");
        }
        const int version = schema_version();
        if (version > kRegistrySchemaVersion)
          throw IOError(fmt::format(
              "{}: the registry has schema version {}, newer than this meshmark's {}: use a "
              "newer meshmark",
              name_, version, kRegistrySchemaVersion));
        // Migrations from version v to v + 1, each in this transaction.
        if (schema_version() == 1) {
          run(kRegistryMigrationV2);
          run("UPDATE meshmark_schema SET version = 2");
        }
        if (schema_version() == 2) {
          run(kRegistryMigrationV3);
          run("UPDATE meshmark_schema SET version = 3");
        }
        if (schema_version() == 3) {
          run(kRegistryMigrationV4);
          run("UPDATE meshmark_schema SET version = 4");
        }
        if (schema_version() == 4) {
          run(registry_migration_v5(true));
          run("UPDATE meshmark_schema SET version = 5");
        }
      });
    } catch (...) {
      PQfinish(conn_);
      throw;
    }
  }
  ~PostgresRegistry() override { PQfinish(conn_); }

  int schema_version() override {
    const Result r = run("SELECT max(version) FROM meshmark_schema");
    return r.rows() ? std::atoi(PQgetvalue(r.get(), 0, 0)) : 0;
  }

  void transaction(const std::function<void()>& body) override {
    run("BEGIN");
    try {
      if (has_copies_table()) run("LOCK TABLE copies IN SHARE ROW EXCLUSIVE MODE");
      body();
      run("COMMIT");
    } catch (...) {
      PQclear(PQexec(conn_, "ROLLBACK"));
      throw;
    }
  }

  bool find(const IssuedCopy& c, IssuedCopy& recorded) override {
    const std::vector<std::string> p = {c.original_hash, c.key_fingerprint, std::to_string(c.id),
                                        c.original_geometry};
    const Result r = run(fmt::format("SELECT row, {} FROM copies WHERE (original_hash = $1 OR "
                                     "($4 <> '' AND original_geometry = $4)) AND "
                                     "key_fingerprint = $2 AND id = $3 ORDER BY row LIMIT 1",
                                     kRegistryColumns),
                         p);
    if (r.rows() == 0) return false;
    recorded = r.copy(0);
    return true;
  }

  std::int64_t insert(const IssuedCopy& c) override {
    // Doubles as the shortest text that reads back to the same value.
    const std::vector<std::string> p = {c.original_hash,
                                        c.original_path,
                                        c.buyer,
                                        std::to_string(c.id),
                                        std::to_string(c.id_bits),
                                        std::to_string(c.bits),
                                        c.variant,
                                        fmt::format("{}", c.strength),
                                        fmt::format("{}", c.strength_spread),
                                        fmt::format("{}", c.bin_offset),
                                        c.key_fingerprint,
                                        std::to_string(c.mark_format),
                                        c.issued_at,
                                        c.output_path,
                                        c.output_hash,
                                        c.method,
                                        c.original_geometry,
                                        c.mac,
                                        c.key_derivation,
                                        c.state,
                                        std::to_string(c.spaced_index)};
    const Result r =
        run(fmt::format("INSERT INTO copies ({}) VALUES ($1, $2, $3, $4, $5, $6, "
                        "$7, $8, $9, $10, $11, $12, $13, $14, $15, $16, $17, $18, $19, $20, $21) "
                        "RETURNING row",
                        kRegistryColumns),
            p);
    return std::strtoll(PQgetvalue(r.get(), 0, 0), nullptr, 10);
  }

  std::vector<IssuedCopy> list(const RegistryQuery& query) override {
    std::vector<std::string> p;
    const std::string where = where_of(query, p);
    const Result r = run(
        fmt::format("SELECT row, {} FROM copies WHERE {} ORDER BY row", kRegistryColumns, where),
        p);
    std::vector<IssuedCopy> out;
    out.reserve(static_cast<std::size_t>(r.rows()));
    for (int i = 0; i < r.rows(); ++i) out.push_back(r.copy(i));
    return out;
  }

  std::vector<CandidateRow> candidates(
      const RegistryQuery& query, const std::string& output_hash,
      const std::function<void(const CandidateRow&)>& first_found) override {
    std::vector<std::string> p;
    const std::string where = where_of(query, p);
    p.push_back(output_hash);
    const Result r = run(fmt::format("SELECT row, id, id_bits, bits, variant, strength, "
                                     "strength_spread, method, mark_format, output_hash = ${} "
                                     "FROM copies WHERE {} ORDER BY row",
                                     p.size(), where),
                         p);
    std::vector<CandidateRow> out;
    out.reserve(static_cast<std::size_t>(r.rows()));
    for (int i = 0; i < r.rows(); ++i) {
      CandidateRow c;
      c.row = std::strtoll(PQgetvalue(r.get(), i, 0), nullptr, 10);
      c.id = std::strtoull(PQgetvalue(r.get(), i, 1), nullptr, 10);
      c.id_bits = std::atoi(PQgetvalue(r.get(), i, 2));
      c.bits = std::atoi(PQgetvalue(r.get(), i, 3));
      c.variant = r.text(i, 4);
      c.strength = std::strtod(PQgetvalue(r.get(), i, 5), nullptr);
      c.strength_spread = std::strtod(PQgetvalue(r.get(), i, 6), nullptr);
      c.method = r.text(i, 7);
      c.mark_format = std::atoi(PQgetvalue(r.get(), i, 8));
      c.same_bytes = r.text(i, 9) == "t";
      if (i == 0 && first_found) first_found(c);
      out.push_back(std::move(c));
    }
    return out;
  }

  std::vector<IssuedCopy> rows(const std::vector<std::int64_t>& rows) override {
    // One query for them all; WITH ORDINALITY keeps the order asked for.
    const Result r =
        run(fmt::format("SELECT c.row, {} FROM unnest($1::bigint[]) WITH ORDINALITY AS w(row, k) "
                        "JOIN copies c ON c.row = w.row ORDER BY w.k",
                        kRegistryColumns),
            {fmt::format("{{{}}}", fmt::join(rows, ","))});
    std::vector<IssuedCopy> out;
    out.reserve(static_cast<std::size_t>(r.rows()));
    for (int i = 0; i < r.rows(); ++i) out.push_back(r.copy(i));
    return out;
  }

  std::uint64_t last_spaced_index(const IssuedCopy& c) override {
    std::uint64_t last = 0;
    for (const bool by_shape : {false, true}) {
      if (by_shape && c.original_geometry.empty()) continue;
      const Result r = run("SELECT coalesce(max(spaced_index), 0) FROM copies WHERE " +
                               spacing_group_where(by_shape, '$'),
                           {by_shape ? c.original_geometry : c.original_hash, c.key_fingerprint,
                            std::to_string(c.bits), std::to_string(c.id_bits)});
      last = std::max<std::uint64_t>(last, std::strtoull(PQgetvalue(r.get(), 0, 0), nullptr, 10));
    }
    return last;
  }

  bool complete(const IssuedCopy& c) override {
    const Result r = run(
        "UPDATE copies SET strength = $1, bin_offset = $2, issued_at = $3, output_path = $4, "
        "output_hash = $5, mac = $6, state = $7, mark_format = $9 WHERE row = $8 AND "
        "state = 'reserved'",
        {fmt::format("{}", c.strength), fmt::format("{}", c.bin_offset), c.issued_at, c.output_path,
         c.output_hash, c.mac, c.state, std::to_string(c.row), std::to_string(c.mark_format)});
    return std::string(PQcmdTuples(r.get())) == "1";
  }

  void release(std::int64_t row) override {
    run("DELETE FROM copies WHERE row = $1 AND state = 'reserved'", {std::to_string(row)});
  }

 private:
  bool has_copies_table() {
    const Result r = run("SELECT to_regclass('copies') IS NOT NULL");
    return r.text(0, 0) == "t";
  }

  // The WHERE condition of query, its parameters appended to p ($1 on).
  static std::string where_of(const RegistryQuery& query, std::vector<std::string>& p) {
    std::string where = "TRUE";
    auto add = [&](const char* column, const std::string& value) {
      p.push_back(value);
      where += fmt::format(" AND {} = ${}", column, p.size());
    };
    if (query.original_hash && query.original_geometry) {
      p.push_back(*query.original_hash), p.push_back(*query.original_geometry);
      where += fmt::format(" AND (original_hash = ${} OR original_geometry = ${})", p.size() - 1,
                           p.size());
    } else if (query.original_hash) {
      add("original_hash", *query.original_hash);
    } else if (query.original_geometry) {
      add("original_geometry", *query.original_geometry);
    }
    if (query.buyer) add("buyer", *query.buyer);
    if (query.key_fingerprint) add("key_fingerprint", *query.key_fingerprint);
    if (query.id) add("id", std::to_string(*query.id));
    if (query.bits) add("bits", std::to_string(*query.bits));
    if (query.id_bits) add("id_bits", std::to_string(*query.id_bits));
    if (query.state) add("state", *query.state);
    if (query.spaced) where += *query.spaced ? " AND spaced_index > 0" : " AND spaced_index = 0";
    return where;
  }

  Result run(const std::string& sql, const std::vector<std::string>& params = {}) {
    std::vector<const char*> values;
    values.reserve(params.size());
    for (const std::string& v : params) values.push_back(v.c_str());
    // Without parameters: the simple protocol, which also runs several statements.
    Result r(params.empty() ? PQexec(conn_, sql.c_str())
                            : PQexecParams(conn_, sql.c_str(), static_cast<int>(values.size()),
                                           nullptr, values.data(), nullptr, nullptr, 0));
    const ExecStatusType status = PQresultStatus(r.get());
    if (status != PGRES_COMMAND_OK && status != PGRES_TUPLES_OK) {
      std::string message = PQerrorMessage(conn_);
      while (!message.empty() && (message.back() == '\n' || message.back() == ' '))
        message.pop_back();
      throw IOError(fmt::format("{}: registry: {}", name_, message));
    }
    return r;
  }

  std::string name_;
  PGconn* conn_ = nullptr;
};

std::unique_ptr<RegistryBackend> open(const std::string& uri) {
  return std::make_unique<PostgresRegistry>(uri);
}

}  // namespace

// The postgres component: Registry opens postgresql:// addresses with this.
const PostgresConnector kPostgresConnector{&open};
MESHMARK_COMPONENT(postgres, postgres_connector_slot(), kPostgresConnector)

}  // namespace meshmark::detail
