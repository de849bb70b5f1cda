#include "meshmark/mark/calibrate.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <optional>
#include <utility>
#include <vector>

#include "mark/embed_problem.h"
#include "meshmark/carrier/carrier_check.h"
#include "meshmark/core/error.h"
#include "meshmark/metrics/metrics.h"

namespace meshmark {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// One embedding tried: its strength, G, distortions and the ratio of the worse one to its
// limit (infinite when it did not embed; RMS alone when RMS already failed, a lower bound).
struct Trial {
  double alpha = 0, bin_offset = 0;
  double rms = 0, msdm = 0, ratio = kInf;
  bool ok = false;
  bool estimated = false;  // msdm is an estimate (steering), not a measurement
  EmbedResult result;
  std::vector<double> strengths;
};

// The strengths' search: brackets the limit between the strongest alpha within it (lo) and
// the weakest beyond it (hi), stepping by the power law log ratio = p log alpha + c fitted to
// the last two trials, and interpolating inside the bracket.
class Search {
 public:
  // min_step: the smallest factor a step outside a bracket takes (1.25 from scratch, where
  // the power law is a guess; less after a steering search, whose law is fitted).
  Search(const CalibrateOptions& o, double exponent = 1, double min_step = 1.25)
      : o_(o), exponent_(exponent), min_step_(min_step) {}

  double exponent() const { return exponent_; }

  void add(const Trial& t) {
    if (std::isfinite(t.ratio) && t.ratio > 0) {
      if (last_ && std::isfinite(last_->ratio) && last_->ratio > 0 && last_->alpha != t.alpha) {
        const double p = std::log(t.ratio / last_->ratio) / std::log(t.alpha / last_->alpha);
        if (std::isfinite(p)) exponent_ = std::clamp(p, 0.5, 3.0);
      }
      last_ = Point{t.alpha, t.ratio};
    }
    if (t.ok && (!lo_ || t.alpha > lo_->alpha)) lo_ = Point{t.alpha, t.ratio};
    if (!t.ok && (!hi_ || t.alpha < hi_->alpha)) hi_ = Point{t.alpha, t.ratio};
  }

  // An exact failure seen before this search (while steering): the weakest so far beyond.
  void bound_above(double alpha, double ratio) {
    if (!hi_ || alpha < hi_->alpha) hi_ = Point{alpha, ratio};
  }

  bool at_maximum() const { return lo_ && lo_->alpha >= o_.max_strength; }
  bool below_minimum() const { return hi_ && hi_->alpha <= o_.min_strength; }
  bool converged() const {
    if (!lo_) return false;
    if (hi_ && hi_->alpha <= lo_->alpha * (1 + o_.precision)) return true;
    return lo_->ratio >= 1 - o_.precision;
  }

  // The next alpha to try.
  double next() const {
    const double target = 1 - 0.5 * o_.precision;  // just inside the limit
    if (lo_ && hi_) {
      const double a = std::log(lo_->alpha), b = std::log(hi_->alpha);
      double f = 0.5;
      if (std::isfinite(hi_->ratio) && hi_->ratio > lo_->ratio && lo_->ratio > 0)
        f = std::log(target / lo_->ratio) / std::log(hi_->ratio / lo_->ratio);
      // Keep to the bracket's inner 70 % so that it shrinks by 15 % at least every step.
      return std::exp(a + std::clamp(f, 0.15, 0.85) * (b - a));
    }
    if (lo_) {  // everything so far within the limits: stronger
      const double r = std::max(lo_->ratio, 1e-9);
      const double step = std::clamp(std::pow(target / r, 1 / exponent_), min_step_, 8.0);
      return std::min(o_.max_strength, lo_->alpha * step);
    }
    // Everything so far beyond the limits (or not embedded): weaker.
    const double r = hi_->ratio;
    const double step =
        std::isfinite(r) ? std::clamp(std::pow(r / target, 1 / exponent_), min_step_, 8.0) : 4.0;
    return std::max(o_.min_strength, hi_->alpha / step);
  }

