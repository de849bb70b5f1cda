// The fingerprint (fingerprint.h) on a real mesh: an innocent's score stays within its null
// (formats 4 and 5's random signs: mean 0, variance 1 and a tail under the Bentkus-Dzindzalieta
// bound; format 3's normal coefficients: exactly standard normal, Kolmogorov-Smirnov over 10^5
// innocent IDs against a real reading), both marks' p-values combine conservatively, an
// unprocessed copy scores at its full strength, an average of k copies keeps about 1/k of each
// colluder's raw correlation, and the field is smooth and as strong as asked.

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <sodium.h>

#include <Eigen/Geometry>
#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <numeric>
#include <random>
#include <string>
#include <tuple>
#include <vector>

#include "meshmark/attacks/attack.h"
#include "meshmark/carrier/center.h"
#include "meshmark/carrier/histogram.h"
#include "meshmark/carrier/method.h"
#include "meshmark/core/error.h"
#include "meshmark/core/mesh.h"
#include "meshmark/forensics/fingerprint.h"
#include "meshmark/forensics/issue.h"
#include "meshmark/forensics/registry.h"
#include "meshmark/forensics/trace.h"
#include "meshmark/io/io.h"
#include "meshmark/mark/calibrate.h"
#include "meshmark/mark/embed.h"
#include "meshmark/metrics/metrics.h"
#include "meshmark/protocol/coding.h"
#include "meshmark/protocol/watermark.h"
#include "test_data.h"

