#include "meshmark/detect.h"

#include <fmt/format.h>

#include <cmath>

#include "meshmark/error.h"

namespace meshmark {

double binomial_tail(int n, int k) {
  if (k <= 0) return 1.0;
  if (k > n) return 0.0;
  // log C(n, i) - n log 2 for i = k..n, summed with a running maximum (log-sum-exp).
  const double log_half_n = n * std::log(0.5);
  auto log_term = [&](int i) {
    return std::lgamma(n + 1.0) - std::lgamma(i + 1.0) - std::lgamma(n - i + 1.0) + log_half_n;
  };
  // Terms decrease from i = max(k, n/2) on, and k is the largest term when k >= n/2.
  double top = log_term(k);
  for (int i = k; i <= n; ++i) top = std::max(top, log_term(i));
  double sum = 0;
  for (int i = k; i <= n; ++i) sum += std::exp(log_term(i) - top);
  return std::min(1.0, std::exp(top) * sum);
}

DetectResult detect(const std::vector<std::uint8_t>& bits, const Payload& expected,
                    const DetectOptions& options) {
  if (static_cast<int>(bits.size()) != expected.size())
    throw InvalidArgumentError(fmt::format("{} bits read for an expected payload of {} bits",
                                           bits.size(), expected.size()));
  if (!(options.threshold > 0 && options.threshold < 1))
    throw InvalidArgumentError(
        fmt::format("the detection threshold {} is out of (0, 1)", options.threshold));
  DetectResult r;
  r.compared = expected.size();
  for (std::size_t j = 0; j < bits.size(); ++j) {
    if (bits[j] > 1)
      ++r.erasures;
    else if (bits[j] == expected.bits[j])
      ++r.matches;
  }
  r.p_value = binomial_tail(r.compared, r.matches);
  r.detected = r.p_value < options.threshold;
  return r;
}

}  // namespace meshmark
