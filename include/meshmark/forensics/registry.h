#pragma once
/// \file registry.h
/// The registry of issued copies: which buyer received which coded ID, from which original,
/// under which key (a fingerprint of it, never the key) and with which settings, so that a
/// leak can later be traced back to the copies a shop issued.
///
/// Stored in an SQLite file (write-ahead log, a busy timeout and write transactions taken
/// immediately, so several processes on one machine can record at once). record() writes a
/// whole batch in one transaction: all of it or nothing. The schema carries a version
/// (SQLite's user_version); an older registry is migrated when opened, a newer one refused.
/// An ID is recorded at most once per original and key: two buyers with the same ID could not
/// be told apart, so record() refuses the whole batch if any of its IDs is taken. An original
/// is known by its file's bytes and by its geometry (geometry_hash): the same shape saved in
/// another format, or with other bytes, is the same original.

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "meshmark/core/enum_names.h"
#include "meshmark/protocol/key.h"

namespace meshmark {

/// The schema version this build writes and reads.
inline constexpr int kRegistrySchemaVersion =
    5;  ///< 2 the method, 3 the geometry, 4 MAC, derivation, 5 spaced_index

/// One issued copy.
struct IssuedCopy {
  std::int64_t row = 0;                  ///< registry row (0 before recording)
  std::string original_hash;             ///< content_hash of the original file's bytes
  std::string original_path;             ///< the original's path as given when issuing
  std::string buyer;                     ///< the buyer's label (free text)
  std::uint64_t id = 0;                  ///< the coded ID
  int id_bits = 32;                      ///< ID length
  int bits = 64;                         ///< payload length nb
  std::string variant = "DRS";           ///< embedding variant
  double strength = 0.05;                ///< alpha
  double strength_spread = 0;            ///< keyed per-bit strength spread
  double bin_offset = 0.05;              ///< G
  std::string key_fingerprint;           ///< key_fingerprint of the key (never the key)
  int mark_format = kMarkFormatVersion;  ///< mark format version
  std::string issued_at;                 ///< UTC, ISO 8601 (filled by record() when empty)
  std::string output_path;               ///< where the copy was written
  std::string output_hash;               ///< content_hash of the copy's bytes
  /// The embedding method (method_name: "qp", "cho-mean", "cho-variance"); copies recorded
  /// by schema version 1 read "qp".
  std::string method = "qp";
  /// geometry_hash of the original as read; "" for copies recorded by schema versions 1 and 2
  /// (known by original_hash alone).
  std::string original_geometry;
  /// row_mac of this row under the key it was issued with (recorded by record() when given
  /// the key); "" for copies recorded before schema version 4 or without the key.
  std::string mac;
  /// How the key of the copy was derived (Key::derivation: a key file, a passphrase's
  /// Argon2id or, before schema 4, BLAKE2b); "" for copies recorded before schema 4 or under
  /// a key given as bytes.
  std::string key_derivation;
  /// "issued": the copy was written and this row completed with its hash; "reserved": the
  /// row was recorded before the copy was written (Registry::reserve) and the issue has not
  /// completed it: it was interrupted (a rerun finishes it) or is still running.
  std::string state = "issued";
  /// 1 + the position of the ID in its code's spaced enumeration under the copy's key
  /// (SpacedIds, spacing.h), 0 when the ID lies outside it. Derived from the ID and the key,
  /// so record() computes it (0 without the key) and the MAC leaves it out; verify_registry
  /// recomputes it. Copies recorded before schema version 5 read 0.
  std::uint64_t spaced_index = 0;
};

/// What trace needs of a candidate to score it (Registry::candidates): its row and the
/// settings both marks were embedded with. A registry of a million rows is read this way in a
/// fraction of what whole rows cost; whole rows are read for the ranking alone (Registry::rows).
struct CandidateRow {
  std::int64_t row = 0;                  ///< registry row
  std::uint64_t id = 0;                  ///< the coded ID
  int id_bits = 32;                      ///< ID length
  int bits = 64;                         ///< payload length nb
  std::string variant = "DRS";           ///< embedding variant
  double strength = 0.05;                ///< alpha (0: the fingerprint alone)
  double strength_spread = 0;            ///< keyed per-bit strength spread
  std::string method = "qp";             ///< embedding method (method_name)
  int mark_format = kMarkFormatVersion;  ///< mark format version
  /// Whether the row's output_hash is the hash Registry::candidates was given (the leak's
  /// bytes are this copy's).
  bool same_bytes = false;
};

/// Whether a candidate's scoring fields are those of the row (a row read twice is the same).
bool same_scoring(const CandidateRow& candidate, const IssuedCopy& row);

/// What the authentication code of a row says (check_row).
enum class RowAuth {
  Authentic,        ///< the MAC matches: the row is as it was recorded
  Edited,           ///< the MAC does not match: a field was changed after it was recorded
  Unauthenticated,  ///< the row has no MAC (recorded before schema 4 or without the key)
  OtherKey,         ///< the row was issued under another key: this key cannot check it
};

template <>
struct EnumTable<RowAuth> {
  static constexpr const char* what = "row authentication";
  static constexpr NamedValue<RowAuth> values[] = {{RowAuth::Authentic, "authentic"},
                                                   {RowAuth::Edited, "edited"},
                                                   {RowAuth::Unauthenticated, "unauthenticated"},
                                                   {RowAuth::OtherKey, "other key"}};
};

/// What list() selects (every given field must match; original_hash and original_geometry,
/// when both are given, select the copies matching either: an original known by its bytes or
/// by its shape).
struct RegistryQuery {
  std::optional<std::string> original_hash;      ///< copies of this original's file
  std::optional<std::string> original_geometry;  ///< copies of an original of this geometry
  std::optional<std::string> buyer;              ///< copies issued to this buyer
  std::optional<std::string> key_fingerprint;    ///< copies issued under this key
  std::optional<std::uint64_t> id;               ///< copies carrying this ID
  std::optional<int> bits;                       ///< copies of this payload length nb
  std::optional<int> id_bits;                    ///< copies of this ID length
  /// copies whose spaced_index is nonzero (true) or zero (false)
  std::optional<bool> spaced;
  std::optional<std::string> state;  ///< copies in this state ("issued", "reserved")
};

/// A fingerprint of a key that reveals nothing of it: the first 16 bytes of
/// derive_key(key, "fingerprint"), in hexadecimal (32 characters).
std::string key_fingerprint(const Key& key);

/// A path as the registry records it: absolute and lexically normal (path itself when it has
/// no absolute form).
std::string normalized_path(const std::string& path);

/// BLAKE2b-256 of bytes, in hexadecimal (64 characters).
std::string content_hash(const std::string& bytes);

/// A hash of a mesh's geometry alone, the same whatever the file format, vertex order, face
/// order, the corner a face starts at, unreferenced vertices and duplicated positions: the
/// referenced positions rounded to float32 (-0 as +0), merged when equal and sorted; the faces
/// renumbered, each turned to start at its smallest index (orientation kept), those with two
/// equal corners dropped, sorted and made unique; BLAKE2b-256 of that (docs/format.md section
/// 7), in hexadecimal.
std::string geometry_hash(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F);

/// The authentication code of a registry row: BLAKE2b-256 keyed with
/// derive_key(key, "registry row") of every field but row and mac, in a fixed order and
/// encoding (docs/format.md section 7.2), in hexadecimal. key is the key the copy was issued
/// under (its fingerprint is the row's key_fingerprint). Whoever edits a row without the key
/// (swaps two buyers' IDs, changes a buyer or a hash) cannot make its MAC match.
std::string row_mac(const Key& key, const IssuedCopy& c);

/// Checks a row's MAC against key (constant-time comparison).
RowAuth check_row(const Key& key, const IssuedCopy& c);

/// A registry location as it may be shown in output, reports and errors: a postgresql:// URI
/// with its password (the user-info password, a password= parameter) replaced by "***"; an
/// SQLite path as it is. Put the password in PGPASSFILE or PGPASSWORD instead.
std::string registry_display_name(const std::string& where);

/// Whether `recorded` (a registry row) is the copy `wanted` describes, issued already: the same
/// original, key, code, ID, buyer and embedding settings, and the same output path (wanted's
/// output_path as record() would store it). Such a copy is not issued again: a batch run again
/// after it was recorded (killed before it printed, or rerun by hand) resumes past it, provided
/// the file still holds the recorded bytes (the caller checks output_hash).
bool same_copy(const IssuedCopy& recorded, const IssuedCopy& wanted);

/// An open registry.
class Registry {
 public:
  /// Opens the SQLite registry at path, creating it (and its schema) if it does not exist.
  /// \throw IOError when it cannot be opened or created, is not a registry, or was written by
  ///        a newer schema.
  explicit Registry(const std::string& path) : Registry(path, false) {}
  /// read_only: opens an existing SQLite registry without changing its bytes (SQLite's
  /// mode=ro: no journal switch, no migration; an older schema is read as it is); record() then
  /// fails. \throw IOError also when it does not exist.
  Registry(const std::string& path, bool read_only);
  ~Registry();
  Registry(const Registry&) = delete;
  Registry& operator=(const Registry&) = delete;

