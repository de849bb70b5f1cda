#pragma once
/// \file fingerprint.h
/// The fingerprint: a second, informed mark that issue_copies can add to a registered copy
/// (IssueSettings::fingerprint) and that only trace reads, with the original in hand
/// (docs/forensics.md, "The fingerprint"; docs/format.md section 8).
///
/// A copy's fingerprint is a smooth field of radial displacements, s = Phi g: Phi holds K
/// Gaussian bumps spread over the original's surface (fingerprint_basis), g is K independent
/// standard normal coefficients regenerated from the key and the buyer's ID
/// (fingerprint_coefficients; the registry stores nothing of them). Smoothing and resampling
/// keep such low frequencies; trace measures the leak's radial residual at the original's
/// vertices, fits it with Phi (read_fingerprint: b), and scores a candidate by the normalized
/// correlation z = g.b / |b|. For an innocent buyer, g is independent of b, and z is then
/// exactly standard normal whatever b is: its p-value (the normal upper tail) is exact. An
/// average of k copies keeps each colluder's coefficients at 1/k: z about sqrt(K / k).
/// What a histogram mark moves (a function of the distance to the center) is kept out of the
/// field and of the reading (add_fingerprint's and read_fingerprint's `keep`).

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <utility>
#include <vector>

#include "meshmark/carrier/center.h"
#include "meshmark/carrier/histogram.h"
#include "meshmark/protocol/key.h"

namespace meshmark {

/// The mark format of a copy issued with the fingerprint (IssuedCopy::mark_format): format 2's
/// histogram mark and ID code (the same keys), plus the fingerprint with FingerprintOptions'
/// defaults, its coefficients random signs (fingerprint_coefficients), its bumps of width
/// 0.45 sqrt(area / K) (fingerprint_width_factor).
inline constexpr int kFingerprintMarkFormat = 5;
/// Mark format 4: as format 5 with bumps of width sqrt(area / K), which overlap so much that
/// the field has about 30 to 50 independent directions instead of a few hundred. Copies were
/// issued so from 2026-12-05 to 2026-12-07 (before any release); trace still reads them.
inline constexpr int kWideBumpFingerprintFormat = 4;
/// Mark format 3: as format 4 with standard normal coefficients. Copies were issued so from
/// 2026-12-05 to 2026-12-06 (before any release); trace still reads them, at about 30 µs a
/// candidate where formats 4 and 5 take under 1 µs.
inline constexpr int kGaussianFingerprintFormat = 3;

/// Whether copies of this mark format carry a fingerprint (formats 3, 4 and 5).
constexpr bool has_fingerprint(int mark_format) {
  return mark_format == kGaussianFingerprintFormat || mark_format == kWideBumpFingerprintFormat ||
         mark_format == kFingerprintMarkFormat;
}

/// The bumps' width in a mark format with a fingerprint, as a multiple of the spacing
/// sqrt(area / K): 1 for formats 3 and 4, 0.45 for format 5.
/// \throw InvalidArgumentError for a format without a fingerprint.
double fingerprint_width_factor(int mark_format);

/// Settings of the fingerprint; part of mark format 3 (docs/format.md section 8).
struct FingerprintOptions {
  /// K, the number of basis functions: at most one per 16 counted carrier vertices. An
  /// innocent's score does not depend on K; the buyer's grows as sqrt(K) (an unprocessed copy
  /// of bunny00: z = 5.6, 8.0, 11.5, 15.3, 20.5 at K = 32 to 512), and so do colluders'.
  int functions = 512;
  /// The fingerprint's expected RMS radial displacement on originals of at least
  /// kFingerprintFullVertices counted carrier vertices, as a fraction of the original's
  /// bounding-box diagonal (1e-4: 0.01 %, a quarter of the paper's RMS limit of 0.04 %); smaller
  /// originals get more (fingerprint_rms).
  double rms = 1e-4;
};

/// Counted carrier vertices from which a fingerprint has FingerprintOptions::rms; below,
/// fingerprint_rms raises it. At 0.01 % the campaigns' meshes of 24k to 44k vertices read
/// strongly enough; ChineseDragon-10kv (10,000) gained 6 of 128 leaks with the raise and lost
/// none (bench/results/trace-all-fingerprint/README.md).
inline constexpr std::size_t kFingerprintFullVertices = 32768;
/// The most fingerprint_rms raises the RMS on small originals: 3 times options.rms (0.03 % of
/// the diagonal by default, still below the paper's RMS limit of 0.04 % on its own).
inline constexpr double kFingerprintMaxBoost = 3;

/// The RMS a fingerprint is issued with on an original of `counted` counted carrier vertices,
/// as a fraction of its bounding-box diagonal: options.rms times
/// min(kFingerprintMaxBoost, sqrt(kFingerprintFullVertices / counted)), and options.rms itself
/// from kFingerprintFullVertices on. A copy's score at trace does not depend on the RMS (the
/// normalized correlation z); its strength against the rest of the reading does, and the rest
/// (what the histogram mark leaves, what processing adds) is averaged over fewer vertices per
/// function on a smaller original: its measured coefficients are noisier by about the square
/// root of the vertex count, which this makes up for (docs/forensics.md, "Small originals").
double fingerprint_rms(std::size_t counted, const FingerprintOptions& options = {});

/// The most basis functions a fingerprint can have (a bump's index is 16 bits).
inline constexpr int kMaxFingerprintFunctions = 65535;

/// K for an original with `counted` counted carrier vertices: options.functions, or one per 16
/// vertices when there are fewer; 0 (no fingerprint) below 8 functions (128 vertices).
int fingerprint_functions(std::size_t counted, const FingerprintOptions& options = {});

/// The basis of an original: K Gaussian bumps exp(-|v - c_k|^2 / (2 w^2)), centered at K
/// carrier vertices picked by farthest-point sampling and cut at 3 w, scaled together so that
/// the mean over the counted carrier vertices of sum_k phi_k(v)^2 is 1 (then a field Phi g with
/// standard normal g has an expected mean square of 1).
struct FingerprintBasis {
  int functions = 0;         ///< K
  Eigen::Vector3d center;    ///< what the displacements point away from
  double diagonal = 0;       ///< the original's bounding-box diagonal (model units)
  double width = 0;          ///< w (model units)
  std::vector<int> centers;  ///< the K vertices the bumps are centered at
  Eigen::MatrixX3d points;   ///< K x 3: their positions (model units)
  double scale = 0;          ///< the factor every bump is multiplied by (see above)
  /// Phi, row by row (compressed rows: vertex i's entries are index/value[row_start[i] ..
  /// row_start[i + 1]], in increasing order of bumps); no entries for vertices off the carrier
  /// or twins. About 36 entries a counted vertex, 6 bytes each: the values are rounded to
  /// single precision (a relative 2^-24 of each; the fingerprint moves vertices by about 1e-4
  /// of the diagonal, so by 1e-11 of it at most).
  std::vector<int> row_start;
  std::vector<std::uint16_t> index;
  std::vector<float> value;

