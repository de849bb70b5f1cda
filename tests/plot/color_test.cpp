// heat_color follows MATLAB's "jet" scale, whose anchors are published: dark blue (0, 0, 1/2)
// at 0, blue at 1/8, cyan at 3/8, yellow at 5/8, red at 7/8, dark red (1/2, 0, 0) at 1.

#include <gtest/gtest.h>

#include "meshmark/plot/color.h"

namespace meshmark {
namespace {

TEST(HeatColor, HitsJetsAnchorsAndClampsOutside) {
  struct Anchor {
    double value;
    Eigen::Vector3d rgb;  // in [0, 1]
  };
  const Anchor anchors[] = {{0, {0, 0, 0.5}},    {0.125, {0, 0, 1}}, {0.375, {0, 1, 1}},
                            {0.625, {1, 1, 0}},  {0.875, {1, 0, 0}}, {1, {0.5, 0, 0}},
                            {0.5, {0.5, 1, 0.5}}};
  constexpr int kTol = 1;  // one 8-bit step of rounding
  for (const Anchor& a : anchors) {
    const Eigen::Vector3i c = heat_color(a.value);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(c(k), 255 * a.rgb(k), kTol) << a.value << " " << k;
  }
  EXPECT_EQ(heat_color(-3), heat_color(0));
  EXPECT_EQ(heat_color(7), heat_color(1));
  const Eigen::VectorXd values = Eigen::Vector3d(0, 0.375, 1);
  const auto colors = heat_colors(values);
  ASSERT_EQ(colors.rows(), 3);
  for (int i = 0; i < 3; ++i)
    EXPECT_EQ(colors.row(i).cast<int>(), heat_color(values(i)).transpose()) << i;
}

}  // namespace
}  // namespace meshmark
