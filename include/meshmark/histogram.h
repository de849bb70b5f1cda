#pragma once
/// \file histogram.h
/// The watermark's carrier: the histogram of vertex distances to a center of mass
/// (../shared/spec/WATERMARK.md section 1; Rolland-Neviere et al., IEEE TIFS 2014, sec. III).

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

namespace meshmark {

/// The center of mass, first letter of a variant: D (discrete), S (surface), V (volume).
enum class CenterKind { Discrete, Surface, Volume };

/// The center and whether it is well defined.
struct Center {
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  /// False for a volume center of an open or inconsistently oriented mesh (|sum w_f| tiny
  /// against sum |w_f|), or a surface center of a mesh with no area.
  bool well_defined = true;
  /// Volume center: |sum w_f| / sum |w_f| (1 for a closed, consistently oriented mesh);
  /// surface center: total area; discrete: number of referenced vertices.
  double quality = 0;
};

/// Computes the center of mass of the referenced vertices (D), of the triangles weighted by
/// area (S), or of the tetrahedra (O, p0, p1, p2) weighted by signed volume with O the
/// discrete center (V). V: #V x 3, F: #F x 3, referenced: size #V (referenced_vertices()).
Center center_of_mass(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                      const std::vector<std::uint8_t>& referenced, CenterKind kind);

/// The histogram of distances to a center, nB = nb + 2 bins over [rho_min, rho_max].
struct Histogram {
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  double rho_min = 0, rho_max = 0;
  double step = 0;               ///< s = (rho_max - rho_min) / nB
  int bins = 0;                  ///< nB
  Eigen::VectorXd rho;           ///< per vertex distance (NaN for unreferenced vertices)
  std::vector<int> bin;          ///< per vertex bin B_i in [0, nB), -1 for unreferenced
  Eigen::VectorXd t;             ///< per vertex position inside its bin, (rho - rho_min)/s - B_i
  int argmin = -1, argmax = -1;  ///< a vertex attaining rho_min, rho_max
  /// False when there is nothing to histogram (no referenced vertex, or all at one distance).
  bool valid() const { return step > 0; }
};

/// Builds the histogram of the referenced vertices around center for nbits bits.
/// Bin of vertex i: floor((rho_i - rho_min) / s), clamped to nB - 1.
Histogram build_histogram(const Eigen::MatrixX3d& V, const std::vector<std::uint8_t>& referenced,
                          const Eigen::Vector3d& center, int nbits);

/// Parses "D", "S", "V" (any case). \throw InvalidArgumentError otherwise.
CenterKind center_from_letter(char letter);

}  // namespace meshmark
