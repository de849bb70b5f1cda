#pragma once
/// \file carrier_check.h
/// Whether a mesh has enough distinct carrier positions to carry nb bits: the check that runs
/// before decoding and embedding, so that collapsed or duplicated geometry (a broken converter
/// that put 50,000 vertices on a few points, a mesh far too coarse for the payload) is reported
/// instead of read or marked silently.

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "meshmark/carrier/center.h"
#include "meshmark/carrier/histogram.h"
#include "meshmark/core/enum_names.h"

namespace meshmark {

/// A data bin with fewer distinct carrier positions than this carries a bit that one position
/// decides. Bit j is the mean t of bin j + 1's n positions, embedded at 1/2 +- alpha with every
/// position kept inside [G, 1 - G] of its bin; one position moving across that range moves
/// the mean by (1 - 2G) / n, which carries it from one hypothesis (1/2 + alpha) to the other
/// (1/2 - alpha) when (1 - 2G) / n >= 2 alpha, i.e. n <= (1 - 2G) / (2 alpha). With the
/// defaults (G = 0.05, and keyed strengths alpha (1 + 0.25 u), u uniform in [0, 1), of mean
/// alpha = 0.05 x 1.125) that is n <= 0.9 / 0.1125 = 8: below 8, one vertex nudged by noise,
/// rounding or an attacker decides the bit, and a mark has no robustness left.
inline constexpr int kMinPositionsPerBin = 8;

/// Thin bins (fewer than kMinPositionsPerBin positions, not empty) tolerated before a warning:
/// one in kThinBinsPerTolerated of the data bins (8 of 64). A thin bin's bit is at risk, not
/// lost (its one decisive vertex must still move across most of its bin), and the tails of a
/// healthy histogram, the first and last data bins near a mesh's nearest and farthest points,
/// are often thin: measured at 64 bits, at most 6 thin bins on every mesh of data/meshes, of
/// CGAL's data and of four larger scans measured then with 2,048 distinct positions or more
/// (lion-head, femur), 9 to 43 on smaller or very skewed ones (elk, head, three_peaks, cactus,
/// hand, pig), which are then reported.
inline constexpr int kThinBinsPerTolerated = 8;

/// What the check concluded.
enum class CarrierHealth {
  Healthy,   ///< nothing to report
  Weak,      ///< readable, but some bits are unreliable or unreadable (a warning)
  Unusable,  ///< nothing can be decoded or embedded (an error)
};

/// The names of CarrierHealth's values (carrier_health_name).
template <>
struct EnumTable<CarrierHealth> {
  static constexpr const char* what = "carrier health";
  static constexpr NamedValue<CarrierHealth> values[] = {{CarrierHealth::Healthy, "healthy"},
                                                         {CarrierHealth::Weak, "weak"},
                                                         {CarrierHealth::Unusable, "unusable"}};
};

/// The check's outcome: a status, one line per finding, and the figures it used.
struct CarrierCheck {
  CarrierHealth status = CarrierHealth::Healthy;
  std::vector<std::string> diagnostics;  ///< one line each for a person; empty when healthy
  int bits = 0;                          ///< nb, the data bins (nB = nb + 2 bins)
  std::int64_t carrier = 0;              ///< carrier vertices (kCounted and kTwin)
  std::int64_t positions = 0;            ///< distinct carrier positions (each counts once)
  int empty_bins = 0;                    ///< data bins with no position: erased bits
  int thin_bins = 0;                     ///< data bins with 1 to kMinPositionsPerBin - 1
  int thin_tolerated = 0;                ///< nb / kThinBinsPerTolerated
  int fewest = 0;                        ///< smallest number of positions in a data bin
  /// The positions nb bits need at least: one per bin (nb + 2), and, for reliable bits,
  /// kMinPositionsPerBin per data bin plus the two extreme bins.
  std::int64_t minimum() const { return bits + 2; }
  std::int64_t recommended() const {
    return static_cast<std::int64_t>(kMinPositionsPerBin) * bits + 2;
  }
  /// The diagnostics in one line ("; " between them).
  std::string summary() const;
};

/// Checks a carrier (carrier_vertices) and the histogram built on it (h.bins = nb + 2).
/// Unusable: no histogram (no carrier, or every position at one distance), or fewer distinct
/// positions than bins (nb + 2): some bins must be empty and the word read is mostly erasures
/// or noise. Weak: some data bin empty (an erased bit), more than nb / kThinBinsPerTolerated
/// thin bins, or fewer positions than recommended() (too coarse for nb bits on average). O(#V).
CarrierCheck check_carrier(const std::vector<std::uint8_t>& carrier, const Histogram& h);

/// The check on a mesh as extract and embed see it: the carrier, the center of the given kind
/// and the histogram for nbits bits. V: #V x 3, F: #F x 3. \pre nbits >= 1.
CarrierCheck check_carrier(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F, int nbits,
                           CenterKind center = CenterKind::Discrete);

/// "healthy", "weak", "unusable".
const char* carrier_health_name(CarrierHealth health);

}  // namespace meshmark
