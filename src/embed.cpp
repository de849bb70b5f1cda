#include "meshmark/embed.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "meshmark/decode.h"
#include "meshmark/error.h"
#include "meshmark/mesh.h"

namespace meshmark {

namespace {

// Per-group data of one round: groups of identical positions share one unknown.
struct Round {
  Histogram hist;
  SeparableQp qp;
  Eigen::MatrixX3d U;  // per vertex unit direction of displacement (radial)
};

void check_options(const Payload& payload, const EmbedOptions& o) {
  if (payload.size() < 1) throw InvalidArgumentError("the payload is empty");
  if (!(o.strength > 0 && o.strength < 0.5))
    throw InvalidArgumentError(fmt::format("strength {} is outside (0, 1/2)", o.strength));
  if (!(o.bin_offset >= 0 && o.bin_offset < 0.5))
    throw InvalidArgumentError(fmt::format("bin offset {} is outside [0, 1/2)", o.bin_offset));
  if (o.max_rounds < 1) throw InvalidArgumentError("max_rounds must be at least 1");
  if (o.center != CenterKind::Discrete)
    throw InvalidArgumentError("only the discrete center (variant DRS) is implemented so far");
}

PositionGroups singleton_groups(const std::vector<std::uint8_t>& referenced) {
  PositionGroups g;
  g.group_of.assign(referenced.size(), -1);
  for (std::size_t i = 0; i < referenced.size(); ++i) {
    if (!referenced[i]) continue;
    g.group_of[i] = static_cast<int>(g.members.size());
    g.members.push_back(static_cast<int>(i));
    g.offsets.push_back(static_cast<int>(g.members.size()));
  }
  return g;
}

// The quadratic program of one round in units of the bin width: x_g = r_g / s.
// Cost sum_i r_i^2 (variant ..S); watermark rows m_j (1/N_j) sum (t_i + x_i) - 1/2 >= alpha;
// center rows sum_i J_i u_i x_i = 0 with J_i = I / n for the discrete center; boxes
// [G - t_i, 1 - G - t_i], zero for the vertices attaining rho_min or rho_max.
void build_problem(const Eigen::MatrixX3d& V, const PositionGroups& groups, const Payload& payload,
                   const EmbedOptions& o, Round& r) {
  const Histogram& h = r.hist;
  const int nb = payload.size(), ng = groups.count();
  std::vector<double> means;
  std::vector<int> counts;
  bin_means(h, means, counts);
  double n_ref = 0;
  for (int b : h.bin) n_ref += b >= 0;
  r.U.resize(V.rows(), 3);
  SeparableQp& qp = r.qp;
  qp.h.resize(ng);
  qp.lo.resize(ng);
  qp.hi.resize(ng);
  qp.a.resize(ng);
  qp.row.assign(static_cast<std::size_t>(ng), -1);
  qp.e.resize(3, ng);
  qp.b.resize(nb);
  for (int j = 0; j < nb; ++j) {
    const double m = payload.bits[j] ? 1.0 : -1.0;
    qp.b(j) = counts[j] > 0 ? o.strength - m * (means[j] - 0.5) : o.strength;
  }
  for (int g = 0; g < ng; ++g) {
    const int first = groups.members[groups.offsets[g]];
    const double w = groups.offsets[g + 1] - groups.offsets[g];
    const Eigen::Vector3d u = (V.row(first).transpose() - h.center) / h.rho(first);
    for (int k = groups.offsets[g]; k < groups.offsets[g + 1]; ++k)
      r.U.row(groups.members[k]) = u.transpose();
    const int bin = h.bin[first];
    const double t = h.t(first);
    const bool extreme = h.rho(first) == h.rho_min || h.rho(first) == h.rho_max;
    qp.h(g) = w;
    qp.lo(g) = extreme ? 0.0 : o.bin_offset - t;
    qp.hi(g) = extreme ? 0.0 : 1.0 - o.bin_offset - t;
    qp.e.col(g) = (w / n_ref) * u;
    qp.a(g) = 0;
    if (bin >= 1 && bin <= nb) {
      const int j = bin - 1;
      qp.row[g] = j;
      qp.a(g) = (payload.bits[j] ? 1.0 : -1.0) * w / counts[j];
    }
  }
}

// Signed margins m_j (tbar_j - 1/2) of the payload's bits in a histogram (-1/2 when empty).
std::vector<double> signed_margins(const Histogram& h, const Payload& payload) {
  std::vector<double> means;
  std::vector<int> counts;
  bin_means(h, means, counts);
  std::vector<double> margins(means.size());
  for (std::size_t j = 0; j < means.size(); ++j)
    margins[j] = counts[j] > 0 ? (payload.bits[j] ? 1.0 : -1.0) * (means[j] - 0.5) : -0.5;
  return margins;
}

void measure(const Eigen::MatrixX3d& V, const std::vector<std::uint8_t>& referenced,
             EmbedResult& res) {
  double sum = 0, n = 0;
  for (Eigen::Index i = 0; i < V.rows(); ++i) {
    const double d2 = (res.V.row(i) - V.row(i)).squaredNorm();
    res.squared_displacement += d2;
    if (referenced[i]) sum += d2, n += 1;
  }
  res.rms_displacement = n > 0 ? std::sqrt(sum / n) : 0;
  const double diag = bounding_box_diagonal(V, referenced);
  res.rms_percent = diag > 0 ? 100.0 * res.rms_displacement / diag : 0;
}

}  // namespace

const char* embed_status_name(EmbedStatus status) {
  switch (status) {
    case EmbedStatus::Embedded:
      return "embedded";
    case EmbedStatus::Infeasible:
      return "infeasible";
    case EmbedStatus::NotConverged:
      return "not converged";
    case EmbedStatus::InvalidMesh:
      return "invalid mesh";
  }
  return "?";
}

EmbedResult embed(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F, const Payload& payload,
                  const EmbedOptions& options) {
  check_options(payload, options);
  const auto start = std::chrono::steady_clock::now();
  EmbedResult res;
  res.V = V;
  const auto referenced = referenced_vertices(F, V.rows());
  const PositionGroups groups = options.keep_duplicates_together
                                    ? group_identical_positions(V, referenced)
                                    : singleton_groups(referenced);
  const Center c0 = center_of_mass(V, F, referenced, options.center);
  Round round;
  round.hist = build_histogram(V, referenced, c0.point, payload.size());
  const double s0 = round.hist.step;
  res.bin_width = s0;
  auto elapsed = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };
  if (!c0.well_defined || !round.hist.valid()) {
    res.status = EmbedStatus::InvalidMesh;
    res.message =
        !c0.well_defined
            ? "the center of mass is not defined for this mesh"
            : "no histogram: the mesh has no referenced vertex or all lie at one distance";
    res.seconds = elapsed();
    return res;
  }
  Eigen::VectorXd warm;
  for (int k = 0; k < options.max_rounds; ++k) {
    build_problem(res.V, groups, payload, options, round);
    const QpResult sol =
        solve_separable_qp(round.qp, options.solver, warm.size() ? &warm : nullptr);
    ++res.rounds;
    res.solver_iterations += sol.iterations;
    res.solver_status = sol.status;
    res.kkt_residual = std::max(sol.primal_residual, sol.complementarity);
    if (sol.status == QpStatus::Infeasible) {
      res.status = EmbedStatus::Infeasible;
      res.infeasible_bits = sol.infeasible_rows;
      res.V = V;
      res.message =
          sol.infeasible_rows.empty()
              ? "the bits cannot be embedded while the center stays fixed"
              : fmt::format("{} bit(s) cannot reach their target inside their bins: {}",
                            sol.infeasible_rows.size(), fmt::join(sol.infeasible_rows, ", "));
      res.seconds = elapsed();
      return res;
    }
    for (int g = 0; g < groups.count(); ++g)
      for (int q = groups.offsets[g]; q < groups.offsets[g + 1]; ++q) {
        const int i = groups.members[q];
        res.V.row(i) += (round.hist.step * sol.x(g)) * round.U.row(i);
      }
    // Decode as a receiver would and stop once every bit holds its margin and the center stays.
    const Center c = center_of_mass(res.V, F, referenced, options.center);
    round.hist = build_histogram(res.V, referenced, c.point, payload.size());
    res.margins = signed_margins(round.hist, payload);
    res.min_margin = *std::min_element(res.margins.begin(), res.margins.end());
    res.center_drift = (c.point - c0.point).norm() / s0;
    warm = sol.y;
    if (sol.status == QpStatus::Solved &&
        res.min_margin >= options.strength - options.margin_tolerance &&
        res.center_drift <= options.center_tolerance) {
      res.status = EmbedStatus::Embedded;
      break;
    }
    res.status = EmbedStatus::NotConverged;
  }
  measure(V, referenced, res);
  res.message = res.status == EmbedStatus::Embedded
                    ? fmt::format("{} bits embedded in {} round(s)", payload.size(), res.rounds)
                    : fmt::format(
                          "after {} round(s): smallest margin {:.3g} (target {}), center drift "
                          "{:.3g} bins, solver {}",
                          res.rounds, res.min_margin, options.strength, res.center_drift,
                          qp_status_name(res.solver_status));
  res.seconds = elapsed();
  return res;
}

}  // namespace meshmark
