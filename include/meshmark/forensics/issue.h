#pragma once
/// \file issue.h
/// Issuing watermarked copies: each copy of an original carries a buyer's coded ID (or a raw
/// payload), is written only when its bytes carry the mark, and is recorded in the registry of
/// issued copies. One copy (the command line's `embed`) and a manifest of many (`embed
/// --batch`) go through the same rules:
///
/// - Before anything is embedded: no two copies write the same file and no copy writes a file
///   any copy reads, the registry or a kept file (IssueSettings::kept_files: the key file, the
///   manifest), a path naming it through a link included; an ID already issued from the same
///   original under the same key, an ID given twice, or an ID whose codeword is closer than
///   kIssuedSpacing bits to one already issued is refused (a buyer must never get a copy that could
///   be taken for another's). A copy asking for `id:auto` gets the next ID of the registry's
///   spaced set that passes these rules (free_ids(), spacing.h).
/// - Each distinct original is read and prepared once, then the copies are embedded on
///   IssueSettings::threads threads, each at the fixed strength or at the strongest within
///   fidelity limits (calibrate.h).
/// - A copy is written (atomically) only when the written bytes, read back, carry every bit
///   with at least half the strength (write_marked_mesh).
/// - With a registry, every copy written is recorded in one transaction; when recording fails,
///   the copies written are removed: no issued copy goes unrecorded.
/// - A copy recorded by an earlier run with the same settings and output, its file intact, is
///   skipped when IssueSettings::resume is set (a batch run again after a kill).

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "meshmark/core/enum_names.h"
#include "meshmark/core/progress.h"
#include "meshmark/forensics/registry.h"
#include "meshmark/io/io.h"
#include "meshmark/mark/calibrate.h"
#include "meshmark/mark/embed.h"
#include "meshmark/mark/payload.h"
#include "meshmark/protocol/key.h"

