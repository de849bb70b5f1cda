// Closest points on a triangle soup: a bounding volume hierarchy of axis-aligned boxes built by
// median splits, queried depth first, nearer child first, pruning every box farther than the
// best triangle found so far. The project's own code, so that trace, registration and the
// surface metrics need no GPL library (CGAL's AABB tree served before; the tests compare the two
// when the CGAL component is built).

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>
#include <string>

#include <Eigen/Geometry>

#include "core/parallel.h"
#include "meshmark/core/error.h"
#include "metrics/closest_point.h"

namespace meshmark {

namespace {

using Vec = Eigen::Vector3d;

struct Box {
  Vec lo = Vec::Constant(std::numeric_limits<double>::infinity());
  Vec hi = Vec::Constant(-std::numeric_limits<double>::infinity());
  void grow(const Vec& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  void grow(const Box& b) {
    lo = lo.cwiseMin(b.lo);
    hi = hi.cwiseMax(b.hi);
  }
  /// Squared distance from p to the box (0 inside).
  double squared_distance(const Vec& p) const {
    double d = 0;
    for (int c = 0; c < 3; ++c) {
      const double e = std::max({lo[c] - p[c], 0.0, p[c] - hi[c]});
      d += e * e;
    }
    return d;
  }
};

// A node: its box, and either two children (left = this + 1, right = `right`) or a leaf's
// triangles [first, first + count) in leaf order.
struct Node {
  Box box;
  int right = -1;
  int first = 0, count = 0;
};

constexpr int kLeafSize = 4;

// The point of triangle abc closest to p and its barycentric weights of a, b, c (Ericson,
// Real-Time Collision Detection, 5.1.5: the Voronoi region of p, vertex, edge or face).
void closest_on_triangle(const Vec& p, const Vec& a, const Vec& b, const Vec& c, Vec& point,
                         Vec& weights) {
  const Vec ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) {
    point = a;
    weights = Vec(1, 0, 0);
    return;
  }
  const Vec bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) {
    point = b;
    weights = Vec(0, 1, 0);
    return;
  }
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const double v = d1 / (d1 - d3);
    point = a + v * ab;
    weights = Vec(1 - v, v, 0);
    return;
  }
  const Vec cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) {
    point = c;
    weights = Vec(0, 0, 1);
    return;
  }
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const double w = d2 / (d2 - d6);
    point = a + w * ac;
    weights = Vec(1 - w, 0, w);
    return;
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    point = b + w * (c - b);
    weights = Vec(0, 1 - w, w);
    return;
  }
  const double denom = 1 / (va + vb + vc);
  const double v = vb * denom, w = vc * denom;
  point = a + v * ab + w * ac;
  weights = Vec(1 - v - w, v, w);
}

}  // namespace

struct SurfaceIndex::Impl {
  std::vector<std::array<Vec, 3>> corners;  // leaf order
  std::vector<int> face_of;                 // leaf order: row of F
  std::vector<Node> nodes;                  // nodes[0]: the root
};

namespace {

// Builds the subtree over items [first, first + count) of `order` (indices into centroids and
// boxes) at nodes.back(); returns its index.
int build(std::vector<Node>& nodes, std::vector<int>& order, const std::vector<Vec>& centroid,
          const std::vector<Box>& box, int first, int count) {
  const int index = static_cast<int>(nodes.size());
  nodes.emplace_back();
  Box bounds, centers;
  for (int k = first; k < first + count; ++k) {
    bounds.grow(box[static_cast<std::size_t>(order[k])]);
    centers.grow(centroid[static_cast<std::size_t>(order[k])]);
  }
  nodes[index].box = bounds;
  if (count <= kLeafSize) {
    nodes[index].first = first;
    nodes[index].count = count;
    return index;
  }
  int axis = 0;
  (centers.hi - centers.lo).maxCoeff(&axis);
  const int half = count / 2;
  std::nth_element(order.begin() + first, order.begin() + first + half,
                   order.begin() + first + count, [&](int a, int b) {
                     return centroid[static_cast<std::size_t>(a)][axis] <
                            centroid[static_cast<std::size_t>(b)][axis];
                   });
  build(nodes, order, centroid, box, first, half);
  const int right = build(nodes, order, centroid, box, first + half, count - half);
  nodes[index].right = right;
  return index;
}

}  // namespace

