#pragma once
/// \file detect.h
/// Detection of an expected payload with a false-alarm probability: the number of bits read
/// that match the expected ones, and the probability that a mesh carrying no such watermark
/// (unmarked, or marked under another key: its bits read as fair coin flips) would match at
/// least as many, P(Binomial(n, 1/2) >= matches).

#include <cstdint>
#include <vector>

#include "meshmark/payload.h"

namespace meshmark {

/// P(X >= k) for X ~ Binomial(n, 1/2), accurate in relative terms far into the tail (computed
/// with logarithms; returns 1 for k <= 0 and 0 for k > n).
double binomial_tail(int n, int k);

/// Options of detect.
struct DetectOptions {
  double threshold = 1e-6;  ///< declare the payload present when the p-value is below this
};

/// What detect found.
struct DetectResult {
  int compared = 0;       ///< bits compared (the payload's length)
  int matches = 0;        ///< bits read equal to the expected ones (erasures never match)
  int erasures = 0;       ///< bits that could not be read (empty bins)
  double p_value = 1;     ///< false-alarm probability of at least this many matches
  bool detected = false;  ///< p_value < threshold
};

/// Compares bits read (payload order; 0, 1, or an erasure > 1) with the expected payload.
/// \throw InvalidArgumentError when the sizes differ or the threshold is not in (0, 1).
DetectResult detect(const std::vector<std::uint8_t>& bits, const Payload& expected,
                    const DetectOptions& options = {});

}  // namespace meshmark
