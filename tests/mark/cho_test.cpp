// Cho, Prost and Jung's Method I and II (cho.h) on meshmark's histogram: the exponent search
// against closed forms, the mapping's contract, read-back on real meshes with the bin
// statistics recomputed here independently, and invariance to similarity and reordering.

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <map>
#include <set>

#include "meshmark/attacks/attack.h"
#include "meshmark/core/error.h"
#include "meshmark/io/io.h"
#include "meshmark/mark/cho.h"
#include "meshmark/mark/decode.h"
#include "meshmark/mark/embed.h"
#include "test_data.h"

using namespace meshmark;
using namespace meshmark::test;

namespace {

// The score tolerance the embedder states (EmbedOptions::margin_tolerance) and the search's.
constexpr double kMarginTolerance = 1e-6;
constexpr double kSearchTolerance = 1e-6;

// Real meshes whose every referenced vertex is at a distinct position and whose faces all have
// area, so that the carrier is simply the referenced vertices (checked by clean_carrier).
std::vector<std::string> clean_meshes() {
  return {cgal_mesh("fandisk.off"), cgal_mesh("elephant.off"), cgal_mesh("camel.off"),
          cgal_mesh("bull.off"),    cgal_mesh("bear.off"),     cgal_mesh("head.off"),
          cgal_mesh("hand.off"),    closed_binary_ply()};
}

// The referenced vertices, after checking (independently of the library) that the carrier is
// exactly them: distinct positions, faces of nonzero area.
std::vector<bool> clean_carrier(const Mesh& m) {
  std::vector<bool> used(static_cast<std::size_t>(m.V.rows()), false);
  for (Eigen::Index f = 0; f < m.F.rows(); ++f) {
    const Eigen::Vector3d a = m.V.row(m.F(f, 0)), b = m.V.row(m.F(f, 1)), c = m.V.row(m.F(f, 2));
    EXPECT_GT((b - a).cross(c - a).norm(), 1e-12 * (b - a).squaredNorm()) << "face " << f;
    for (int k = 0; k < 3; ++k) used[m.F(f, k)] = true;
  }
  std::set<std::array<double, 3>> seen;
  for (Eigen::Index i = 0; i < m.V.rows(); ++i)
    if (used[i]) EXPECT_TRUE(seen.insert({m.V(i, 0), m.V(i, 1), m.V(i, 2)}).second) << i;
  return used;
}

// The paper's histogram, recomputed here: the discrete center (mean of the referenced
// vertices), nb + 2 bins over [rho_min, rho_max], and per bit bin the mean of t and of u^2.
struct Stats {
  Eigen::Vector3d center;
  double rho_min = 0, step = 0;
  std::vector<double> mean_t, mean_u2;
};

Stats statistics(const Eigen::MatrixX3d& V, const std::vector<bool>& used, int nb,
                 const Eigen::Vector3d* center = nullptr) {
  Stats s;
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  double n = 0;
  for (Eigen::Index i = 0; i < V.rows(); ++i)
    if (used[i]) c += V.row(i).transpose(), n += 1;
  s.center = center ? *center : Eigen::Vector3d(c / n);
  double lo = 1e300, hi = -1e300;
  for (Eigen::Index i = 0; i < V.rows(); ++i)
    if (used[i]) {
      const double r = (V.row(i).transpose() - s.center).norm();
      lo = std::min(lo, r), hi = std::max(hi, r);
    }
  s.rho_min = lo, s.step = (hi - lo) / (nb + 2);
  std::vector<double> st(nb, 0), su(nb, 0), cnt(nb, 0);
  for (Eigen::Index i = 0; i < V.rows(); ++i) {
    if (!used[i]) continue;
    const double x = ((V.row(i).transpose() - s.center).norm() - lo) / s.step;
    const int b = std::min(static_cast<int>(std::floor(x)), nb + 1);
    if (b < 1 || b > nb) continue;
    const double t = x - b, u = 2 * t - 1;
    st[b - 1] += t, su[b - 1] += u * u, cnt[b - 1] += 1;
  }
  for (int j = 0; j < nb; ++j)
    s.mean_t.push_back(st[j] / cnt[j]), s.mean_u2.push_back(su[j] / cnt[j]);
  return s;
}

}  // namespace