SurfaceIndex::SurfaceIndex(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F) : impl_(new Impl) {
  std::vector<int> kept;
  std::vector<Vec> centroid;
  std::vector<Box> box;
  kept.reserve(static_cast<std::size_t>(F.rows()));
  centroid.reserve(kept.capacity());
  box.reserve(kept.capacity());
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Vec a = V.row(F(f, 0)).transpose(), b = V.row(F(f, 1)).transpose(),
              c = V.row(F(f, 2)).transpose();
    // Degenerate: collinear corners (a zero cross product), as CGAL's is_degenerate skipped.
    if ((b - a).cross(c - a).isZero(0)) continue;
    if (!a.allFinite() || !b.allFinite() || !c.allFinite()) continue;
    kept.push_back(static_cast<int>(f));
    centroid.push_back((a + b + c) / 3);
    Box bb;
    bb.grow(a);
    bb.grow(b);
    bb.grow(c);
    box.push_back(bb);
  }
  if (kept.empty())
    throw InvalidArgumentError("closest points: the mesh has no non-degenerate triangle");
  std::vector<int> order(kept.size());
  std::iota(order.begin(), order.end(), 0);
  impl_->nodes.reserve(2 * kept.size() / kLeafSize + 2);
  build(impl_->nodes, order, centroid, box, 0, static_cast<int>(order.size()));
  impl_->corners.reserve(order.size());
  impl_->face_of.reserve(order.size());
  for (int k : order) {
    const int f = kept[static_cast<std::size_t>(k)];
    impl_->face_of.push_back(f);
    impl_->corners.push_back(
        {V.row(F(f, 0)).transpose(), V.row(F(f, 1)).transpose(), V.row(F(f, 2)).transpose()});
  }
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
    std::vector<std::pair<double, int>> stack;
    stack.reserve(128);
    Vec point, weights;
    for (Eigen::Index i = begin; i < end; ++i) {
      const Vec q = Q.row(i).transpose();
      double best = std::numeric_limits<double>::infinity();
      int best_leaf = -1;
      Vec best_point = Vec::Zero(), best_weights(1, 0, 0);
      stack.clear();
      stack.emplace_back(m.nodes[0].box.squared_distance(q), 0);
      while (!stack.empty()) {
        const auto [bound, n] = stack.back();
        stack.pop_back();
        if (bound >= best) continue;
        const Node& node = m.nodes[static_cast<std::size_t>(n)];
        if (node.right < 0) {
          for (int k = node.first; k < node.first + node.count; ++k) {
            const auto& t = m.corners[static_cast<std::size_t>(k)];
            closest_on_triangle(q, t[0], t[1], t[2], point, weights);
            const double d = (point - q).squaredNorm();
            if (d < best) {
              best = d;
              best_leaf = k;
              best_point = point;
              best_weights = weights;
            }
          }
          continue;
        }
        const int left = n + 1, right = node.right;
        const double dl = m.nodes[static_cast<std::size_t>(left)].box.squared_distance(q),
                     dr = m.nodes[static_cast<std::size_t>(right)].box.squared_distance(q);
        // The nearer child on top of the stack: searched first, it makes the best small early.
        if (dl <= dr) {
          if (dr < best) stack.emplace_back(dr, right);
          if (dl < best) stack.emplace_back(dl, left);
        } else {
          if (dl < best) stack.emplace_back(dl, left);
          if (dr < best) stack.emplace_back(dr, right);
        }
      }
      if (best_leaf < 0)
        throw InvalidArgumentError("closest points: query point " + std::to_string(i) +
                                   " is not a finite point");
      out.point.row(i) = best_point.transpose();
      out.face[static_cast<std::size_t>(i)] = m.face_of[static_cast<std::size_t>(best_leaf)];
      out.barycentric.row(i) = best_weights.transpose();
      out.distance(i) = std::sqrt(best);
    }
  });
  return out;
}

ClosestPoints closest_points(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                             const Eigen::MatrixX3d& Q) {
  return SurfaceIndex(V, F).query(Q);
}

}  // namespace meshmark