namespace meshmark {

/// What every copy of one issue shares.
struct IssueSettings {
  int bits = 64;           ///< payload length nb
  EmbedOptions embedding;  ///< method, variant, strength, solver (strengths are set here)
  ReadOptions read;        ///< how originals are read, and written copies read back
  WriteOptions write;      ///< output format settings (format from the path when unset)
  std::optional<Key> key;  ///< keyed layout; the key of coded IDs (public_key() without)
  /// Coded IDs without key are coded under public_key(), which anyone can read, remove or
  /// forge: such a request is refused unless this is set.
  bool allow_public_key = false;
  int id_bits = 32;  ///< length of a coded ID in bits (1..32)
  double strength_spread =
      0.25;  ///< keyed or coded marks: per-bit strength spread (keyed_strengths)
  /// Fidelity limits: each copy gets the strongest mark within them; none: every copy at
  /// embedding.strength.
  std::optional<CalibrateOptions> limits;
  /// The buyer's fingerprint (fingerprint.h), a second mark that only trace reads, with the
  /// original; a copy with one is recorded as mark format 5 (kFingerprintMarkFormat). It moves
  /// the vertices by a further RMS of fingerprint_rms() of the diagonal (0.01 %, up to 0.03 %
  /// on originals under 32,768 counted carrier vertices); with fidelity limits both marks
  /// together stay within them, and a copy whose histogram mark cannot fit, or is infeasible at
  /// the fixed strength without limits, is issued with the fingerprint alone
  /// (CopyOutcome::fingerprint_alone) when that copy, as issued, would be named among
  /// kFingerprintAloneCandidates, and not issued otherwise.
  /// - unset (the default): every copy recorded in a registry (a coded ID) carries one, unless
  ///   its original has fewer counted carrier vertices than a fingerprint needs (128,
  ///   fingerprint_functions()): such copies are issued without, with a warning;
  /// - true: every coded copy, registered or not; a raw payload, or an original too small for
  ///   one, is refused;
  /// - false: none.
  std::optional<bool> fingerprint;
  std::string registry;  ///< record coded copies there (SQLite file or postgresql:// URI); "" none
  bool resume = true;    ///< skip copies an earlier run issued and recorded, their files intact
  int threads = 0;       ///< copies embedded at once; 0: one per hardware thread
  /// Files no copy may write, besides the inputs and the registry: the key's file and the
  /// manifest, each refused by what it is ("the key file"); paths, as given.
  std::vector<std::pair<std::string, std::string>> kept_files;  ///< (what it is, path)
  /// Called as originals are prepared and copies made (progress.h): phase "preparing",
  /// originals read and prepared of those to prepare, the original just prepared; then phase
  /// "issuing", copies done of those to make, the output just made. One copy made within
  /// `limits` (whose own progress is empty) reports its strength search instead of "issuing":
  /// the MSDM of each strength tried (CalibrateOptions::progress).
  ProgressCallback progress;
};

/// One copy to issue.
struct CopyRequest {
  std::string input;  ///< the original's path, or its name when `mesh` is set
  /// The original in memory (Python's arrays, a caller's mesh): then it is not read from
  /// `input`, which only names it in messages and as the registry's original_path, and the
  /// registry's original_hash is its geometry_hash (there are no file bytes to hash).
  std::shared_ptr<const Mesh> mesh;
  std::string output;               ///< where the copy goes (format from its extension)
  std::optional<std::uint64_t> id;  ///< a coded buyer ID, or none: a raw payload
  std::string payload_hex;          ///< the raw payload (hexadecimal), when there is no ID
  std::string buyer;                ///< the buyer's label, recorded with a coded ID
  std::size_t line = 0;             ///< its manifest line (1-based), 0 when not from one
  std::string refusal;              ///< why the request is refused before it runs, or ""
  bool auto_id = false;             ///< no id given: the registry picks it (id:auto, free_ids())
};

/// What became of a copy.
/// A copy issued with the fingerprint alone must be named, as issued, among this many
/// candidates (its own p-value times this below TraceOptions::threshold); otherwise it is not
/// issued (CopyStatus::NotEmbedded).
inline constexpr int kFingerprintAloneCandidates = 10000;

/// How a copy carrying the fingerprint alone reads as it is issued (fingerprint_alone_reading).
struct SelfReading {
  double p = 1;           ///< its own p-value, traced against its row alone
  double z = 0;           ///< its fingerprint score
  bool nameable = false;  ///< p times kFingerprintAloneCandidates below trace's 1e-6
  std::string message;    ///< one sentence saying so
};

/// Traces `copy` (the fingerprint alone of `record`'s ID under key, from `original`) as it is
/// against its own row alone: whether it would be named among kFingerprintAloneCandidates.
/// issue_copies issues such a copy only then, and campaigns do the same.
SelfReading fingerprint_alone_reading(const Mesh& copy, const Mesh& original,
                                      const IssuedCopy& record, const Key& key);

enum class CopyStatus {
  Written,            ///< written, carrying the mark (and recorded, with a registry)
  Skipped,            ///< issued and recorded by an earlier run, its file intact
  Refused,            ///< not run: a malformed request, a clash or the registry refuses it
  Unreadable,         ///< its original cannot be read
  NotEmbedded,        ///< the embedding failed (infeasible, not converged, no usable carrier)
  NotWithinFidelity,  ///< no strength within the fidelity limits carries the mark
  NotCarried,         ///< the bytes it would write do not carry the mark (nothing written)
  WriteFailed,        ///< the file cannot be written
  NotRecorded,        ///< written, but the registry could not record it: removed
};

/// The names of CopyStatus's values (copy_status_name).
template <>
struct EnumTable<CopyStatus> {
  static constexpr const char* what = "copy status";
  static constexpr NamedValue<CopyStatus> values[] = {
      {CopyStatus::Written, "written"},
      {CopyStatus::Skipped, "skipped"},
      {CopyStatus::Refused, "refused"},
      {CopyStatus::Unreadable, "unreadable"},
      {CopyStatus::NotEmbedded, "not embedded"},
      {CopyStatus::NotWithinFidelity, "not within the fidelity limits"},
      {CopyStatus::NotCarried, "not carried by the file"},
      {CopyStatus::WriteFailed, "write failed"},
      {CopyStatus::NotRecorded, "not recorded"}};
};

/// "written", "skipped", "refused", "unreadable", "not embedded", "not within the fidelity
/// limits", "not carried by the file", "write failed", "not recorded".
const char* copy_status_name(CopyStatus status);

/// One copy's outcome.
struct CopyOutcome {
  CopyStatus status = CopyStatus::Refused;
  std::string message;                ///< why it failed, or a one-line summary of the copy
  std::vector<std::string> warnings;  ///< the reader's notes and a weak carrier's diagnostics
  Payload word;                       ///< payload order (a coded ID's codeword)
  Payload bins;                       ///< bin order: what was embedded
  EmbedOptions embedding;             ///< as embedded (the strength found by a search)
  EmbedResult result;                 ///< the embedding (positions dropped once written)
  std::optional<CalibrateResult> calibration;  ///< the fidelity search, with limits
  IssuedCopy record;                           ///< the registry record (coded IDs with a registry)
  std::int64_t vertices = 0;                   ///< the original's vertex count
  /// Written with the fingerprint alone: no histogram mark fits the fidelity limits, or none is
  /// feasible at the fixed strength of a registered copy (word, bins, embedding and result are
  /// then the search's weakest attempt or the infeasible embedding, not in the copy, but for
  /// result.rms_percent, the copy's; the record's strength is 0).
  bool fingerprint_alone = false;
  /// Written with the fingerprint kept from moving the center (add_fingerprint's
  /// center_motion): the plain field would have cost the file histogram bits (weak marks).
  bool kept_center = false;
  bool ok() const { return status == CopyStatus::Written || status == CopyStatus::Skipped; }
};

/// What issue_copies did.
struct IssueResult {
  std::vector<CopyOutcome> copies;             ///< one per request, in order
  std::size_t inputs = 0;                      ///< distinct originals
  int threads = 1;                             ///< threads the copies were embedded on
  double seconds = 0;                          ///< wall time
  std::size_t count(CopyStatus status) const;  ///< copies with this status
};

/// Issues one copy per request (see the file's comment for the rules). Never throws for one
/// copy's failure: each outcome says what happened to it.
/// \throw InvalidArgumentError for settings out of range; IOError when the registry cannot be
///        opened.
IssueResult issue_copies(std::vector<CopyRequest> requests, const IssueSettings& settings);

/// An original an Issuer has prepared.
struct PreparedOriginal {
  std::string geometry;              ///< its geometry_hash: how it is known (registry.h)
  std::string name;                  ///< the name it was prepared under (its original_path)
  std::int64_t vertices = 0;         ///< vertices
  std::int64_t faces = 0;            ///< faces
  bool prepared_before = false;      ///< prepare() found it prepared already: nothing done
  std::shared_ptr<const Mesh> mesh;  ///< the mesh: a request's CopyRequest::mesh names it
};

/// A long-running issuer (`meshmark serve`, Python's `meshmark.Issuer`): it holds the registry
/// open and up to max_originals prepared originals (read, checked, hashed, the embedder's and
/// the fingerprint's preparation), the least recently used dropped first, so that a copy of a
/// prepared original costs its embedding and writing alone. Its calls may come from several
/// threads: the registry's steps (choosing and reserving IDs, completing rows) run one at a
/// time, the embedding and writing of copies side by side. Every rule of issue_copies holds.
class Issuer {
 public:
  /// \throw InvalidArgumentError for settings out of range; IOError when the registry cannot
  ///        be opened.
  explicit Issuer(IssueSettings settings, std::size_t max_originals = 16);
  ~Issuer();
  Issuer(const Issuer&) = delete;
  Issuer& operator=(const Issuer&) = delete;

