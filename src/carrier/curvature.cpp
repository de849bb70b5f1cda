#include "carrier/curvature.h"

#include <array>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numeric>

#include "carrier/curvature_edges.h"
#include "carrier/sphere_walk.h"
#include "core/parallel.h"

namespace meshmark {

namespace detail {

EdgeTable edge_table(const Eigen::MatrixX3i& F, const Adjacency& adj, Eigen::Index nv_) {
  // Half-edges (max, face, +1 if the face runs min->max) bucketed by their min vertex, each
  // bucket sorted: linear in the faces, no global sort.
  const auto nv = static_cast<std::size_t>(nv_);
  std::vector<int> start(nv + 1, 0);
  for (Eigen::Index t = 0; t < F.rows(); ++t)
    for (int c = 0; c < 3; ++c) {
      const int a = F(t, c), b = F(t, (c + 1) % 3);
      if (a != b) ++start[std::min(a, b) + 1];
    }
  std::partial_sum(start.begin(), start.end(), start.begin());
  std::vector<std::array<int, 5>> half(static_cast<std::size_t>(start[nv]));
  std::vector<int> fill(start.begin(), start.end() - 1);
  for (Eigen::Index t = 0; t < F.rows(); ++t)
    for (int c = 0; c < 3; ++c) {
      const int a = F(t, c), b = F(t, (c + 1) % 3);
      if (a != b)
        half[fill[std::min(a, b)]++] = {std::min(a, b), std::max(a, b), static_cast<int>(t),
                                        a < b ? 1 : -1, c};
    }
  for (std::size_t v = 0; v < nv; ++v)
    std::sort(half.begin() + start[v], half.begin() + start[v + 1]);
  EdgeTable table;
  table.face_edges.assign(static_cast<std::size_t>(F.rows()), {-1, -1, -1});
  for (std::size_t k = 0; k < half.size();) {
    std::size_t e = k;
    while (e < half.size() && half[e][0] == half[k][0] && half[e][1] == half[k][1]) ++e;
    std::array<int, 2> sides = {-1, -1};
    if (e - k == 2 && half[k][3] != half[k + 1][3]) {  // manifold, consistently oriented
      // f1 runs a -> b (a = min), f2 runs b -> a.
      sides[0] = half[k][3] > 0 ? half[k][2] : half[k + 1][2];
      sides[1] = half[k][3] > 0 ? half[k + 1][2] : half[k][2];
    }
    for (std::size_t h = k; h < e; ++h) {
      table.faces.push_back(half[h][2]);
      table.face_edges[static_cast<std::size_t>(half[h][2])][half[h][4]] =
          static_cast<int>(table.ends.size());
    }
    table.face_offsets.push_back(static_cast<int>(table.faces.size()));
    table.ends.push_back({half[k][0], half[k][1]});
    table.sides.push_back(sides);
    k = e;
  }
  auto slot = [&](int from, int to) {
    const auto first = adj.indices.begin() + adj.offsets[from],
               last = adj.indices.begin() + adj.offsets[from + 1];
    const auto it = std::lower_bound(first, last, to);
    return it != last && *it == to ? static_cast<int>(it - adj.indices.begin()) : -1;
  };
  table.edge_of_slot.assign(adj.indices.size(), -1);
  for (std::size_t k = 0; k < table.ends.size(); ++k)
    for (int s :
         {slot(table.ends[k][0], table.ends[k][1]), slot(table.ends[k][1], table.ends[k][0])})
      if (s >= 0) table.edge_of_slot[static_cast<std::size_t>(s)] = static_cast<int>(k);
  return table;
}

}  // namespace detail

namespace {

using detail::EdgeTable;

constexpr double kPi = 3.14159265358979323846;

// Per undirected edge of the table, its tensor beta / |e| e e^T (6 distinct entries: the
// whole edge's contribution divided by its length, so that a piece of fraction t of the edge
// contributes t times it; zero without a dihedral angle). beta is the signed dihedral angle
// between its two faces (0 on boundary and non-manifold edges). Edges in parallel chunks.
std::vector<std::array<double, 6>> edge_tensors(const Eigen::MatrixX3d& V,
                                                const Eigen::MatrixX3i& F, const EdgeTable& table) {
  auto normal = [&](int t) {
    const Eigen::Vector3d p0 = V.row(F(t, 0)), p1 = V.row(F(t, 1)), p2 = V.row(F(t, 2));
    const Eigen::Vector3d n = (p1 - p0).cross(p2 - p0);
    const double len = n.norm();
    return len > 0 ? Eigen::Vector3d(n / len) : Eigen::Vector3d::Zero();
  };
  std::vector<std::array<double, 6>> tensor(table.ends.size(), {0, 0, 0, 0, 0, 0});
  const auto ne = static_cast<std::int64_t>(table.ends.size());
  detail::parallel_chunks(ne, [&](int, std::int64_t begin, std::int64_t end) {
    for (auto k = static_cast<std::size_t>(begin); k < static_cast<std::size_t>(end); ++k) {
      const int a = table.ends[k][0], b = table.ends[k][1];
      if (table.sides[k][0] < 0) continue;
      const Eigen::Vector3d n1 = normal(table.sides[k][0]), n2 = normal(table.sides[k][1]);
      const Eigen::Vector3d dir = V.row(b) - V.row(a);
      const double len = dir.norm();
      if (!(len > 0)) continue;
      const double beta = std::atan2(n1.cross(n2).dot(dir / len), n1.dot(n2));
      const Eigen::Vector3d d = (V.row(b) - V.row(a)).transpose();
      const double length = d.norm();
      if (beta == 0 || length == 0) continue;
      const double w = beta / length;
      tensor[k] = {w * d(0) * d(0), w * d(0) * d(1), w * d(0) * d(2),
                   w * d(1) * d(1), w * d(1) * d(2), w * d(2) * d(2)};
    }
  });
  return tensor;
}

// Fraction of the segment a -> b inside the ball of squared radius r2 around o.
double fraction_inside(const Eigen::RowVector3d& o, double r2, const Eigen::RowVector3d& a,
                       const Eigen::RowVector3d& b) {
  const Eigen::RowVector3d p = a - o, d = b - a;
  const double A = d.squaredNorm(), B = d.dot(p), C = p.squaredNorm() - r2;
  if (A == 0) return 0;
  const double disc = B * B - A * C;
  if (disc <= 0) return 0;
  const double root = std::sqrt(disc);
  return std::max(0.0, std::min(1.0, (-B + root) / A) - std::max(0.0, (-B - root) / A));
}

// Exact clipping: faces flooded from those around `center` across every edge that meets the
// ball; each edge seen once, for its fraction inside. visit(edge, fraction).
template <class Points, class Visit>
void flood_ball(const Points& P, const Adjacency& adj, const EdgeTable& table, int center,
                double radius, std::vector<int>& face_stamp, std::vector<int>& edge_stamp,
                std::vector<int>& queue, int mark, Visit&& visit) {
  const Eigen::RowVector3d o = P.row(center);
  const double r2 = radius * radius;
  queue.clear();
  auto push_faces = [&](int e) {
    for (int k = table.face_offsets[e]; k < table.face_offsets[e + 1]; ++k)
      if (face_stamp[table.faces[k]] != mark) {
        face_stamp[table.faces[k]] = mark;
        queue.push_back(table.faces[k]);
      }
  };
  for (int s = adj.offsets[center]; s < adj.offsets[center + 1]; ++s)
    if (table.edge_of_slot[s] >= 0) push_faces(table.edge_of_slot[s]);
  for (std::size_t q = 0; q < queue.size(); ++q)
    for (int e : table.face_edges[static_cast<std::size_t>(queue[q])]) {
      if (e < 0 || edge_stamp[e] == mark) continue;
      edge_stamp[e] = mark;
      const double f = fraction_inside(o, r2, P.row(table.ends[e][0]), P.row(table.ends[e][1]));
      if (f <= 0) continue;
      visit(e, f);
      push_faces(e);
    }
}

// The two eigenvalues of largest magnitude of the symmetric tensor t (6 entries) / area,
// smaller magnitude first; the smallest belongs to the normal.
Eigen::Vector2d principal_pair(const std::array<double, 6>& t, double area) {
  Eigen::Matrix3d T;
  T << t[0], t[1], t[2], t[1], t[3], t[4], t[2], t[4], t[5];
  T /= area;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
  eig.computeDirect(T, Eigen::EigenvaluesOnly);  // closed form for 3 x 3
  Eigen::Vector3d ev = eig.eigenvalues();
  std::sort(ev.data(), ev.data() + 3, [](double x, double y) { return std::abs(x) < std::abs(y); });
  return {ev(1), ev(2)};
}

}  // namespace

Neighborhoods ball_neighborhoods(const Eigen::MatrixX3d& V, const Adjacency& adj, double radius) {
  // Each chunk of vertices gathers its lists on its own thread; the lists are then joined in
  // vertex order.
  const std::int64_t nv = V.rows();
  const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> P =
      V;  // one cache line per point
  std::vector<Neighborhoods> parts(static_cast<std::size_t>(detail::chunk_count(nv)));
  detail::parallel_chunks(nv, [&](int chunk, std::int64_t begin, std::int64_t end) {
    Neighborhoods& part = parts[chunk];
    std::vector<int> stamp(static_cast<std::size_t>(nv), -1), queue;
    for (std::int64_t i = begin; i < end; ++i) {
      if (adj.degree(static_cast<int>(i)) > 0)
        for_each_vertex_in_ball(P, adj, static_cast<int>(i), P.row(i), radius, stamp, queue,
                                static_cast<int>(i), [&](int v) { part.indices.push_back(v); });
      part.offsets.push_back(static_cast<std::int64_t>(part.indices.size()));
    }
  });
  Neighborhoods near;
  for (const Neighborhoods& part : parts) {
    const std::int64_t base = static_cast<std::int64_t>(near.indices.size());
    for (std::size_t k = 1; k < part.offsets.size(); ++k)
      near.offsets.push_back(base + part.offsets[k]);
    near.indices.insert(near.indices.end(), part.indices.begin(), part.indices.end());
  }
  return near;
}

CurvatureField normal_cycle_curvature(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                                      double radius, BallEdges which) {
  return normal_cycle_curvature(V, F, vertex_adjacency(F, V.rows()), radius, which);
}

CurvatureField normal_cycle_curvature(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                                      const Adjacency& adj, double radius, BallEdges which) {
  if (!(radius > 0)) return detail::normal_cycle_curvature(V, F, adj, {}, radius, which);
  return detail::normal_cycle_curvature(V, F, adj, detail::edge_table(F, adj, V.rows()), radius,
                                        which);
}

namespace detail {

CurvatureField normal_cycle_curvature(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                                      const Adjacency& adj, const EdgeTable& table, double radius,
                                      BallEdges which) {
  const Eigen::Index nv = V.rows();
  CurvatureField field;
  field.kmin = Eigen::VectorXd::Zero(nv);
  field.kmax = Eigen::VectorXd::Zero(nv);
  if (!(radius > 0)) return field;
  const std::vector<std::array<double, 6>> tensor = edge_tensors(V, F, table);
  const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> P =
      V;                                      // one cache line per point
  const double area = kPi * radius * radius;  // the disc's, as MEPP divides by
  // Vertices are independent: chunks of them on separate threads, each with its own scratch.
  detail::parallel_chunks(nv, [&](int, std::int64_t begin, std::int64_t end) {
    detail::WalkScratch scratch(nv);
    std::vector<int> face_stamp(static_cast<std::size_t>(F.rows()), -1),
        edge_stamp(tensor.size(), -1), queue;
    for (Eigen::Index i = begin; i < end; ++i) {
      std::array<double, 6> t = {0, 0, 0, 0, 0, 0};
      auto add = [&](int e, double fraction) {
        for (int c = 0; c < 6; ++c) t[c] += fraction * tensor[e][c];
      };
      if (which == BallEdges::kReferenceWalk)
        detail::walk_sphere(P, adj, static_cast<int>(i), radius, scratch,
                            [&](int, int slot, int, const detail::Clip& clip, bool) {
                              if (table.edge_of_slot[slot] >= 0)
                                add(table.edge_of_slot[slot], clip.t);
                            });
      else
        flood_ball(P, adj, table, static_cast<int>(i), radius, face_stamp, edge_stamp, queue,
                   static_cast<int>(i), add);
      const Eigen::Vector2d k = principal_pair(t, area);
      field.kmin(i) = k(0);
      field.kmax(i) = k(1);
    }
  });
  return field;
}

}  // namespace detail

}  // namespace meshmark
