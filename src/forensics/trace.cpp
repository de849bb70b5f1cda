#include "meshmark/forensics/trace.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <functional>
#include <future>
#include <limits>
#include <map>
#include <optional>
#include <tuple>

#include "core/parallel.h"
#include "core/progress_counter.h"
#include "meshmark/attacks/attack.h"
#include "meshmark/carrier/histogram.h"
#include "meshmark/carrier/method.h"
#include "meshmark/carrier/variant.h"
#include "meshmark/core/error.h"
#include "meshmark/forensics/fingerprint.h"
#include "meshmark/protocol/coding.h"
#include "meshmark/protocol/detect.h"
#include "meshmark/protocol/watermark.h"
#include "metrics/closest_point.h"

namespace meshmark {

const char* trace_status_name(TraceStatus status) {
  return enum_name(status);
}

namespace {

// The readings trace scores every candidate on: bits whose shift lies within this distance of
// the middle between the hypotheses (position 0.5, see position()) are erased. A candidate's
// p-value is its smallest over the readings times their number (Bonferroni).
constexpr std::array<double, 3> kBands = {0.0, 0.2, 0.35};

// Where the rays from center through the counted rows of P (carrier[i] == kCounted) cross the
// surface (V, F): the plane of the nearest face, or the nearest point itself where the ray runs
// nearly along that plane or crosses it farther than `erase` from it; rows with no face within
// `erase` are not crossed. Also each crossing's face, barycentric weights and face normal.
struct Crossings {
  Eigen::MatrixX3d point;             ///< #P x 3 (P's own row where not crossed)
  std::vector<std::uint8_t> crossed;  ///< #P
  std::vector<int> face;              ///< #P, -1 where not crossed
  Eigen::MatrixX3d barycentric;       ///< #P x 3, of the nearest point on the face
  Eigen::MatrixX3d normal;            ///< #P x 3, unit normal of the face
  std::size_t counted = 0, found = 0;
};

// Crossings of the rows of P with none crossed yet (each row's point its own).
Crossings uncrossed(const Eigen::MatrixX3d& P) {
  Crossings x;
  x.point = P;
  x.crossed.assign(static_cast<std::size_t>(P.rows()), 0);
  x.face.assign(static_cast<std::size_t>(P.rows()), -1);
  x.barycentric = Eigen::MatrixX3d::Zero(P.rows(), 3);
  x.normal = Eigen::MatrixX3d::Zero(P.rows(), 3);
  return x;
}

Crossings cross_rays(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                     const Eigen::MatrixX3d& P, const std::vector<std::uint8_t>& carrier,
                     const Eigen::Vector3d& center, double erase) {
  std::vector<Eigen::Index> rows;
  for (Eigen::Index i = 0; i < P.rows(); ++i)  // each position once
    if (carrier[i] == kCounted) rows.push_back(i);
  Eigen::MatrixX3d Q(static_cast<Eigen::Index>(rows.size()), 3);
  for (std::size_t k = 0; k < rows.size(); ++k) Q.row(k) = P.row(rows[k]);
  const ClosestPoints cp = closest_points(V, F, Q);
  Crossings x = uncrossed(P);
  x.counted = rows.size();
  for (std::size_t k = 0; k < rows.size(); ++k) {
    if (!(cp.distance(k) <= erase)) continue;
    const Eigen::Vector3d q = cp.point.row(k).transpose();
    const Eigen::Vector3d a = V.row(F(cp.face[k], 0)), b = V.row(F(cp.face[k], 1)),
                          c = V.row(F(cp.face[k], 2));
    const Eigen::Vector3d n = (b - a).cross(c - a).normalized();
    const Eigen::Vector3d dir = (Q.row(k).transpose() - center).normalized();
    const double along = dir.dot(n);
    Eigen::Vector3d p = q;
    if (std::abs(along) > 0.1) {
      const Eigen::Vector3d hit = center + dir * ((a - center).dot(n) / along);
      if ((hit - q).norm() <= erase) p = hit;
    }
    const Eigen::Index i = rows[k];
    x.point.row(i) = p.transpose();
    x.crossed[i] = 1;
    x.face[i] = cp.face[k];
    x.barycentric.row(i) = cp.barycentric.row(k);
    x.normal.row(i) = n.transpose();
    ++x.found;
  }
  return x;
}

// For a leak P with the surface's faces F (noise, quantization, smoothing, an average of
// copies: vertex i is vertex i), each counted row within `erase` of its own vertex V_i is
// "crossed" there: point V_i, a face of F holding it with its barycentric weight 1, and the
// ray's direction from the center through P_i as the normal, so that a reading at P's
// vertices measures |P_i - c| - |V_i - c| (the leak's radial change at the vertex) and a
// surface motion delta at V_i moves it by delta's radial part. Read through a face's plane,
// as cross_rays does, the noise's part along the surface came in times the surface's slope.
Crossings cross_vertices(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                         const Eigen::MatrixX3d& P, const std::vector<std::uint8_t>& carrier,
                         const Eigen::Vector3d& center, double erase) {
  Crossings x = uncrossed(P);
  std::vector<int> slot(static_cast<std::size_t>(P.rows()), -1);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k)
      if (x.face[F(f, k)] < 0) x.face[F(f, k)] = static_cast<int>(f), slot[F(f, k)] = k;
  for (Eigen::Index i = 0; i < P.rows(); ++i) {
    if (carrier[i] != kCounted) {
      x.face[i] = -1;
      continue;
    }
    ++x.counted;
    const Eigen::Vector3d ray = P.row(i).transpose() - center;
    if (x.face[i] < 0 || !((P.row(i) - V.row(i)).norm() <= erase) || !(ray.norm() > 0)) {
      x.face[i] = -1;
      continue;
    }
    x.point.row(i) = V.row(i);
    x.crossed[i] = 1;
    x.barycentric(i, slot[i]) = 1;
    x.normal.row(i) = ray.normalized().transpose();
    ++x.found;
  }
  return x;
}

Resampled measure(const Eigen::MatrixX3d& VL, const Eigen::MatrixX3i& FL,
                  const Eigen::MatrixX3d& VO, const std::vector<std::uint8_t>& carrier,
                  const Eigen::Vector3d& center, double erase) {
  Crossings x = cross_rays(VL, FL, VO, carrier, center, erase);
  Resampled m;
  m.point = std::move(x.point);
  m.measured = std::move(x.crossed);
  m.fraction = x.counted ? static_cast<double>(x.found) / x.counted : 0;
  return m;
}

// Where a bin's shift lies between the attenuated hypotheses: 0 at a 0, 1 at a 1.
double position(const BitEvidence& e) {
  const double span = e.if_one - e.if_zero;
  return span != 0 ? (e.shift - e.if_zero) / span : 0.5;
}

// Each bin's evidence (bin order; shift detrended; bit: the nearer hypothesis, kErasure for a
// bin with nothing measured) and the fitted attenuation gamma. gamma and a linear trend are
// first the least-squares fit of the shifts to the hypotheses they are nearer to, then refitted
// on the confident bins only (those outside the middle band of kBands' widest width), so that
// bins a mark does not explain (an average of two copies moves the bins where they differ to
// the middle) do not pull gamma down.
std::vector<BitEvidence> read_bins(const Eigen::MatrixX3d& VO, const Eigen::VectorXd& reference,
                                   const std::vector<std::uint8_t>& carrier, const Histogram& h,
                                   const Resampled& m, const std::vector<double>& alpha,
                                   BinStatistic statistic, double& gamma) {
  const int nb = h.bins - 2;
  std::vector<double> sum0(nb, 0), sum(nb, 0);
  std::vector<int> count(nb, 0);
  for (Eigen::Index i = 0; i < VO.rows(); ++i) {
    if (carrier[i] != kCounted || !m.measured[i]) continue;
    const int j = h.bin[i] - 1;
    if (j < 0 || j >= nb) continue;
    const double rho = (m.point.row(i).transpose() - h.center).norm();
    // The reference: the original, or the original processed as the leak seems to have been.
    // Each on the bins' score scale (method.h: t itself for the mean).
    sum0[j] += bin_score_term(statistic, (reference(i) - h.rho_min) / h.step - h.bin[i]);
    sum[j] += bin_score_term(statistic, (rho - h.rho_min) / h.step - h.bin[i]);
    ++count[j];
  }
  std::vector<double> shift(nb, 0), up(nb, 0), down(nb, 0);
  for (int j = 0; j < nb; ++j) {
    if (!count[j]) continue;
    const double m0 = sum0[j] / count[j];
    shift[j] = (sum[j] - sum0[j]) / count[j];
    up[j] = 0.5 + alpha[j] - m0;  // the shift a 1 asks for
    down[j] = 0.5 - alpha[j] - m0;
  }
  // shift_j = gamma e_j + a + b x_j: the mark's attenuated shift plus a trend linear in the
  // bin's radius x_j (a residue of scale from registration, or a shrinkage, moves every bin by
  // about a + b x_j; the mark's signs are keyed, so they do not follow it).
  std::vector<double> x(nb);
  for (int j = 0; j < nb; ++j) x[j] = (j + 0.5) / nb - 0.5;
  std::vector<BitEvidence> ev(nb);
  double a = 0, b = 0;
  auto classify = [&](double g) {
    for (int j = 0; j < nb; ++j) {
      const double s = shift[j] - a - b * x[j];
      ev[j] = {s, g * up[j], g * down[j], count[j], kErasure};
      if (count[j]) ev[j].bit = std::abs(s - ev[j].if_one) < std::abs(s - ev[j].if_zero);
    }
  };
  // Least squares for (gamma, a, b) over the measured bins (or the confident ones), each bin
  // against the hypothesis it is nearer to, until the bits stop changing.
  auto fit = [&](double g, bool confident_only) {
    for (int round = 0; round < 20; ++round) {
      classify(g);
      Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
      Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
      int used = 0;
      for (int j = 0; j < nb; ++j) {
        if (!count[j]) continue;
        if (confident_only && std::abs(position(ev[j]) - 0.5) < kBands.back()) continue;
        const Eigen::Vector3d row(ev[j].bit ? up[j] : down[j], 1.0, x[j]);
        A += row * row.transpose(), rhs += row * shift[j], ++used;
      }
      if (used < 8) break;  // too few bins to fit a trend besides the mark
      const Eigen::Vector3d solution = A.ldlt().solve(rhs);
      if (!solution.allFinite()) break;
      const double next = std::clamp(solution(0), 0.02, 2.0);
      const bool settled = std::abs(next - g) < 1e-12 && std::abs(solution(1) - a) < 1e-12 &&
                           std::abs(solution(2) - b) < 1e-12;
      g = next, a = solution(1), b = solution(2);
      if (settled) break;
    }
    return g;
  };
  gamma = fit(fit(1.0, false), true);
  classify(gamma);
  return ev;
}

// The bits (bin order) with those whose position lies within `band` of the middle erased.
std::vector<std::uint8_t> banded_bits(const std::vector<BitEvidence>& ev, double band) {
  std::vector<std::uint8_t> bits(ev.size(), kErasure);
  for (std::size_t j = 0; j < ev.size(); ++j)
    if (ev[j].vertices && !(std::abs(position(ev[j]) - 0.5) < band)) bits[j] = ev[j].bit;
  return bits;
}

// The distance from center of a surface through P's vertices, where the leak was measured:
// for a leak measured along rays, where the tangent plane at P_i (normal N_i) crosses the ray
// from center through the original's vertex i (as the leak's own surface was, see measure());
// |P_i - center| for a leak measured vertex for vertex, or where the ray runs nearly along the
// plane. For P = VO both give |VO_i - center|.
Eigen::VectorXd radii(const Eigen::MatrixX3d& P, const Eigen::MatrixX3d& VO,
                      const Eigen::MatrixX3d& N, const Resampled& m,
                      const Eigen::Vector3d& center) {
  Eigen::VectorXd r(P.rows());
  for (Eigen::Index i = 0; i < P.rows(); ++i) {
    const Eigen::Vector3d p = P.row(i).transpose() - center;
    r(i) = p.norm();
    if (m.vertexwise) continue;
    const Eigen::Vector3d u = (VO.row(i).transpose() - center).normalized();
    const Eigen::Vector3d n = N.row(i).transpose();
    const double along = n.dot(u);
    if (std::abs(along) > 0.1) r(i) = n.dot(p) / along;
  }
  return r;
}

// The leak may have been smoothed: the processing of the original that the measured leak
// resembles best becomes the reference the shifts are measured from, when it lowers the RMS
// difference of the distances to the center over the measured carrier vertices (the quantity
// the bins are made of) by 5 % at least; its shrinking is then not taken for the mark. It uses
// no candidate's codeword, so the null of the scores does not depend on it. Processing:
// Laplacian smoothing with lambda 0.3, or Taubin, k = 1 to 40 iterations (a series stops 5
// iterations past its best), its displacement scaled by a fitted s in [0, 4] (smoothing
// another mesh of the same surface, after decimation or remeshing, shrinks it by another
// amount per iteration). Returns the reference positions.
Eigen::MatrixX3d processed_reference(const Mesh& original, const Eigen::MatrixX3d& normals,
                                     const std::vector<std::uint8_t>& carrier, const Resampled& m,
                                     const Eigen::Vector3d& center, std::string& processing) {
  std::vector<Eigen::Index> rows;
  for (Eigen::Index i = 0; i < original.V.rows(); ++i)
    if (carrier[i] == kCounted && m.measured[i]) rows.push_back(i);
  const Eigen::VectorXd base = radii(original.V, original.V, normals, m, center);
  // d: what the leak's distances to the center differ by from the original's.
  Eigen::VectorXd d(static_cast<Eigen::Index>(rows.size()));
  for (std::size_t k = 0; k < rows.size(); ++k)
    d(static_cast<Eigen::Index>(k)) =
        (m.point.row(rows[k]).transpose() - center).norm() - base(rows[k]);
  const double unprocessed = d.norm();
  double best = unprocessed;
  Eigen::MatrixX3d reference = original.V;
  processing = "none";
  Eigen::VectorXd change(d.size());
  const Smoother smoother(original.F, original.V.rows());
  for (const bool taubin : {false, true}) {
    Eigen::MatrixX3d current = original.V;
    double series_best = unprocessed;
    int worse = 0;  // iterations since the series' best
    for (int k = 1; k <= 40 && worse < 5; ++k) {
      if (taubin)
        smoother.taubin(current, 1);
      else
        smoother.laplacian(current, 1);
      const Eigen::VectorXd now = radii(current, original.V, normals, m, center);
      for (std::size_t j = 0; j < rows.size(); ++j)
        change(static_cast<Eigen::Index>(j)) = now(rows[j]) - base(rows[j]);
      const double norm2 = change.squaredNorm();
      const double scale = norm2 > 0 ? std::clamp(change.dot(d) / norm2, 0.0, 4.0) : 0.0;
      const double e = (d - scale * change).norm();
      worse = e < series_best ? 0 : worse + 1;
      series_best = std::min(series_best, e);
      if (e < best) {
        best = e;
        reference = original.V + scale * (current - original.V);
        processing = fmt::format("{} smoothing x {} scaled by {:.2f}",
                                 taubin ? "Taubin" : "Laplacian", k, scale);
      }
    }
  }
  if (!(best < 0.95 * unprocessed)) reference = original.V, processing = "none";
  return reference;
}

// The smoothing counts the fits combine (fit_smoothings, unsmoothed_residuals).
constexpr std::array<int, 9> kSmoothingLevels = {1, 2, 4, 7, 11, 17, 26, 40, 60};

// What explains a leak's radial residuals best: the residuals left, and the processing's name.
struct SmoothingFit {
  Eigen::VectorXd residual;
  std::string processing = "none";
};

// The fit of a leak's radial residuals d by the effects of Laplacian smoothing of `base` at
// several iteration counts together (least squares: a low-pass filter of another shape than any
// one count's), change_of(smoothed positions of base) being an effect at d's places. Replaces
// fit's residual when it is lower and 5 % below d's; `name` becomes fit's processing.
void fit_smoothings(const Smoother& smoother, const Eigen::MatrixX3d& base,
                    const Eigen::VectorXd& d,
                    const std::function<Eigen::VectorXd(const Eigen::MatrixX3d&)>& change_of,
                    const char* name, SmoothingFit& fit) {
  const auto& kLevels = kSmoothingLevels;
  Eigen::MatrixXd C(d.size(), static_cast<Eigen::Index>(kLevels.size()));
  Eigen::MatrixX3d current = base;
  int done = 0;
  for (std::size_t l = 0; l < kLevels.size(); ++l) {
    smoother.laplacian(current, kLevels[l] - done);
    done = kLevels[l];
    C.col(static_cast<Eigen::Index>(l)) = change_of(current);
  }
  Eigen::MatrixXd G = C.transpose() * C;
  G.diagonal().array() += 1e-12 * std::max(G.trace(), 1e-300);
  const Eigen::VectorXd residual = d - C * G.ldlt().solve(C.transpose() * d);
  if (!(residual.norm() < fit.residual.norm() && residual.norm() < 0.95 * d.norm())) return;
  fit.residual = residual;
  fit.processing = name;
}

// How far a surface moving by delta at a crossing (face normal n) moves along the ray u: through
// the face's plane, or along the ray where it runs nearly along the plane.
double along_ray(const Eigen::Vector3d& n, const Eigen::Vector3d& u, const Eigen::Vector3d& delta) {
  const double along = u.dot(n);
  return std::abs(along) > 0.1 ? n.dot(delta) / along : u.dot(delta);
}

// A leak's radial residuals at its own vertices, against a surface on the original's faces
// (the original, or the original processed as the leak seems to have been): for each counted
// leak vertex within `erase` of that surface, the residual between it and where the ray from
// the center through it crosses the surface (cross_rays). A resampled leak's vertices lie on the
// marked surface (decimation and remeshing place them there); its faces cut corners between
// them, which a reading at the original's vertices would take for a mark. What smoothing
// explains is taken out (fit_smoothings: the surface smoothed, its motion interpolated at each
// crossing; and the surface sampled at the crossings, on the leak's faces, smoothed as a
// resampled leak would have been).
struct LeakResiduals {
  Eigen::VectorXd residual;           ///< #VL (0 where not crossed)
  std::vector<std::uint8_t> crossed;  ///< #VL
  Eigen::MatrixX3d on_original;       ///< #VL x 3: each crossing's place on the original
  std::size_t count = 0;              ///< crossed vertices
  double rms = 0;                     ///< of the residuals left
  std::string processing = "none";    ///< what the fit took out
  /// #VL (0 where not crossed), when computed (unsmoothed_residuals): empty otherwise.
  Eigen::VectorXd unsmoothed;
  /// #VL (0 where not crossed): (n . u)^2 at each crossing, n the original's vertex normals
  /// interpolated there, u the ray (read_fingerprint_at's obliquity).
  Eigen::VectorXd obliquity;
};

// A leak smoothed after resampling has vertices that slid along the surface: read against the
// place where each one's ray crosses the reference, the slide times the surface's slope reads as
// radial noise several times the fingerprint (bunny00 simplified to 30 % then Laplacian 10:
// residuals of 0.0014 where the field is 0.00008). For each smoothing count k of
// kSmoothingLevels, the places P_k the leak's vertices had before smoothing are estimated in
// the planes of the faces their rays cross: from the crossings, P <- P + T (VL - S^k P), T the
// projection onto that plane and S the Laplacian step on the leak's faces
// (attack_smooth_laplacian's defaults), kUnsmoothingSteps times. Each estimate moves along the
// surface only, so the radial part of what smoothing carried (the fingerprint among it) is not
// absorbed; the slide is. The residuals d (rows' order) are then fitted by the radial changes
// |S^k P_k - c| - |x_j - c| together (least squares), and what is left is returned, or nothing
// when it explains no more than 5 % of d. It uses no candidate: an innocent's score keeps its
// null.
constexpr int kUnsmoothingSteps = 4;

std::optional<Eigen::VectorXd> unsmoothed_residuals(
    const Smoother& on_leak, const Eigen::MatrixX3d& VL, const std::vector<Eigen::Index>& rows,
    const Eigen::MatrixX3d& crossing, const Eigen::MatrixX3d& normal, const Eigen::Vector3d& center,
    const Eigen::VectorXd& d) {
  const auto n = static_cast<Eigen::Index>(rows.size());
  if (n == 0) return std::nullopt;
  Eigen::MatrixXd C(n, static_cast<Eigen::Index>(kSmoothingLevels.size()));
  detail::parallel_for(static_cast<std::int64_t>(kSmoothingLevels.size()), 0, [&](std::int64_t l) {
    const int k = kSmoothingLevels[static_cast<std::size_t>(l)];
    Eigen::MatrixX3d P = VL;  // the rows not crossed stay where the leak has them
    for (Eigen::Index j = 0; j < n; ++j) P.row(rows[j]) = crossing.row(rows[j]);
    Eigen::MatrixX3d S;
    for (int step = 0; step < kUnsmoothingSteps; ++step) {
      S = P;
      on_leak.laplacian(S, k);
      for (Eigen::Index j = 0; j < n; ++j) {
        const Eigen::Vector3d plane = normal.row(rows[j]).transpose();
        Eigen::Vector3d move = (VL.row(rows[j]) - S.row(rows[j])).transpose();
        move -= plane * plane.dot(move);
        P.row(rows[j]) += move.transpose();
      }
    }
    on_leak.laplacian(P, k);
    for (Eigen::Index j = 0; j < n; ++j)
      C(j, l) = (P.row(rows[j]).transpose() - center).norm() -
                (crossing.row(rows[j]).transpose() - center).norm();
  });
  Eigen::MatrixXd G = C.transpose() * C;
  G.diagonal().array() += 1e-12 * std::max(G.trace(), 1e-300);
  Eigen::VectorXd residual = d - C * G.ldlt().solve(C.transpose() * d);
  if (!(residual.norm() < 0.95 * d.norm())) return std::nullopt;
  return residual;
}

LeakResiduals leak_residuals(const Mesh& original, const Eigen::MatrixX3d& normals,
                             const Smoother& on_original, const Smoother& on_leak,
                             const Eigen::MatrixX3d& surface, const Eigen::MatrixX3d& VL,
                             const std::vector<std::uint8_t>& leak_carrier,
                             const Eigen::Vector3d& center, double erase,
                             std::size_t unsmooth_limit, bool same_faces) {
  // A leak with the original's faces is read vertex to vertex (cross_vertices): its vertices
  // did not slide off their rays, so it is not read before a smoothing either.
  const Crossings x = same_faces
                          ? cross_vertices(surface, original.F, VL, leak_carrier, center, erase)
                          : cross_rays(surface, original.F, VL, leak_carrier, center, erase);
  if (same_faces) unsmooth_limit = 0;
  std::vector<Eigen::Index> rows;  // the crossed rows of VL, d's order
  for (Eigen::Index i = 0; i < VL.rows(); ++i)
    if (x.crossed[i]) rows.push_back(i);
  const auto n = static_cast<Eigen::Index>(rows.size());
  Eigen::VectorXd d(n);
  Eigen::MatrixX3d ray(n, 3);
  LeakResiduals out;
  out.on_original = VL;
  out.obliquity = Eigen::VectorXd::Zero(VL.rows());
  for (Eigen::Index j = 0; j < n; ++j) {
    const Eigen::Index i = rows[j];
    const Eigen::Vector3d v = VL.row(i).transpose() - center;
    d(j) = v.norm() - (x.point.row(i).transpose() - center).norm();
    ray.row(j) = v.normalized().transpose();
    out.on_original.row(i).setZero();
    Eigen::RowVector3d normal = Eigen::RowVector3d::Zero();
    for (int c = 0; c < 3; ++c) {
      out.on_original.row(i) += x.barycentric(i, c) * original.V.row(original.F(x.face[i], c));
      normal += x.barycentric(i, c) * normals.row(original.F(x.face[i], c));
    }
    const double along = normal.norm() > 0 ? normal.normalized().dot(ray.row(j)) : 0;
    out.obliquity(i) = along * along;
  }
  SmoothingFit fit;
  fit.residual = d;
  fit_smoothings(
      on_original, surface, d,
      [&](const Eigen::MatrixX3d& P) {
        Eigen::VectorXd change(n);
        for (Eigen::Index j = 0; j < n; ++j) {
          const Eigen::Index i = rows[j];
          Eigen::Vector3d delta = Eigen::Vector3d::Zero();
          for (int v = 0; v < 3; ++v) {
            const int vertex = original.F(x.face[i], v);
            delta += x.barycentric(i, v) * (P.row(vertex) - surface.row(vertex)).transpose();
          }
          change(j) = along_ray(x.normal.row(i), ray.row(j), delta);
        }
        return change;
      },
      "the reference smoothed", fit);
  fit_smoothings(
      on_leak, x.point, d,
      [&](const Eigen::MatrixX3d& P) {
        Eigen::VectorXd change(n);
        for (Eigen::Index j = 0; j < n; ++j)
          change(j) = along_ray(x.normal.row(rows[j]), ray.row(j),
                                (P.row(rows[j]) - x.point.row(rows[j])).transpose());
        return change;
      },
      "the reference resampled at the leak's vertices and smoothed", fit);
  out.residual = Eigen::VectorXd::Zero(VL.rows());
  for (Eigen::Index j = 0; j < n; ++j) out.residual(rows[j]) = fit.residual(j);
  // A leak that fits a smoothing is also read against where its vertices were before it
  // (unsmooth_limit: the most crossed vertices it is done for; 0 never).
  std::string skipped;
  if (fit.processing != "none" && unsmooth_limit > 0 && rows.size() > unsmooth_limit)
    skipped = fmt::format(" (not read before the smoothing: {} leak vertices, over {})",
                          rows.size(), unsmooth_limit);
  else if (fit.processing != "none" && unsmooth_limit > 0)
    if (const std::optional<Eigen::VectorXd> u =
            unsmoothed_residuals(on_leak, VL, rows, x.point, x.normal, center, d)) {
      out.unsmoothed = Eigen::VectorXd::Zero(VL.rows());
      for (Eigen::Index j = 0; j < n; ++j) out.unsmoothed(rows[j]) = (*u)(j);
    }
  out.crossed = x.crossed;
  out.count = rows.size();
  out.rms = n > 0 ? fit.residual.norm() / std::sqrt(static_cast<double>(n)) : 0;
  out.processing = fit.processing + skipped;
  return out;
}

// The fingerprint of a leak (fingerprint.h), read at the leak's own vertices (leak_residuals)
// against the original and, when the bins were read against a processed original, against that
// too, each also against the leak's vertices before smoothing when it fits a smoothing and has
// at most `unsmooth_limit` crossed vertices (unsmoothed_residuals, against the original only: the
// vertices before the smoothing lay on it): one to three readings of the whole surface, then each
// again over the regions of TraceOptions::fingerprint_regions (`whole`: how many of the readings
// are of the whole; score_group gives a candidate fingerprint_p_value of its best whole and best
// regional z), with the bumps of mark `format`. The original's bumps and bins are evaluated at the
// crossings' places on it. No basis when the original has too few counted vertices for one. Like
// the bins, the readings use no candidate's coefficients, so an innocent's score in each is within
// its null (fingerprint_p_value: exactly standard normal for format 3, bounded for signs).
std::optional<FingerprintBasis> fingerprint_reading(
    const Mesh& original, const std::vector<std::uint8_t>& carrier,
    const Eigen::MatrixX3d& reference, bool processed, const Eigen::MatrixX3d& VL,
    const Eigen::MatrixX3i& FL, const Histogram& h, int format, double erase, double ridge,
    const std::vector<int>& partitions, std::size_t unsmooth_limit, std::string& processing,
    std::vector<Eigen::VectorXd>& readings, std::size_t& whole) {
  readings.clear();
  whole = 0;
  std::size_t counted = 0;
  for (const std::uint8_t c : carrier) counted += c == kCounted;
  const int functions = fingerprint_functions(counted);
  if (functions <= 0) return std::nullopt;
  // The bumps alone: the readings evaluate them at the crossings, never at the original's
  // vertices. An original no basis can stand on (issue then gave its copies none) is read
  // without one, as one too small.
  FingerprintBasis basis;
  try {
    basis = fingerprint_bumps(original.V, original.F, carrier, h.center, functions, format);
  } catch (const InvalidArgumentError& e) {
    processing = fmt::format("none: no fingerprint can be made on the original ({})", e.what());
    return std::nullopt;
  }
  const std::vector<std::uint8_t> leak_carrier = carrier_vertices(VL, FL);
  const Smoother on_original(original.F, original.V.rows()), on_leak(FL, VL.rows());
  const Eigen::MatrixX3d normals = vertex_normals(original.V, original.F);
  const bool same_faces =
      VL.rows() == original.V.rows() && FL.rows() == original.F.rows() && FL == original.F;
  std::vector<std::string> taken;
  for (const bool against_processed : {false, true}) {
    if (against_processed && !processed) continue;
    const LeakResiduals x = leak_residuals(
        original, normals, on_original, on_leak, against_processed ? reference : original.V, VL,
        leak_carrier, h.center, erase, against_processed ? 0 : unsmooth_limit, same_faces);
    taken.push_back(fmt::format(
        "against the {}original, {} ({} leak vertices{})", against_processed ? "processed " : "",
        x.processing, x.count,
        x.unsmoothed.size() > 0 ? ", and against its vertices before the smoothing" : ""));
    const Histogram classes = histogram_at(h, x.on_original, x.crossed);
    readings.push_back(read_fingerprint_at(basis, x.on_original, x.residual, x.crossed, &classes,
                                           ridge, &x.obliquity));
    if (x.unsmoothed.size() > 0)
      readings.push_back(read_fingerprint_at(basis, x.on_original, x.unsmoothed, x.crossed,
                                             &classes, ridge, &x.obliquity));
  }
  // Each reading also over the regions of each partition (fingerprint_regions: the bumps
  // alone decide them), for a splice whose colluders each kept a part of the surface.
  const std::vector<std::vector<int>> regions = fingerprint_regions(basis, partitions);
  whole = readings.size();
  for (std::size_t w = 0; w < whole; ++w)
    for (const std::vector<int>& region : regions)
      readings.push_back(regional_reading(readings[w], region));
  std::vector<int> used;  // the partitions the basis has enough bumps for
  for (const int count : partitions)
    if (count <= basis.functions) used.push_back(count);
  if (!regions.empty())
    taken.push_back(fmt::format("each also over {} regions (partitions of {})", regions.size(),
                                fmt::join(used, ", ")));
  processing = fmt::format("{}", fmt::join(taken, "; "));
  return basis;
}

// The scores of a group of candidates read alike (same variant, bits, ID bits, strengths and
// method): each one's best exact p over the readings of kBands' widths times their number, and
// for a copy with a fingerprint (and a basis) that combined with the fingerprint's p
// (combined_p_value: conservative whichever mark the leak kept). Not yet corrected for the number
// of candidates. Codewords are packed (matches are popcounts) and the candidates are scored in
// batches on the thread budget: each score depends on its candidate alone.
struct Score {  // a candidate's evidence before the ranking (CandidateScore without the row)
  const CandidateRow* copy = nullptr;
  std::size_t order = 0;  // its place among the candidates, for ties
  int matches = 0, compared = 0;
  double p_value = 1, corrected_p = 1;
  double fingerprint_z = std::numeric_limits<double>::quiet_NaN(), fingerprint_p = 1;
};

std::vector<Score> score_group(const std::vector<const CandidateRow*>& copies,
                               const std::vector<BitEvidence>& evidence, const BitLayout& layout,
                               int id_bits, const Key& key, const FingerprintBasis* basis,
                               const std::vector<Eigen::VectorXd>& readings, std::size_t whole,
                               double share) {
  const int bits = layout.size();
  IdCodeOptions co;
  co.bits = bits;
  co.id_bits = id_bits;
  const IdCode code(co);
  const CodewordEncoder encoder(code, key);
  const int words = encoder.words();
  // The distinct readings of the bands, packed: the bits read (known) and those read as 1.
  struct Reading {
    std::vector<std::uint64_t> known, ones;
    int compared = 0;
    CodewordNull null;
  };
  std::vector<Reading> bands;  // none without a histogram mark (empty evidence)
  std::vector<std::uint8_t> previous;
  for (const double band : kBands) {
    if (evidence.empty()) break;
    const std::vector<std::uint8_t> read = layout.from_bins(banded_bits(evidence, band));
    if (read == previous) continue;  // the same reading: the same p-values
    previous = read;
    Reading r{std::vector<std::uint64_t>(words, 0), std::vector<std::uint64_t>(words, 0), 0,
              CodewordNull(code, read, key)};
    for (int j = 0; j < bits; ++j) {
      if (read[j] > 1) continue;
      r.known[j / 64] |= std::uint64_t{1} << (j % 64), ++r.compared;
      if (read[j] == 1) r.ones[j / 64] |= std::uint64_t{1} << (j % 64);
    }
    bands.push_back(std::move(r));
  }
  const std::optional<FingerprintScorer> fingerprint =
      basis && !readings.empty()
          ? std::optional<FingerprintScorer>(std::in_place, key, basis->functions, readings)
          : std::nullopt;
  std::vector<Score> scores(copies.size());
  // Candidates 256 at a time: their codewords encoded together (CodewordEncoder) and their
  // fingerprints scored together, each format's apart (FingerprintScorer); each thread takes
  // the next batch when done with one.
  constexpr std::int64_t kBatch = 256;
  const auto count = static_cast<std::int64_t>(copies.size());
  detail::parallel_for((count + kBatch - 1) / kBatch, 0, [&](std::int64_t batch) {
    const std::int64_t begin = batch * kBatch, end = std::min(count, begin + kBatch);
    std::vector<std::uint64_t> ids, codewords(static_cast<std::size_t>(kBatch * words));
    if (!bands.empty()) {  // no codeword without bins
      for (std::int64_t c = begin; c < end; ++c) ids.push_back(copies[c]->id);
      encoder.encode(ids.data(), ids.size(), codewords.data());
    }
    std::vector<std::pair<double, double>> z(kBatch), batch_z(kBatch);
    std::vector<int> formats;
    for (std::int64_t c = begin; fingerprint && c < end; ++c)
      if (has_fingerprint(copies[c]->mark_format) &&
          std::find(formats.begin(), formats.end(), copies[c]->mark_format) == formats.end())
        formats.push_back(copies[c]->mark_format);
    std::vector<std::int64_t> at;
    for (const int format : formats) {
      ids.clear(), at.clear();
      for (std::int64_t c = begin; c < end; ++c)
        if (copies[c]->mark_format == format) ids.push_back(copies[c]->id), at.push_back(c);
      fingerprint->best_z_split(ids.data(), ids.size(), format, whole, batch_z.data());
      for (std::size_t j = 0; j < at.size(); ++j) z[at[j] - begin] = batch_z[j];
    }
    for (std::int64_t c = begin; c < end; ++c) {
      const CandidateRow& copy = *copies[c];
      Score& best = scores[c];
      best.copy = &copy;
      const std::uint64_t* codeword =
          codewords.data() + static_cast<std::size_t>((c - begin) * words);
      for (std::size_t k = 0; k < bands.size(); ++k) {
        const Reading& r = bands[k];
        int matches = 0;
        for (int w = 0; w < words; ++w)
          matches += __builtin_popcountll(r.known[w] & ~(codeword[w] ^ r.ones[w]));
        const double p =
            std::min(1.0, r.null.p_value(matches) * static_cast<double>(kBands.size()));
        if (k == 0 || p < best.p_value)
          best.compared = r.compared, best.matches = matches, best.p_value = p;
      }
      if (fingerprint && has_fingerprint(copy.mark_format)) {
        const auto [z_whole, z_regional] = z[c - begin];
        best.fingerprint_z = std::max(z_whole, z_regional);
        best.fingerprint_p = fingerprint_p_value(z_whole, whole, z_regional,
                                                 readings.size() - whole, share, copy.mark_format);
        best.p_value = bands.empty() ? best.fingerprint_p  // the fingerprint alone
                                     : combined_p_value(best.p_value, best.fingerprint_p);
      }
    }
  });
  return scores;
}

// Names the candidates of the ranking (sorted, best first) below the threshold. A row edited
// after it was recorded is never named (its buyer or its ID may be anyone's), nor, when the rows
// come from a registry (from_registry), one without a MAC (whoever can edit the registry can
// blank one: swap two rows' IDs and remove their MACs); a list the caller gives is its own, and
// a row of it without a MAC is named with a warning. A reserved row is named with a warning.
// Sets the status and the message.
void name_buyers(TraceResult& r, const Key& key, double threshold, bool from_registry) {
  std::size_t edited = 0;
  for (CandidateScore& s : r.ranking) {
    s.auth = check_row(key, s.copy);
    if (s.auth == RowAuth::Edited) {
      ++edited;
      if (s.corrected_p < threshold)
        r.warnings.push_back(fmt::format(
            "row {} (ID {}) reads as the leaker (p = {:.3g} after correction) but fails its "
            "authentication code: it was changed after it was recorded, and is not named",
            s.copy.row, s.copy.id, s.corrected_p));
      continue;
    }
    if (s.auth == RowAuth::Unauthenticated && from_registry) {
      if (s.corrected_p < threshold)
        r.warnings.push_back(fmt::format(
            "row {} (ID {}, '{}') reads as the leaker (p = {:.3g} after correction) but carries "
            "no authentication code (recorded before registry schema 4, or its code was "
            "removed): its buyer and ID cannot be verified, and it is not named",
            s.copy.row, s.copy.id, s.copy.buyer, s.corrected_p));
      continue;
    }
    if (s.corrected_p < threshold) {
      r.named.push_back(s);
      if (s.auth == RowAuth::Unauthenticated)
        r.warnings.push_back(fmt::format(
            "row {} (ID {}) of the candidates given carries no authentication code: its buyer "
            "and ID are as the list says, unverified",
            s.copy.row, s.copy.id));
      if (s.copy.state == "reserved")
        r.warnings.push_back(fmt::format(
            "row {} (ID {}) is reserved, not completed: the issue of its copy was interrupted "
            "(or is running) after the ID was reserved; check that the copy was delivered",
            s.copy.row, s.copy.id));
    }
  }
  if (edited > 0)
    r.warnings.push_back(fmt::format(
        "{} of the {} {}candidate rows fail their authentication code (meshmark registry verify "
        "lists them{})",
        edited, r.ranking.size(), r.ranking.size() < r.candidates ? "best-ranked " : "",
        r.ranking.size() < r.candidates ? ", and checks all of them" : ""));
  r.status = r.named.empty() ? TraceStatus::NoBuyer : TraceStatus::Named;
  if (r.named.empty() && !r.warnings.empty() && r.ranking.front().corrected_p < threshold &&
      r.ranking.front().auth != RowAuth::Authentic) {
    r.message =
        "no buyer: the candidates that read as the leaker fail or lack their authentication "
        "code (see the warnings)";
    return;
  }
  r.message =
      r.named.empty()
          ? fmt::format("no buyer: the best of {} candidates has p = {:.3g} after correction",
                        r.candidates, r.ranking.front().corrected_p)
          : fmt::format(
                "{} named: '{}' (ID {}), p = {:.3g} after correction for {} candidates",
                r.named.size() == 1 ? "one buyer" : fmt::format("{} buyers", r.named.size()),
                r.named[0].copy.buyer, r.named[0].copy.id, r.named[0].corrected_p, r.candidates);
}

}  // namespace

