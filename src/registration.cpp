#include "meshmark/registration.h"

#include <fmt/format.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <vector>

#include "meshmark/closest_point.h"
#include "meshmark/error.h"
#include "meshmark/histogram.h"
#include "meshmark/mesh.h"
#include "meshmark/random.h"

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

// Trimmed ICP from start: returns the transform, its trimmed RMS and the steps taken.
// with_scale false: the scale stays as it is (rigid steps); true: Umeyama's similarity.
Similarity icp(const Eigen::MatrixX3d& S, const SurfaceIndex& original, Similarity T,
               const RegistrationOptions& o, bool with_scale, double& rms, int& steps) {
  const Eigen::Index n = S.rows();
  const Eigen::Index keep = std::max<Eigen::Index>(3, static_cast<Eigen::Index>(o.trim * n));
  std::vector<Eigen::Index> order(static_cast<std::size_t>(n));
  rms = std::numeric_limits<double>::infinity();
  for (steps = 0; steps < o.iterations; ++steps) {
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
    if (std::abs(previous - now) <= 1e-10 * now) break;  // converged
  }
  // The residual of the final transform.
  const ClosestPoints cp = original.query(T.apply(S));
  std::vector<double> d(cp.distance.data(), cp.distance.data() + n);
  std::nth_element(d.begin(), d.begin() + (keep - 1), d.end());
  double sum = 0;
  for (Eigen::Index k = 0; k < keep; ++k) sum += d[k] * d[k];
  rms = std::sqrt(sum / keep);
  return T;
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
  for (Eigen::Index i = 0; i < VL.rows(); ++i)
    if (used_l[i]) rows.push_back(i);
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
  Eigen::MatrixX3d PO(std::count(used_o.begin(), used_o.end(), 1), 3);
  for (Eigen::Index i = 0, k = 0; i < VO.rows(); ++i)
    if (used_o[i]) PO.row(k++) = VO.row(i);
  const double diagonal = bounding_box_diagonal(VO, used_o);

  // Starts: the identity, then the principal axes matched in the four proper ways.
  std::vector<Similarity> starts(1);
  Eigen::Vector3d mean_l, mean_o;
  Eigen::Matrix3d cov_l, cov_o;
  Eigen::MatrixX3d all_l(static_cast<Eigen::Index>(std::count(used_l.begin(), used_l.end(), 1)), 3);
  for (Eigen::Index i = 0, k = 0; i < VL.rows(); ++i)
    if (used_l[i]) all_l.row(k++) = VL.row(i);
  moments(all_l, mean_l, cov_l);
  moments(PO, mean_o, cov_o);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> el(cov_l), eo(cov_o);
  const double scale = std::sqrt(cov_o.trace() / std::max(cov_l.trace(), 1e-300));
  for (const Eigen::Vector3d& signs : {Eigen::Vector3d(1, 1, 1), Eigen::Vector3d(1, -1, -1),
                                       Eigen::Vector3d(-1, 1, -1), Eigen::Vector3d(-1, -1, 1)}) {
    Eigen::Matrix3d R = eo.eigenvectors() * signs.asDiagonal() * el.eigenvectors().transpose();
    if (R.determinant() < 0) R = -R;  // eigenvector bases may be left-handed
    Similarity s;
    s.rotation = R;
    s.scale = scale;
    s.translation = mean_o - scale * R * mean_l;
    starts.push_back(s);
  }
  const SurfaceIndex index(VO, FO);
  RegistrationResult best;
  best.residual = std::numeric_limits<double>::infinity();
  // A leak near the original's frame (what decimation, remeshing, smoothing, noise, cropping
  // and compression tools give) is refined from the identity only, and kept as it is unless
  // that halves its residual: fitting a transform to an unmoved leak would absorb part of the
  // mark (a scale that shrinks or grows the bins' radii).
  double at_identity = 0;
  {
    const ClosestPoints cp = index.query(S);
    std::vector<double> d(cp.distance.data(), cp.distance.data() + S.rows());
    const auto keep = static_cast<std::size_t>(std::max(3.0, o.trim * S.rows()));
    std::nth_element(d.begin(), d.begin() + (keep - 1), d.end());
    double sum = 0;
    for (std::size_t k = 0; k < keep; ++k) sum += d[k] * d[k];
    at_identity = std::sqrt(sum / keep) / diagonal;
  }
  const bool near_frame = at_identity <= o.in_frame;
  if (near_frame) {
    starts.resize(1);  // the identity
    best.residual = at_identity;
  }
  for (const Similarity& start : starts) {
    // Rigid steps first at the start's scale (a free scale from a poor start collapses the leak
    // onto a patch of the original), then the similarity from there.
    double rms = 0;
    int steps = 0, more = 0;
    const Similarity rigid = icp(S, index, start, o, false, rms, steps);
    const Similarity T = icp(S, index, rigid, o, true, rms, more);
    steps += more;
    if (rms / diagonal < (near_frame ? 0.5 : 1.0) * best.residual) {
      best.transform = T;
      best.residual = rms / diagonal;
      best.iterations = steps;
    }
    if (best.residual <= 1e-3) break;  // registered well enough: the other starts cannot matter
  }
  const ClosestPoints cp = index.query(best.transform.apply(S));
  const double near = std::max(3 * best.residual, 1e-3) * diagonal;
  best.overlap = static_cast<double>((cp.distance.array() <= near).count()) / S.rows();
  best.status =
      best.residual <= o.max_residual ? RegistrationStatus::Registered : RegistrationStatus::Failed;
  best.message = fmt::format(
      "{}{}: residual {:.3g} of the diagonal, {:.0f} % of the leak near the "
      "original, scale {:.6f}",
      best.status == RegistrationStatus::Registered ? "registered" : "FAILED",
      best.iterations == 0 ? " (in the original's frame)" : "", best.residual, 100 * best.overlap,
      best.transform.scale);
  return best;
}

}  // namespace meshmark
