#pragma once
/// \file trace.h
/// Informed tracing of a leak: with the original mesh and the copies issued from it (registry.h),
/// which buyers' marks are present in the leaked mesh?
///
/// Steps: the leak is registered onto the original (registration.h) and measured at every
/// original vertex (the closest point of the registered leak's surface; vertices with no
/// surface within `erase_distance` are erased: cropped away or in holes). The histogram is the
/// original's (its carrier, center, range and bins: the embedding kept them), so resampling,
/// cropping and decimation do not desynchronize it. Each bin's mean position is compared with
/// the original's: a mark moves it from the original's mean m0 to 1/2 +- alpha_j, and attacks
/// attenuate that shift by a common factor gamma (smoothing shrinks it), which is fitted; each
/// bit is the hypothesis nearer to what was measured. Three readings are made: every bit, and
/// the bits outside a middle band of two widths (bits whose shift lies near the middle between
/// the hypotheses are erased: attacks leave the weakest bits there, and an average of two
/// copies leaves there every bit on which the two differ). gamma is fitted on the bits outside
/// the widest band. These readings do not depend on any candidate. Each candidate copy's
/// codeword is then compared with each, and its p-value is the smallest exact probability
/// (detect.h, CodewordNull) that an innocent codeword matches as well, times the number of
/// readings, then times the number of candidates (Bonferroni). Buyers below the threshold are
/// named; two or more are reported together (collusion: both colluders of an average of two
/// copies match every bit outside the band).

#include <limits>
#include <string>
#include <vector>

#include "meshmark/core/enum_names.h"
#include "meshmark/core/mesh.h"
#include "meshmark/core/progress.h"
#include "meshmark/forensics/registration.h"
#include "meshmark/forensics/registry.h"
#include "meshmark/mark/decode.h"
#include "meshmark/protocol/key.h"