Resampled resample_at_original(const Eigen::MatrixX3d& VL, const Eigen::MatrixX3i& FL,
                               const Eigen::MatrixX3d& VO, const Eigen::MatrixX3i& FO,
                               const Eigen::Vector3d& center, double erase_distance) {
  const std::vector<std::uint8_t> carrier = carrier_vertices(VO, FO);
  if (VL.rows() == VO.rows() && FL.rows() == FO.rows() && FL == FO) {
    // The same connectivity (noise, quantization, smoothing, a similarity): vertex i is
    // vertex i, measured where it is, unless it moved beyond the erase distance.
    Resampled m;
    m.point = VL;
    m.measured.assign(static_cast<std::size_t>(VO.rows()), 0);
    std::size_t used = 0, found = 0;
    for (Eigen::Index i = 0; i < VO.rows(); ++i) {
      if (carrier[i] != kCounted) continue;
      ++used;
      if ((VL.row(i) - VO.row(i)).norm() <= erase_distance) m.measured[i] = 1, ++found;
    }
    m.fraction = used ? static_cast<double>(found) / used : 0;
    m.vertexwise = true;
    return m;
  }
  return measure(VL, FL, VO, carrier, center, erase_distance);
}

namespace {

// The whole rows of the candidates at these positions, in that order.
using FetchRows = std::function<std::vector<IssuedCopy>(const std::vector<std::size_t>&)>;

// The scoring fields of the candidates, read while the leak is registered and measured (a
// registry read on another thread: a third of a trace against a million rows).
using ReadCandidates = std::function<const std::vector<CandidateRow>&()>;
// The first candidate the read found, as soon as it is found (none when there is none): a guess
// at the group to measure first. Empty: no guess.
using FirstCandidate = std::function<std::optional<CandidateRow>()>;

// What the candidates of one group are scored against (trace_candidates' measure).
// The center's letter, bits, ID bits, strength, spread, method, and the mark format whose
// fingerprint bumps the group is read with (fingerprint_width_factor; 4 also for copies
// without a fingerprint, as before format 5).
using GroupKey = std::tuple<char, int, int, double, double, std::string, int>;
struct GroupReading {
  GroupKey group;
  Histogram histogram;
  double fraction = 0, gamma = 1;
  Eigen::MatrixX3d reference;  // the first group's only
  std::string processing;      // the reference's, the first group's only
  std::vector<BitEvidence> evidence;
  bool fingerprint_read = false;
  std::optional<FingerprintBasis> basis;
  std::vector<Eigen::VectorXd> readings;  // of the whole surface first, then by region
  std::size_t whole_readings = 0;
  std::string fingerprint_processing;
  double seconds_resampling = 0, seconds_reference = 0, seconds_reading = 0;
};

// What row_problem has parsed: each name's verdict, and the last readable row's names.
struct ParsedRows {
  std::map<std::string, std::string> verdicts;
  std::string variant, method;
  int bits = 0, id_bits = 0;
};

// Why a candidate row's scoring fields are none that meshmark records ("" when they are):
// an ID longer than its length, a layout or code that cannot exist, an unknown variant,
// method or mark format, a strength that is not a number in [0, 1/2). Such a row was edited
// or is damaged; reading it could ask for anything (a layout of 10^8 bits).
std::string row_problem(const CandidateRow& c, ParsedRows& parsed) {
  if (c.id_bits < 1 || c.id_bits > 32) return fmt::format("an ID length of {} bits", c.id_bits);
  if (c.id >> c.id_bits != 0)
    return fmt::format("ID {} does not fit in its {} bits", c.id, c.id_bits);
  if (c.bits < 8 || c.bits > 1024) return fmt::format("{} bits (8 to 1024 are read)", c.bits);
  if (!(std::isfinite(c.strength) && c.strength >= 0 && c.strength < 0.5))
    return fmt::format("strength {}", c.strength);
  if (!(std::isfinite(c.strength_spread) && c.strength_spread >= 0 && c.strength_spread < 1))
    return fmt::format("strength spread {}", c.strength_spread);
  if (c.mark_format < 1 || c.mark_format > kFingerprintMarkFormat)
    return fmt::format("mark format {}", c.mark_format);
  if (c.bits == parsed.bits && c.id_bits == parsed.id_bits && c.variant == parsed.variant &&
      c.method == parsed.method)
    return "";  // as the row before (a registry's rows mostly are)
  const auto check = [&](const std::string& what, const std::function<void()>& parse) {
    const auto [it, fresh] = parsed.verdicts.try_emplace(what);
    if (fresh) try {
        parse();
      } catch (const Error& e) {
        it->second = e.what();
      }
    return it->second;
  };
  std::string why = check("variant " + c.variant, [&] { (void)parse_variant(c.variant); });
  if (why.empty()) why = check("method " + c.method, [&] { (void)parse_method(c.method); });
  if (why.empty())
    why = check(fmt::format("code {} {}", c.bits, c.id_bits), [&] {
      IdCodeOptions o;
      o.bits = c.bits, o.id_bits = c.id_bits;
      (void)IdCode(o);
    });
  if (why.empty())
    parsed.bits = c.bits, parsed.id_bits = c.id_bits, parsed.variant = c.variant,
    parsed.method = c.method;
  return why;
}

// trace() on candidates all issued under key, given by their scoring fields; whole rows are
// fetched for the ranking alone.
TraceResult trace_candidates(const Mesh& leaked, const Mesh& original,
                             const ReadCandidates& read_candidates, const FirstCandidate& hint,
                             const FetchRows& fetch, const Key& key, const TraceOptions& o,
                             bool from_registry) {
  if (!(o.threshold > 0 && o.threshold < 1))
    throw InvalidArgumentError(fmt::format("the threshold {} is out of (0, 1)", o.threshold));
  if (!(o.erase_distance > 0)) throw InvalidArgumentError("the erase distance must be positive");
  if (!(o.fingerprint_ridge >= 0 && o.fingerprint_ridge < 1e6))
    throw InvalidArgumentError(
        fmt::format("the fingerprint ridge {} is outside [0, 1e6)", o.fingerprint_ridge));
  if (!(o.fingerprint_region_share > 0 && o.fingerprint_region_share < 1))
    throw InvalidArgumentError(
        fmt::format("the regions' share {} is outside (0, 1)", o.fingerprint_region_share));
  check_fingerprint_partitions(o.fingerprint_regions);
  TraceResult r;
  using Clock = std::chrono::steady_clock;
  auto since = [](Clock::time_point t) {
    return std::chrono::duration<double>(Clock::now() - t).count();
  };
  Clock::time_point t = Clock::now();
  if (o.register_leak) {
    r.registration =
        register_similarity(leaked.V, leaked.F, original.V, original.F, o.registration);
  } else {
    r.registration.status = RegistrationStatus::Registered;
    r.registration.message = "in the original's frame (not registered)";
  }
  r.seconds.registration = since(t);
  const bool registered = r.registration.status == RegistrationStatus::Registered;
  const Eigen::MatrixX3d VL =
      registered ? r.registration.transform.apply(leaked.V) : Eigen::MatrixX3d();
  const std::vector<std::uint8_t> carrier = carrier_vertices(original.V, original.F);
  const double diagonal = bounding_box_diagonal(original.V, carrier);
  const Eigen::MatrixX3d normals = vertex_normals(original.V, original.F);
  const auto group_of = [](const CandidateRow& c) {
    return GroupKey{c.variant.empty() ? 'D' : c.variant[0],
                    c.bits,
                    c.id_bits,
                    c.strength,
                    c.strength_spread,
                    c.method,
                    c.mark_format == kFingerprintMarkFormat ? kFingerprintMarkFormat
                                                            : kWideBumpFingerprintFormat};
  };
  // The fingerprint's readings of group g's histogram, against `reference` (the original, or
  // as fitted: `processing` says which).
  const auto read_fingerprint_of = [&](GroupReading& g, const Eigen::MatrixX3d& reference,
                                       const std::string& processing) {
    g.basis = fingerprint_reading(original, carrier, reference, processing != "none", VL, leaked.F,
                                  g.histogram, std::get<6>(g.group), o.erase_distance * diagonal,
                                  o.fingerprint_ridge, o.fingerprint_regions,
                                  o.fingerprint_unsmoothing ? o.fingerprint_unsmoothing_limit : 0,
                                  g.fingerprint_processing, g.readings, g.whole_readings);
    g.fingerprint_read = true;
  };
  // One group's reading of the leak, before any candidate is scored. The first group (in
  // GroupKey order) also fits the reference (processed_reference) that every group reads against.
  const auto measure = [&](const GroupKey& group, const GroupReading* first, bool fingerprinted) {
    const auto& [letter, bits, id_bits, strength, spread, method, bumps] = group;
    GroupReading g;
    g.group = group;
    const CenterKind kind = parse_variant(std::string(1, letter) + "RS").center;
    const Center center = center_of_mass(original.V, original.F, carrier, kind);
    g.histogram = build_histogram(original.V, carrier, center.point, bits);
    if (!g.histogram.valid()) throw InvalidArgumentError("the original has no histogram");
    Clock::time_point at = Clock::now();
    const Resampled m = resample_at_original(VL, leaked.F, original.V, original.F, center.point,
                                             o.erase_distance * diagonal);
    g.seconds_resampling = since(at);
    g.fraction = m.fraction;
    if (!first) {
      at = Clock::now();
      g.reference = processed_reference(original, normals, carrier, m, center.point, g.processing);
      g.seconds_reference = since(at);
    }
    const Eigen::MatrixX3d& reference = first ? first->reference : g.reference;
    const std::string& processing = first ? first->processing : g.processing;
    at = Clock::now();
    // Strength 0: copies issued with the fingerprint alone (issue.h), no histogram mark to read.
    if (strength > 0) {
      const std::vector<double> alpha = mark_strengths(key, bits, true, strength, spread);
      const Eigen::VectorXd reference_radii =
          radii(reference, original.V, normals, m, center.point);
      g.evidence = read_bins(original.V, reference_radii, carrier, g.histogram, m, alpha,
                             bin_statistic(parse_method(method)), g.gamma);
    }
    // The fingerprint of copies issued with one (fingerprint.h), read at the leak's vertices.
    // Like the bins, the reading uses no candidate's coefficients.
    if (fingerprinted) read_fingerprint_of(g, reference, processing);
    g.seconds_reading = since(at);
    return g;
  };
  // While the registry is read (trace_issued reads it on another thread), the group of the
  // first candidate found is measured: a million rows take as long to read as a reading. It is
  // kept when it is the first group, and measured again otherwise.
  std::optional<GroupReading> guess;
  ParsedRows parsed;  // row_problem's cache
  if (registered && hint)
    if (const std::optional<CandidateRow> c = hint(); c && row_problem(*c, parsed).empty())
      guess = measure(group_of(*c), nullptr, has_fingerprint(c->mark_format));
  const std::vector<CandidateRow>& mine = read_candidates();
  r.candidates = mine.size();
  if (mine.empty()) {  // before a failed registration: nothing to trace either way
    r.status = TraceStatus::NoCandidates;
    r.message = "no copy was issued under this key";
    return r;
  }
  if (!registered) {
    r.status = TraceStatus::RegistrationFailed;
    r.message = r.registration.message;
    return r;
  }
  // Groups of candidates read alike; rows that cannot be read (row_problem) are scored p = 1,
  // counted among the candidates, and named in a warning.
  std::map<GroupKey, std::vector<std::size_t>> groups;
  std::vector<Score> scores;
  scores.reserve(mine.size());
  std::vector<std::string> unreadable;
  for (std::size_t k = 0; k < mine.size(); ++k) {
    const std::string why = row_problem(mine[k], parsed);
    if (why.empty()) {
      groups[group_of(mine[k])].push_back(k);
      continue;
    }
    Score x;
    x.copy = &mine[k], x.order = k;
    scores.push_back(x);
    if (unreadable.size() < 5)
      unreadable.push_back(fmt::format("row {} (ID {}): {}", mine[k].row, mine[k].id, why));
  }
  if (!scores.empty())
    r.warnings.push_back(fmt::format(
        "{} candidate row(s) hold values no copy is issued with, so they were edited or are "
        "damaged; they are counted among the candidates but not read (p = 1): {}{} (meshmark "
        "registry verify checks them)",
        scores.size(), fmt::join(unreadable, "; "),
        scores.size() > unreadable.size() ? "; ..." : ""));
  if (groups.empty()) {
    r.status = TraceStatus::NoBuyer;
    r.message = "no buyer: no candidate row can be read (see the warnings)";
    return r;
  }
  // Progress: the registration (done), then each group measured and scored.
  detail::ProgressCounter progress(o.progress, "tracing", 1 + static_cast<long>(groups.size()));
  progress.step(1, "registered");
  std::optional<GroupReading> first;
  if (guess && guess->group == groups.begin()->first) first = std::move(guess);
  for (const auto& [group, members] : groups) {
    const bool fingerprinted = std::any_of(members.begin(), members.end(), [&](std::size_t k) {
      return has_fingerprint(mine[k].mark_format);
    });
    const bool is_first = group == groups.begin()->first;
    if (is_first && !first) first = measure(group, nullptr, fingerprinted);
    GroupReading other;
    if (!is_first) other = measure(group, &*first, fingerprinted);
    GroupReading& g = is_first ? *first : other;
    if (fingerprinted && !g.fingerprint_read)  // a guess measured without
      read_fingerprint_of(g, first->reference, first->processing);
    if (!fingerprinted)  // a guess measured with
      g.basis.reset(), g.readings.clear(), g.whole_readings = 0;
    if (g.basis && r.fingerprint_processing.empty())
      r.fingerprint_processing = g.fingerprint_processing;
    r.seconds.resampling += g.seconds_resampling;
    r.seconds.reference += g.seconds_reference;
    t = Clock::now();
    const int bits = std::get<1>(group), id_bits = std::get<2>(group);
    const BitLayout layout = mark_layout(key, bits, true);
    std::vector<const CandidateRow*> group_copies;
    group_copies.reserve(members.size());
    for (const std::size_t k : members) group_copies.push_back(&mine[k]);
    std::vector<Score> scored =
        score_group(group_copies, g.evidence, layout, id_bits, key, g.basis ? &*g.basis : nullptr,
                    g.readings, g.whole_readings, o.fingerprint_region_share);
    for (std::size_t i = 0; i < scored.size(); ++i) {
      scored[i].order = members[i];
      scored[i].corrected_p = std::min(1.0, scored[i].p_value * static_cast<double>(mine.size()));
    }
    scores.insert(scores.end(), scored.begin(), scored.end());
    r.seconds.scoring += g.seconds_reading + since(t);
    progress.step(1, fmt::format("{} candidates scored", members.size()));
    if (is_first) {
      r.processing = g.processing;
      r.measured_fraction = g.fraction, r.attenuation = g.gamma;
      const std::vector<BitEvidence>& evidence = g.evidence;
      const std::vector<std::uint8_t> read = evidence.empty()
                                                 ? std::vector<std::uint8_t>()
                                                 : layout.from_bins(banded_bits(evidence, 0.0));
      for (int j = 0; j < bits && !evidence.empty(); ++j) {
        BitEvidence e = evidence[layout.bin_of[j]];
        if (layout.whitening[j]) std::swap(e.if_one, e.if_zero);
        e.bit = read[j];
        r.bits.push_back(e);
      }
    }
  }
  // The ranking: the best o.ranking candidates (ties in the candidates' order), every one below
  // the threshold, and the copy whose file the leak is; every candidate's score for plots.
  const auto better = [](const Score& a, const Score& b) {
    return a.p_value != b.p_value ? a.p_value < b.p_value : a.order < b.order;
  };
  r.log_scores.reserve(scores.size());
  for (const Score& x : scores)
    r.log_scores.push_back(static_cast<float>(-std::log10(std::max(x.corrected_p, 1e-300))));
  auto kept = scores.end();
  if (o.ranking > 0 && o.ranking < scores.size()) {
    kept = scores.begin() + static_cast<std::ptrdiff_t>(o.ranking);
    std::nth_element(scores.begin(), kept, scores.end(), better);
    kept = std::partition(kept, scores.end(), [&](const Score& x) {
      return x.corrected_p < o.threshold || x.copy->same_bytes;
    });
  }
  std::sort(scores.begin(), kept, better);
  std::vector<std::size_t> ranked;
  for (auto x = scores.begin(); x != kept; ++x) ranked.push_back(x->order);
  std::vector<IssuedCopy> rows = fetch(ranked);
  r.ranking.reserve(ranked.size());
  for (auto x = scores.begin(); x != kept; ++x) {
    CandidateScore c;
    c.copy = std::move(rows[static_cast<std::size_t>(x - scores.begin())]);
    c.matches = x->matches, c.compared = x->compared;
    c.p_value = x->p_value, c.corrected_p = x->corrected_p;
    c.fingerprint_z = x->fingerprint_z, c.fingerprint_p = x->fingerprint_p;
    r.ranking.push_back(std::move(c));
  }
  name_buyers(r, key, o.threshold, from_registry);
  return r;
}

}  // namespace

