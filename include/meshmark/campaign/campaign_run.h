#pragma once
/// \file campaign_run.h
/// Running a whole campaign (campaign.h) into a results directory, resumably, on several
/// threads and, through rank hooks, on several processes.
///
/// The directory holds campaign.json (the campaign file's text: a directory is refused for
/// another campaign), calibration.jsonl and rows.jsonl, journals appended one whole line per
/// write, which a later run reads to skip what is done: a run that was killed resumes where it
/// stopped, a last line cut by the kill dropped (and reported). Process r of n calibrates every
/// n-th (model, variant, protocol) and runs every n-th unit from the r-th; when all are done,
/// process 0 rewrites rows.jsonl with one row per trial in canonical order and writes rows.csv,
/// wall_seconds.txt (the wall time of every run of the campaign) and the report
/// (write_campaign_report).

#include <functional>
#include <string>
#include <vector>

#include "meshmark/campaign/campaign.h"
#include "meshmark/core/enum_names.h"
#include "meshmark/core/progress.h"

namespace meshmark {

/// The processes of a distributed run (an MPI job, for instance); the defaults are one process.
struct CampaignRanks {
  int rank = 0;  ///< this process, in [0, size)
  int size = 1;  ///< number of processes
  /// Returns when every process has called it (empty: nothing to wait for).
  std::function<void()> barrier;
  /// Whether every process passed true (empty: the value passed).
  std::function<bool(bool)> all;
};

/// Options of run_campaign.
struct CampaignRunOptions {
  std::string out_dir;  ///< results directory; empty: bench-results/NAME
  int jobs = 0;         ///< threads of this process (nested work included); 0: every core
  bool fresh = false;   ///< discard what the directory holds and start over
  /// Called as work is done (progress.h): phase ("calibrating", then "trials"), units done
  /// and to do in this phase on this process, and what was just done.
  ProgressCallback progress;
  /// Called with a warning about an input (a model file's notes).
  std::function<void(const std::string& message)> warn;
  CampaignRanks ranks;
};

/// What run_campaign did.
struct CampaignRunResult {
  /// Complete: every trial has a row (rows and the report are written on process 0; the other
  /// processes return Complete with only their own counts). Refused: another process could not
  /// prepare the directory (process 0 throws the reason instead).
  enum class Status { Complete, Refused };  // names: EnumTable below
  Status status = Status::Complete;
  std::string out_dir;
  int jobs = 1;                   ///< threads this process used
  long calibrations_run = 0;      ///< calibrated by this process in this run
  long calibrations_resumed = 0;  ///< found in calibration.jsonl at the start (all processes')
  long trials_run = 0;            ///< trials this process ran in this run
  long trials_resumed = 0;        ///< rows found in rows.jsonl at the start (all processes')
  int dropped_lines = 0;          ///< cut last lines dropped from the journals
  std::vector<std::string> diagnostics;         ///< one line per repair or unreadable journal line
  std::vector<TrialRow> rows;                   ///< process 0: every trial, in canonical order
  std::vector<CalibrationRecord> calibrations;  ///< process 0: every (model, variant, protocol)
  double wall_seconds = 0;                      ///< this run
  double total_wall_seconds = 0;                ///< every run of the campaign in this directory
  std::string rows_csv, summary_csv, report;    ///< process 0: the files' paths
};

/// The names of CampaignRunResult::Status's values: "complete", "refused".
template <>
struct EnumTable<CampaignRunResult::Status> {
  static constexpr const char* what = "campaign status";
  static constexpr NamedValue<CampaignRunResult::Status> values[] = {
      {CampaignRunResult::Status::Complete, "complete"},
      {CampaignRunResult::Status::Refused, "refused"}};
};

/// Runs (or resumes) the campaign into options.out_dir. \throw InvalidArgumentError when the
/// directory holds another campaign's results (process 0); IOError when a file cannot be
/// written; InvalidInputError when a model cannot be read; Error when a trial is missing at the
/// end (a bug).
CampaignRunResult run_campaign(const CampaignConfig& config, const CampaignRunOptions& options);

}  // namespace meshmark