  /// The copies among `copies` whose (original_hash, key_fingerprint, id) is already recorded
  /// (as recorded, whatever its bits and ID length), and those repeated within `copies`
  /// itself (the later ones, row 0).
  std::vector<IssuedCopy> conflicts(const std::vector<IssuedCopy>& copies) const;

  /// Records copies in one transaction and returns them with their rows (and issued_at when
  /// it was empty), without a MAC: trace_issued never names such a row (trace.h).
  /// \throw InvalidArgumentError listing the conflicts (nothing recorded); IOError when the
  /// database fails (nothing recorded).
  std::vector<IssuedCopy> record(std::vector<IssuedCopy> copies);
  /// The same, each row authenticated: its mac is row_mac(key, row) with issued_at filled.
  /// \throw InvalidArgumentError also when a copy's key_fingerprint is not key's.
  std::vector<IssuedCopy> record(std::vector<IssuedCopy> copies, const Key& key);

  /// Reserves copies before they are written: records them as record(copies, key) does, with
  /// the same refusals, in state "reserved" with no output hash, so that no other issue can
  /// take their IDs and an issue killed while writing leaves rows, never a copy without one.
  std::vector<IssuedCopy> reserve(std::vector<IssuedCopy> copies, const Key& key);
  /// Completes reserved rows in one transaction: each copy's row (by IssuedCopy::row) takes its
  /// strength, bin_offset, mark_format, output_path and output_hash, state "issued", issued_at
  /// now and its MAC anew. \throw IOError when a row is no longer reserved (nothing completed).
  std::vector<IssuedCopy> complete(std::vector<IssuedCopy> copies, const Key& key);
  /// Deletes the reserved rows of copies that were not written, in one transaction (rows that
  /// are not reserved are left alone).
  void release(const std::vector<IssuedCopy>& copies);

