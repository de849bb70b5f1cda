#include "meshmark/forensics/registration.h"

#include <fmt/format.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>
#include <optional>
#include <unordered_map>
#include <vector>

#include "meshmark/attacks/attack.h"
#include "meshmark/carrier/histogram.h"
#include "meshmark/core/error.h"
#include "meshmark/core/mesh.h"
#include "meshmark/core/random.h"
#include "metrics/closest_point.h"

namespace meshmark {

Eigen::MatrixX3d Similarity::apply(const Eigen::MatrixX3d& V) const {
  Eigen::MatrixX3d out = (scale * V * rotation.transpose());
  out.rowwise() += translation.transpose();
  return out;
}

Similarity Similarity::inverse() const {
  Similarity inv;
  inv.rotation = rotation.transpose();
  inv.scale = 1 / scale;
  inv.translation = -inv.scale * (inv.rotation * translation);
  return inv;
}

namespace {

// Centroid and covariance of the rows of P.
void moments(const Eigen::MatrixX3d& P, Eigen::Vector3d& mean, Eigen::Matrix3d& cov) {
  mean = P.colwise().mean().transpose();
  const Eigen::MatrixX3d Q = P.rowwise() - mean.transpose();
  cov = Q.transpose() * Q / std::max<double>(1, static_cast<double>(P.rows()));
}

// The RMS distance of the closest `trim` fraction of the samples S, moved by T, to the surface.
double trimmed_rms(const Eigen::MatrixX3d& S, const SurfaceIndex& surface, const Similarity& T,
                   double trim) {
  const ClosestPoints cp = surface.query(T.apply(S));
  std::vector<double> d(cp.distance.data(), cp.distance.data() + S.rows());
  const auto keep =
      std::max<std::size_t>(3, static_cast<std::size_t>(trim * static_cast<double>(S.rows())));
  std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(keep - 1), d.end());
  double sum = 0;
  for (std::size_t k = 0; k < keep; ++k) sum += d[k] * d[k];
  return std::sqrt(sum / static_cast<double>(keep));
}

// Trimmed ICP from start: returns the transform, its trimmed RMS and the steps taken (at most
// `iterations`; it stops when the trimmed RMS changes by less than `tolerance` of itself).
// with_scale false: the scale stays as it is (rigid steps); true: Umeyama's similarity.
Similarity icp(const Eigen::MatrixX3d& S, const SurfaceIndex& original, Similarity T,
               const RegistrationOptions& o, bool with_scale, int iterations, double tolerance,
               double& rms, int& steps) {
  const Eigen::Index n = S.rows();
  const Eigen::Index keep =
      std::min(n, std::max<Eigen::Index>(3, static_cast<Eigen::Index>(o.trim * n)));
  std::vector<Eigen::Index> order(static_cast<std::size_t>(n));
  rms = std::numeric_limits<double>::infinity();
  for (steps = 0; steps < iterations; ++steps) {
    const ClosestPoints cp = original.query(T.apply(S));
    std::iota(order.begin(), order.end(), 0);
    std::nth_element(
        order.begin(), order.begin() + (keep - 1), order.end(),
        [&](Eigen::Index a, Eigen::Index b) { return cp.distance(a) < cp.distance(b); });
    Eigen::Matrix3Xd src(3, keep), dst(3, keep);
    double sum = 0;
    for (Eigen::Index k = 0; k < keep; ++k) {
      src.col(k) = S.row(order[k]).transpose();
      dst.col(k) = cp.point.row(order[k]).transpose();
      sum += cp.distance(order[k]) * cp.distance(order[k]);
    }
    const double now = std::sqrt(sum / keep);
    Similarity next;
    if (!with_scale) src *= T.scale;
    const Eigen::Matrix4d M = Eigen::umeyama(src, dst, with_scale);
    next.scale = with_scale ? M.block<3, 3>(0, 0).col(0).norm() : T.scale;
    next.rotation = M.block<3, 3>(0, 0) / (with_scale ? next.scale : 1.0);
    next.translation = M.block<3, 1>(0, 3);
    const double previous = rms;
    T = next;
    rms = now;
    if (std::abs(previous - now) <= tolerance * now) break;  // converged
  }
  // The residual of the final transform.
  rms = trimmed_rms(S, original, T, o.trim);
  return T;
}

// Trimmed point-to-plane ICP with a free scale, from T: each step minimizes the squared
// distances of the kept samples to the tangent planes at their closest points, linearized in a
// small rotation w, a translation t and a relative scale change c about the samples' centroid
// (Gauss-Newton; it converges in far fewer steps than point to point once near). Same stopping
// rule as icp().
Similarity icp_plane(const Eigen::MatrixX3d& S, const SurfaceIndex& original,
                     const Eigen::MatrixX3d& VO, const Eigen::MatrixX3i& FO, Similarity T,
                     const RegistrationOptions& o, int iterations, double tolerance, double& rms,
                     int& steps) {
  const Eigen::Index n = S.rows();
  const Eigen::Index keep =
      std::min(n, std::max<Eigen::Index>(7, static_cast<Eigen::Index>(o.trim * n)));
  if (keep < 7) {  // too few samples for the 7 unknowns: the start as it is
    rms = trimmed_rms(S, original, T, o.trim);
    steps = 0;
    return T;
  }
  std::vector<Eigen::Index> order(static_cast<std::size_t>(n));
  rms = std::numeric_limits<double>::infinity();
  double lowest = rms;
  int stalled = 0;
  for (steps = 0; steps < iterations; ++steps) {
    const Eigen::MatrixX3d P = T.apply(S);
    const ClosestPoints cp = original.query(P);
    std::iota(order.begin(), order.end(), 0);
    std::nth_element(
        order.begin(), order.begin() + (keep - 1), order.end(),
        [&](Eigen::Index a, Eigen::Index b) { return cp.distance(a) < cp.distance(b); });
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    for (Eigen::Index k = 0; k < keep; ++k) centroid += P.row(order[k]).transpose();
    centroid /= static_cast<double>(keep);
    Eigen::Matrix<double, 7, 7> A = Eigen::Matrix<double, 7, 7>::Zero();
    Eigen::Matrix<double, 7, 1> b = Eigen::Matrix<double, 7, 1>::Zero();
    double sum = 0;
    for (Eigen::Index k = 0; k < keep; ++k) {
      const Eigen::Index i = order[k];
      const int f = cp.face[i];
      const Eigen::Vector3d a = VO.row(FO(f, 0)), e1 = VO.row(FO(f, 1)).transpose() - a,
                            e2 = VO.row(FO(f, 2)).transpose() - a;
      const Eigen::Vector3d normal = e1.cross(e2).normalized();
      const Eigen::Vector3d p = P.row(i).transpose() - centroid;
      Eigen::Matrix<double, 7, 1> J;
      J << p.cross(normal), normal, normal.dot(p);
      const double r = normal.dot(P.row(i).transpose() - cp.point.row(i).transpose());
      A += J * J.transpose();
      b -= J * r;
      sum += cp.distance(i) * cp.distance(i);
    }
    const double now = std::sqrt(sum / static_cast<double>(keep));
    const Eigen::Matrix<double, 7, 1> x = A.ldlt().solve(b);
    if (!x.allFinite()) break;
    double radius = 0;  // of the kept samples about their centroid
    for (Eigen::Index k = 0; k < keep; ++k)
      radius = std::max(radius, (P.row(order[k]).transpose() - centroid).norm());
    const Eigen::Vector3d w = x.head<3>();
    const Eigen::Matrix3d dR = w.norm() > 0
                                   ? Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix()
                                   : Eigen::Matrix3d::Identity();
    const double ds = 1 + x(6);
    if (!(ds > 0.5 && ds < 2)) break;
    // p -> ds dR (p - centroid) + centroid + t, composed with T.
    Similarity next;
    next.rotation = dR * T.rotation;
    next.scale = ds * T.scale;
    next.translation = ds * dR * (T.translation - centroid) + centroid + x.segment<3>(3);
    T = next;
    rms = now;
    // Converged when the step moves no kept sample by more than `tolerance` of their radius,
    // or when the residual has not improved for 3 steps (the kept set and the closest faces
    // switching back and forth).
    const double moved = (w.norm() + std::abs(x(6))) * radius + x.segment<3>(3).norm();
    if (moved <= tolerance * radius) break;
    if (now < (1 - 1e-6) * lowest)
      lowest = now, stalled = 0;
    else if (++stalled >= 3)
      break;
  }
  rms = trimmed_rms(S, original, T, o.trim);
  return T;
}

}  // namespace

