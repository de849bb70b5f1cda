#pragma once
/// \file decode.h
/// Blind decoding (docs/method.md section 2): rebuild the histogram from the mesh
/// alone and read bit j from the mean normalized position of bin j + 1.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "meshmark/carrier/carrier_check.h"
#include "meshmark/carrier/histogram.h"
#include "meshmark/carrier/method.h"
#include "meshmark/mark/payload.h"

namespace meshmark {

/// Options of extract.
struct ExtractOptions {
  int bits = 64;                             ///< payload length nb (nB = nb + 2 bins)
  CenterKind center = CenterKind::Discrete;  ///< the variant's center
  /// Carrier positions (each with every vertex at it) left out, nearest the center and farthest
  /// from it: a reading that undoes outliers an attacker added (read_id in watermark.h tries a
  /// few). 0 for the normal reading.
  int skip_nearest = 0;
  int skip_farthest = 0;  ///< see skip_nearest
  /// The method the mark was written with: it decides the bin statistic read (method.h; QP
  /// and Cho's Method I read the mean, Cho's Method II the variance).
  Method method = Method::Qp;
};

/// Value of an erased bit (its bin is empty) in ExtractResult::bits.
inline constexpr std::uint8_t kErasure = 2;

/// What extract read.
struct ExtractResult {
  std::vector<std::uint8_t> bits;  ///< 0, 1, or kErasure for an empty bin
  /// Bin j + 1's score (NaN when empty): the mean of bin_score_term over its positions
  /// (method.h), i.e. tbar_j, the mean position, for the mean statistic; bit 1 above 1/2.
  std::vector<double> means;
  std::vector<double> margins;  ///< |score_j - 1/2|, the bit's confidence (0 when erased)
  std::vector<int> counts;      ///< distinct carrier positions in bin j + 1
  int erasures = 0;             ///< number of empty bins
  Center center;                ///< the center the histogram was built around
  Histogram histogram;          ///< the histogram itself
  /// Whether the carrier can carry nb bits (carrier_check.h): a warning (Weak) or an error
  /// (Unusable: collapsed, duplicated or far too coarse geometry) to report with the bits.
  CarrierCheck check;
  /// The bits read (bin order; BitLayout::from_bins gives payload order), erasures read as 0.
  BinWord word() const;
  /// Smallest margin over the bits (0 with an erasure).
  double min_margin() const;
};

/// Decodes nb bits from V, F (#V x 3, #F x 3). Only the carrier counts (carrier_vertices in
/// histogram.h: vertices of faces of nonzero area), each position once: a mesh with split
/// corners or stacked duplicates reads as its welded version. A mesh whose vertices all lie at
/// one distance gives all erasures.
ExtractResult extract(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                      const ExtractOptions& options = {});

// bin_means, the per-bin scores extract reads, is in histogram.h (included above).

}  // namespace meshmark
