#pragma once
// CGAL's closest points (cgal_closest_reference.cpp), the reference for the library's own tree.

#include <Eigen/Core>
#include <vector>

namespace meshmark::test {

struct ReferenceClosest {
  Eigen::Vector3d point;
  double distance;
};

/// The closest point on the non-degenerate triangles of (V, F) to each row of Q, by CGAL's
/// AABB tree.
std::vector<ReferenceClosest> cgal_closest_points(const Eigen::MatrixX3d& V,
                                                  const Eigen::MatrixX3i& F,
                                                  const Eigen::MatrixX3d& Q);

}  // namespace meshmark::test
