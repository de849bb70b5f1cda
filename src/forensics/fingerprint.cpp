// The fingerprint (fingerprint.h): its basis, its keyed coefficients, adding it, reading it.

#include "meshmark/forensics/fingerprint.h"

#include <fmt/format.h>
#include <sodium.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/QR>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>

#include "core/exact_scale.h"
#include "core/parallel.h"
#include "meshmark/core/error.h"
#include "meshmark/core/mesh.h"

namespace meshmark {

namespace {

// Each edge scaled by a power of two (exact) before the cross product, whose squared norm
// underflowed below coordinates of about 1e-77 (no area) and overflowed above about 1e77;
// elsewhere the same area bit for bit.
double triangle_area_sum(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F) {
  double area = 0;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Eigen::Vector3d a = V.row(F(f, 0)), b = V.row(F(f, 1)), c = V.row(F(f, 2));
    int eu = 0, ev = 0;
    const Eigen::Vector3d u = detail::power_of_two_scaled<Eigen::Vector3d>(b - a, eu),
                          v = detail::power_of_two_scaled<Eigen::Vector3d>(c - a, ev);
    area += 0.5 * std::ldexp(u.cross(v).norm(), eu + ev);
  }
  return area;
}

// The radial classes a histogram mark moves together: each bin cut into kSlices slices of
// equal width (the mark's displacement is, but for the center's small motion, a function of a
// vertex's distance to the center: the bin it lies in and where in the bin). -1: none.
constexpr int kSlices = 8;

int radial_class(const Histogram& h, Eigen::Index i) {
  if (h.bin[i] < 0 || !std::isfinite(h.t(i))) return -1;
  const int slice = std::clamp(static_cast<int>(std::floor(h.t(i) * kSlices)), 0, kSlices - 1);
  return h.bin[i] * kSlices + slice;
}

// What maps a class's moments m = sum x v (x = (1, t)) to the coefficients (a, b) of the
// least-squares line through its values, from its Gram matrix G = sum x x^T: G^-1, or the mean
// alone (a constant) when t does not vary; zero for an empty class.
Eigen::Matrix2d line_fit_operator(const Eigen::Matrix2d& G) {
  if (!(G(0, 0) > 0)) return Eigen::Matrix2d::Zero();
  if (G.determinant() > 1e-12 * G(0, 0) * G(0, 0)) return G.inverse();
  return (Eigen::Matrix2d() << 1 / G(0, 0), 0, 0, 0).finished();
}

// The bumps' points in a uniform grid: every point within `reach` of a position lies in the
// 3 x 3 x 3 block of cells around the position's cell. Cells are at least reach wide (a little
// more, so that rounding cannot put such a point two cells away) and at most 64 to a side.
class BumpGrid {
 public:
  BumpGrid(const Eigen::MatrixX3d& points, double reach) {
    lo_ = points.colwise().minCoeff();
    const Eigen::RowVector3d extent = points.colwise().maxCoeff() - lo_;
    cell_ = std::max(reach * (1 + 1e-9), extent.maxCoeff() / 64);
    if (!(cell_ > 0)) cell_ = 1;
    for (int c = 0; c < 3; ++c) dims_[c] = static_cast<int>(extent(c) / cell_) + 1;
    start_.assign(static_cast<std::size_t>(dims_[0]) * dims_[1] * dims_[2] + 1, 0);
    std::vector<std::size_t> of(static_cast<std::size_t>(points.rows()));
    for (Eigen::Index k = 0; k < points.rows(); ++k) {
      std::array<int, 3> at;
      for (int c = 0; c < 3; ++c) at[c] = std::min(coordinate(points(k, c), c), dims_[c] - 1);
      of[k] = flat(at);
      ++start_[of[k] + 1];
    }
    for (std::size_t c = 1; c < start_.size(); ++c) start_[c] += start_[c - 1];
    points_.resize(static_cast<std::size_t>(points.rows()));
    std::vector<int> fill(start_.begin(), start_.end() - 1);
    for (Eigen::Index k = 0; k < points.rows(); ++k) points_[fill[of[k]]++] = static_cast<int>(k);
  }

  /// Calls visit(k) for every point k in the block of cells around p (in no set order), none
  /// for a position that is not finite.
  template <class Visit>
  void near(const Eigen::RowVector3d& p, Visit&& visit) const {
    if (!p.allFinite()) return;
    std::array<int, 3> from, to;
    for (int c = 0; c < 3; ++c) {
      const int at = coordinate(p(c), c);
      from[c] = std::max(at - 1, 0), to[c] = std::min(at + 1, dims_[c] - 1);
      if (from[c] > to[c]) return;
    }
    for (int x = from[0]; x <= to[0]; ++x)
      for (int y = from[1]; y <= to[1]; ++y)
        for (int z = from[2]; z <= to[2]; ++z) {
          const std::size_t f = flat({x, y, z});
          for (int e = start_[f]; e < start_[f + 1]; ++e) visit(points_[e]);
        }
  }

