#pragma once
/// \file calibrate.h
/// Strength calibration (../shared/spec/WATERMARK.md section 6): the largest strength alpha
/// whose embedding keeps the vertex RMS distortion and MSDM within limits, found by bisection
/// on log(alpha). Both distortions grow with alpha; an alpha whose embedding fails (infeasible
/// bits, not converged) counts as too strong.

#include <Eigen/Core>
#include <string>

#include "meshmark/embed.h"
#include "meshmark/payload.h"

namespace meshmark {

/// Limits and search range of calibrate_strength.
struct CalibrateOptions {
  double max_rms_percent = 0.04;  ///< vertex RMS, % of the bounding-box diagonal
  double max_msdm = 0.25;         ///< MSDM (Lavoue et al. 2006)
  double min_strength = 1e-3;     ///< search range of alpha
  double max_strength = 0.44;
  int iterations = 12;  ///< bisection steps (relative precision (max/min)^(2^-k))
};

/// Outcome of calibrate_strength.
enum class CalibrateStatus {
  Calibrated,    ///< strength meets both limits; strength * (1 + precision) does not
  AtMaximum,     ///< even max_strength meets both limits
  BelowMinimum,  ///< not even min_strength meets them (or embeds)
};

/// What calibrate_strength found.
struct CalibrateResult {
  CalibrateStatus status = CalibrateStatus::BelowMinimum;
  double strength = 0;     ///< the calibrated alpha (0 when BelowMinimum)
  double rms_percent = 0;  ///< distortions of the embedding at that strength
  double msdm = 0;
  int evaluations = 0;  ///< embeddings tried
  double seconds = 0;   ///< wall time
  std::string message;  ///< one line for a person
};

/// Calibrates options.strength for embedding payload into V, F with the other embed options.
CalibrateResult calibrate_strength(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                                   const Payload& payload, const EmbedOptions& embed_options,
                                   const CalibrateOptions& options = {});

/// "calibrated", "at maximum", "below minimum".
const char* calibrate_status_name(CalibrateStatus status);

}  // namespace meshmark
