#include "meshmark/plot/color.h"

#include <algorithm>
#include <cmath>

namespace meshmark {

Eigen::Vector3i heat_color(double value) {
  const double v = std::clamp(value, 0.0, 1.0);
  // Blue -> cyan -> green -> yellow -> red: each channel a tent of half-width 3/8 in v.
  const double r = std::clamp(1.5 - std::abs(4 * v - 3), 0.0, 1.0);
  const double g = std::clamp(1.5 - std::abs(4 * v - 2), 0.0, 1.0);
  const double b = std::clamp(1.5 - std::abs(4 * v - 1), 0.0, 1.0);
  return Eigen::Vector3i(static_cast<int>(std::lround(255 * r)),
                         static_cast<int>(std::lround(255 * g)),
                         static_cast<int>(std::lround(255 * b)));
}

Eigen::Matrix<std::uint8_t, Eigen::Dynamic, 3> heat_colors(const Eigen::VectorXd& values) {
  Eigen::Matrix<std::uint8_t, Eigen::Dynamic, 3> colors(values.size(), 3);
  for (Eigen::Index i = 0; i < values.size(); ++i)
    colors.row(i) = heat_color(values(i)).cast<std::uint8_t>().transpose();
  return colors;
}

}  // namespace meshmark
