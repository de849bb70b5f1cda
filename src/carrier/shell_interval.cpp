#include "carrier/shell_interval.h"

#include <cmath>

namespace meshmark {

ShellInterval shell_interval(double rho, double cos_psi, double lower, double upper) {
  // |p + r u - C|^2 = r^2 + 2 gamma r + rho^2 with gamma = rho cos(psi).
  const double gamma = rho * cos_psi;
  const double U = upper * upper - rho * rho, L = lower * lower - rho * rho;
  ShellInterval out;
  const double du = gamma * gamma + U;
  if (du < 0) return out;  // C1: r^2 + 2 gamma r - U <= 0 has no solution
  const double su = std::sqrt(du);
  const double s1 = -gamma - su, s2 = -gamma + su;
  const double dl = gamma * gamma + L;
  if (dl < 0) {  // C2: the inner constraint holds everywhere on the line
    out.which = ShellCase::C2;
    out.lo = s1;
    out.hi = s2;
    return out;
  }
  const double sl = std::sqrt(dl);
  const double s3 = -gamma - sl, s4 = -gamma + sl;  // inside the inner sphere for r in (s3, s4)
  const bool first_has_zero = s1 * s3 <= 0, second_has_zero = s4 * s2 <= 0;
  const bool take_first = first_has_zero || (!second_has_zero && std::abs(s3) < std::abs(s4));
  out.which = first_has_zero || second_has_zero ? ShellCase::C3 : ShellCase::C4;
  out.lo = take_first ? s1 : s4;
  out.hi = take_first ? s3 : s2;
  return out;
}

}  // namespace meshmark