TEST(Cho, ExponentSearchMatchesTheClosedFormOfOnePosition) {
  // One position t0: its mean after mapping is t0^k, target m at k = ln m / ln t0.
  for (const double t0 : {0.2, 0.5, 0.7}) {
    for (const bool bit : {true, false}) {
      const double target = bit ? 0.55 : 0.45;
      const ChoBinMapping m = cho_search_exponent({t0}, BinStatistic::Mean, bit, target);
      const bool needs_move = bit ? t0 < target : t0 > target;
      if (!needs_move) {
        EXPECT_EQ(m.status, ChoSearchStatus::Unchanged);
        EXPECT_EQ(m.k, 1.0);
        continue;
      }
      ASSERT_EQ(m.status, ChoSearchStatus::Reached) << t0;
      EXPECT_NEAR(m.k, std::log(target) / std::log(t0), 1e-4);
      EXPECT_TRUE(bit ? m.score >= target : m.score <= target);
      EXPECT_NEAR(m.score, target, kSearchTolerance);
    }
  }
  // Variance: one position u0 = 2 t0 - 1; 3 |u0|^(2k) - 1/2 = target.
  const double t0 = 0.8, u0 = 0.6, target = 0.5 + 0.1;
  const ChoBinMapping v = cho_search_exponent({t0}, BinStatistic::Variance, true, target);
  ASSERT_EQ(v.status, ChoSearchStatus::Reached);
  EXPECT_NEAR(v.k, std::log((target + 0.5) / 3) / (2 * std::log(u0)), 1e-4);
}

TEST(Cho, ExponentSearchSaysWhenItCannot) {
  EXPECT_EQ(cho_search_exponent({}, BinStatistic::Mean, true, 0.55).status,
            ChoSearchStatus::Unreachable);
  // Half the positions at t = 0, which no power moves: the mean stays below 1/2.
  EXPECT_EQ(cho_search_exponent({0.0, 0.0, 0.3, 0.4}, BinStatistic::Mean, true, 0.55).status,
            ChoSearchStatus::Unreachable);
  // All at the middle (u = 0): the variance cannot grow.
  EXPECT_EQ(cho_search_exponent({0.5, 0.5}, BinStatistic::Variance, true, 0.55).status,
            ChoSearchStatus::Unreachable);
  // Too few steps for the tolerance: on the target's side, status Tolerance, never silent.
  ChoSettings few;
  few.max_iterations = 3;
  const ChoBinMapping m = cho_search_exponent({0.1, 0.2, 0.3}, BinStatistic::Mean, true, 0.55, few);
  EXPECT_EQ(m.status, ChoSearchStatus::Tolerance);
  EXPECT_GE(m.score, 0.55);
  EXPECT_GT(m.score - 0.55, kSearchTolerance);
}

TEST(Cho, OnePassMapsEachBinOntoItsTargetRadiallyInsideItsBin) {
  const std::string path = cgal_mesh("elephant.off");
  MESHMARK_REQUIRE(path, "elephant.off");
  const Mesh m = read_mesh(path);
  const std::vector<bool> used = clean_carrier(m);
  const int nb = 64;
  const Payload p = random_payload(nb, 5);
  for (const Method method : {Method::ChoMean, Method::ChoVariance}) {
    SCOPED_TRACE(method_name(method));
    EmbedOptions o;
    o.method = method;
    o.max_rounds = 1;  // Cho's single pass: the targets hold around the original center
    o.strength = 0.05;
    const EmbedResult r = embed(m.V, m.F, p, o);
    ASSERT_EQ(r.rounds, 1);
    const Stats before = statistics(m.V, used, nb);
    const Stats after = statistics(r.V, used, nb, &before.center);
    for (int j = 0; j < nb; ++j) {
      // Score on the decision scale: the mean, or 1/2 + (3 var - 1).
      auto score = [&](const Stats& s) {
        return method == Method::ChoMean ? s.mean_t[j] : 0.5 + 3 * s.mean_u2[j] - 1;
      };
      const double target = p.bits[j] ? 0.55 : 0.45;
      const bool met = p.bits[j] ? score(before) >= target : score(before) <= target;
      if (met) {
        EXPECT_NEAR(score(after), score(before), 1e-12) << "bit " << j << " needed no move";
      } else {
        EXPECT_GE((p.bits[j] ? 1 : -1) * (score(after) - target), -1e-12) << "bit " << j;
        EXPECT_LE(std::abs(score(after) - target), kSearchTolerance + 1e-12) << "bit " << j;
      }
    }
    // Radial moves that keep each vertex in its bin (of the original histogram).
    for (Eigen::Index i = 0; i < m.V.rows(); ++i) {
      if (!used[i]) continue;
      const Eigen::Vector3d a = m.V.row(i).transpose() - before.center;
      const Eigen::Vector3d b = r.V.row(i).transpose() - before.center;
      EXPECT_LT(a.cross(b).norm(), 1e-9 * a.squaredNorm()) << "vertex " << i;
      EXPECT_EQ(std::floor((a.norm() - before.rho_min) / before.step),
                std::floor((b.norm() - before.rho_min) / before.step))
          << "vertex " << i;
    }
  }
}