 private:
  // The cell coordinate along axis c, clamped to [-2, dims + 1] (far outside: no neighbours).
  int coordinate(double x, int c) const {
    const double at = std::floor((x - lo_(c)) / cell_);
    return static_cast<int>(std::clamp(at, -2.0, static_cast<double>(dims_[c]) + 1));
  }
  std::size_t flat(const std::array<int, 3>& at) const {
    return (static_cast<std::size_t>(at[0]) * dims_[1] + at[1]) * dims_[2] + at[2];
  }
  Eigen::RowVector3d lo_;
  double cell_ = 1;
  std::array<int, 3> dims_{1, 1, 1};
  std::vector<int> start_, points_;
};

// Calls visit(i, k, d2) for every bump k within 3 w of P's row i (mask[i] != 0), d2 the
// squared distance, rows cut into chunks on the thread budget (each row on one thread, its
// bumps in the grid's order).
template <class Visit>
void for_each_bump(const FingerprintBasis& b, const BumpGrid& grid, const Eigen::MatrixX3d& P,
                   const std::vector<std::uint8_t>& mask, Visit&& visit) {
  const double cut2 = 9 * b.width * b.width;
  detail::parallel_chunks(P.rows(), [&](int, std::int64_t begin, std::int64_t end) {
    for (Eigen::Index i = begin; i < end; ++i)
      if (mask[i])
        grid.near(P.row(i), [&](int k) {
          const double d2 = (P.row(i) - b.points.row(k)).squaredNorm();
          if (d2 <= cut2) visit(i, k, d2);
        });
  });
}

// The mean over the rows with mask[i] != 0 of sum_k phi_k(P_i)^2 for unscaled bumps (what the
// scale makes 1): per-row sums first, then added in row order, whatever the threads.
double bump_mean_square(const FingerprintBasis& b, const Eigen::MatrixX3d& P,
                        const std::vector<std::uint8_t>& mask, std::size_t rows) {
  const BumpGrid grid(b.points, 3 * b.width);
  const double inv = 1 / (b.width * b.width);  // phi^2 = exp(-d2 / w^2)
  std::vector<double> sums(static_cast<std::size_t>(P.rows()), 0.0);
  for_each_bump(b, grid, P, mask,
                [&](Eigen::Index i, int, double d2) { sums[i] += std::exp(-d2 * inv); });
  double total = 0;
  for (const double x : sums) total += x;
  return total / static_cast<double>(rows);
}

// Fills b's rows with its bumps (b.points, width, scale) evaluated at the rows of P with
// mask[i] != 0, cut at 3 w, each row in bump order, values rounded to single precision; no
// entries for the others. The rows are counted first and then filled, so the entries take
// exactly their size (a few dozen a vertex, 6 bytes each: the largest share of a trace's
// memory).
void evaluate_bumps(FingerprintBasis& b, const BumpGrid& grid, const Eigen::MatrixX3d& P,
                    const std::vector<std::uint8_t>& mask) {
  const double inv = 1 / (2 * b.width * b.width);
  const Eigen::Index n = P.rows();
  b.row_start.assign(static_cast<std::size_t>(n) + 1, 0);
  for_each_bump(b, grid, P, mask, [&](Eigen::Index i, int, double) { ++b.row_start[i + 1]; });
  std::int64_t total = 0;
  for (Eigen::Index i = 0; i < n; ++i) {
    total += b.row_start[i + 1];
    if (total > std::numeric_limits<int>::max())
      throw Error("the fingerprint's basis would have more than 2^31 - 1 entries");
    b.row_start[i + 1] = static_cast<int>(total);
  }
  b.index.assign(static_cast<std::size_t>(b.row_start[n]), 0);
  b.value.assign(b.index.size(), 0.0F);
  std::vector<int> filled(b.row_start.begin(), b.row_start.end() - 1);
  for_each_bump(b, grid, P, mask, [&](Eigen::Index i, int k, double) {
    b.index[filled[i]++] = static_cast<std::uint16_t>(k);
  });
  detail::parallel_chunks(n, [&](int, std::int64_t begin, std::int64_t end) {
    for (Eigen::Index i = begin; i < end; ++i) {
      const int first = b.row_start[i], last = b.row_start[i + 1];
      std::sort(b.index.begin() + first, b.index.begin() + last);
      for (int e = first; e < last; ++e) {
        const double d2 = (P.row(i) - b.points.row(b.index[e])).squaredNorm();
        b.value[e] = static_cast<float>(b.scale * std::exp(-d2 * inv));
      }
    }
  });
}

// \throw InvalidArgumentError unless b's compressed rows are well formed: row_start from 0 to
// the entries' count, never decreasing; with `entries`, also each row's bumps in increasing
// order within [0, K) (field() checks the bounds as it sums instead: one pass, not two).
void check_rows(const FingerprintBasis& b, bool entries) {
  const Eigen::Index n = static_cast<Eigen::Index>(b.row_start.size()) - 1;
  if (n < 0 || b.index.size() != b.value.size() || b.row_start[0] != 0 ||
      static_cast<std::size_t>(b.row_start[n]) != b.index.size() ||
      !std::is_sorted(b.row_start.begin(), b.row_start.end()))
    throw InvalidArgumentError("the basis' compressed rows do not match its entries");
  for (Eigen::Index i = 0; entries && i < n; ++i)
    for (int e = b.row_start[i]; e < b.row_start[i + 1]; ++e)
      if (b.index[e] >= b.functions || (e > b.row_start[i] && b.index[e] <= b.index[e - 1]))
        throw InvalidArgumentError(fmt::format(
            "the basis' row {} is not in increasing order of bumps 0 to {}", i, b.functions - 1));
}

// basis' bumps (positions, width, scale) without rows, checked against P and its mask.
FingerprintBasis bumps_of(const FingerprintBasis& basis, const Eigen::MatrixX3d& P,
                          const std::vector<std::uint8_t>& mask) {
  if (mask.size() != static_cast<std::size_t>(P.rows()))
    throw InvalidArgumentError("the mask does not match the points");
  if (basis.points.rows() != basis.functions)
    throw InvalidArgumentError("the basis has no bump positions");
  FingerprintBasis b;
  b.functions = basis.functions, b.center = basis.center, b.diagonal = basis.diagonal;
  b.width = basis.width, b.centers = basis.centers, b.points = basis.points;
  b.scale = basis.scale;
  return b;
}

// The normal equations of read_fingerprint, summed over rows given in blocks (rows [offset,
// offset + block's rows) of the whole), in increasing order of rows: the same sums, whatever
// the blocks. Normal equations of Phi b ~ residual, with both taken out of the span of (1, t)
// in each radial class (with `keep`): A = Phi^T Phi - sum_c M_c G_c^-1 M_c^T and
// y = Phi^T r - sum_c M_c G_c^-1 R_c, where per class G_c = sum x x^T, M_c = sum phi_i x^T
// (K x 2) and R_c = sum x r_i, x = (1, t_i).
class NormalEquations {
 public:
  // obliquity: per row, a third regressor of each class beside (1, t) (trace's (n . u)^2: a
  // mark moving vertices along the normals moves the distance to the center by that much).
  NormalEquations(int functions, const Histogram* keep, const Eigen::VectorXd* obliquity = nullptr)
      : K_(functions),
        keep_(keep),
        obliquity_(keep ? obliquity : nullptr),
        D_(obliquity_ ? 3 : 2),
        classes_(keep ? keep->bins * kSlices : 0),
        A_(Eigen::MatrixXd::Zero(functions, functions)),
        y_(Eigen::VectorXd::Zero(functions)),
        G_(static_cast<std::size_t>(classes_), Eigen::Matrix3d::Zero()),
        R_(static_cast<std::size_t>(classes_), Eigen::Vector3d::Zero()),
        M_(static_cast<std::size_t>(classes_), Eigen::MatrixX3d::Zero(functions, 3)) {}

