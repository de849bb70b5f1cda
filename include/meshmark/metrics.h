#pragma once
/// \file metrics.h
/// Distortion metrics as the mesh watermarking field computes them (WATERMARK.md section 7):
/// vertex RMS, surface-sampled RMS (MRMS, Wang et al. SMI 2010) and Hausdorff distance, MSDM
/// (Lavoue et al., SPIE 2006) and MSDM2 (Lavoue, SGP 2011), with per-vertex local maps.

#include <Eigen/Core>
#include <cstdint>

namespace meshmark {

/// Vertex-wise RMS of B - A over the vertices F references, as a percentage of A's
/// bounding-box diagonal. A and B share the connectivity F. \throw InvalidArgumentError when
/// the sizes differ.
double vertex_rms_percent(const Eigen::MatrixX3d& A, const Eigen::MatrixX3d& B,
                          const Eigen::MatrixX3i& F);

/// Points on a surface: its referenced vertices, then `count` points drawn uniformly by area
/// (seeded, deterministic).
Eigen::MatrixX3d sample_surface(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F, int count,
                                std::uint64_t seed);

/// Options of surface_distance.
struct SurfaceDistanceOptions {
  int samples =
      0;  ///< area samples per surface besides the vertices; 0: 2 per vertex, at least 50k
  std::uint64_t seed = 1;  ///< sampling seed
};

/// One-sided and symmetric surface distances between two meshes of any connectivity, from the
/// samples of each surface to the other surface (exact point-to-triangle distances).
struct SurfaceDistance {
  double rms_ab = 0, rms_ba = 0;  ///< one-sided RMS distances (model units)
  double max_ab = 0, max_ba = 0;  ///< one-sided maxima (model units)
  double mrms = 0;                ///< max(rms_ab, rms_ba)
  double hausdorff = 0;           ///< max(max_ab, max_ba)
  double diagonal = 0;            ///< A's bounding-box diagonal, for percentages
  double mrms_percent() const { return diagonal > 0 ? 100 * mrms / diagonal : 0; }
  double hausdorff_percent() const { return diagonal > 0 ? 100 * hausdorff / diagonal : 0; }
};

/// Computes MRMS and Hausdorff between (VA, FA) and (VB, FB).
SurfaceDistance surface_distance(const Eigen::MatrixX3d& VA, const Eigen::MatrixX3i& FA,
                                 const Eigen::MatrixX3d& VB, const Eigen::MatrixX3i& FB,
                                 const SurfaceDistanceOptions& options = {});

/// MSDM's constants, fractions of the bounding box's longest side D.
struct MsdmOptions {
  double curvature_radius = 0.005;  ///< normal-cycle disc
  double window_radius = 0.015;     ///< local window
  double window_sigma = 0.008;      ///< its Gaussian
};

/// A global score in [0, 1) (0 for identical meshes) and the local score per vertex.
struct PerceptualDistance {
  double global = 0;
  Eigen::VectorXd local;  ///< per vertex of the first mesh
};

/// MSDM between two meshes with the same connectivity F (positions A and B).
PerceptualDistance msdm(const Eigen::MatrixX3d& A, const Eigen::MatrixX3d& B,
                        const Eigen::MatrixX3i& F, const MsdmOptions& options = {});

/// MSDM2's constants, fractions of D.
struct Msdm2Options {
  double scales[3] = {0.002, 0.003, 0.004};  ///< curvature radii h
  double window_factor = 5;                  ///< window radius = 5 h
  double sigma_factor = 2.5;                 ///< Gaussian sigma = 2.5 h
};

/// MSDM2 between meshes of any connectivity: each vertex is matched to the closest point of
/// the other surface, whose curvature is interpolated there; three scales averaged; pooled
/// with exponent 3; made symmetric by averaging both directions. `local` is A -> B.
PerceptualDistance msdm2(const Eigen::MatrixX3d& VA, const Eigen::MatrixX3i& FA,
                         const Eigen::MatrixX3d& VB, const Eigen::MatrixX3i& FB,
                         const Msdm2Options& options = {});

}  // namespace meshmark
