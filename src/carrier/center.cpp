#include "meshmark/carrier/center.h"

#include <Eigen/Geometry>
#include <cmath>

#include <fmt/format.h>

#include "meshmark/core/error.h"
#include "meshmark/core/mesh.h"

namespace meshmark {

namespace {

Eigen::Vector3d discrete_center(const Eigen::MatrixX3d& V,
                                const std::vector<std::uint8_t>& referenced, double& count) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  count = 0;
  for (Eigen::Index i = 0; i < V.rows(); ++i)
    if (referenced[i] == kCounted) {
      sum += V.row(i).transpose();
      count += 1;
    }
  return count > 0 ? Eigen::Vector3d(sum / count) : sum;
}

// The positions relative to O as contiguous points: the face loops below gather three vertices
// per face, and a column-major #V x 3 matrix spreads each vertex over three cache lines.
// Relative to O (the discrete center), sums stay exact for meshes far from the origin.
std::vector<Eigen::Vector3d> relative_points(const Eigen::MatrixX3d& V, const Eigen::Vector3d& O) {
  std::vector<Eigen::Vector3d> Q(static_cast<std::size_t>(V.rows()));
  for (Eigen::Index i = 0; i < V.rows(); ++i) Q[i] = V.row(i).transpose() - O;
  return Q;
}

// Every quantity below is written with q_k = p_k - O. For a face, with s = q0 + q1 + q2:
//   S: weight A_f = w6 / 2 (w6 = |(q1 - q0) x (q2 - q0)|), centroid O + s / 3,
//      gradients grad_k A_f = g_k / 2 with g_k = n x (q_{k+2} - q_{k+1});
//   V: weight w_f = w6 / 6 (w6 = q0 . (q1 x q2)), centroid O + s / 4,
//      gradients grad_k w_f = g_k / 6 with g_k = q_{k+1} x q_{k+2}.
// With T = sum w6, D = C - O and d = 3 (S) or 4 (V), the center is C = O + sum w6 s / (d T)
// and the Jacobian (section 3, item 2) J_i = (1/T) sum_{f around i} [(s / d - D) g_k^T +
// (w6 / d) I]: one formula for both, with per-vertex sums that do not depend on C, so that
// the center and the Jacobian products come out of a single pass over the faces.
struct FaceGeometry {
  double w6 = 0;
  Eigen::Vector3d s;
  Eigen::Vector3d g[3];
};

template <CenterKind kind>
inline FaceGeometry face_geometry(const Eigen::Vector3d& q0, const Eigen::Vector3d& q1,
                                  const Eigen::Vector3d& q2, bool gradients) {
  FaceGeometry t;
  t.s = q0 + q1 + q2;
  if constexpr (kind == CenterKind::Surface) {
    const Eigen::Vector3d N = (q1 - q0).cross(q2 - q0);
    t.w6 = N.norm();
    if (gradients) {
      const Eigen::Vector3d n = t.w6 > 0 ? Eigen::Vector3d(N / t.w6) : Eigen::Vector3d::Zero();
      t.g[0] = n.cross(q2 - q1);
      t.g[1] = n.cross(q0 - q2);
      t.g[2] = n.cross(q1 - q0);
    }
  } else {
    t.g[0] = q1.cross(q2);
    t.w6 = q0.dot(t.g[0]);
    if (gradients) {
      t.g[1] = q2.cross(q0);
      t.g[2] = q0.cross(q1);
    }
  }
  return t;
}

// Sums over all faces. M and G (V with gradients) give the dependence through O.
struct FaceTotals {
  double T = 0, magnitude = 0;                   // sum w6, sum |w6|
  Eigen::Vector3d ws = Eigen::Vector3d::Zero();  // sum w6 s
  Eigen::Matrix3d M = Eigen::Matrix3d::Zero();   // sum s G^T, G = g0 + g1 + g2
  Eigen::Vector3d G = Eigen::Vector3d::Zero();   // sum G
};

// One pass over the faces; corner(i, geometry, k) for every corner k (vertex i) of every face
// when gradients are wanted.
constexpr Eigen::Index kPrefetchDistance = 16;

template <CenterKind kind, class Corner, class Ahead>
FaceTotals face_pass(const std::vector<Eigen::Vector3d>& Q, const Eigen::MatrixX3i& F,
                     bool gradients, Corner&& corner, Ahead&& ahead) {
  FaceTotals tot;
  const int* f0 = F.col(0).data();
  const int* f1 = F.col(1).data();
  const int* f2 = F.col(2).data();
  const Eigen::Index nf = F.rows();
  for (Eigen::Index f = 0; f < nf; ++f) {
    // Large meshes in an arbitrary vertex order miss the cache on most corners: ask for the
    // corners of a face some way ahead while this one computes.
    if (f + kPrefetchDistance < nf)
      for (const int* fk : {f0, f1, f2}) {
        __builtin_prefetch(&Q[fk[f + kPrefetchDistance]]);
        ahead(fk[f + kPrefetchDistance]);
      }
    const int i[3] = {f0[f], f1[f], f2[f]};
    const FaceGeometry t = face_geometry<kind>(Q[i[0]], Q[i[1]], Q[i[2]], gradients);
    tot.T += t.w6;
    tot.magnitude += std::abs(t.w6);
    tot.ws += t.w6 * t.s;
    if (!gradients) continue;
    for (int k = 0; k < 3; ++k) corner(i[k], t, k);
    if constexpr (kind == CenterKind::Volume) {
      const Eigen::Vector3d G = t.g[0] + t.g[1] + t.g[2];
      tot.M.noalias() += t.s * G.transpose();
      tot.G += G;
    }
  }
  return tot;
}

// ahead(i) is told of the vertices a few faces ahead, to prefetch what corner() will touch.
template <class Corner, class Ahead = void (*)(int)>
FaceTotals face_pass(
    CenterKind kind, const std::vector<Eigen::Vector3d>& Q, const Eigen::MatrixX3i& F,
    bool gradients, Corner&& corner, Ahead&& ahead = [](int) {}) {
  if (kind == CenterKind::Surface)
    return face_pass<CenterKind::Surface>(Q, F, gradients, corner, ahead);
  return face_pass<CenterKind::Volume>(Q, F, gradients, corner, ahead);
}

double centroid_divisor(CenterKind kind) {
  return kind == CenterKind::Surface ? 3.0 : 4.0;
}

Center center_from_totals(CenterKind kind, const Eigen::Vector3d& O, const FaceTotals& tot) {
  Center c;
  if (kind == CenterKind::Surface) {
    c.mass = tot.T / 2;  // w6 is twice each triangle's area
    c.well_defined = tot.T > 0;
  } else {
    c.mass = tot.T / 6;  // w6 is six times each tetrahedron's signed volume
    c.volume_consistency = tot.magnitude > 0 ? std::abs(tot.T) / tot.magnitude : 0;
    c.well_defined = c.volume_consistency > kVolumeCenterMinConsistency;
  }
  c.point = tot.T != 0 ? Eigen::Vector3d(O + tot.ws / (centroid_divisor(kind) * tot.T)) : O;
  return c;
}

// V: the dependence of C on O (the discrete center) as the 3 x 3 matrix every referenced
// vertex's Jacobian gains, dC/dO / n: with w_f written around O, moving O changes every
// tetrahedron; on closed meshes the sum vanishes up to rounding, on open ones it does not.
Eigen::Matrix3d reference_point_term(const FaceTotals& tot, const Eigen::Vector3d& D, double n) {
  const double d = centroid_divisor(CenterKind::Volume);
  Eigen::Matrix3d K = -tot.M / d + D * tot.G.transpose();
  K.diagonal().array() += tot.T / d;
  return K / (tot.T * n);
}

}  // namespace