namespace {

// The area of the faces F over V.
double area(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F) {
  double sum = 0;
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    sum += 0.5 * (V.row(F(f, 1)) - V.row(F(f, 0))).cross(V.row(F(f, 2)) - V.row(F(f, 0))).norm();
  return sum;
}

// The median length of the edges of the faces F over V (0 without faces).
double median_edge(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F) {
  std::vector<double> length;
  length.reserve(static_cast<std::size_t>(3 * F.rows()));
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k)
      length.push_back((V.row(F(f, k)) - V.row(F(f, (k + 1) % 3))).norm());
  if (length.empty()) return 0;
  std::nth_element(length.begin(), length.begin() + static_cast<std::ptrdiff_t>(length.size() / 2),
                   length.end());
  return length[length.size() / 2];
}

// Registration's starts besides the identity (first): the principal axes of the leak's points
// matched to the original's in the four proper ways, at the scale of their spreads. With
// `partial`, the starts for a leak that is part of the original (cropped), whose spread and axes
// are not the original's: each of the 24 proper ways of matching the axes (a part may order its
// axes otherwise), at the spreads' scale and at `edge_scale` (the ratio of the meshes' median
// edge lengths, which cropping keeps), the first four left out.
std::vector<Similarity> principal_axis_starts(const Eigen::MatrixX3d& leak,
                                              const Eigen::MatrixX3d& original, bool partial,
                                              double edge_scale) {
  std::vector<Similarity> starts;
  if (!partial) starts.resize(1);
  Eigen::Vector3d mean_l, mean_o;
  Eigen::Matrix3d cov_l, cov_o;
  moments(leak, mean_l, cov_l);
  moments(original, mean_o, cov_o);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> el(cov_l), eo(cov_o);
  const double spread_scale = std::sqrt(cov_o.trace() / std::max(cov_l.trace(), 1e-300));
  std::vector<double> scales{spread_scale};
  if (partial && std::isfinite(edge_scale) && edge_scale > 0) scales.push_back(edge_scale);
  std::array<int, 3> axes{0, 1, 2};
  int order = 0;
  do {
    Eigen::Matrix3d P = Eigen::Matrix3d::Zero();  // leak axis axes[k] to original axis k
    for (int k = 0; k < 3; ++k) P(k, axes[k]) = 1;
    for (const Eigen::Vector3d& signs : {Eigen::Vector3d(1, 1, 1), Eigen::Vector3d(1, -1, -1),
                                         Eigen::Vector3d(-1, 1, -1), Eigen::Vector3d(-1, -1, 1)}) {
      Eigen::Matrix3d R =
          eo.eigenvectors() * signs.asDiagonal() * P * el.eigenvectors().transpose();
      if (R.determinant() < 0) R = -R;  // eigenvector bases may be left-handed
      for (std::size_t k = 0; k < scales.size(); ++k) {
        if (partial && order == 0 && k == 0) continue;  // the first four, already tried
        Similarity s;
        s.rotation = R;
        s.scale = scales[k];
        s.translation = mean_o - scales[k] * R * mean_l;
        starts.push_back(s);
      }
    }
    ++order;
  } while (partial && std::next_permutation(axes.begin(), axes.end()));
  return starts;
}

