// Exact bin constraints along a line against brute-force sampling of the line.

#include <gtest/gtest.h>

#include <cmath>

#include "carrier/shell_interval.h"
#include "meshmark/core/random.h"

using namespace meshmark;

namespace {

// |p + r u - C| for a point at distance rho with cos(psi) = c, in the plane of p - C and u.
double distance(double rho, double c, double r) {
  return std::sqrt(rho * rho + 2 * r * rho * c + r * r);
}

// Scans r over [-span, span] and returns the maximal runs where lower <= distance <= upper.
std::vector<std::pair<double, double>> runs(double rho, double c, double lower, double upper,
                                            double span, int n) {
  std::vector<std::pair<double, double>> out;
  bool inside = false;
  for (int k = 0; k <= n; ++k) {
    const double r = -span + 2 * span * k / n;
    const double d = distance(rho, c, r);
    const bool in = d >= lower && d <= upper;
    if (in && !inside) out.push_back({r, r});
    if (in) out.back().second = r;
    inside = in;
  }
  return out;
}

}  // namespace

TEST(ShellInterval, AgreesWithBruteForceInAllFourCases) {
  Random rng(3);
  int seen[4] = {0, 0, 0, 0};
  const int n = 200000;
  for (int trial = 0; trial < 400; ++trial) {
    const double rho = rng.uniform(0.5, 2.0);
    const double c = rng.uniform(-1, 1);
    const double lower = rng.uniform(0.2, 2.0), upper = lower + rng.uniform(0.01, 0.6);
    const ShellInterval iv = shell_interval(rho, c, lower, upper);
    const double span = 6.0, step = 2 * span / n;
    const auto found = runs(rho, c, lower, upper, span, n);
    ++seen[static_cast<int>(iv.which)];
    if (iv.empty()) {
      EXPECT_TRUE(found.empty()) << "C1 but the line reaches the shell";
      continue;
    }
    ASSERT_FALSE(found.empty());
    // The interval is one of the runs, and the one that holds r = 0 or is nearest to it.
    auto dist0 = [](const std::pair<double, double>& run) {
      return run.first > 0 ? run.first : run.second < 0 ? -run.second : 0.0;
    };
    const auto best = *std::min_element(found.begin(), found.end(),
                                        [&](auto& a, auto& b) { return dist0(a) < dist0(b); });
    EXPECT_NEAR(iv.lo, best.first, 2 * step);
    EXPECT_NEAR(iv.hi, best.second, 2 * step);
    if (iv.which == ShellCase::C3) EXPECT_EQ(dist0(best), 0.0);
    if (iv.which == ShellCase::C4) EXPECT_GT(dist0(best), 0.0);
    if (iv.which == ShellCase::C2)
      EXPECT_EQ(found.size(), 1u) << "C2: the line misses the inner sphere";
    // The ends lie on the spheres.
    for (double r : {iv.lo, iv.hi}) {
      const double d = distance(rho, c, r);
      EXPECT_TRUE(std::abs(d - lower) < 1e-9 || std::abs(d - upper) < 1e-9);
    }
  }
  for (int k = 0; k < 4; ++k) EXPECT_GT(seen[k], 0) << "case C" << k + 1 << " never occurred";
}

TEST(ShellInterval, RadialDirectionGivesTheBox) {
  // Along the radius the constraint is lower - rho <= r <= upper - rho.
  const ShellInterval iv = shell_interval(1.0, 1.0, 0.9, 1.2);
  EXPECT_EQ(iv.which, ShellCase::C3);
  EXPECT_NEAR(iv.lo, -0.1, 1e-15);
  EXPECT_NEAR(iv.hi, 0.2, 1e-15);
}
