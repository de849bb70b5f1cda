#pragma once
/// \file color.h
/// Colors for maps of per-vertex values (the CLI's roughness and distortion heat maps).

#include <Eigen/Core>
#include <cstdint>

namespace meshmark {

/// Maps a value in [0, 1] to an RGB color on the "jet" scale (dark blue 0, cyan, green,
/// yellow, dark red 1), components in [0, 255]; values outside [0, 1] are clamped.
Eigen::Vector3i heat_color(double value);

/// heat_color of every value (n), as an n x 3 matrix of 8-bit RGB (WriteOptions::vertex_colors).
Eigen::Matrix<std::uint8_t, Eigen::Dynamic, 3> heat_colors(const Eigen::VectorXd& values);

}  // namespace meshmark