  // Phi^T Phi and Phi^T r, accumulated row by row over the used vertices (each touches a few
  // dozen bumps, in bump order: its products fall in A's upper triangle). rows' row i is the
  // whole's row offset + i; residual and measured are the whole's.
  void add(const FingerprintBasis& rows, Eigen::Index offset, const Eigen::VectorXd& residual,
           const std::vector<std::uint8_t>& measured) {
    const Eigen::Index n = static_cast<Eigen::Index>(rows.row_start.size()) - 1;
    for (Eigen::Index j = 0; j < n; ++j) {
      const Eigen::Index i = offset + j;
      const int first = rows.row_start[j], last = rows.row_start[j + 1];
      if (!measured[i] || !std::isfinite(residual(i)) || last <= first) continue;
      const int c = keep_ ? radial_class(*keep_, i) : 0;
      if (c < 0) continue;
      for (int e = first; e < last; ++e) {
        const int k = rows.index[e];
        const double v = rows.value[e];
        y_(k) += v * residual(i);
        double* column = A_.col(k).data();
        for (int f = first; f <= e; ++f) column[rows.index[f]] += rows.value[f] * v;
      }
      if (!keep_) continue;
      const double w = obliquity_ && std::isfinite((*obliquity_)(i)) ? (*obliquity_)(i) : 0;
      const Eigen::Vector3d x(1, keep_->t(i), w);
      G_[c] += x * x.transpose(), R_[c] += x * residual(i);
      for (int e = first; e < last; ++e)
        M_[c].row(rows.index[e]) += static_cast<double>(rows.value[e]) * x.transpose();
    }
  }

  Eigen::VectorXd solve(double ridge) {
    Eigen::MatrixXd& A = A_;
    A.triangularView<Eigen::StrictlyLower>() = A.transpose();
    // sum_c M_c G_c^-1 M_c^T as one product W W^T, W's columns M_c S_c with S_c S_c^T = G_c^-1
    // (G_c^-1 is symmetric and positive semi-definite).
    Eigen::MatrixXd W = Eigen::MatrixXd::Zero(K_, D_ * static_cast<Eigen::Index>(classes_));
    for (int c = 0; c < classes_; ++c) {
      if (G_[c](0, 0) == 0) continue;
      if (D_ == 2) {
        const Eigen::Matrix2d Ginv = line_fit_operator(G_[c].topLeftCorner<2, 2>());
        const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(Ginv);
        const Eigen::Matrix2d S =
            eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal();
        W.middleCols(2 * c, 2) = M_[c].leftCols<2>() * S;
        y_.noalias() -= M_[c].leftCols<2>() * (Ginv * R_[c].head<2>());
        continue;
      }
      // The pseudo-inverse: a class whose t or obliquity does not vary fits fewer terms.
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(G_[c]);
      const double floor = 1e-12 * std::max(eig.eigenvalues().maxCoeff(), 1e-300);
      Eigen::Vector3d root = Eigen::Vector3d::Zero();
      for (int d = 0; d < 3; ++d)
        if (eig.eigenvalues()(d) > floor) root(d) = 1 / std::sqrt(eig.eigenvalues()(d));
      const Eigen::Matrix3d S = eig.eigenvectors() * root.asDiagonal();
      W.middleCols(3 * c, 3) = M_[c] * S;
      y_.noalias() -= M_[c] * (S * (S.transpose() * R_[c]));
    }
    if (classes_ > 0) A.selfadjointView<Eigen::Lower>().rankUpdate(W, -1.0);
    A.triangularView<Eigen::StrictlyUpper>() = A.transpose();
    A.diagonal().array() += std::max(ridge, 1e-9) * std::max(A.trace() / K_, 1e-300);
    return A.ldlt().solve(y_);
  }

 private:
  int K_;
  const Histogram* keep_;
  const Eigen::VectorXd* obliquity_;
  int D_;
  int classes_;
  Eigen::MatrixXd A_;
  Eigen::VectorXd y_;
  std::vector<Eigen::Matrix3d> G_;
  std::vector<Eigen::Vector3d> R_;
  std::vector<Eigen::MatrixX3d> M_;
};

// \throw InvalidArgumentError for a ridge outside [0, 1e6), or a residual, mask or histogram
// not of n rows.
void check_reading(Eigen::Index n, const Eigen::VectorXd& residual,
                   const std::vector<std::uint8_t>& measured, const Histogram* keep, double ridge,
                   const Eigen::VectorXd* obliquity = nullptr) {
  if (obliquity && obliquity->size() != n)
    throw InvalidArgumentError("the obliquities and the basis differ in size");
  if (!(ridge >= 0 && ridge < 1e6))
    throw InvalidArgumentError(fmt::format("the fingerprint ridge {} is outside [0, 1e6)", ridge));
  if (residual.size() != n || measured.size() != static_cast<std::size_t>(n))
    throw InvalidArgumentError("the residual, the measured mask and the basis differ in size");
  if (keep && keep->bin.size() != static_cast<std::size_t>(n))
    throw InvalidArgumentError("the histogram to keep is of another mesh");
}

// The rows evaluated at once where a basis' rows are not held: about 14 MB of entries.
constexpr Eigen::Index kFieldBlock = Eigen::Index{1} << 16;

// 1 for the counted vertices of carrier, 0 for the others.
std::vector<std::uint8_t> counted_mask(const std::vector<std::uint8_t>& carrier) {
  std::vector<std::uint8_t> mask(carrier.size());
  for (std::size_t i = 0; i < mask.size(); ++i) mask[i] = carrier[i] == kCounted;
  return mask;
}

}  // namespace

int fingerprint_functions(std::size_t counted, const FingerprintOptions& options) {
  const int k = static_cast<int>(
      std::min<std::size_t>({static_cast<std::size_t>(std::max(options.functions, 0)), counted / 16,
                             static_cast<std::size_t>(kMaxFingerprintFunctions)}));
  return k >= 8 ? k : 0;
}

