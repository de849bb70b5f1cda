#pragma once
// The storage behind Registry (registry.h): SQLite or PostgreSQL. Each backend keeps the same
// table, copies, with the same columns and the same unique key; the rules (conflicts, one
// transaction per batch) are Registry's.

#include <fmt/format.h>

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "meshmark/forensics/registry.h"

namespace meshmark::detail {

class RegistryBackend {
 public:
  virtual ~RegistryBackend() = default;
  /// The schema version of the open store.
  virtual int schema_version() = 0;
  /// Runs body in one write transaction that excludes other writers until it ends; commits
  /// when body returns, rolls back and rethrows when it throws.
  virtual void transaction(const std::function<void()>& body) = 0;
  /// The first recorded copy with c's identity (original, key, id: whatever its bits and ID
  /// length), if any; the original matched by its file's hash or, when c has one, its
  /// geometry.
  virtual bool find(const IssuedCopy& c, IssuedCopy& recorded) = 0;
  /// Inserts c (inside transaction()); returns its row.
  virtual std::int64_t insert(const IssuedCopy& c) = 0;
  /// Rewrites the row c.row with c's fields (those Registry::complete names; inside
  /// transaction()); false when no reserved row
  /// has that number.
  virtual bool complete(const IssuedCopy& c) = 0;
  /// Deletes the row if it is reserved (inside transaction()).
  virtual void release(std::int64_t row) = 0;
  /// The copies matching query, by row.
  virtual std::vector<IssuedCopy> list(const RegistryQuery& query) = 0;
  /// The scoring fields of the copies matching query, by row; same_bytes when the row's
  /// output_hash is output_hash; first_found (when set) called with the first row found.
  virtual std::vector<CandidateRow> candidates(
      const RegistryQuery& query, const std::string& output_hash,
      const std::function<void(const CandidateRow&)>& first_found) = 0;
  /// The rows numbered rows, in that order; a row that is not there is left out.
  virtual std::vector<IssuedCopy> rows(const std::vector<std::int64_t>& rows) = 0;
  /// The largest spaced_index among the copies of c's original (its file's hash or, when c
  /// has one, its geometry), key, bits and ID length; 0 when none. By index, not a scan.
  virtual std::uint64_t last_spaced_index(const IssuedCopy& c) = 0;
  /// The store's own integrity check: "ok", or its findings one per line.
  virtual std::string integrity_check() { return "ok"; }
};

/// Opens (creating its schema) the SQLite registry file at path; read_only: an existing one,
/// without changing it (an older schema read as it is, inserts refused).
std::unique_ptr<RegistryBackend> open_sqlite_registry(const std::string& path, bool read_only);

/// Connects to the PostgreSQL registry at uri (postgresql://...), creating its schema.
std::unique_ptr<RegistryBackend> open_postgres_registry(const std::string& uri);
/// The postgres component's entry point (registry_postgres.cpp), which open_postgres_registry
/// calls; without the component it throws MissingComponentError.
struct PostgresConnector {
  std::unique_ptr<RegistryBackend> (*open)(const std::string& uri);
};
/// The core's slot for it (core/component.h).
const PostgresConnector*& postgres_connector_slot();

/// The columns after row, in the order every backend lists them.
inline constexpr const char* kRegistryColumns =
    "original_hash, original_path, buyer, id, id_bits, bits, variant, strength, "
    "strength_spread, bin_offset, key_fingerprint, mark_format, issued_at, output_path, "
    "output_hash, method, original_geometry, mac, key_derivation, state, spaced_index";

/// The statements that create schema version 1's table and index, in SQLite's or
/// PostgreSQL's types.
inline std::string registry_schema_v1(bool postgres) {
  struct Column {
    const char *name, *sqlite, *postgres;
  };
  static const Column columns[] = {
      {"row", "INTEGER PRIMARY KEY", "BIGSERIAL PRIMARY KEY"},
      {"original_hash", "TEXT NOT NULL", "TEXT NOT NULL"},
      {"original_path", "TEXT NOT NULL", "TEXT NOT NULL"},
      {"buyer", "TEXT NOT NULL", "TEXT NOT NULL"},
      {"id", "INTEGER NOT NULL", "BIGINT NOT NULL"},
      {"id_bits", "INTEGER NOT NULL", "INTEGER NOT NULL"},
      {"bits", "INTEGER NOT NULL", "INTEGER NOT NULL"},
      {"variant", "TEXT NOT NULL", "TEXT NOT NULL"},
      {"strength", "REAL NOT NULL", "DOUBLE PRECISION NOT NULL"},
      {"strength_spread", "REAL NOT NULL", "DOUBLE PRECISION NOT NULL"},
      {"bin_offset", "REAL NOT NULL", "DOUBLE PRECISION NOT NULL"},
      {"key_fingerprint", "TEXT NOT NULL", "TEXT NOT NULL"},
      {"mark_format", "INTEGER NOT NULL", "INTEGER NOT NULL"},
      {"issued_at", "TEXT NOT NULL", "TEXT NOT NULL"},
      {"output_path", "TEXT NOT NULL", "TEXT NOT NULL"},
      {"output_hash", "TEXT NOT NULL", "TEXT NOT NULL"},
  };
  std::string sql = "CREATE TABLE copies (\n";
  for (const Column& c : columns)
    sql += std::string("  ") + c.name + " " + (postgres ? c.postgres : c.sqlite) + ",\n";
  sql += "  UNIQUE (original_hash, key_fingerprint, bits, id_bits, id)\n);\n";
  sql += "CREATE INDEX copies_by_buyer ON copies (buyer);\n";
  return sql;
}

/// The statements that take schema version 1's table to version 2 (the method column; earlier
/// copies were all marked by the QP framework).
inline constexpr const char* kRegistryMigrationV2 =
    "ALTER TABLE copies ADD COLUMN method TEXT NOT NULL DEFAULT 'qp'";

/// The statements that take version 2 to version 3: the original's geometry (geometry_hash;
/// '' for the copies recorded before, known by their file alone), and the index trace and the
/// duplicate-ID guard look it up by.
inline constexpr const char* kRegistryMigrationV3 =
    "ALTER TABLE copies ADD COLUMN original_geometry TEXT NOT NULL DEFAULT '';\n"
    "CREATE INDEX copies_by_geometry ON copies (original_geometry, key_fingerprint, id);";

/// The statements that take version 3 to version 4: each row's MAC (row_mac; '' for the
/// copies recorded before, which carry none) and how its key was derived (Key::derivation;
/// '' for the copies recorded before: a key file, or a passphrase's key_from_passphrase_v1),
/// and its state (IssuedCopy::state; the copies recorded before were all issued).
inline constexpr const char* kRegistryMigrationV4 =
    "ALTER TABLE copies ADD COLUMN mac TEXT NOT NULL DEFAULT '';\n"
    "ALTER TABLE copies ADD COLUMN key_derivation TEXT NOT NULL DEFAULT '';\n"
    "ALTER TABLE copies ADD COLUMN state TEXT NOT NULL DEFAULT 'issued';";

/// The statements that take version 4 to version 5: where each copy's ID lies in its code's
/// spaced enumeration (IssuedCopy::spaced_index; 0 for the copies recorded before, which are
/// checked one by one), the indexes the spacing rule looks the copies of a group up by, and
/// one that finds an ID of an original's file without reading the original's other copies.
inline std::string registry_migration_v5(bool postgres) {
  return std::string("ALTER TABLE copies ADD COLUMN spaced_index ") +
         (postgres ? "BIGINT" : "INTEGER") +
         " NOT NULL DEFAULT 0;\n"
         "CREATE INDEX copies_spaced_by_file ON copies (original_hash, key_fingerprint, bits, "
         "id_bits, spaced_index);\n"
         "CREATE INDEX copies_spaced_by_shape ON copies (original_geometry, key_fingerprint, "
         "bits, id_bits, spaced_index);\n"
         "CREATE INDEX copies_by_file ON copies (original_hash, key_fingerprint, id);";
}

/// The WHERE condition of the copies of c's group (last_spaced_index) for one way of knowing
/// the original: by_shape selects by geometry, else by file. Parameters: 1 the original's
/// file hash or geometry, 2 key_fingerprint, 3 bits, 4 id_bits (SQLite ?N, PostgreSQL $N).
inline std::string spacing_group_where(bool by_shape, char mark) {
  return fmt::format("{} = {}1 AND key_fingerprint = {}2 AND bits = {}3 AND id_bits = {}4",
                     by_shape ? "original_geometry" : "original_hash", mark, mark, mark, mark);
}

}  // namespace meshmark::detail
