// meshmark bench CONFIG [--out DIR] [--jobs N] [--fresh]
//
// Runs a campaign (the library's run_campaign, campaign_run.h: journals, resume, merge,
// report) on every core, and over several processes under mpirun: this file parses the
// options, provides the rank hooks (OpenMPI, opened at run time), draws the progress and prints
// the summary.

#include <fmt/format.h>
#include <unistd.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <memory>
#include <thread>

#ifdef MESHMARK_HAVE_MPI
#include <dlfcn.h>
#define OMPI_SKIP_MPICXX 1  // the C API only
#include <mpi.h>
#endif

#include "cli.h"
#include "meshmark/campaign/campaign.h"
#include "meshmark/campaign/campaign_run.h"
#include "meshmark/core/error.h"
#include "progress.h"

namespace meshmark::cli {

namespace {

struct BenchArgs {
  std::string config, out;
  int jobs = 0;
  bool fresh = false, json = false;
};

#ifdef MESHMARK_HAVE_MPI
// OpenMPI, loaded at run time. Debian's sequential MUMPS (under Ipopt) brings libmpiseq, whose
// stub MPI_Init would win over OpenMPI's if both were linked; so libmpi is opened with
// RTLD_DEEPBIND (its own references bind to itself) and every entry point is looked up in it.
class Mpi {
 public:
  Mpi() {
    handle_ = dlopen("libmpi.so.40", RTLD_NOW | RTLD_GLOBAL | RTLD_DEEPBIND);
    if (!handle_)
      throw Error(
          fmt::format("mpirun started meshmark, but OpenMPI cannot be loaded: {}", dlerror()));
    init_ = sym<int (*)(int*, char***)>("MPI_Init");
    rank_ = sym<int (*)(MPI_Comm, int*)>("MPI_Comm_rank");
    size_ = sym<int (*)(MPI_Comm, int*)>("MPI_Comm_size");
    barrier_ = sym<int (*)(MPI_Comm)>("MPI_Barrier");
    allreduce_ =
        sym<int (*)(const void*, void*, int, MPI_Datatype, MPI_Op, MPI_Comm)>("MPI_Allreduce");
    finalize_ = sym<int (*)()>("MPI_Finalize");
    world_ = reinterpret_cast<MPI_Comm>(sym<void*>("ompi_mpi_comm_world"));
    int_ = reinterpret_cast<MPI_Datatype>(sym<void*>("ompi_mpi_int"));
    min_ = reinterpret_cast<MPI_Op>(sym<void*>("ompi_mpi_op_min"));
    if (init_(nullptr, nullptr) != 0) throw Error("MPI_Init failed");
  }
  ~Mpi() { finalize_(); }
  int rank() const {
    int r = 0;
    rank_(world_, &r);
    return r;
  }
  int size() const {
    int n = 1;
    size_(world_, &n);
    return n;
  }
  void barrier() const { barrier_(world_); }
  int min(int value) const {
    int out = 0;
    allreduce_(&value, &out, 1, int_, min_, world_);
    return out;
  }

 private:
  template <class T>
  T sym(const char* name) {
    void* p = dlsym(handle_, name);
    if (!p) throw Error(fmt::format("OpenMPI has no symbol {}", name));
    return reinterpret_cast<T>(p);
  }
  void* handle_ = nullptr;
  int (*init_)(int*, char***) = nullptr;
  int (*rank_)(MPI_Comm, int*) = nullptr;
  int (*size_)(MPI_Comm, int*) = nullptr;
  int (*barrier_)(MPI_Comm) = nullptr;
  int (*allreduce_)(const void*, void*, int, MPI_Datatype, MPI_Op, MPI_Comm) = nullptr;
  int (*finalize_)() = nullptr;
  MPI_Comm world_{};
  MPI_Datatype int_{};
  MPI_Op min_{};
};
#endif

// The processes of the run: one, or the ranks of an MPI job (started by mpirun), as the
// library's rank hooks.
class World {
 public:
  World() {
#ifdef MESHMARK_HAVE_MPI
    if (std::getenv("OMPI_COMM_WORLD_SIZE")) mpi_ = std::make_unique<Mpi>();
#endif
  }
  CampaignRanks ranks() const {
    CampaignRanks r;
#ifdef MESHMARK_HAVE_MPI
    if (!mpi_) return r;
    r.rank = mpi_->rank();
    r.size = mpi_->size();
    r.barrier = [this] { mpi_->barrier(); };
    r.all = [this](bool ok) { return mpi_->min(ok ? 1 : 0) != 0; };  // a failed rank stops all
#endif
    return r;
  }