double fingerprint_rms(std::size_t counted, const FingerprintOptions& options) {
  if (counted >= kFingerprintFullVertices) return options.rms;
  const double boost =
      counted == 0
          ? kFingerprintMaxBoost
          : std::sqrt(static_cast<double>(kFingerprintFullVertices) / static_cast<double>(counted));
  return options.rms * std::min(kFingerprintMaxBoost, boost);
}

namespace {

// Rows [offset, offset + rows' rows) of Phi a into s (and 1 into covered where a row has
// entries), summed in each row's order of bumps.
void add_field(const FingerprintBasis& rows, Eigen::Index offset, const Eigen::VectorXd& a,
               Eigen::VectorXd& s, std::vector<std::uint8_t>* covered) {
  const Eigen::Index n = static_cast<Eigen::Index>(rows.row_start.size()) - 1;
  for (Eigen::Index j = 0; j < n; ++j) {
    const Eigen::Index i = offset + j;
    for (int e = rows.row_start[j]; e < rows.row_start[j + 1]; ++e) {
      if (static_cast<unsigned>(rows.index[e]) >= static_cast<unsigned>(rows.functions))
        throw InvalidArgumentError(
            fmt::format("the basis' row {} names bump {} of {}", i, rows.index[e], rows.functions));
      s(i) += rows.value[e] * a(rows.index[e]);
    }
    if (covered && rows.row_start[j + 1] > rows.row_start[j]) (*covered)[i] = 1;
  }
}

void check_coefficients(const FingerprintBasis& b, const Eigen::VectorXd& a) {
  if (a.size() != b.functions)
    throw InvalidArgumentError(
        fmt::format("a fingerprint of {} coefficients for a basis of {}", a.size(), b.functions));
}

}  // namespace

Eigen::VectorXd FingerprintBasis::field(const Eigen::VectorXd& a) const {
  check_coefficients(*this, a);
  check_rows(*this, false);
  Eigen::VectorXd s = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(row_start.size()) - 1);
  add_field(*this, 0, a, s, nullptr);
  return s;
}

Eigen::VectorXd fingerprint_field_at(const FingerprintBasis& basis, const Eigen::MatrixX3d& P,
                                     const std::vector<std::uint8_t>& mask,
                                     const Eigen::VectorXd& a, std::vector<std::uint8_t>* covered) {
  FingerprintBasis block = bumps_of(basis, P, mask);
  check_coefficients(block, a);
  const BumpGrid grid(block.points, 3 * block.width);
  Eigen::VectorXd s = Eigen::VectorXd::Zero(P.rows());
  if (covered) covered->assign(static_cast<std::size_t>(P.rows()), 0);
  for (Eigen::Index begin = 0; begin < P.rows(); begin += kFieldBlock) {
    const Eigen::Index rows = std::min(kFieldBlock, P.rows() - begin);
    const std::vector<std::uint8_t> part(mask.begin() + begin, mask.begin() + begin + rows);
    evaluate_bumps(block, grid, P.middleRows(begin, rows), part);
    add_field(block, begin, a, s, covered);
  }
  return s;
}

FingerprintBasis fingerprint_bumps(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                                   const std::vector<std::uint8_t>& carrier,
                                   const Eigen::Vector3d& center, int functions, int format) {
  const double width_factor = fingerprint_width_factor(format);
  if (functions < 1 || functions > kMaxFingerprintFunctions)
    throw InvalidArgumentError(fmt::format("a fingerprint needs 1 to {} functions, not {}",
                                           kMaxFingerprintFunctions, functions));
  if (carrier.size() != static_cast<std::size_t>(V.rows()))
    throw InvalidArgumentError("the carrier mask does not match the vertices");
  std::vector<Eigen::Index> counted;
  for (Eigen::Index i = 0; i < V.rows(); ++i)
    if (carrier[i] == kCounted) counted.push_back(i);
  if (counted.size() < 16 * static_cast<std::size_t>(functions))
    throw InvalidArgumentError(fmt::format(
        "a fingerprint of {} functions needs {} counted carrier vertices; the mesh has {}",
        functions, 16 * functions, counted.size()));
  FingerprintBasis b;
  b.functions = functions;
  b.center = center;
  b.diagonal = bounding_box_diagonal(V, carrier);
  const double area = triangle_area_sum(V, F);
  if (!(area > 0)) throw InvalidArgumentError("the mesh has no area to spread a fingerprint on");
  if (!std::isfinite(area))
    throw InvalidArgumentError("the mesh's area overflows double: too large for a fingerprint");
  b.width = width_factor * std::sqrt(area / functions);
  // Farthest-point sampling: the first center the counted vertex farthest from `center`.
  std::vector<double> nearest(counted.size(), std::numeric_limits<double>::infinity());
  std::size_t pick = 0;
  double far = -1;
  for (std::size_t j = 0; j < counted.size(); ++j) {
    const double d = (V.row(counted[j]).transpose() - center).squaredNorm();
    if (d > far) far = d, pick = j;
  }
  for (int k = 0; k < functions; ++k) {
    b.centers.push_back(static_cast<int>(counted[pick]));
    const Eigen::RowVector3d c = V.row(counted[pick]);
    std::size_t next = 0;
    double best = -1;
    for (std::size_t j = 0; j < counted.size(); ++j) {
      nearest[j] = std::min(nearest[j], (V.row(counted[j]) - c).squaredNorm());
      if (nearest[j] > best) best = nearest[j], next = j;
    }
    pick = next;
  }
  b.points.resize(functions, 3);
  for (int k = 0; k < functions; ++k) b.points.row(k) = V.row(b.centers[k]);
  // Scaled to a mean square of 1 over the counted vertices.
  b.scale = 1 / std::sqrt(bump_mean_square(b, V, counted_mask(carrier), counted.size()));
  if (!std::isfinite(b.scale) || !(b.scale > 0))  // squared distances overflowed
    throw InvalidArgumentError(
        "the mesh's squared distances overflow double: too large for a "
        "fingerprint");
  return b;
}

FingerprintBasis fingerprint_basis(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                                   const std::vector<std::uint8_t>& carrier,
                                   const Eigen::Vector3d& center, int functions, int format) {
  FingerprintBasis b = fingerprint_bumps(V, F, carrier, center, functions, format);
  evaluate_bumps(b, BumpGrid(b.points, 3 * b.width), V, counted_mask(carrier));
  return b;
}

