#pragma once
/// \file calibrate.h
/// Strength calibration (docs/method.md section 6): the strongest mark whose
/// vertex RMS distortion and MSDM stay within limits, for one payload on one mesh. Both
/// distortions grow with the strength alpha; an alpha whose embedding fails (infeasible bits,
/// not converged) counts as too strong. The search brackets the limit and interpolates on
/// log(distortion) against log(alpha), so it needs about 5 to 8 embeddings where a bisection
/// needs 12 or more; every embedding reuses one PreparedEmbedder and the original's side of
/// MSDM. When not even the smallest strength fits, the result says why and what would.

#include <Eigen/Core>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "meshmark/core/enum_names.h"
#include "meshmark/core/progress.h"
#include "meshmark/mark/embed.h"
#include "meshmark/mark/payload.h"
#include "meshmark/metrics/metrics.h"

namespace meshmark {

/// How the bin offset G (EmbedOptions::bin_offset) follows the strength alpha.
enum class BinOffsetRule {
  Fixed,           ///< G = embed_options.bin_offset for every alpha (the paper's)
  AtMostStrength,  ///< G = min(embed_options.bin_offset, alpha): a weak mark does not pay for
                   ///< a wide guard band, so a mesh whose vertices crowd bin edges still fits
};

/// The names of BinOffsetRule's values.
template <>
struct EnumTable<BinOffsetRule> {
  static constexpr const char* what = "bin offset rule";
  static constexpr NamedValue<BinOffsetRule> values[] = {
      {BinOffsetRule::Fixed, "fixed"}, {BinOffsetRule::AtMostStrength, "at-most-strength"}};
};

/// Vertices whose windows steer the search (CalibrateOptions::steer), about.
inline constexpr int kSteeringSample = 4096;

/// Limits and search of calibrate_strength.
struct CalibrateOptions {
  double max_rms_percent = 0.04;  ///< vertex RMS, % of the bounding-box diagonal
  double max_msdm = 0.25;         ///< MSDM (Lavoue et al. 2006)
  double min_strength = 1e-3;     ///< search range of alpha
  double max_strength = 0.44;
  double initial_strength = 0.03;  ///< first alpha tried (clamped to the range)
  /// Stop when the strongest alpha within the limits and the weakest beyond them differ by at
  /// most this ratio minus 1, or when the strongest reaches (1 - precision) of a limit.
  double precision = 0.01;
  int iterations = 12;  ///< embeddings at most after the first two (a bound, seldom reached)
  /// On meshes of at least 4 x kSteeringSample vertices, search first with MSDM estimated
  /// from every k-th vertex's window (MsdmReference::estimate, k = #V / kSteeringSample),
  /// then measure MSDM in full only from where that search ends: the same stopping rule on
  /// full measurements, usually one or two of them instead of three or four. false: every
  /// trial measured in full.
  bool steer = true;
  BinOffsetRule bin_offset = BinOffsetRule::AtMostStrength;
  /// Per-bit strengths (EmbedOptions::strengths) for a strength alpha, for marks whose bits
  /// have their own strengths (watermark.h: mark_strengths). Empty: embed_options.strengths
  /// scaled by alpha / embed_options.strength, or none.
  std::function<std::vector<double>(double alpha)> strengths;
  /// What is added to every embedding before it is measured, given its positions (an issuer's
  /// second mark: issue.h adds the fingerprint): the limits then hold for the positions
  /// returned, which CalibrateResult::embedding holds. Empty: nothing.
  std::function<Eigen::MatrixX3d(const Eigen::MatrixX3d& V)> finish;
  /// Called as each embedding tried is measured (progress.h): MSDM's phases (metrics.h), the
  /// strength in their names ("strength 0.03000: measuring MSDM"), one unit per vertex. On a
  /// few 100k vertices each takes minutes. Empty: nothing.
  ProgressCallback progress;
  /// The original's side of MSDM, shared by searches on one original (an issuer's copies):
  /// computed by the first search that needs it and reused by the others. Null: each search
  /// computes its own. \throw InvalidArgumentError (from calibrate_strength) when it holds
  /// the reference of another mesh.
  std::shared_ptr<SharedMsdmReference> msdm_reference;
};

/// Outcome of calibrate_strength.
enum class CalibrateStatus {
  Calibrated,    ///< strength meets both limits, and its distortion is within precision of
                 ///< a limit or strength * (1 + precision) breaks one
  AtMaximum,     ///< even max_strength meets both limits
  BelowMinimum,  ///< not even min_strength meets them (or embeds): see cause
};

/// The names of CalibrateStatus's values (calibrate_status_name).
template <>
struct EnumTable<CalibrateStatus> {
  static constexpr const char* what = "calibration status";
  static constexpr NamedValue<CalibrateStatus> values[] = {
      {CalibrateStatus::Calibrated, "calibrated"},
      {CalibrateStatus::AtMaximum, "at maximum"},
      {CalibrateStatus::BelowMinimum, "below minimum"}};
};

/// Why not even the smallest strength fits (BelowMinimum), or None.
enum class CalibrateCause {
  None,
  Carrier,       ///< too few distinct positions or empty bins for nb bits (carrier check)
  Infeasible,    ///< some bits cannot reach their targets inside their bins
  NotConverged,  ///< the embedding does not converge even at the smallest strength
  RmsLimit,      ///< the vertex RMS at the smallest strength is beyond its limit
  MsdmLimit,     ///< the MSDM at the smallest strength is beyond its limit
};

/// The names of CalibrateCause's values (calibrate_cause_name).
template <>
struct EnumTable<CalibrateCause> {
  static constexpr const char* what = "calibration cause";
  static constexpr NamedValue<CalibrateCause> values[] = {
      {CalibrateCause::None, "none"},
      {CalibrateCause::Carrier, "carrier"},
      {CalibrateCause::Infeasible, "infeasible"},
      {CalibrateCause::NotConverged, "not converged"},
      {CalibrateCause::RmsLimit, "rms limit"},
      {CalibrateCause::MsdmLimit, "msdm limit"}};
};

/// What calibrate_strength found.
struct CalibrateResult {
  CalibrateStatus status = CalibrateStatus::BelowMinimum;
  CalibrateCause cause = CalibrateCause::None;
  double strength = 0;     ///< the calibrated alpha (0 when BelowMinimum)
  double bin_offset = 0;   ///< G of that embedding
  double rms_percent = 0;  ///< distortions of the embedding at that strength (when
  double msdm = 0;         ///< BelowMinimum: at min_strength, MSDM 0 when RMS already failed)
  /// The embedding at strength (status Embedded unless BelowMinimum): the positions every
  /// caller can write as they are, since they were measured within the limits.
  EmbedResult embedding;
  std::vector<double> strengths;  ///< per-bit strengths of that embedding (empty: uniform)
  int evaluations = 0;            ///< embeddings tried
  int measurements = 0;           ///< full MSDM measurements (the expensive step)
  int estimates = 0;              ///< MSDM estimates (CalibrateOptions::steer)
  double seconds = 0;             ///< wall time
  std::string message;            ///< one line for a person
  /// BelowMinimum: the cause and the ways out, one line each (fewer bits, another center,
  /// the values reached at the smallest strength and the limits that would admit them).
  std::vector<std::string> diagnostics;
};

/// The strongest mark of payload on the prepared mesh within options' limits, embedding with
/// embed_options (variant, lambda, solver, ...) and the strength and G the search sets.
/// \throw InvalidArgumentError for limits or a range out of bounds, or embed_options the
///        embedder was not prepared for.
CalibrateResult calibrate_strength(const PreparedEmbedder& embedder, const Payload& payload,
                                   const EmbedOptions& embed_options,
                                   const CalibrateOptions& options = {});

/// The same on V, F (#V x 3, #F x 3), preparing the embedder first.
CalibrateResult calibrate_strength(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                                   const Payload& payload, const EmbedOptions& embed_options,
                                   const CalibrateOptions& options = {});

/// "calibrated", "at maximum", "below minimum".
const char* calibrate_status_name(CalibrateStatus status);

/// "none", "carrier", "infeasible", "not converged", "rms limit", "msdm limit".
const char* calibrate_cause_name(CalibrateCause cause);

/// "fixed", "at-most-strength".
const char* bin_offset_rule_name(BinOffsetRule rule);

/// The paper's fidelity limits (TIFS 2014, section V): vertex RMS 0.04 % of the diagonal and
/// MSDM 0.25.
inline constexpr double kPaperMaxRmsPercent = 0.04;
inline constexpr double kPaperMaxMsdm = 0.25;

}  // namespace meshmark