 private:
#ifdef MESHMARK_HAVE_MPI
  std::unique_ptr<Mpi> mpi_;
#endif
};

// The run's summary on stdout: the files, and the medians (the outcomes in trace mode).
void print_summary(const CampaignConfig& config, const CampaignRunResult& r, int processes) {
  fmt::print(
      "campaign {}: {} trials ({} run now on {} process(es) x {} threads) in {:.1f} s ({:.1f} s "
      "over all runs)\n",
      config.name, r.rows.size(), r.trials_run, processes, r.jobs, r.wall_seconds,
      r.total_wall_seconds);
  fmt::print("rows     {}\nsummary  {}\nreport   {}\n", r.rows_csv, r.summary_csv, r.report);
  if (config.trace) {
    for (const TraceSummaryRow& s : summarize_trace(config, r.rows))
      fmt::print("  {:<34} trace right/none/wrong {}/{}/{}{}, blind {}/{}/{}\n",
                 trace_attack_label(s.attack, s.attack_strength, s.coalition), s.trace_right,
                 s.trace_none, s.trace_wrong,
                 s.colluders > 1 ? fmt::format(" (every colluder {})", s.trace_all) : "",
                 s.blind_right, s.blind_none, s.blind_wrong);
    return;
  }
  for (const SummaryRow& s : summarize(config, r.rows))
    if (s.attack != "none")
      fmt::print("  {}{} {:<12} {:<8g} median BER {:.3f} ({} trials)\n", s.variant,
                 s.protocol.empty() ? "" : " " + s.protocol, s.attack, s.attack_strength,
                 s.median_ber, s.trials);
}

// The summary as one JSON object (--json): the files and the summary rows.
void print_summary_json(const CampaignConfig& config, const CampaignRunResult& r, int processes) {
  nlohmann::json j = {{"campaign", config.name},
                      {"trials", r.rows.size()},
                      {"trials_run", r.trials_run},
                      {"processes", processes},
                      {"threads", r.jobs},
                      {"seconds", r.wall_seconds},
                      {"seconds_over_all_runs", r.total_wall_seconds},
                      {"rows", r.rows_csv},
                      {"summary", r.summary_csv},
                      {"report", r.report}};
  nlohmann::json rows = nlohmann::json::array();
  if (config.trace) {
    for (const TraceSummaryRow& s : summarize_trace(config, r.rows))
      rows.push_back(
          {{"attack", s.attack},
           {"attack_strength", s.attack_strength},
           {"colluders", s.colluders},
           {"coalition", s.coalition},
           {"every_leaker_named", s.trace_all},
           {"trials", s.trials},
           {"trace", {{"right", s.trace_right}, {"none", s.trace_none}, {"wrong", s.trace_wrong}}},
           {"blind", {{"right", s.blind_right}, {"none", s.blind_none}, {"wrong", s.blind_wrong}}},
           {"worst_right_p", s.worst_right_p},
           {"median_trace_seconds", s.median_trace_seconds}});
  } else {
    for (const SummaryRow& s : summarize(config, r.rows))
      rows.push_back({{"protocol", s.protocol},
                      {"variant", s.variant},
                      {"attack", s.attack},
                      {"attack_strength", s.attack_strength},
                      {"median_ber", s.median_ber},
                      {"mean_ber", s.mean_ber},
                      {"trials", s.trials},
                      {"excluded", s.excluded}});
  }
  j["medians"] = rows;
  fmt::print("{}\n", j.dump(2));
}

int run(const BenchArgs& a) {
  World world;
  const CampaignConfig config = load_campaign(a.config);  // ReadError: exit 2
  CampaignRunOptions options;
  options.ranks = world.ranks();
  options.out_dir = a.out;
  options.fresh = a.fresh;
  int local = 1;  // ranks on this machine share its cores
  if (const char* s = std::getenv("OMPI_COMM_WORLD_LOCAL_SIZE")) local = std::max(1, std::atoi(s));
  options.jobs = a.jobs > 0
                     ? a.jobs
                     : std::max(1, static_cast<int>(std::thread::hardware_concurrency()) / local);
  // On a terminal rank 0 draws a bar and the other ranks stay quiet; otherwise log lines.
  const int rank = options.ranks.rank, size = options.ranks.size;
  Progress progress(!isatty(STDERR_FILENO) ? Progress::Lines
                    : rank == 0            ? Progress::Bar
                                           : Progress::Quiet,
                    size > 1 ? fmt::format("[rank {}] ", rank) : "");
  options.progress = [&](const std::string& phase, long done, long total, const std::string& note) {
    progress.report(phase, done, total, note);
  };
  options.warn = [](const std::string& m) { fmt::print(stderr, "warning: {}\n", printable(m)); };
  const CampaignRunResult r = run_campaign(config, options);
  progress.finish();
  for (const std::string& d : r.diagnostics) fmt::print(stderr, "note: {}\n", printable(d));
  if (r.status == CampaignRunResult::Status::Refused) return kUsage;
  if (rank == 0) a.json ? print_summary_json(config, r, size) : print_summary(config, r, size);
  return kOk;
}

}  // namespace

void register_bench(CLI::App& app, int& exit_code) {
  auto args = std::make_shared<BenchArgs>();
  CLI::App* sub = app.add_subcommand(
      "bench",
      "Run a benchmark campaign (models x variants x payloads x attacks); resumable; "
      "under mpirun -np N, distributed");
  sub->add_option("CONFIG", args->config, "campaign file (JSON), e.g. bench/campaigns/quick.json")
      ->required();
  sub->add_option("--out", args->out, "results directory (default bench-results/NAME)");
  sub->add_option("--jobs", args->jobs, "threads per process (default: cores / local ranks)")
      ->check(CLI::Range(1, 1024));
  sub->add_flag("--fresh", args->fresh, "discard earlier results in the directory and start over");
  sub->add_flag("--json", args->json,
                "print the summary as JSON (the files, and the medians or the trace outcomes)");
  sub->callback([args, &exit_code] { exit_code = run(*args); });
}

}  // namespace meshmark::cli