TraceResult trace(const Mesh& leaked, const Mesh& original,
                  const std::vector<IssuedCopy>& candidates, const Key& key,
                  const TraceOptions& o) {
  const std::string fingerprint = key_fingerprint(key);
  std::vector<const IssuedCopy*> mine;  // the candidates under this key, in their order
  std::vector<CandidateRow> rows;
  for (const IssuedCopy& c : candidates) {
    if (c.key_fingerprint != fingerprint) continue;
    mine.push_back(&c);
    rows.push_back({c.row, c.id, c.id_bits, c.bits, c.variant, c.strength, c.strength_spread,
                    c.method, c.mark_format,
                    !o.leaked_hash.empty() && c.output_hash == o.leaked_hash});
  }
  return trace_candidates(
      leaked, original, [&]() -> const std::vector<CandidateRow>& { return rows; }, {},
      [&](const std::vector<std::size_t>& at) {
        std::vector<IssuedCopy> out;
        out.reserve(at.size());
        for (const std::size_t k : at) out.push_back(*mine[k]);
        return out;
      },
      key, o, false);
}

void compare_with_issued_files(TraceResult& r, const std::string& leaked_hash) {
  const CandidateScore* same = nullptr;
  for (const CandidateScore& s : r.ranking)
    if (!s.copy.output_hash.empty() && s.copy.output_hash == leaked_hash) same = &s;
  if (!same) return;
  r.identical_row = same->copy.row;
  bool named = false;
  for (const CandidateScore& s : r.named) named = named || s.copy.row == same->copy.row;
  if (named) {
    r.message +=
        fmt::format("; the leak is byte for byte the file issued in row {}", same->copy.row);
  } else if (!r.named.empty()) {
    r.warnings.push_back(fmt::format(
        "the leak's bytes are those of the copy recorded in row {} (ID {}), not of a named "
        "buyer's: the mark and the registry contradict each other, and nobody is named",
        same->copy.row, same->copy.id));
    r.named.clear();
    r.status = TraceStatus::NoBuyer;
    r.message =
        "no buyer: the mark read and the leak's bytes name different rows (see the "
        "warnings)";
  }
}

