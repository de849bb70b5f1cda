// Closest points on a triangle soup with CGAL's AABB tree.

#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Simple_cartesian.h>

#include "core/parallel.h"
#include "meshmark/core/error.h"
#include "metrics/closest_point.h"

namespace meshmark {

namespace {
using K = CGAL::Simple_cartesian<double>;
using Triangles = std::vector<K::Triangle_3>;
using Primitive = CGAL::AABB_triangle_primitive<K, Triangles::const_iterator>;
using Tree = CGAL::AABB_tree<CGAL::AABB_traits<K, Primitive>>;

// Barycentric coordinates of p (on or near the triangle) in a, b, c.
Eigen::Vector3d barycentric(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                            const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const Eigen::Vector3d v0 = b - a, v1 = c - a, v2 = p - a;
  const double d00 = v0.dot(v0), d01 = v0.dot(v1), d11 = v1.dot(v1), d20 = v2.dot(v0),
               d21 = v2.dot(v1);
  const double den = d00 * d11 - d01 * d01;
  if (den <= 0) return Eigen::Vector3d(1, 0, 0);
  const double v = (d11 * d20 - d01 * d21) / den, w = (d00 * d21 - d01 * d20) / den;
  return Eigen::Vector3d(1 - v - w, v, w);
}
}  // namespace

struct SurfaceIndex::Impl {
  const Eigen::MatrixX3d& V;
  const Eigen::MatrixX3i& F;
  Triangles triangles;
  std::vector<int> face_of;
  std::unique_ptr<Tree> tree;
};

SurfaceIndex::SurfaceIndex(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F)
    : impl_(new Impl{V, F, {}, {}, nullptr}) {
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const K::Point_3 a(V(F(f, 0), 0), V(F(f, 0), 1), V(F(f, 0), 2)),
        b(V(F(f, 1), 0), V(F(f, 1), 1), V(F(f, 1), 2)),
        c(V(F(f, 2), 0), V(F(f, 2), 1), V(F(f, 2), 2));
    K::Triangle_3 t(a, b, c);
    if (t.is_degenerate()) continue;
    impl_->triangles.push_back(t);
    impl_->face_of.push_back(static_cast<int>(f));
  }
  if (impl_->triangles.empty())
    throw InvalidArgumentError("closest points: the mesh has no non-degenerate triangle");
  impl_->tree = std::make_unique<Tree>(impl_->triangles.cbegin(), impl_->triangles.cend());
  impl_->tree->accelerate_distance_queries();
}

SurfaceIndex::~SurfaceIndex() = default;

ClosestPoints SurfaceIndex::query(const Eigen::MatrixX3d& Q) const {
  const Impl& m = *impl_;
  ClosestPoints out;
  out.point.resize(Q.rows(), 3);
  out.face.resize(static_cast<std::size_t>(Q.rows()));
  out.barycentric.resize(Q.rows(), 3);
  out.distance.resize(Q.rows());
  // The tree is read-only here: queries run on all cores, each row on its own.
  detail::parallel_chunks(Q.rows(), [&](int, std::int64_t begin, std::int64_t end) {
    for (Eigen::Index i = begin; i < end; ++i) {
      const K::Point_3 q(Q(i, 0), Q(i, 1), Q(i, 2));
      const auto [p, it] = m.tree->closest_point_and_primitive(q);
      const int f = m.face_of[static_cast<std::size_t>(it - m.triangles.cbegin())];
      const Eigen::Vector3d pe(p.x(), p.y(), p.z());
      out.point.row(i) = pe.transpose();
      out.face[i] = f;
      out.barycentric.row(i) =
          barycentric(pe, m.V.row(m.F(f, 0)).transpose(), m.V.row(m.F(f, 1)).transpose(),
                      m.V.row(m.F(f, 2)).transpose())
              .transpose();
      out.distance(i) = (pe - Q.row(i).transpose()).norm();
    }
  });
  return out;
}

ClosestPoints closest_points(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                             const Eigen::MatrixX3d& Q) {
  return SurfaceIndex(V, F).query(Q);
}

}  // namespace meshmark
