#include "meshmark/center.h"

#include <Eigen/Geometry>
#include <cmath>

#include <fmt/format.h>

#include "meshmark/error.h"

namespace meshmark {

namespace {

Eigen::Vector3d discrete_center(const Eigen::MatrixX3d& V,
                                const std::vector<std::uint8_t>& referenced, double& count) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  count = 0;
  for (Eigen::Index i = 0; i < V.rows(); ++i)
    if (referenced[i]) {
      sum += V.row(i).transpose();
      count += 1;
    }
  return count > 0 ? Eigen::Vector3d(sum / count) : sum;
}

// The positions as contiguous points: the face loops below gather three vertices per face, and
// a column-major #V x 3 matrix spreads each vertex over three cache lines.
std::vector<Eigen::Vector3d> to_points(const Eigen::MatrixX3d& V) {
  std::vector<Eigen::Vector3d> P(static_cast<std::size_t>(V.rows()));
  for (Eigen::Index i = 0; i < V.rows(); ++i) P[i] = V.row(i).transpose();
  return P;
}

// One face's weight (area or signed volume) and its center.
struct FaceTerm {
  double w;
  Eigen::Vector3d c;
};

FaceTerm face_term(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1, const Eigen::Vector3d& p2,
                   const Eigen::Vector3d& O, CenterKind kind) {
  if (kind == CenterKind::Surface)
    return {0.5 * (p1 - p0).cross(p2 - p0).norm(), (p0 + p1 + p2) / 3.0};
  return {(p0 - O).dot((p1 - O).cross(p2 - O)) / 6.0, (O + p0 + p1 + p2) / 4.0};
}

}  // namespace

Center center_of_mass(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                      const std::vector<std::uint8_t>& referenced, CenterKind kind) {
  Center c;
  double count = 0;
  const Eigen::Vector3d d = discrete_center(V, referenced, count);
  if (kind == CenterKind::Discrete) {
    c.point = d;
    c.quality = count;
    c.well_defined = count > 0;
    return c;
  }
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  double weight = 0, magnitude = 0;
  const std::vector<Eigen::Vector3d> P = to_points(V);
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const FaceTerm t = face_term(P[F(f, 0)], P[F(f, 1)], P[F(f, 2)], d, kind);
    sum += t.w * t.c;
    weight += t.w;
    magnitude += std::abs(t.w);
  }
  if (kind == CenterKind::Surface) {
    c.quality = weight;
    c.well_defined = weight > 0;
  } else {
    c.quality = magnitude > 0 ? std::abs(weight) / magnitude : 0;
    c.well_defined = c.quality > kVolumeCenterMinQuality;
  }
  c.point = weight != 0 ? Eigen::Vector3d(sum / weight) : d;
  return c;
}

namespace {

// Visits every face's contribution to the Jacobians of the S or V center: visit(f, k, a, g,
// share) for corner k of face f means J_{F(f,k)} += a g^T + share I (before division by W).
// Returns W and accumulates dC/dO (V only; times W).
template <class Visit>
double visit_jacobian_terms(const std::vector<Eigen::Vector3d>& P, const Eigen::MatrixX3i& F,
                            const Eigen::Vector3d& O, const Eigen::Vector3d& C, CenterKind kind,
                            Eigen::Matrix3d& dC_dO, Visit&& visit) {
  double W = 0;
  dC_dO.setZero();
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Eigen::Vector3d& p0 = P[F(f, 0)];
    const Eigen::Vector3d& p1 = P[F(f, 1)];
    const Eigen::Vector3d& p2 = P[F(f, 2)];
    const Eigen::Vector3d* p[3] = {&p0, &p1, &p2};
    const FaceTerm t = face_term(p0, p1, p2, O, kind);
    W += t.w;
    Eigen::Vector3d grad[3];
    if (kind == CenterKind::Surface) {
      const Eigen::Vector3d N = (p1 - p0).cross(p2 - p0);
      const double len = N.norm();
      const Eigen::Vector3d nf = len > 0 ? Eigen::Vector3d(N / len) : Eigen::Vector3d::Zero();
      for (int k = 0; k < 3; ++k) grad[k] = 0.5 * nf.cross(*p[(k + 2) % 3] - *p[(k + 1) % 3]);
    } else {
      for (int k = 0; k < 3; ++k) grad[k] = (*p[(k + 1) % 3] - O).cross(*p[(k + 2) % 3] - O) / 6.0;
    }
    const double share = kind == CenterKind::Surface ? t.w / 3.0 : t.w / 4.0;
    const Eigen::Vector3d a = t.c - C;
    for (int k = 0; k < 3; ++k) visit(f, k, a, grad[k], share);
    if (kind == CenterKind::Volume) {
      dC_dO -= a * (grad[0] + grad[1] + grad[2]).transpose();
      dC_dO.diagonal().array() += share;
    }
  }
  return W;
}

}  // namespace

