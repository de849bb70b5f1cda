#include "meshmark/carrier/carrier_check.h"

#include <algorithm>

#include <fmt/format.h>

#include "meshmark/core/error.h"
#include "meshmark/core/mesh.h"

namespace meshmark {

std::string CarrierCheck::summary() const {
  std::string out;
  for (const std::string& d : diagnostics) out += (out.empty() ? "" : "; ") + d;
  return out;
}

CarrierCheck check_carrier(const std::vector<std::uint8_t>& carrier, const Histogram& h) {
  CarrierCheck c;
  c.bits = std::max(h.bins - 2, 0);
  c.thin_tolerated = c.bits / kThinBinsPerTolerated;
  for (const std::uint8_t v : carrier) {
    c.carrier += v != 0;
    c.positions += v == kCounted;
  }
  // Positions per data bin (bins 1..nb).
  std::vector<int> counts(static_cast<std::size_t>(c.bits), 0);
  for (const int b : h.bin)
    if (b >= 1 && b <= c.bits) ++counts[static_cast<std::size_t>(b - 1)];
  c.fewest = counts.empty() ? 0 : *std::min_element(counts.begin(), counts.end());
  for (const int n : counts) {
    c.empty_bins += n == 0;
    c.thin_bins += n > 0 && n < kMinPositionsPerBin;
  }
  const std::string vertices =
      c.carrier > c.positions ? fmt::format("; {} carrier vertices", c.carrier) : "";
  if (!h.valid() || c.positions < c.minimum()) {
    c.status = CarrierHealth::Unusable;
    c.diagnostics.push_back(
        !h.valid() && c.positions >= c.minimum()
            ? fmt::format("{} distinct positions{}, all at one distance from the center: no "
                          "histogram",
                          c.positions, vertices)
            : fmt::format("{} distinct positions for {} bits ({} bins{}): at least {} needed to "
                          "fill every bin once, {} for reliable bits (collapsed, duplicated or "
                          "far too coarse geometry)",
                          c.positions, c.bits, c.bits + 2, vertices, c.minimum(), c.recommended()));
    return c;
  }
  if (c.empty_bins > 0)
    c.diagnostics.push_back(fmt::format("{} of {} bins empty: {} bit(s) cannot be read",
                                        c.empty_bins, c.bits, c.empty_bins));
  if (c.thin_bins > c.thin_tolerated)
    c.diagnostics.push_back(fmt::format(
        "{} of {} bins hold fewer than {} distinct positions (fewest {}): one vertex decides "
        "each of those bits",
        c.thin_bins, c.bits, kMinPositionsPerBin, c.fewest));
  if (c.positions < c.recommended())
    c.diagnostics.push_back(
        fmt::format("{} distinct positions for {} bits{}: {} recommended ({} per bin): too coarse",
                    c.positions, c.bits, vertices.empty() ? "" : " (" + vertices.substr(2) + ")",
                    c.recommended(), kMinPositionsPerBin));
  if (!c.diagnostics.empty()) c.status = CarrierHealth::Weak;
  return c;
}

CarrierCheck check_carrier(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F, int nbits,
                           CenterKind center) {
  if (nbits < 1) throw InvalidArgumentError(fmt::format("cannot check {} bits", nbits));
  const std::vector<std::uint8_t> carrier = carrier_vertices(V, F);
  const Center c = center_of_mass(V, F, carrier, center);
  return check_carrier(carrier, build_histogram(V, carrier, c.point, nbits));
}

const char* carrier_health_name(CarrierHealth health) {
  return enum_name(health);
}

}  // namespace meshmark