FingerprintBasis fingerprint_basis_at(const FingerprintBasis& basis, const Eigen::MatrixX3d& P,
                                      const std::vector<std::uint8_t>& mask) {
  FingerprintBasis b = bumps_of(basis, P, mask);
  evaluate_bumps(b, BumpGrid(b.points, 3 * b.width), P, mask);
  return b;
}

std::optional<FingerprintFrame> fingerprint_frame(const Eigen::MatrixX3d& V,
                                                  const Eigen::MatrixX3i& F, CenterKind kind,
                                                  int nbits, bool rows, int format) {
  const std::vector<std::uint8_t> carrier = carrier_vertices(V, F);
  const int functions = fingerprint_functions(
      static_cast<std::size_t>(std::count(carrier.begin(), carrier.end(), kCounted)));
  if (functions <= 0) return std::nullopt;
  const Center c = center_of_mass(V, F, carrier, kind);
  Eigen::MatrixX3d U = V.rowwise() - c.point.transpose();  // the rays the field moves along
  for (Eigen::Index i = 0; i < U.rows(); ++i)
    if (const double n = U.row(i).norm(); n > 0) U.row(i) /= n;
  return FingerprintFrame{rows ? fingerprint_basis(V, F, carrier, c.point, functions, format)
                               : fingerprint_bumps(V, F, carrier, c.point, functions, format),
                          build_histogram(V, carrier, c.point, nbits),
                          center_jacobian_products(V, F, carrier, kind, U).E,
                          counted_mask(carrier)};
}

namespace {

// Buyer id's signs (formats 4 and 5) into out (bytes bytes): the ChaCha20 keystream of
// derive_key(key, "fingerprint-signs") with the ID as its nonce (8 bytes, least significant
// first); sign i is bit 7 - i % 8 of byte i / 8, 1 giving +1.
void sign_bytes(const Key& sign_key, std::uint64_t id, std::size_t bytes, std::uint8_t* out) {
  std::array<unsigned char, crypto_stream_chacha20_NONCEBYTES> nonce;
  for (std::size_t s = 0; s < nonce.size(); ++s)
    nonce[s] = static_cast<unsigned char>(id >> (8 * s));
  crypto_stream_chacha20(out, bytes, nonce.data(), sign_key.bytes.data());
}

Key sign_key(const Key& key) {
  static_assert(crypto_stream_chacha20_KEYBYTES == 32 && crypto_stream_chacha20_NONCEBYTES == 8);
  if (sodium_init() < 0) throw Error("libsodium could not be initialized");
  return derive_key(key, "fingerprint-signs");
}

Eigen::VectorXd gaussian_coefficients(const Key& key, std::uint64_t id, int functions) {
  const Key k = derive_key(key, "fingerprint");
  Eigen::VectorXd g(functions);
  const double two_pi = 6.283185307179586476925286766559;
  int filled = 0;
  for (std::uint32_t block = 0; filled < functions; ++block) {
    std::vector<std::uint8_t> data;
    for (int s = 0; s < 64; s += 8) data.push_back(static_cast<std::uint8_t>(id >> s));
    for (int s = 0; s < 32; s += 8) data.push_back(static_cast<std::uint8_t>(block >> s));
    const std::vector<std::uint8_t> bits = keyed_hash_bits(k, "fingerprint", data, 512);
    // 8 words of 64 bits; each pair gives two normals (Box-Muller on uniforms in (0, 1)).
    double u[8];
    for (int w = 0; w < 8; ++w) {
      std::uint64_t x = 0;
      for (int i = 0; i < 64; ++i) x = x << 1 | bits[64 * w + i];
      u[w] = (static_cast<double>(x >> 11) + 0.5) / 9007199254740992.0;  // (0, 1), 53 bits
    }
    for (int p = 0; p < 4 && filled < functions; ++p) {
      const double r = std::sqrt(-2 * std::log(u[2 * p])), t = two_pi * u[2 * p + 1];
      g(filled++) = r * std::cos(t);
      if (filled < functions) g(filled++) = r * std::sin(t);
    }
  }
  return g;
}

void check_format(int format) {
  if (!has_fingerprint(format))
    throw InvalidArgumentError(fmt::format("mark format {} carries no fingerprint", format));
}

}  // namespace

double fingerprint_width_factor(int format) {
  check_format(format);
  return format == kFingerprintMarkFormat ? 0.45 : 1.0;
}

Eigen::VectorXd fingerprint_coefficients(const Key& key, std::uint64_t id, int functions,
                                         int format) {
  check_format(format);
  if (functions < 1)
    throw InvalidArgumentError(
        fmt::format("a fingerprint needs at least 1 function, not {}", functions));
  if (format == kGaussianFingerprintFormat) return gaussian_coefficients(key, id, functions);
  std::vector<std::uint8_t> signs(static_cast<std::size_t>(functions + 7) / 8);
  sign_bytes(sign_key(key), id, signs.size(), signs.data());
  Eigen::VectorXd g(functions);
  for (int i = 0; i < functions; ++i) g(i) = (signs[i / 8] >> (7 - i % 8)) & 1 ? 1.0 : -1.0;
  return g;
}

