#include "meshmark/mark/cho.h"

#include <cmath>

namespace meshmark {

namespace {

double mean_score(const std::vector<double>& t, BinStatistic statistic, double k) {
  double sum = 0;
  for (const double x : t) sum += bin_score_term(statistic, cho_map(statistic, x, k));
  return sum / static_cast<double>(t.size());
}

// Whether a score is on bit's side of the target.
bool meets(bool bit, double score, double target) {
  return bit ? score >= target : score <= target;
}

}  // namespace

double cho_map(BinStatistic statistic, double t, double k) {
  if (statistic == BinStatistic::Mean) return std::pow(t, k);
  const double u = 2 * t - 1;
  return 0.5 * (1 + std::copysign(std::pow(std::abs(u), k), u));
}

ChoBinMapping cho_search_exponent(const std::vector<double>& t, BinStatistic statistic, bool bit,
                                  double target, const ChoSettings& settings) {
  ChoBinMapping m;
  if (t.empty()) return m;  // an empty bin: unreachable
  m.k = 1;
  m.score = mean_score(t, statistic, 1.0);
  m.iterations = 1;
  if (meets(bit, m.score, target)) {
    m.status = ChoSearchStatus::Unchanged;
    return m;
  }
  // The score falls as k grows: bit 1 needs k < 1, bit 0 needs k > 1. Bracket first.
  const double step = bit ? 0.5 : 2.0;
  double good = 0, bad = 1;  // good: an exponent that meets the target (0: none yet)
  double good_score = 0;
  for (int q = 0; q < 64 && m.iterations < settings.max_iterations; ++q) {
    const double k = bad * step;
    const double s = mean_score(t, statistic, k);
    ++m.iterations;
    if (meets(bit, s, target)) {
      good = k, good_score = s;
      break;
    }
    bad = k;
  }
  if (good == 0) return m;  // the limit of t^k as k -> 0 or infinity falls short
  // Bisection of log k between the bracket's ends, keeping the end that meets the target.
  while (std::abs(good_score - target) > settings.tolerance &&
         m.iterations < settings.max_iterations) {
    const double k = std::sqrt(good * bad);
    if (k == good || k == bad) break;  // the bracket cannot shrink in doubles
    const double s = mean_score(t, statistic, k);
    ++m.iterations;
    if (meets(bit, s, target))
      good = k, good_score = s;
    else
      bad = k;
  }
  m.k = good;
  m.score = good_score;
  m.status = std::abs(good_score - target) <= settings.tolerance ? ChoSearchStatus::Reached
                                                                 : ChoSearchStatus::Tolerance;
  return m;
}

const char* cho_search_status_name(ChoSearchStatus status) {
  return enum_name(status);
}

}  // namespace meshmark