 private:
  struct Point {
    double alpha, ratio;
  };
  const CalibrateOptions& o_;
  std::optional<Point> lo_, hi_, last_;
  double exponent_ = 1;  // distortion ~ alpha^p; 1 until two trials say otherwise
  double min_step_ = 1.25;
};

// The original's side of MSDM, computed at the first call (reporting to its progress).
using MsdmReferenceOf = std::function<const MsdmReference&(const ProgressCallback&)>;

// Per-bit strengths for alpha: the caller's rule, or the given ones scaled.
std::vector<double> strengths_for(const CalibrateOptions& o, const EmbedOptions& eo, double alpha) {
  if (o.strengths) return o.strengths(alpha);
  std::vector<double> s = eo.strengths;
  for (double& x : s) x = std::min(x * alpha / eo.strength, 0.499);
  return s;
}

// Why not even min_strength fits, and what would: one line each.
void explain(const PreparedEmbedder& embedder, const Payload& payload, const EmbedOptions& eo,
             const CalibrateOptions& o, const MsdmReferenceOf& reference_of, const Trial& weakest,
             CalibrateResult& result) {
  const int nb = payload.size();
  auto& d = result.diagnostics;
  const EmbedResult& r = weakest.result;
  // Bits the carrier can hold: the largest nb' with a healthy check.
  // And whether the weakest mark of that many bits (the payload's first ones) fits the limits:
  // fewer bits have wider bins, whose vertices move farther for the same strength.
  auto fewer_bits = [&]() -> std::string {
    int k = nb - 1;
    while (k >= 1 && embedder.check(k).status != CarrierHealth::Healthy)
      k = k > 16 ? k - k / 8 : k - 1;
    if (k < 1) return "no payload length gives every bin enough positions";
    Payload prefix;
    prefix.bits.assign(payload.bits.begin(), payload.bits.begin() + k);
    EmbedOptions e = eo;
    e.strength = o.min_strength;
    e.bin_offset = o.bin_offset == BinOffsetRule::Fixed ? eo.bin_offset
                                                        : std::min(eo.bin_offset, o.min_strength);
    e.strengths.clear();
    const EmbedResult w = embedder.embed(prefix, e);
    const std::string healthy = fmt::format("{} bits give every bin enough positions", k);
    if (w.status != EmbedStatus::Embedded)
      return fmt::format("{}, but do not embed either: {}", healthy, w.message);
    const double m = w.rms_percent <= o.max_rms_percent ? reference_of({}).compare(w.V).global : -1;
    if (m >= 0 && m <= o.max_msdm)
      return fmt::format("{} and fit the limits at strength {}", healthy, o.min_strength);
    return fmt::format(
        "{}, but not the limits: their wider bins cost more, RMS {:.5f} %{} at strength {}",
        healthy, w.rms_percent, m >= 0 ? fmt::format(" and MSDM {:.4f}", m) : "", o.min_strength);
  };
  auto other_centers = [&] {
    std::vector<std::string> ok;
    for (const CenterKind c : {CenterKind::Discrete, CenterKind::Surface, CenterKind::Volume})
      if (c != eo.variant.center &&
          check_carrier(embedder.V(), embedder.F(), nb, c).status == CarrierHealth::Healthy)
        ok.push_back(Variant{c, eo.variant.direction, eo.variant.cost}.name());
    return ok;
  };
  const CarrierCheck& check = r.check;
  const std::string per_bin = fmt::format(
      "{} distinct carrier positions for {} bits: {:.1f} per data bin on average ({} recommended "
      "for a bit one vertex does not decide)",
      check.positions, nb, static_cast<double>(check.positions) / nb, kMinPositionsPerBin);
  if (r.status == EmbedStatus::InvalidMesh) {
    result.cause = CalibrateCause::Carrier;
    d.push_back("the mesh cannot carry the payload: " + r.message);
    d.push_back(per_bin);
  } else if (r.status == EmbedStatus::Infeasible) {
    // Empty bins are the carrier's fault, not the strength's: no vertex to move.
    result.cause = check.empty_bins > 0 ? CalibrateCause::Carrier : CalibrateCause::Infeasible;
    d.push_back(fmt::format(
        "{}even strength {}: {}",
        check.empty_bins > 0 ? fmt::format("{} of {} bins are empty; ", check.empty_bins, nb) : "",
        weakest.alpha, r.message));
    for (const std::string& line : check.diagnostics) d.push_back(line);
    d.push_back(per_bin);
  } else if (r.status == EmbedStatus::NotConverged) {
    result.cause = CalibrateCause::NotConverged;
    d.push_back(fmt::format("even strength {} does not converge: {}", weakest.alpha, r.message));
  } else {
    const bool rms_over = weakest.rms > o.max_rms_percent;
    result.cause = rms_over ? CalibrateCause::RmsLimit : CalibrateCause::MsdmLimit;
    d.push_back(fmt::format(
        "the weakest mark (strength {}, bin offset G = {}) already costs RMS {:.5f} % (limit {}) "
        "and MSDM {} (limit {})",
        weakest.alpha, weakest.bin_offset, weakest.rms, o.max_rms_percent,
        rms_over ? std::string("not measured") : fmt::format("{:.4f}", weakest.msdm), o.max_msdm));
    if (o.bin_offset == BinOffsetRule::Fixed && eo.bin_offset > weakest.alpha)
      d.push_back(fmt::format(
          "way out: let G follow the strength (G <= alpha, the default search): G = {} keeps "
          "every vertex {} bin widths from its bin's edges, and that costs most at small "
          "strengths",
          eo.bin_offset, eo.bin_offset));
    d.push_back(fmt::format("way out: limits of at least {} and {} admit the weakest mark",
                            rms_over ? fmt::format("RMS {:.5f} %", weakest.rms)
                                     : fmt::format("RMS {} %", o.max_rms_percent),
                            rms_over ? std::string("an MSDM still to measure")
                                     : fmt::format("MSDM {:.4f}", weakest.msdm)));
  }
  if (result.cause == CalibrateCause::Carrier || result.cause == CalibrateCause::Infeasible) {
    d.push_back("way out: " + fewer_bits());
    const std::vector<std::string> centers = other_centers();
    if (!centers.empty())
      d.push_back(fmt::format("way out: another center gives a healthy carrier for {} bits: {}", nb,
                              fmt::join(centers, ", ")));
  }
}

}  // namespace