namespace {

// How near its bin's edge (in bins) the field may move a vertex of the copy.
constexpr double kBinMargin = 0.02;

// Takes out of s, over the counted vertices not in `bound`, the least-squares line a + b t of
// each radial class of keep (so every class's mean and first moment in t are those of the bound
// values alone: 0 when none is bound) and, with `motion` (row i: how the center moves per unit
// of vertex i's radial move), the field's first-order move of the center: one least-squares
// projection onto all these constraints together (per class 2, the center 3; solved through the
// center's 3 x 3 Schur complement). A class whose t does not vary keeps only its mean.
void take_out(const Histogram& keep, const Eigen::MatrixX3d* motion,
              const std::vector<std::uint8_t>& bound, Eigen::VectorXd& s) {
  const int classes = keep.bins * kSlices;
  std::vector<Eigen::Matrix2d> G(classes, Eigen::Matrix2d::Zero());
  std::vector<Eigen::Matrix<double, 2, 3>> C(classes, Eigen::Matrix<double, 2, 3>::Zero());
  std::vector<Eigen::Vector2d> m(classes, Eigen::Vector2d::Zero());
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  Eigen::Vector3d r = Eigen::Vector3d::Zero();
  const auto e_of = [&](Eigen::Index i) -> Eigen::Vector3d {
    return motion ? Eigen::Vector3d(motion->row(i).transpose()) : Eigen::Vector3d::Zero();
  };
  for (Eigen::Index i = 0; i < s.size(); ++i) {
    const int c = radial_class(keep, i);
    const Eigen::Vector3d e = e_of(i);
    r += e * s(i);  // every vertex moves the center, counted or not
    if (c < 0) continue;
    const Eigen::Vector2d x(1, keep.t(i));
    m[c] += x * s(i);
    if (bound[static_cast<std::size_t>(i)]) continue;
    G[c] += x * x.transpose(), C[c] += x * e.transpose(), H += e * e.transpose();
  }
  std::vector<Eigen::Matrix2d> inv(classes);
  Eigen::Matrix3d S = H;
  Eigen::Vector3d rhs = r;
  for (int c = 0; c < classes; ++c) {
    inv[c] = line_fit_operator(G[c]);
    S -= C[c].transpose() * inv[c] * C[c];
    rhs -= C[c].transpose() * inv[c] * m[c];
  }
  // The center's part: none without motion, or where the free vertices cannot move it.
  Eigen::Vector3d mu = Eigen::Vector3d::Zero();
  if (motion && S.trace() > 0) mu = S.completeOrthogonalDecomposition().solve(rhs);
  for (Eigen::Index i = 0; i < s.size(); ++i) {
    const int c = radial_class(keep, i);
    if (c < 0 || bound[static_cast<std::size_t>(i)]) continue;
    const Eigen::Vector2d lambda = inv[c] * (m[c] - C[c] * mu);
    s(i) -= Eigen::Vector2d(1, keep.t(i)).dot(lambda) + e_of(i).dot(mu);
  }
}

// Bounds the field s so that no counted vertex of the copy V crosses into another bin of keep
// or past the range's ends: a crossing changes two bins' means by about 1 / (their count), far
// more than the field's own mean does (on spot, a vertex the mark had parked at G = 0.05 from
// its bin's edge crossed, and a vertex overtook the farthest one: two bits flipped). Each vertex
// keeps kBinMargin of a bin from the edge it moves towards (measured in V around keep's center;
// one already nearer does not move towards it); the line fit of each class is then taken out
// again over the vertices the bounds leave free, up to four times, and the bounds applied last.
void keep_in_bins(const Eigen::MatrixX3d& V, const Histogram& keep, const Eigen::MatrixX3d* motion,
                  Eigen::VectorXd& s) {
  const Eigen::Index n = s.size();
  std::vector<Eigen::Index> counted;
  Eigen::VectorXd lo = Eigen::VectorXd::Zero(n), hi = Eigen::VectorXd::Zero(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    if (radial_class(keep, i) < 0) continue;
    counted.push_back(i);
    const double u = ((V.row(i).transpose() - keep.center).norm() - keep.rho_min) / keep.step;
    const double t = u - std::clamp(std::floor(u), 0.0, static_cast<double>(keep.bins - 1));
    lo(i) = std::min(0.0, (kBinMargin - t) * keep.step);
    hi(i) = std::max(0.0, (1 - kBinMargin - t) * keep.step);
  }
  std::vector<std::uint8_t> bound(static_cast<std::size_t>(n), 0);
  for (const int extreme : {keep.argmin, keep.argmax})
    if (extreme >= 0) bound[static_cast<std::size_t>(extreme)] = 1;  // they stay where they are
  for (int round = 0; round < 4; ++round) {
    bool clamped = false;
    for (const Eigen::Index i : counted)
      if (s(i) < lo(i) || s(i) > hi(i))
        s(i) = std::clamp(s(i), lo(i), hi(i)), bound[i] = 1, clamped = true;
    if (!clamped) return;
    take_out(keep, motion, bound, s);  // bound values count in the sums, and are not refitted
  }
  for (const Eigen::Index i : counted) s(i) = std::clamp(s(i), lo(i), hi(i));
}

}  // namespace

namespace {

// add_fingerprint with the field s = Phi g at VO's rows (in model units) and covered[i] != 0
// where row i has basis entries.
Eigen::MatrixX3d place_field(const Eigen::MatrixX3d& V, const Eigen::MatrixX3d& VO,
                             const Eigen::Vector3d& center, Eigen::VectorXd s,
                             const std::vector<std::uint8_t>& covered, const Histogram* keep,
                             const Eigen::MatrixX3d* center_motion) {
  if (keep) {
    if (keep->bin.size() != static_cast<std::size_t>(VO.rows()))
      throw InvalidArgumentError("the histogram to keep is of another mesh");
    if (center_motion && center_motion->rows() != VO.rows())
      throw InvalidArgumentError("the center's motion is of another mesh");
    // Per class, the least-squares fit a + b t of the field (t: the position in the bin) is
    // taken out, and with center_motion the field's move of the center, together; the
    // vertices that set the range stay where they are.
    std::vector<std::uint8_t> bound(static_cast<std::size_t>(s.size()), 0);
    for (const int extreme : {keep->argmin, keep->argmax})
      if (extreme >= 0) s(extreme) = 0, bound[static_cast<std::size_t>(extreme)] = 1;
    take_out(*keep, center_motion, bound, s);
    keep_in_bins(V, *keep, center_motion, s);
  }
  // Twins (bit-identical positions) take the displacement of the vertex with basis entries at
  // their position; a vertex without one stays where it is.
  const auto bits_of = [&](Eigen::Index i) {
    std::array<std::uint64_t, 3> key;
    for (int c = 0; c < 3; ++c) std::memcpy(&key[c], &VO(i, c), sizeof(double));
    return key;
  };
  // A vertex with entries moves by its own value (two vertices at one position never both have
  // entries); the others look their position up among those with entries (sorted once, and
  // only when there are any: a map here cost a copy of 44k vertices 15 ms).
  std::vector<Eigen::Index> owner(static_cast<std::size_t>(VO.rows()), -1), without;
  for (Eigen::Index i = 0; i < VO.rows(); ++i) {
    if (covered[i])
      owner[i] = i;
    else
      without.push_back(i);
  }
  if (!without.empty()) {
    std::vector<std::pair<std::array<std::uint64_t, 3>, Eigen::Index>> first;
    for (Eigen::Index i = 0; i < VO.rows(); ++i)
      if (owner[i] == i) first.emplace_back(bits_of(i), i);
    std::sort(first.begin(), first.end());
    for (const Eigen::Index i : without) {
      const std::array<std::uint64_t, 3> key = bits_of(i);
      const auto it = std::lower_bound(
          first.begin(), first.end(), key,
          [](const auto& entry, const std::array<std::uint64_t, 3>& k) { return entry.first < k; });
      if (it != first.end() && it->first == key) owner[i] = it->second;
    }
  }
  Eigen::MatrixX3d out = V;
  for (Eigen::Index i = 0; i < V.rows(); ++i) {
    if (owner[i] < 0) continue;
    const Eigen::Vector3d u = VO.row(owner[i]).transpose() - center;
    const double len = u.norm();
    if (len > 0) out.row(i) += (s(owner[i]) / len) * u.transpose();
  }
  return out;
}

void check_adding(const Eigen::MatrixX3d& V, const Eigen::MatrixX3d& VO, double rms) {
  if (V.rows() != VO.rows())
    throw InvalidArgumentError("the copy and the original differ in vertex count");
  if (!(rms >= 0 && rms < 0.01))
    throw InvalidArgumentError(fmt::format("fingerprint RMS {} is outside [0, 0.01)", rms));
}

}  // namespace