  /// The copies that match query, in the order they were recorded.
  std::vector<IssuedCopy> list(const RegistryQuery& query = {}) const;
  /// The scoring fields of the copies that match query, in the order they were recorded;
  /// same_bytes tells the row whose output_hash is output_hash ("": none). first_found, when
  /// set, is called with the first row the read finds (any of them, not always the earliest)
  /// before the others are read: trace starts on it while a large registry is read.
  std::vector<CandidateRow> candidates(
      const RegistryQuery& query, const std::string& output_hash = "",
      const std::function<void(const CandidateRow&)>& first_found = {}) const;
  /// The whole rows numbered rows, in that order. \throw IOError when one of them is not in
  /// the registry (deleted since it was listed).
  std::vector<IssuedCopy> rows(const std::vector<std::int64_t>& rows) const;
  /// The largest spaced_index among the copies of c's original (by file or geometry), key,
  /// bits and ID length, 0 when there is none: one indexed lookup, whatever the registry's size.
  std::uint64_t last_spaced_index(const IssuedCopy& c) const;

  /// The schema version of the open registry.
  int schema_version() const;

  /// SQLite's integrity check of the file ("ok" when sound, else its findings, one per
  /// line); "ok" for a PostgreSQL registry (the server keeps its own pages).
  std::string integrity_check() const;

 private:
  // record()'s transaction, spaced_index as given.
  std::vector<IssuedCopy> insert(std::vector<IssuedCopy> copies);
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// The copies of an existing registry (an SQLite file or a postgresql:// URI) that match
/// query. A registry is only read here, opened read-only: one that does not exist is not
/// created, and an SQLite file keeps its bytes (a read-only file can be read).
/// \throw IOError when it does not exist, cannot be opened or is not a registry.
std::vector<IssuedCopy> read_registry(const std::string& where, const RegistryQuery& query = {});

/// What verify_registry found.
struct RegistryCheck {
  std::string integrity = "ok";             ///< integrity_check()
  std::size_t rows = 0;                     ///< rows in the registry
  std::size_t authentic = 0;                ///< rows under the key whose MAC matches
  std::vector<IssuedCopy> edited;           ///< rows under the key whose MAC does not match
  std::vector<IssuedCopy> unauthenticated;  ///< rows under the key with no MAC
  std::size_t other_key = 0;                ///< rows of other keys (not checkable here)
  /// Rows under the key reserved and not completed (an interrupted or running issue); they
  /// do not make the check fail.
  std::vector<IssuedCopy> reserved;
  /// Whether the file is sound and every row under the key is authentic, some row being under
  /// it when the registry has any (rows of other keys alone verify nothing: the wrong key).
  bool ok() const {
    return integrity == "ok" && edited.empty() && unauthenticated.empty() &&
           (rows == 0 || other_key < rows);
  }
};

/// Checks an existing registry, opened read-only: SQLite's integrity check, and the MAC of
/// every row issued under key (the key as trace takes it). \throw IOError as read_registry.
RegistryCheck verify_registry(const std::string& where, const Key& key);

/// The key a passphrase stands for in a registry (passphrase_key_in).
struct PassphraseKey {
  Key key;                 ///< key_from_passphrase's key, or key_from_passphrase_v1's (see below)
  std::size_t copies = 0;  ///< copies in the registry issued under key
  std::size_t earlier_copies = 0;  ///< copies under the other derivation, not under key
  /// What a user should know: that the earlier derivation was used, or that copies issued
  /// under it are left out (trace them with key_from_passphrase_v1); "" otherwise.
  std::string note;
};

/// The key a passphrase stands for among the copies of an existing registry: the Argon2id key
/// of key_from_passphrase, unless the registry holds copies under the passphrase's earlier
/// key (key_from_passphrase_v1, issued before registry schema 4) and none under the Argon2id
/// one, in which case the earlier key: copies issued before still trace with their
/// passphrase. The registry is opened read-only. \throw IOError as read_registry;
/// InvalidArgumentError for an empty passphrase.
PassphraseKey passphrase_key_in(const std::string& where, std::string_view passphrase);

}  // namespace meshmark
