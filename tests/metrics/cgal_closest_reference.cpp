// The reference the closest-point tests compare the library's own tree with: CGAL's AABB tree
// (what the library used before its core dropped CGAL), compiled in a translation unit of its
// own with CGAL's flags.

#include "cgal_closest_reference.h"

#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Simple_cartesian.h>

namespace meshmark::test {

std::vector<ReferenceClosest> cgal_closest_points(const Eigen::MatrixX3d& V,
                                                  const Eigen::MatrixX3i& F,
                                                  const Eigen::MatrixX3d& Q) {
  using K = CGAL::Simple_cartesian<double>;
  using Triangles = std::vector<K::Triangle_3>;
  using Primitive = CGAL::AABB_triangle_primitive<K, Triangles::const_iterator>;
  using Tree = CGAL::AABB_tree<CGAL::AABB_traits<K, Primitive>>;
  Triangles triangles;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    auto corner = [&](int k) { return K::Point_3(V(F(f, k), 0), V(F(f, k), 1), V(F(f, k), 2)); };
    K::Triangle_3 t(corner(0), corner(1), corner(2));
    if (!t.is_degenerate()) triangles.push_back(t);
  }
  Tree tree(triangles.cbegin(), triangles.cend());
  tree.accelerate_distance_queries();
  std::vector<ReferenceClosest> out;
  out.reserve(static_cast<std::size_t>(Q.rows()));
  for (Eigen::Index i = 0; i < Q.rows(); ++i) {
    const K::Point_3 p = tree.closest_point(K::Point_3(Q(i, 0), Q(i, 1), Q(i, 2)));
    const Eigen::Vector3d pe(p.x(), p.y(), p.z());
    out.push_back({pe, (pe - Q.row(i).transpose()).norm()});
  }
  return out;
}

}  // namespace meshmark::test