  /// Prepares an original named `name`; an original of the same geometry prepared before is
  /// not prepared again (prepared_before). \throw InvalidInputError for a mesh validate_mesh
  /// refuses; InvalidArgumentError when the settings cannot embed in it.
  PreparedOriginal prepare(Mesh mesh, const std::string& name);
  /// The prepared original of this geometry hash, if it is held.
  std::optional<PreparedOriginal> find(const std::string& geometry);
  /// Issues copies as issue_copies does; a request whose CopyRequest::mesh is a prepared
  /// original's `mesh` uses its preparation.
  IssueResult issue(std::vector<CopyRequest> requests);
  /// The settings every copy is issued with.
  const IssueSettings& settings() const;
  /// The open registry, or nullptr without one.
  Registry* registry();

 private:
  std::optional<PreparedOriginal> find_locked(const std::string& geometry) const;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Sets request's ID from text: "auto" (the registry picks it: CopyRequest::auto_id) or an ID
/// in decimal or 0x hex (parse_id() in coding.h, which throws InvalidArgumentError).
void set_copy_id(CopyRequest& request, const std::string& text);

/// Reads a manifest. A path ending in `.csv` is CSV (RFC 4180: commas, quoted fields holding
/// commas, doubled quotes or line breaks, any UTF-8) with a header row naming the columns
/// `input`, `output`, `id` or `payload`, and `buyer`, in any order. Any other path holds one
/// copy per line, `INPUT OUTPUT PAYLOAD` (hexadecimal) or `INPUT OUTPUT id:N BUYER...` (a coded
/// ID, or `id:auto`, and the buyer's label); `#` starts a comment, and a line whose buyer label
/// a `#` would cut is refused (such a label needs CSV); blank lines are skipped. A malformed line
/// or record is a request with its refusal set, so that it is reported like any other failure.
/// \throw IOError when the file cannot be read (at most 64 MiB); InvalidInputError for a CSV
///        header without the needed columns, or a CSV record whose quoting is broken.
std::vector<CopyRequest> read_manifest(const std::string& path);

/// The registry record of a copy of input (its content hash read from the file) carrying the
/// coded id for buyer, under key, with settings' embedding. \throw IOError when input cannot
/// be read.
IssuedCopy issued_copy(const std::string& input, const std::string& buyer, std::uint64_t id,
                       const IssueSettings& settings);

/// The same for an original in memory named `name` (CopyRequest::mesh): its original_hash is
/// its geometry_hash, its original_path the name as given. Both record mark format 5
/// (kFingerprintMarkFormat) when settings give such a copy the fingerprint
/// (IssueSettings::fingerprint), else kMarkFormatVersion.
IssuedCopy issued_copy(const Mesh& original, const std::string& name, const std::string& buyer,
                       std::uint64_t id, const IssueSettings& settings);

}  // namespace meshmark
