// Where the fingerprint goes (docs/forensics.md, "The fingerprint"): reads a leak's fingerprint
// against a reference surface given by hand, such as the same attack applied to a copy issued
// without the fingerprint, which trace cannot have. The leak and the reference are each
// resampled at the original's vertices as trace does (no registration: both must be in the
// original's frame), their radial difference read with the original's basis (DRS center, the
// histogram of 64 bits kept), and the score of the buyer's coefficients printed.
// Usage: meshmark_fingerprint_probe ORIGINAL LEAK KEY_FILE ID REFERENCE [K]

#include <fmt/format.h>

#include <cstdlib>
#include <exception>
#include <string>

#include "meshmark/carrier/center.h"
#include "meshmark/carrier/histogram.h"
#include "meshmark/forensics/fingerprint.h"
#include "meshmark/forensics/trace.h"
#include "meshmark/io/io.h"

int main(int argc, char** argv) try {
  using namespace meshmark;
  if (argc < 6) {
    fmt::print(stderr, "usage: {} ORIGINAL LEAK KEY_FILE ID REFERENCE [K]\n", argv[0]);
    return 2;
  }
  const Mesh O = read_mesh(argv[1]), L = read_mesh(argv[2]), R = read_mesh(argv[5]);
  const Key key = key_from_file(argv[3]);
  const std::uint64_t id = std::stoull(argv[4]);
  const std::vector<std::uint8_t> carrier = carrier_vertices(O.V, O.F);
  std::size_t counted = 0;
  for (const std::uint8_t c : carrier) counted += c == kCounted;
  const Center c = center_of_mass(O.V, O.F, carrier, CenterKind::Discrete);
  const int K = argc > 6 ? std::atoi(argv[6]) : fingerprint_functions(counted);
  const FingerprintBasis basis = fingerprint_basis(O.V, O.F, carrier, c.point, K);
  const Histogram h = build_histogram(O.V, carrier, c.point, 64);
  const double e = 0.005 * basis.diagonal;
  const Resampled mL = resample_at_original(L.V, L.F, O.V, O.F, c.point, e);
  const Resampled mR = resample_at_original(R.V, R.F, O.V, O.F, c.point, e);
  std::vector<std::uint8_t> used(carrier.size());
  Eigen::VectorXd r(O.V.rows());
  double sq = 0, n = 0;
  for (Eigen::Index i = 0; i < O.V.rows(); ++i) {
    used[i] = carrier[i] == kCounted && mL.measured[i] && mR.measured[i];
    r(i) = (mL.point.row(i).transpose() - c.point).norm() -
           (mR.point.row(i).transpose() - c.point).norm();
    if (used[i]) sq += r(i) * r(i), n += 1;
  }
  const Eigen::VectorXd b = read_fingerprint(basis, r, used, &h, TraceOptions().fingerprint_ridge);
  fmt::print("K {}: residual RMS {:.3g} of the diagonal, buyer {}'s z = {:.2f}\n", K,
             std::sqrt(sq / n) / basis.diagonal, id,
             fingerprint_score(fingerprint_coefficients(key, id, K), b));
  return 0;
} catch (const std::exception& e) {
  fmt::print(stderr, "meshmark_fingerprint_probe: {}\n", e.what());
  return 1;
}