// A patch of a mesh around face f: its corners in order of the length of the opposite edge
// (shortest first), those lengths, and the apexes of the faces across its three edges (-1
// where none), each across the edge opposite the corner of the same rank.
struct FacePatch {
  std::array<double, 3> length{};
  std::array<int, 3> corner{};
  std::array<int, 3> apex{-1, -1, -1};
};

// Directed edge (u, v) -> the vertex opposite it in its face.
using Apexes = std::unordered_map<std::uint64_t, int>;

std::uint64_t edge_key(int u, int v) {
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(u)) << 32) |
         static_cast<std::uint32_t>(v);
}

Apexes apexes_of(const Eigen::MatrixX3i& F) {
  Apexes apex;
  apex.reserve(static_cast<std::size_t>(3 * F.rows()));
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k)
      apex.emplace(edge_key(F(f, k), F(f, (k + 1) % 3)), F(f, (k + 2) % 3));
  return apex;
}

FacePatch face_patch(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F, const Apexes& apex,
                     Eigen::Index f) {
  FacePatch p;
  std::array<int, 3> order{0, 1, 2};
  std::array<double, 3> opposite{};
  for (int k = 0; k < 3; ++k)
    opposite[k] = (V.row(F(f, (k + 1) % 3)) - V.row(F(f, (k + 2) % 3))).norm();
  std::sort(order.begin(), order.end(), [&](int a, int b) { return opposite[a] < opposite[b]; });
  for (int r = 0; r < 3; ++r) {
    const int k = order[r];
    p.corner[r] = F(f, k);
    p.length[r] = opposite[k];
    // The face across the edge opposite corner k holds that edge reversed.
    const auto it = apex.find(edge_key(F(f, (k + 2) % 3), F(f, (k + 1) % 3)));
    if (it != apex.end()) p.apex[r] = it->second;
  }
  return p;
}

