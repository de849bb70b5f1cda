#pragma once
/// \file method.h
/// The embedding methods meshmark offers on one histogram, payload layout, key and ID coding:
/// the constrained-optimization framework of Rolland-Neviere, Doerr and Alliez (IEEE TIFS
/// 2014, the default), and, as baselines, the two histogram-mapping methods of Cho, Prost and
/// Jung ("An oblivious watermarking for 3-D polygonal meshes using distribution of vertex
/// norms", IEEE TSP 55(1), 2007), which it improves on (docs/cho.md).

#include <string>
#include <string_view>

#include "meshmark/carrier/variant.h"
#include "meshmark/core/enum_names.h"

namespace meshmark {

/// Who moves the vertices, and which bin statistic carries a bit.
enum class Method {
  Qp,           ///< the QP framework (embed.h): bin means to 1/2 +- alpha at least distortion
  ChoMean,      ///< Cho et al.'s Method I: bin means to 1/2 +- alpha by a power mapping t^k
  ChoVariance,  ///< Cho et al.'s Method II: bin variances to (1 +- alpha)/3 by |u|^k mapping
};

/// The names of Method's values (method_name).
template <>
struct EnumTable<Method> {
  static constexpr const char* what = "method";
  static constexpr NamedValue<Method> values[] = {
      {Method::Qp, "qp"}, {Method::ChoMean, "cho-mean"}, {Method::ChoVariance, "cho-variance"}};
};

/// Which statistic of a bin's normalized positions t in [0, 1) carries its bit.
enum class BinStatistic {
  Mean,      ///< the mean of t (QP and Cho's Method I)
  Variance,  ///< the mean of u^2, u = 2t - 1 in [-1, 1) (Cho's Method II)
};

/// The statistic a method writes and a reader of its marks reads.
constexpr BinStatistic bin_statistic(Method method) {
  return method == Method::ChoVariance ? BinStatistic::Variance : BinStatistic::Mean;
}

/// A vertex's contribution to its bin's score, so that the score (the mean of the
/// contributions over the bin) reads bit 1 above 1/2 and bit 0 below, and a mark of strength
/// alpha sits at 1/2 +- alpha for either statistic:
/// - Mean: t (the score is the bin mean);
/// - Variance: 3 u^2 - 1/2, u = 2t - 1 (the score is 1/2 + (3 var - 1) with var the mean of
///   u^2, which is 1/3 for uniform positions and (1 +- alpha)/3 when marked).
/// \param t position in the bin, in [0, 1]
constexpr double bin_score_term(BinStatistic statistic, double t) {
  if (statistic == BinStatistic::Mean) return t;
  const double u = 2 * t - 1;
  return 3 * u * u - 0.5;
}

/// "qp", "cho-mean", "cho-variance".
const char* method_name(Method method);

/// Parses a method's name (method_name; any case).
/// \throw InvalidArgumentError naming the method and the ones there are.
Method parse_method(std::string_view name);

/// How a mark is written: a method and its variant (for Cho's methods only the center letter
/// varies: DRS, SRS or VRS). Campaigns list schemes where they list variants.
struct MarkScheme {
  Method method = Method::Qp;
  Variant variant;
  /// The QP framework's: its variant's name ("VRL"); Cho's: the method's name ("cho-mean"),
  /// followed by "/SRS" or "/VRS" when the center is not the discrete one.
  std::string name() const;
};

/// Parses a scheme's name (MarkScheme::name; any case; "cho-mean/DRS" is "cho-mean").
/// \throw InvalidArgumentError naming what is wrong (an unknown method, a bad variant, or a
///        variant other than ?RS for Cho's methods).
MarkScheme parse_scheme(std::string_view name);

}  // namespace meshmark