TEST(Cho, BothMethodsEmbedAndReadBack64BitsOnEightRealMeshes) {
  const int nb = 64;
  int meshes = 0;
  for (const std::string& path : clean_meshes()) {
    if (path.empty()) continue;
    SCOPED_TRACE(path);
    ++meshes;
    const Mesh m = read_mesh(path);
    const std::vector<bool> used = clean_carrier(m);
    for (const Method method : {Method::ChoMean, Method::ChoVariance}) {
      SCOPED_TRACE(method_name(method));
      const Payload p = random_payload(nb, 11 + meshes);
      EmbedOptions o;
      o.method = method;
      o.strength = 0.05;
      const EmbedResult r = embed(m.V, m.F, p, o);
      ASSERT_EQ(r.status, EmbedStatus::Embedded) << r.message;
      ExtractOptions xo;
      xo.method = method;
      const ExtractResult x = extract(r.V, m.F, xo);
      EXPECT_EQ(bit_error_rate(x.bits, p), 0.0);
      // The marked mesh's own histogram (recomputed here) meets every target: mean 1/2 +-
      // alpha, or variance (1 +- alpha) / 3, to the embedder's stated margin tolerance.
      const Stats s = statistics(r.V, used, nb);
      for (int j = 0; j < nb; ++j) {
        const double sign = p.bits[j] ? 1 : -1;
        if (method == Method::ChoMean)
          EXPECT_GE(sign * (s.mean_t[j] - 0.5), 0.05 - kMarginTolerance) << "bit " << j;
        else
          EXPECT_GE(sign * (s.mean_u2[j] - 1.0 / 3), 0.05 / 3 - kMarginTolerance / 3)
              << "bit " << j;
      }
      std::printf("%-16s %-13s rounds %d  RMS %.5f %% of the diagonal\n",
                  path.substr(path.find_last_of('/') + 1).c_str(), method_name(method), r.rounds,
                  r.rms_percent);
    }
  }
  if (meshes < 8) GTEST_FAIL() << "only " << meshes << " of the 8 meshes are available";
}

TEST(Cho, MarksReadTheSameAfterSimilarityAndReordering) {
  const std::string path = cgal_mesh("fandisk.off");
  MESHMARK_REQUIRE(path, "fandisk.off");
  Mesh m = read_mesh(path);
  const Payload p = random_payload(64, 3);
  for (const Method method : {Method::ChoMean, Method::ChoVariance}) {
    SCOPED_TRACE(method_name(method));
    EmbedOptions o;
    o.method = method;
    Mesh marked = m;
    marked.V = embed(m.V, m.F, p, o).V;
    ExtractOptions xo;
    xo.method = method;
    const ExtractResult reference = extract(marked.V, marked.F, xo);
    ASSERT_EQ(bit_error_rate(reference.bits, p), 0.0);
    for (std::uint64_t seed = 1; seed <= 3; ++seed) {
      SimilarityOptions so;
      so.max_scale = 10;
      const Mesh t = attack_reorder(attack_similarity(marked, seed, so), seed);
      const ExtractResult x = extract(t.V, t.F, xo);
      EXPECT_EQ(bit_error_rate(x.bits, p), 0.0);
      for (int j = 0; j < 64; ++j) EXPECT_NEAR(x.means[j], reference.means[j], 1e-9);
    }
  }
}

TEST(Cho, RefusesAVariantWithAnotherDirectionOrCost) {
  const Mesh m = bumpy_sphere(20, 20, 1);
  EmbedOptions o;
  o.method = Method::ChoMean;
  o.variant = parse_variant("VRL");
  EXPECT_THROW(embed(m.V, m.F, random_payload(16, 1), o), InvalidArgumentError);
  EXPECT_THROW(parse_method("cho"), InvalidArgumentError);
  EXPECT_EQ(parse_method("Cho-Variance"), Method::ChoVariance);
}
