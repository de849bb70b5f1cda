#include "meshmark/mark/decode.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "meshmark/core/error.h"
#include "meshmark/core/mesh.h"

namespace meshmark {

BinWord ExtractResult::word() const {
  BinWord p;
  p.bits.reserve(bits.size());
  for (auto b : bits) p.bits.push_back(b == 1 ? 1 : 0);
  return p;
}

double ExtractResult::min_margin() const {
  if (margins.empty()) return 0;
  return *std::min_element(margins.begin(), margins.end());
}

ExtractResult extract(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                      const ExtractOptions& options) {
  validate_mesh(V, F);
  if (options.bits < 1)
    throw InvalidArgumentError(fmt::format("cannot extract {} bits", options.bits));
  if (options.skip_nearest < 0 || options.skip_farthest < 0)
    throw InvalidArgumentError("cannot skip a negative number of vertices");
  ExtractResult r;
  auto referenced = carrier_vertices(V, F);
  r.center = center_of_mass(V, F, referenced, options.center);
  if (options.skip_nearest > 0 || options.skip_farthest > 0) {
    // Leave out the farthest positions one at a time, then the nearest, each time recomputing
    // the center without the vertices left out and without their faces (an outlier's faces
    // add area and volume to the surface and volume centers).
    std::vector<std::uint8_t> left_out(referenced.size(), 0);
    Eigen::MatrixX3i kept = F;
    auto leave_out_one = [&](bool farthest) {
      int pick = -1;
      double best = 0;
      for (Eigen::Index i = 0; i < V.rows(); ++i) {
        if (referenced[i] != kCounted) continue;
        const double d = (V.row(i).transpose() - r.center.point).squaredNorm();
        if (pick < 0 || (farthest ? d > best : d < best)) pick = static_cast<int>(i), best = d;
      }
      if (pick < 0) return;
      // The position leaves, with every vertex at it (a split corner's twins and their faces).
      const Eigen::RowVector3d p = V.row(pick);
      for (Eigen::Index i = 0; i < V.rows(); ++i)
        if (referenced[i] && V.row(i) == p) referenced[i] = 0, left_out[i] = 1;
      Eigen::Index count = 0;
      for (Eigen::Index f = 0; f < kept.rows(); ++f)
        if (!left_out[kept(f, 0)] && !left_out[kept(f, 1)] && !left_out[kept(f, 2)])
          kept.row(count++) = kept.row(f);
      kept.conservativeResize(count, 3);
      r.center = center_of_mass(V, kept, referenced, options.center);
    };
    for (int q = 0; q < options.skip_farthest; ++q) leave_out_one(true);
    for (int q = 0; q < options.skip_nearest; ++q) leave_out_one(false);
  }
  r.histogram = build_histogram(V, referenced, r.center.point, options.bits);
  r.check = check_carrier(referenced, r.histogram);
  const auto nb = static_cast<std::size_t>(options.bits);
  if (!r.histogram.valid()) {
    r.bits.assign(nb, kErasure);
    r.means.assign(nb, std::numeric_limits<double>::quiet_NaN());
    r.margins.assign(nb, 0.0);
    r.counts.assign(nb, 0);
    r.erasures = options.bits;
    return r;
  }
  bin_means(r.histogram, r.means, r.counts, bin_statistic(options.method));
  r.bits.resize(nb);
  r.margins.resize(nb);
  for (std::size_t j = 0; j < nb; ++j) {
    if (r.counts[j] == 0) {
      r.bits[j] = kErasure;
      r.margins[j] = 0;
      ++r.erasures;
    } else {
      r.bits[j] = r.means[j] > 0.5 ? 1 : 0;
      r.margins[j] = std::abs(r.means[j] - 0.5);
    }
  }
  return r;
}

}  // namespace meshmark
