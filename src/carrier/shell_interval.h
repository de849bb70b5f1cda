#pragma once
/// \file shell_interval.h
/// Exact bin constraints for a displacement along a non-radial direction (docs/method.md
/// section 3, item 3; TIFS 2014 Appendix, Algorithm 1): the displacements r for which
/// p + r u stays between two spheres around the center.

namespace meshmark {

/// Which case of Algorithm 1 gave the interval.
enum class ShellCase {
  C1,  ///< the line misses the outer sphere: no interval (fall back to the radial direction)
  C2,  ///< the line misses the inner sphere: the whole chord of the outer one
  C3,  ///< one of the two pieces contains r = 0
  C4,  ///< neither piece contains r = 0: the nearer one
};

/// The interval [lo, hi] of displacements, or none (C1).
struct ShellInterval {
  ShellCase which = ShellCase::C1;
  double lo = 0, hi = 0;
  bool empty() const { return which == ShellCase::C1; }
};

/// For a point at distance rho > 0 from the center, moving along a unit direction u with
/// cos_psi = (p - C)/rho . u: the interval of r with lower <= |p + r u - C| <= upper that
/// contains r = 0 or, failing that, lies nearest to it. 0 <= lower <= upper.
ShellInterval shell_interval(double rho, double cos_psi, double lower, double upper);

}  // namespace meshmark