const char* calibrate_status_name(CalibrateStatus status) {
  return enum_name(status);
}

const char* calibrate_cause_name(CalibrateCause cause) {
  return enum_name(cause);
}

const char* bin_offset_rule_name(BinOffsetRule rule) {
  return enum_name(rule);
}

CalibrateResult calibrate_strength(const PreparedEmbedder& embedder, const Payload& payload,
                                   const EmbedOptions& embed_options, const CalibrateOptions& o) {
  if (!(o.min_strength > 0 && o.min_strength < o.max_strength && o.max_strength < 0.5))
    throw InvalidArgumentError(fmt::format("calibration range [{}, {}] is not inside (0, 1/2)",
                                           o.min_strength, o.max_strength));
  if (!(o.max_rms_percent > 0) || !(o.max_msdm > 0) || o.iterations < 1)
    throw InvalidArgumentError("calibration limits must be positive, with at least 1 step");
  if (!(o.precision > 0 && o.precision < 0.5))
    throw InvalidArgumentError(
        fmt::format("calibration precision {} is outside (0, 1/2)", o.precision));
  if (!embedder.accepts(embed_options))
    throw InvalidArgumentError("calibration options differ from the prepared embedder's");
  const auto start = std::chrono::steady_clock::now();
  CalibrateResult result;
  const Eigen::MatrixX3d& V = embedder.V();
  const Eigen::MatrixX3i& F = embedder.F();
  // The original's side of MSDM: computed (or taken from o.msdm_reference) once, when first
  // needed.
  std::optional<MsdmReference> reference;
  const MsdmReferenceOf reference_of =
      [&](const ProgressCallback& progress) -> const MsdmReference& {
    if (!reference)
      reference = o.msdm_reference ? o.msdm_reference->get(V, F, progress)
                                   : MsdmReference(V, F, MsdmOptions{}, progress);
    return *reference;
  };
  std::vector<std::uint8_t> counted;  // the carrier, for options.finish's displacement
  // MSDM of an embedding whose RMS passed: measured in full (stride 1), or estimated from
  // every stride-th vertex's window.
  auto measure = [&](Trial& t, int stride) {
    ProgressCallback progress;
    if (o.progress)
      progress = [&o, alpha = t.alpha](const std::string& phase, long done, long total,
                                       const std::string& what) {
        o.progress(fmt::format("strength {:.5f}: {}", alpha, phase), done, total, what);
      };
    const MsdmReference& r = reference_of(progress);
    t.estimated = stride > 1;
    if (t.estimated) {
      t.msdm = r.estimate(t.result.V, stride, progress);
      ++result.estimates;
    } else {
      t.msdm = r.compare(t.result.V, progress).global;
      ++result.measurements;
    }
    t.ratio = std::max(t.rms / o.max_rms_percent, t.msdm / o.max_msdm);
    t.ok = t.ratio <= 1;
  };
  auto evaluate = [&](double alpha, int stride) {
    Trial t;
    t.alpha = alpha;
    EmbedOptions eo = embed_options;
    eo.strength = alpha;
    eo.bin_offset = o.bin_offset == BinOffsetRule::Fixed
                        ? embed_options.bin_offset
                        : std::min(embed_options.bin_offset, alpha);
    eo.strengths = strengths_for(o, embed_options, alpha);
    t.bin_offset = eo.bin_offset;
    t.strengths = eo.strengths;
    ++result.evaluations;
    t.result = embedder.embed(payload, eo);
    if (t.result.status != EmbedStatus::Embedded) return t;
    if (o.finish) {  // the positions as they will be written, measured as embed measures
      if (counted.empty()) counted = carrier_vertices(V, F);
      t.result.V = o.finish(t.result.V);
      detail::measure_displacement(V, counted, t.result);
    }
    t.rms = t.result.rms_percent;
    t.ratio = t.rms / o.max_rms_percent;
    // MSDM only when RMS passes: it is the expensive one.
    if (t.rms <= o.max_rms_percent) measure(t, stride);
    t.ok = t.ratio <= 1;
    return t;
  };
  // Trials whose outcome is exact: every one measured in full, and those that failed on RMS
  // or did not embed (no MSDM needed).
  std::optional<Trial> best, weakest_failure;
  auto keep = [&](Trial& t) {
    if (t.ok && (!best || t.alpha > best->alpha))
      best = std::move(t);
    else if (!t.ok && (!weakest_failure || t.alpha < weakest_failure->alpha))
      weakest_failure = std::move(t);
  };
  const auto refused = [&] {  // no strength helps: the carrier is the cause
    return weakest_failure && weakest_failure->result.status == EmbedStatus::InvalidMesh;
  };
  CalibrateStatus status = CalibrateStatus::Calibrated;
  double alpha = std::clamp(o.initial_strength, o.min_strength, o.max_strength);
  // Steering: the same search on estimates, whose end is where the full measurements start.
  // Both searches share one budget of embeddings (o.iterations + 2, and the smallest strength
  // once more when nothing fitted by then), as one search alone had.
  const int budget = o.iterations + 2;
  const int stride = static_cast<int>(V.rows() / kSteeringSample);
  // Where the full measurements start: the strongest trial estimated within the limits, or
  // else the smallest strength's if it was tried; its embedding is measured, not made again.
  std::optional<Trial> restart;
  std::vector<std::pair<double, double>> beyond;  // exact failures while steering: alpha, ratio
  double exponent = 1, min_step = 1.25;
  if (o.steer && stride >= 4) {
    Search search(o);
    std::optional<Trial> weakest_estimated;  // beyond the limits on its estimate
    for (;;) {
      Trial t = evaluate(alpha, stride);
      search.add(t);
      if (t.ok) {
        if (!restart || t.alpha > restart->alpha) restart = std::move(t);
      } else if (t.estimated) {
        if (!weakest_estimated || t.alpha < weakest_estimated->alpha)
          weakest_estimated = std::move(t);
      } else {
        beyond.emplace_back(t.alpha, t.ratio);
        keep(t);
      }
      if (refused() || search.at_maximum() || search.converged() || result.evaluations >= budget ||
          (search.below_minimum() && !restart))
        break;
      alpha = search.next();
    }
    exponent = search.exponent();
    min_step = 1 + o.precision;  // the law is fitted: small steps from here
    if (!restart && weakest_estimated && weakest_estimated->alpha <= o.min_strength)
      restart = std::move(weakest_estimated);
    alpha = restart ? restart->alpha : o.min_strength;
  }
  if (refused()) {
    status = CalibrateStatus::BelowMinimum;
  } else if (!restart && weakest_failure && weakest_failure->alpha <= o.min_strength) {
    status = CalibrateStatus::BelowMinimum;  // known exactly while steering
  } else {
    Search search(o, exponent, min_step);
    for (const auto& [a, r] : beyond) search.bound_above(a, r);
    for (;;) {
      Trial t;
      if (restart && restart->alpha == alpha) {  // its embedding, measured in full now
        t = std::move(*restart);
        restart.reset();
        measure(t, 1);
      } else {
        t = evaluate(alpha, 1);
      }
      search.add(t);
      keep(t);
      if (refused()) {
        status = CalibrateStatus::BelowMinimum;
        break;
      }
      if (search.at_maximum()) {
        status = CalibrateStatus::AtMaximum;
        break;
      }
      if (search.below_minimum() && !best) {
        status = CalibrateStatus::BelowMinimum;
        break;
      }
      if (search.converged() || (best && result.evaluations >= budget)) break;
      // Out of steps without a strength that fits: the smallest one decides.
      alpha = result.evaluations >= budget ? o.min_strength : search.next();
    }
  }
  result.status = status;
  if (best) {
    result.strength = best->alpha;
    result.bin_offset = best->bin_offset;
    result.rms_percent = best->rms;
    result.msdm = best->msdm;
    result.strengths = std::move(best->strengths);
    result.embedding = std::move(best->result);
    result.message = fmt::format(
        "strength {:.5f} (bin offset {:.4f}): RMS {:.5f} %, MSDM {:.4f} ({} embeddings; MSDM "
        "measured {} times, estimated {})",
        result.strength, result.bin_offset, result.rms_percent, result.msdm, result.evaluations,
        result.measurements, result.estimates);
  } else {
    const Trial& w = *weakest_failure;
    result.rms_percent = w.rms;
    result.msdm = w.msdm;
    result.bin_offset = w.bin_offset;
    result.embedding = w.result;
    explain(embedder, payload, embed_options, o, reference_of, w, result);
    result.message =
        fmt::format("no strength from {} fits RMS {} % and MSDM {}: {}", o.min_strength,
                    o.max_rms_percent, o.max_msdm, result.diagnostics.front());
  }
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

CalibrateResult calibrate_strength(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                                   const Payload& payload, const EmbedOptions& embed_options,
                                   const CalibrateOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  CalibrateResult r =
      calibrate_strength(PreparedEmbedder(V, F, embed_options), payload, embed_options, options);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return r;
}

}  // namespace meshmark
