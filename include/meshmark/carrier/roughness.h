#pragma once
/// \file roughness.h
/// A local roughness field after Lavoue ("A roughness measure for 3D mesh visual masking",
/// APGV 2007): roughness is where the curvature of the surface differs from the curvature of
/// a smoothed copy of it, averaged over a local window. Every length is a fraction of the
/// bounding-box diagonal D and every average is area-weighted over geometric balls reached
/// through the mesh, so the field does not depend on the resolution or the connectivity.
///
/// Construction (constants in RoughnessOptions):
///  1. c(v) = |kmin| + |kmax|, normal-cycle curvature over balls of radius 0.01 D.
///  2. A smoothed copy: every vertex moved to the Gaussian-weighted (sigma 0.01 D, window
///     2 sigma), area-weighted mean of the positions around it; its curvature c_s(v).
///  3. Roughness r(v): the Gaussian-weighted (sigma 0.01 D, window 2 sigma) area-weighted mean
///     of |c - c_s| around v, times D (dimensionless).
///  4. Outliers discarded and rescaled: smoothness(v) = 1 - min(r, r95) / r95, r95 the 95th
///     percentile of r; 1 = smooth, 0 = rough.

#include <Eigen/Core>

namespace meshmark {

/// Constants of the construction, as fractions of the bounding-box diagonal.
struct RoughnessOptions {
  double curvature_radius = 0.01;  ///< ball radius of the normal-cycle curvature
  double smoothing_sigma = 0.01;   ///< Gaussian of the smoothed copy (window 2 sigma)
  double window_sigma = 0.01;      ///< Gaussian of the averaging window (window 2 sigma)
  double outlier_quantile = 0.95;  ///< roughness above this quantile counts as fully rough
};

/// Roughness and its rescaled smoothness per vertex (unreferenced vertices: roughness 0,
/// smoothness 1).
struct RoughnessField {
  Eigen::VectorXd roughness;   ///< r(v) >= 0, dimensionless
  Eigen::VectorXd smoothness;  ///< in [0, 1], 1 = smooth
  /// The threshold of the S direction: a vertex is smooth where smoothness is above
  /// min(0.8, the 8th decile of the field) (TIFS 2014, sec. V-C).
  double smooth_threshold = 0.8;
};

/// Computes the field. V: #V x 3, F: #F x 3.
RoughnessField roughness_field(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                               const RoughnessOptions& options = {});

}  // namespace meshmark
