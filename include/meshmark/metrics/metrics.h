#pragma once
/// \file metrics.h
/// Distortion metrics as the mesh watermarking field computes them (docs/method.md section 7):
/// vertex RMS, surface-sampled RMS (MRMS, Wang et al. SMI 2010) and Hausdorff distance, MSDM
/// (Lavoue et al., SPIE 2006) and MSDM2 (Lavoue, SGP 2011), with per-vertex local maps.

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>

#include "meshmark/core/mesh.h"
#include "meshmark/core/progress.h"

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
  /// Called as the distances go (progress.h): phase "measuring surface distances", one unit
  /// per direction.
  ProgressCallback progress;
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
/// \throw InvalidArgumentError when either mesh has no face (there is no surface to sample).
SurfaceDistance surface_distance(const Eigen::MatrixX3d& VA, const Eigen::MatrixX3i& FA,
                                 const Eigen::MatrixX3d& VB, const Eigen::MatrixX3i& FB,
                                 const SurfaceDistanceOptions& options = {});

/// MSDM's constants, fractions of the bounding box's longest side D (of the first mesh).
struct MsdmOptions {
  double curvature_radius = 0.005;  ///< normal-cycle ball
  double window_radius = 0.015;     ///< local window
  double window_sigma = 0.008;      ///< its Gaussian
};

/// A global score in [0, 1) (0 for identical meshes) and the local score per vertex.
struct PerceptualDistance {
  double global = 0;
  Eigen::VectorXd local;  ///< per vertex of the first mesh
};

/// MSDM (Lavoue et al., SPIE 2006) as its reference implementation, MEPP's MSDM component,
/// computes it. Curvature c = (|kmax| + |kmin|) D / 2 from the normal cycle over balls of
/// curvature_radius D (curvature.h). Around each vertex, each mesh is walked on its own
/// geometry over the window's ball (the walk of curvature.h): every edge seen gives a sample
/// at its far end or where it leaves the sphere, its curvature interpolated along the edge.
/// Gaussian weights of the distance to the vertex give each mesh's mean and deviation; the
/// covariance pairs each sample with the nearest sample of the other window (by index when
/// both walks saw the same edges), weighted by the distance to the second mesh's vertex, and
/// averages both directions (MEPP's ProcessCovariance). Local value
/// ((L^3 + C^3 + 0.5 S^3) / 2.5)^(1/3), global (mean of local^3)^(1/3) over the referenced
/// vertices; unreferenced vertices score 0.
///
/// This class is the first mesh's side, computed once: D, the adjacency, A's curvature and
/// A's window statistics. compare(B) computes B's curvature and walks, and walks A's windows
/// again for the pairing (storing A's samples would take ~150 samples per vertex). B's
/// windows are not A's reused: B may see other edges near the sphere, and MEPP walks each mesh
/// on its own, so reusing A's would change the value. msdm(A, B, F, o) equals
/// MsdmReference(A, F, o).compare(B). Copies share the state; compare is const and may run
/// concurrently.
class MsdmReference {
 public:
  /// A: #V x 3 positions of the original, F: #F x 3 its triangles (kept, copied).
  /// `progress` (progress.h) is called with phase "measuring MSDM (the original's windows)",
  /// one unit per vertex.
  MsdmReference(const Eigen::MatrixX3d& A, const Eigen::MatrixX3i& F,
                const MsdmOptions& options = {}, const ProgressCallback& progress = {});
  /// MSDM from the original to B (#V x 3, same connectivity); `progress` is called with phase
  /// "measuring MSDM", one unit per vertex. \throw InvalidArgumentError when B's vertex count
  /// differs.
  PerceptualDistance compare(const Eigen::MatrixX3d& B,
                             const ProgressCallback& progress = {}) const;
  /// compare(B).global estimated from the local values of every `stride`-th vertex (0,
  /// stride, 2 stride, ...: the same vertices for every B, each valued as compare values it):
  /// the cube root of the mean of their cubes, over those F references. Costs B's curvature
  /// and about 1/stride of compare's windows. An estimate, to steer a search; the value a
  /// limit is held against is compare's. `progress`: phase "estimating MSDM", one unit per
  /// vertex valued. \throw InvalidArgumentError when B's vertex count differs or stride < 1.
  double estimate(const Eigen::MatrixX3d& B, int stride,
                  const ProgressCallback& progress = {}) const;
  /// D, the longest side of the original's bounding box (model units).
  double longest_side() const;
  /// The original's curvature per vertex as MSDM compares it, (|kmax| + |kmin|) D / 2.
  const Eigen::VectorXd& curvature() const;

 private:
  struct State;
  std::shared_ptr<const State> state_;
  // The local values of every stride-th vertex (the others 0), for compare and estimate.
  Eigen::VectorXd locals(const Eigen::MatrixX3d& B, int stride, const char* phase,
                         const ProgressCallback& progress) const;
};

