#pragma once
/// \file embed.h
/// Watermark embedding as a constrained optimization (docs/method.md sections 3
/// to 5; Rolland-Neviere, Doerr, Alliez, IEEE TIFS 9(9) 2014): move every referenced vertex
/// along a direction, as little as the cost allows, so that each bit's bin mean reaches its
/// target while the center, the histogram range and every vertex's bin stay as they were.
/// Rounds of linearized solves repeat until every bit decodes with its margin.

#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "meshmark/carrier/carrier_check.h"
#include "meshmark/carrier/histogram.h"
#include "meshmark/carrier/method.h"
#include "meshmark/carrier/roughness.h"
#include "meshmark/carrier/variant.h"
#include "meshmark/core/enum_names.h"
#include "meshmark/mark/cho.h"
#include "meshmark/mark/payload.h"
#include "meshmark/solve/separable_qp.h"
#include "meshmark/solve/solver_settings.h"

namespace meshmark {

/// Options of embed. Units: strength and bin offset are fractions of a bin width.
struct EmbedOptions {
  /// Who moves the vertices (method.h): the QP framework, or Cho et al.'s Method I or II
  /// (cho.h: radial moves around the variant's center; the variant must be ?RS, and
  /// bin_offset, lambda, the solvers and the backend do not apply).
  Method method = Method::Qp;
  ChoSettings cho;         ///< Cho's methods: the exponent search's tolerance and bound
  Variant variant;         ///< center, direction and cost (default DRS)
  double lambda = 0.5;     ///< costs Q and L: weight of the squared error, in [0, 1]
  double strength = 0.05;  ///< alpha in (0, 1/2): each bin mean moves to 1/2 +- alpha
  /// Per-bit strengths (bit j's bin mean moves to 1/2 +- strengths[j]), each in
  /// [strength, 1/2); empty: every bit gets `strength`. watermark.h draws keyed ones.
  std::vector<double> strengths;
  double bin_offset = 0.05;  ///< G in [0, 1/2): vertices stay inside [G, 1 - G] of their bin
  /// Linearize-and-solve rounds at most (QP); for Cho's methods, mapping rounds at most, each
  /// around the center and histogram of the previous one's result (1: Cho's single pass).
  int max_rounds = 10;
  /// A bit "decodes with its margin" when m_j (tbar_j - 1/2) >= strength - margin_tolerance.
  double margin_tolerance = 1e-6;
  /// The center may move by at most this many bin widths.
  double center_tolerance = 1e-6;
  RoughnessOptions roughness;  ///< direction S: constants of the roughness field
  /// Who solves the rounds (the CLI's --solver): the native solvers below, or Ipopt.
  SolverBackend backend = SolverBackend::Native;
  QpSettings separable;  ///< backend Native, costs S and Q: the exact separable solver's settings
  AdmmSettings admm;     ///< backend Native, cost L: the ADMM solver's settings
  IpoptOptions ipopt;    ///< backend Ipopt's settings
};

/// Outcome of embed.
enum class EmbedStatus {
  Embedded,      ///< every bit decodes with its margin, center within tolerance
  Infeasible,    ///< some bits cannot reach their targets (infeasible_bits); V unchanged
  NotConverged,  ///< max_rounds or the solver's iteration limit reached; V is the last round's
  InvalidMesh,   ///< no histogram (no referenced vertex, all at one distance), fewer distinct
                 ///< positions than bins (check), or a volume center that is ill-defined
                 ///< (open or inconsistently oriented mesh)
};

/// The names of EmbedStatus's values (embed_status_name).
template <>
struct EnumTable<EmbedStatus> {
  static constexpr const char* what = "embedding status";
  static constexpr NamedValue<EmbedStatus> values[] = {{EmbedStatus::Embedded, "embedded"},
                                                       {EmbedStatus::Infeasible, "infeasible"},
                                                       {EmbedStatus::NotConverged, "not converged"},
                                                       {EmbedStatus::InvalidMesh, "invalid mesh"}};
};

/// What embed did.
struct EmbedResult {
  EmbedStatus status = EmbedStatus::InvalidMesh;
  std::string message;                        ///< one line for a person
  Eigen::MatrixX3d V;                         ///< #V x 3 watermarked positions
  std::vector<int> infeasible_bits;           ///< bits j whose bin j + 1 cannot reach its target
  int rounds = 0;                             ///< solves performed
  int solver_iterations = 0;                  ///< Newton (S, Q) or ADMM (L) iterations, all rounds
  int radial_fallbacks = 0;                   ///< vertices whose direction missed their bin (C1)
  QpStatus solver_status = QpStatus::Solved;  ///< last solve's status
  /// The last solve's largest residual (bin widths): max of QpResult's primal_residual,
  /// complementarity and dual_residual, whichever the solver fills (separable_qp.h).
  double kkt_residual = 0;
  std::vector<double> margins;      ///< per bit, m_j (tbar_j - 1/2) after embedding (signed)
  double min_margin = 0;            ///< smallest of margins
  double squared_displacement = 0;  ///< sum_i |p_i^w - p_i|^2 (model units squared)
  double rms_displacement = 0;      ///< sqrt(mean over carrier positions of |p^w - p|^2)
  double rms_percent = 0;           ///< rms_displacement as % of the bounding-box diagonal
  double center_drift = 0;          ///< |C^w - C| in bin widths
  double bin_width = 0;             ///< s of the original histogram (model units)
  /// Wall time of the computation (no file I/O), in seconds: embed() counts the preparation
  /// (carrier, center, VSS's roughness field), PreparedEmbedder::embed the embedding alone.
  double seconds = 0;
  /// The input's carrier checked for nb bits before embedding (carrier_check.h): Weak is a
  /// warning (bits that one vertex decides, or empty bins); Unusable stops with InvalidMesh.
  CarrierCheck check;
};

/// Embeds payload (nb = payload.size() bits, in bin order: bit j moves bin j + 1's mean; a
/// keyed mark's BitLayout::to_bins gives it) into V, F (#V x 3, #F x 3) with options.method
/// (the QP framework by default; Cho's mapping: cho.h, with the same status and fields, the
/// solver's being the exponent search's: solver_iterations counts score evaluations). Unreferenced
/// vertices do not move. Vertices at bit-identical positions (unwelded seams, split corners)
/// share one unknown, so seams stay closed, and count once in the bin means, the center and the
/// cost, as the decoder counts them (carrier_vertices): a mesh with split corners is marked as
/// its welded version is. The input is not modified; the result holds the new positions.
/// \throw InvalidArgumentError for an empty payload or options out of range.
EmbedResult embed(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F, const BinWord& payload,
                  const EmbedOptions& options = {});

/// What embed computes from the mesh and the variant alone (the carrier and its groups of
/// identical positions, the one-ring structure of cost L, the roughness field of direction S,
/// the original center), computed once and reused for every payload, strength and bin offset:
/// calibration, batches of copies of one original and campaigns embed through one. It keeps
/// its own copy of V and F. Safe to use from several threads at once (embed() is const).
class PreparedEmbedder {
 public:
  /// Prepares V, F (#V x 3, #F x 3) for options' variant, roughness constants and solver.
  PreparedEmbedder(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                   const EmbedOptions& options = {});
  /// The same as embed(V, F, payload, options) on the prepared mesh.
  /// \throw InvalidArgumentError as embed, or when options ask for another variant, roughness
  ///        or solver than prepared (accepts() is false).
  EmbedResult embed(const BinWord& payload, const EmbedOptions& options) const;
  /// Whether options can use this preparation: the same variant and roughness constants and,
  /// when options need cost L's Hessian assembled (backend Ipopt or Cholesky x-steps), a
  /// preparation for such options.
  bool accepts(const EmbedOptions& options) const;
  const Eigen::MatrixX3d& V() const;  ///< the prepared positions
  const Eigen::MatrixX3i& F() const;  ///< the prepared faces
  /// The carrier check for nb bits (carrier_check.h), as embed reports it.
  CarrierCheck check(int nb) const;

 private:
  struct Impl;
  std::shared_ptr<const Impl> impl_;
};

/// Bit j's target strength under options: strengths[j], or strength when there are none.
double bit_strength(const EmbedOptions& options, int j);

/// "embedded", "infeasible", "not converged", "invalid mesh".
const char* embed_status_name(EmbedStatus status);

}  // namespace meshmark
