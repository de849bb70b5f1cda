#pragma once
/// \file cho.h
/// Cho, Prost and Jung's histogram mapping (IEEE TSP 55(1), 2007), the baseline the QP
/// framework improves on, on meshmark's histogram (histogram.h): in each bin carrying a bit,
/// every position t in [0, 1) is mapped by a power function of one exponent k, searched until
/// the bin's score (method.h) reaches its target, and the vertex moves radially from the
/// center to the mapped distance. Method I maps t to t^k (the bin mean moves to 1/2 +- alpha);
/// Method II maps u = 2t - 1 to sign(u) |u|^k (the bin variance of u moves to (1 +- alpha)/3).
/// Both keep 0 and 1 in place, so every vertex stays in its bin. embed() (embed.h) runs them
/// when EmbedOptions::method asks; docs/cho.md lists what was implemented and every choice.

#include <vector>

#include "meshmark/carrier/method.h"
#include "meshmark/core/enum_names.h"

namespace meshmark {

/// Settings of the exponent search of Cho's methods.
struct ChoSettings {
  /// A bin's score after mapping lies in [target, target + tolerance] for bit 1 (in
  /// [target - tolerance, target] for bit 0), score units (bin widths for the mean).
  double tolerance = 1e-6;
  /// Steps of the exponent search per bin at most (bracketing by halving or doubling k,
  /// then bisection of log k).
  int max_iterations = 200;
};

/// How one bin's exponent search ended.
enum class ChoSearchStatus {
  Unchanged,    ///< the bin already met its target: k = 1, nothing moves
  Reached,      ///< the score is on the target's side and within the tolerance of it
  Tolerance,    ///< on the target's side, but max_iterations ran out before the tolerance
  Unreachable,  ///< no exponent reaches the target (an empty bin, or too many positions
                ///< at t = 0 or |u| = 0 or 1, which no power moves)
};

/// The names of ChoSearchStatus's values (cho_search_status_name).
template <>
struct EnumTable<ChoSearchStatus> {
  static constexpr const char* what = "Cho search status";
  static constexpr NamedValue<ChoSearchStatus> values[] = {
      {ChoSearchStatus::Unchanged, "unchanged"},
      {ChoSearchStatus::Reached, "reached"},
      {ChoSearchStatus::Tolerance, "tolerance"},
      {ChoSearchStatus::Unreachable, "unreachable"}};
};

/// One bin's exponent.
struct ChoBinMapping {
  ChoSearchStatus status = ChoSearchStatus::Unreachable;
  double k = 1;        ///< the exponent (> 0)
  double score = 0;    ///< the bin's score with it (method.h's scale)
  int iterations = 0;  ///< evaluations of the score
};

/// Cho's mapping of a position t in [0, 1] with exponent k > 0: t^k for the mean statistic;
/// (1 + sign(u) |u|^k) / 2, u = 2t - 1, for the variance statistic.
double cho_map(BinStatistic statistic, double t, double k);

/// The exponent k with which the positions t (in [0, 1)) of one bin reach a score of at least
/// target (bit 1) or at most target (bit 0), the score being the mean of
/// bin_score_term(statistic, cho_map(statistic, t, k)): k = 1 when they already do, else the k
/// whose score is within settings.tolerance of the target on its side. The score decreases
/// with k, so the search brackets k by halving (bit 1) or doubling (bit 0) from 1, then
/// bisects log k.
ChoBinMapping cho_search_exponent(const std::vector<double>& t, BinStatistic statistic, bool bit,
                                  double target, const ChoSettings& settings = {});

/// "unchanged", "reached", "tolerance", "unreachable".
const char* cho_search_status_name(ChoSearchStatus status);

}  // namespace meshmark