Center center_of_mass(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                      const std::vector<std::uint8_t>& referenced, CenterKind kind) {
  double count = 0;
  const Eigen::Vector3d O = discrete_center(V, referenced, count);
  if (kind == CenterKind::Discrete) {
    Center c;
    c.point = O;
    c.mass = count;
    c.well_defined = count > 0;
    return c;
  }
  const FaceTotals tot =
      face_pass(kind, relative_points(V, O), F, false, [](int, const FaceGeometry&, int) {});
  return center_from_totals(kind, O, tot);
}

CenterJacobians center_jacobians(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                                 const std::vector<std::uint8_t>& referenced, CenterKind kind) {
  CenterJacobians out;
  out.J.assign(static_cast<std::size_t>(V.rows()), Eigen::Matrix3d::Zero());
  double n = 0;
  const Eigen::Vector3d O = discrete_center(V, referenced, n);
  if (kind == CenterKind::Discrete) {
    out.center = center_of_mass(V, F, referenced, kind);
    for (Eigen::Index i = 0; i < V.rows(); ++i)
      if (referenced[i] == kCounted) out.J[i] = Eigen::Matrix3d::Identity() / n;
    return out;
  }
  // J_i T = sum (s g^T + w6 I) / d - D sum g^T: the first sum in J, the second in B.
  std::vector<Eigen::Vector3d> B(out.J.size(), Eigen::Vector3d::Zero());
  const FaceTotals tot =
      face_pass(kind, relative_points(V, O), F, true, [&](int i, const FaceGeometry& t, int k) {
        out.J[i].noalias() += t.s * t.g[k].transpose();
        out.J[i].diagonal().array() += t.w6;
        B[i] += t.g[k];
      });
  out.center = center_from_totals(kind, O, tot);
  if (tot.T == 0) {
    for (auto& J : out.J) J.setZero();
    return out;
  }
  const Eigen::Vector3d D = out.center.point - O;
  const double d = centroid_divisor(kind);
  const Eigen::Matrix3d K =
      kind == CenterKind::Volume ? reference_point_term(tot, D, n) : Eigen::Matrix3d::Zero();
  for (Eigen::Index i = 0; i < V.rows(); ++i) {
    out.J[i] = (out.J[i] / d - D * B[i].transpose()) / tot.T;
    if (referenced[i] == kCounted) out.J[i] += K;
  }
  return out;
}

