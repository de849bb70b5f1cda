#pragma once
/// \file histogram.h
/// The watermark's carrier: the histogram of vertex distances to a center of mass
/// (docs/method.md section 1; Rolland-Neviere et al., IEEE TIFS 2014, sec. III).

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "meshmark/carrier/center.h"
#include "meshmark/carrier/method.h"

namespace meshmark {

/// The histogram of distances to a center, nB = nb + 2 bins over [rho_min, rho_max].
struct Histogram {
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  double rho_min = 0, rho_max = 0;
  double step = 0;               ///< s = (rho_max - rho_min) / nB
  int bins = 0;                  ///< nB
  Eigen::VectorXd rho;           ///< per vertex distance (NaN for vertices that do not count)
  std::vector<int> bin;          ///< per vertex bin B_i in [0, nB), -1 for those that do not
  Eigen::VectorXd t;             ///< per vertex position inside its bin, (rho - rho_min)/s - B_i
  int argmin = -1, argmax = -1;  ///< a vertex attaining rho_min, rho_max
  /// False when there is nothing to histogram (no referenced vertex, or all at one distance).
  bool valid() const { return step > 0; }
};

/// The carrier: vertices used by at least one face whose three corners are at three different
/// positions and not on one line (the sine of its angle at the first corner above 1e-9), and
/// the vertices some face uses at the same position as one of those. A vertex that only
/// collapsed or flat faces use, away from the carrier, (a repeated index or two corners at the
/// same point: an invisible vertex an attacker added, or debris a tool left) never counts in
/// the histogram or the discrete center, and never moves. Embedding moves vertices at one
/// position together, so collapsed faces stay collapsed. A flat face whose corners move can
/// unfold, which adds its private vertex to the decoder's carrier: one vertex inside the range
/// (embed's check of the written file reads the mark as a decoder would, so it is caught if it
/// ever matters).
///
/// Each position counts once (welding for decoding): the first carrier vertex at a position is
/// kCounted, every later one at the bit-identical position kTwin (mesh.h). A mesh whose every
/// corner is split (glTF, Draco, an OBJ with per-face normals, or each triangle its own three
/// vertices) therefore has the same histogram, bin means and center as its welded version, and
/// copies of one vertex stacked at a point by an attacker change nothing. Cost: one hash pass
/// over the positions. Returns a mask of size #V with values 0, kCounted, kTwin.
std::vector<std::uint8_t> carrier_vertices(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F);

/// Builds the histogram of the counted vertices (referenced[i] == kCounted: a plain 0/1 mask
/// counts every marked vertex; twins and unmarked vertices get NaN and bin -1) around center
/// for nbits bits. Bin of vertex i: floor((rho_i - rho_min) / s), clamped to nB - 1.
Histogram build_histogram(const Eigen::MatrixX3d& V, const std::vector<std::uint8_t>& referenced,
                          const Eigen::Vector3d& center, int nbits);

/// The bins of h applied to other points: for each row of P with mask[i] != 0 whose distance
/// to h.center lies in [h.rho_min, h.rho_max], its distance, bin and position in the bin as
/// build_histogram computes them (h's range and step unchanged); the others get NaN and bin -1.
/// argmin and argmax are -1 (no point sets the range). Used to read a leak at its own vertices
/// on the original's bins.
Histogram histogram_at(const Histogram& h, const Eigen::MatrixX3d& P,
                       const std::vector<std::uint8_t>& mask);

/// Per-bin score over bins 1..nb of a histogram: means[j], the mean of
/// bin_score_term(statistic, t) (the mean of t for BinStatistic::Mean), and counts[j], for
/// bin j + 1.
void bin_means(const Histogram& h, std::vector<double>& means, std::vector<int>& counts,
               BinStatistic statistic = BinStatistic::Mean);

}  // namespace meshmark
