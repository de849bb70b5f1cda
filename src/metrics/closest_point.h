#pragma once
/// \file closest_point.h
/// Closest points on a triangle mesh for many query points, on the project's own bounding volume
/// hierarchy (closest_point.cpp): what surface distances (MRMS, Hausdorff), MSDM2's matching of
/// vertices to the other surface, registration and trace need.

#include <Eigen/Core>
#include <memory>
#include <vector>

namespace meshmark {

/// For each query: the closest point, the triangle it lies on, its barycentric coordinates in
/// that triangle, and the distance.
struct ClosestPoints {
  Eigen::MatrixX3d point;        ///< #Q x 3
  std::vector<int> face;         ///< #Q, row of F
  Eigen::MatrixX3d barycentric;  ///< #Q x 3, weights of F(face, 0..2)
  Eigen::VectorXd distance;      ///< #Q
};

/// A tree of axis-aligned boxes over the triangles F of V (degenerate triangles skipped), built
/// once and queried many times (registration queries one surface at every step). About 100
/// bytes a triangle while built and after: the corners in double precision (72), the row of F,
/// and nodes of 32 bytes whose boxes are single precision, relative to the mesh's center and
/// rounded outward, so that no box is nearer to a query than a triangle inside it: every answer
/// is the one double-precision boxes would give, except between triangles whose distances tie
/// to within double rounding (either may be returned, as with any visiting order).
class SurfaceIndex {
 public:
  /// \throw InvalidArgumentError when F has no usable triangle. V and F must outlive it.
  SurfaceIndex(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F);
  ~SurfaceIndex();
  SurfaceIndex(const SurfaceIndex&) = delete;
  SurfaceIndex& operator=(const SurfaceIndex&) = delete;
  /// The closest points to every row of Q (queries on all cores).
  /// \throw InvalidArgumentError for a row that is not a finite point.
  ClosestPoints query(const Eigen::MatrixX3d& Q) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Closest points on the triangles F of V (degenerate triangles skipped) to every row of Q.
/// Builds the tree once per call. \throw InvalidArgumentError when F has no usable triangle.
ClosestPoints closest_points(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                             const Eigen::MatrixX3d& Q);

}  // namespace meshmark