CenterProducts center_jacobian_products(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                                        const std::vector<std::uint8_t>& referenced,
                                        CenterKind kind, const Eigen::MatrixX3d& U) {
  CenterProducts out;
  out.E = Eigen::MatrixX3d::Zero(V.rows(), 3);
  double n = 0;
  const Eigen::Vector3d O = discrete_center(V, referenced, n);
  if (kind == CenterKind::Discrete) {
    out.center = center_of_mass(V, F, referenced, kind);
    for (Eigen::Index i = 0; i < V.rows(); ++i)
      if (referenced[i] == kCounted) out.E.row(i) = U.row(i) / n;
    return out;
  }
  // (J_i u_i) T = sum (s (g . u_i) + w6 u_i) / d - D sum g . u_i: a 3-vector and a scalar.
  struct Sums {
    Eigen::Vector3d a;
    double b;
  };
  std::vector<Eigen::Vector3d> Uv(static_cast<std::size_t>(U.rows()));
  for (Eigen::Index i = 0; i < U.rows(); ++i) Uv[i] = U.row(i).transpose();
  std::vector<Sums> acc(Uv.size(), Sums{Eigen::Vector3d::Zero(), 0.0});
  const FaceTotals tot = face_pass(
      kind, relative_points(V, O), F, true,
      [&](int i, const FaceGeometry& t, int k) {
        const double gu = t.g[k].dot(Uv[i]);
        acc[i].a += gu * t.s + t.w6 * Uv[i];
        acc[i].b += gu;
      },
      [&](int i) {
        __builtin_prefetch(&Uv[i]);
        __builtin_prefetch(&acc[i], 1);
      });
  out.center = center_from_totals(kind, O, tot);
  if (tot.T == 0) return out;
  const Eigen::Vector3d D = out.center.point - O;
  const double d = centroid_divisor(kind);
  const Eigen::Matrix3d K =
      kind == CenterKind::Volume ? reference_point_term(tot, D, n) : Eigen::Matrix3d::Zero();
  for (Eigen::Index i = 0; i < V.rows(); ++i) {
    Eigen::Vector3d e = (acc[i].a / d - D * acc[i].b) / tot.T;
    if (kind == CenterKind::Volume && referenced[i] == kCounted) e += K * Uv[i];
    out.E.row(i) = e.transpose();
  }
  return out;
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