namespace meshmark {
namespace {

struct Scene {
  Mesh original;
  std::vector<std::uint8_t> carrier;
  FingerprintBasis basis;
  Key key = key_from_passphrase_v1("fingerprint test key");
};

Scene setup(const std::string& name, int functions = 128) {
  Scene s;
  s.original = read_mesh(test::cgal_mesh(name));
  s.carrier = carrier_vertices(s.original.V, s.original.F);
  const Center c = center_of_mass(s.original.V, s.original.F, s.carrier, CenterKind::Discrete);
  s.basis = fingerprint_basis(s.original.V, s.original.F, s.carrier, c.point, functions);
  return s;
}

// The radial residual of positions P against the original, at the counted vertices.
Eigen::VectorXd residual(const Scene& s, const Eigen::MatrixX3d& P) {
  Eigen::VectorXd r(P.rows());
  for (Eigen::Index i = 0; i < P.rows(); ++i) {
    const Eigen::Vector3d u = s.original.V.row(i).transpose() - s.basis.center;
    r(i) = (P.row(i).transpose() - s.basis.center).dot(u.normalized()) - u.norm();
  }
  return r;
}

std::vector<std::uint8_t> counted(const Scene& s) {
  std::vector<std::uint8_t> m(s.carrier.size());
  for (std::size_t i = 0; i < m.size(); ++i) m[i] = s.carrier[i] == kCounted;
  return m;
}

TEST(Fingerprint, CoefficientsAreKeyedSignsAndReproducible) {
  ASSERT_GE(sodium_init(), 0);
  const Key k = key_from_passphrase_v1("fingerprint test key");
  const Eigen::VectorXd g = fingerprint_coefficients(k, 42, 128);
  EXPECT_EQ(g, fingerprint_coefficients(k, 42, 128));  // regenerated, never stored
  EXPECT_NE(g, fingerprint_coefficients(k, 43, 128));
  EXPECT_NE(g, fingerprint_coefficients(key_from_passphrase_v1("another key"), 42, 128));
  // The first K of a longer draw are the same: K only cuts the stream.
  EXPECT_EQ(g, fingerprint_coefficients(k, 42, 1000).head(128));
  // docs/format.md section 8.1: bit 7 - i % 8 of byte i / 8 of the ChaCha20 keystream of
  // derive_key(key, "fingerprint-signs"), nonce the ID little-endian; 1 is +1.
  for (const std::uint64_t id : {std::uint64_t{0}, std::uint64_t{42}, ~std::uint64_t{0}}) {
    const Key sk = derive_key(k, "fingerprint-signs");
    unsigned char nonce[8], stream[125];
    for (int b = 0; b < 8; ++b) nonce[b] = static_cast<unsigned char>(id >> (8 * b));
    crypto_stream_chacha20(stream, sizeof(stream), nonce, sk.bytes.data());
    const Eigen::VectorXd x = fingerprint_coefficients(k, id, 1000);
    for (int i = 0; i < 1000; ++i)
      ASSERT_EQ(x(i), (stream[i / 8] >> (7 - i % 8)) & 1 ? 1.0 : -1.0) << "ID " << id << ", " << i;
  }
  // Over 10^4 consecutive IDs x 128: a mean of 0 (standard error 0.0009), and neighbouring
  // coefficients and the same coefficient of consecutive IDs uncorrelated (standard errors
  // 0.0009 and 0.01).
  double m1 = 0, within = 0, across = 0, n = 0;
  Eigen::VectorXd previous = fingerprint_coefficients(k, 0, 128);
  for (std::uint64_t id = 1; id <= 10000; ++id) {
    const Eigen::VectorXd x = fingerprint_coefficients(k, id, 128);
    ASSERT_TRUE((x.array().abs() == 1).all());
    m1 += x.sum(), n += 128;
    within += x.head(127).dot(x.tail(127)) / 127;
    across += x.dot(previous) / 128;
    previous = x;
  }
  EXPECT_NEAR(m1 / n, 0.0, 0.005);
  EXPECT_NEAR(within / 10000, 0.0, 0.05);
  EXPECT_NEAR(across / 10000, 0.0, 0.05);
  EXPECT_THROW(fingerprint_coefficients(k, 1, 128, 2), InvalidArgumentError);
  EXPECT_THROW(fingerprint_coefficients(k, 1, 0), InvalidArgumentError);
}

TEST(Fingerprint, FormatThreeCoefficientsAreKeyedStandardNormal) {
  const Key k = key_from_passphrase_v1("fingerprint test key");
  const int three = kGaussianFingerprintFormat;
  const Eigen::VectorXd g = fingerprint_coefficients(k, 42, 128, three);
  EXPECT_EQ(g, fingerprint_coefficients(k, 42, 200, three).head(128));
  // Moments over 4 x 10^3 IDs x 128: mean 0, variance 1, kurtosis 3 (standard errors 0.0014,
  // 0.002, 0.008; tolerance about 4 of them).
  double m1 = 0, m2 = 0, m4 = 0, n = 0;
  for (std::uint64_t id = 1; id <= 4000; ++id) {
    const Eigen::VectorXd x = fingerprint_coefficients(k, id, 128, three);
    m1 += x.sum(), m2 += x.squaredNorm(), m4 += x.array().pow(4).sum(), n += 128;
  }
  EXPECT_NEAR(m1 / n, 0.0, 0.006);
  EXPECT_NEAR(m2 / n, 1.0, 0.009);
  EXPECT_NEAR(m4 / n, 3.0, 0.04);
}

TEST(Fingerprint, TheFieldIsAsStrongAsAsked) {
  const Scene s = setup("elephant.off");
  const double rms = 1e-4;
  double sum = 0;
  int copies = 0;
  for (std::uint64_t id = 1; id <= 20; ++id, ++copies) {
    const Eigen::MatrixX3d P = add_fingerprint(s.original.V, s.original.V, s.basis,
                                               fingerprint_coefficients(s.key, id, 128), rms);
    double sq = 0, n = 0;
    for (Eigen::Index i = 0; i < P.rows(); ++i)
      if (s.carrier[i] == kCounted) sq += (P.row(i) - s.original.V.row(i)).squaredNorm(), ++n;
    sum += std::sqrt(sq / n) / s.basis.diagonal;
  }
  // The basis is scaled so that the expected mean square is rms^2: the mean RMS over 20 copies
  // lies within 10 % of it (each copy's RMS varies with its 128 coefficients).
  EXPECT_NEAR(sum / copies / rms, 1.0, 0.1);
}

TEST(Fingerprint, AnUnprocessedCopyScoresAtFullStrength) {
  const Scene s = setup("elephant.off");
  const Eigen::VectorXd g = fingerprint_coefficients(s.key, 1500, 128);
  const Eigen::MatrixX3d P = add_fingerprint(s.original.V, s.original.V, s.basis, g, 1e-4);
  const Eigen::VectorXd b = read_fingerprint(s.basis, residual(s, P), counted(s));
  // b is the coefficients themselves, scaled by rms x diagonal: the score is |g| (about
  // sqrt(128) = 11.3), within 1 % (the radial residual of a radial move is exact).
  EXPECT_NEAR(fingerprint_score(g, b) / g.norm(), 1.0, 0.01);
  EXPECT_LT(normal_upper_tail(fingerprint_score(g, b)), 1e-25);
}

// A mesh scaled by a power of two (exact in floating point) has the same basis but for its
// width and points, scaled by the same power, bit for bit: its area underflowed below
// coordinates of about 1e-77 ("no area to spread a fingerprint on") and overflowed above 1e77.
TEST(Fingerprint, APowerOfTwoScaleScalesTheBasisAndNothingElse) {
  const Scene s = setup("elephant.off");
  const Center c = center_of_mass(s.original.V, s.original.F, s.carrier, CenterKind::Discrete);
  for (const int k : {-300, -100, 100, 300}) {
    SCOPED_TRACE(k);
    const double f = std::ldexp(1.0, k);
    const Eigen::MatrixX3d V = s.original.V * f;
    const FingerprintBasis b =
        fingerprint_basis(V, s.original.F, carrier_vertices(V, s.original.F), c.point * f, 128);
    EXPECT_EQ(b.width, s.basis.width * f);
    EXPECT_TRUE(b.points == s.basis.points * f);
    EXPECT_EQ(b.centers, s.basis.centers);
    EXPECT_EQ(b.scale, s.basis.scale);
    EXPECT_EQ(b.row_start, s.basis.row_start);
    EXPECT_EQ(b.index, s.basis.index);
    EXPECT_EQ(b.value, s.basis.value);
  }
}

// The ridge reading against a dense computation from the bumps' definition: Phi evaluated
// directly (Gaussians of width w around the basis' points, cut at 3 w, times the scale), then
// b = (Phi^T Phi + ridge x mean diag I)^-1 Phi^T r with a dense QR solver. Also the basis
// evaluated at the original's own vertices is the basis itself.
TEST(Fingerprint, ARidgeReadingIsTheRidgeRegressionOfTheResidual) {
  const Scene s = setup("elephant.off", 64);
  const Eigen::Index n = s.original.V.rows();
  const int K = s.basis.functions;
  Eigen::MatrixXd Phi = Eigen::MatrixXd::Zero(n, K);
  for (Eigen::Index i = 0; i < n; ++i)
    if (s.carrier[i] == kCounted)
      for (int k = 0; k < K; ++k) {
        const double d2 =
            (s.original.V.row(i) - s.original.V.row(s.basis.centers[k])).squaredNorm();
        if (d2 <= 9 * s.basis.width * s.basis.width)  // stored in single precision
          Phi(i, k) = static_cast<float>(s.basis.scale *
                                         std::exp(-d2 / (2 * s.basis.width * s.basis.width)));
      }
  const FingerprintBasis again = fingerprint_basis_at(s.basis, s.original.V, counted(s));
  EXPECT_EQ(again.index, s.basis.index);
  ASSERT_EQ(again.value.size(), s.basis.value.size());
  for (std::size_t e = 0; e < again.value.size(); ++e) EXPECT_EQ(again.value[e], s.basis.value[e]);
  // A residual: a fingerprint plus noise of twice its RMS.
  const Eigen::VectorXd g = fingerprint_coefficients(s.key, 7, K);
  Eigen::VectorXd r = residual(s, add_fingerprint(s.original.V, s.original.V, s.basis, g, 1e-4));
  std::mt19937_64 rng(3);
  std::normal_distribution<double> noise(0.0, 2e-4 * s.basis.diagonal);
  for (Eigen::Index i = 0; i < n; ++i) r(i) += noise(rng);
  for (const double ridge : {0.0, 0.3, 1.0, 3.0}) {
    Eigen::MatrixXd A = Phi.transpose() * Phi;
    A.diagonal().array() += std::max(ridge, 1e-9) * A.trace() / K;
    const Eigen::VectorXd expected = A.colPivHouseholderQr().solve(Phi.transpose() * r);
    const Eigen::VectorXd b = read_fingerprint(s.basis, r, counted(s), nullptr, ridge);
    EXPECT_LT((b - expected).norm(), 1e-8 * expected.norm()) << "ridge " << ridge;
  }
  EXPECT_THROW(read_fingerprint(s.basis, r, counted(s), nullptr, -1), InvalidArgumentError);
}

// The bumps a basis holds, against their definition evaluated by brute force over every bump:
// exactly those within 3 w, in increasing order, each scale x exp(-d^2 / (2 w^2)); at the
// original's counted vertices (fingerprint_basis), at points off the surface (the vertices
// moved by about w in every direction), and none at points far from every bump, not finite, or
// masked out. (The basis finds the bumps through a grid; this looks at all of them.)
TEST(Fingerprint, TheBasisHoldsExactlyTheBumpsWithinReachInBumpOrder) {
  for (const auto& [name, functions] :
       {std::pair<const char*, int>{"elephant.off", 64}, {"refined_elephant.off", 512}}) {
    SCOPED_TRACE(name);
    const Scene s = setup(name, functions);
    const double w = s.basis.width, cut2 = 9 * w * w;
    const auto check = [&](const FingerprintBasis& b, const Eigen::MatrixX3d& P,
                           const std::vector<std::uint8_t>& mask) {
      ASSERT_EQ(b.row_start.size(), static_cast<std::size_t>(P.rows()) + 1);
      std::size_t entries = 0;
      for (Eigen::Index i = 0; i < P.rows(); ++i) {
        std::vector<std::uint16_t> index;
        std::vector<double> value;
        for (int k = 0; mask[i] && k < s.basis.functions; ++k) {
          const double d2 = (P.row(i) - s.original.V.row(s.basis.centers[k])).squaredNorm();
          if (d2 <= cut2)
            index.push_back(static_cast<std::uint16_t>(k)),
                value.push_back(s.basis.scale * std::exp(-d2 / (2 * w * w)));
        }
        const std::vector<std::uint16_t> got(b.index.begin() + b.row_start[i],
                                             b.index.begin() + b.row_start[i + 1]);
        ASSERT_EQ(got, index) << "row " << i;
        for (std::size_t e = 0; e < value.size(); ++e)  // single precision: within one ulp
          ASSERT_NEAR(b.value[b.row_start[i] + e], value[e], 0x1p-23 * value[e]) << "row " << i;
        entries += index.size();
      }
      EXPECT_EQ(b.index.size(), entries);
      EXPECT_EQ(b.value.size(), entries);
    };
    check(s.basis, s.original.V, counted(s));
    // The scale: a mean over the counted vertices of sum_k phi_k^2 of 1.
    double squares = 0;
    for (const float v : s.basis.value) squares += static_cast<double>(v) * v;
    const std::vector<std::uint8_t> mask = counted(s);
    const auto rows = std::count(mask.begin(), mask.end(), 1);
    EXPECT_NEAR(squares / static_cast<double>(rows), 1.0, 1e-6);
    std::mt19937_64 rng(11);
    std::normal_distribution<double> step(0.0, w);
    Eigen::MatrixX3d moved = s.original.V;
    for (Eigen::Index i = 0; i < moved.rows(); ++i)
      for (int c = 0; c < 3; ++c) moved(i, c) += step(rng);
    std::vector<std::uint8_t> every(static_cast<std::size_t>(moved.rows()), 1);
    every[0] = 0;  // masked out: no entries whatever its place
    check(fingerprint_basis_at(s.basis, moved, every), moved, every);
    Eigen::MatrixX3d off(4, 3);
    off.row(0) = s.original.V.row(s.basis.centers[0]);  // on a bump
    off.row(1) = off.row(0) + Eigen::RowVector3d(10 * s.basis.diagonal, 0, 0);
    off.row(2) = off.row(0) - Eigen::RowVector3d(0, 0, 1e300);
    off(3, 0) = std::numeric_limits<double>::quiet_NaN();
    off(3, 1) = off(3, 2) = 0;
    const FingerprintBasis far = fingerprint_basis_at(s.basis, off, {1, 1, 1, 1});
    EXPECT_GT(far.row_start[1], 0);
    EXPECT_EQ(far.row_start[4], far.row_start[1]) << "far, huge or NaN points got bumps";
  }
}

// A basis whose compressed rows are not well formed is refused with a message, not read out of
// bounds: a bump index out of [0, K), row starts that go back, entries and values of different
// counts; and by read_fingerprint (which sums each row's products into one triangle of Phi^T Phi)
// a row out of order or naming a bump twice.
TEST(Fingerprint, RowsThatAreNotWellFormedAreRefused) {
  const Scene s = setup("elephant.off", 64);
  const Eigen::VectorXd g = fingerprint_coefficients(s.key, 7, 64);
  const Eigen::VectorXd r = Eigen::VectorXd::Zero(s.original.V.rows());
  EXPECT_NO_THROW(s.basis.field(g));
  EXPECT_NO_THROW(read_fingerprint(s.basis, r, counted(s)));
  std::size_t row = 0;
  while (s.basis.row_start[row + 1] - s.basis.row_start[row] < 2) ++row;
  const int first = s.basis.row_start[row];
  std::vector<FingerprintBasis> bad(6, s.basis);
  bad[0].index[first] = 64;
  bad[1].index[first] = 65535;
  std::swap(bad[2].index[first], bad[2].index[first + 1]);
  bad[3].index[first + 1] = bad[3].index[first];
  bad[4].row_start[row + 1] = bad[4].row_start[row] - 1;
  bad[5].value.pop_back();
  for (std::size_t b = 0; b < bad.size(); ++b) {
    SCOPED_TRACE(b);
    if (b != 2 && b != 3)  // the field is a plain sum: its rows' order does not matter to it
      EXPECT_THROW(bad[b].field(g), InvalidArgumentError);
    EXPECT_THROW(read_fingerprint(bad[b], r, counted(s)), InvalidArgumentError);
  }
}

// The original's bins at other points: a point's bin and position from its distance alone, with
// the range and step of the original's histogram; points out of the range or masked get none.
TEST(Fingerprint, HistogramAtOtherPointsUsesTheOriginalsBins) {
  const Scene s = setup("elephant.off", 64);
  const Histogram h = build_histogram(s.original.V, s.carrier, s.basis.center, 32);
  const Histogram same = histogram_at(h, s.original.V, counted(s));
  for (Eigen::Index i = 0; i < s.original.V.rows(); ++i) {
    EXPECT_EQ(same.bin[i], h.bin[i]) << i;
    if (h.bin[i] >= 0) EXPECT_NEAR(same.t(i), h.t(i), 1e-12) << i;
  }
  Eigen::MatrixX3d P(4, 3);
  const Eigen::RowVector3d c = h.center.transpose(), x(1, 0, 0);
  P.row(0) = c + x * (h.rho_min + 2.25 * h.step);  // bin 2, t 0.25
  P.row(1) = c + x * (h.rho_min - 0.1 * h.step);   // below the range
  P.row(2) = c + x * (h.rho_max + 0.1 * h.step);   // above it
  P.row(3) = c + x * (h.rho_min + 5.5 * h.step);   // masked
  const Histogram at = histogram_at(h, P, {1, 1, 1, 0});
  EXPECT_EQ(at.bin, (std::vector<int>{2, -1, -1, -1}));
  EXPECT_NEAR(at.t(0), 0.25, 1e-9);
  EXPECT_EQ(at.argmin, -1);
  EXPECT_THROW(histogram_at(h, P, {1, 1}), InvalidArgumentError);
}

// A real reading: an average of three copies, so that b holds other buyers' fingerprints.
Eigen::VectorXd averaged_reading(const Scene& s, int format) {
  Eigen::MatrixX3d P = Eigen::MatrixX3d::Zero(s.original.V.rows(), 3);
  for (const std::uint64_t id : {7, 8, 9})
    P += add_fingerprint(s.original.V, s.original.V, s.basis,
                         fingerprint_coefficients(s.key, id, 128, format), 1e-4) /
         3.0;
  return read_fingerprint(s.basis, residual(s, P), counted(s));
}

// Kolmogorov-Smirnov distance of sorted scores to the standard normal.
double ks_to_normal(const std::vector<double>& z) {
  double D = 0;
  const double n = static_cast<double>(z.size());
  for (std::size_t i = 0; i < z.size(); ++i) {
    const double F = 1 - normal_upper_tail(z[i]);
    D = std::max({D, std::abs(F - i / n), std::abs(F - (i + 1) / n)});
  }
  return D;
}

TEST(Fingerprint, FormatThreeInnocentScoresAreStandardNormal) {
  const Scene s = setup("elephant.off");
  const Eigen::VectorXd b = averaged_reading(s, kGaussianFingerprintFormat);
  const FingerprintScorer scorer(s.key, 128, {b});
  std::vector<double> z;
  for (std::uint64_t id = 1000; id < 101000; ++id)
    z.push_back(scorer.best_z(id, kGaussianFingerprintFormat));
  std::sort(z.begin(), z.end());
  // Kolmogorov-Smirnov against the standard normal: D below the 0.1 % critical value
  // 1.95 / sqrt(n) for n = 10^5.
  const double D = ks_to_normal(z);
  EXPECT_LT(D, 1.95 / std::sqrt(static_cast<double>(z.size()))) << "KS distance";
  // The tail: the count beyond z = 3.09 (p = 1e-3) is binomial(10^5, 1e-3): 100 +- 10.
  const auto beyond = std::count_if(z.begin(), z.end(), [](double x) { return x > 3.0902; });
  EXPECT_NEAR(static_cast<double>(beyond), 100.0, 40.0);
  RecordProperty("ks_distance", std::to_string(D));
}

// Format 4: given b, an innocent's score sum_k e_k b_k / |b| is a sum of independent random
// signs with unit weights: mean 0 and variance 1 exactly, within Berry-Esseen's distance of
// the normal (0.56 sum |a_k|^3, Shevtsova 2010), and its tail under c* times the normal's
// (Bentkus and Dzindzalieta 2015), which fingerprint_p_value uses. Checked over 10^5 innocent
// IDs against a real reading; the scorer agrees with fingerprint_score on the coefficients.
TEST(Fingerprint, InnocentScoresStayWithinTheirNull) {
  const Scene s = setup("elephant.off");
  const Eigen::VectorXd b = averaged_reading(s, kFingerprintMarkFormat);
  const FingerprintScorer scorer(s.key, 128, {b, -b});
  // Scored 1,000 at a time (as trace does) and split after the first reading: each part is the
  // score of one sign of b.
  std::vector<std::uint64_t> batch(1000);
  std::iota(batch.begin(), batch.end(), std::uint64_t{1000});
  std::vector<std::pair<double, double>> parts(batch.size());
  scorer.best_z_split(batch.data(), batch.size(), kFingerprintMarkFormat, 1, parts.data());
  for (std::size_t i = 0; i < batch.size(); ++i) {
    const double one = fingerprint_score(fingerprint_coefficients(s.key, batch[i], 128), b);
    ASSERT_NEAR(parts[i].first, one, 1e-12) << "ID " << batch[i];
    ASSERT_NEAR(parts[i].second, -one, 1e-12) << "ID " << batch[i];
  }
  std::vector<double> z;
  double mean = 0, square = 0;
  for (std::uint64_t id = 1000; id < 101000; ++id) {
    const double best = scorer.best_z(id, kFingerprintMarkFormat);
    const double one = fingerprint_score(fingerprint_coefficients(s.key, id, 128), b);
    if (id < 2000) ASSERT_NEAR(best, std::abs(one), 1e-12) << "ID " << id;  // best of b, -b
    z.push_back(one), mean += one, square += one * one;
  }
  const double n = static_cast<double>(z.size());
  EXPECT_NEAR(mean / n, 0.0, 5 / std::sqrt(n));
  EXPECT_NEAR(square / n, 1.0, 5 * std::sqrt(2 / n));  // var(z^2) <= 2 for these sums
  std::sort(z.begin(), z.end());
  const double berry_esseen = 0.56 * (b / b.norm()).array().abs().cube().sum();
  const double D = ks_to_normal(z);
  EXPECT_LT(D, berry_esseen + 1.95 / std::sqrt(n)) << "KS distance";
  for (const double level : {2.0, 3.0, 3.5, 4.0}) {
    const double bound = n * fingerprint_p_value(level, kFingerprintMarkFormat);
    const auto beyond = std::count_if(z.begin(), z.end(), [&](double x) { return x >= level; });
    EXPECT_LE(static_cast<double>(beyond), bound + 5 * std::sqrt(bound) + 1) << "z >= " << level;
  }
  RecordProperty("ks_distance", std::to_string(D));
  RecordProperty("berry_esseen", std::to_string(berry_esseen));
}

// c* against its definition computed from erfc here, the two p-values' shapes, and the
// combination of both marks' p-values: conservative for independent uniform p-values and for
// discrete super-uniform ones (a binomial test's), over 10^6 draws.
TEST(Fingerprint, BothMarksCombineIntoAConservativePValue) {
  const double c = 1 / (4 * 0.5 * std::erfc(1.0));  // P(Z >= sqrt 2) = erfc(1) / 2
  EXPECT_NEAR(rademacher_tail_factor(), c, 1e-12);
  EXPECT_NEAR(rademacher_tail_factor(), 3.178, 1e-3);  // as the paper states it, 3 decimals
  EXPECT_EQ(fingerprint_p_value(5, kGaussianFingerprintFormat), normal_upper_tail(5));
  EXPECT_NEAR(fingerprint_p_value(5, kFingerprintMarkFormat), c * normal_upper_tail(5), 1e-20);
  EXPECT_EQ(fingerprint_p_value(-3, kFingerprintMarkFormat), 1.0);
  EXPECT_THROW(fingerprint_p_value(1, 2), InvalidArgumentError);
  EXPECT_EQ(combined_p_value(1, 1), 1.0);
  EXPECT_NEAR(combined_p_value(1e-9, 1), 4e-9, 1e-20);  // one mark lost: 4 min
  const double t = 1e-9 * 1e-6;
  EXPECT_NEAR(combined_p_value(1e-9, 1e-6), 2 * t * (1 - std::log(t)), 1e-25);
  EXPECT_EQ(combined_p_value(0, 0.5), 0.0);
  EXPECT_THROW(combined_p_value(-0.1, 0.5), InvalidArgumentError);
  EXPECT_THROW(combined_p_value(0.5, 1.5), InvalidArgumentError);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> U(0, 1);
  std::binomial_distribution<int> coin(16, 0.5);
  const int draws = 1000000;
  const std::vector<double> levels = {0.05, 0.01, 1e-3, 1e-4};
  std::vector<int> continuous(levels.size(), 0), discrete(levels.size(), 0);
  for (int i = 0; i < draws; ++i) {
    const double p1 = U(rng), p2 = U(rng);
    // A discrete p: P(Binomial(16, 1/2) >= m) at the matches m drawn from the same law.
    const int m = coin(rng);
    double tail = 0;
    for (int j = m; j <= 16; ++j)
      tail +=
          std::exp(std::lgamma(17) - std::lgamma(j + 1) - std::lgamma(17 - j) - 16 * std::log(2.0));
    const double p = combined_p_value(p1, p2), q = combined_p_value(std::min(1.0, tail), p2);
    for (std::size_t k = 0; k < levels.size(); ++k)
      continuous[k] += p <= levels[k], discrete[k] += q <= levels[k];
  }
  for (std::size_t k = 0; k < levels.size(); ++k) {
    const double expected = levels[k] * draws;
    EXPECT_LE(continuous[k], expected + 5 * std::sqrt(expected)) << levels[k];
    EXPECT_LE(discrete[k], expected + 5 * std::sqrt(expected)) << levels[k];
  }
}

TEST(Fingerprint, AnAverageOfKCopiesKeepsAboutOneKthOfEachColluder) {
  const Scene s = setup("elephant.off");
  const int K = s.basis.functions;
  std::vector<Eigen::VectorXd> g, single;  // each colluder's coefficients and lone reading
  for (int j = 0; j < 8; ++j) {
    g.push_back(fingerprint_coefficients(s.key, 100 + j, K));
    single.push_back(read_fingerprint(
        s.basis, residual(s, add_fingerprint(s.original.V, s.original.V, s.basis, g[j], 1e-4)),
        counted(s)));
  }
  for (const int k : {2, 3, 5, 8}) {
    Eigen::MatrixX3d P = Eigen::MatrixX3d::Zero(s.original.V.rows(), 3);
    Eigen::VectorXd mean_single = Eigen::VectorXd::Zero(K);
    for (int j = 0; j < k; ++j) {
      P += add_fingerprint(s.original.V, s.original.V, s.basis, g[j], 1e-4) / k;
      mean_single += single[j] / k;
    }
    const Eigen::VectorXd b = read_fingerprint(s.basis, residual(s, P), counted(s));
    // The reading is linear: the average's reading is the average of the lone readings.
    EXPECT_LT((b - mean_single).norm(), 1e-9 * mean_single.norm()) << k << " copies";
    // Colluder 0's raw correlation is 1/k of its lone copy's, plus the others' g_0.g_j / k,
    // each of standard deviation sqrt(K) against |g_0|^2 of about K: within 4 standard
    // deviations, 4 sqrt((k - 1) / K) / k.
    const double ratio = g[0].dot(b) / g[0].dot(single[0]);
    EXPECT_NEAR(ratio, 1.0 / k, 4 * std::sqrt((k - 1.0) / K) / k) << k << " copies";
    // The colluders' normalized scores average about sqrt(K / k) (4 for k = 8, K = 128);
    // within 3 times their spread, sqrt((k - 1) / k).
    double mean_z = 0;
    for (int j = 0; j < k; ++j) mean_z += fingerprint_score(g[j], b) / k;
    EXPECT_NEAR(mean_z, std::sqrt(K / static_cast<double>(k)), 3 * std::sqrt((k - 1.0) / k))
        << k << " copies";
  }
}

// fingerprint_regions cuts the bumps into Voronoi cells of far-apart centers, each partition
// a cover of every bump once; a splice of 3 copies, each colluder's field whole over its part,
// scores each colluder higher over some region than over the whole surface (where the other
// two parts dilute it), while an innocent's best score over all the readings stays within the
// Bonferroni bound of their number.
TEST(Fingerprint, ReadingByRegionsFindsSplicedColludersWholeAndKeepsInnocentsWithinTheNull) {
  const Scene s = setup("elephant.off");
  const int K = s.basis.functions;
  const std::vector<int> partitions{2, 3, 4};
  const std::vector<std::vector<int>> regions = fingerprint_regions(s.basis, partitions);
  ASSERT_EQ(regions.size(), 9U);
  std::size_t at = 0;
  for (const int R : partitions) {
    std::vector<int> owner(K, -1);
    for (int r = 0; r < R; ++r) {
      const std::vector<int>& region = regions[at + r];
      ASSERT_TRUE(std::is_sorted(region.begin(), region.end()));
      EXPECT_TRUE(std::binary_search(region.begin(), region.end(), r)) << "seed " << r;
      for (const int k : region) {
        ASSERT_EQ(owner[k], -1) << "bump " << k << " in two regions of " << R;
        owner[k] = r;
        // Voronoi: no other seed is nearer to bump k than its own.
        const double own = (s.basis.points.row(k) - s.basis.points.row(r)).squaredNorm();
        for (int o = 0; o < R; ++o)
          EXPECT_LE(own, (s.basis.points.row(k) - s.basis.points.row(o)).squaredNorm())
              << "bump " << k << ", partition of " << R;
      }
    }
    EXPECT_EQ(std::count(owner.begin(), owner.end(), -1), 0) << "partition of " << R;
    at += R;
  }
  EXPECT_THROW((void)fingerprint_regions(s.basis, {1}), InvalidArgumentError);
  EXPECT_THROW((void)fingerprint_regions(s.basis, {kMaxFingerprintRegions + 1}),
               InvalidArgumentError);
  EXPECT_THROW((void)fingerprint_regions(s.basis, {3, 2, 3}), InvalidArgumentError);
  // trace refuses them too, and a share of the budget outside (0, 1), before any work.
  for (const auto& [partitions, share] : std::vector<std::pair<std::vector<int>, double>>{
           {{2, 2}, 0.2}, {{1}, 0.2}, {{2, 3, 4}, 0.0}, {{2, 3, 4}, 1.0}}) {
    TraceOptions bad;
    bad.fingerprint_regions = partitions;
    bad.fingerprint_region_share = share;
    EXPECT_THROW((void)trace(s.original, s.original, {}, s.key, bad), InvalidArgumentError)
        << share;
  }
  // A basis of 8 bumps has no partition of 16: skipped.
  const Center c = center_of_mass(s.original.V, s.original.F, s.carrier, CenterKind::Discrete);
  EXPECT_TRUE(fingerprint_regions(
                  fingerprint_bumps(s.original.V, s.original.F, s.carrier, c.point, 8), {16})
                  .empty());
  const Eigen::VectorXd ramp = Eigen::VectorXd::LinSpaced(K, 1, K);
  const Eigen::VectorXd part = regional_reading(ramp, regions[0]);
  for (int k = 0; k < K; ++k)
    EXPECT_EQ(part(k), std::binary_search(regions[0].begin(), regions[0].end(), k) ? k + 1 : 0);
  EXPECT_THROW((void)regional_reading(ramp, {K}), InvalidArgumentError);

  // Three colluders' copies spliced along the partition of 3: each vertex from the copy of
  // the nearest of the first 3 bump centers. A lone copy reads exactly (no ridge, no attack):
  // b = c g, z = sqrt(K). Colluder j's field is then whole over its region's n_j bumps and
  // absent elsewhere, where the others' signs are independent of its own: over the whole
  // surface it scores (n_j + N(0, K - n_j)) / sqrt(K), about f z1 with f = n_j / K; over its
  // region sqrt(n_j), 1 / sqrt(f) times more (1.7 for f = 1/3), within 10 % (bumps astride the
  // border read a mix).
  std::vector<Mesh> copies;
  std::vector<Eigen::VectorXd> g;
  for (int j = 0; j < 3; ++j) {
    g.push_back(fingerprint_coefficients(s.key, 300 + j, K));
    copies.push_back(s.original);
    copies.back().V = add_fingerprint(s.original.V, s.original.V, s.basis, g[j], 1e-4);
  }
  Eigen::MatrixX3d P = s.original.V;
  for (Eigen::Index i = 0; i < P.rows(); ++i) {
    int nearest = 0;
    for (int j = 1; j < 3; ++j)
      if ((s.original.V.row(i) - s.basis.points.row(j)).squaredNorm() <
          (s.original.V.row(i) - s.basis.points.row(nearest)).squaredNorm())
        nearest = j;
    P.row(i) = copies[nearest].V.row(i);
  }
  const Eigen::VectorXd b = read_fingerprint(s.basis, residual(s, P), counted(s));
  std::vector<Eigen::VectorXd> readings{b};
  for (const std::vector<int>& region : regions) readings.push_back(regional_reading(b, region));
  const FingerprintScorer scorer(s.key, K, readings);
  for (int j = 0; j < 3; ++j) {
    const double whole = fingerprint_score(g[j], b);
    const double best = scorer.best_z(300 + j, kFingerprintMarkFormat);
    const double n = static_cast<double>(regions[2 + j].size());  // the partition of 3
    RecordProperty(fmt::format("colluder_{}", j),
                   fmt::format("{} bumps, whole z {:.2f}, best z {:.2f}", n, whole, best));
    EXPECT_NEAR(whole, n / std::sqrt(K), 4 * std::sqrt((K - n) / K)) << "colluder " << j;
    EXPECT_GE(best, 0.9 * std::sqrt(n)) << "colluder " << j;
    EXPECT_GE(fingerprint_score(g[j], readings[3 + j]), 0.9 * std::sqrt(n)) << "colluder " << j;
  }
  // Innocents: their best over the 10 readings beyond z at most 10 times the bound of one,
  // plus 5 standard deviations.
  const int innocents = 100000;
  for (const double level : {2.5, 3.0, 3.5}) {
    int beyond = 0;
    for (int id = 0; id < innocents; ++id)
      beyond +=
          scorer.best_z(10000 + static_cast<std::uint64_t>(id), kFingerprintMarkFormat) >= level;
    const double bound =
        innocents * std::min(1.0, static_cast<double>(readings.size()) *
                                      fingerprint_p_value(level, kFingerprintMarkFormat));
    EXPECT_LE(beyond, bound + 5 * std::sqrt(bound) + 1) << "z >= " << level;
  }
  // The weighted Bonferroni trace applies (the whole reading 0.8 of the budget, the 9 regional
  // ones 0.2): its p is at most u for at most a fraction u of the innocents, plus 5 standard
  // deviations; and it is the formula, computed here from the normal tail.
  std::vector<double> p;
  for (int id = 0; id < innocents; ++id) {
    const auto [whole, regional] =
        scorer.best_z_split(10000 + static_cast<std::uint64_t>(id), kFingerprintMarkFormat, 1);
    p.push_back(fingerprint_p_value(whole, 1, regional, 9, 0.2, kFingerprintMarkFormat));
    if (id < 100) {
      const double c = rademacher_tail_factor();
      const double tail_whole = 0.5 * std::erfc(whole / std::sqrt(2.0));
      const double tail_regional = 0.5 * std::erfc(regional / std::sqrt(2.0));
      EXPECT_NEAR(p.back(), std::min({1.0, c * tail_whole / 0.8, c * tail_regional * 9 / 0.2}),
                  1e-12 * p.back())
          << "ID " << 10000 + id;
      EXPECT_EQ(std::max(whole, regional),
                scorer.best_z(10000 + static_cast<std::uint64_t>(id), kFingerprintMarkFormat));
    }
  }
  for (const double u : {0.1, 0.01, 0.001}) {
    const auto below = std::count_if(p.begin(), p.end(), [&](double x) { return x <= u; });
    const double bound = innocents * u;
    EXPECT_LE(static_cast<double>(below), bound + 5 * std::sqrt(bound) + 1) << "p <= " << u;
  }
  EXPECT_EQ(fingerprint_p_value(3, 2, -INFINITY, 0, 0.2, kFingerprintMarkFormat),
            std::min(1.0, 2 * fingerprint_p_value(3, kFingerprintMarkFormat)));
  for (const double share : {0.0, 1.0, std::nan("")})
    EXPECT_THROW((void)fingerprint_p_value(3, 1, 3, 9, share, kFingerprintMarkFormat),
                 InvalidArgumentError);
  EXPECT_THROW((void)fingerprint_p_value(3, 0, 3, 9, 0.2, kFingerprintMarkFormat),
               InvalidArgumentError);
}

// A re-mark along the normals (anyone's `embed --id 9 --variant DNL` over a copy) moves each
// vertex's distance to the center by about its motion times n . u (n the normal, u the direction
// from the center), and its Laplacian cost spreads that motion in a way no function of the
// distance alone describes: read with the radial classes alone, it buries the fingerprint. With
// each class also fitted on (n . u)^2 (the obliquity, computed here from the original's vertex
// normals) the copy scores again near its own score, and on the copy itself the obliquity costs
// the reading little.
TEST(Fingerprint, AReMarkAlongTheNormalsDropsOutWithTheObliquity) {
  const Scene s = setup("diplodocus.off");
  const Histogram h = build_histogram(s.original.V, s.carrier, s.basis.center, 64);
  const Eigen::VectorXd g = fingerprint_coefficients(s.key, 500, s.basis.functions);
  Mesh copy = s.original;
  copy.V = add_fingerprint(s.original.V, s.original.V, s.basis, g, 1e-4, &h);
  EmbedOptions eo;
  eo.variant = parse_scheme("DNL").variant;
  const EmbedResult remark = embed(copy.V, copy.F, id_bins(IdCode(), 9, std::nullopt), eo);
  ASSERT_EQ(remark.status, EmbedStatus::Embedded) << remark.message;
  const Eigen::MatrixX3d normals = vertex_normals(s.original.V, s.original.F);
  Eigen::VectorXd obliquity(s.original.V.rows());
  for (Eigen::Index i = 0; i < obliquity.size(); ++i) {
    const Eigen::Vector3d u = (s.original.V.row(i).transpose() - s.basis.center).normalized();
    obliquity(i) = std::pow(normals.row(i).normalized().dot(u), 2);
  }
  const double ridge = TraceOptions().fingerprint_ridge;
  const auto z = [&](const Eigen::MatrixX3d& P, const Eigen::VectorXd* w) {
    return fingerprint_score(g,
                             read_fingerprint(s.basis, residual(s, P), counted(s), &h, ridge, w));
  };
  const double own = z(copy.V, nullptr), own_oblique = z(copy.V, &obliquity);
  const double plain = z(remark.V, nullptr), oblique = z(remark.V, &obliquity);
  RecordProperty("z_copy", std::to_string(own));
  RecordProperty("z_copy_oblique", std::to_string(own_oblique));
  RecordProperty("z_remarked", std::to_string(plain));
  RecordProperty("z_remarked_oblique", std::to_string(oblique));
  EXPECT_NEAR(own_oblique / own, 1.0, 0.05);
  EXPECT_LT(plain, 0.6 * own);
  EXPECT_GT(oblique, 0.8 * own);
  // read_fingerprint_at reads the same with the obliquity as read_fingerprint does, bit for bit.
  const Eigen::VectorXd r = residual(s, remark.V);
  const FingerprintBasis bumps =
      fingerprint_bumps(s.original.V, s.original.F, s.carrier, s.basis.center, s.basis.functions);
  EXPECT_EQ(read_fingerprint_at(bumps, s.original.V, r, counted(s), &h, ridge, &obliquity),
            read_fingerprint(s.basis, r, counted(s), &h, ridge, &obliquity));
  const Eigen::VectorXd short_obliquity = obliquity.head(10);
  EXPECT_THROW(read_fingerprint(s.basis, r, counted(s), &h, ridge, &short_obliquity),
               InvalidArgumentError);
}

TEST(Fingerprint, KeepingAHistogramLeavesItsBinMeansAndRangeAndReadsBackAsThePlainField) {
  const Scene s = setup("elephant.off");
  const Histogram h = build_histogram(s.original.V, s.carrier, s.basis.center, 64);
  const Eigen::VectorXd g = fingerprint_coefficients(s.key, 77, s.basis.functions);
  const Eigen::MatrixX3d P = add_fingerprint(s.original.V, s.original.V, s.basis, g, 1e-4, &h);
  // Each bin's mean distance to the center, computed here from the positions: unchanged to
  // 1e-9 of the bin width (the field's line in t over each slice of a bin is taken out).
  std::vector<double> before(h.bins, 0), after(h.bins, 0), count(h.bins, 0);
  for (Eigen::Index i = 0; i < P.rows(); ++i) {
    if (h.bin[i] < 0) continue;
    before[h.bin[i]] += (s.original.V.row(i).transpose() - h.center).norm();
    after[h.bin[i]] += (P.row(i).transpose() - h.center).norm();
    count[h.bin[i]] += 1;
  }
  for (int b = 0; b < h.bins; ++b)
    if (count[b] > 0)
      EXPECT_NEAR((after[b] - before[b]) / count[b] / h.step, 0.0, 1e-9) << "bin " << b;
  // The vertices that set the range stay.
  EXPECT_EQ(P.row(h.argmin), s.original.V.row(h.argmin));
  EXPECT_EQ(P.row(h.argmax), s.original.V.row(h.argmax));
  // Read with the same histogram and trace's ridge, the field scores as the plain field (no
  // classes taken out, no bins kept) read without them: within 2 %. (The bins' bounds change
  // the field at the few vertices near a bin's edge, 104 of 2,775 here; a plain fit, ridge 0,
  // amplifies that, so trace never reads with one.)
  const double ridge = TraceOptions().fingerprint_ridge;
  const Eigen::VectorXd plain = read_fingerprint(
      s.basis, residual(s, add_fingerprint(s.original.V, s.original.V, s.basis, g, 1e-4)),
      counted(s), nullptr, ridge);
  const Eigen::VectorXd b = read_fingerprint(s.basis, residual(s, P), counted(s), &h, ridge);
  EXPECT_NEAR(fingerprint_score(g, b) / fingerprint_score(g, plain), 1.0, 0.02);
  // What depends on the distance to the center alone drops out of the reading: a smooth radial
  // profile 10 times the fingerprint's size (a shrinkage, a histogram mark) changes the score
  // by under 2 %.
  Eigen::VectorXd profile = residual(s, P);
  for (Eigen::Index i = 0; i < profile.size(); ++i) {
    const double rho = (s.original.V.row(i).transpose() - h.center).norm();
    profile(i) += 1e-3 * s.basis.diagonal * std::sin(40 * rho / s.basis.diagonal);
  }
  const Eigen::VectorXd b2 = read_fingerprint(s.basis, profile, counted(s), &h, ridge);
  EXPECT_NEAR(fingerprint_score(g, b2) / fingerprint_score(g, b), 1.0, 0.02);
}

// A fresh folder for a test's files.
std::string fresh_dir(const std::string& name) {
  const std::string dir = test::scratch_dir() + "/" + name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

// A copy's vertex RMS against the original as calibration measures it: each counted carrier
// position once, % of the carrier's bounding-box diagonal.
double counted_rms_percent(const Mesh& original, const Mesh& copy) {
  const std::vector<std::uint8_t> carrier = carrier_vertices(original.V, original.F);
  double sum = 0, n = 0;
  for (Eigen::Index i = 0; i < original.V.rows(); ++i)
    if (carrier[i] == kCounted) sum += (copy.V.row(i) - original.V.row(i)).squaredNorm(), n += 1;
  return 100 * std::sqrt(sum / n) / bounding_box_diagonal(original.V, carrier);
}

// With fidelity limits, both marks fit them together: each written copy's vertex RMS (each
// position once, % of the carrier's diagonal) and MSDM against the original, computed here
// from the files, are within the limits, and the histogram mark is calibrated weaker than
// without the fingerprint; the copies trace to their buyers.
TEST(Fingerprint, BothMarksFitOneFidelityBudget) {
  const std::string original = test::cgal_mesh("camel.off");
  MESHMARK_REQUIRE(original, "libcgal-demo's camel.off");
  const std::string dir = fresh_dir("fingerprint-budget");
  IssueSettings settings;
  settings.key = key_from_passphrase_v1("fingerprint budget key");
  settings.limits = CalibrateOptions();  // the paper's: RMS 0.04 %, MSDM 0.25
  const auto issue = [&](bool fingerprint, const std::string& name) {
    settings.fingerprint = fingerprint;
    settings.registry = dir + "/" + name + ".db";
    std::vector<CopyRequest> requests;
    for (std::uint64_t id = 71; id <= 73; ++id) {
      CopyRequest r;
      r.input = original;
      r.output = dir + "/" + name + "-" + std::to_string(id) + ".ply";
      r.id = id;
      r.buyer = "buyer " + std::to_string(id);
      requests.push_back(r);
    }
    const IssueResult result = issue_copies(requests, settings);
    EXPECT_EQ(result.count(CopyStatus::Written), requests.size()) << result.copies[0].message;
    return std::make_pair(requests, result);
  };
  const auto [with_requests, with] = issue(true, "with");
  const auto [plain_requests, plain] = issue(false, "plain");
  const Mesh O = read_mesh(original);
  for (std::size_t k = 0; k < with_requests.size(); ++k) {
    const Mesh copy = read_mesh(with_requests[k].output);
    ASSERT_EQ(copy.V.rows(), O.V.rows());
    const double rms = counted_rms_percent(O, copy);
    // The file stores floats: 1e-6 of the limit for rounding.
    EXPECT_LE(rms, kPaperMaxRmsPercent * (1 + 1e-6)) << with_requests[k].output;
    EXPECT_LE(msdm(O.V, copy.V, O.F).global, kPaperMaxMsdm * (1 + 1e-6));
    ASSERT_TRUE(with.copies[k].calibration && plain.copies[k].calibration);
    EXPECT_LE(with.copies[k].calibration->strength, plain.copies[k].calibration->strength);
    const TraceResult r =
        trace_issued(copy, O, content_hash(read_file(original)), dir + "/with.db", *settings.key);
    ASSERT_EQ(r.status, TraceStatus::Named) << r.message;
    EXPECT_EQ(r.named[0].copy.id, with_requests[k].id.value());
    EXPECT_GT(r.named[0].fingerprint_z, 5);
  }
}

// The copies of mesh with IDs first to last - 1 under key, issued with the histogram mark alone
// (DRS, the default strength) and read back from their files.
std::vector<std::pair<std::uint64_t, Mesh>> marked_copies(const std::string& mesh,
                                                          std::uint64_t first, std::uint64_t last,
                                                          const Key& key) {
  const std::string dir = fresh_dir("fingerprint-marked-copies");
  IssueSettings settings;
  settings.key = key;
  settings.fingerprint = false;
  std::vector<std::pair<std::uint64_t, Mesh>> out;
  for (std::uint64_t id = first; id < last; ++id) {
    CopyRequest r;
    r.input = mesh, r.output = dir + "/copy.ply", r.id = id;
    const CopyOutcome c = issue_copies({r}, settings).copies[0];
    EXPECT_EQ(c.status, CopyStatus::Written) << mesh << " ID " << id << ": " << c.message;
    out.emplace_back(id, read_mesh(r.output));
  }
  return out;
}

// The fingerprint moves no counted vertex of a marked copy into another bin, nor past the
// range's ends: for 20 IDs of spot (where, before the bound, ID 127's copy under this key had a
// vertex cross from bin 11 to 10 and another overtake the farthest one, flipping two bits) and
// of camel, each counted vertex's bin in the copy's own histogram (its own center, built here)
// is the same with the field as without, the range's ends move by less than a hundredth of a
// bin, and the field's RMS stays above half of FingerprintOptions::rms of the diagonal.
TEST(Fingerprint, NoVertexOfACopyCrossesIntoAnotherBin) {
  const Key key = key_from_passphrase_v1("fingerprint bins key");
  for (const std::string& mesh : {test::data_mesh("spot.obj"), test::cgal_mesh("camel.off")}) {
    MESHMARK_REQUIRE(mesh, mesh);
    const Mesh O = read_mesh(mesh);
    const std::vector<std::uint8_t> carrier = carrier_vertices(O.V, O.F);
    const std::optional<FingerprintFrame> frame =
        fingerprint_frame(O.V, O.F, CenterKind::Discrete, 64);
    ASSERT_TRUE(frame);
    const auto histogram_of = [&](const Eigen::MatrixX3d& V) {
      return build_histogram(V, carrier,
                             center_of_mass(V, O.F, carrier, CenterKind::Discrete).point, 64);
    };
    for (const auto& [id, copy] : marked_copies(mesh, 120, 140, key)) {
      const Eigen::VectorXd g = fingerprint_coefficients(key, id, frame->basis.functions);
      const Eigen::MatrixX3d with = add_fingerprint(copy.V, O.V, frame->basis, g,
                                                    FingerprintOptions().rms, &frame->histogram);
      const Histogram a = histogram_of(copy.V), b = histogram_of(with);
      int crossed = 0;
      for (std::size_t i = 0; i < a.bin.size(); ++i) crossed += a.bin[i] != b.bin[i];
      EXPECT_EQ(crossed, 0) << mesh << " ID " << id;
      // The range's ends move with the center alone (spot is symmetric: which of two mirrored
      // vertices is the farthest may change): by less than a hundredth of a bin.
      EXPECT_LT(std::abs(b.rho_max - a.rho_max), 0.01 * a.step) << mesh << " ID " << id;
      EXPECT_LT(std::abs(b.rho_min - a.rho_min), 0.01 * a.step) << mesh << " ID " << id;
      // The bound leaves the field: its RMS over the vertices stays above half the target.
      const double moved = std::sqrt((with - copy.V).rowwise().squaredNorm().mean());
      EXPECT_GT(moved, 0.5 * FingerprintOptions().rms * frame->basis.diagonal)
          << mesh << " ID " << id;
    }
  }
}

// The fingerprint leaves a blind decoder's center where the histogram mark put it: on copies of
// spot and camel (IDs 120 to 129), the center recomputed from the copy with the field (discrete
// and volume centers, each with its own frame) moves by less than 1e-4 of a bin, where the field
// kept only from the bins' means (no center_motion) moves it by 10 times that or more.
TEST(Fingerprint, TheFieldLeavesTheCenterWhereItWas) {
  const Key key = key_from_passphrase_v1("fingerprint bins key");
  for (const std::string& mesh : {test::data_mesh("spot.obj"), test::cgal_mesh("camel.off")}) {
    MESHMARK_REQUIRE(mesh, mesh);
    const Mesh O = read_mesh(mesh);
    const std::vector<std::uint8_t> carrier = carrier_vertices(O.V, O.F);
    const std::vector<std::pair<std::uint64_t, Mesh>> copies = marked_copies(mesh, 120, 130, key);
    for (const CenterKind kind : {CenterKind::Discrete, CenterKind::Volume}) {
      const std::optional<FingerprintFrame> frame = fingerprint_frame(O.V, O.F, kind, 64);
      ASSERT_TRUE(frame);
      double kept = 0, loose = 0;  // the largest drifts, in bins, with and without
      for (const auto& [id, copy] : copies) {
        const Eigen::VectorXd g = fingerprint_coefficients(key, id, frame->basis.functions);
        const auto drift = [&](const Eigen::MatrixX3d* motion) {
          const Eigen::MatrixX3d with = add_fingerprint(
              copy.V, O.V, frame->basis, g, FingerprintOptions().rms, &frame->histogram, motion);
          return (center_of_mass(with, O.F, carrier, kind).point -
                  center_of_mass(copy.V, O.F, carrier, kind).point)
                     .norm() /
                 frame->histogram.step;
        };
        kept = std::max(kept, drift(&frame->center_motion));
        loose = std::max(loose, drift(nullptr));
      }
      EXPECT_LT(kept, 1e-4) << mesh << " " << static_cast<int>(kind);
      EXPECT_GT(loose, 10 * kept) << mesh << " " << static_cast<int>(kind);
      RecordProperty(fmt::format("drift_{}_{}", std::filesystem::path(mesh).stem().string(),
                                 static_cast<int>(kind)),
                     fmt::format("{:.3g} kept, {:.3g} without", kept, loose));
    }
  }
}

// The default (IssueSettings::fingerprint unset): a copy recorded in a registry carries the
// fingerprint (its row says mark format 5, trace reads a z above 5, the copy differs from the
// same copy issued with false by a field whose RMS is within a factor 2 of
// FingerprintOptions::rms); false records the histogram mark's format and trace reads no
// fingerprint; a copy issued without a registry carries none (the same positions as false's).
// An original with too few counted carrier vertices for one (ellipsoid simplified to 122) is
// issued without by default, with a warning, and refused when the fingerprint is asked for;
// so is a raw payload.
TEST(Fingerprint, RegisteredCopiesCarryItByDefault) {
  const std::string original = test::cgal_mesh("camel.off");
  MESHMARK_REQUIRE(original, "libcgal-demo's camel.off");
  const std::string dir = fresh_dir("fingerprint-default");
  const Mesh O = read_mesh(original);
  const std::string hash = content_hash(read_file(original));
  IssueSettings settings;
  settings.key = key_from_passphrase_v1("fingerprint default key");
  const auto issue = [&](std::optional<bool> fingerprint, const std::string& name,
                         bool registered) {
    settings.fingerprint = fingerprint;
    settings.registry = registered ? dir + "/" + name + ".db" : "";
    CopyRequest r;
    r.input = original, r.output = dir + "/" + name + ".ply", r.id = 91, r.buyer = "buyer 91";
    const IssueResult result = issue_copies({r}, settings);
    EXPECT_EQ(result.copies[0].status, CopyStatus::Written) << result.copies[0].message;
    return read_mesh(r.output);
  };
  const Mesh by_default = issue(std::nullopt, "default", true);
  const Mesh plain = issue(false, "plain", true);
  const Mesh unregistered = issue(std::nullopt, "unregistered", false);
  EXPECT_EQ(read_registry(dir + "/default.db")[0].mark_format, kFingerprintMarkFormat);
  EXPECT_EQ(read_registry(dir + "/plain.db")[0].mark_format, kMarkFormatVersion);
  ASSERT_EQ(unregistered.V.rows(), plain.V.rows());
  EXPECT_EQ((unregistered.V - plain.V).cwiseAbs().maxCoeff(), 0.0);
  const double field = counted_rms_percent(plain, by_default) / 100;
  EXPECT_GT(field, FingerprintOptions().rms / 2);
  EXPECT_LT(field, FingerprintOptions().rms * 2);
  const TraceResult with = trace_issued(by_default, O, hash, dir + "/default.db", *settings.key);
  ASSERT_EQ(with.status, TraceStatus::Named) << with.message;
  EXPECT_EQ(with.named[0].copy.id, 91u);
  EXPECT_GT(with.named[0].fingerprint_z, 5);
  const TraceResult without = trace_issued(plain, O, hash, dir + "/plain.db", *settings.key);
  ASSERT_EQ(without.status, TraceStatus::Named) << without.message;
  EXPECT_TRUE(std::isnan(without.named[0].fingerprint_z));

  // Too small for a fingerprint: 122 counted carrier vertices, fewer than 16 per function for 8.
  const std::string ellipsoid = test::cgal_mesh("ellipsoid.off");
  MESHMARK_REQUIRE(ellipsoid, "libcgal-demo's ellipsoid.off");
  Mesh small = apply_attack_chain(read_mesh(ellipsoid), parse_attack_chain("simplify:0.75"), 1);
  const std::vector<std::uint8_t> carrier = carrier_vertices(small.V, small.F);
  ASSERT_EQ(fingerprint_functions(
                static_cast<std::size_t>(std::count(carrier.begin(), carrier.end(), kCounted))),
            0);
  settings.bits = 32, settings.id_bits = 4;
  settings.registry = dir + "/small.db";
  CopyRequest r;
  r.mesh = std::make_shared<const Mesh>(std::move(small));
  r.input = "small ellipsoid", r.output = dir + "/small.ply", r.id = 5, r.buyer = "buyer 5";
  settings.fingerprint.reset();
  const CopyOutcome issued = issue_copies({r}, settings).copies[0];
  EXPECT_NE(issued.status, CopyStatus::Refused) << issued.message;
  EXPECT_TRUE(std::any_of(issued.warnings.begin(), issued.warnings.end(), [](const auto& w) {
    return w.find("too few for a fingerprint") != std::string::npos &&
           w.find("histogram mark alone") != std::string::npos;
  })) << issued.message;
  settings.fingerprint = true;
  const CopyOutcome refused = issue_copies({r}, settings).copies[0];
  EXPECT_EQ(refused.status, CopyStatus::Refused);
  EXPECT_NE(refused.message.find("too few for a fingerprint"), std::string::npos)
      << refused.message;
  // Enough vertices, but a geometry the basis cannot stand on: coordinates 1e200 times the
  // original's (areas and squared distances overflow double). The copy goes on without a
  // fingerprint, saying why, and its histogram mark then says what it can do (here: not
  // embedded, a named status); with a fingerprint required, it is refused naming the reason.
  // Neither throws (the CLI exited 1, "bad command line", with no file named).
  Mesh huge = read_mesh(original);
  huge.V *= 1e200;
  huge.image.reset();
  CopyRequest h;
  h.mesh = std::make_shared<const Mesh>(std::move(huge));
  h.input = "huge original", h.output = dir + "/huge.ply", h.id = 6, h.buyer = "buyer 6";
  settings.registry = dir + "/huge.db";
  settings.fingerprint.reset();
  const CopyOutcome without_basis = issue_copies({h}, settings).copies[0];
  EXPECT_EQ(without_basis.status, CopyStatus::NotEmbedded) << without_basis.message;
  EXPECT_TRUE(std::any_of(without_basis.warnings.begin(), without_basis.warnings.end(),
                          [](const auto& w) {
                            return w.find("huge original: no fingerprint can be made on it") !=
                                   std::string::npos;
                          }))
      << without_basis.message;
  settings.fingerprint = true;
  const CopyOutcome huge_refused = issue_copies({h}, settings).copies[0];
  EXPECT_EQ(huge_refused.status, CopyStatus::Refused);
  EXPECT_NE(huge_refused.message.find("no fingerprint can be made on it"), std::string::npos)
      << huge_refused.message;
  CopyRequest raw;
  raw.input = original, raw.output = dir + "/raw.ply", raw.payload_hex = "00ff00ff";
  settings.registry.clear();
  const CopyOutcome payload = issue_copies({raw}, settings).copies[0];
  EXPECT_EQ(payload.status, CopyStatus::Refused);
  EXPECT_NE(payload.message.find("a fingerprint goes with a coded ID"), std::string::npos)
      << payload.message;
  settings.fingerprint.reset();
  EXPECT_EQ(issue_copies({raw}, settings).copies[0].status, CopyStatus::Written);
}

// Settings issuing under key into registry within a vertex RMS of max_rms_percent (the other
// limits the paper's).
IssueSettings within_limits(const Key& key, double max_rms_percent, const std::string& registry) {
  IssueSettings settings;
  settings.key = key;
  settings.limits = CalibrateOptions();
  settings.limits->max_rms_percent = max_rms_percent;
  settings.registry = registry;
  return settings;
}

// A request for the copy of input with ID id, for "buyer ID", written to output.
CopyRequest copy_request(const std::string& input, const std::string& output, std::uint64_t id) {
  CopyRequest r;
  r.input = input, r.output = output, r.id = id, r.buyer = "buyer " + std::to_string(id);
  return r;
}

// Limits no histogram mark fits (strengths from 0.2 only, RMS at most 0.015 %) but the
// fingerprint does (raised for camel's 9,770 vertices: it measures 0.0148 % under this key, and
// the plain 0.01 % would be tried if it did not fit): the copy is issued with the fingerprint
// alone, says so, records strength 0, stays within the limits (measured from the file here), and
// traces to its buyer by the fingerprint alone; the unmarked original names nobody. Without the
// fingerprint the copy is refused.
TEST(Fingerprint, ACopyWhoseHistogramMarkCannotFitIsIssuedWithTheFingerprintAlone) {
  const std::string original = test::cgal_mesh("camel.off");
  MESHMARK_REQUIRE(original, "libcgal-demo's camel.off");
  const std::string dir = fresh_dir("fingerprint-alone");
  IssueSettings settings =
      within_limits(key_from_passphrase_v1("fingerprint alone key"), 0.015, dir + "/shop.db");
  settings.limits->min_strength = 0.2;
  CopyRequest r = copy_request(original, dir + "/copy.ply", 81);
  settings.fingerprint = false;
  const IssueResult refused = issue_copies({r}, settings);
  EXPECT_EQ(refused.copies[0].status, CopyStatus::NotWithinFidelity);
  EXPECT_FALSE(std::filesystem::exists(r.output));
  settings.fingerprint = true;
  const IssueResult issued = issue_copies({r}, settings);
  ASSERT_EQ(issued.copies[0].status, CopyStatus::Written) << issued.copies[0].message;
  EXPECT_NE(issued.copies[0].message.find("fingerprint alone"), std::string::npos);
  ASSERT_FALSE(issued.copies[0].warnings.empty());
  EXPECT_NE(issued.copies[0].warnings.back().find("fingerprint alone"), std::string::npos);
  const std::vector<IssuedCopy> rows = read_registry(settings.registry, {});
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0].strength, 0.0);
  EXPECT_EQ(rows[0].mark_format, kFingerprintMarkFormat);
  const Mesh O = read_mesh(original), copy = read_mesh(r.output);
  EXPECT_LE(counted_rms_percent(O, copy), 0.015 * (1 + 1e-6));
  const std::string hash = content_hash(read_file(original));
  const TraceResult found = trace_issued(copy, O, hash, settings.registry, *settings.key);
  ASSERT_EQ(found.status, TraceStatus::Named) << found.message;
  EXPECT_EQ(found.named[0].copy.id, 81u);
  EXPECT_EQ(found.named[0].compared, 0);  // no histogram mark was read
  EXPECT_GT(found.named[0].fingerprint_z, 6);
  EXPECT_EQ(found.named[0].p_value, found.named[0].fingerprint_p);
  const TraceResult nobody = trace_issued(O, O, hash, settings.registry, *settings.key);
  EXPECT_EQ(nobody.status, TraceStatus::NoBuyer) << nobody.message;
}

// fingerprint_rms against its rule written out: FingerprintOptions::rms from 32,768 counted
// vertices on, times sqrt(32,768 / counted) below, at most 3 times; the options' rms scales it.
TEST(Fingerprint, ASmallOriginalsFieldIsRaisedByTheSquareRootOfItsVertexCount) {
  const FingerprintOptions plain;
  for (const std::size_t counted : {32768, 40000, 1000000})
    EXPECT_EQ(fingerprint_rms(counted), plain.rms) << counted;
  EXPECT_DOUBLE_EQ(fingerprint_rms(8192), 2 * plain.rms);  // sqrt(32768 / 8192) = 2
  EXPECT_DOUBLE_EQ(fingerprint_rms(16384), std::sqrt(2.0) * plain.rms);
  EXPECT_DOUBLE_EQ(fingerprint_rms(32767), std::sqrt(32768.0 / 32767.0) * plain.rms);
  for (const std::size_t counted : {0, 1, 500, 3640})  // sqrt(32768 / 3640) > 3
    EXPECT_DOUBLE_EQ(fingerprint_rms(counted), 3 * plain.rms) << counted;
  FingerprintOptions stronger;
  stronger.rms = 5e-4;
  EXPECT_DOUBLE_EQ(fingerprint_rms(8192, stronger), 1e-3);
}

// libcgal-demo's mushroom (2,337 vertices): at the default strength (0.05, no fidelity
// limits) its histogram mark is infeasible (bits that cannot reach their targets inside their
// bins). Issued by default into a registry, each copy carries the fingerprint alone: its
// outcome and warning say so, its row records strength 0 and mark format 5, and the file's
// displacement (the field alone) has the raised RMS of fingerprint_rms, computed here from the
// counted vertices: the mean over 4 IDs within [0.7, 1.15] of 3e-4 (the most it is raised:
// sqrt(32768 / counted) is above 3; a copy's RMS varies with its 146 signs, and the classes'
// lines the field leaves out take 6 to 16 % of it; the plain 1e-4 would read about 0.28 of it). A
// copy smoothed 10 times names its buyer by the fingerprint alone, the original nobody. Without the
// fingerprint, or without a registry, the copy is not embedded, as before.
TEST(Fingerprint, ACopyWhoseHistogramMarkIsInfeasibleAtItsStrengthCarriesTheFingerprintAlone) {
  const std::string original = test::cgal_mesh("mushroom.off");
  MESHMARK_REQUIRE(original, "libcgal-demo's mushroom.off");
  const std::string dir = fresh_dir("fingerprint-alone-fixed");
  IssueSettings settings;
  settings.key = key_from_passphrase_v1("mushroom shop key");
  settings.registry = dir + "/shop.db";
  const Mesh O = read_mesh(original);
  const std::vector<std::uint8_t> carrier = carrier_vertices(O.V, O.F);
  const auto counted = static_cast<double>(std::count(carrier.begin(), carrier.end(), kCounted));
  ASSERT_GT(std::sqrt(32768 / counted), 3);
  const double expected = 3e-4;
  double sum = 0;
  for (std::uint64_t id = 1; id <= 4; ++id) {
    const CopyRequest r = copy_request(original, dir + fmt::format("/copy{}.ply", id), id);
    const CopyOutcome c = issue_copies({r}, settings).copies[0];
    ASSERT_EQ(c.status, CopyStatus::Written) << c.message;
    EXPECT_TRUE(c.fingerprint_alone) << c.message;
    EXPECT_NE(c.message.find("the fingerprint alone"), std::string::npos) << c.message;
    ASSERT_FALSE(c.warnings.empty());
    EXPECT_NE(c.warnings.back().find("no histogram mark at strength 0.05"), std::string::npos)
        << c.warnings.back();
    sum += counted_rms_percent(O, read_mesh(r.output)) / 100;
  }
  EXPECT_GT(sum / 4 / expected, 0.7);
  EXPECT_LT(sum / 4 / expected, 1.15);
  const std::vector<IssuedCopy> rows = read_registry(settings.registry, {});
  ASSERT_EQ(rows.size(), 4u);
  for (const IssuedCopy& row : rows) {
    EXPECT_EQ(row.strength, 0.0);
    EXPECT_EQ(row.mark_format, kFingerprintMarkFormat);
  }
  const std::string hash = content_hash(read_file(original));
  const Mesh leak =
      apply_attack_chain(read_mesh(dir + "/copy3.ply"), parse_attack_chain("smooth:10"), 1);
  const TraceResult found = trace_issued(leak, O, hash, settings.registry, *settings.key);
  ASSERT_EQ(found.status, TraceStatus::Named) << found.message;
  ASSERT_EQ(found.named.size(), 1u);
  EXPECT_EQ(found.named[0].copy.id, 3u);
  EXPECT_EQ(found.named[0].compared, 0);  // no histogram mark was read
  const TraceResult nobody = trace_issued(O, O, hash, settings.registry, *settings.key);
  EXPECT_EQ(nobody.status, TraceStatus::NoBuyer) << nobody.message;
  settings.fingerprint = false;
  settings.registry = dir + "/without.db";
  const CopyOutcome without =
      issue_copies({copy_request(original, dir + "/without.ply", 1)}, settings).copies[0];
  EXPECT_EQ(without.status, CopyStatus::NotEmbedded) << without.message;
  EXPECT_FALSE(std::filesystem::exists(dir + "/without.ply"));
  // Asked for without a registry: a copy with the fingerprint alone could not be read by
  // anyone (no row for trace, no histogram mark for extract): refused as before.
  settings.fingerprint = true;
  settings.registry.clear();
  const CopyOutcome unregistered =
      issue_copies({copy_request(original, dir + "/unregistered.ply", 1)}, settings).copies[0];
  EXPECT_EQ(unregistered.status, CopyStatus::NotEmbedded) << unregistered.message;
  EXPECT_FALSE(unregistered.fingerprint_alone);
  EXPECT_FALSE(std::filesystem::exists(dir + "/unregistered.ply"));
}

// On libcgal-demo's plane.off (841 vertices, 52 bumps) the histogram mark is infeasible at 0.05
// too, and the fingerprint alone is too weak to name anyone among many: the copy as issue_copies
// would make it (built here from fingerprint_frame and add_fingerprint, as campaigns do), traced
// unprocessed against 10,000 rows of consecutive IDs, names nobody. So the copy is not issued
// (exit 4 in the CLI), nothing is written or recorded, and the message gives its own p.
TEST(Fingerprint, AFingerprintAloneThatCannotNameItsBuyerIsNotIssued) {
  const std::string original = test::cgal_mesh("plane.off");
  MESHMARK_REQUIRE(original, "libcgal-demo's plane.off");
  const std::string dir = fresh_dir("fingerprint-alone-weak");
  IssueSettings settings;
  settings.key = key_from_passphrase_v1("plane shop key");
  settings.registry = dir + "/shop.db";
  const std::uint64_t id = 5000;
  const CopyOutcome c =
      issue_copies({copy_request(original, dir + "/copy.ply", id)}, settings).copies[0];
  EXPECT_EQ(c.status, CopyStatus::NotEmbedded) << c.message;
  EXPECT_NE(c.message.find("would not name its buyer among 10000 candidates"), std::string::npos)
      << c.message;
  EXPECT_FALSE(c.fingerprint_alone);
  EXPECT_FALSE(std::filesystem::exists(dir + "/copy.ply"));
  EXPECT_TRUE(read_registry(settings.registry, {}).empty());

  const Mesh O = read_mesh(original);
  const std::optional<FingerprintFrame> frame =
      fingerprint_frame(O.V, O.F, settings.embedding.variant.center, settings.bits);
  ASSERT_TRUE(frame.has_value());
  const auto counted =
      static_cast<std::size_t>(std::count(frame->counted.begin(), frame->counted.end(), 1));
  Mesh copy = O;
  copy.V = add_fingerprint(O.V, O.V, frame->basis,
                           fingerprint_coefficients(*settings.key, id, frame->basis.functions),
                           fingerprint_rms(counted), &frame->histogram, &frame->center_motion);
  std::vector<IssuedCopy> rows(kFingerprintAloneCandidates);
  for (int k = 0; k < kFingerprintAloneCandidates; ++k) {
    IssuedCopy& row = rows[static_cast<std::size_t>(k)];
    row.row = k + 1;
    row.id = id - kFingerprintAloneCandidates / 2 + static_cast<std::uint64_t>(k);
    row.bits = settings.bits;
    row.variant = settings.embedding.variant.name();
    row.strength = 0;
    row.key_fingerprint = key_fingerprint(*settings.key);
    row.mark_format = kFingerprintMarkFormat;
  }
  TraceOptions o;
  o.register_leak = false;
  const TraceResult among = trace(copy, O, rows, *settings.key, o);
  EXPECT_EQ(among.status, TraceStatus::NoBuyer) << among.message;
  EXPECT_EQ(among.ranking.front().copy.id, id);  // it reads best, but not enough
}

// Within limits (RMS 0.02 %, MSDM 1) under this key, spot's copy for ID 25 calibrated with
// format 4's field lost 8 histogram bits in its OBJ file and needed the field kept from moving
// the center. Format 5's narrower field costs more of the RMS limit on this small mesh (at 0.02 %
// no histogram mark fits beside it any more: such copies carry the fingerprint alone), so within
// RMS 0.025 %: the copy is written with the plain field (no second chance: none of spot's IDs 1
// to 40 needs it, within these limits or at strengths 0.01 to 0.001 without them), its row
// records mark format 5, the file stays within the limits (measured here), what the outcome
// reports is the file's, and trace names its buyer with every bit of the file read. Asked for
// (fingerprint true), the same. The field raised for spot's 2,930 vertices (3 times 0.01 %)
// leaves no room for a histogram mark within 0.025 %: the search is run again with the plain
// field, which the outcome's message reports (its RMS alone at most 0.0125 %, where the raised
// one measures about 0.024 %).
TEST(Fingerprint, ACalibratedCopyOfASmallOriginalKeepsEveryBitWithThePlainField) {
  const std::string original = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(original, "spot.obj");
  const std::string dir = fresh_dir("fingerprint-calibrated-centered");
  for (const bool asked : {false, true}) {
    SCOPED_TRACE(asked ? "asked for" : "by default");
    IssueSettings settings = within_limits(key_from_passphrase("fallback shop key"), 0.025,
                                           dir + (asked ? "/asked.db" : "/shop.db"));
    settings.limits->max_msdm = 1;
    if (asked) settings.fingerprint = true;
    const CopyRequest r = copy_request(original, dir + (asked ? "/asked.obj" : "/copy.obj"), 25);
    const IssueResult issued = issue_copies({r}, settings);
    const CopyOutcome& c = issued.copies[0];
    ASSERT_EQ(c.status, CopyStatus::Written) << c.message;
    ASSERT_TRUE(c.calibration.has_value());
    EXPECT_GT(c.calibration->strength, 0.0);
    EXPECT_FALSE(c.fingerprint_alone) << c.message;
    EXPECT_FALSE(c.kept_center) << c.message;
    const std::string alone = "the fingerprint's alone ";
    const std::size_t at = c.message.find(alone);
    ASSERT_NE(at, std::string::npos) << c.message;
    EXPECT_LE(std::stod(c.message.substr(at + alone.size())), 0.0125) << c.message;
    const std::vector<IssuedCopy> rows = read_registry(settings.registry, {});
    ASSERT_EQ(rows.size(), 1u);
    EXPECT_EQ(rows[0].mark_format, kFingerprintMarkFormat);
    EXPECT_EQ(rows[0].strength, c.calibration->strength);
    const Mesh O = read_mesh(original), copy = read_mesh(r.output);
    const double rms = counted_rms_percent(O, copy), m = msdm(O.V, copy.V, O.F).global;
    EXPECT_LE(rms, 0.025 * (1 + 1e-6));
    EXPECT_LE(m, 1.0);
    // What the outcome reports is the written copy's (OBJ's decimals: 1e-3 of the value).
    EXPECT_NEAR(c.calibration->rms_percent, rms, 1e-3 * rms);
    EXPECT_NEAR(c.calibration->msdm, m, 1e-3 * m);
    const TraceResult found =
        trace_issued(copy, O, content_hash(read_file(original)), settings.registry, *settings.key);
    ASSERT_EQ(found.status, TraceStatus::Named) << found.message;
    EXPECT_EQ(found.named[0].copy.id, 25u);
    EXPECT_EQ(found.named[0].compared, 64);
    EXPECT_GT(found.named[0].fingerprint_z, 4);
  }
}

// Requests for copies of `original` to IDs 1001 to 1020, written as dir/copy-ID.ply.
std::vector<CopyRequest> twenty_copies(const std::string& original, const std::string& dir) {
  std::vector<CopyRequest> requests;
  for (std::uint64_t id = 1001; id <= 1020; ++id) {
    CopyRequest r;
    r.input = original;
    r.output = dir + "/copy-" + std::to_string(id) + ".ply";
    r.id = id;
    r.buyer = "buyer " + std::to_string(id);
    requests.push_back(r);
  }
  return requests;
}

// A shop issuing every copy with the fingerprint into `dir`/shop.db.
IssueSettings fingerprinted_shop(const std::string& dir) {
  IssueSettings settings;
  settings.key = key_from_passphrase_v1("fingerprint shop key");
  settings.registry = dir + "/shop.db";
  settings.fingerprint = true;
  return settings;
}

// twenty_copies of `original`, issued next to the registry; empty (after a failed expectation)
// unless every copy was written.
std::vector<CopyRequest> issue_twenty_copies(const std::string& original,
                                             const IssueSettings& settings) {
  const std::string dir = settings.registry.substr(0, settings.registry.rfind('/'));
  const std::vector<CopyRequest> requests = twenty_copies(original, dir);
  const IssueResult issued = issue_copies(requests, settings);
  EXPECT_EQ(issued.count(CopyStatus::Written), requests.size()) << issued.copies[0].message;
  if (issued.count(CopyStatus::Written) != requests.size()) return {};
  return requests;
}

// Issued and traced through the library as the CLI does: 20 consecutive IDs of bunny00 with
// the fingerprint (a real scan, 37,706 vertices). An unprocessed copy names its buyer with the
// fingerprint at the strength its reading allows; vertex-wise averages of three and five copies,
// which the histogram mark alone does not survive (issue 30), name colluders and nobody else; a
// decimated copy, a copy smoothed then decimated, and a copy re-marked with the public key name
// their buyer alone.
TEST(Fingerprint, IssuedCopiesNameTheirBuyerAfterAveragingResamplingAndRemarking) {
  const std::string original = test::cgal_mesh("bunny00.off");
  MESHMARK_REQUIRE(original, "libcgal-demo's bunny00.off");
  const IssueSettings settings = fingerprinted_shop(fresh_dir("fingerprint-issue"));
  const std::vector<CopyRequest> requests = issue_twenty_copies(original, settings);
  ASSERT_FALSE(requests.empty());
  const Mesh O = read_mesh(original);
  const auto trace_of = [&](const Mesh& leak) {
    return trace_issued(leak, O, content_hash(read_file(original)), settings.registry,
                        *settings.key);
  };
  const TraceResult one = trace_of(read_mesh(requests[6].output));
  ASSERT_EQ(one.status, TraceStatus::Named) << one.message;
  ASSERT_EQ(one.named.size(), 1u);
  EXPECT_EQ(one.named[0].copy.id, 1007u);
  // Full strength: the z of the field alone (without the histogram mark) read at the original's
  // vertices with trace's ridge, computed here from the field; within 10 %. It is below |g|
  // (about sqrt(K), K = 512 on bunny00): the ridge gives up part of an unprocessed copy's score
  // for the resampled ones below.
  const std::vector<std::uint8_t> carrier = carrier_vertices(O.V, O.F);
  const int K = fingerprint_functions(
      static_cast<std::size_t>(std::count(carrier.begin(), carrier.end(), kCounted)));
  EXPECT_EQ(K, FingerprintOptions().functions);
  {
    const Center c = center_of_mass(O.V, O.F, carrier, CenterKind::Discrete);
    const FingerprintBasis basis = fingerprint_basis(O.V, O.F, carrier, c.point, K);
    const Histogram h = build_histogram(O.V, carrier, c.point, 64);
    const Eigen::VectorXd g = fingerprint_coefficients(*settings.key, 1007, K);
    const Eigen::VectorXd field = basis.field(g) * (FingerprintOptions().rms * basis.diagonal);
    std::vector<std::uint8_t> mask(carrier.size());
    for (std::size_t i = 0; i < mask.size(); ++i) mask[i] = carrier[i] == kCounted;
    const double z_field = fingerprint_score(
        g, read_fingerprint(basis, field, mask, &h, TraceOptions().fingerprint_ridge));
    EXPECT_NEAR(one.named[0].fingerprint_z / z_field, 1.0, 0.1) << "field alone: " << z_field;
  }
  for (const CandidateScore& c : one.ranking) EXPECT_EQ(c.copy.mark_format, kFingerprintMarkFormat);
  // Averages of 3 and 5 copies (IDs 1003 to 1005, 1003 to 1007): colluders named, only them.
  for (const int k : {3, 5}) {
    Mesh average = read_mesh(requests[2].output);
    for (int j = 1; j < k; ++j) average.V += read_mesh(requests[2 + j].output).V;
    average.V /= k;
    const TraceResult avg = trace_of(average);
    ASSERT_EQ(avg.status, TraceStatus::Named) << k << " copies: " << avg.message;
    for (const CandidateScore& n : avg.named)
      EXPECT_TRUE(n.copy.id >= 1003 && n.copy.id < 1003u + k)
          << k << " copies: an innocent named: " << n.copy.id;
    RecordProperty("colluders_named_of_" + std::to_string(k), std::to_string(avg.named.size()));
  }
  // Three copies (IDs 1003 to 1005) merged otherwise: unequal weights, and cut into three
  // regions pasted together. Colluders named, only them.
  std::vector<Mesh> three;
  for (int j = 0; j < 3; ++j) three.push_back(read_mesh(requests[2 + j].output));
  const Mesh spliced = attack_collude(three, {CollusionKind::Splice, {}}, 3);
  for (const auto& [name, leak] :
       {std::pair<std::string, Mesh>{
            "unequal", attack_collude(three, {CollusionKind::Average, {0.6, 0.3, 0.1}})},
        {"spliced", spliced}}) {
    const TraceResult merged = trace_of(leak);
    ASSERT_EQ(merged.status, TraceStatus::Named) << name << ": " << merged.message;
    for (const CandidateScore& n : merged.named)
      EXPECT_TRUE(n.copy.id >= 1003 && n.copy.id <= 1005) << name << ": an innocent: " << n.copy.id;
    RecordProperty("colluders_named_" + name, std::to_string(merged.named.size()));
  }
  // The splice read without regions and with them: each candidate's fingerprint p is, from the
  // scores of the two traces (the same readings of the whole), min(1, P(z) n) without and the
  // weighted Bonferroni with (n readings of the whole, 9 n regional ones, a fifth of the budget
  // to the latter; P the format's p of one reading).
  TraceOptions whole_only;
  whole_only.fingerprint_regions = {};
  whole_only.ranking = 0;
  TraceOptions by_region;
  by_region.ranking = 0;
  const TraceResult plain = trace_issued(spliced, O, content_hash(read_file(original)),
                                         settings.registry, *settings.key, whole_only);
  const TraceResult regional = trace_issued(spliced, O, content_hash(read_file(original)),
                                            settings.registry, *settings.key, by_region);
  ASSERT_EQ(plain.ranking.size(), requests.size());
  ASSERT_EQ(regional.ranking.size(), requests.size());
  const double n =
      plain.fingerprint_processing.find("processed original") != std::string::npos ? 2 : 1;
  EXPECT_NE(
      regional.fingerprint_processing.find("each also over 9 regions (partitions of 2, 3, 4)"),
      std::string::npos)
      << regional.fingerprint_processing;
  const auto P = [](double z) { return fingerprint_p_value(z, kFingerprintMarkFormat); };
  for (const CandidateScore& w : plain.ranking) {
    const auto it = std::find_if(regional.ranking.begin(), regional.ranking.end(),
                                 [&](const CandidateScore& c) { return c.copy.id == w.copy.id; });
    ASSERT_NE(it, regional.ranking.end()) << w.copy.id;
    EXPECT_NEAR(w.fingerprint_p, std::min(1.0, P(w.fingerprint_z) * n), 1e-12) << w.copy.id;
    EXPECT_GE(it->fingerprint_z, w.fingerprint_z) << w.copy.id;
    const double expected =
        it->fingerprint_z > w.fingerprint_z
            ? std::min({1.0, P(w.fingerprint_z) * n / 0.8, P(it->fingerprint_z) * 9 * n / 0.2})
            : std::min(1.0, P(w.fingerprint_z) * n / 0.8);
    EXPECT_NEAR(it->fingerprint_p, expected, 1e-12 + 1e-9 * expected) << w.copy.id;
  }
  // Resampled: decimated to 30 % (its faces cut corners between vertices on the marked surface),
  // and smoothed 10 times then decimated to 30 %. The buyer named by the fingerprint (read at the
  // leak's vertices) and nobody else.
  const Mesh copy = read_mesh(requests[6].output);
  for (const char* chain : {"simplify:0.3", "smooth:10,simplify:0.3"}) {
    const TraceResult r = trace_of(apply_attack_chain(copy, parse_attack_chain(chain), 1));
    ASSERT_EQ(r.status, TraceStatus::Named) << chain << ": " << r.message;
    ASSERT_EQ(r.named.size(), 1u) << chain;
    EXPECT_EQ(r.named[0].copy.id, 1007u) << chain;
    EXPECT_LT(r.named[0].fingerprint_p * 2 * 20, TraceOptions().threshold) << chain;
    RecordProperty(std::string("z_") + chain, std::to_string(r.named[0].fingerprint_z));
  }
  // Re-marked by anyone with meshmark's public key (another ID's histogram mark over the buyer's,
  // at the default strength), which removes the buyer's histogram mark: named by the fingerprint.
  const EmbedResult remarked = embed(copy.V, copy.F, id_bins(IdCode(), 5, std::nullopt));
  ASSERT_EQ(remarked.status, EmbedStatus::Embedded) << remarked.message;
  Mesh laundered = copy;
  laundered.V = remarked.V;
  const TraceResult r = trace_of(laundered);
  ASSERT_EQ(r.status, TraceStatus::Named) << "re-marked: " << r.message;
  ASSERT_EQ(r.named.size(), 1u);
  EXPECT_EQ(r.named[0].copy.id, 1007u);
  EXPECT_LT(r.named[0].fingerprint_p * 2 * 20, TraceOptions().threshold);
  RecordProperty("z_remarked", std::to_string(r.named[0].fingerprint_z));
  // Registries without the leakers: the same leaks against the other 19 (or 17, 15) rows name
  // nobody, and every innocent's fingerprint p stays above the threshold over 20.
  const std::vector<IssuedCopy> all = read_registry(settings.registry);
  const auto without = [&](std::uint64_t first, std::uint64_t count) {
    std::vector<IssuedCopy> rows;
    for (const IssuedCopy& c : all)
      if (c.id < first || c.id >= first + count) rows.push_back(c);
    return rows;
  };
  Mesh average3 = read_mesh(requests[2].output);
  for (int j = 1; j < 3; ++j) average3.V += read_mesh(requests[2 + j].output).V;
  average3.V /= 3;
  for (const auto& [leak, first, count] :
       {std::tuple<const Mesh*, std::uint64_t, std::uint64_t>{&copy, 1007, 1},
        {&laundered, 1007, 1},
        {&average3, 1003, 3},
        {&spliced, 1003, 3}}) {
    const TraceResult innocent = trace(*leak, O, without(first, count), *settings.key);
    EXPECT_EQ(innocent.status, TraceStatus::NoBuyer) << first << ": " << innocent.message;
    EXPECT_TRUE(innocent.named.empty()) << first;
    for (const CandidateScore& c : innocent.ranking)
      EXPECT_GT(c.fingerprint_p * 2 * 20, TraceOptions().threshold) << "innocent " << c.copy.id;
  }
}

// A copy decimated to 30 % then smoothed 10 times (Laplacian, lambda 0.3: issue 30's resampling
// then smoothing) has vertices that slid along the surface; read against the place where each
// one's ray crosses the original, the slide reads as noise several times the fingerprint. Read
// also against where its vertices were before the smoothing (TraceOptions::
// fingerprint_unsmoothing, the default), its buyer is named, by the fingerprint alone (the
// histogram mark does not survive it), where without that reading it scores under half as
// high. That reading is one more of the whole surface: every candidate's best z is at least
// the one without it. Against the registry without the buyer nobody is named and every
// innocent's fingerprint p stays above the threshold over 20 (times 4: combined_p_value with
// the histogram mark lost).
TEST(Fingerprint, AResampledThenSmoothedLeakIsReadAgainstItsVerticesBeforeTheSmoothing) {
  const std::string original = test::cgal_mesh("bunny00.off");
  MESHMARK_REQUIRE(original, "libcgal-demo's bunny00.off");
  const IssueSettings settings = fingerprinted_shop(fresh_dir("fingerprint-unsmoothing"));
  const std::vector<CopyRequest> requests = issue_twenty_copies(original, settings);
  ASSERT_FALSE(requests.empty());
  const Mesh O = read_mesh(original);
  const Mesh leak = apply_attack_chain(read_mesh(requests[6].output),
                                       parse_attack_chain("simplify:0.3,smooth:10"), 1);
  TraceOptions with;
  with.ranking = 0;
  TraceOptions without = with;
  without.fingerprint_unsmoothing = false;
  const std::string hash = content_hash(read_file(original));
  const TraceResult a = trace_issued(leak, O, hash, settings.registry, *settings.key, with);
  const TraceResult b = trace_issued(leak, O, hash, settings.registry, *settings.key, without);
  ASSERT_EQ(a.status, TraceStatus::Named) << a.message << "; " << a.fingerprint_processing;
  ASSERT_EQ(a.named.size(), 1u);
  EXPECT_EQ(a.named[0].copy.id, 1007u);
  EXPECT_LT(a.named[0].fingerprint_p * 4 * 20, TraceOptions().threshold);
  EXPECT_NE(a.fingerprint_processing.find("before the smoothing"), std::string::npos)
      << a.fingerprint_processing;
  EXPECT_EQ(b.fingerprint_processing.find("before the smoothing"), std::string::npos)
      << b.fingerprint_processing;
  ASSERT_EQ(a.ranking.size(), requests.size());
  ASSERT_EQ(b.ranking.size(), requests.size());
  for (const CandidateScore& c : b.ranking) {
    const auto it = std::find_if(a.ranking.begin(), a.ranking.end(),
                                 [&](const CandidateScore& x) { return x.copy.id == c.copy.id; });
    ASSERT_NE(it, a.ranking.end()) << c.copy.id;
    EXPECT_GE(it->fingerprint_z, c.fingerprint_z - 1e-12) << c.copy.id;
    if (c.copy.id == 1007)
      EXPECT_LT(2 * c.fingerprint_z, it->fingerprint_z)
          << "without " << c.fingerprint_z << ", with " << it->fingerprint_z;
  }
  RecordProperty("z_with", std::to_string(a.named[0].fingerprint_z));
  // A leak with more crossed vertices than the limit (here 1,000 of about 11,000) is read as
  // without the reading, and the processing says why.
  TraceOptions limited = with;
  limited.fingerprint_unsmoothing_limit = 1000;
  const TraceResult l = trace_issued(leak, O, hash, settings.registry, *settings.key, limited);
  EXPECT_NE(l.fingerprint_processing.find("(not read before the smoothing: "), std::string::npos)
      << l.fingerprint_processing;
  EXPECT_NE(l.fingerprint_processing.find(" leak vertices, over 1000)"), std::string::npos)
      << l.fingerprint_processing;
  ASSERT_EQ(l.ranking.size(), b.ranking.size());
  for (std::size_t i = 0; i < l.ranking.size(); ++i) {
    EXPECT_EQ(l.ranking[i].copy.id, b.ranking[i].copy.id);
    EXPECT_EQ(l.ranking[i].fingerprint_z, b.ranking[i].fingerprint_z);
  }
  std::vector<IssuedCopy> innocents;
  for (const IssuedCopy& c : read_registry(settings.registry))
    if (c.id != 1007) innocents.push_back(c);
  const TraceResult none = trace(leak, O, innocents, *settings.key, with);
  EXPECT_EQ(none.status, TraceStatus::NoBuyer) << none.message;
  for (const CandidateScore& c : none.ranking)
    EXPECT_GT(c.fingerprint_p * 4 * 20, TraceOptions().threshold) << "innocent " << c.copy.id;
}

// A leak with the original's faces (here the copy of 1007 of ChineseDragon-10kv with uniform
// noise of 0.1 % of the diagonal) is read vertex to vertex. The buyer's z equals, within 2 %,
// an independent reading: the leak resampled at the original's vertices (resample_at_original,
// vertex for vertex for such a leak) and read there with read_fingerprint. Read through the
// planes of the faces its rays cross, as before 2026-12-07, it was 5.5 where both readings gave
// 11.9 (11.5 since reading 4 also fits each class on the obliquity). The buyer is named by the
// fingerprint alone.
TEST(Fingerprint, ALeakWithTheOriginalsFacesIsReadVertexToVertex) {
  const std::string original = test::cgal_mesh("ChineseDragon-10kv.off");
  MESHMARK_REQUIRE(original, "libcgal-demo's ChineseDragon-10kv.off");
  const IssueSettings settings = fingerprinted_shop(fresh_dir("fingerprint-vertex"));
  const std::vector<CopyRequest> requests = issue_twenty_copies(original, settings);
  ASSERT_FALSE(requests.empty());
  const Mesh O = read_mesh(original);
  const Mesh leak =
      apply_attack_chain(read_mesh(requests[6].output), parse_attack_chain("noise:0.001"), 1);
  TraceOptions o;
  o.ranking = 0;
  const TraceResult t =
      trace_issued(leak, O, content_hash(read_file(original)), settings.registry, *settings.key, o);
  ASSERT_EQ(t.status, TraceStatus::Named) << t.message << "; " << t.fingerprint_processing;
  ASSERT_EQ(t.named.size(), 1u);
  EXPECT_EQ(t.named[0].copy.id, 1007u);
  EXPECT_LT(t.named[0].fingerprint_p * 4 * 20, TraceOptions().threshold);
  // The independent reading, as meshmark_fingerprint_probe makes it.
  const std::vector<std::uint8_t> carrier = carrier_vertices(O.V, O.F);
  std::size_t counted = 0;
  for (const std::uint8_t c : carrier) counted += c == kCounted;
  const Center c = center_of_mass(O.V, O.F, carrier, CenterKind::Discrete);
  const int K = fingerprint_functions(counted);
  const FingerprintBasis basis = fingerprint_basis(O.V, O.F, carrier, c.point, K);
  const Histogram h = build_histogram(O.V, carrier, c.point, 64);
  const Resampled m =
      resample_at_original(leak.V, leak.F, O.V, O.F, c.point, 0.005 * basis.diagonal);
  std::vector<std::uint8_t> used(carrier.size());
  Eigen::VectorXd r(O.V.rows()), obliquity(O.V.rows());
  const Eigen::MatrixX3d normals = vertex_normals(O.V, O.F);
  for (Eigen::Index i = 0; i < O.V.rows(); ++i) {
    used[i] = carrier[i] == kCounted && m.measured[i];
    r(i) =
        (m.point.row(i).transpose() - c.point).norm() - (O.V.row(i).transpose() - c.point).norm();
    // Each radial class is also fitted on (n . u)^2 (fingerprint reading 4): n the original's
    // normal at the vertex, u the direction from the center to the leak's vertex.
    const Eigen::Vector3d u = (m.point.row(i).transpose() - c.point).normalized();
    obliquity(i) = std::pow(normals.row(i).normalized().dot(u), 2);
  }
  const Eigen::VectorXd b =
      read_fingerprint(basis, r, used, &h, TraceOptions().fingerprint_ridge, &obliquity);
  const double z = fingerprint_score(fingerprint_coefficients(*settings.key, 1007, K), b);
  EXPECT_NEAR(t.named[0].fingerprint_z, z, 0.02 * z);
  RecordProperty("z_trace", std::to_string(t.named[0].fingerprint_z));
  RecordProperty("z_resampled", std::to_string(z));
}

// Format 5's bumps are 0.45 times as wide as format 4's, whose width is the spacing
// sqrt(A / K) (A the triangles' area, summed here); a copy carrying either field is read with its
// own format's bumps (the rows' mark format says which), the same beside rows of the other
// format (a registry holding both), and there scores higher than read with the other's; format 5's
// unprocessed copy scores higher than format 4's (its bumps overlap less: more independent
// directions for the same RMS).
TEST(Fingerprint, EachFormatIsReadWithItsOwnBumpsAndFormatFiveScoresHigher) {
  const std::string original = test::cgal_mesh("camel.off");
  MESHMARK_REQUIRE(original, "libcgal-demo's camel.off");
  const Mesh O = read_mesh(original);
  const std::vector<std::uint8_t> carrier = carrier_vertices(O.V, O.F);
  const int K = fingerprint_functions(
      static_cast<std::size_t>(std::count(carrier.begin(), carrier.end(), kCounted)));
  double area = 0;
  for (Eigen::Index f = 0; f < O.F.rows(); ++f) {
    const Eigen::Vector3d a = O.V.row(O.F(f, 0)), b = O.V.row(O.F(f, 1)), c = O.V.row(O.F(f, 2));
    area += 0.5 * (b - a).cross(c - a).norm();
  }
  std::map<int, std::optional<FingerprintFrame>> frames;
  for (const int format : {kWideBumpFingerprintFormat, kFingerprintMarkFormat}) {
    frames[format] = fingerprint_frame(O.V, O.F, CenterKind::Discrete, 64, true, format);
    ASSERT_TRUE(frames[format]);
    ASSERT_EQ(frames[format]->basis.functions, K);
  }
  EXPECT_NEAR(frames[4]->basis.width / std::sqrt(area / K), 1.0, 1e-12);
  EXPECT_NEAR(frames[5]->basis.width / frames[4]->basis.width, 0.45, 1e-12);

  // Copies of IDs 1001 to 1020 with the histogram mark alone, then buyer 1007's with each field.
  const std::string dir = fresh_dir("fingerprint-formats");
  IssueSettings settings;
  settings.key = key_from_passphrase_v1("fingerprint formats key");
  settings.registry = dir + "/shop.db";
  settings.fingerprint = false;
  const std::vector<CopyRequest> requests = twenty_copies(original, dir);
  const IssueResult issued = issue_copies(requests, settings);
  ASSERT_EQ(issued.count(CopyStatus::Written), requests.size()) << issued.copies[0].message;
  const std::vector<IssuedCopy> rows = read_registry(settings.registry);
  const Mesh plain = read_mesh(requests[6].output);
  // The fingerprint z of 1007 when the rows say `as` (its edited rows are never named: the
  // ranking has every candidate's score).
  // `others`: the format of the other rows (0: as 1007's), so that a registry holding both
  // formats of one original, read as two groups, is tried too.
  const auto z_of = [&](const Mesh& leak, int as, int others = 0) {
    std::vector<IssuedCopy> edited = rows;
    for (IssuedCopy& c : edited) c.mark_format = c.id == 1007 || others == 0 ? as : others;
    const TraceResult r = trace(leak, O, edited, *settings.key);
    for (const CandidateScore& c : r.ranking)
      if (c.copy.id == 1007) return c.fingerprint_z;
    ADD_FAILURE() << "1007 not ranked";
    return 0.0;
  };
  std::map<int, double> z;
  for (const int format : {kWideBumpFingerprintFormat, kFingerprintMarkFormat}) {
    const FingerprintFrame& f = *frames[format];
    Mesh copy = plain;
    copy.V = add_fingerprint(plain.V, O.V, f.basis,
                             fingerprint_coefficients(*settings.key, 1007, K, format),
                             FingerprintOptions().rms, &f.histogram, &f.center_motion);
    const int other =
        format == kFingerprintMarkFormat ? kWideBumpFingerprintFormat : kFingerprintMarkFormat;
    z[format] = z_of(copy, format);
    const double misread = z_of(copy, other);
    // Beside rows of the other format (two groups), 1007's row is read as alone.
    EXPECT_NEAR(z_of(copy, format, other), z[format], 1e-9) << "format " << format;
    EXPECT_GT(z[format], 5) << "format " << format;
    EXPECT_GT(z[format], misread) << "format " << format << " read with format " << other;
    RecordProperty("z_format_" + std::to_string(format), std::to_string(z[format]));
    RecordProperty("z_format_" + std::to_string(format) + "_misread", std::to_string(misread));
  }
  EXPECT_GT(z[kFingerprintMarkFormat], z[kWideBumpFingerprintFormat]);
}

TEST(Fingerprint, RefusesWhatItCannotDo) {
  const Scene s = setup("elephant.off");
  EXPECT_THROW(fingerprint_basis(s.original.V, s.original.F, s.carrier, s.basis.center, 0),
               InvalidArgumentError);
  // 16 counted vertices a function at least.
  EXPECT_THROW(fingerprint_basis(s.original.V, s.original.F, s.carrier, s.basis.center,
                                 static_cast<int>(s.original.V.rows())),
               InvalidArgumentError);
  EXPECT_THROW(add_fingerprint(s.original.V, s.original.V, s.basis,
                               fingerprint_coefficients(s.key, 1, 64), 1e-4),
               InvalidArgumentError);
  EXPECT_THROW(add_fingerprint(s.original.V, s.original.V, s.basis,
                               fingerprint_coefficients(s.key, 1, 128), 0.5),
               InvalidArgumentError);
}

// trace reads a leak without holding the basis at all its points (read_fingerprint_at sums
// rows 65,536 at a time): the reading must be the one of the whole basis, bit for bit. 150,000
// points on and off elephant's surface (three blocks, the last one partial), a mask with holes,
// residuals with NaNs, with and without a histogram's classes taken out.
TEST(Fingerprint, ReadingAtPointsInBlocksIsTheWholeBasisReadingBitForBit) {
  const Scene s = setup("elephant.off");
  Eigen::MatrixX3d P = sample_surface(s.original.V, s.original.F, 150000, 3);
  const Eigen::Index n = P.rows();  // sample_surface adds the vertices
  ASSERT_GT(n, 2 * 65536);
  std::mt19937_64 rng(5);
  std::normal_distribution<double> gauss;
  Eigen::VectorXd r(n);
  std::vector<std::uint8_t> mask(static_cast<std::size_t>(n));
  for (Eigen::Index i = 0; i < n; ++i) {
    for (int c = 0; c < 3; ++c) P(i, c) += 1e-3 * s.basis.diagonal * gauss(rng);
    r(i) = i % 997 == 0 ? std::nan("") : 1e-4 * s.basis.diagonal * gauss(rng);
    mask[static_cast<std::size_t>(i)] = i % 7 != 0;
  }
  const Histogram h = build_histogram(s.original.V, s.carrier, s.basis.center, 64);
  const Histogram classes = histogram_at(h, P, mask);
  const FingerprintBasis whole = fingerprint_basis_at(s.basis, P, mask);
  ASSERT_GT(whole.index.size(), 0U);
  const FingerprintBasis bumps =
      fingerprint_bumps(s.original.V, s.original.F, s.carrier, s.basis.center, s.basis.functions);
  EXPECT_TRUE(bumps.row_start.empty() && bumps.index.empty() && bumps.value.empty());
  EXPECT_EQ(bumps.points, s.basis.points);
  EXPECT_EQ(bumps.scale, s.basis.scale);
  EXPECT_EQ(bumps.width, s.basis.width);
  for (const Histogram* keep : {static_cast<const Histogram*>(nullptr), &classes})
    for (const double ridge : {0.0, 1.0}) {
      const Eigen::VectorXd expected = read_fingerprint(whole, r, mask, keep, ridge);
      const Eigen::VectorXd b = read_fingerprint_at(s.basis, P, r, mask, keep, ridge);
      ASSERT_TRUE(expected.allFinite());
      EXPECT_EQ(b, expected) << (keep ? "with" : "without") << " classes, ridge " << ridge;
      // trace reads with the bumps alone (fingerprint_bumps: no rows at the original's
      // vertices): the same reading.
      EXPECT_EQ(read_fingerprint_at(bumps, P, r, mask, keep, ridge), expected);
    }
  // Its checks are read_fingerprint's and fingerprint_basis_at's.
  EXPECT_THROW(read_fingerprint_at(s.basis, P, r.head(n - 1), mask), InvalidArgumentError);
  EXPECT_THROW(read_fingerprint_at(s.basis, P.topRows(n - 1), r, mask), InvalidArgumentError);
  EXPECT_THROW(read_fingerprint_at(s.basis, P, r, mask, nullptr, -1), InvalidArgumentError);
}

// A copy made once does not hold the basis' rows (about 216 bytes a vertex): add_fingerprint_at
// evaluates them 65,536 vertices at a time. The field must be the whole basis' field bit for
// bit (150,000 points on and off elephant's surface, three blocks, a mask with holes), and the
// copies the same, with and without a histogram and the center's motion kept (spot: twins on
// its seams, camel), for 5 IDs each.
TEST(Fingerprint, AFieldAddedWithoutItsRowsIsTheSameCopyBitForBit) {
  const Scene s = setup("elephant.off");
  Eigen::MatrixX3d P = sample_surface(s.original.V, s.original.F, 150000, 3);
  const Eigen::Index n = P.rows();
  ASSERT_GT(n, 2 * 65536);
  std::mt19937_64 rng(11);
  std::normal_distribution<double> gauss;
  std::vector<std::uint8_t> mask(static_cast<std::size_t>(n));
  for (Eigen::Index i = 0; i < n; ++i) {
    for (int c = 0; c < 3; ++c) P(i, c) += 1e-3 * s.basis.diagonal * gauss(rng);
    mask[static_cast<std::size_t>(i)] = i % 5 != 0;
  }
  Eigen::VectorXd a(s.basis.functions);
  for (Eigen::Index k = 0; k < a.size(); ++k) a(k) = gauss(rng);
  const FingerprintBasis whole = fingerprint_basis_at(s.basis, P, mask);
  std::vector<std::uint8_t> covered;
  const Eigen::VectorXd field = fingerprint_field_at(s.basis, P, mask, a, &covered);
  EXPECT_EQ(field, whole.field(a));
  ASSERT_EQ(covered.size(), mask.size());
  std::size_t with_entries = 0;
  for (Eigen::Index i = 0; i < n; ++i) {
    const bool entries = whole.row_start[i + 1] > whole.row_start[i];
    EXPECT_EQ(covered[static_cast<std::size_t>(i)], entries ? 1 : 0) << "row " << i;
    with_entries += entries;
  }
  EXPECT_GT(with_entries, static_cast<std::size_t>(n / 2));
  EXPECT_THROW(fingerprint_field_at(s.basis, P, mask, a.head(3)), InvalidArgumentError);
  EXPECT_THROW(fingerprint_field_at(s.basis, P.topRows(n - 1), mask, a), InvalidArgumentError);

  const Key key = key_from_passphrase_v1("fingerprint rows key");
  for (const std::string& mesh : {test::data_mesh("spot.obj"), test::cgal_mesh("camel.off")}) {
    MESHMARK_REQUIRE(mesh, mesh);
    const Mesh O = read_mesh(mesh);
    const std::optional<FingerprintFrame> held =
        fingerprint_frame(O.V, O.F, CenterKind::Discrete, 64);
    const std::optional<FingerprintFrame> bumps =
        fingerprint_frame(O.V, O.F, CenterKind::Discrete, 64, false);
    ASSERT_TRUE(held && bumps);
    EXPECT_TRUE(bumps->basis.row_start.empty() && bumps->basis.index.empty());
    EXPECT_FALSE(held->basis.row_start.empty());
    EXPECT_EQ(bumps->counted, held->counted);
    for (const auto& [id, copy] : marked_copies(mesh, 120, 125, key)) {
      const Eigen::VectorXd g = fingerprint_coefficients(key, id, held->basis.functions);
      const double rms = FingerprintOptions().rms;
      for (const bool keep : {false, true})
        for (const bool centered : {false, true}) {
          if (centered && !keep) continue;
          const Histogram* h = keep ? &held->histogram : nullptr;
          const Eigen::MatrixX3d* m = centered ? &held->center_motion : nullptr;
          const Eigen::MatrixX3d expected = add_fingerprint(copy.V, O.V, held->basis, g, rms, h, m);
          const Eigen::MatrixX3d got =
              add_fingerprint_at(copy.V, O.V, bumps->basis, bumps->counted, g, rms, h, m);
          EXPECT_GT((expected - copy.V).cwiseAbs().maxCoeff(), 0.0);
          EXPECT_EQ(got, expected)
              << mesh << " ID " << id << (keep ? " kept" : "") << (centered ? " centered" : "");
        }
    }
  }
}

// The same end to end: a copy issued alone (its original prepared without the rows) is the
// file issued beside another copy of the same original (prepared with them), byte for byte.
TEST(Fingerprint, ACopyIssuedAloneIsTheFileIssuedInABatch) {
  const std::string original = test::cgal_mesh("camel.off");
  MESHMARK_REQUIRE(original, "libcgal-demo's camel.off");
  const std::string dir = fresh_dir("fingerprint-alone");
  IssueSettings settings;
  settings.key = key_from_passphrase_v1("fingerprint alone key");
  settings.fingerprint = true;
  const auto request = [&](std::uint64_t id, const std::string& name) {
    CopyRequest r;
    r.input = original, r.output = dir + "/" + name + ".ply", r.id = id;
    return r;
  };
  const IssueResult alone = issue_copies({request(77, "alone")}, settings);
  const IssueResult batch = issue_copies({request(77, "batch"), request(78, "other")}, settings);
  for (const IssueResult* r : {&alone, &batch})
    for (const CopyOutcome& c : r->copies) ASSERT_EQ(c.status, CopyStatus::Written) << c.message;
  EXPECT_EQ(read_file(dir + "/alone.ply"), read_file(dir + "/batch.ply"));
  EXPECT_NE(read_file(dir + "/alone.ply"), read_file(dir + "/other.ply"));
}

}  // namespace
}  // namespace meshmark
