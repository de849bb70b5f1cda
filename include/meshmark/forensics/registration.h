#pragma once
/// \file registration.h
/// Registration of a leaked mesh onto its original: the similarity transform (rotation,
/// uniform scale, translation) that brings the leak back into the original's frame, found by
/// trimmed iterative closest points (point to surface, on CGAL's AABB tree) from several
/// starts: the identity (tools that decimate, remesh, smooth or crop keep the frame) and the
/// four proper alignments of the principal axes. When the best of those fits loosely (trimmed
/// RMS above 1e-3 of the diagonal) and fails or leaves the leak with another area than the
/// original's, or shrinks it below a quarter of that area (a part of it, or a pose at a wrong
/// scale), more starts are tried: leak faces matched by shape to original faces (a face and the
/// three across its edges, whose corners give a similarity: cropping keeps the faces it
/// leaves), and the other 20 matchings of the axes at the spreads' scale and at the ratio of
/// the median edge lengths, ranked by rigid steps and the best 8 refined: a cropped leak after
/// a similarity. A registration that leaves the leak's edges over 16 times off the original's
/// is refused (the leak shrunk onto a patch). The leak may be decimated, remeshed, noisy or
/// cropped: only the closest `trim` fraction of its samples drives each step. A leak with the
/// original's faces is fitted vertex to vertex instead (Umeyama), to the original's vertices and
/// to them after 1 to 40 Laplacian or Taubin steps (smoothing commutes with a similarity), the
/// closest fit kept.

#include <Eigen/Core>
#include <cstdint>
#include <string>

namespace meshmark {

/// x -> scale * R x + t.
struct Similarity {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  ///< R, a rotation (det +1)
  double scale = 1;                                        ///< s > 0
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();   ///< t (model units)
  /// Every row of V transformed.
  Eigen::MatrixX3d apply(const Eigen::MatrixX3d& V) const;
  /// The inverse transform.
  Similarity inverse() const;
};

/// Options of register_similarity.
struct RegistrationOptions {
  int samples = 2000;          ///< leak vertices used (a seeded random subset when more)
  int iterations = 150;        ///< ICP steps per start and phase (rigid, then scaled) at most
  double trim = 0.8;           ///< fraction of the closest samples each step fits
  double max_residual = 0.01;  ///< success: trimmed RMS below this fraction of the diagonal
  /// A leak whose trimmed RMS distance to the original, as it is, is below this fraction of the
  /// diagonal is near the original's frame: refined from the identity only, and moved only if
  /// that halves the distance.
  double in_frame = 5e-3;
  std::uint64_t seed = 1;  ///< sample selection
};

/// Whether registration succeeded.
enum class RegistrationStatus {
  Registered,  ///< residual within max_residual
  Failed,      ///< no start converged to a residual within max_residual
};

/// What register_similarity found.
struct RegistrationResult {
  RegistrationStatus status = RegistrationStatus::Failed;
  Similarity transform;  ///< leak -> original frame
  double residual = 0;   ///< trimmed RMS distance, fraction of the original's diagonal
  double overlap = 0;    ///< fraction of the samples within 3 residuals (at least 1e-3 D)
  int iterations = 0;    ///< ICP steps of the best start
  std::string message;   ///< one line for a person
};

/// Registers the leak (VL, FL) onto the original (VO, FO). \throw InvalidArgumentError when
/// either mesh has no usable triangle.
RegistrationResult register_similarity(const Eigen::MatrixX3d& VL, const Eigen::MatrixX3i& FL,
                                       const Eigen::MatrixX3d& VO, const Eigen::MatrixX3i& FO,
                                       const RegistrationOptions& options = {});

}  // namespace meshmark
