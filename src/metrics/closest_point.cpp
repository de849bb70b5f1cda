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

// A node: its box in single precision, in the tree's frame (below), rounded outward (so that
// its distance to a query is never more than the distance to any triangle inside: pruning
// stays exact), and either two children (left = this + 1, right = `next`; count 0) or a leaf's
// `count` triangles from `next` on, in leaf order. 32 bytes.
struct Node {
  std::array<float, 3> lo{}, hi{};
  int next = 0;
  int count = 0;
  /// Squared distance from p (in the tree's frame) to the box (0 inside).
  double squared_distance(const Vec& p) const {
    double d = 0;
    for (int c = 0; c < 3; ++c) {
      const double e = std::max({static_cast<double>(lo[static_cast<std::size_t>(c)]) - p[c], 0.0,
                                 p[c] - static_cast<double>(hi[static_cast<std::size_t>(c)])});
      d += e * e;
    }
    return d;
  }
};

// The boxes' frame: x' = (x - origin) * scale, origin the center of all the triangles' box and
// scale the power of two that brings its largest side into (1/2, 1]. Single precision then
// resolves a box to about 1e-7 of the mesh's size wherever the mesh lies (a scan placed a
// million units from 0 keeps its detail), and any size from 1e-300 to 1e300 fits in a float.
// Scaling by a power of two is exact; the subtraction rounds to 2^-53 of its result, which
// the boxes' extra step outward covers.
struct Frame {
  Vec origin = Vec::Zero();
  double scale = 1, unscale2 = 1;  // unscale2 = 1 / scale^2: squared distances back
  Vec to(const Vec& x) const { return (x - origin) * scale; }
};

// A float below x by at least one float step (x itself may be off by 2^-53 of it), and one
// above; infinite beyond float's range.
float float_below(double x) {
  constexpr double kMax = std::numeric_limits<float>::max();
  constexpr float kInf = std::numeric_limits<float>::infinity();
  if (x > kMax) return std::numeric_limits<float>::max();
  if (x < -kMax) return -kInf;
  auto f = static_cast<float>(x);
  if (static_cast<double>(f) > x) f = std::nextafter(f, -kInf);
  return std::nextafter(f, -kInf);
}
float float_above(double x) {
  return -float_below(-x);
}

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
  Frame frame;                              // the nodes' boxes are in it
};

namespace {

// Nodes of the tree over `count` triangles (what build makes), to reserve exactly.
std::size_t node_count(int count) {
  return count <= kLeafSize ? 1 : 1 + node_count(count / 2) + node_count(count - count / 2);
}

// Builds the subtree over items [first, first + count) of `order` (indices into corners) at
// nodes.back(); returns its index. Boxes and centroids come from the corners as it goes: no
// array of either per triangle.
int build(std::vector<Node>& nodes, std::vector<int>& order,
          const std::vector<std::array<Vec, 3>>& corners, const Frame& frame, int first,
          int count) {
  const int index = static_cast<int>(nodes.size());
  nodes.emplace_back();
  constexpr double kInf = std::numeric_limits<double>::infinity();
  Vec lo = Vec::Constant(kInf), hi = Vec::Constant(-kInf);
  Vec center_lo = lo, center_hi = hi;
  for (int k = first; k < first + count; ++k) {
    const auto& t = corners[static_cast<std::size_t>(order[static_cast<std::size_t>(k)])];
    lo = lo.cwiseMin(t[0]).cwiseMin(t[1]).cwiseMin(t[2]);
    hi = hi.cwiseMax(t[0]).cwiseMax(t[1]).cwiseMax(t[2]);
    const Vec center = t[0] + t[1] + t[2];  // 3 times the centroid: the same order
    center_lo = center_lo.cwiseMin(center);
    center_hi = center_hi.cwiseMax(center);
  }
  const Vec lo_in_frame = frame.to(lo), hi_in_frame = frame.to(hi);
  for (int c = 0; c < 3; ++c) {
    nodes[static_cast<std::size_t>(index)].lo[static_cast<std::size_t>(c)] =
        float_below(lo_in_frame[c]);
    nodes[static_cast<std::size_t>(index)].hi[static_cast<std::size_t>(c)] =
        float_above(hi_in_frame[c]);
  }
  if (count <= kLeafSize) {
    nodes[static_cast<std::size_t>(index)].next = first;
    nodes[static_cast<std::size_t>(index)].count = count;
    return index;
  }
  int axis = 0;
  (center_hi - center_lo).maxCoeff(&axis);
  const int half = count / 2;
  const auto center = [&](int item) {
    const auto& t = corners[static_cast<std::size_t>(item)];
    return t[0][axis] + t[1][axis] + t[2][axis];
  };
  std::nth_element(order.begin() + first, order.begin() + first + half,
                   order.begin() + first + count,
                   [&](int a, int b) { return center(a) < center(b); });
  build(nodes, order, corners, frame, first, half);
  const int right = build(nodes, order, corners, frame, first + half, count - half);
  nodes[static_cast<std::size_t>(index)].next = right;
  return index;
}

// Puts corners[k] = old corners[order[k]] and the same for rows, for every k, in place,
// following each cycle of the permutation (order is used up: set to -1).
void permute_in_place(std::vector<std::array<Vec, 3>>& corners, std::vector<int>& rows,
                      std::vector<int>& order) {
  for (std::size_t start = 0; start < order.size(); ++start) {
    if (order[start] < 0) continue;
    const std::array<Vec, 3> held_corners = corners[start];
    const int held_row = rows[start];
    std::size_t k = start;
    for (;;) {
      const auto from = static_cast<std::size_t>(order[k]);
      order[k] = -1;
      if (from == start) {
        corners[k] = held_corners;
        rows[k] = held_row;
        break;
      }
      corners[k] = corners[from];
      rows[k] = rows[from];
      k = from;
    }
  }
}

}  // namespace

