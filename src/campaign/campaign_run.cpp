// Running a whole campaign: the results directory prepared (process 0), the calibrations and
// the units not yet in the journals run on this process's threads, then (process 0) the
// journal merged in canonical order, the CSV and the report written.

#include "meshmark/campaign/campaign_run.h"

#include <fmt/format.h>

#include <chrono>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <set>

#include "campaign/campaign_journal.h"
#include "campaign/campaign_parts.h"
#include "core/parallel.h"
#include "core/progress_counter.h"
#include "meshmark/core/error.h"
#include "meshmark/forensics/fingerprint.h"
#include "meshmark/forensics/trace.h"
#include "meshmark/io/io.h"

namespace meshmark {

namespace fs = std::filesystem;
using detail::Journal;
using detail::journal_lines;

namespace {

using Clock = std::chrono::steady_clock;

// The files of a results directory.
struct Paths {
  fs::path dir;
  std::string rows, calibrations, stamp, wall, format;
  explicit Paths(const fs::path& d)
      : dir(d),
        rows((d / "rows.jsonl").string()),
        calibrations((d / "calibration.jsonl").string()),
        stamp((d / "campaign.json").string()),
        wall((d / "wall_seconds.txt").string()),
        format((d / "mark_format.txt").string()) {}
};

// Models, each read once per process on first use.
class ModelCache {
 public:
  ModelCache(const CampaignConfig& c, const std::function<void(const std::string&)>& warn)
      : config_(c),
        warn_(warn),
        meshes_(c.models.size()),
        flags_(new std::once_flag[c.models.size()]) {}
  const Mesh& get(int m) {
    std::call_once(flags_[m], [&] {
      const std::string& path = config_.models[m].path;
      Mesh mesh;
      try {
        mesh = read_mesh(path);
      } catch (const IOError& e) {
        throw InvalidInputError(path, 0, e.what());  // a model that cannot be read is bad input
      }
      if (warn_)
        for (const std::string& note : mesh.notes) warn_(fmt::format("{}: {}", path, note));
      meshes_[m] = std::make_shared<const Mesh>(std::move(mesh));
    });
    return *meshes_[m];
  }