  /// Phi a: the field of coefficients a (size K) at every vertex.
  /// \throw InvalidArgumentError for a of another size, row starts that do not match the
  /// entries, or a bump index outside [0, K).
  Eigen::VectorXd field(const Eigen::VectorXd& a) const;
};

/// The basis of (V, F) around center, over the carrier (histogram.h: carrier_vertices), for
/// copies of mark `format`; w is fingerprint_width_factor(format) times the spacing
/// sqrt(area / K) of K points over the carrier's surface. Deterministic: the first center is
/// the counted vertex farthest from `center` (the smallest index among equals).
/// \throw InvalidArgumentError for functions outside [1, kMaxFingerprintFunctions], fewer
/// than 16 counted vertices a function, or a format without a fingerprint.
FingerprintBasis fingerprint_basis(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                                   const std::vector<std::uint8_t>& carrier,
                                   const Eigen::Vector3d& center, int functions,
                                   int format = kFingerprintMarkFormat);

/// fingerprint_basis' bumps (functions, center, diagonal, width, centers, points, scale)
/// without its rows (row_start, index and value empty): what read_fingerprint_at needs. trace
/// reads a leak with them and never needs the rows at the original's vertices.
/// \throw InvalidArgumentError as fingerprint_basis does.
FingerprintBasis fingerprint_bumps(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                                   const std::vector<std::uint8_t>& carrier,
                                   const Eigen::Vector3d& center, int functions,
                                   int format = kFingerprintMarkFormat);

/// The same K bumps (basis' points, width and scale) evaluated at other points: row i holds
/// phi_k(P_i) for the bumps within 3 w of P_i, for the rows with mask[i] != 0 (none for the
/// others). trace reads a leak at its own vertices with it: a resampled leak's vertices lie on
/// the marked surface, where the faces between them cut corners.
FingerprintBasis fingerprint_basis_at(const FingerprintBasis& basis, const Eigen::MatrixX3d& P,
                                      const std::vector<std::uint8_t>& mask);

/// What adding and reading a fingerprint needs of an original: its basis and the histogram
/// the field keeps (its bins' means and range), around the center of `kind`.
struct FingerprintFrame {
  FingerprintBasis basis;
  Histogram histogram;  ///< of nbits bits around the basis' center
  /// #V x 3: row i, how the center (of the frame's kind) moves per unit of vertex i's move
  /// along the ray from the center (center_jacobian_products), for add_fingerprint.
  Eigen::MatrixX3d center_motion;
  /// #V: 1 for the counted carrier vertices, where the basis is evaluated (add_fingerprint_at).
  std::vector<std::uint8_t> counted;
};

/// The frame of (V, F) for a histogram mark of nbits bits centered as `kind` says, with
/// fingerprint_functions' K and the bumps of mark `format`; none when the original has too few
/// counted carrier vertices. With `rows` false, the basis is its bumps alone
/// (fingerprint_bumps), for add_fingerprint_at: a copy made once need not hold the rows (about
/// 216 bytes a vertex).
std::optional<FingerprintFrame> fingerprint_frame(const Eigen::MatrixX3d& V,
                                                  const Eigen::MatrixX3i& F, CenterKind kind,
                                                  int nbits, bool rows = true,
                                                  int format = kFingerprintMarkFormat);

/// The K coefficients of buyer `id` under key for a copy of mark `format`, the same on every
/// machine:
/// - formats 4 and 5: independent random signs (+1 or -1, each with probability 1/2): bit 7 - i % 8
///   of byte i / 8 of the ChaCha20 keystream of derive_key(key, "fingerprint-signs") with
///   nonce id (8 bytes, least significant first), 1 giving +1;
/// - format 3: independent standard normal values (Box-Muller on 53-bit uniforms from
///   keyed_hash_bits under derive_key(key, "fingerprint")).
/// \throw InvalidArgumentError for another format, or functions < 1.
Eigen::VectorXd fingerprint_coefficients(const Key& key, std::uint64_t id, int functions,
                                         int format = kFingerprintMarkFormat);

/// V with the fingerprint g added: vertex i moved by rms x diagonal x (Phi g)_i along the unit
/// vector from the basis' center through VO_i (VO: the original's positions, on which the basis
/// was built; V: the copy's, the same rows). Twins move like the vertex they sit on.
/// With `keep` (the original's histogram, built around the basis' center), the field's mean
/// over each radial class of it (each bin cut into 8 slices of equal width) is taken out and
/// the vertices that set its range do not move: the bins' mean distances, which a histogram
/// mark sets, stay as they are, and the field is orthogonal to any function of the distance to
/// the center alone, which is what a histogram mark's displacement nearly is. The field is
/// also bounded so that no counted vertex of V leaves its bin (it keeps 0.02 of a bin from the
/// edge it moves towards; docs/format.md 8.1). With `keep` and `center_motion`
/// (FingerprintFrame::center_motion), it does not move the center either, to first order: a
/// blind decoder's center stays where the histogram mark put it.
Eigen::MatrixX3d add_fingerprint(const Eigen::MatrixX3d& V, const Eigen::MatrixX3d& VO,
                                 const FingerprintBasis& basis, const Eigen::VectorXd& g,
                                 double rms, const Histogram* keep = nullptr,
                                 const Eigen::MatrixX3d* center_motion = nullptr);

/// add_fingerprint with the basis' bumps alone (fingerprint_bumps), evaluated at the rows of VO
/// with counted[i] != 0 (FingerprintFrame::counted, where fingerprint_basis evaluates them): the
/// same copy bit for bit, the rows evaluated 65,536 vertices at a time and never held.
/// \throw InvalidArgumentError as add_fingerprint, or for a mask of another size.
Eigen::MatrixX3d add_fingerprint_at(const Eigen::MatrixX3d& V, const Eigen::MatrixX3d& VO,
                                    const FingerprintBasis& bumps,
                                    const std::vector<std::uint8_t>& counted,
                                    const Eigen::VectorXd& g, double rms,
                                    const Histogram* keep = nullptr,
                                    const Eigen::MatrixX3d* center_motion = nullptr);

/// Phi a at points P: FingerprintBasis::field of fingerprint_basis_at(basis, P, mask), bit for
/// bit, without holding its rows (evaluated 65,536 points at a time). `covered`, when given,
/// gets 1 for the rows with entries (a bump within reach), 0 for the others.
/// \throw InvalidArgumentError for a of another size than K, or a mask of another size than P.
Eigen::VectorXd fingerprint_field_at(const FingerprintBasis& basis, const Eigen::MatrixX3d& P,
                                     const std::vector<std::uint8_t>& mask,
                                     const Eigen::VectorXd& a,
                                     std::vector<std::uint8_t>* covered = nullptr);

/// b: the least-squares fit Phi b ~ residual over the vertices where measured[i] != 0 and the
/// basis has entries, with `ridge` times the mean diagonal of Phi^T Phi added to its diagonal
/// (0: a plain fit, kept defined by a tiny ridge where no vertex covers a bump). Neighbouring
/// bumps overlap, so a plain fit amplifies whatever the bumps do not explain (resampling and
/// smoothing leave plenty); a ridge of 1 keeps the reading of a resampled or smoothed leak
/// (TraceOptions::fingerprint_ridge). With `keep`
/// (the histogram add_fingerprint kept), the residual and every column of Phi lose their mean
/// over each radial class first: what a histogram mark moved (a function of the distance to the
/// center) drops out, and a field added with the same `keep` reads back whole. With
/// `obliquity` too (per row; needs `keep`), each class also loses its fit on it: trace passes
/// (n . u)^2 at each point, n the original's normal and u the direction from the center, which
/// is how much a mark moving vertices along the normals (a re-mark in an N variant) moves their
/// distance to the center.
/// \throw InvalidArgumentError for a ridge outside [0, 1e6), sizes that differ, or a basis whose
/// rows are not well formed (each in increasing order of bumps within [0, K)).
Eigen::VectorXd read_fingerprint(const FingerprintBasis& basis, const Eigen::VectorXd& residual,
                                 const std::vector<std::uint8_t>& measured,
                                 const Histogram* keep = nullptr, double ridge = 0,
                                 const Eigen::VectorXd* obliquity = nullptr);

/// read_fingerprint(fingerprint_basis_at(basis, P, measured), residual, measured, keep, ridge,
/// obliquity),
/// the same reading bit for bit, without holding the basis at P: its rows are evaluated and
/// summed 65,536 at a time. What trace reads a leak with: the rows at all of a leak's points
/// would be the largest allocation of a trace (about 216 bytes a vertex).
/// \throw InvalidArgumentError as fingerprint_basis_at and read_fingerprint do.
Eigen::VectorXd read_fingerprint_at(const FingerprintBasis& basis, const Eigen::MatrixX3d& P,
                                    const Eigen::VectorXd& residual,
                                    const std::vector<std::uint8_t>& measured,
                                    const Histogram* keep = nullptr, double ridge = 0,
                                    const Eigen::VectorXd* obliquity = nullptr);

/// The most regions a partition of fingerprint_regions may have.
inline constexpr int kMaxFingerprintRegions = 64;

/// Throws InvalidArgumentError unless every count of `partitions` is in
/// [2, kMaxFingerprintRegions] and none is listed twice (a second would only cost budget).
void check_fingerprint_partitions(const std::vector<int>& partitions);

/// The regions trace also reads a fingerprint over (docs/forensics.md, "Reading by regions"): for
/// each count R in `partitions`, the K bumps cut into R regions, each bump in the region of the
/// nearest of the first R bump centers (Euclidean distance between centers, ties to the lower
/// index; farthest-point sampling put those R far apart). Each region lists its bumps in
/// increasing order (none is empty); a count above K is skipped (an original too small for
/// it). Depends on the basis alone, on no leak and no candidate, so a
/// reading restricted to a region (regional_reading) keeps an innocent's score within its null.
/// \throw InvalidArgumentError as check_fingerprint_partitions.
std::vector<std::vector<int>> fingerprint_regions(const FingerprintBasis& basis,
                                                  const std::vector<int>& partitions);

/// b over one region: b's coefficients of the region's bumps, 0 for the others.
/// \throw InvalidArgumentError for a bump of the region outside [0, b.size()).
Eigen::VectorXd regional_reading(const Eigen::VectorXd& b, const std::vector<int>& region);

/// A candidate's score: g.b / |b| (0 when b is 0). Exactly standard normal when g is a standard
/// normal vector independent of b.
double fingerprint_score(const Eigen::VectorXd& g, const Eigen::VectorXd& b);

/// P(Z >= z) for a standard normal Z, accurate in the far tail (erfc).
double normal_upper_tail(double z);

/// c* = 1 / (4 P(Z >= sqrt 2)), about 3.178: for independent random signs e_k and any unit
/// vector a, P(sum_k e_k a_k >= z) <= c* P(Z >= z) for every z (Bentkus and Dzindzalieta,
/// Bernoulli 21(2), 2015, the least such constant).
double rademacher_tail_factor();

/// The p-value of an innocent's fingerprint score z (fingerprint_score) for a copy of mark
/// `format`: P(Z >= z) for format 3's normal coefficients (exact), min(1, c* P(Z >= z)) for
/// format 4's signs (a bound that holds whatever the reading).
/// \throw InvalidArgumentError for a format without a fingerprint.
double fingerprint_p_value(double z, int format);

/// The p-value of a candidate's fingerprint read over two families of readings: `whole`
/// readings of the whole surface whose best score is z_whole, and `regional` readings over
/// regions (fingerprint_regions, regional_reading) whose best is z_regional. A weighted
/// Bonferroni: the regions get the share `share` of the false-alarm budget and the whole the
/// rest, min(1, p(z_whole) whole / (1 - share), p(z_regional) regional / share) with p =
/// fingerprint_p_value. For an innocent each reading's p is conservative, so P(p <= u) <=
/// (1 - share) u + share u = u. Without regional readings (regional 0), min(1, p(z_whole)
/// whole): plain Bonferroni.
/// \throw InvalidArgumentError for share outside (0, 1), no whole reading, or a format without
/// a fingerprint.
double fingerprint_p_value(double z_whole, std::size_t whole, double z_regional,
                           std::size_t regional, double share, int format);

/// One p-value from a candidate's two marks, p_bins (the histogram mark's codeword test) and
/// p_fingerprint (fingerprint_p_value), both conservative: P(p <= u) <= u for an innocent.
/// For an innocent the two are independent (its codeword and its signs come from the key
/// through different derived keys, and neither enters the other's reading), so two tests are
/// valid: the smaller p times 2 (Bonferroni), and the product t = p_bins p_fingerprint
/// through the distribution of a product of two independent uniforms, P(U V <= t) =
/// t (1 - ln t) (Fisher's method for two p-values: conservative, because each p is
/// stochastically larger than a uniform). The result is twice the smaller of the two tests'
/// p (Bonferroni again), at most 1: 4 min(p_bins, p_fingerprint) when one mark is lost, about
/// 2 t (1 - ln t) when both read. \throw InvalidArgumentError for a p outside [0, 1].
double combined_p_value(double p_bins, double p_fingerprint);

/// The fingerprint scores of many candidates against the same readings (trace's): each
/// candidate's best z = g.b / |b| over the readings b. A format-4 candidate costs K / 8 bytes
/// of ChaCha20 and K / 8 look-ups of every reading's term at once: each reading's partial sums
/// over every byte of signs are tabulated once, the readings side by side. Format 3 candidates are
/// scored through fingerprint_coefficients.
class FingerprintScorer {
 public:
  /// readings: each of `functions` coefficients (read_fingerprint's b).
  /// \throw InvalidArgumentError when a reading's length is not functions.
  FingerprintScorer(const Key& key, int functions, std::vector<Eigen::VectorXd> readings);
  /// The best z of buyer id's fingerprint over the readings (-infinity without readings).
  /// \throw InvalidArgumentError for a format without a fingerprint.
  double best_z(std::uint64_t id, int format) const;
  /// The best z over the readings before `split` and over those from `split` on, from one draw
  /// of the buyer's coefficients (-infinity for a part without readings).
  /// \throw InvalidArgumentError as best_z.
  std::pair<double, double> best_z_split(std::uint64_t id, int format, std::size_t split) const;
  /// best_z_split of count buyers of one format at once, into out[0 .. count): the same
  /// numbers, computed byte by byte of the signs over the whole batch (each byte's part of the
  /// precomputed table is read once for all of them, so it stays in cache). trace scores its
  /// candidates 256 at a time with it.
  /// \throw InvalidArgumentError as best_z.
  void best_z_split(const std::uint64_t* ids, std::size_t count, int format, std::size_t split,
                    std::pair<double, double>* out) const;
  /// The number of readings.
  std::size_t readings() const { return readings_.size(); }

 private:
  Key key_, sign_key_;
  int functions_ = 0;
  std::vector<Eigen::VectorXd> readings_;
  std::vector<double> table_;  // (K / 8 rounded up) x 256 x readings, readings innermost
};

}  // namespace meshmark