CenterJacobians center_jacobians(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                                 const std::vector<std::uint8_t>& referenced, CenterKind kind) {
  CenterJacobians out;
  out.center = center_of_mass(V, F, referenced, kind);
  out.J.assign(static_cast<std::size_t>(V.rows()), Eigen::Matrix3d::Zero());
  double n = 0;
  const Eigen::Vector3d O = discrete_center(V, referenced, n);
  if (kind == CenterKind::Discrete) {
    for (Eigen::Index i = 0; i < V.rows(); ++i)
      if (referenced[i]) out.J[i] = Eigen::Matrix3d::Identity() / n;
    return out;
  }
  Eigen::Matrix3d dC_dO;
  const double W = visit_jacobian_terms(
      to_points(V), F, O, out.center.point, kind, dC_dO,
      [&](Eigen::Index f, int k, const Eigen::Vector3d& a, const Eigen::Vector3d& g, double share) {
        Eigen::Matrix3d& J = out.J[F(f, k)];
        J.noalias() += a * g.transpose();
        J.diagonal().array() += share;
      });
  if (W == 0) return out;
  for (Eigen::Index i = 0; i < V.rows(); ++i) {
    out.J[i] /= W;
    if (kind == CenterKind::Volume && referenced[i]) out.J[i] += dC_dO / (W * n);
  }
  return out;
}

Eigen::MatrixX3d center_jacobian_products(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                                          const std::vector<std::uint8_t>& referenced,
                                          CenterKind kind, const Eigen::Vector3d& center,
                                          const Eigen::MatrixX3d& U) {
  Eigen::MatrixX3d E = Eigen::MatrixX3d::Zero(V.rows(), 3);
  double n = 0;
  const Eigen::Vector3d O = discrete_center(V, referenced, n);
  if (kind == CenterKind::Discrete) {
    for (Eigen::Index i = 0; i < V.rows(); ++i)
      if (referenced[i]) E.row(i) = U.row(i) / n;
    return E;
  }
  Eigen::Matrix3d dC_dO;
  const std::vector<Eigen::Vector3d> Uv = to_points(U);
  std::vector<Eigen::Vector3d> acc(Uv.size(), Eigen::Vector3d::Zero());
  const double W = visit_jacobian_terms(
      to_points(V), F, O, center, kind, dC_dO,
      [&](Eigen::Index f, int k, const Eigen::Vector3d& a, const Eigen::Vector3d& g, double share) {
        const Eigen::Index i = F(f, k);
        acc[i] += a * g.dot(Uv[i]) + share * Uv[i];
      });
  for (Eigen::Index i = 0; i < V.rows(); ++i) E.row(i) = acc[i].transpose();
  if (W == 0) return E;
  E /= W;
  if (kind == CenterKind::Volume)
    for (Eigen::Index i = 0; i < V.rows(); ++i)
      if (referenced[i]) E.row(i) += (dC_dO * U.row(i).transpose()).transpose() / (W * n);
  return E;
}

CenterKind center_from_letter(char letter) {
  switch (letter) {
    case 'D':
    case 'd':
      return CenterKind::Discrete;
    case 'S':
    case 's':
      return CenterKind::Surface;
    case 'V':
    case 'v':
      return CenterKind::Volume;
    default:
      break;
  }
  throw InvalidArgumentError(fmt::format("unknown center '{}' (expected D, S or V)", letter));
}

char center_letter(CenterKind kind) {
  return kind == CenterKind::Discrete ? 'D' : kind == CenterKind::Surface ? 'S' : 'V';
}

}  // namespace meshmark
