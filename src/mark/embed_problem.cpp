#include "mark/embed_problem.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "carrier/shell_interval.h"
#include "meshmark/carrier/histogram.h"

namespace meshmark::detail {

namespace {

// The variant's direction for group g (first member `first`), before any fallback.
Eigen::Vector3d group_direction(const EmbedContext& ctx, DirectionKind kind,
                                const Eigen::MatrixX3d& N, int g, int first,
                                const Eigen::Vector3d& rhohat) {
  if (kind == DirectionKind::Radial) return rhohat;
  Eigen::Vector3d n = Eigen::Vector3d::Zero();
  for (int k = ctx.groups.offsets[g]; k < ctx.groups.offsets[g + 1]; ++k)
    n += N.row(ctx.groups.members[k]).transpose();
  if (n.norm() == 0) return rhohat;
  n.normalize();
  if (kind == DirectionKind::Normal) return n;
  // S: radial where rough; in smooth areas the radial direction projected on the tangent plane.
  if (ctx.smoothness(first) <= ctx.smooth_threshold) return rhohat;
  const Eigen::Vector3d tangent = rhohat - rhohat.dot(n) * n;
  const double len = tangent.norm();
  return len > 1e-9 ? Eigen::Vector3d(tangent / len) : rhohat;
}

}  // namespace

// B's row block i is u_gi e_gi^T - (1 / |N1(i)|) sum_j u_gj e_gj^T = sum_g c_ig u_g e_g^T, so
// (B^T B)_gh = (u_g . u_h) (C^T C)_gh with C the scalar matrix of the c_ig: topology only, built
// once per embedding (with the diagonal stored even where it is zero).
Eigen::SparseMatrix<double> laplacian_topology(const PositionGroups& groups,
                                               const Adjacency& adjacency) {
  const auto ng = static_cast<Eigen::Index>(groups.count());
  std::vector<Eigen::Triplet<double>> tc;
  Eigen::Index row = 0;
  for (std::size_t i = 0; i < groups.group_of.size(); ++i) {
    const int gi = groups.group_of[i];
    const int deg = adjacency.degree(static_cast<int>(i));
    if (gi < 0 || deg == 0) continue;
    tc.emplace_back(row, gi, 1.0);
    for (int k = adjacency.offsets[i]; k < adjacency.offsets[i + 1]; ++k) {
      const int gj = groups.group_of[adjacency.indices[k]];
      if (gj >= 0) tc.emplace_back(row, gj, -1.0 / deg);
    }
    ++row;
  }
  Eigen::SparseMatrix<double> C(row, ng);
  C.setFromTriplets(tc.begin(), tc.end());
  Eigen::SparseMatrix<double> zero_diagonal(ng, ng);
  std::vector<Eigen::Triplet<double>> td;
  for (Eigen::Index g = 0; g < ng; ++g) td.emplace_back(g, g, 0.0);
  zero_diagonal.setFromTriplets(td.begin(), td.end());
  Eigen::SparseMatrix<double> S = Eigen::SparseMatrix<double>(C.transpose() * C) + zero_diagonal;
  S.makeCompressed();
  return S;
}

LaplacianRows laplacian_rows(const PositionGroups& groups, const Adjacency& adjacency) {
  const std::size_t nv = groups.group_of.size();
  LaplacianRows rows;
  rows.row_group.assign(nv, -1);
  rows.inv_degree.assign(nv, 0.0);
  rows.neighbor_group.assign(adjacency.indices.size(), -1);
  rows.ctc_diagonal = Eigen::VectorXd::Zero(groups.count());
  std::vector<std::pair<int, double>> coefficients;  // one row's c_ig, merged per group
  for (std::size_t i = 0; i < nv; ++i) {
    const int gi = groups.group_of[i];
    const int deg = adjacency.degree(static_cast<int>(i));
    if (gi < 0 || deg == 0) continue;
    rows.row_group[i] = gi;
    rows.inv_degree[i] = 1.0 / deg;
    for (int k = adjacency.offsets[i]; k < adjacency.offsets[i + 1]; ++k)
      rows.neighbor_group[k] = groups.group_of[adjacency.indices[k]];
    coefficients.assign(1, {gi, 1.0});
    for (int k = adjacency.offsets[i]; k < adjacency.offsets[i + 1]; ++k)
      coefficients.emplace_back(groups.group_of[adjacency.indices[k]], -1.0 / deg);
    std::sort(coefficients.begin(), coefficients.end());
    for (std::size_t a = 0; a < coefficients.size();) {
      double c = 0;
      std::size_t b = a;
      for (; b < coefficients.size() && coefficients[b].first == coefficients[a].first; ++b)
        c += coefficients[b].second;
      rows.ctc_diagonal(coefficients[a].first) += c * c;
      a = b;
    }
  }
  return rows;
}

LaplacianOperator::LaplacianOperator(const EmbedContext& ctx, const Eigen::MatrixX3d& U,
                                     double lambda)
    : ctx_(&ctx), U_(&U), lambda_(lambda) {}

void LaplacianOperator::apply(const Eigen::VectorXd& x, Eigen::VectorXd& Hx) const {
  const PositionGroups& groups = ctx_->groups;
  const Adjacency& adj = ctx_->adjacency;
  const LaplacianRows& rows = ctx_->laplacian;
  const Eigen::MatrixX3d& U = *U_;
  const int ng = groups.count();
  const auto nv = static_cast<std::int64_t>(groups.group_of.size());
  v_.resize(static_cast<std::size_t>(ng));
  w_.resize(static_cast<std::size_t>(nv));
  t_.resize(static_cast<std::size_t>(nv));
  s_.resize(static_cast<std::size_t>(nv));
  for (int g = 0; g < ng; ++g) v_[g] = x(g) * U.row(g).transpose();
  // (B x)_i = v_gi - mean over N1(i) of v_gj, and t_i = (B x)_i / |N1(i)|.
  for (std::int64_t i = 0; i < nv; ++i) {
    const int gi = rows.row_group[i];
    if (gi < 0) {
      w_[i].setZero();
      t_[i].setZero();
      continue;
    }
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (int k = adj.offsets[i]; k < adj.offsets[i + 1]; ++k) sum += v_[rows.neighbor_group[k]];
    w_[i] = v_[gi] - rows.inv_degree[i] * sum;
    t_[i] = rows.inv_degree[i] * w_[i];
  }
  // (B^T w)_g = u_g . sum over g's vertices j of (w_j - sum over N1(j) of t_i): column j of
  // the neighbour terms gathered through the (symmetric) adjacency.
  for (std::int64_t j = 0; j < nv; ++j) {
    const int gj = groups.group_of[j];
    if (gj < 0) continue;
    Eigen::Vector3d sum = w_[j];
    for (int k = adj.offsets[j]; k < adj.offsets[j + 1]; ++k) sum -= t_[adj.indices[k]];
    s_[j] = U.row(gj).dot(sum);
  }
  Hx.resize(ng);
  for (int g = 0; g < ng; ++g) {
    double sum = 0;
    for (int k = groups.offsets[g]; k < groups.offsets[g + 1]; ++k) sum += s_[groups.members[k]];
    Hx(g) = lambda_ * x(g) + (1 - lambda_) * sum;
  }
}

Eigen::VectorXd LaplacianOperator::diagonal() const {
  Eigen::VectorXd d = (1 - lambda_) * ctx_->laplacian.ctc_diagonal;  // u_g . u_g = 1
  d.array() += lambda_;
  return d;
}

namespace {

// Laplacian-cost Hessian over groups: lambda I + (1 - lambda) B^T B (docs/method.md section 3;
// each position's squared displacement once), from the topology matrix and this round's
// directions: O(nonzeros), no sort.
Eigen::SparseMatrix<double> laplacian_hessian(const EmbedContext& ctx, const Eigen::MatrixX3d& U,
                                              double lambda) {
  Eigen::SparseMatrix<double> H = ctx.laplacian_topology;
  for (Eigen::Index g = 0; g < H.outerSize(); ++g)
    for (Eigen::SparseMatrix<double>::InnerIterator it(H, g); it; ++it) {
      it.valueRef() *= (1 - lambda) * U.row(it.row()).dot(U.row(g));
      if (it.row() == g) it.valueRef() += lambda;
    }
  return H;
}

// A bin whose vertices' directions cannot move its mean to the target (directions nearly
// tangent to the spheres, as normals on flat CAD panels) is given radial directions, as a
// single vertex is in case C1 of Algorithm 1. Counted in radial_fallbacks.
void fall_back_where_bins_cannot_reach(const EmbedContext& ctx, const Payload& payload,
                                       const EmbedOptions& o, const Eigen::MatrixX3d& V,
                                       const Histogram& h, const std::vector<int>& counts,
                                       RoundProblem& round) {
  SeparableQp& qp = round.qp;
  const Eigen::Index m = qp.b.size();
  Eigen::VectorXd reach = Eigen::VectorXd::Zero(m);
  for (Eigen::Index g = 0; g < qp.lo.size(); ++g)
    if (qp.row[g] >= 0) reach(qp.row[g]) += qp.a(g) * (qp.a(g) > 0 ? qp.hi(g) : qp.lo(g));
  for (int g = 0; g < static_cast<int>(qp.lo.size()); ++g) {
    const int j = qp.row[g];
    if (j < 0 || reach(j) >= qp.b(j) || qp.lo(g) == qp.hi(g)) continue;
    const int first = ctx.groups.members[ctx.groups.offsets[g]];
    const Eigen::Vector3d rhohat = (V.row(first).transpose() - h.center) / h.rho(first);
    const Eigen::Vector3d u = round.U.row(g).transpose();
    if (u == rhohat) continue;
    qp.a(g) = (payload.bits[j] ? 1.0 : -1.0) / counts[j];  // cos(psi) = 1
    qp.lo(g) = o.bin_offset - h.t(first);
    qp.hi(g) = 1 - o.bin_offset - h.t(first);
    round.U.row(g) = rhohat.transpose();
    ++round.radial_fallbacks;
  }
}

// Each group's direction u_g and the bounds of its step along it: radial for the positions at
// the extreme distances (fixed: they define the histogram's range) and where the variant's
// direction cannot reach the bin's shell (counted in round.radial_fallbacks); the payload rows'
// coefficients a_g.
void set_group_directions(const EmbedContext& ctx, const Payload& payload, const EmbedOptions& o,
                          const Eigen::MatrixX3d& V, const Eigen::MatrixX3d& N,
                          const std::vector<int>& counts, RoundProblem& round) {
  const Histogram& h = round.hist;
  SeparableQp& qp = round.qp;
  const int nb = payload.size(), ng = ctx.groups.count();
  const double s = h.step;
  round.U.resize(ng, 3);
  round.radial_fallbacks = 0;
  for (int g = 0; g < ng; ++g) {
    const int first = ctx.groups.members[ctx.groups.offsets[g]];  // the one that counts
    const double rho = h.rho(first), t = h.t(first);
    const int bin = h.bin[first];
    const Eigen::Vector3d rhohat = (V.row(first).transpose() - ctx.original_center) / rho;
    Eigen::Vector3d u = group_direction(ctx, o.variant.direction, N, g, first, rhohat);
    const bool extreme = rho == h.rho_min || rho == h.rho_max;
    if (extreme) {
      u = rhohat;
      qp.lo(g) = qp.hi(g) = 0;
    } else if (u == rhohat) {
      qp.lo(g) = o.bin_offset - t;
      qp.hi(g) = 1 - o.bin_offset - t;
    } else {
      const double lower = h.rho_min + s * (bin + o.bin_offset),
                   upper = h.rho_min + s * (bin + 1 - o.bin_offset);
      const ShellInterval iv = shell_interval(rho, rhohat.dot(u), lower, upper);
      if (iv.empty()) {  // C1: this direction cannot reach the bin's shell
        u = rhohat;
        ++round.radial_fallbacks;
        qp.lo(g) = o.bin_offset - t;
        qp.hi(g) = 1 - o.bin_offset - t;
      } else {
        qp.lo(g) = iv.lo / s;
        qp.hi(g) = iv.hi / s;
      }
    }
    round.U.row(g) = u.transpose();
    if (bin >= 1 && bin <= nb) {
      qp.row[g] = bin - 1;
      qp.a(g) = (payload.bits[bin - 1] ? 1.0 : -1.0) * rhohat.dot(u) / counts[bin - 1];
    }
    qp.h(g) = 1;  // the position's squared displacement, once however many vertices share it
  }
}

// The center rows: e_g = sum over the group's vertices of J_i u_g, and the center itself,
// brought back where it was. False, with a message, when the center is ill-defined.
bool set_center_rows(const EmbedContext& ctx, const EmbedOptions& o, const Eigen::MatrixX3d& V,
                     RoundProblem& round, std::string& message) {
  SeparableQp& qp = round.qp;
  const int ng = ctx.groups.count();
  // When every vertex is referenced and alone at its position (the common case), group g is
  // vertex g and the per-vertex directions are the groups'.
  const bool one_to_one = ng == V.rows();
  Eigen::MatrixX3d Uv;
  if (!one_to_one) {
    Uv.setZero(V.rows(), 3);
    for (int g = 0; g < ng; ++g)
      for (int k = ctx.groups.offsets[g]; k < ctx.groups.offsets[g + 1]; ++k)
        Uv.row(ctx.groups.members[k]) = round.U.row(g);
  }
  const CenterProducts cp = center_jacobian_products(V, *ctx.F, ctx.referenced, o.variant.center,
                                                     one_to_one ? round.U : Uv);
  round.center = cp.center;
  if (!round.center.well_defined) {
    message = fmt::format(
        "the {} center is ill-defined for this mesh (|sum of signed volumes| / sum of volumes = "
        "{:.2g}): open or inconsistently oriented",
        center_letter(o.variant.center), round.center.volume_consistency);
    return false;
  }
  qp.c = (ctx.original_center - round.center.point) / round.hist.step;
  if (one_to_one) {
    qp.e = cp.E.transpose();
  } else {
    qp.e.setZero();
    for (int g = 0; g < ng; ++g)
      for (int k = ctx.groups.offsets[g]; k < ctx.groups.offsets[g + 1]; ++k)
        qp.e.col(g) += cp.E.row(ctx.groups.members[k]).transpose();
  }
  return true;
}

// Cost Q: q_g = sum over the faces around the group of (u . n_f)^2, the quadric error of moving
// along u, mixed with the displacement by lambda.
void set_quadric_costs(const EmbedContext& ctx, const EmbedOptions& o, const Eigen::MatrixX3d& V,
                       RoundProblem& round) {
  const Eigen::MatrixX3i& F = *ctx.F;
  SeparableQp& qp = round.qp;
  const Eigen::MatrixX3d FN = face_normals(V, F);
  Eigen::VectorXd q = Eigen::VectorXd::Zero(ctx.groups.count());
  for (Eigen::Index t = 0; t < F.rows(); ++t)
    for (int c = 0; c < 3; ++c) {
      const int g = ctx.groups.group_of[F(t, c)];
      const double d = round.U.row(g).dot(FN.row(t));
      q(g) += d * d;
    }
  qp.h = o.lambda * qp.h + (1 - o.lambda) * q;
  qp.h = qp.h.cwiseMax(1e-12 * qp.h.maxCoeff());  // keep the cost strictly convex
}

}  // namespace

bool build_round(const EmbedContext& ctx, const Payload& payload, const EmbedOptions& o,
                 const Eigen::MatrixX3d& V, bool assemble_hessian, RoundProblem& round,
                 std::string& message) {
  const int nb = payload.size(), ng = ctx.groups.count();
  // Distances are measured from the original center, where this round puts the center back:
  // the decoder will see them so (up to the center's second-order error), and the rows need not
  // model the shift of every distance that bringing the center back causes.
  round.hist = build_histogram(V, ctx.referenced, ctx.original_center, nb);
  const Histogram& h = round.hist;
  if (!h.valid()) {
    message =
        "no histogram: the mesh has no referenced vertex or all lie at one distance from the "
        "center";
    return false;
  }
  std::vector<double> means;
  std::vector<int> counts;
  bin_means(h, means, counts);
  const bool need_normals = o.variant.direction != DirectionKind::Radial;
  const Eigen::MatrixX3d N = need_normals ? vertex_normals(V, *ctx.F) : Eigen::MatrixX3d();

  SeparableQp& qp = round.qp;
  qp.h.resize(ng);
  qp.lo.resize(ng);
  qp.hi.resize(ng);
  qp.a = Eigen::VectorXd::Zero(ng);
  qp.row.assign(static_cast<std::size_t>(ng), -1);
  qp.e.resize(3, ng);
  qp.b.resize(nb);
  for (int j = 0; j < nb; ++j) {
    const double m = payload.bits[j] ? 1.0 : -1.0;
    const double alpha = bit_strength(o, j);
    qp.b(j) = counts[j] > 0 ? alpha - m * (means[j] - 0.5) : alpha;
  }
  set_group_directions(ctx, payload, o, V, N, counts, round);
  fall_back_where_bins_cannot_reach(ctx, payload, o, V, h, counts, round);
  if (!set_center_rows(ctx, o, V, round, message)) return false;
  if (o.variant.cost == CostKind::Quadric) set_quadric_costs(ctx, o, V, round);
  if (assemble_hessian) round.H = laplacian_hessian(ctx, round.U, o.lambda);
  return true;
}

}  // namespace meshmark::detail
