// Cho et al.'s Method I and II (cho.h) as embed() runs them: rounds of histogram mapping, each
// around the center and histogram of the previous round's result, until every bit holds its
// margin as a reader rebuilding the histogram sees it.

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "mark/embed_problem.h"
#include "meshmark/carrier/histogram.h"
#include "meshmark/mark/cho.h"

namespace meshmark::detail {

namespace {

// The bins' positions: t of the counted vertices of bin j + 1 in t[j].
std::vector<std::vector<double>> bin_positions(const Histogram& h, int nb) {
  std::vector<std::vector<double>> t(static_cast<std::size_t>(nb));
  for (std::size_t i = 0; i < h.bin.size(); ++i) {
    const int j = h.bin[i] - 1;
    if (j >= 0 && j < nb) t[j].push_back(h.t(static_cast<Eigen::Index>(i)));
  }
  return t;
}

// Moves every carrier vertex of a bit's bin radially to its mapped distance. Vertices at one
// position (a counted one and its twins) get the same new position.
void apply_mapping(const Histogram& h, const std::vector<std::uint8_t>& referenced,
                   const std::vector<ChoBinMapping>& maps, BinStatistic statistic,
                   Eigen::MatrixX3d& W) {
  const int nb = h.bins - 2;
  for (Eigen::Index i = 0; i < W.rows(); ++i) {
    if (!referenced[i]) continue;
    const Eigen::Vector3d d = W.row(i).transpose() - h.center;
    const double rho = d.norm();
    if (!(rho > 0)) continue;
    const int b = std::min(static_cast<int>(std::floor((rho - h.rho_min) / h.step)), h.bins - 1);
    if (b < 1 || b > nb || maps[b - 1].k == 1) continue;
    const double t = std::clamp((rho - h.rho_min) / h.step - b, 0.0, 1.0);
    const double mapped = h.rho_min + h.step * (b + cho_map(statistic, t, maps[b - 1].k));
    W.row(i) = (h.center + d * (mapped / rho)).transpose();
  }
}

}  // namespace

void embed_cho(const Eigen::MatrixX3d& V, const EmbedContext& ctx, const Payload& payload,
               const EmbedOptions& options, EmbedResult& res) {
  const Eigen::MatrixX3i& F = *ctx.F;
  const int nb = payload.size();
  const BinStatistic statistic = bin_statistic(options.method);
  res.status = EmbedStatus::NotConverged;
  for (int round = 0; round < options.max_rounds; ++round) {
    // The histogram a reader of the current positions builds.
    const Center c = center_of_mass(res.V, F, ctx.referenced, options.variant.center);
    const Histogram h = build_histogram(res.V, ctx.referenced, c.point, nb);
    if (!h.valid()) {
      res.status = EmbedStatus::InvalidMesh;
      res.message = "the mesh has no histogram (its vertices are all at one distance)";
      res.V = V;
      return;
    }
    if (round == 0) res.bin_width = h.step;
    // Each bit's exponent; a bin that no exponent brings to its target stops the embedding.
    const std::vector<std::vector<double>> t = bin_positions(h, nb);
    std::vector<ChoBinMapping> maps(static_cast<std::size_t>(nb));
    std::vector<int> unreachable;
    for (int j = 0; j < nb; ++j) {
      const double alpha = bit_strength(options, j);
      const bool bit = payload.bits[j] != 0;
      maps[j] =
          cho_search_exponent(t[j], statistic, bit, bit ? 0.5 + alpha : 0.5 - alpha, options.cho);
      res.solver_iterations += maps[j].iterations;
      if (maps[j].status == ChoSearchStatus::Unreachable) unreachable.push_back(j);
    }
    if (!unreachable.empty()) {
      res.infeasible_bits = unreachable;
      res.message =
          fmt::format("{} bit(s) cannot reach their target by {}'s mapping: {}", unreachable.size(),
                      method_name(options.method), fmt::join(unreachable, ", "));
      if (round == 0) {
        res.status = EmbedStatus::Infeasible;
        res.V = V;
        return;
      }
      break;  // NotConverged, with the last round's positions
    }
    apply_mapping(h, ctx.referenced, maps, statistic, res.V);
    ++res.rounds;
    // Decode as a receiver would.
    const Center cw = center_of_mass(res.V, F, ctx.referenced, options.variant.center);
    const Histogram hw = build_histogram(res.V, ctx.referenced, cw.point, nb);
    res.margins = hw.valid() ? signed_margins(hw, payload, statistic)
                             : std::vector<double>(static_cast<std::size_t>(nb), -0.5);
    res.min_margin = *std::min_element(res.margins.begin(), res.margins.end());
    res.center_drift = (cw.point - ctx.original_center).norm() / res.bin_width;
    if (margins_held(res.margins, options)) {
      res.status = EmbedStatus::Embedded;
      break;
    }
  }
  measure_displacement(V, ctx.referenced, res);
  if (res.status == EmbedStatus::Embedded)
    res.message = fmt::format("{} bits embedded with {} in {} round(s)", nb,
                              method_name(options.method), res.rounds);
  else if (res.infeasible_bits.empty())
    res.message =
        fmt::format("after {} round(s) of {}: smallest margin {:.3g} (target {})", res.rounds,
                    method_name(options.method), res.min_margin, options.strength);
}

}  // namespace meshmark::detail
