#include "meshmark/mark/embed.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "mark/embed_problem.h"
#include "mark/qp_solver.h"
#include "meshmark/carrier/histogram.h"
#include "meshmark/core/error.h"
#include "meshmark/core/mesh.h"

namespace meshmark {

bool detail::margins_held(const std::vector<double>& margins, const EmbedOptions& options) {
  for (std::size_t j = 0; j < margins.size(); ++j) {
    const double alpha = bit_strength(options, static_cast<int>(j));
    if (margins[j] < alpha - std::min(options.margin_tolerance, 0.5 * alpha)) return false;
  }
  return true;
}

namespace {

void check_options(const Payload& payload, const EmbedOptions& o) {
  if (payload.size() < 1) throw InvalidArgumentError("the payload is empty");
  if (!(o.strength > 0 && o.strength < 0.5))
    throw InvalidArgumentError(fmt::format("strength {} is outside (0, 1/2)", o.strength));
  if (!o.strengths.empty() && static_cast<int>(o.strengths.size()) != payload.size())
    throw InvalidArgumentError(
        fmt::format("{} strengths for a payload of {} bits", o.strengths.size(), payload.size()));
  for (std::size_t j = 0; j < o.strengths.size(); ++j)
    if (!(o.strengths[j] >= o.strength && o.strengths[j] < 0.5))
      throw InvalidArgumentError(
          fmt::format("bit {}'s strength {} is outside [strength, 1/2) = [{}, 0.5)", j,
                      o.strengths[j], o.strength));
  if (!(o.bin_offset >= 0 && o.bin_offset < 0.5))
    throw InvalidArgumentError(fmt::format("bin offset {} is outside [0, 1/2)", o.bin_offset));
  if (!(o.lambda >= 0 && o.lambda <= 1))
    throw InvalidArgumentError(fmt::format("lambda {} is outside [0, 1]", o.lambda));
  if (o.max_rounds < 1) throw InvalidArgumentError("max_rounds must be at least 1");
  if (o.method != Method::Qp &&
      (o.variant.direction != DirectionKind::Radial || o.variant.cost != CostKind::Squared))
    throw InvalidArgumentError(fmt::format(
        "method {} moves vertices radially and has no cost to weigh: its variant is DRS, SRS "
        "or VRS (the center's letter), not {}",
        method_name(o.method), o.variant.name()));
  if (o.method != Method::Qp && !(o.cho.tolerance > 0 && o.cho.max_iterations >= 1))
    throw InvalidArgumentError("Cho's exponent search needs a positive tolerance and iterations");
}

}  // namespace

std::vector<double> detail::signed_margins(const Histogram& h, const Payload& payload,
                                           BinStatistic statistic) {
  std::vector<double> means;
  std::vector<int> counts;
  bin_means(h, means, counts, statistic);
  std::vector<double> margins(means.size());
  for (std::size_t j = 0; j < means.size(); ++j)
    margins[j] = counts[j] > 0 ? (payload.bits[j] ? 1.0 : -1.0) * (means[j] - 0.5) : -0.5;
  return margins;
}

void detail::measure_displacement(const Eigen::MatrixX3d& V,
                                  const std::vector<std::uint8_t>& referenced, EmbedResult& res) {
  double sum = 0, n = 0;
  res.squared_displacement = 0;
  for (Eigen::Index i = 0; i < V.rows(); ++i) {
    const double d2 = (res.V.row(i) - V.row(i)).squaredNorm();
    res.squared_displacement += d2;
    if (referenced[i] == kCounted) sum += d2, n += 1;  // each position once
  }
  res.rms_displacement = n > 0 ? std::sqrt(sum / n) : 0;
  const double diag = bounding_box_diagonal(V, referenced);
  res.rms_percent = diag > 0 ? 100.0 * res.rms_displacement / diag : 0;
}

namespace {

// Everything that depends on the mesh and the variant only: groups, adjacency (L), the
// roughness field (S), the center.
void make_context(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F, const EmbedOptions& o,
                  detail::EmbedContext& ctx) {
  ctx.F = &F;
  ctx.referenced = carrier_vertices(V, F);
  ctx.groups = group_identical_positions(V, ctx.referenced);
  if (o.variant.cost == CostKind::Laplacian) {
    ctx.adjacency = vertex_adjacency(F, V.rows());
    ctx.laplacian = detail::laplacian_rows(ctx.groups, ctx.adjacency);
    if (detail::needs_assembled_hessian(o))
      ctx.laplacian_topology = detail::laplacian_topology(ctx.groups, ctx.adjacency);
  }
  if (o.variant.direction == DirectionKind::Smooth) {
    const RoughnessField field = roughness_field(V, F, o.roughness);
    ctx.smoothness = field.smoothness;
    ctx.smooth_threshold = field.smooth_threshold;
  }
  ctx.original_center = center_of_mass(V, F, ctx.referenced, o.variant.center).point;
}

bool same_roughness(const RoughnessOptions& a, const RoughnessOptions& b) {
  return a.curvature_radius == b.curvature_radius && a.smoothing_sigma == b.smoothing_sigma &&
         a.window_sigma == b.window_sigma && a.outlier_quantile == b.outlier_quantile;
}

}  // namespace

const char* embed_status_name(EmbedStatus status) {
  return enum_name(status);
}

struct PreparedEmbedder::Impl {
  Eigen::MatrixX3d V;
  Eigen::MatrixX3i F;
  EmbedOptions prepared;  // the variant, roughness and solver the context was built for
  detail::EmbedContext ctx;
};

PreparedEmbedder::PreparedEmbedder(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                                   const EmbedOptions& options) {
  validate_mesh(V, F);
  auto impl = std::make_shared<Impl>();
  impl->V = V;
  impl->F = F;
  impl->prepared = options;
  make_context(impl->V, impl->F, options, impl->ctx);
  impl_ = std::move(impl);
}

bool PreparedEmbedder::accepts(const EmbedOptions& o) const {
  const EmbedOptions& p = impl_->prepared;
  // The solvers keep no state across embeddings; only an assembled Hessian needs preparing.
  return o.variant == p.variant && same_roughness(o.roughness, p.roughness) &&
         (!detail::needs_assembled_hessian(o) || detail::needs_assembled_hessian(p));
}

const Eigen::MatrixX3d& PreparedEmbedder::V() const {
  return impl_->V;
}

const Eigen::MatrixX3i& PreparedEmbedder::F() const {
  return impl_->F;
}

CarrierCheck PreparedEmbedder::check(int nb) const {
  const detail::EmbedContext& ctx = impl_->ctx;
  return check_carrier(ctx.referenced,
                       build_histogram(impl_->V, ctx.referenced, ctx.original_center, nb));
}

EmbedResult embed(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F, const Payload& payload,
                  const EmbedOptions& options) {
  check_options(payload, options);
  // The time covers the preparation too (VSS's roughness field is most of a one-shot embed).
  const auto start = std::chrono::steady_clock::now();
  EmbedResult res = PreparedEmbedder(V, F, options).embed(payload, options);
  res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return res;
}

EmbedResult PreparedEmbedder::embed(const Payload& payload, const EmbedOptions& options) const {
  check_options(payload, options);
  if (!accepts(options))
    throw InvalidArgumentError(fmt::format(
        "the embedder was prepared for variant {} (its roughness constants, and an assembled "
        "Hessian or not), not for variant {} with these settings",
        impl_->prepared.variant.name(), options.variant.name()));
  const Eigen::MatrixX3d& V = impl_->V;
  const Eigen::MatrixX3i& F = impl_->F;
  const detail::EmbedContext& ctx = impl_->ctx;
  const auto start = std::chrono::steady_clock::now();
  auto elapsed = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };
  EmbedResult res;
  res.V = V;
  res.check = check(payload.size());
  if (res.check.status == CarrierHealth::Unusable) {
    res.status = EmbedStatus::InvalidMesh;
    res.message = res.check.summary();
    res.seconds = elapsed();
    return res;
  }
  if (options.method != Method::Qp) {
    detail::embed_cho(V, ctx, payload, options, res);
    res.seconds = elapsed();
    return res;
  }
  detail::RoundProblem round;
  detail::RoundSolver solver(options);
  const bool assemble = detail::needs_assembled_hessian(options);
  for (int k = 0; k < options.max_rounds; ++k) {
    if (!detail::build_round(ctx, payload, options, res.V, assemble, round, res.message)) {
      res.status = EmbedStatus::InvalidMesh;
      res.V = V;
      res.seconds = elapsed();
      return res;
    }
    const double s = round.hist.step;
    if (k == 0) res.bin_width = s;
    const QpResult sol = solver.solve(ctx, round);
    ++res.rounds;
    res.solver_iterations += sol.iterations;
    res.solver_status = sol.status;
    res.kkt_residual = std::max({sol.primal_residual, sol.complementarity, sol.dual_residual});
    res.radial_fallbacks = round.radial_fallbacks;
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
    const auto& groups = ctx.groups;
    for (int g = 0; g < groups.count(); ++g)
      for (int q = groups.offsets[g]; q < groups.offsets[g + 1]; ++q)
        res.V.row(groups.members[q]) += (s * sol.x(g)) * round.U.row(g);
    // Decode as a receiver would; stop once every bit holds its margin and the center stays.
    const Center c = center_of_mass(res.V, F, ctx.referenced, options.variant.center);
    const Histogram h = build_histogram(res.V, ctx.referenced, c.point, payload.size());
    res.margins = detail::signed_margins(h, payload);
    res.min_margin = *std::min_element(res.margins.begin(), res.margins.end());
    res.center_drift = (c.point - ctx.original_center).norm() / res.bin_width;
    res.status = EmbedStatus::NotConverged;
    if (sol.status == QpStatus::Solved && detail::margins_held(res.margins, options) &&
        res.center_drift <= options.center_tolerance) {
      res.status = EmbedStatus::Embedded;
      break;
    }
  }
  detail::measure_displacement(V, ctx.referenced, res);
  res.message = res.status == EmbedStatus::Embedded
                    ? fmt::format("{} bits embedded with {} in {} round(s)", payload.size(),
                                  options.variant.name(), res.rounds)
                    : fmt::format(
                          "after {} round(s): smallest margin {:.3g} (target {}), center drift "
                          "{:.3g} bins, solver {}",
                          res.rounds, res.min_margin, options.strength, res.center_drift,
                          qp_status_name(res.solver_status));
  res.seconds = elapsed();
  return res;
}

double bit_strength(const EmbedOptions& options, int j) {
  return options.strengths.empty() ? options.strength
                                   : options.strengths[static_cast<std::size_t>(j)];
}

}  // namespace meshmark