SurfaceIndex::SurfaceIndex(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F) : impl_(new Impl) {
  // The usable triangles' corners and rows of F, in F's order; the tree is built over them and
  // they are then put in leaf order. About 110 bytes a triangle at the peak (corners 72, rows 4,
  // order 4, nodes 32 for every 1.5 triangles or so).
  std::vector<std::array<Vec, 3>>& corners = impl_->corners;
  std::vector<int>& face_of = impl_->face_of;
  std::size_t usable = 0;
  const auto corners_of = [&](Eigen::Index f) {
    return std::array<Vec, 3>{V.row(F(f, 0)).transpose(), V.row(F(f, 1)).transpose(),
                              V.row(F(f, 2)).transpose()};
  };
  // Degenerate: collinear corners (a zero cross product), as CGAL's is_degenerate skipped.
  const auto is_usable = [](const std::array<Vec, 3>& t) {
    return !(t[1] - t[0]).cross(t[2] - t[0]).isZero(0) && t[0].allFinite() && t[1].allFinite() &&
           t[2].allFinite();
  };
  for (Eigen::Index f = 0; f < F.rows(); ++f) usable += is_usable(corners_of(f)) ? 1 : 0;
  if (usable == 0)
    throw InvalidArgumentError("closest points: the mesh has no non-degenerate triangle");
  if (usable > static_cast<std::size_t>(std::numeric_limits<int>::max()))
    throw InvalidArgumentError("closest points: more than 2^31 - 1 triangles");
  corners.reserve(usable);
  face_of.reserve(usable);
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    auto t = corners_of(f);
    if (!is_usable(t)) continue;
    corners.push_back(t);
    face_of.push_back(static_cast<int>(f));
  }
  std::vector<int> order(usable);
  std::iota(order.begin(), order.end(), 0);
  constexpr double kInf = std::numeric_limits<double>::infinity();
  Vec lo = Vec::Constant(kInf), hi = Vec::Constant(-kInf);
  for (const auto& t : corners)
    for (const Vec& p : t) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  Frame& frame = impl_->frame;
  if (const double side = (hi - lo).maxCoeff(); std::isfinite(side) && side > 0) {
    frame.origin = lo + (hi - lo) / 2;  // (lo + hi) / 2 could overflow
    int exponent = 0;
    std::frexp(side, &exponent);  // side in [2^(e-1), 2^e); e kept where 2^-e and 2^2e are
    exponent = std::clamp(exponent, -500, 500);  // finite (sizes beyond: correct, slower)
    frame.scale = std::ldexp(1.0, -exponent);
    frame.unscale2 = std::ldexp(1.0, 2 * exponent);
  }
  impl_->nodes.reserve(node_count(static_cast<int>(usable)));
  build(impl_->nodes, order, corners, frame, 0, static_cast<int>(usable));
  permute_in_place(corners, face_of, order);
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
      const Vec u = m.frame.to(q);  // the query in the boxes' frame
      stack.emplace_back(m.nodes[0].squared_distance(u) * m.frame.unscale2, 0);
      while (!stack.empty()) {
        const auto [bound, n] = stack.back();
        stack.pop_back();
        if (bound >= best) continue;
        const Node& node = m.nodes[static_cast<std::size_t>(n)];
        if (node.count > 0) {
          for (int k = node.next; k < node.next + node.count; ++k) {
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
        const int left = n + 1, right = node.next;
        const double dl = m.nodes[static_cast<std::size_t>(left)].squared_distance(u) *
                          m.frame.unscale2,
                     dr = m.nodes[static_cast<std::size_t>(right)].squared_distance(u) *
                          m.frame.unscale2;
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
