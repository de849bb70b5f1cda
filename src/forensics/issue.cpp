// Issuing watermarked copies (issue.h): the registry's refusals, each original read once, the
// copies embedded in parallel, written only when they carry the mark, recorded in one
// transaction.

#include "meshmark/forensics/issue.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <set>

#include "core/parallel.h"
#include "core/progress_counter.h"
#include "meshmark/carrier/center.h"
#include "meshmark/carrier/histogram.h"
#include "meshmark/core/error.h"
#include "meshmark/forensics/fingerprint.h"
#include "meshmark/forensics/spacing.h"
#include "meshmark/forensics/trace.h"
#include "meshmark/metrics/metrics.h"
#include "meshmark/protocol/coding.h"
#include "meshmark/protocol/watermark.h"

namespace meshmark {

namespace fs = std::filesystem;

namespace {

// The same file for two names (an existing file by identity, a new one by its absolute path).
std::string file_identity(const std::string& path) {
  std::error_code ec;
  const auto absolute = fs::absolute(path, ec);
  if (ec) return path;
  const auto canonical = fs::weakly_canonical(absolute, ec);
  return ec ? absolute.lexically_normal().string() : canonical.lexically_normal().string();
}

// What an original is read and prepared once under: its path, or the address of the mesh given
// in memory (two meshes in memory may share a name).
std::string original_key(const CopyRequest& r) {
  return r.mesh ? fmt::format("\x01mesh {}", static_cast<const void*>(r.mesh.get())) : r.input;
}

void refuse(CopyOutcome& outcome, std::string message) {
  outcome.status = CopyStatus::Refused;
  outcome.message = std::move(message);
}

bool pending(const CopyOutcome& outcome) {
  return outcome.status == CopyStatus::Written && outcome.message.empty();
}

// Whether a and b name one file: the same canonical path (links resolved), or, both existing,
// the same inode (a hard link).
bool same_file(const std::string& a, const std::string& b) {
  if (file_identity(a) == file_identity(b)) return true;
  std::error_code ec;
  return fs::equivalent(a, b, ec);
}

// Before anything is embedded: no two copies write the same file, and no copy writes a file
// any copy reads, the registry or a kept file. Every copy involved is refused.
void refuse_clashes(const std::vector<CopyRequest>& requests, const IssueSettings& settings,
                    std::vector<CopyOutcome>& out) {
  std::vector<std::pair<std::string, std::string>> kept = settings.kept_files;
  if (!settings.registry.empty() && settings.registry.find("://") == std::string::npos)
    kept.emplace_back("the registry", settings.registry);
  for (std::size_t k = 0; k < requests.size(); ++k) {
    if (!pending(out[k])) continue;
    for (const auto& [what, path] : kept)
      if (!path.empty() && pending(out[k]) && same_file(requests[k].output, path))
        refuse(out[k],
               fmt::format("{}: refusing to overwrite {} ({})", requests[k].output, what, path));
  }
  const auto where = [&](std::size_t k) {
    return requests[k].line ? fmt::format("line {}", requests[k].line)
                            : fmt::format("copy {}", k + 1);
  };
  std::map<std::string, std::vector<std::size_t>> writers;
  std::map<std::string, std::size_t> readers;
  for (std::size_t k = 0; k < requests.size(); ++k) {
    if (!pending(out[k])) continue;
    const std::string output = file_identity(requests[k].output);
    if (!requests[k].mesh && same_file(requests[k].output, requests[k].input)) {
      refuse(out[k], fmt::format("{}: refusing to overwrite the input file", requests[k].output));
      continue;
    }
    writers[output].push_back(k);
    if (!requests[k].mesh) readers.emplace(file_identity(requests[k].input), k);
  }
  for (const auto& [file, ks] : writers) {
    if (ks.size() > 1) {
      std::string names;
      for (const std::size_t k : ks) names += (names.empty() ? "" : ", ") + where(k);
      for (const std::size_t k : ks)
        refuse(out[k], fmt::format("{} all write this output: none of them is run", names));
    }
    const auto r = readers.find(file);
    if (r != readers.end())
      for (const std::size_t k : ks)
        if (pending(out[k]))
          refuse(out[k], fmt::format("the output is the input of {}", where(r->second)));
  }
}

// What an issue of `wanted` may have decided for itself, taken from the row `taken` records:
// the strength and G a fidelity search found (searched), and a copy issued without the
// fingerprint it was to carry by default because it would have cost the file its histogram
// mark (make_copy).
void as_decided(const IssuedCopy& taken, IssuedCopy& wanted, bool searched,
                const IssueSettings& settings) {
  if (searched) wanted.strength = taken.strength, wanted.bin_offset = taken.bin_offset;
  if (wanted.mark_format == kFingerprintMarkFormat && taken.mark_format == kMarkFormatVersion &&
      !settings.fingerprint.value_or(false))
    wanted.mark_format = taken.mark_format;
}

// Whether the recorded copy is this one, issued by an earlier run, with its file as recorded
// (with fidelity limits, the strength and G recorded are whatever the search found for it).
bool resumable(const IssuedCopy& taken, IssuedCopy wanted, const std::string& output,
               const IssueSettings& settings) {
  if (taken.state != "issued") return false;
  wanted.output_path = normalized_path(output);
  as_decided(taken, wanted, settings.limits.has_value(), settings);
  if (!same_copy(taken, wanted)) return false;
  try {
    return content_hash(read_file(output)) == taken.output_hash;
  } catch (const std::exception&) {
    return false;  // gone or unreadable: not resumable, refused as already issued
  }
}

// How a copy is refused when another issue took its ID between the choice and the
// reservation (another server on the same registry), or the reservation failed (that, or the
// database): Issuer issues such a copy again when the registry chose its ID.
constexpr const char* kChosenMeanwhile = "taken meanwhile: ";
constexpr const char* kNotReserved = "not reserved: ";

// The registry's refusals: coded IDs only, an ID issued before or given twice (or skipped, an
// intact copy of an earlier run), a codeword too close to an issued one.
// Requests with id:auto get theirs here, chosen by free_ids() (spacing.h).
void check_registry(const Registry& registry, std::vector<CopyRequest>& requests,
                    const IssueSettings& settings, std::map<std::string, IssuedCopy>& originals,
                    std::vector<CopyOutcome>& out) {
  std::vector<std::size_t> candidates, automatic;
  std::vector<IssuedCopy> given, chosen;  // the copies with an ID, those asking for one
  for (std::size_t k = 0; k < requests.size(); ++k) {
    if (!pending(out[k])) continue;
    if (!requests[k].id && !requests[k].auto_id) {
      refuse(out[k], "a registry records coded IDs only (id:N, id:auto, --id)");
      continue;
    }
    try {
      const CopyRequest& r = requests[k];
      auto it = originals.find(original_key(r));
      if (it == originals.end())
        it = originals
                 .emplace(original_key(r), r.mesh ? issued_copy(*r.mesh, r.input, "", 0, settings)
                                                  : issued_copy(r.input, "", 0, settings))
                 .first;
      out[k].record = it->second;
      out[k].record.buyer = requests[k].buyer;
      out[k].record.id = requests[k].id.value_or(0);
      candidates.push_back(k);
      if (requests[k].auto_id)
        automatic.push_back(k), chosen.push_back(out[k].record);
      else
        given.push_back(out[k].record);
    } catch (const IOError& e) {
      out[k].status = CopyStatus::Unreadable, out[k].message = e.what();
    } catch (const InvalidInputError& e) {
      out[k].status = CopyStatus::Unreadable, out[k].message = e.what();
    }
  }
  if (!automatic.empty()) {
    try {
      const std::vector<std::uint64_t> ids =
          free_ids(registry, given, chosen, id_key(settings.key));
      for (std::size_t j = 0; j < automatic.size(); ++j)
        requests[automatic[j]].id = out[automatic[j]].record.id = ids[j];
    } catch (const InvalidArgumentError& e) {
      for (const std::size_t k : automatic) refuse(out[k], e.what());
    }
  }
  // The same ID of the same original: the same file, or the same geometry in another file.
  const auto same = [&](std::size_t k, const IssuedCopy& c) {
    const IssuedCopy& r = out[k].record;
    return pending(out[k]) && r.id == c.id &&
           (r.original_hash == c.original_hash ||
            (!c.original_geometry.empty() && r.original_geometry == c.original_geometry));
  };
  std::vector<IssuedCopy> wanted;
  wanted.reserve(candidates.size());
  for (const std::size_t k : candidates) wanted.push_back(out[k].record);
  for (const IssuedCopy& taken : registry.conflicts(wanted))
    for (const std::size_t k : candidates) {
      if (!same(k, taken)) continue;
      if (requests[k].auto_id && taken.row) {
        // Chosen free a moment ago: another issue (another server on the registry) took it.
        refuse(out[k], kChosenMeanwhile + fmt::format("ID {} was taken by another issue while "
                                                      "this one chose it",
                                                      taken.id));
        continue;
      }
      if (taken.row && taken.state == "reserved") {
        // An issue that reserved this row and did not complete it: this very copy (buyer,
        // settings, output) is finished under the same row, whatever its file holds now.
        IssuedCopy request = out[k].record;
        request.output_path = normalized_path(requests[k].output);
        as_decided(taken, request, true, settings);
        if (same_copy(taken, request)) {
          out[k].record.row = taken.row;
          out[k].record.issued_at = taken.issued_at;
          out[k].warnings.push_back(fmt::format(
              "{}: ID {} was reserved for '{}' on {} (row {}) by an issue that did not complete "
              "it: this run writes the copy and completes the row",
              requests[k].output, taken.id, taken.buyer, taken.issued_at, taken.row));
          continue;
        }
        refuse(out[k],
               fmt::format("ID {} is reserved for '{}' since {} (row {}, {}) by an issue "
                           "that is running or was interrupted: rerun that issue to "
                           "finish it, or choose another ID",
                           taken.id, taken.buyer, taken.issued_at, taken.row, taken.output_path));
        continue;
      }
      if (taken.row && settings.resume &&
          resumable(taken, out[k].record, requests[k].output, settings)) {
        out[k].status = CopyStatus::Skipped;
        out[k].message = fmt::format("already issued to '{}' on {} and its file is intact: skipped",
                                     taken.buyer, taken.issued_at);
        continue;
      }
      const bool other_file = taken.original_hash != out[k].record.original_hash;
      refuse(out[k],
             taken.row
                 ? fmt::format("ID {} already issued from this original{} under this key to '{}' "
                               "on {} ({}): choose another ID",
                               taken.id,
                               other_file
                                   ? fmt::format(" (the same geometry, as {})", taken.original_path)
                                   : "",
                               taken.buyer, taken.issued_at, taken.output_path)
                 : fmt::format("ID {} is given twice for this original", taken.id));
    }
  // An output file that is another row's issued copy of this original would be lost: refused.
  // The rows are listed only when the file exists (a fresh output, the usual case, costs nothing).
  std::map<std::string, std::vector<IssuedCopy>> issued_of;  // by original file hash
  for (const std::size_t k : candidates) {
    std::error_code ec;
    if (!pending(out[k]) || !fs::exists(requests[k].output, ec)) continue;
    const IssuedCopy& r = out[k].record;
    auto it = issued_of.find(r.original_hash);
    if (it == issued_of.end()) {
      RegistryQuery q;
      q.original_hash = r.original_hash;
      it = issued_of.emplace(r.original_hash, registry.list(q)).first;
    }
    const std::string path = normalized_path(requests[k].output);
    for (const IssuedCopy& other : it->second)
      if (other.output_path == path && other.id != r.id) {
        refuse(out[k],
               fmt::format("{} is the copy issued to '{}' (ID {}, row {}) on {}: writing "
                           "this copy there would lose it; choose another output",
                           requests[k].output, other.buyer, other.id, other.row, other.issued_at));
        break;
      }
  }
  wanted.clear();
  std::vector<std::size_t> index;
  for (const std::size_t k : candidates)
    if (pending(out[k])) wanted.push_back(out[k].record), index.push_back(k);
  for (const CloseCodeword& c : close_codewords(registry, wanted, id_key(settings.key)))
    for (const std::size_t k : index)
      if (same(k, c.copy))
        refuse(out[k], fmt::format("ID {}'s codeword is {} bits from that of ID {} ('{}'), closer "
                                   "than {}: a copy of one could be taken for the other; choose "
                                   "another ID",
                                   c.copy.id, c.distance, c.near.id, c.near.buyer, kIssuedSpacing));
}

// Whether coded copies are to carry the fingerprint (IssueSettings::fingerprint: unset, those
// recorded in a registry), where their original can carry one.
bool wants_fingerprint(const IssueSettings& settings) {
  return settings.fingerprint.value_or(!settings.registry.empty());
}

// An original, read and prepared once for every copy made from it.
struct Original {
  Mesh mesh;
  PreparedEmbedder embedder;
  /// The fingerprint's basis (IssueSettings::fingerprint); none without, or for an original
  /// too small for one (fingerprint_functions()). Its bumps alone (no rows) for an original
  /// prepared for one copy: the rows are then evaluated as the copy is made (add_fingerprint_at).
  std::optional<FingerprintBasis> fingerprint;
  Histogram histogram;  ///< the original's, around the fingerprint's center (settings.bits)
  Eigen::MatrixX3d center_motion;  ///< FingerprintFrame's: the field leaves the center alone
  std::size_t counted = 0;         ///< counted carrier vertices
  /// Where the basis is evaluated (FingerprintFrame::counted), when its rows are not held.
  std::vector<std::uint8_t> counted_mask;
  /// Why the original has no fingerprint though it has enough counted vertices (its geometry
  /// gives the basis nothing to stand on: no area, sizes beyond double's squares); empty if not.
  std::string no_fingerprint;
  /// MSDM's side of the original, computed by the first copy measured within fidelity limits
  /// and shared by every later one and every measure of the copies' distortion.
  std::shared_ptr<SharedMsdmReference> msdm = std::make_shared<SharedMsdmReference>();
};

// What issue_copies keeps of the originals it has read, and Issuer across its calls.
struct OriginalCache {
  std::map<std::string, std::shared_ptr<const Original>> prepared;  // by original_key
  std::map<std::string, IssuedCopy> records;  // by original_key: its registry record
  /// Whether the cache outlives one issue (Issuer): its originals are then prepared with the
  /// fingerprint's rows, for the copies to come.
  bool kept = false;
};

// Reads (unless in memory), checks and prepares an original for every copy made from it; for
// one copy (`several` false), without the fingerprint's rows (Original::fingerprint).
std::shared_ptr<const Original> prepare_original(const CopyRequest& request,
                                                 const IssueSettings& settings, bool several) {
  Mesh mesh = request.mesh ? *request.mesh : read_mesh(request.input, settings.read);
  if (request.mesh) validate_mesh(mesh.V, mesh.F, request.input);
  PreparedEmbedder embedder(mesh.V, mesh.F, settings.embedding);
  std::optional<FingerprintBasis> basis;
  Histogram histogram;
  Eigen::MatrixX3d center_motion;
  std::size_t counted = 0;
  std::vector<std::uint8_t> counted_mask;
  std::string no_fingerprint;
  if (wants_fingerprint(settings)) {
    const std::vector<std::uint8_t> carrier = carrier_vertices(mesh.V, mesh.F);
    counted = static_cast<std::size_t>(std::count(carrier.begin(), carrier.end(), kCounted));
    try {
      if (std::optional<FingerprintFrame> frame = fingerprint_frame(
              mesh.V, mesh.F, settings.embedding.variant.center, settings.bits, several)) {
        basis = std::move(frame->basis);
        histogram = std::move(frame->histogram);
        center_motion = std::move(frame->center_motion);
        if (!several) counted_mask = std::move(frame->counted);
      }
    } catch (const InvalidArgumentError& e) {
      // The copy then goes as one without a fingerprint (make_copy says why), and its
      // histogram mark says what it can do with such a shape.
      no_fingerprint = e.what();
    }
  }
  return std::make_shared<const Original>(Original{
      std::move(mesh), std::move(embedder), std::move(basis), std::move(histogram),
      std::move(center_motion), counted, std::move(counted_mask), std::move(no_fingerprint)});
}

// The distortion of positions V of the original O as calibration measures it: each counted
// position once, % of the carrier's diagonal; MSDM against the original, measured only when the
// RMS is within its limit (-1 otherwise).
struct Distortion {
  double rms_percent = 0, msdm = -1;
  bool within(const CalibrateOptions& limits) const {
    return msdm >= 0 && rms_percent <= limits.max_rms_percent && msdm <= limits.max_msdm;
  }
};

Distortion distortion(const Original& original, const Eigen::MatrixX3d& V,
                      const CalibrateOptions& limits) {
  const Mesh& O = original.mesh;
  const std::vector<std::uint8_t> carrier = carrier_vertices(O.V, O.F);
  double sum = 0, n = 0;
  for (Eigen::Index i = 0; i < O.V.rows(); ++i)
    if (carrier[i] == kCounted) sum += (V.row(i) - O.V.row(i)).squaredNorm(), n += 1;
  Distortion d;
  d.rms_percent = n > 0 ? 100 * std::sqrt(sum / n) / bounding_box_diagonal(O.V, carrier) : 0;
  if (d.rms_percent <= limits.max_rms_percent)
    d.msdm = original.msdm->get(O.V, O.F).compare(V).global;
  return d;
}

using Field = std::function<Eigen::MatrixX3d(const Eigen::MatrixX3d&)>;

// A copy whose histogram mark cannot fit the limits, or cannot be embedded at a fixed strength
// (no limits: some bits infeasible), issued with the fingerprint alone when that fits them (its
// row records strength 0: trace then reads the fingerprint only), or refused naming both.
// `fields`: the fingerprint at the RMS issued (fingerprint_rms), then at FingerprintOptions::rms
// when that is less (a small original's raised RMS may not fit where the plain one does); the
// first that fits is issued. `why`: the calibration's or the embedding's message.
void issue_fingerprint_alone(const CopyRequest& request, const Original& original,
                             const IssueSettings& settings, const std::vector<Field>& fields,
                             const std::optional<CalibrateOptions>& fidelity,
                             const std::string& why, CopyOutcome& out) {
  const Mesh& O = original.mesh;
  Mesh copy = O;
  CalibrateOptions limits;  // none: measured for the message alone
  limits.max_rms_percent = limits.max_msdm = std::numeric_limits<double>::infinity();
  if (fidelity) limits = *fidelity;
  Distortion d;
  for (const Field& add : fields) {
    copy.V = add(O.V);
    d = distortion(original, copy.V, limits);
    if (d.within(limits)) break;
  }
  const double rms = d.rms_percent, m = d.msdm;
  if (!d.within(limits)) {
    out.status = CopyStatus::NotWithinFidelity;
    out.message = fmt::format("{}; the fingerprint alone does not fit either (RMS {:.5f} %{})", why,
                              rms, m >= 0 ? fmt::format(", MSDM {:.4f}", m) : std::string());
    return;
  }
  // A copy nobody can name is no copy: traced as it is, against its own row alone, it must be
  // named among kFingerprintAloneCandidates (on a few hundred vertices, or a shape whose every
  // displacement moves the histogram, the field is too weak for that).
  const SelfReading self =
      fingerprint_alone_reading(copy, O, out.record, settings.key.value_or(public_key()));
  if (!self.nameable) {
    out.status = CopyStatus::NotEmbedded;
    out.message = fmt::format("{}; {}: not issued", why, self.message);
    return;
  }
  std::error_code ec;
  if (!request.mesh && fs::equivalent(request.output, request.input, ec)) {
    refuse(out, fmt::format("{}: refusing to overwrite the input file", request.output));
    return;
  }
  try {
    write_mesh(request.output, copy, settings.write);
  } catch (const IOError& e) {
    out.status = CopyStatus::WriteFailed, out.message = e.what();
    return;
  }
  out.record.strength = 0, out.record.bin_offset = 0;
  out.fingerprint_alone = true;
  // No histogram mark in the copy: what is reported of it is the copy's (the fingerprint's).
  out.result.V.resize(0, 3);
  out.result.rms_percent = rms;
  out.message = fmt::format("the fingerprint alone, RMS {:.5f} %, MSDM {:.4f}", rms, m);
  if (request.auto_id) out.message = fmt::format("ID {}, {}", *request.id, out.message);
  out.warnings.push_back(fmt::format(
      "{}: {} ({}): issued with the fingerprint alone, which only trace reads, with the "
      "original and the registry",
      request.input,
      fidelity ? "no histogram mark fits the fidelity limits"
               : fmt::format("no histogram mark at strength {:g}", out.embedding.strength),
      why));
}

// Embeds and writes one copy (out[k] pending).
void make_copy(const CopyRequest& request, const Original& original, const IssueSettings& settings,
               const IdCode* code, CopyOutcome& out) {
  const int nb = settings.bits;
  const bool coded = request.id.has_value();
  out.vertices = original.mesh.V.rows();
  for (const std::string& note : original.mesh.notes)
    out.warnings.push_back(fmt::format("{}: {}", request.input, note));
  out.word = coded ? code->encode(*request.id, id_key(settings.key))
                   : payload_from_hex(request.payload_hex, nb);
  out.bins = mark_layout(settings.key, nb, coded).to_bins(out.word);
  EmbedOptions& o = out.embedding;
  o.strengths = mark_strengths(settings.key, nb, coded, o.strength, settings.strength_spread);
  // The fingerprint (fingerprint.h), added after the histogram mark; with fidelity limits,
  // to every strength tried, so that both marks together fit them.
  Field fingerprint;
  Field plain_fingerprint;  // at FingerprintOptions::rms, when fingerprint's is raised
  const bool required = settings.fingerprint.value_or(false);
  if (required && !coded) {
    refuse(out, "a fingerprint goes with a coded ID, not a raw payload");
    return;
  }
  if (coded && wants_fingerprint(settings) && !original.fingerprint) {
    const std::string few =
        original.no_fingerprint.empty()
            ? fmt::format(
                  "{}: {} counted carrier vertices are too few for a fingerprint ({} at least)",
                  request.input, original.counted, 16 * 8)
            : fmt::format("{}: no fingerprint can be made on it ({})", request.input,
                          original.no_fingerprint);
    if (required) {
      refuse(out, few + "; issue it without one");
      return;
    }
    out.warnings.push_back(few + ": issued with the histogram mark alone");
  }
  // The field kept from moving the center too (add_fingerprint's center_motion): a second
  // chance for a copy whose file the plain field would cost histogram bits (the center's drift,
  // which weak marks feel); it costs the field 6 to 16 % of its RMS, so it is not the default.
  Field centered;
  // The plain RMS (the fingerprint's is fingerprint_rms, raised on small originals), and what
  // sets the fields above at an RMS.
  const double plain_rms = FingerprintOptions().rms;
  std::function<void(double)> use_rms;
  if (coded && original.fingerprint) {
    const FingerprintBasis& b = *original.fingerprint;
    const Eigen::VectorXd g =
        fingerprint_coefficients(id_key(settings.key), *request.id, b.functions);
    const auto add = [&original, &b, g](const Eigen::MatrixX3d& V,
                                        const Eigen::MatrixX3d* center_motion, double r) {
      if (b.row_start.empty())  // prepared for one copy: the rows are not held
        return add_fingerprint_at(V, original.mesh.V, b, original.counted_mask, g, r,
                                  &original.histogram, center_motion);
      return add_fingerprint(V, original.mesh.V, b, g, r, &original.histogram, center_motion);
    };
    use_rms = [add, &original, &fingerprint, &centered](double r) {
      fingerprint = [add, r](const Eigen::MatrixX3d& V) { return add(V, nullptr, r); };
      centered = [add, &original, r](const Eigen::MatrixX3d& V) {
        return add(V, &original.center_motion, r);
      };
    };
    const double rms = fingerprint_rms(original.counted);
    use_rms(rms);
    if (rms > plain_rms)
      plain_fingerprint = [add, plain_rms](const Eigen::MatrixX3d& V) {
        return add(V, nullptr, plain_rms);
      };
  }
  const EmbedOptions searched = o;  // what a search starts from
  // The strength search within the limits, with `finish` added to every embedding tried.
  const auto search = [&](const Field& finish) {
    CalibrateOptions co = *settings.limits;
    co.strengths = [&](double alpha) {
      return mark_strengths(settings.key, nb, coded, alpha, settings.strength_spread);
    };
    co.finish = finish;
    co.msdm_reference = original.msdm;
    return calibrate_strength(original.embedder, out.bins, searched, co);
  };
  if (settings.limits) {
    CalibrateOptions co = *settings.limits;
    out.calibration = search(fingerprint);
    const CalibrateCause cause = out.calibration->cause;
    if (out.calibration->status == CalibrateStatus::BelowMinimum && plain_fingerprint &&
        (cause == CalibrateCause::RmsLimit || cause == CalibrateCause::MsdmLimit)) {
      // A small original's raised field may leave no room for a histogram mark where the plain
      // one does: both marks, with the plain field, before the fingerprint alone.
      CalibrateResult again = search(plain_fingerprint);
      if (again.status != CalibrateStatus::BelowMinimum) {
        out.calibration = std::move(again);
        use_rms(plain_rms);
      }
    }
    const CalibrateResult& c = *out.calibration;
    o.strength = c.strength > 0 ? c.strength : co.min_strength;
    o.bin_offset = c.bin_offset, o.strengths = c.strengths;
    out.result = c.embedding;
    out.calibration->embedding.V.resize(0, 3);
    if (c.status == CalibrateStatus::BelowMinimum) {
      if (fingerprint)
        issue_fingerprint_alone(request, original, settings,
                                plain_fingerprint
                                    ? std::vector<Field>{fingerprint, plain_fingerprint}
                                    : std::vector<Field>{fingerprint},
                                co, c.message, out);
      else
        out.status = CopyStatus::NotWithinFidelity, out.message = c.message;
      return;
    }
  } else {
    out.result = original.embedder.embed(out.bins, o);
    if (out.result.status == EmbedStatus::Infeasible && fingerprint &&
        !settings.registry.empty()) {  // unregistered, it would carry no mark anyone reads
      issue_fingerprint_alone(request, original, settings, {fingerprint}, std::nullopt,
                              out.result.message, out);
      return;
    }
  }
  out.record.strength = o.strength, out.record.bin_offset = o.bin_offset;
  if (out.result.check.status == CarrierHealth::Weak)
    for (const std::string& d : out.result.check.diagnostics)
      out.warnings.push_back(fmt::format("{}: {}", request.input, d));
  if (out.result.status != EmbedStatus::Embedded) {
    out.status = CopyStatus::NotEmbedded, out.message = out.result.message;
    return;
  }
  std::error_code ec;
  if (!request.mesh && fs::equivalent(request.output, request.input, ec)) {
    refuse(out, fmt::format("{}: refusing to overwrite the input file", request.output));
    return;
  }
  Mesh copy = original.mesh;
  copy.V = std::move(out.result.V);
  out.result.V.resize(0, 3);
  // The RMS of a field alone, as a fraction of the diagonal: it moves each vertex by its own
  // amount along the original's ray, whatever the positions it is added to, so it is measured
  // on the original's.
  const auto field_rms = [&original](const Field& field) {
    const Eigen::MatrixX3d& VO = original.mesh.V;
    return std::sqrt((field(VO) - VO).rowwise().squaredNorm().mean()) /
           original.fingerprint->diagonal;
  };
  double field_alone = 0;  // the fingerprint's RMS, as a fraction of the diagonal
  // The copy with the histogram mark alone (at a fixed strength; found again for a calibrated
  // one when needed), for the second chances below.
  std::optional<Eigen::MatrixX3d> unmarked;
  if (fingerprint) {
    field_alone = field_rms(fingerprint);  // a calibrated embedding already carries it
    if (!out.calibration) {
      unmarked = copy.V;
      copy.V = fingerprint(copy.V);
    }
  }
  ExtractOptions eo;
  eo.center = o.variant.center;
  eo.method = o.method;
  // Positions written instead of copy.V's when they carry the mark and, with limits, fit them
  // (measured again: they differ from what the search measured).
  const auto try_instead = [&](Eigen::MatrixX3d V) {
    std::optional<Distortion> d;
    if (out.calibration) {
      d = distortion(original, V, *settings.limits);
      if (!d->within(*settings.limits)) return std::optional<WrittenCheck>();
    }
    Mesh other = original.mesh;
    other.V = std::move(V);
    WrittenCheck w = write_marked_mesh(request.output, other, settings.write, settings.read,
                                       out.bins, eo, 0.5 * o.strength);
    if (w.carried) {
      copy.V = std::move(other.V);
      if (d) {
        out.result.rms_percent = out.calibration->rms_percent = d->rms_percent;
        out.calibration->msdm = d->msdm;
      }
    }
    return std::optional<WrittenCheck>(std::move(w));
  };
  try {
    WrittenCheck written = write_marked_mesh(request.output, copy, settings.write, settings.read,
                                             out.bins, eo, 0.5 * o.strength);
    if (!written.carried && fingerprint) {
      // First the field kept from moving the center, then (at a fixed strength, on a small
      // original) the plain field, then (unless asked for) none.
      if (out.calibration) {
        // Searched again with it: the field changes what the copy costs, near a limit.
        CalibrateResult again = search(centered);
        if (again.status != CalibrateStatus::BelowMinimum) {
          const EmbedOptions first = o;  // the file is checked at the new strength
          o.strength = again.strength, o.bin_offset = again.bin_offset;
          o.strengths = again.strengths;
          std::optional<WrittenCheck> w = try_instead(again.embedding.V);
          if (w && w->carried) {
            written = std::move(*w);
            out.record.strength = o.strength, out.record.bin_offset = o.bin_offset;
            again.embedding.V.resize(0, 3);
            out.result = again.embedding;
            out.calibration = std::move(again);
            field_alone = field_rms(centered);
            out.kept_center = true;
          } else {
            o = first;
          }
        }
        if (!written.carried) {  // the mark at the strength first found, for the last chance
          EmbedResult alone = original.embedder.embed(out.bins, o);
          if (alone.status == EmbedStatus::Embedded) unmarked = std::move(alone.V);
        }
      } else if (std::optional<WrittenCheck> w = try_instead(centered(*unmarked));
                 w && w->carried) {
        written = std::move(*w);
        field_alone = field_rms(centered);
        out.kept_center = true;
      } else if (plain_fingerprint) {  // a small original's raised field: the plain one next
        if (std::optional<WrittenCheck> p = try_instead(plain_fingerprint(*unmarked));
            p && p->carried) {
          written = std::move(*p);
          field_alone = field_rms(plain_fingerprint);
        }
      }
      if (!written.carried && unmarked && !required)
        if (std::optional<WrittenCheck> w = try_instead(*unmarked); w && w->carried) {
          out.warnings.push_back(fmt::format(
              "{}: with the fingerprint, {}: issued without the fingerprint (trace then reads "
              "the histogram mark alone)",
              request.input, written.message));
          written = std::move(*w);
          field_alone = 0;
          out.record.mark_format = kMarkFormatVersion;
        }
    }
    if (!written.carried) {
      out.status = CopyStatus::NotCarried, out.message = written.message;
      return;
    }
  } catch (const IOError& e) {
    out.status = CopyStatus::WriteFailed, out.message = e.what();
    return;
  }
  out.message = fmt::format(
      "{} rounds, RMS {:.5f} %{}{}, {:.1f} ms", out.result.rounds, out.result.rms_percent,
      field_alone <= 0 ? ""
      : out.calibration
          ? fmt::format(" for both marks (the fingerprint's alone {:.5f} %)", 100 * field_alone)
          : fmt::format(" and fingerprint RMS {:.5f} %", 100 * field_alone),
      out.calibration ? fmt::format(", strength {:.5f}, MSDM {:.4f}", out.calibration->strength,
                                    out.calibration->msdm)
                      : "",
      1e3 * out.result.seconds);
  if (out.kept_center) out.message += " (the fingerprint kept from moving the center)";
  if (request.auto_id) out.message = fmt::format("ID {}, {}", *request.id, out.message);
  if (out.result.check.status == CarrierHealth::Weak)
    out.message += fmt::format(" (warning: {})", out.result.check.summary());
}

}  // namespace

const char* copy_status_name(CopyStatus status) {
  return enum_name(status);
}

std::size_t IssueResult::count(CopyStatus status) const {
  std::size_t n = 0;
  for (const CopyOutcome& c : copies) n += c.status == status;
  return n;
}

IssuedCopy issued_copy(const std::string& input, const std::string& buyer, std::uint64_t id,
                       const IssueSettings& settings) {
  const std::string file_hash = content_hash(read_file(input));
  IssuedCopy c = issued_copy(read_mesh(input, settings.read), input, buyer, id, settings);
  c.original_hash = file_hash;
  c.original_path = normalized_path(input);
  return c;
}

IssuedCopy issued_copy(const Mesh& original, const std::string& name, const std::string& buyer,
                       std::uint64_t id, const IssueSettings& settings) {
  IssuedCopy c;
  c.original_geometry = geometry_hash(original.V, original.F);
  c.original_hash = c.original_geometry;
  c.original_path = name;
  c.buyer = buyer;
  c.id = id;
  c.id_bits = settings.id_bits;
  c.bits = settings.bits;
  c.variant = settings.embedding.variant.name();
  c.strength = settings.embedding.strength;
  c.strength_spread = settings.strength_spread;
  c.bin_offset = settings.embedding.bin_offset;
  c.key_fingerprint = key_fingerprint(id_key(settings.key));
  c.key_derivation = id_key(settings.key).derivation;
  c.method = method_name(settings.embedding.method);
  if (wants_fingerprint(settings)) {
    const std::vector<std::uint8_t> carrier = carrier_vertices(original.V, original.F);
    if (fingerprint_functions(
            static_cast<std::size_t>(std::count(carrier.begin(), carrier.end(), kCounted))) > 0)
      c.mark_format = kFingerprintMarkFormat;
  }
  return c;
}

namespace {

// Reserves the rows of the copies about to be made (those without one: an interrupted
// issue's rows are finished as they are), in one transaction; when that fails (another issue
// took an ID meanwhile, the database failed), none of these copies is made.
void reserve_rows(Registry& registry, const std::vector<CopyRequest>& requests,
                  std::vector<std::size_t>& jobs, const IssueSettings& settings,
                  std::vector<CopyOutcome>& out) {
  std::vector<IssuedCopy> fresh;
  std::vector<std::size_t> index;
  for (const std::size_t k : jobs)
    if (out[k].record.row == 0) {
      out[k].record.output_path = normalized_path(requests[k].output);
      fresh.push_back(out[k].record), index.push_back(k);
    }
  if (fresh.empty()) return;
  try {
    fresh = registry.reserve(std::move(fresh), id_key(settings.key));
    for (std::size_t j = 0; j < index.size(); ++j) out[index[j]].record = fresh[j];
  } catch (const std::exception& e) {
    for (const std::size_t k : index) refuse(out[k], kNotReserved + std::string(e.what()));
    std::erase_if(jobs, [&](std::size_t k) { return !pending(out[k]); });
  }
}

// Completes the rows of the copies written, in one transaction (all, or none and their files
// removed), and releases the rows of the copies that were not.
void complete_rows(Registry& registry, const std::vector<CopyRequest>& requests,
                   const IssueSettings& settings, std::vector<CopyOutcome>& out) {
  std::vector<IssuedCopy> done, dropped;
  for (std::size_t k = 0; k < requests.size(); ++k)
    if (out[k].record.row != 0 && out[k].status != CopyStatus::Written)
      dropped.push_back(out[k].record);
  try {
    for (std::size_t k = 0; k < requests.size(); ++k) {
      if (out[k].record.row == 0 || out[k].status != CopyStatus::Written) continue;
      IssuedCopy c = out[k].record;
      c.output_path = normalized_path(requests[k].output);
      c.output_hash = content_hash(read_file(requests[k].output));
      done.push_back(c);
    }
    if (!done.empty()) registry.complete(std::move(done), id_key(settings.key));
  } catch (const std::exception& e) {
    // A copy that another run of the same request completed meanwhile, its file as recorded,
    // is kept; every other copy written is removed and its row given back.
    std::map<std::string, std::string> completed;
    try {
      for (const IssuedCopy& c : registry.list())
        if (c.state == "issued") completed[c.output_path] = c.output_hash;
    } catch (const std::exception&) {
      completed.clear();
    }
    for (std::size_t k = 0; k < requests.size(); ++k) {
      CopyOutcome& c = out[k];
      if (c.status != CopyStatus::Written || c.record.row == 0) continue;
      const auto other = completed.find(normalized_path(requests[k].output));
      std::string hash;
      try {
        hash = content_hash(read_file(requests[k].output));
      } catch (const std::exception&) {
        hash.clear();
      }
      if (other != completed.end() && !hash.empty() && other->second == hash) {
        c.status = CopyStatus::Skipped;
        c.message = "issued and recorded by another run of the same request: its file is intact";
        continue;
      }
      std::remove(requests[k].output.c_str());
      c.status = CopyStatus::NotRecorded;
      c.message = fmt::format("not recorded, removed: {}", e.what());
      dropped.push_back(c.record);
    }
  }
  try {
    registry.release(dropped);
  } catch (const std::exception& e) {
    for (CopyOutcome& c : out)
      if (c.status != CopyStatus::Written && c.record.row != 0)
        c.warnings.push_back(fmt::format("row {} stays reserved: {}", c.record.row, e.what()));
  }
}

}  // namespace

namespace {

// The settings no copy can be issued with, refused before any ID is reserved (a strength that is
// not a number would reach the registry's NOT NULL columns).
void check_settings(const IssueSettings& s) {
  if (s.bits < 1) throw InvalidArgumentError(fmt::format("{} payload bits: at least 1", s.bits));
  const EmbedOptions& o = s.embedding;
  if (!(o.strength > 0 && o.strength < 0.5))
    throw InvalidArgumentError(fmt::format("strength {} is outside (0, 1/2)", o.strength));
  if (!(o.bin_offset >= 0 && o.bin_offset < 0.5))
    throw InvalidArgumentError(fmt::format("bin offset {} is outside [0, 1/2)", o.bin_offset));
  if (!(std::isfinite(s.strength_spread) && s.strength_spread >= 0))
    throw InvalidArgumentError(
        fmt::format("strength spread {} is not a finite number >= 0", s.strength_spread));
  if (s.limits && !(s.limits->max_rms_percent > 0 && std::isfinite(s.limits->max_rms_percent) &&
                    s.limits->max_msdm > 0 && std::isfinite(s.limits->max_msdm)))
    throw InvalidArgumentError(
        fmt::format("fidelity limits RMS {} % and MSDM {} are not finite positive numbers",
                    s.limits->max_rms_percent, s.limits->max_msdm));
}

// issue_copies, with the originals of cache prepared before and the registry open (when given).
// lock (when given, held on entry): what guards the cache and the registry; it is released
// while the copies are embedded and written, so that several issues embed side by side, and
// held again on return.
IssueResult issue_with(std::vector<CopyRequest> requests, const IssueSettings& settings,
                       OriginalCache& cache, Registry* open_registry,
                       std::unique_lock<std::mutex>* lock = nullptr) {
  const auto start = std::chrono::steady_clock::now();
  check_settings(settings);
  IssueResult result;
  std::vector<CopyOutcome>& out = result.copies;
  out.resize(requests.size());
  bool any_coded = false;
  for (std::size_t k = 0; k < requests.size(); ++k) {
    out[k].status = CopyStatus::Written;  // pending: Written with no message yet
    out[k].embedding = settings.embedding;
    const CopyRequest& r = requests[k];
    if (!r.refusal.empty()) {
      refuse(out[k], r.refusal);
      continue;
    }
    if (r.auto_id && settings.registry.empty()) {
      refuse(out[k], "id:auto needs a registry (--registry): it picks an ID no copy has yet");
      continue;
    }
    if ((r.id || r.auto_id) && !settings.key && !settings.allow_public_key) {
      refuse(out[k],
             "a coded ID without a secret key is coded under the public key: anyone could read "
             "it, remove it or write another buyer's ID; give a key (--key-file), or say "
             "--public-key to issue it anyway");
      continue;
    }
    if (r.id && settings.id_bits >= 1 && settings.id_bits < 64 && *r.id >> settings.id_bits != 0) {
      refuse(out[k], fmt::format("ID {} does not fit in {} bits (the IDs' length)", *r.id,
                                 settings.id_bits));
      continue;
    }
    any_coded = any_coded || r.id || r.auto_id;
    if (!r.id && !r.auto_id) {
      try {
        payload_from_hex(r.payload_hex, settings.bits);
      } catch (const Error& e) {
        refuse(out[k], e.what());
      }
    }
  }
  // The ID code (its options checked once, for every coded copy).
  std::optional<IdCode> code;
  if (any_coded) {
    IdCodeOptions co;
    co.bits = settings.bits;
    co.id_bits = settings.id_bits;
    code.emplace(co);
  }
  refuse_clashes(requests, settings, out);
  std::optional<Registry> own_registry;
  Registry* registry = open_registry;
  if (!settings.registry.empty() && !registry) registry = &own_registry.emplace(settings.registry);
  if (registry) check_registry(*registry, requests, settings, cache.records, out);
  // Each distinct original read and prepared once, before the work is shared out.
  // An original that cannot be read is Unreadable; options its preparation refuses make every
  // copy of it Refused.
  std::map<std::string, std::shared_ptr<const Original>>& originals = cache.prepared;
  std::map<std::string, std::pair<CopyStatus, std::string>> failed;
  std::set<std::string> inputs, to_prepare;
  std::map<std::string, std::size_t> copies_of;  // pending copies per original to prepare
  for (std::size_t k = 0; k < requests.size(); ++k)
    if (pending(out[k]) && !originals.count(original_key(requests[k]))) {
      to_prepare.insert(original_key(requests[k]));
      ++copies_of[original_key(requests[k])];
    }
  // Progress: each original read and prepared (on a million vertices, a few seconds each),
  // then each copy made.
  detail::ProgressCounter preparing(settings.progress, "preparing",
                                    static_cast<long>(to_prepare.size()));
  for (std::size_t k = 0; k < requests.size(); ++k) {
    const std::string input = original_key(requests[k]);
    if (!pending(out[k])) continue;
    inputs.insert(input);
    if (originals.count(input) || failed.count(input)) continue;
    try {
      originals[input] =
          prepare_original(requests[k], settings, cache.kept || copies_of[input] > 1);
    } catch (const IOError& e) {
      failed[input] = {CopyStatus::Unreadable, e.what()};
    } catch (const InvalidInputError& e) {
      failed[input] = {CopyStatus::Unreadable, e.what()};
    } catch (const InvalidArgumentError& e) {
      failed[input] = {CopyStatus::Refused, e.what()};
    } catch (const std::exception& e) {
      failed[input] = {CopyStatus::NotEmbedded, e.what()};
    }
    preparing.step(1, requests[k].input);  // counted as prepared however its preparation ended
  }
  result.inputs = inputs.size();
  std::vector<std::size_t> jobs;
  for (std::size_t k = 0; k < requests.size(); ++k) {
    if (!pending(out[k])) continue;
    const auto bad = failed.find(original_key(requests[k]));
    if (bad != failed.end())
      out[k].status = bad->second.first, out[k].message = bad->second.second;
    else
      jobs.push_back(k);
  }
  // The registry reserves every ID before its copy is written: an issue killed while writing
  // leaves reserved rows (which a rerun completes), never a copy that no row names.
  if (registry) reserve_rows(*registry, requests, jobs, settings, out);
  // One copy within fidelity limits: its strength search reports each MSDM it measures (minutes
  // on a few 100k vertices) in place of the one "issuing" step.
  std::optional<IssueSettings> searched_alone;
  if (jobs.size() == 1 && settings.limits && settings.progress && !settings.limits->progress) {
    searched_alone = settings;
    searched_alone->limits->progress = settings.progress;
  }
  const ProgressCallback none;
  detail::ProgressCounter progress(searched_alone ? none : settings.progress, "issuing",
                                   static_cast<long>(jobs.size()));
  std::vector<std::shared_ptr<const Original>> job_originals;  // held while unlocked
  job_originals.reserve(jobs.size());
  for (const std::size_t k : jobs) job_originals.push_back(originals.at(original_key(requests[k])));
  if (lock) lock->unlock();
  result.threads = detail::parallel_for(jobs.size(), settings.threads, [&](std::size_t j) {
    const std::size_t k = jobs[j];

    try {
      make_copy(requests[k], *job_originals[j], searched_alone ? *searched_alone : settings,
                code ? &*code : nullptr, out[k]);
    } catch (const InvalidArgumentError& e) {  // options this copy's embedding refuses
      refuse(out[k], e.what());
    } catch (const std::exception& e) {
      out[k].status = CopyStatus::NotEmbedded, out[k].message = e.what();
    }
    progress.step(1, requests[k].output);
  });
  if (lock) lock->lock();
  if (registry) complete_rows(*registry, requests, settings, out);
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace

IssueResult issue_copies(std::vector<CopyRequest> requests, const IssueSettings& settings) {
  OriginalCache cache;
  return issue_with(std::move(requests), settings, cache, nullptr);
}

struct Issuer::Impl {
  IssueSettings settings;
  std::size_t max_originals = 0;
  std::optional<Registry> registry;
  OriginalCache cache;
  // The prepared originals by geometry hash, the most recently used last.
  std::vector<PreparedOriginal> order;
  std::mutex mutex;

  // Moves the original to the most recently used place; drops the least recently used beyond
  // the bound, with what the cache holds of it.
  void touch(const std::string& geometry) {
    auto it = std::find_if(order.begin(), order.end(),
                           [&](const PreparedOriginal& p) { return p.geometry == geometry; });
    if (it != order.end()) std::rotate(it, it + 1, order.end());
    while (order.size() > max_originals) {
      CopyRequest r;
      r.mesh = order.front().mesh;
      cache.prepared.erase(original_key(r));
      cache.records.erase(original_key(r));
      order.erase(order.begin());
    }
  }
};

Issuer::Issuer(IssueSettings settings, std::size_t max_originals)
    : impl_(std::make_unique<Impl>()) {
  if (max_originals == 0) throw InvalidArgumentError("an issuer holds at least one original");
  check_settings(settings);
  impl_->settings = std::move(settings);
  impl_->max_originals = max_originals;
  impl_->cache.kept = true;
  if (!impl_->settings.registry.empty()) impl_->registry.emplace(impl_->settings.registry);
}

Issuer::~Issuer() = default;

PreparedOriginal Issuer::prepare(Mesh mesh, const std::string& name) {
  validate_mesh(mesh.V, mesh.F, name);
  const std::string geometry = geometry_hash(mesh.V, mesh.F);
  const std::lock_guard<std::mutex> lock(impl_->mutex);
  if (const std::optional<PreparedOriginal> known = find_locked(geometry)) {
    PreparedOriginal again = *known;
    again.prepared_before = true;
    impl_->touch(geometry);
    return again;
  }
  PreparedOriginal p;
  p.geometry = geometry;
  p.name = name;
  p.vertices = mesh.V.rows();
  p.faces = mesh.F.rows();
  p.mesh = std::make_shared<const Mesh>(std::move(mesh));
  CopyRequest r;
  r.input = name;
  r.mesh = p.mesh;
  impl_->cache.prepared[original_key(r)] = prepare_original(r, impl_->settings, true);
  impl_->cache.records[original_key(r)] = issued_copy(*p.mesh, name, "", 0, impl_->settings);
  impl_->order.push_back(p);
  impl_->touch(geometry);
  return p;
}

std::optional<PreparedOriginal> Issuer::find(const std::string& geometry) {
  const std::lock_guard<std::mutex> lock(impl_->mutex);
  return find_locked(geometry);
}

std::optional<PreparedOriginal> Issuer::find_locked(const std::string& geometry) const {
  for (const PreparedOriginal& p : impl_->order)
    if (p.geometry == geometry) return p;
  return std::nullopt;
}

IssueResult Issuer::issue(std::vector<CopyRequest> requests) {
  std::unique_lock<std::mutex> lock(impl_->mutex);
  std::vector<std::string> used;
  for (const CopyRequest& r : requests)
    for (const PreparedOriginal& p : impl_->order)
      if (r.mesh && r.mesh == p.mesh) used.push_back(p.geometry);
  // A copy whose ID the registry chose, refused because another issuer (another server on the
  // same PostgreSQL registry) reserved that ID first, is issued again with the next one.
  constexpr int kAttempts = 8;
  const std::vector<CopyRequest> asked = requests;
  IssueResult result = issue_with(std::move(requests), impl_->settings, impl_->cache,
                                  impl_->registry ? &*impl_->registry : nullptr, &lock);
  for (int attempt = 1; attempt < kAttempts; ++attempt) {
    std::vector<std::size_t> again;
    for (std::size_t k = 0; k < asked.size(); ++k)
      if (asked[k].auto_id && result.copies[k].status == CopyStatus::Refused &&
          (result.copies[k].message.rfind(kNotReserved, 0) == 0 ||
           result.copies[k].message.rfind(kChosenMeanwhile, 0) == 0))
        again.push_back(k);
    if (again.empty()) break;
    std::vector<CopyRequest> retry;
    retry.reserve(again.size());
    for (const std::size_t k : again) retry.push_back(asked[k]);
    IssueResult second = issue_with(std::move(retry), impl_->settings, impl_->cache,
                                    impl_->registry ? &*impl_->registry : nullptr, &lock);
    for (std::size_t j = 0; j < again.size(); ++j)
      result.copies[again[j]] = std::move(second.copies[j]);
  }
  for (const std::string& g : used) impl_->touch(g);
  // Originals given in memory but not prepared are not kept.
  std::map<std::string, std::shared_ptr<const Original>> kept;
  std::map<std::string, IssuedCopy> records;
  for (const PreparedOriginal& p : impl_->order) {
    CopyRequest r;
    r.mesh = p.mesh;
    const std::string k = original_key(r);
    if (impl_->cache.prepared.count(k)) kept[k] = impl_->cache.prepared[k];
    if (impl_->cache.records.count(k)) records[k] = impl_->cache.records[k];
  }
  impl_->cache.prepared = std::move(kept);
  impl_->cache.records = std::move(records);
  return result;
}

const IssueSettings& Issuer::settings() const {
  return impl_->settings;
}

Registry* Issuer::registry() {
  return impl_->registry ? &*impl_->registry : nullptr;
}

SelfReading fingerprint_alone_reading(const Mesh& copy, const Mesh& original,
                                      const IssuedCopy& record, const Key& key) {
  IssuedCopy row = record;
  row.strength = 0, row.bin_offset = 0, row.mark_format = kFingerprintMarkFormat;
  row.key_fingerprint = key_fingerprint(key);
  TraceOptions o;
  o.register_leak = false, o.ranking = 1;
  const TraceResult t = trace(copy, original, {row}, key, o);
  SelfReading out;
  if (!t.ranking.empty())
    out.p = t.ranking.front().p_value, out.z = t.ranking.front().fingerprint_z;
  out.nameable = out.p * kFingerprintAloneCandidates < o.threshold;
  out.message = fmt::format(
      "the fingerprint alone would {}name its buyer among {} candidates in the copy as issued "
      "(its own p = {:.3g}, fingerprint z = {:.2f})",
      out.nameable ? "" : "not ", kFingerprintAloneCandidates, out.p, out.z);
  return out;
}

}  // namespace meshmark