/// The original's side of MSDM computed once and shared by everything measured against one
/// original: the strength searches of its copies (CalibrateOptions::msdm_reference, an
/// issuer's copies of one original, issue.h). Safe to use from several threads.
class SharedMsdmReference {
 public:
  /// The reference of A (#V x 3) and F (#F x 3) with MsdmOptions{}: computed by the first call
  /// (reporting to `progress` as MsdmReference's constructor does), the same one afterwards;
  /// a call while another computes it waits. \throw InvalidArgumentError when A's vertex count
  /// or its bounding box's longest side differ from the first call's mesh.
  MsdmReference get(const Eigen::MatrixX3d& A, const Eigen::MatrixX3i& F,
                    const ProgressCallback& progress = {});

 private:
  std::mutex lock_;
  std::optional<MsdmReference> reference_;
};

/// MSDM between two meshes with the same connectivity F (positions A and B): see
/// MsdmReference. \throw InvalidArgumentError when the vertex counts differ.
PerceptualDistance msdm(const Eigen::MatrixX3d& A, const Eigen::MatrixX3d& B,
                        const Eigen::MatrixX3i& F, const MsdmOptions& options = {},
                        const ProgressCallback& progress = {});

/// MSDM2's constants, fractions of D.
struct Msdm2Options {
  double scales[3] = {0.002, 0.003, 0.004};  ///< curvature radii h
  double window_factor = 5;                  ///< window radius = 5 h
  double sigma_factor = 2.5;                 ///< Gaussian sigma = 2.5 h
  /// Called as the windows are walked (progress.h): phase "measuring MSDM2", one unit per
  /// vertex of either mesh at each scale.
  ProgressCallback progress;
};

/// MSDM2 (Lavoue, SGP 2011) between meshes of any connectivity, as MEPP2's msdm2.h computes
/// it in each direction: each vertex of X is matched to the closest point of Y, whose
/// curvature (interpolated there) and position stand for it on Y's side. At each scale h,
/// curvature (|kmax| + |kmin|) D / 2 over balls of h D on both meshes; X's window of radius
/// 5 h D walked as in msdm (curvature.h's walk), sampling the center, each newly reached
/// vertex and each point where an edge leaves the sphere (X's curvature and the matched one
/// interpolated along the edge); Gaussian weights (sigma 2.5 h D) of the distance to the
/// vertex on X's side and to its match on Y's; local value (L + C + 0.5 S) / 2.5 averaged over
/// the three scales, pooled with exponent 3. Made symmetric by averaging both directions
/// (MEPP2 computes one). D is the larger of both meshes' longest sides, the same both ways.
/// The matched curvature uses the closest point's barycentric coordinates (MEPP2 weighs by
/// triangle areas to the unprojected vertex: the same for a vertex on the surface).
/// `local` is A -> B.
PerceptualDistance msdm2(const Eigen::MatrixX3d& VA, const Eigen::MatrixX3i& FA,
                         const Eigen::MatrixX3d& VB, const Eigen::MatrixX3i& FB,
                         const Msdm2Options& options = {});

/// Options of compare_meshes.
struct CompareOptions {
  SurfaceDistanceOptions sampling;  ///< MRMS and Hausdorff's samples (its progress is unused)
  /// Called as the comparison goes (progress.h), one phase after the other: MSDM's two (same
  /// connectivity only), the surface distances', MSDM2's. MSDM and MSDM2 walk a window of a
  /// fixed share of the bounding box around every vertex, so their time grows with the square
  /// of the vertex count on one shape (docs/formats.md, Sizes): minutes from a few 100k.
  ProgressCallback progress;
};

/// Every distortion `meshmark compare` reports, from A (the reference) to B.
struct MeshComparison {
  bool same_connectivity = false;  ///< same vertex count and triangles: vertex RMS and MSDM
  double rms_percent = 0;          ///< vertex RMS, % of A's diagonal (same connectivity)
  double msdm = 0;                 ///< MSDM (same connectivity)
  SurfaceDistance surface;         ///< MRMS and Hausdorff
  PerceptualDistance msdm2;        ///< MSDM2, `local` per vertex of A
};

/// Compares B with A: vertex RMS and MSDM when they share their connectivity, surface
/// distances and MSDM2 always. \throw InvalidInputError naming the mesh's source_path (or "the
/// reference mesh", "the distorted mesh") when it has no triangle of finite, non-zero area (no
/// surface to measure); InvalidArgumentError when either is otherwise invalid.
MeshComparison compare_meshes(const Mesh& A, const Mesh& B, const CompareOptions& options = {});

}  // namespace meshmark