// Starts for a leak that kept some of the original's faces as they were, moved by a similarity
// (a part cut out and moved): leak faces whose shapes (the ratios of their edge lengths) match
// an original face's within 1.5 %, at a size within 15 % of the leak's times `scale` (the ratio
// of the median edges, which a part keeps only roughly), are paired with it, each pairing of
// corners that keeps the ratios. The patches (a face and the apexes across its edges, the
// faces' winding fixing the side) give a similarity, kept when they agree within a fifth of the
// face's shortest edge and ranked by the trimmed distance of the samples S to the original.
// The best `count`, at most.
std::vector<Similarity> matched_face_starts(const Eigen::MatrixX3d& VL, const Eigen::MatrixX3i& FL,
                                            const Eigen::MatrixX3d& VO, const Eigen::MatrixX3i& FO,
                                            const Eigen::MatrixX3d& S, const SurfaceIndex& index,
                                            double scale, double trim, std::uint64_t seed,
                                            std::size_t count) {
  if (!(std::isfinite(scale) && scale > 0) || FL.rows() == 0 || FO.rows() == 0) return {};
  constexpr double kShape = 0.015;     // tolerance on the ratios of edge lengths
  constexpr double kSize = 0.15;       // on the size, against the median edges' ratio
  constexpr int kLeakFaces = 96;       // leak faces tried
  constexpr std::size_t kPerFace = 4;  // pairings measured per leak face
  const Apexes apex_o = apexes_of(FO), apex_l = apexes_of(FL);
  std::vector<FacePatch> patch_o(static_cast<std::size_t>(FO.rows()));
  std::vector<Eigen::Index> by_shortest(patch_o.size());
  for (Eigen::Index f = 0; f < FO.rows(); ++f) patch_o[f] = face_patch(VO, FO, apex_o, f);
  std::iota(by_shortest.begin(), by_shortest.end(), 0);
  std::sort(by_shortest.begin(), by_shortest.end(), [&](Eigen::Index a, Eigen::Index b) {
    return patch_o[a].length[0] < patch_o[b].length[0];
  });
  const Eigen::MatrixX3d coarse = S.topRows(std::min<Eigen::Index>(S.rows(), 200));
  std::vector<std::pair<double, Similarity>> ranked, pairings;
  Random rng(seed);
  for (int tried = 0; tried < kLeakFaces; ++tried) {
    const auto f = static_cast<Eigen::Index>(rng.index(static_cast<std::uint64_t>(FL.rows())));
    const FacePatch pl = face_patch(VL, FL, apex_l, f);
    if (std::find(pl.apex.begin(), pl.apex.end(), -1) != pl.apex.end()) continue;
    const double size = scale * pl.length[0];
    if (!(size > 0)) continue;
    auto it = std::lower_bound(
        by_shortest.begin(), by_shortest.end(), size * (1 - kSize),
        [&](Eigen::Index a, double value) { return patch_o[a].length[0] < value; });
    for (; it != by_shortest.end() && patch_o[*it].length[0] <= size * (1 + kSize); ++it) {
      const FacePatch& po = patch_o[*it];
      if (std::find(po.apex.begin(), po.apex.end(), -1) != po.apex.end()) continue;
      std::array<int, 3> pair{0, 1, 2};  // leak rank r -> original rank pair[r]
      do {
        // The ratios of each edge to the sum of the three, the same on both sides.
        const double sum_l = pl.length[0] + pl.length[1] + pl.length[2];
        const double sum_o = po.length[0] + po.length[1] + po.length[2];
        bool shape = true;
        for (int r = 0; r < 3; ++r)
          shape = shape && std::abs(po.length[pair[r]] / sum_o - pl.length[r] / sum_l) <=
                               kShape * pl.length[r] / sum_l;
        if (!shape) continue;
        // The patch's corners and apexes: rank r's apex lies across the edge opposite corner r
        // on both sides.
        Eigen::Matrix3Xd src(3, 6), dst(3, 6);
        for (int r = 0; r < 3; ++r) {
          src.col(r) = VL.row(pl.corner[r]).transpose();
          dst.col(r) = VO.row(po.corner[pair[r]]).transpose();
          src.col(3 + r) = VL.row(pl.apex[r]).transpose();
          dst.col(3 + r) = VO.row(po.apex[pair[r]]).transpose();
        }
        const Eigen::Matrix4d M = Eigen::umeyama(src, dst, true);
        const Eigen::Matrix3Xd moved = (M.block<3, 3>(0, 0) * src).colwise() + M.block<3, 1>(0, 3);
        const double disagreement = (moved - dst).colwise().norm().maxCoeff() / po.length[0];
        if (disagreement > 0.2) continue;
        Similarity T;
        T.scale = M.block<3, 3>(0, 0).col(0).norm();
        T.rotation = M.block<3, 3>(0, 0) / T.scale;
        T.translation = M.block<3, 1>(0, 3);
        pairings.emplace_back(disagreement, T);
      } while (std::next_permutation(pair.begin(), pair.end()));
    }
    // A regular mesh has many look-alike patches: the closest few are measured.
    const std::size_t kept = std::min<std::size_t>(kPerFace, pairings.size());
    std::partial_sort(pairings.begin(), pairings.begin() + static_cast<std::ptrdiff_t>(kept),
                      pairings.end(),
                      [](const auto& a, const auto& b) { return a.first < b.first; });
    for (std::size_t k = 0; k < kept; ++k)
      ranked.emplace_back(trimmed_rms(coarse, index, pairings[k].second, trim), pairings[k].second);
    pairings.clear();
  }
  std::sort(ranked.begin(), ranked.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<Similarity> starts;
  for (std::size_t k = 0; k < std::min(count, ranked.size()); ++k)
    starts.push_back(ranked[k].second);
  return starts;
}

// For a leak with the original's faces (noise, quantization, smoothing, a similarity), where
// vertex i corresponds to vertex i: the least-squares similarity of the pairs (Umeyama),
// refitted on the closest `trim` of them; none with fewer than 3 pairs.
std::optional<Similarity> fit_corresponding_vertices(const Eigen::MatrixX3d& VL,
                                                     const Eigen::MatrixX3d& VO,
                                                     const std::vector<std::uint8_t>& used_l,
                                                     const std::vector<std::uint8_t>& used_o,
                                                     double trim, double& residual) {
  std::vector<Eigen::Index> pairs;
  for (Eigen::Index i = 0; i < VL.rows(); ++i)
    if (used_l[i] && used_o[i]) pairs.push_back(i);
  if (pairs.size() < 3) return std::nullopt;
  Similarity T;
  for (const double share : {1.0, trim}) {
    std::vector<double> d(pairs.size());
    const Eigen::MatrixX3d moved = T.apply(VL);
    for (std::size_t k = 0; k < pairs.size(); ++k)
      d[k] = (moved.row(pairs[k]) - VO.row(pairs[k])).norm();
    std::vector<std::size_t> order(pairs.size());
    std::iota(order.begin(), order.end(), 0);
    const auto keep = std::max<std::size_t>(
        3, static_cast<std::size_t>(share * static_cast<double>(pairs.size())));
    std::nth_element(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(keep - 1),
                     order.end(), [&](std::size_t a, std::size_t b) { return d[a] < d[b]; });
    Eigen::Matrix3Xd src(3, keep), dst(3, keep);
    for (std::size_t k = 0; k < keep; ++k) {
      src.col(static_cast<Eigen::Index>(k)) = VL.row(pairs[order[k]]).transpose();
      dst.col(static_cast<Eigen::Index>(k)) = VO.row(pairs[order[k]]).transpose();
    }
    const Eigen::Matrix4d M = Eigen::umeyama(src, dst, true);
    T.scale = M.block<3, 3>(0, 0).col(0).norm();
    T.rotation = M.block<3, 3>(0, 0) / T.scale;
    T.translation = M.block<3, 1>(0, 3);
    // The RMS distance of the fitted pairs, moved by the fit.
    residual = std::sqrt(((T.scale * src.transpose() * T.rotation.transpose()).rowwise() +
                          T.translation.transpose() - dst.transpose())
                             .rowwise()
                             .squaredNorm()
                             .mean());
  }
  return T;
}

// The same for a leak that may have been smoothed too (before or after the similarity: uniform
// Laplacian and Taubin steps commute with one): its vertices match the original's smoothed
// ones, and a fit to the original's own would take the shrinking for a scale and a shift. The
// fit is also made to the original after 1 to 40 Laplacian (lambda 0.3) or Taubin steps on its
// faces F (each series stopped 5 steps past its best), and the one whose pairs fit closest is
// kept when it lowers their residual by 5 % at least. `best` and `unsmoothed`: the fit to the
// original's own vertices and its residual.
Similarity fit_corresponding_smoothed(const Eigen::MatrixX3d& VL, const Eigen::MatrixX3d& VO,
                                      const Eigen::MatrixX3i& F,
                                      const std::vector<std::uint8_t>& used_l,
                                      const std::vector<std::uint8_t>& used_o, double trim,
                                      Similarity best, double unsmoothed) {
  const Smoother smoother(F, VO.rows());
  double lowest = 0.95 * unsmoothed;
  for (const bool taubin : {false, true}) {
    Eigen::MatrixX3d current = VO;
    double series_best = unsmoothed;
    int worse = 0;  // steps since the series' best
    for (int k = 1; k <= 40 && worse < 5; ++k) {
      if (taubin)
        smoother.taubin(current, 1);
      else
        smoother.laplacian(current, 1);
      double residual = 0;
      const std::optional<Similarity> T =
          fit_corresponding_vertices(VL, current, used_l, used_o, trim, residual);
      worse = residual < series_best ? 0 : worse + 1;
      series_best = std::min(series_best, residual);
      if (T && residual < lowest) lowest = residual, best = *T;
    }
  }
  return best;
}

// The verdict on the best transform: its overlap (the share of samples S near the original),
// Registered when its residual is at most max_residual, the registered leak (all its points)
// spans at least 2 % of the original's diagonal and its median edge is within a factor 16 of
// the original's (`edge_ratio`: the leak's median edge over the original's, before the
// transform); a leak shrunk onto a patch of the original fits it closely and means nothing,
// while resampling changes edges by far less (three rounds of subdivision: 8), and the message.
void judge(RegistrationResult& best, const SurfaceIndex& index, const Eigen::MatrixX3d& S,
           const Eigen::MatrixX3d& all_l, double diagonal, double max_residual, double edge_ratio) {
  const ClosestPoints cp = index.query(best.transform.apply(S));
  const double near = std::max(3 * best.residual, 1e-3) * diagonal;
  best.overlap = static_cast<double>((cp.distance.array() <= near).count()) / S.rows();
  const Eigen::MatrixX3d moved = best.transform.apply(all_l);
  const double span = (moved.colwise().maxCoeff() - moved.colwise().minCoeff()).norm() / diagonal;
  const double edges = best.transform.scale * edge_ratio;  // registered over original
  std::string why;
  if (!(span >= 0.02))
    why = fmt::format(
        " (the registered leak spans only {:.2g} of the original's diagonal: it is "
        "not this original)",
        span);
  else if (std::isfinite(edges) && edges > 0 && !(edges >= 1.0 / 16 && edges <= 16))
    why = fmt::format(
        " (the registered leak's edges are {:.2g} times the original's: it is not "
        "this original)",
        edges);
  best.status = best.residual <= max_residual && why.empty() ? RegistrationStatus::Registered
                                                             : RegistrationStatus::Failed;
  best.message = fmt::format(
      "{}{}: residual {:.3g} of the diagonal, {:.0f} % of the leak near the "
      "original, scale {:.6f}{}",
      best.status == RegistrationStatus::Registered ? "registered" : "FAILED",
      best.iterations == 0 ? " (in the original's frame)" : "", best.residual, 100 * best.overlap,
      best.transform.scale, why);
}

}  // namespace

