#pragma once
/// \file center.h
/// The three centers of mass of the framework (docs/method.md sections 1 and 3;
/// TIFS 2014 section IV-A) and their Jacobians dC/dp_i, which linearize the constraint that
/// the center must not move.

#include <Eigen/Core>
#include <cstdint>
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
  /// The total weight the center averages with: discrete, the number of counted vertices;
  /// surface, the total area (model units^2); volume, the total signed volume of the
  /// tetrahedra (O, p0, p1, p2) (model units^3, negative for inward-facing triangles).
  double mass = 0;
  /// Volume center only: |sum w_f| / sum |w_f| in [0, 1] over the tetrahedra's signed volumes
  /// w_f, 1 for a closed, consistently oriented mesh, near 0 for an open or inconsistently
  /// oriented one (well_defined is false below kVolumeCenterMinConsistency). 1 for D and S.
  double volume_consistency = 1;
};

/// Below this volume_consistency the volume center is reported as ill-defined.
inline constexpr double kVolumeCenterMinConsistency = 1e-3;

/// Computes the center of mass of the referenced vertices (D), of the triangles weighted by
/// area (S), or of the tetrahedra (O, p0, p1, p2) weighted by signed volume with O the
/// discrete center (V). V: #V x 3, F: #F x 3, referenced: size #V (referenced_vertices(), or
/// carrier_vertices(): only vertices marked kCounted count in the discrete center, so a twin
/// at the position of a counted vertex adds nothing; faces count whatever their corners).
Center center_of_mass(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                      const std::vector<std::uint8_t>& referenced, CenterKind kind);

/// The center and the 3 x 3 Jacobian J_i = dC/dp_i of every vertex (its faces' share only, for
/// twins; zero for unreferenced vertices), stored as J[i]. Moving a position moves every vertex
/// at it: its Jacobian is the sum over them.
struct CenterJacobians {
  Center center;
  std::vector<Eigen::Matrix3d> J;
};

/// Analytic Jacobians (docs/method.md section 3, item 2): D: I / n; S: (1/A) sum_f [(c_f - C)
/// grad_i A_f^T + A_f / 3 I]; V: (1/W) sum_f [(c_f - C) grad_i w_f^T + w_f / 4 I], plus, for
/// V, the dependence through the reference point O (the discrete center), which vanishes on
/// closed meshes and makes the Jacobian exact on open ones.
CenterJacobians center_jacobians(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                                 const std::vector<std::uint8_t>& referenced, CenterKind kind);

/// The center and the products J_i u_i, row i of E.
struct CenterProducts {
  Center center;
  Eigen::MatrixX3d E;  ///< #V x 3
};

/// The products J_i u_i for one direction per vertex (U: #V x 3) without forming the
/// matrices, what the linearized center constraint needs, and the center itself, both from one
/// pass over the faces (the sums it gathers per vertex do not depend on the center).
CenterProducts center_jacobian_products(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                                        const std::vector<std::uint8_t>& referenced,
                                        CenterKind kind, const Eigen::MatrixX3d& U);

/// Parses "D", "S", "V" (any case). \throw InvalidArgumentError otherwise.
CenterKind center_from_letter(char letter);

/// 'D', 'S' or 'V'.
char center_letter(CenterKind kind);

}  // namespace meshmark
