// Campaigns: run_campaign (campaign_run.h, the CLI's bench) on a campaign file or a dict of the
// same keys, the GIL released while it runs and taken back for Python's callbacks.

#include <fmt/format.h>

#include <exception>
#include <filesystem>
#include <mutex>

#include "bindings.h"
#include "meshmark/campaign/campaign.h"
#include "meshmark/campaign/campaign_run.h"
#include "meshmark/core/error.h"
#include "meshmark/io/io.h"

namespace meshmark::python {

namespace {

namespace fs = std::filesystem;

// Python's progress and warning callbacks, called from the library's worker threads.
class Callbacks {
 public:
  Callbacks(py::handle progress, py::handle warn)
      : gate_(progress), warn_(py::reinterpret_borrow<py::object>(warn)) {}

  /// The library's hooks, calling the Python callables under the GIL.
  void install(CampaignRunOptions& o) {
    o.progress = gate_.progress();
    o.warn = [this](const std::string& message) {
      gate_.call([&] {
        if (!warn_.is_none())
          warn_(message);
        else if (PyErr_WarnEx(PyExc_UserWarning, message.c_str(), 1) != 0)
          throw py::error_already_set();
      });
    };
  }

  /// Raises what a callback raised, if one did (with the GIL held).
  void rethrow() { gate_.rethrow(); }

 private:
  CallbackGate gate_;
  py::object warn_;
};

// A dict's model paths made absolute (relative ones: to the current directory), "${...}"
// paths left to the library.
void absolute_models(const py::dict& config) {
  if (!config.contains("models") || !py::isinstance<py::list>(config["models"])) return;
  const py::module_ os = py::module_::import("os");
  auto absolute = [&](py::handle path) -> py::object {
    if (!py::isinstance<py::str>(path) && !py::hasattr(path, "__fspath__"))
      return py::reinterpret_borrow<py::object>(path);
    const std::string p = to_path(path);
    if (p.find("${") != std::string::npos) return py::str(p);
    return os.attr("path").attr("abspath")(p);
  };
  py::list models = config["models"];
  for (std::size_t i = 0; i < models.size(); ++i) {
    if (py::isinstance<py::dict>(models[i])) {
      py::dict model = py::dict(models[i]);
      if (model.contains("path")) model["path"] = absolute(model["path"]);
      models[i] = model;
    } else {
      models[i] = absolute(models[i]);
    }
  }
}

// The campaign of a dict: written as out_dir/campaign.json (the file a results directory keeps,
// keys sorted, so the same campaign in another key order is the same file) once it reads as a
// campaign; its errors name "config". \throw InvalidArgumentError when the
// directory holds another campaign (unless fresh).
CampaignConfig dict_campaign(const py::dict& config, const std::string& out_dir, bool fresh) {
  py::dict copy = py::module_::import("copy").attr("deepcopy")(config);
  absolute_models(copy);
  const std::string text =
      py::module_::import("json")
          .attr("dumps")(copy, py::arg("indent") = 2, py::arg("sort_keys") = true)
          .cast<std::string>() +
      "\n";
  const fs::path dir(out_dir), stamp = dir / "campaign.json";
  if (!fresh && fs::exists(stamp) && read_file(stamp.string()) != text)
    throw InvalidArgumentError(fmt::format(
        "{} holds the results of another campaign: pass fresh=True to start over, or another "
        "out_dir",
        out_dir));
  const py::object scratch = py::module_::import("tempfile").attr("TemporaryDirectory")();
  const std::string checked = (fs::path(to_path(scratch.attr("name"))) / "campaign.json").string();
  write_file_atomically(checked, text);
  try {
    (void)load_campaign(checked);
  } catch (const InvalidInputError& e) {
    scratch.attr("cleanup")();
    throw InvalidInputError("config", 0, e.detail());
  }
  scratch.attr("cleanup")();
  fs::create_directories(dir);
  write_file_atomically(stamp.string(), text);
  return load_campaign(stamp.string());
}

py::dict result_dict(const CampaignRunResult& r) {
  py::dict out;
  out["status"] = enum_name(r.status);
  out["out_dir"] = r.out_dir;
  out["jobs"] = r.jobs;
  out["calibrations_run"] = r.calibrations_run;
  out["calibrations_resumed"] = r.calibrations_resumed;
  out["trials_run"] = r.trials_run;
  out["trials_resumed"] = r.trials_resumed;
  out["dropped_lines"] = r.dropped_lines;
  out["diagnostics"] = r.diagnostics;
  py::list rows, calibrations;
  for (const TrialRow& row : r.rows) rows.append(json_object(row_to_json(row)));
  for (const CalibrationRecord& c : r.calibrations)
    calibrations.append(json_object(calibration_to_json(c)));
  out["rows"] = rows;
  out["calibrations"] = calibrations;
  out["wall_seconds"] = r.wall_seconds;
  out["total_wall_seconds"] = r.total_wall_seconds;
  out["rows_jsonl"] = r.rows_csv.empty() ? "" : (fs::path(r.out_dir) / "rows.jsonl").string();
  out["rows_csv"] = r.rows_csv;
  out["summary_csv"] = r.summary_csv;
  out["report"] = r.report;
  return out;
}

}  // namespace

void init_campaign(py::module_& m) {
  m.def(
      "run_campaign",
      [](py::handle config, py::handle out_dir, int jobs, bool fresh, py::handle progress,
         py::handle warn) {
        CampaignRunOptions o;
        o.out_dir = to_path(out_dir);
        o.jobs = jobs;
        o.fresh = fresh;
        const CampaignConfig c =
            py::isinstance<py::dict>(config)
                ? dict_campaign(py::reinterpret_borrow<py::dict>(config), o.out_dir, fresh)
                : load_campaign(to_path(config));
        Callbacks callbacks(progress, warn);
        callbacks.install(o);
        CampaignRunResult r;
        try {
          py::gil_scoped_release unlocked;
          r = run_campaign(c, o);
        } catch (const CallbackRaised&) {
          callbacks.rethrow();
          throw;
        }
        callbacks.rethrow();  // a callback raised where the library went on
        return result_dict(r);
      },
      py::arg("config"), py::arg("out_dir"), py::kw_only(), py::arg("jobs") = 0,
      py::arg("fresh") = false, py::arg("progress") = py::none(), py::arg("warn") = py::none(),
      "Runs (or resumes) a benchmark campaign into out_dir as the CLI's `meshmark bench CONFIG "
      "--out DIR` does (campaign.json, calibration.jsonl, rows.jsonl, rows.csv, summary.csv, "
      "report.md). config: a campaign file's path, or a dict of its keys (written as "
      "out_dir/campaign.json; relative model paths are relative to the current directory). "
      "jobs: threads (0: every core); fresh: discard the directory's results first. "
      "progress(phase, done, total, what) is called as work is done (phase 'calibrating', then "
      "'trials'); an exception it raises stops the run (resumable) and is raised here. warn("
      "message): a model file's notes (default: warnings.warn). Returns a dict: status, "
      "out_dir, jobs, calibrations_run, calibrations_resumed, trials_run, trials_resumed, "
      "dropped_lines, diagnostics, rows (one dict per trial, the keys of rows.jsonl), "
      "calibrations, wall_seconds, total_wall_seconds, rows_jsonl, rows_csv, summary_csv, "
      "report. Raises InvalidInputError naming the file (or 'config') and the bad key.");
}

}  // namespace meshmark::python