RegistrationResult register_similarity(const Eigen::MatrixX3d& VL, const Eigen::MatrixX3i& FL,
                                       const Eigen::MatrixX3d& VO, const Eigen::MatrixX3i& FO,
                                       const RegistrationOptions& o) {
  if (!(o.trim > 0 && o.trim <= 1) || o.samples < 3 || o.iterations < 1 || !(o.max_residual > 0))
    throw InvalidArgumentError("registration options out of range");
  const std::vector<std::uint8_t> used_l = carrier_vertices(VL, FL);
  const std::vector<std::uint8_t> used_o = carrier_vertices(VO, FO);
  std::vector<Eigen::Index> rows;
  for (Eigen::Index i = 0; i < VL.rows(); ++i)  // each position once (kCounted)
    if (used_l[i] == kCounted) rows.push_back(i);
  if (rows.size() < 3)
    throw InvalidArgumentError("the leaked mesh has fewer than 3 usable vertices");
  Random rng(o.seed);
  if (static_cast<int>(rows.size()) > o.samples) {
    for (int k = 0; k < o.samples; ++k)
      std::swap(rows[k], rows[k + rng.next() % (rows.size() - k)]);
    rows.resize(static_cast<std::size_t>(o.samples));
  }
  Eigen::MatrixX3d S(static_cast<Eigen::Index>(rows.size()), 3);
  for (std::size_t k = 0; k < rows.size(); ++k) S.row(k) = VL.row(rows[k]);
  Eigen::MatrixX3d PO(std::count(used_o.begin(), used_o.end(), kCounted), 3);
  for (Eigen::Index i = 0, k = 0; i < VO.rows(); ++i)
    if (used_o[i] == kCounted) PO.row(k++) = VO.row(i);
  const double diagonal = bounding_box_diagonal(VO, used_o);

  Eigen::MatrixX3d all_l(
      static_cast<Eigen::Index>(std::count(used_l.begin(), used_l.end(), kCounted)), 3);
  for (Eigen::Index i = 0, k = 0; i < VL.rows(); ++i)
    if (used_l[i] == kCounted) all_l.row(k++) = VL.row(i);
  std::vector<Similarity> starts = principal_axis_starts(all_l, PO, false, 0);
  const SurfaceIndex index(VO, FO);
  const double edge_l = median_edge(VL, FL), edge_o = median_edge(VO, FO);
  RegistrationResult best;
  best.residual = std::numeric_limits<double>::infinity();
  // A leak near the original's frame (what decimation, remeshing, smoothing, noise, cropping
  // and compression tools give) is refined from the identity only, and kept as it is unless
  // that halves its residual: fitting a transform to an unmoved leak would absorb part of the
  // mark (a scale that shrinks or grows the bins' radii).
  const double at_identity = trimmed_rms(S, index, Similarity{}, o.trim) / diagonal;
  const bool near_frame = at_identity <= o.in_frame;
  if (near_frame) {
    starts.resize(1);  // the identity
    best.residual = at_identity;
  }
  // Rigid steps first at the start's scale (a free scale from a poor start collapses the leak
  // onto a patch of the original), then the similarity from there.
  auto refine = [&](const Eigen::MatrixX3d& samples, const Similarity& start, int iterations,
                    double tolerance, double& rms, int& steps) {
    int more = 0;
    const Similarity rigid =
        icp(samples, index, start, o, false, iterations, tolerance, rms, steps);
    Similarity T = icp(samples, index, rigid, o, true, iterations, tolerance, rms, more);
    steps += more;
    return T;
  };
  if (VL.rows() == VO.rows() && FL.rows() == FO.rows() && FL == FO) {
    // The leak has the original's faces (noise, quantization, smoothing, a similarity): vertex
    // i corresponds to vertex i, and the similarity is the least-squares fit of the pairs
    // (Umeyama), refitted on the closest `trim` of them; to the original's vertices, and to them
    // smoothed unless the leak is near the original's frame and stays there (the fit to its own
    // vertices does not halve the residual): smoothing in place is what trace's reference
    // models then, and the series would cost 0.1 to 0.3 s for nothing.
    double unsmoothed = 0;
    if (std::optional<Similarity> fitted =
            fit_corresponding_vertices(VL, VO, used_l, used_o, o.trim, unsmoothed)) {
      Similarity T = *fitted;
      double rms = trimmed_rms(S, index, T, o.trim) / diagonal;
      if (!near_frame || rms < 0.5 * best.residual) {
        T = fit_corresponding_smoothed(VL, VO, FO, used_l, used_o, o.trim, T, unsmoothed);
        rms = trimmed_rms(S, index, T, o.trim) / diagonal;
      }
      if (rms < (near_frame ? 0.5 : 1.0) * best.residual) {
        best.transform = T;
        best.residual = rms;
        best.iterations = 1;
      }
      starts.clear();  // no ICP
    }
  }
  // The starts in order of promise: each is run for a few loose steps on a coarse subset (the
  // first rows of S are a random subset of it) and ranked by its residual there.
  const auto try_starts = [&](const std::vector<Similarity>& tried, bool part) {
    std::vector<std::pair<double, Similarity>> ranked;
    const Eigen::Index coarse = std::min<Eigen::Index>(S.rows(), 200);
    for (const Similarity& start : tried) {
      double rms = 0;
      int steps = 0;
      const Similarity T =
          near_frame ? start
          : part     ? icp(S.topRows(coarse), index, start, o, false, 12, 1e-4, rms, steps)
                     : refine(S.topRows(coarse), start, 12, 1e-4, rms, steps);
      ranked.emplace_back(rms, T);
    }
    std::stable_sort(ranked.begin(), ranked.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    // A part's starts: the 8 best of the coarse ranking refined, each (a free scale can fit a
    // part onto a patch closely, so no start is ruled out by another's residual).
    const std::size_t refined = part ? std::min<std::size_t>(8, ranked.size()) : ranked.size();
    for (std::size_t k = 0; k < refined; ++k) {
      const Similarity& from = ranked[k].second;
      // Point to point until near (on 300 samples), then point to plane with every sample (point
      // to point creeps along the surface).
      double rms = 0;
      int steps = 0, more = 0;
      const Similarity near =
          refine(S.topRows(std::min<Eigen::Index>(S.rows(), 300)), from, 60, 1e-5, rms, steps);
      const Similarity T = icp_plane(S, index, VO, FO, near, o, o.iterations, 1e-6, rms, more);
      steps += more;
      // A transform that leaves the leak's edges over 16 times off the original's has collapsed
      // it onto a patch (or blown it up): judge() refuses it, so it cannot stand for a start
      // that registers it.
      const double edges = T.scale * edge_l / edge_o;
      const bool plausible = !(edges < 1.0 / 16 || edges > 16);
      if (plausible && rms / diagonal < (near_frame ? 0.5 : 1.0) * best.residual) {
        best.transform = T;
        best.residual = rms / diagonal;
        best.iterations = std::max(steps, 1);
      }
      // Registered well enough, or the other starts were far worse on the coarse subset (a
      // noisy leak cannot get below its noise): the other starts cannot matter.
      if (best.residual <= 1e-3 ||
          (!part && k + 1 < ranked.size() && ranked[k + 1].first / diagonal > 3 * best.residual))
        break;
    }
  };
  try_starts(starts, false);
  // No start brought a moved leak within 1e-3 of the diagonal: it may be a part of the
  // original (cropped), whose axes and spread are not the original's. The other matchings of
  // the axes, at both scales, then.
  // Tried when the best registers loosely and either fails or leaves the leak with another area
  // than the original's (a part; or a pose at a wrong scale), not for every noisy leak.
  if (!near_frame && !starts.empty()) {
    const double scaled = area(VL, FL) * best.transform.scale * best.transform.scale;
    const double ratio = scaled / std::max(area(VO, FO), 1e-300);
    if ((best.residual > 1e-3 &&
         (best.residual > o.max_residual || !(ratio > 0.9 && ratio < 1.1))) ||
        ratio < 0.25) {
      const double edge_scale = edge_o / edge_l;
      std::vector<Similarity> part =
          matched_face_starts(VL, FL, VO, FO, S, index, edge_scale, o.trim, o.seed, 4);
      const std::vector<Similarity> axes = principal_axis_starts(all_l, PO, true, edge_scale);
      part.insert(part.end(), axes.begin(), axes.end());
      try_starts(part, true);
    }
  }
  judge(best, index, S, all_l, diagonal, o.max_residual, edge_l / edge_o);
  return best;
}

}  // namespace meshmark