namespace meshmark {

/// The leak measured at the original's carrier vertices: for each, the point of the leak's
/// surface on the ray from center through the vertex (where the plane of the nearest leaked
/// triangle crosses that ray), or the nearest point itself where the ray runs along that plane.
/// An unattacked copy of a radially marked mesh gives back its own vertices.
struct Resampled {
  Eigen::MatrixX3d point;              ///< #VO x 3 (rows of unmeasured vertices: the original's)
  std::vector<std::uint8_t> measured;  ///< 1 where a surface lies within erase_distance
  double fraction = 0;                 ///< measured share of the carrier
  bool vertexwise = false;  ///< true: point[i] is the leak's vertex i (same faces), not a ray hit
};

/// Resamples the leak (VL, FL, already in the original's frame) at the carrier vertices of
/// (VO, FO); erase_distance in model units. A leak with the original's faces (noise,
/// quantization, smoothing, a similarity) is measured vertex for vertex.
Resampled resample_at_original(const Eigen::MatrixX3d& VL, const Eigen::MatrixX3i& FL,
                               const Eigen::MatrixX3d& VO, const Eigen::MatrixX3i& FO,
                               const Eigen::Vector3d& center, double erase_distance);

/// The version of trace's reading of a fingerprint, which a trace campaign's directory records
/// beside the mark format (mark_format.txt) so that rows read otherwise are not resumed beside
/// new ones: 1, the whole surface and its regions; 2, also against a smoothed leak's vertices
/// before the smoothing (TraceOptions::fingerprint_unsmoothing, 2026-12-07); 3, a leak with the
/// original's faces read vertex to vertex, and registered against the original smoothed
/// (2026-12-07, later); 4, each radial class also fitted on (n . u)^2, what a re-mark along the
/// normals moves (read_fingerprint_at's obliquity, 2026-12-07, session 52).
inline constexpr int kFingerprintReading = 4;

/// Options of trace.
struct TraceOptions {
  double threshold = 1e-6;        ///< family-wise false-alarm probability for naming a buyer
  double erase_distance = 0.005;  ///< no surface within this fraction of the diagonal: erased
  bool register_leak = true;      ///< false: the leak is already in the original's frame
  RegistrationOptions registration;
  /// The ridge of the fingerprint's reading (read_fingerprint), relative to the mean diagonal
  /// of the normal equations: 0 reads an unprocessed copy at its full strength (z about
  /// sqrt(K)) and loses a resampled one; 1 trades a third of the former for most of the latter
  /// (docs/forensics.md, "Reading the fingerprint").
  double fingerprint_ridge = 1.0;
  /// Besides the whole surface, the fingerprint is read over the regions of each of these
  /// partitions (fingerprint_regions: 2, 3 and 4 regions by default, 9 regional readings per
  /// reading of the whole), each count at most once: a splice of copies keeps each colluder's
  /// field whole over its part of the surface, where a reading of the whole dilutes it. Empty:
  /// the whole alone (docs/forensics.md, "Reading by regions": measured on splices cut the way
  /// these regions are, around far-apart points; other cuts are not measured).
  std::vector<int> fingerprint_regions = {2, 3, 4};
  /// The share of the false-alarm budget the regional readings get, in (0, 1): a candidate's
  /// fingerprint p is the smaller of its best whole score's p times the whole readings over
  /// 1 - share and its best regional score's p times the regional readings over share
  /// (fingerprint_p_value, a weighted Bonferroni). With one reading of the whole and 9 regions,
  /// 0.2 costs an average of copies, which the whole reads best, a factor 1.25 and a splice a
  /// factor 45 (2.5 and 90 with two readings of the whole: a processed original).
  double fingerprint_region_share = 0.2;
  /// When the leak seems smoothed (its residuals fit a smoothing), the fingerprint is also read
  /// against where its vertices were before that smoothing: points on the reference surface
  /// that Laplacian smoothing on the leak's own faces carries onto the leak's vertices (found by
  /// a projected fixed point, docs/forensics.md, "Smoothing after resampling"). A resampled
  /// then smoothed leak's vertices have slid along the surface; read against the surface
  /// where each ray crosses it, the slide reads as noise several times the fingerprint. Each
  /// such reading is one more reading of the whole (the Bonferroni factor grows with them).
  bool fingerprint_unsmoothing = true;
  /// The most crossed leak vertices that reading is made for: it costs about 10 µs a vertex on
  /// 2 cores (0.5 s for 49,000), so a leak of millions of vertices is read without it, and
  /// TraceResult::fingerprint_processing says so (0: never, as fingerprint_unsmoothing false).
  std::size_t fingerprint_unsmoothing_limit = 1000000;
  /// How many of the best candidates TraceResult::ranking keeps (0: every one); it always
  /// keeps every candidate below the threshold and the copy whose output_hash is
  /// leaked_hash. Only the kept rows' authentication codes are checked (name_buyers).
  std::size_t ranking = 1000;
  /// The content hash of the leaked file's bytes (content_hash, registry.h) when known, so
  /// that compare_with_issued_files finds the copy recorded with it in the ranking; "" when
  /// not known.
  std::string leaked_hash;
  /// Called as the trace goes (progress.h): phase "tracing", the registration and then each
  /// group of candidates read alike.
  ProgressCallback progress;
};

/// One candidate's evidence.
struct CandidateScore {
  IssuedCopy copy;         ///< the issued copy
  int matches = 0;         ///< bits read equal to its codeword's (best reading)
  int compared = 0;        ///< bits compared (not erased) in that reading
  double p_value = 1;      ///< this candidate alone: the smallest exact p over the readings
                           ///< times their number; for a copy with a fingerprint (mark formats
                           ///< 3 and 4), twice the smaller of that and fingerprint_p
  double corrected_p = 1;  ///< min(1, p_value x candidates)
  /// The fingerprint's best score over the readings (fingerprint.h: each reading's about
  /// standard normal for an innocent; this is the largest of them) and its p-value
  /// (fingerprint_p_value over the readings of the whole and by region,
  /// TraceOptions::fingerprint_region_share), for a copy issued with one; NaN and 1 otherwise.
  double fingerprint_z = std::numeric_limits<double>::quiet_NaN();
  double fingerprint_p = 1;
  /// The row's authentication code under the trace's key (check_row): an Edited row is
  /// scored and counted but never named.
  RowAuth auth = RowAuth::Unauthenticated;
};

/// What trace concluded.
enum class TraceStatus {
  Named,               ///< at least one buyer passes the threshold
  NoBuyer,             ///< none does
  RegistrationFailed,  ///< the leak could not be brought onto the original
  NoCandidates,        ///< no copy of this original under this key in the list
};

/// The names of TraceStatus's values (trace_status_name).
template <>
struct EnumTable<TraceStatus> {
  static constexpr const char* what = "trace status";
  static constexpr NamedValue<TraceStatus> values[] = {
      {TraceStatus::Named, "named"},
      {TraceStatus::NoBuyer, "no-buyer"},
      {TraceStatus::RegistrationFailed, "registration-failed"},
      {TraceStatus::NoCandidates, "no-candidates"}};
};

/// "named", "no-buyer", "registration-failed", "no-candidates".
const char* trace_status_name(TraceStatus status);

/// The soft evidence of one payload bit (first group of candidates), in bin units: what the
/// bin's mean moved by from the reference, and what a 0 or a 1 would have moved it by after
/// the fitted attenuation.
struct BitEvidence {
  double shift = 0;             ///< measured shift of the bin's mean (bin widths)
  double if_one = 0;            ///< expected shift for a 1 (bin widths, attenuated)
  double if_zero = 0;           ///< expected shift for a 0 (bin widths, attenuated)
  int vertices = 0;             ///< measured vertices in the bin (0: the bit is erased)
  std::uint8_t bit = kErasure;  ///< the hypothesis nearer to the shift, or kErasure
};

/// Where trace spent its time (seconds, wall clock).
struct TraceTimings {
  double registry = 0;      ///< reading the candidates of a registry (trace_issued)
  double registration = 0;  ///< register_similarity
  double reference = 0;     ///< the search for the smoothing the leak resembles
  double resampling = 0;    ///< the leak measured at the original's vertices (every group)
  double scoring = 0;       ///< readings, null distributions and candidates' p-values
};

/// What trace found.
struct TraceResult {
  TraceStatus status = TraceStatus::NoBuyer;
  std::size_t candidates = 0;       ///< copies issued under this key (scored or not)
  RegistrationResult registration;  ///< leak -> original
  double measured_fraction = 0;     ///< original carrier vertices measured (not erased)
  double attenuation = 0;           ///< fitted gamma of the first group of candidates
  std::string processing;           ///< the smoothing the leak was read against, or "none"
  /// What the fingerprint's reading took out of the leak's residuals as smoothing (the first
  /// group with fingerprinted copies), "none", or empty when no fingerprint was read.
  std::string fingerprint_processing;
  std::vector<BitEvidence> bits;      ///< per payload bit, first group of candidates
  std::vector<CandidateScore> named;  ///< candidates below the threshold, best first
  /// The best candidates, best first (ties in the candidates' order): TraceOptions::ranking
  /// of them, every one below the threshold, and the copy of TraceOptions::leaked_hash.
  std::vector<CandidateScore> ranking;
  /// -log10 of every candidate's corrected p-value (floored at 1e-300), in no set order: the
  /// whole registry's evidence for plots, when the ranking keeps fewer.
  std::vector<float> log_scores;
  std::string message;  ///< one line for a person
  /// What weakens or qualifies the verdict, one sentence each: candidate rows whose MAC fails
  /// (never named) or that carry none, a leak whose bytes are another row's file.
  std::vector<std::string> warnings;
  /// The row whose recorded output_hash the leak's bytes equal (compare_with_issued_files),
  /// 0 when none does or it was not checked.
  std::int64_t identical_row = 0;
  TraceTimings seconds;  ///< where the time went
};

/// Traces leaked against the copies issued from original under key (candidates: every copy
/// whose key fingerprint is key's; others are ignored). Candidates may differ in variant,
/// bits, ID length, strength and spread: each group is read with its own settings. The list
/// is the caller's: a row whose MAC fails is never named, one without a MAC is named with a
/// warning (trace_issued, which reads a registry, never names one).
/// \throw InvalidArgumentError when a mesh has no usable triangle.
TraceResult trace(const Mesh& leaked, const Mesh& original,
                  const std::vector<IssuedCopy>& candidates, const Key& key,
                  const TraceOptions& options = {});

/// Checks a trace against the bytes of the leaked file (content_hash, registry.h): when they
/// are those of a candidate's recorded copy (its output_hash), identical_row is that row, and
/// the message says so when it is a named buyer's. When it is not a named buyer's while some
/// buyer is named, the mark and the registry contradict each other: nobody is named and a
/// warning says why.
void compare_with_issued_files(TraceResult& r, const std::string& leaked_hash);

/// Traces leaked against the copies a registry (an SQLite file or a postgresql:// URI, which
/// must exist) recorded under key of the original: of the file whose content hash is
/// original_hash, and of any file of the same geometry (geometry_hash of original, registry.h;
/// the same shape saved in another format). When none was, the message says how many copies of
/// other originals were issued under that key (the original given is then likely not the file the
/// copies were made from). The registry is read on a thread of its own while the leak is
/// registered and measured; the result is trace()'s on the registry's list, bit for bit, but
/// for a row without a MAC, which is never named here (anyone who can edit the registry can
/// remove MACs).
/// \throw IOError when the registry does not exist or cannot be read; as trace() otherwise.
TraceResult trace_issued(const Mesh& leaked, const Mesh& original, const std::string& original_hash,
                         const std::string& registry, const Key& key,
                         const TraceOptions& options = {});

}  // namespace meshmark
