#include "meshmark/calibrate.h"

#include <fmt/format.h>

#include <chrono>
#include <cmath>

#include "meshmark/error.h"
#include "meshmark/metrics.h"

namespace meshmark {

namespace {

struct Trial {
  bool ok = false;  // embedded and within both limits
  double rms = 0, msdm = 0;
};

}  // namespace

const char* calibrate_status_name(CalibrateStatus status) {
  switch (status) {
    case CalibrateStatus::Calibrated:
      return "calibrated";
    case CalibrateStatus::AtMaximum:
      return "at maximum";
    case CalibrateStatus::BelowMinimum:
      return "below minimum";
  }
  return "?";
}

CalibrateResult calibrate_strength(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                                   const Payload& payload, const EmbedOptions& embed_options,
                                   const CalibrateOptions& o) {
  if (!(o.min_strength > 0 && o.min_strength < o.max_strength && o.max_strength < 0.5))
    throw InvalidArgumentError(fmt::format("calibration range [{}, {}] is not inside (0, 1/2)",
                                           o.min_strength, o.max_strength));
  if (!(o.max_rms_percent > 0) || !(o.max_msdm > 0) || o.iterations < 1)
    throw InvalidArgumentError("calibration limits must be positive, with at least 1 step");
  const auto start = std::chrono::steady_clock::now();
  CalibrateResult result;
  auto evaluate = [&](double alpha) {
    EmbedOptions eo = embed_options;
    eo.strength = alpha;
    ++result.evaluations;
    const EmbedResult r = embed(V, F, payload, eo);
    Trial t;
    if (r.status != EmbedStatus::Embedded) return t;
    t.rms = r.rms_percent;
    // MSDM only when RMS passes: it is the expensive one.
    if (t.rms <= o.max_rms_percent) t.msdm = msdm(V, r.V, F).global;
    t.ok = t.rms <= o.max_rms_percent && t.msdm <= o.max_msdm;
    return t;
  };
  auto finish = [&](CalibrateStatus status, double alpha, const Trial& t) {
    result.status = status;
    result.strength = alpha;
    result.rms_percent = t.rms;
    result.msdm = t.msdm;
    result.seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    result.message =
        status == CalibrateStatus::BelowMinimum
            ? fmt::format("even strength {} exceeds RMS {} % or MSDM {}, or does not embed",
                          o.min_strength, o.max_rms_percent, o.max_msdm)
            : fmt::format("strength {:.5f}: RMS {:.5f} %, MSDM {:.4f} ({} embeddings)", alpha,
                          t.rms, t.msdm, result.evaluations);
    return result;
  };
  const Trial top = evaluate(o.max_strength);
  if (top.ok) return finish(CalibrateStatus::AtMaximum, o.max_strength, top);
  Trial best = evaluate(o.min_strength);
  if (!best.ok) return finish(CalibrateStatus::BelowMinimum, 0, best);
  double lo = std::log(o.min_strength), hi = std::log(o.max_strength);
  for (int k = 0; k < o.iterations; ++k) {
    const double mid = 0.5 * (lo + hi);
    const Trial t = evaluate(std::exp(mid));
    if (t.ok)
      lo = mid, best = t;
    else
      hi = mid;
  }
  return finish(CalibrateStatus::Calibrated, std::exp(lo), best);
}

}  // namespace meshmark
