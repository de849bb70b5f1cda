#pragma once
/// \file random.h
/// A small, portable, seeded random generator (SplitMix64): the same seed gives the same
/// numbers on every platform and standard library, so attacks and payloads are reproducible.

#include <cstdint>

namespace meshmark {

/// SplitMix64 (Steele, Lea, Flood 2014). Not cryptographic.
class Random {
 public:
  explicit Random(std::uint64_t seed) : state_(seed) {}
  /// Next 64 random bits.
  std::uint64_t next() {
    std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  /// Uniform double in [0, 1) with 53 random bits.
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
  /// Uniform double in [lo, hi).
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  /// Uniform integer in [0, n), n > 0 (Lemire's multiply-shift, bias below 2^-64 n).
  std::uint64_t index(std::uint64_t n) {
    __extension__ using u128 = unsigned __int128;
    return static_cast<std::uint64_t>((static_cast<u128>(next()) * n) >> 64);
  }
  /// Standard normal variate (Box-Muller).
  double normal();

 private:
  std::uint64_t state_;
};

}  // namespace meshmark