TraceResult trace_issued(const Mesh& leaked, const Mesh& original, const std::string& original_hash,
                         const std::string& registry, const Key& key, const TraceOptions& options) {
  const Registry store(registry, true);
  RegistryQuery q;  // the copies of this file, and of its geometry in any other file
  q.original_hash = original_hash;
  q.original_geometry = geometry_hash(original.V, original.F);
  q.key_fingerprint = key_fingerprint(key);
  // The scoring fields of every candidate, whole rows for the ranking alone: a row read twice
  // must not have changed in between (a reserved copy completed meanwhile is traced again).
  // The read runs on its own thread while the leak is registered and the first row's group
  // measured; the connection is used by one thread at a time (the future is waited for before
  // any other use).
  std::chrono::duration<double> reading{};
  std::promise<std::optional<CandidateRow>> found;
  std::future<std::optional<CandidateRow>> first = found.get_future();
  std::future<std::vector<CandidateRow>> pending =
      std::async(std::launch::async, [&store, &q, &options, &reading, &found] {
        const auto start = std::chrono::steady_clock::now();
        bool told = false;
        const auto tell = [&](std::optional<CandidateRow> c) {
          if (!told) found.set_value(std::move(c)), told = true;
        };
        try {
          std::vector<CandidateRow> read =
              store.candidates(q, options.leaked_hash, [&](const CandidateRow& c) { tell(c); });
          tell(std::nullopt);
          reading = std::chrono::steady_clock::now() - start;
          return read;
        } catch (...) {
          tell(std::nullopt);  // the error comes with the candidates
          throw;
        }
      });
  std::vector<CandidateRow> candidates;
  bool received = false;
  TraceResult r = trace_candidates(
      leaked, original,
      [&]() -> const std::vector<CandidateRow>& {
        if (!received) candidates = pending.get(), received = true;
        return candidates;
      },
      [&] { return first.get(); },
      [&](const std::vector<std::size_t>& at) {
        std::vector<std::int64_t> numbers;
        numbers.reserve(at.size());
        for (const std::size_t k : at) numbers.push_back(candidates[k].row);
        std::vector<IssuedCopy> rows = store.rows(numbers);
        for (std::size_t i = 0; i < at.size(); ++i)
          if (!same_scoring(candidates[at[i]], rows[i]))
            throw IOError(fmt::format(
                "{}: row {} changed while it was read (a copy completed meanwhile?): trace again",
                registry_display_name(registry), rows[i].row));
        return rows;
      },
      key, options, true);
  r.seconds.registry = reading.count();

  if (r.status == TraceStatus::NoCandidates) {
    RegistryQuery by_key;
    by_key.key_fingerprint = q.key_fingerprint;
    if (const std::size_t others = store.candidates(by_key).size(); others > 0)
      r.message = fmt::format(
          "no copy of this original was issued under this key ({} copies of other originals "
          "were: is the original the file the copies were made from?)",
          others);
  }
  return r;
}

}  // namespace meshmark