Eigen::MatrixX3d add_fingerprint(const Eigen::MatrixX3d& V, const Eigen::MatrixX3d& VO,
                                 const FingerprintBasis& basis, const Eigen::VectorXd& g,
                                 double rms, const Histogram* keep,
                                 const Eigen::MatrixX3d* center_motion) {
  check_adding(V, VO, rms);
  if (static_cast<Eigen::Index>(basis.row_start.size()) != V.rows() + 1)
    throw InvalidArgumentError("the copy, the original and the basis differ in vertex count");
  Eigen::VectorXd s = basis.field(g) * (rms * basis.diagonal);
  std::vector<std::uint8_t> covered(static_cast<std::size_t>(V.rows()), 0);
  for (Eigen::Index i = 0; i < V.rows(); ++i)
    covered[i] = basis.row_start[i + 1] > basis.row_start[i];
  return place_field(V, VO, basis.center, std::move(s), covered, keep, center_motion);
}

Eigen::MatrixX3d add_fingerprint_at(const Eigen::MatrixX3d& V, const Eigen::MatrixX3d& VO,
                                    const FingerprintBasis& bumps,
                                    const std::vector<std::uint8_t>& counted,
                                    const Eigen::VectorXd& g, double rms, const Histogram* keep,
                                    const Eigen::MatrixX3d* center_motion) {
  check_adding(V, VO, rms);
  std::vector<std::uint8_t> covered;
  Eigen::VectorXd s = fingerprint_field_at(bumps, VO, counted, g, &covered);
  s *= rms * bumps.diagonal;
  return place_field(V, VO, bumps.center, std::move(s), covered, keep, center_motion);
}

Eigen::VectorXd read_fingerprint(const FingerprintBasis& basis, const Eigen::VectorXd& residual,
                                 const std::vector<std::uint8_t>& measured, const Histogram* keep,
                                 double ridge, const Eigen::VectorXd* obliquity) {
  const Eigen::Index n = static_cast<Eigen::Index>(basis.row_start.size()) - 1;
  check_reading(n, residual, measured, keep, ridge, obliquity);
  check_rows(basis, true);
  NormalEquations equations(basis.functions, keep, obliquity);
  equations.add(basis, 0, residual, measured);
  return equations.solve(ridge);
}

Eigen::VectorXd read_fingerprint_at(const FingerprintBasis& basis, const Eigen::MatrixX3d& P,
                                    const Eigen::VectorXd& residual,
                                    const std::vector<std::uint8_t>& measured,
                                    const Histogram* keep, double ridge,
                                    const Eigen::VectorXd* obliquity) {
  FingerprintBasis block = bumps_of(basis, P, measured);
  check_reading(P.rows(), residual, measured, keep, ridge, obliquity);
  const BumpGrid grid(block.points, 3 * block.width);
  NormalEquations equations(basis.functions, keep, obliquity);
  for (Eigen::Index begin = 0; begin < P.rows(); begin += kFieldBlock) {
    const Eigen::Index rows = std::min(kFieldBlock, P.rows() - begin);
    const std::vector<std::uint8_t> mask(measured.begin() + begin, measured.begin() + begin + rows);
    evaluate_bumps(block, grid, P.middleRows(begin, rows), mask);
    equations.add(block, begin, residual, measured);
  }
  return equations.solve(ridge);
}

void check_fingerprint_partitions(const std::vector<int>& partitions) {
  for (auto it = partitions.begin(); it != partitions.end(); ++it) {
    if (*it < 2 || *it > kMaxFingerprintRegions)
      throw InvalidArgumentError(
          fmt::format("a fingerprint is read over 2 to {} regions at a time, not {}",
                      kMaxFingerprintRegions, *it));
    if (std::find(partitions.begin(), it, *it) != it)
      throw InvalidArgumentError(fmt::format("the partition of {} regions is listed twice", *it));
  }
}

std::vector<std::vector<int>> fingerprint_regions(const FingerprintBasis& basis,
                                                  const std::vector<int>& partitions) {
  check_fingerprint_partitions(partitions);
  std::vector<std::vector<int>> regions;
  for (const int r : partitions) {
    if (r > basis.functions || basis.points.rows() < r) continue;
    std::vector<std::vector<int>> cut(static_cast<std::size_t>(r));
    for (int k = 0; k < basis.functions && k < basis.points.rows(); ++k) {
      int nearest = 0;
      double best = std::numeric_limits<double>::infinity();
      for (int s = 0; s < r; ++s) {
        const double d = (basis.points.row(k) - basis.points.row(s)).squaredNorm();
        if (d < best) best = d, nearest = s;
      }
      cut[static_cast<std::size_t>(nearest)].push_back(k);
    }
    for (std::vector<int>& region : cut)
      if (!region.empty()) regions.push_back(std::move(region));
  }
  return regions;
}

Eigen::VectorXd regional_reading(const Eigen::VectorXd& b, const std::vector<int>& region) {
  Eigen::VectorXd out = Eigen::VectorXd::Zero(b.size());
  for (const int k : region) {
    if (k < 0 || k >= b.size())
      throw InvalidArgumentError(
          fmt::format("a region holds bump {} of a reading of {} coefficients", k, b.size()));
    out(k) = b(k);
  }
  return out;
}

