// Embedding: EmbedOptions and its solver settings, EmbedResult, embed.

#include <fmt/format.h>

#include "bindings.h"
#include "meshmark/core/error.h"
#include "meshmark/mark/embed.h"
#include "meshmark/protocol/watermark.h"

namespace meshmark::python {

namespace {

void bind_settings(py::module_& m) {
  py::enum_<SolverBackend>(m, "SolverBackend", "Who solves each round's quadratic program.")
      .value("Native", SolverBackend::Native, "the structured solvers (the CLI's --solver native)")
      .value("Ipopt", SolverBackend::Ipopt, "Ipopt, for comparison (--solver ipopt)");
  py::enum_<Method>(m, "Method", "Who moves the vertices (method.h; the CLI's --method).")
      .value("Qp", Method::Qp, "the QP framework (qp, the default)")
      .value("ChoMean", Method::ChoMean, "Cho et al.'s Method I (cho-mean)")
      .value("ChoVariance", Method::ChoVariance, "Cho et al.'s Method II (cho-variance)");
  py::class_<ChoSettings> cho(m, "ChoSettings", "Cho's methods: the exponent search.");
  Fields<ChoSettings>(cho)
      .rw("tolerance", &ChoSettings::tolerance, "score units from the target")
      .rw("max_iterations", &ChoSettings::max_iterations, "score evaluations per bin at most")
      .done(true);
  py::enum_<AdmmXStep>(m, "AdmmXStep", "How ADMM's x-steps are solved (cost L).")
      .value("ConjugateGradients", AdmmXStep::ConjugateGradients, "--x-step cg")
      .value("Cholesky", AdmmXStep::Cholesky, "--x-step cholesky");
  py::enum_<QpStatus>(m, "QpStatus", "Outcome of a solve.")
      .value("Solved", QpStatus::Solved)
      .value("Infeasible", QpStatus::Infeasible)
      .value("IterationLimit", QpStatus::IterationLimit);
  py::class_<QpSettings> qp(m, "QpSettings", "The exact separable solver (costs S and Q).");
  Fields<QpSettings>(qp)
      .rw("max_iterations", &QpSettings::max_iterations, "Newton iterations")
      .rw("tolerance", &QpSettings::tolerance, "on the KKT residuals")
      .done(true);
  py::class_<AdmmSettings> admm(m, "AdmmSettings", "The ADMM solver (cost L).");
  Fields<AdmmSettings>(admm)
      .rw("x_step", &AdmmSettings::x_step, "AdmmXStep")
      .rw("rho", &AdmmSettings::rho, "penalty; 0 picks one from the Hessian's diagonal")
      .rw("relaxation", &AdmmSettings::relaxation, "over-relaxation in (0, 2)")
      .rw("tolerance", &AdmmSettings::tolerance, "on the primal and dual residuals")
      .rw("max_iterations", &AdmmSettings::max_iterations, "ADMM iterations at most")
      .rw("stall_iterations", &AdmmSettings::stall_iterations, "iterations without progress")
      .rw("cg_tolerance", &AdmmSettings::cg_tolerance, "relative residual of each x-step")
      .rw("max_cg_iterations", &AdmmSettings::max_cg_iterations, "per x-step")
      .done(true);
  py::class_<RoughnessOptions> rough(m, "RoughnessOptions",
                                     "Direction S: constants of the roughness field.");
  Fields<RoughnessOptions>(rough)
      .rw("curvature_radius", &RoughnessOptions::curvature_radius, "fraction of the diagonal")
      .rw("smoothing_sigma", &RoughnessOptions::smoothing_sigma, "fraction of the diagonal")
      .rw("window_sigma", &RoughnessOptions::window_sigma, "fraction of the diagonal")
      .rw("outlier_quantile", &RoughnessOptions::outlier_quantile, "in (0, 1]")
      .done(true);
  py::class_<IpoptOptions> ipopt(m, "IpoptOptions", "Backend Ipopt's settings.");
  Fields<IpoptOptions>(ipopt)
      .rw("tolerance", &IpoptOptions::tolerance, "Ipopt's tol")
      .rw("max_iterations", &IpoptOptions::max_iterations, "Ipopt's max_iter")
      .done(true);
}

void bind_options(py::module_& m) {
  py::class_<EmbedOptions> o(m, "EmbedOptions",
                             "Options of embed (C++ EmbedOptions, the same defaults). Strength and "
                             "bin offset are fractions of a bin width. `lambda` is `lambda_` "
                             "(a Python keyword).");
  Fields<EmbedOptions>(o)
      .rw("method", &EmbedOptions::method, "Method (Qp, or Cho's ChoMean or ChoVariance)")
      .rw("cho", &EmbedOptions::cho, "ChoSettings")
      .rw_property(
          "variant", [](EmbedOptions& x) -> Variant& { return x.variant; },
          [](EmbedOptions& x, py::handle v) { x.variant = to_variant(v); },
          "Variant, or its three letters ('DRS')")
      .rw("lambda_", &EmbedOptions::lambda, "costs Q and L: weight of the squared error, [0, 1]")
      .rw("strength", &EmbedOptions::strength, "alpha in (0, 1/2)")
      .rw("strengths", &EmbedOptions::strengths,
          "per-bit strengths (bin order); empty: drawn from the key for keyed or coded marks, "
          "else `strength` for every bit")
      .rw("bin_offset", &EmbedOptions::bin_offset, "G in [0, 1/2)")
      .rw("max_rounds", &EmbedOptions::max_rounds, "linearize-and-solve rounds at most")
      .rw("margin_tolerance", &EmbedOptions::margin_tolerance, "bin widths")
      .rw("center_tolerance", &EmbedOptions::center_tolerance, "bin widths")
      .rw("separable", &EmbedOptions::separable,
          "QpSettings: the exact separable solver (backend Native, costs S and Q)")
      .rw("admm", &EmbedOptions::admm, "AdmmSettings")
      .rw("roughness", &EmbedOptions::roughness, "RoughnessOptions")
      .rw("backend", &EmbedOptions::backend, "SolverBackend")
      .rw("ipopt", &EmbedOptions::ipopt, "IpoptOptions")
      .done(true);
}

void bind_result(py::module_& m) {
  py::enum_<EmbedStatus>(m, "EmbedStatus", "Outcome of embed.")
      .value("Embedded", EmbedStatus::Embedded, "every bit decodes with its margin")
      .value("Infeasible", EmbedStatus::Infeasible, "some bits cannot reach their targets")
      .value("NotConverged", EmbedStatus::NotConverged, "round or iteration limit reached")
      .value("InvalidMesh", EmbedStatus::InvalidMesh, "no histogram, or an ill-defined center");
  py::class_<EmbedResult> r(m, "EmbedResult", "What embed did (C++ EmbedResult).");
  Fields<EmbedResult>(r)
      .ro("status", &EmbedResult::status, "EmbedStatus")
      .ro("message", &EmbedResult::message, "one line for a person")
      .ro("rounds", &EmbedResult::rounds, "solves performed")
      .ro("solver_iterations", &EmbedResult::solver_iterations, "all rounds")
      .ro("radial_fallbacks", &EmbedResult::radial_fallbacks, "vertices moved radially instead")
      .ro("solver_status", &EmbedResult::solver_status, "last solve's QpStatus")
      .ro("kkt_residual", &EmbedResult::kkt_residual, "last solve's, bin widths")
      .ro("min_margin", &EmbedResult::min_margin, "smallest of margins (bin widths)")
      .ro("squared_displacement", &EmbedResult::squared_displacement, "model units squared")
      .ro("rms_displacement", &EmbedResult::rms_displacement, "model units")
      .ro("rms_percent", &EmbedResult::rms_percent, "% of the bounding-box diagonal")
      .ro("center_drift", &EmbedResult::center_drift, "bin widths")
      .ro("bin_width", &EmbedResult::bin_width, "model units")
      .ro("seconds", &EmbedResult::seconds, "wall time without file I/O")
      .ro("infeasible_bits", &EmbedResult::infeasible_bits, "bits (bin order) out of reach")
      .array(
          "V", [](const EmbedResult& x) { return positions_array(x.V); },
          "(n, 3) float64 watermarked positions (a new array on each access)")
      .array(
          "margins", [](const EmbedResult& x) { return vector_array(x.margins); },
          "(nb,) float64 signed margin per bit, bin order (bin widths)")
      .array(
          "check", [](const EmbedResult& x) { return x.check; }, "CarrierCheck of the input")
      .done(false);
}

// The payload's word in bin order and the options' strengths, as the CLI's embed makes them.
Payload mark_bins(py::handle payload, py::handle id, py::handle bits, const std::optional<Key>& key,
                  int id_bits, double spread, EmbedOptions& options) {
  if (payload.is_none() == id.is_none()) throw InvalidArgumentError("give payload or id, not both");
  const bool coded = !id.is_none();
  Payload word;
  if (coded) {
    if (!key)
      PyErr_WarnEx(PyExc_UserWarning,
                   "an id without a key is coded under the public key: anyone can read it, remove "
                   "it, or write any other buyer's ID",
                   1);
    IdCodeOptions code;
    code.bits = bits.is_none() ? 64 : bits.cast<int>();
    code.id_bits = id_bits;
    word = IdCode(code).encode(to_id(id), id_key(key));
  } else {
    word = to_payload(payload, bits);
  }
  if (options.strengths.empty())
    options.strengths = mark_strengths(key, word.size(), coded, options.strength, spread);
  return mark_layout(key, word.size(), coded).to_bins(word);
}

}  // namespace

void init_embed(py::module_& m) {
  bind_settings(m);
  bind_options(m);
  bind_result(m);
  m.def(
      "embed",
      [](py::handle V, py::handle F, py::handle payload, py::handle id, py::handle bits,
         py::handle key, py::handle key_file, int id_bits, double strength_spread,
         py::handle options, const py::kwargs& kwargs) {
        const Eigen::MatrixX3d v = to_positions(V);
        const Eigen::MatrixX3i f = to_faces(F, v.rows());
        EmbedOptions o = options.is_none() ? EmbedOptions{} : options.cast<EmbedOptions>();
        apply_keywords(py::cast(&o, py::return_value_policy::reference), kwargs);
        const std::optional<Key> k = resolve_key(key, key_file);
        const Payload bins = mark_bins(payload, id, bits, k, id_bits, strength_spread, o);
        py::gil_scoped_release unlocked;
        return embed(v, f, bins, o);
      },
      py::arg("V"), py::arg("F"), py::arg("payload") = py::none(), py::kw_only(),
      py::arg("id") = py::none(), py::arg("bits") = py::none(), py::arg("key") = py::none(),
      py::arg("key_file") = py::none(), py::arg("id_bits") = 32, py::arg("strength_spread") = 0.25,
      py::arg("options") = py::none(),
      "Embeds a payload into (V, F) as the CLI's embed does, and returns an EmbedResult (its V "
      "holds the new positions; nothing is written).\n\n"
      "payload: hexadecimal str (bits=64 by default) or a sequence of 0/1; or id: a buyer ID "
      "coded with error correction (id_bits, bits). key: a passphrase or a Key (or key_file: a "
      "path): keyed layout and per-bit strengths spread by strength_spread. Without a key, a "
      "raw payload uses the spec's canonical layout (bin j + 1 carries bit j). options: an "
      "EmbedOptions; further keywords set its fields (variant='VRS', strength=0.05, lambda_=0.5, "
      "...).");
}

}  // namespace meshmark::python