 private:
  const CampaignConfig& config_;
  const std::function<void(const std::string&)>& warn_;
  std::vector<std::shared_ptr<const Mesh>> meshes_;
  std::unique_ptr<std::once_flag[]> flags_;
};

// Progress reports, one at a time, counted per phase.
class Progress : public detail::ProgressCounter {
 public:
  Progress(const CampaignRunOptions& o, std::string phase, long total)
      : ProgressCounter(o.progress, std::move(phase), total) {}
};

// Process 0: a fresh start, or a check that the directory holds this campaign; cut last lines
// of the journals dropped.
void prepare_directory(const CampaignConfig& config, const CampaignRunOptions& o, const Paths& p,
                       CampaignRunResult& result) {
  const std::string stamp = read_file(config.source);
  if (o.fresh) fs::remove_all(p.dir);
  fs::create_directories(p.dir);
  if (fs::exists(p.stamp) && read_file(p.stamp) != stamp)
    throw InvalidArgumentError(fmt::format(
        "{} holds the results of another campaign file: use --fresh to start over, or --out "
        "elsewhere",
        p.dir.string()));
  if (!fs::exists(p.stamp)) write_file_atomically(p.stamp, stamp);
  // Copies with the fingerprint are issued in this build's mark format, with its field's RMS
  // (fingerprint_rms), and read by its version of trace's reading: rows of another (a directory
  // without the file holds rows of format 4, or none; one naming no reading, rows of reading 1;
  // one naming no raise, rows at 0.01 % on every original) are not resumed beside them.
  if (config.trace && config.fingerprint) {
    const std::string format =
        fmt::format("mark format {}, fingerprint reading {}, raised below {} vertices\n",
                    kFingerprintMarkFormat, kFingerprintReading, kFingerprintFullVertices);
    const bool rows = fs::exists(p.rows) && fs::file_size(p.rows) > 0;
    const std::string held = fs::exists(p.format) ? read_file(p.format)
                             : rows               ? "mark format 4\n"
                                                  : format;
    if (held != format)
      throw InvalidArgumentError(fmt::format(
          "{} holds rows of copies issued and traced as {}, where this build has {}: use "
          "--fresh to start over, or --out elsewhere",
          p.dir.string(), held.substr(0, held.find('\n')), format.substr(0, format.find('\n'))));
    if (!fs::exists(p.format)) write_file_atomically(p.format, format);
  }
  for (const std::string& journal : {p.calibrations, p.rows})
    if (const std::size_t cut = detail::repair_journal(journal)) {
      ++result.dropped_lines;
      result.diagnostics.push_back(
          fmt::format("{}: dropped a last line cut short ({} bytes)", journal, cut));
    }
}

std::string calibration_name(const std::string& model, const std::string& variant,
                             const std::string& protocol) {
  return model + "|" + variant + "|" + protocol;
}

// The calibrations in the journal, by model|variant|protocol (unreadable lines skipped).
std::map<std::string, CalibrationRecord> read_calibrations(const std::string& path) {
  std::map<std::string, CalibrationRecord> out;
  for (const std::string& line : journal_lines(path)) {
    try {
      const CalibrationRecord r = calibration_from_json(line);
      out.emplace(calibration_name(r.model, r.variant, r.protocol), r);
    } catch (const InvalidInputError&) {
    }
  }
  return out;
}

// Calibrations not yet in the journal, every size-th (model, variant, protocol) on this process.
void calibrate_missing(const CampaignConfig& config, const CampaignRunOptions& o, const Paths& p,
                       ModelCache& models, CampaignRunResult& result) {
  const auto known = read_calibrations(p.calibrations);
  result.calibrations_resumed = static_cast<long>(known.size());
  const int nv = static_cast<int>(config.variants.size());
  const int np = static_cast<int>(config.protocols.size());
  const int pairs = static_cast<int>(config.models.size()) * nv * np;
  std::vector<int> mine;  // calibration i: model i / (nv np), variant i / np % nv, protocol i % np
  for (int i = 0; i < pairs; ++i)
    if (i % o.ranks.size == o.ranks.rank &&
        !known.count(calibration_name(config.models[i / (nv * np)].name,
                                      config.variants[i / np % nv], config.protocols[i % np].name)))
      mine.push_back(i);
  if (mine.empty()) return;
  Journal journal(p.calibrations);
  Progress progress(o, "calibrating", static_cast<long>(mine.size()));
  detail::parallel_for(static_cast<std::int64_t>(mine.size()), 0, [&](std::int64_t k) {
    const int i = mine[k], m = i / (nv * np);
    const CalibrationRecord r =
        calibrate_for_campaign(config, m, i / np % nv, models.get(m), i % np);
    journal.append(calibration_to_json(r));
    progress.step(1, fmt::format("{} {}{}: alpha {:.4f}, {}", r.model, r.variant,
                                 r.protocol.empty() ? "" : " " + r.protocol, r.strength, r.status));
  });
  result.calibrations_run = static_cast<long>(mine.size());
}

// The keys of the rows in the journal (unreadable lines skipped).
std::set<std::string> done_keys(const std::string& path) {
  std::set<std::string> done;
  for (const std::string& line : journal_lines(path)) {
    try {
      done.insert(row_from_json(line).key);
    } catch (const InvalidInputError&) {
    }
  }
  return done;
}

// Units with trials not yet in the journal, every size-th on this process.
void run_missing(const CampaignConfig& config, const CampaignRunOptions& o, const Paths& p,
                 ModelCache& models, CampaignRunResult& result) {
  const auto calibrations = read_calibrations(p.calibrations);
  const std::set<std::string> done = done_keys(p.rows);
  result.trials_resumed = static_cast<long>(done.size());
  const std::vector<CampaignUnit> units = campaign_units(config);
  std::vector<int> mine;
  long todo = 0;
  for (int i = 0; i < static_cast<int>(units.size()); ++i) {
    if (i % o.ranks.size != o.ranks.rank) continue;
    long missing = 0;
    for (const std::string& key : unit_trial_keys(config, units[i])) missing += !done.count(key);
    if (missing > 0) mine.push_back(i), todo += missing;
  }
  Journal journal(p.rows);
  Progress progress(o, "trials", todo);
  detail::parallel_for(static_cast<std::int64_t>(mine.size()), 0, [&](std::int64_t k) {
    const CampaignUnit& u = units[mine[k]];
    const std::string key = calibration_name(
        config.models[u.model].name, config.variants[u.variant], config.protocols[u.protocol].name);
    const auto it = calibrations.find(key);
    if (it == calibrations.end()) throw Error(fmt::format("no calibration for {} (a bug)", key));
    long n = 0;
    run_campaign_unit(
        config, u, models.get(u.model), it->second,
        [&](const std::string& trial) { return done.count(trial) > 0; },
        [&](const TrialRow& row) {
          journal.append(row_to_json(row));
          ++n;
        });
    progress.step(n, fmt::format("{} {} payload {}", config.models[u.model].name,
                                 config.variants[u.variant], u.payload));
  });
  result.trials_run = todo;
}

// Process 0: one row per trial in canonical order, from the journal. \throw Error naming the
// first missing trial (a bug).
std::vector<TrialRow> merge_rows(const CampaignConfig& config, const Paths& p,
                                 CampaignRunResult& result) {
  std::map<std::string, TrialRow> by_key;
  int unreadable = 0;
  for (const std::string& line : journal_lines(p.rows)) {
    try {
      TrialRow r = row_from_json(line);
      by_key.emplace(r.key, std::move(r));
    } catch (const InvalidInputError& e) {
      if (unreadable++ == 0)
        result.diagnostics.push_back(fmt::format("{}: unreadable line skipped: {} ({})", p.rows,
                                                 line.substr(0, 200), e.what()));
    }
  }
  std::vector<TrialRow> rows;
  std::vector<std::string> missing;
  for (const CampaignUnit& u : campaign_units(config))
    for (const std::string& key : unit_trial_keys(config, u)) {
      auto it = by_key.find(key);
      if (it == by_key.end())
        missing.push_back(key);
      else
        rows.push_back(it->second);
    }
  if (!missing.empty())
    throw Error(fmt::format("{} trials missing after the run, first {} (a bug){}", missing.size(),
                            missing.front(),
                            unreadable ? fmt::format("; {} journal lines unreadable, first: {}",
                                                     unreadable, result.diagnostics.back())
                                       : ""));
  return rows;
}

// Process 0: the journal rewritten, rows.csv, the wall times and the report.
void write_results(const CampaignConfig& config, const Paths& p, CampaignRunResult& result) {
  std::string jsonl, csv = csv_header(config.trace) + "\n";
  for (const TrialRow& r : result.rows)
    jsonl += row_to_json(r) + "\n", csv += row_to_csv(r, config.trace) + "\n";
  write_file_atomically(p.rows, jsonl);
  result.rows_csv = (p.dir / "rows.csv").string();
  write_file_atomically(result.rows_csv, csv);
  for (const auto& [name, r] : read_calibrations(p.calibrations)) result.calibrations.push_back(r);
  result.total_wall_seconds = result.wall_seconds;
  if (fs::exists(p.wall)) {
    try {
      result.total_wall_seconds += std::stod(read_file(p.wall));
    } catch (const std::exception&) {
    }
  }
  write_file_atomically(p.wall, fmt::format("{}\n", result.total_wall_seconds));
  result.summary_csv = (p.dir / "summary.csv").string();
  result.report = write_campaign_report(p.dir.string(), config, result.calibrations, result.rows,
                                        result.total_wall_seconds);
}

}  // namespace

CampaignRunResult run_campaign(const CampaignConfig& config, const CampaignRunOptions& o) {
  // What load_campaign checks in a file, checked again for a config built in code: a coalition
  // takes its colluders among the copies issued.
  if (config.trace)
    for (const CampaignCoalition& k : config.coalitions)
      if (k.size < 2 || k.size > 64 || k.size > config.copies)
        throw InvalidArgumentError(
            fmt::format("the coalition \"{}\" needs 2 to 64 colluders among the {} copies issued",
                        coalition_name(k), config.copies));
  const auto start = Clock::now();
  const detail::ThreadBudgetScope budget(o.jobs);
  auto barrier = [&] {
    if (o.ranks.barrier) o.ranks.barrier();
  };
  auto all = [&](bool ok) { return o.ranks.all ? o.ranks.all(ok) : ok; };
  CampaignRunResult result;
  result.jobs = detail::thread_budget();
  const Paths p(o.out_dir.empty() ? fs::path("bench-results") / config.name : fs::path(o.out_dir));
  result.out_dir = p.dir.string();

  // Stage 1 (process 0): the directory. A failure stops every process.
  std::exception_ptr problem;
  if (o.ranks.rank == 0) try {
      try {
        prepare_directory(config, o, p, result);
      } catch (const fs::filesystem_error& e) {
        throw IOError(e.what());
      }
    } catch (...) {
      problem = std::current_exception();
    }
  if (!all(!problem)) {
    if (problem) std::rethrow_exception(problem);
    result.status = CampaignRunResult::Status::Refused;
    return result;
  }

  // Stages 2 and 3: calibrations, then trials, what is missing, on every process.
  ModelCache models(config, o.warn);
  calibrate_missing(config, o, p, models, result);
  barrier();
  run_missing(config, o, p, models, result);
  barrier();
  if (o.ranks.rank != 0) return result;

  // Stage 4 (process 0): merge and write.
  result.rows = merge_rows(config, p, result);
  result.wall_seconds = std::chrono::duration<double>(Clock::now() - start).count();
  write_results(config, p, result);
  return result;
}

}  // namespace meshmark
