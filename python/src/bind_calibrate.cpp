// Strength calibration: calibrate_strength on arrays (calibrate.h) and calibrate_file with its
// cache (calibration_cache.h, the CLI's calibrate), with the library's option names and
// defaults.

#include <fmt/format.h>
#include <pybind11/functional.h>

#include "bindings.h"
#include "meshmark/campaign/calibration_cache.h"
#include "meshmark/campaign/campaign.h"
#include "meshmark/carrier/method.h"
#include "meshmark/core/error.h"
#include "meshmark/mark/calibrate.h"

namespace meshmark::python {

namespace {

// The calibration payload's length: at least one bit.
int checked_bits(int bits) {
  if (bits < 1) throw InvalidArgumentError(fmt::format("bits {} is not at least 1", bits));
  return bits;
}

// The limits: a CalibrateOptions (or the defaults) with keyword arguments set on it.
CalibrateOptions to_limits(py::handle limits, const py::kwargs& kwargs) {
  CalibrateOptions o = limits.is_none() ? CalibrateOptions{} : limits.cast<CalibrateOptions>();
  apply_keywords(py::cast(&o, py::return_value_policy::reference), kwargs);
  return o;
}

void bind_types(py::module_& m) {
  py::enum_<BinOffsetRule>(m, "BinOffsetRule",
                           "How the bin offset G follows the strength alpha (C++ BinOffsetRule).")
      .value("Fixed", BinOffsetRule::Fixed, "'fixed': G as the embedding asks (the paper's)")
      .value("AtMostStrength", BinOffsetRule::AtMostStrength,
             "'at-most-strength': G = min(G, alpha), the default");
  py::class_<CalibrateOptions> o(m, "CalibrateOptions",
                                 "Limits and search of calibrate (C++ CalibrateOptions, the same "
                                 "defaults: the paper's limits).");
  Fields<CalibrateOptions>(o)
      .rw("max_rms_percent", &CalibrateOptions::max_rms_percent,
          "vertex RMS limit, % of the bounding-box diagonal")
      .rw("max_msdm", &CalibrateOptions::max_msdm, "MSDM limit (Lavoue et al. 2006)")
      .rw("min_strength", &CalibrateOptions::min_strength, "smallest alpha searched")
      .rw("max_strength", &CalibrateOptions::max_strength, "largest alpha searched (< 1/2)")
      .rw("initial_strength", &CalibrateOptions::initial_strength,
          "first alpha tried (clamped to the range)")
      .rw("precision", &CalibrateOptions::precision,
          "stop when alpha is known to this ratio, or the distortion is this close to a limit")
      .rw("iterations", &CalibrateOptions::iterations, "embeddings at most after the first two")
      .rw("steer", &CalibrateOptions::steer,
          "on meshes of 16,384 vertices or more, search on MSDM estimated from every k-th "
          "vertex's window and measure in full only where that search ends (False: every "
          "trial measured in full)")
      .rw_property(
          "bin_offset", [](CalibrateOptions& x) { return x.bin_offset; },
          [](CalibrateOptions& x, py::handle v) {
            x.bin_offset = to_enum<BinOffsetRule>(v, "bin_offset");
          },
          "BinOffsetRule, or its name ('at-most-strength', 'fixed')")
      .rw("strengths", &CalibrateOptions::strengths,
          "None, or a callable alpha -> per-bit strengths (nb floats, bin order) for marks "
          "whose bits have their own strengths; None: the embedding's strengths scaled by "
          "alpha / strength, or uniform")
      .done(true);
  py::class_<CalibrateResult> r(m, "CalibrateResult",
                                "What calibrate found (C++ CalibrateResult).");
  Fields<CalibrateResult>(r)
      .ro_property(
          "status", [](const CalibrateResult& x) { return calibrate_status_name(x.status); },
          "'calibrated', 'at maximum' or 'below minimum'")
      .ro_property(
          "cause", [](const CalibrateResult& x) { return calibrate_cause_name(x.cause); },
          "below minimum: 'carrier', 'infeasible', 'not converged', 'rms limit' or 'msdm "
          "limit'; else 'none'")
      .ro("strength", &CalibrateResult::strength, "the calibrated alpha (0 when below minimum)")
      .ro("bin_offset", &CalibrateResult::bin_offset, "G of that embedding (bin widths)")
      .ro("rms_percent", &CalibrateResult::rms_percent,
          "vertex RMS at that strength, % of the diagonal (below minimum: at min_strength)")
      .ro("msdm", &CalibrateResult::msdm,
          "MSDM at that strength (below minimum: 0 when the "
          "RMS already failed)")
      .ro("evaluations", &CalibrateResult::evaluations, "embeddings tried")
      .ro("measurements", &CalibrateResult::measurements, "full MSDM measurements")
      .ro("estimates", &CalibrateResult::estimates, "MSDM estimates (steer)")
      .ro("seconds", &CalibrateResult::seconds, "wall time")
      .ro("message", &CalibrateResult::message, "one line for a person")
      .ro("diagnostics", &CalibrateResult::diagnostics,
          "below minimum: the cause and the ways out, one line each")
      .array(
          "strengths", [](const CalibrateResult& x) { return vector_array(x.strengths); },
          "(nb,) float64 per-bit strengths of the embedding (empty: uniform)")
      .array(
          "embedding", [](const CalibrateResult& x) { return x.embedding; },
          "EmbedResult at strength (its V: positions within the limits)")
      .done(false);
  m.attr("PAPER_MAX_RMS_PERCENT") = kPaperMaxRmsPercent;
  m.attr("PAPER_MAX_MSDM") = kPaperMaxMsdm;
}

}  // namespace

void init_calibrate(py::module_& m) {
  bind_types(m);
  m.def(
      "calibrate",
      [](py::handle V, py::handle F, py::handle payload, py::handle bits, py::handle options,
         py::handle limits, py::handle progress, const py::kwargs& kwargs) {
        const Eigen::MatrixX3d v = to_positions(V);
        const Eigen::MatrixX3i f = to_faces(F, v.rows());
        const Payload word =
            payload.is_none()
                ? calibration_payload(checked_bits(bits.is_none() ? 64 : bits.cast<int>()), 1)
                : to_payload(payload, bits);
        const EmbedOptions eo = options.is_none() ? EmbedOptions{} : options.cast<EmbedOptions>();
        CalibrateOptions co = to_limits(limits, kwargs);
        return with_progress(progress, [&](const ProgressCallback& report) {
          co.progress = report;
          return calibrate_strength(v, f, word, eo, co);
        });
      },
      py::arg("V"), py::arg("F"), py::arg("payload") = py::none(), py::kw_only(),
      py::arg("bits") = py::none(), py::arg("options") = py::none(), py::arg("limits") = py::none(),
      py::arg("progress") = py::none(),
      "The strongest mark of payload on (V, F) whose vertex RMS and MSDM stay within the "
      "limits (C++ calibrate_strength); returns a CalibrateResult.\n\n"
      "payload: hexadecimal str or 0/1 sequence in bin order (as embed without a key); None: "
      "the calibration payload of `bits` bits (64), the one `meshmark calibrate` uses. options: "
      "the EmbedOptions to embed with (variant, method, bin_offset G, ...; the search sets "
      "strength). limits: a CalibrateOptions; further keywords set its fields "
      "(max_rms_percent=0.04, max_msdm=0.25, bin_offset='fixed', ...). progress(phase, done, "
      "total, what) is called as each strength tried is measured (the phase names it); an "
      "exception it raises (or Ctrl-C) stops the search and is raised here.");
  m.def(
      "calibrate_file",
      [](py::handle path, py::handle variant, py::handle method, int bits, double bin_offset,
         py::handle cache, double weld_tolerance, py::handle limits, py::handle progress,
         const py::kwargs& kwargs) {
        FileCalibrationOptions o;
        o.variant = to_variant(variant);
        o.method = to_enum<Method>(method, "method");
        o.bits = checked_bits(bits);
        o.bin_offset = bin_offset;
        o.limits = to_limits(limits, kwargs);
        if (o.limits.strengths)
          throw InvalidArgumentError(
              "calibrate_file calibrates a uniform mark: limits.strengths must be None");
        o.read.weld_tolerance = weld_tolerance;
        o.cache = cache.is_none() ? "" : to_path(cache);
        const std::string file = to_path(path);
        const FileCalibration c = with_progress(progress, [&](const ProgressCallback& report) {
          o.limits.progress = report;
          return calibrate_file(file, o);
        });
        if (!c.warning.empty() && PyErr_WarnEx(PyExc_UserWarning, c.warning.c_str(), 1) != 0)
          throw py::error_already_set();
        py::object out = json_object(file_calibration_to_json(c));
        out["cached"] = c.cached;
        out["cache"] = o.cache;
        return out;
      },
      py::arg("path"), py::kw_only(), py::arg("variant") = "DRS", py::arg("method") = Method::Qp,
      py::arg("bits") = 64, py::arg("bin_offset") = 0.05, py::arg("cache") = py::none(),
      py::arg("weld_tolerance") = 0.0, py::arg("limits") = py::none(),
      py::arg("progress") = py::none(),
      "The calibration of a mesh file as the CLI's `meshmark calibrate --json` prints it (a "
      "dict: status, strength, bin_offset, rms_percent, msdm, cause, diagnostics, evaluations, "
      "seconds, key, cached, cache, ...), with the same defaults. cache: a JSON-lines file read "
      "first and appended to (None: no cache, unlike the CLI; default_calibration_cache() is "
      "the CLI's). limits, progress and keywords: as calibrate's.");
  m.def("default_calibration_cache", &default_calibration_cache,
        "The CLI's cache: $XDG_CACHE_HOME/meshmark/calibration.jsonl, else "
        "~/.cache/meshmark/calibration.jsonl.");
}

}  // namespace meshmark::python