double fingerprint_score(const Eigen::VectorXd& g, const Eigen::VectorXd& b) {
  if (g.size() != b.size())
    throw InvalidArgumentError("a fingerprint and a reading of different lengths");
  const double norm = b.norm();
  return norm > 0 ? g.dot(b) / norm : 0.0;
}

double normal_upper_tail(double z) {
  return 0.5 * std::erfc(z / std::sqrt(2.0));
}

double rademacher_tail_factor() {
  static const double c = 1 / (4 * normal_upper_tail(std::sqrt(2.0)));
  return c;
}

double fingerprint_p_value(double z, int format) {
  check_format(format);
  if (format == kGaussianFingerprintFormat) return normal_upper_tail(z);
  return std::min(1.0, rademacher_tail_factor() * normal_upper_tail(z));
}

double fingerprint_p_value(double z_whole, std::size_t whole, double z_regional,
                           std::size_t regional, double share, int format) {
  if (!(share > 0 && share < 1))
    throw InvalidArgumentError(
        fmt::format("the regions' share of the false-alarm budget {} is outside (0, 1)", share));
  if (whole == 0) throw InvalidArgumentError("a fingerprint's p needs a reading of the whole");
  const double p_whole = fingerprint_p_value(z_whole, format) * static_cast<double>(whole);
  if (regional == 0) return std::min(1.0, p_whole);
  const double p_regional = fingerprint_p_value(z_regional, format) * static_cast<double>(regional);
  return std::min({1.0, p_whole / (1 - share), p_regional / share});
}

double combined_p_value(double p_bins, double p_fingerprint) {
  if (!(p_bins >= 0 && p_bins <= 1 && p_fingerprint >= 0 && p_fingerprint <= 1))
    throw InvalidArgumentError(
        fmt::format("p-values {} and {} are not both in [0, 1]", p_bins, p_fingerprint));
  const double bonferroni = 2 * std::min(p_bins, p_fingerprint);
  double product = 0;  // t (1 - ln t), in logarithms (t may underflow)
  if (p_bins > 0 && p_fingerprint > 0) {
    const double log_t = std::log(p_bins) + std::log(p_fingerprint);
    product = std::exp(log_t) * (1 - log_t);
  }
  return std::min(1.0, 2 * std::min(bonferroni, product));
}

FingerprintScorer::FingerprintScorer(const Key& key, int functions,
                                     std::vector<Eigen::VectorXd> readings)
    : key_(key), sign_key_(sign_key(key)), functions_(functions), readings_(std::move(readings)) {
  if (functions < 1)
    throw InvalidArgumentError(
        fmt::format("a fingerprint needs at least 1 function, not {}", functions));
  // table_[(c 256 + v) R + r]: reading r's partial sum over byte c of the signs when that byte
  // is v, divided by |b_r| (R readings side by side, so that a candidate's byte fetches every
  // reading's term from one place).
  const int bytes = (functions + 7) / 8;
  const std::size_t R = readings_.size();
  table_.assign(static_cast<std::size_t>(bytes) * 256 * R, 0.0);
  for (std::size_t r = 0; r < R; ++r) {
    const Eigen::VectorXd& b = readings_[r];
    if (b.size() != functions)
      throw InvalidArgumentError(
          fmt::format("a reading of {} coefficients for a fingerprint of {}", b.size(), functions));
    const double norm = b.norm();
    if (norm > 0)
      for (int c = 0; c < bytes; ++c)
        for (int v = 0; v < 256; ++v) {
          double sum = 0;
          for (int bit = 0; bit < 8 && 8 * c + bit < functions; ++bit)
            sum += ((v >> (7 - bit)) & 1 ? 1.0 : -1.0) * b(8 * c + bit);
          table_[(static_cast<std::size_t>(c) * 256 + v) * R + r] = sum / norm;
        }
  }
}

double FingerprintScorer::best_z(std::uint64_t id, int format) const {
  const auto [z, none] = best_z_split(id, format, readings_.size());
  return z;
}

std::pair<double, double> FingerprintScorer::best_z_split(std::uint64_t id, int format,
                                                          std::size_t split) const {
  std::pair<double, double> best;
  best_z_split(&id, 1, format, split, &best);
  return best;
}

void FingerprintScorer::best_z_split(const std::uint64_t* ids, std::size_t count, int format,
                                     std::size_t split, std::pair<double, double>* out) const {
  check_format(format);
  constexpr double kNone = -std::numeric_limits<double>::infinity();
  const std::size_t R = readings_.size();
  const auto take = [&](std::pair<double, double>& best, std::size_t r, double z) {
    double& part = r < split ? best.first : best.second;
    part = std::max(part, z);
  };
  std::fill(out, out + count, std::pair<double, double>{kNone, kNone});
  if (format == kGaussianFingerprintFormat) {
    for (std::size_t i = 0; i < count; ++i) {
      const Eigen::VectorXd g = gaussian_coefficients(key_, ids[i], functions_);
      for (std::size_t r = 0; r < R; ++r) take(out[i], r, fingerprint_score(g, readings_[r]));
    }
    return;
  }
  // Every buyer's sign bytes, then byte by byte the table's slice of that byte (256 x R terms)
  // added to each buyer's sums: the slice stays in cache across the batch. Each sum still adds
  // its terms in byte order, as for one buyer alone.
  const std::size_t bytes = (static_cast<std::size_t>(functions_) + 7) / 8;
  std::vector<std::uint8_t> signs(count * bytes);
  for (std::size_t i = 0; i < count; ++i) sign_bytes(sign_key_, ids[i], bytes, &signs[i * bytes]);
  std::vector<double> z(count * R, 0.0);
  for (std::size_t c = 0; c < bytes; ++c) {
    const double* slice = table_.data() + c * 256 * R;
    for (std::size_t i = 0; i < count; ++i) {
      const double* terms = slice + static_cast<std::size_t>(signs[i * bytes + c]) * R;
      double* sum = &z[i * R];
      for (std::size_t r = 0; r < R; ++r) sum[r] += terms[r];
    }
  }
  for (std::size_t i = 0; i < count; ++i)
    for (std::size_t r = 0; r < R; ++r) take(out[i], r, z[i * R + r]);
}

}  // namespace meshmark
