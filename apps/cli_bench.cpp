// meshmark bench CONFIG [--out DIR] [--jobs N] [--fresh]
//
// Runs a campaign on every core, and over several processes under mpirun (each rank takes every
// size-th calibration and unit). Rows are appended, one whole line per write, to a journal
// (rows.jsonl) that a restarted campaign reads to skip what is done; a line cut by a kill is
// dropped. At the end rank 0 rewrites the journal in canonical order, writes rows.csv, the
// summary, the figures and the report.

#include <fcntl.h>
#include <fmt/format.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <thread>

#ifdef MESHMARK_HAVE_MPI
#include <dlfcn.h>
#define OMPI_SKIP_MPICXX 1  // the C API only
#include <mpi.h>
#endif

#include "cli.h"
#include "meshmark/campaign.h"
#include "meshmark/error.h"
#include "meshmark/io.h"
#include "meshmark/key.h"

namespace meshmark::cli {

namespace fs = std::filesystem;

namespace {

using Clock = std::chrono::steady_clock;

struct BenchArgs {
  std::string config, out;
  int jobs = 0;
  bool fresh = false;
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

// The processes of the run: one, or the ranks of an MPI job (started by mpirun).
class World {
 public:
  World() {
#ifdef MESHMARK_HAVE_MPI
    if (std::getenv("OMPI_COMM_WORLD_SIZE")) {
      mpi_ = std::make_unique<Mpi>();
      rank_ = mpi_->rank();
      size_ = mpi_->size();
    }
#endif
  }
  int rank() const {
    return rank_;
  }
  int size() const {
    return size_;
  }
  void barrier() const {
#ifdef MESHMARK_HAVE_MPI
    if (mpi_) mpi_->barrier();
#endif
  }
  // Whether every rank says ok (a failed rank makes all stop).
  bool all(bool ok) const {
#ifdef MESHMARK_HAVE_MPI
    if (mpi_) return mpi_->min(ok ? 1 : 0) != 0;
#endif
    return ok;
  }

 private:
  int rank_ = 0, size_ = 1;
#ifdef MESHMARK_HAVE_MPI
  std::unique_ptr<Mpi> mpi_;
#endif
};

// An append-only file of JSON lines, written one whole line per write(2) (O_APPEND).
class Journal {
 public:
  explicit Journal(const std::string& path) : path_(path) {
    fd_ = ::open(path.c_str(), O_WRONLY | O_APPEND | O_CREAT | O_CLOEXEC, 0644);
    if (fd_ < 0) throw IOError(fmt::format("{}: cannot open for appending", path));
  }
  ~Journal() {
    if (fd_ >= 0) ::close(fd_);
  }
  Journal(const Journal&) = delete;
  Journal& operator=(const Journal&) = delete;
  void append(const std::string& line) {
    const std::string text = line + "\n";
    std::lock_guard<std::mutex> lock(mutex_);
    std::size_t done = 0;
    while (done < text.size()) {
      const ssize_t n = ::write(fd_, text.data() + done, text.size() - done);
      if (n < 0) throw IOError(fmt::format("{}: write failed", path_));
      done += static_cast<std::size_t>(n);
    }
  }

 private:
  std::string path_;
  int fd_ = -1;
  std::mutex mutex_;
};

// Drops a trailing line cut short by a kill (no final newline).
void repair_journal(const std::string& path) {
  if (!fs::exists(path)) return;
  const std::string text = read_file(path);
  if (text.empty() || text.back() == '\n') return;
  const std::size_t keep = text.rfind('\n') == std::string::npos ? 0 : text.rfind('\n') + 1;
  fs::resize_file(path, keep);
}

// The complete lines of a journal (a cut last line is ignored).
std::vector<std::string> journal_lines(const std::string& path) {
  std::vector<std::string> lines;
  if (!fs::exists(path)) return lines;
  const std::string text = read_file(path);
  std::size_t start = 0;
  for (std::size_t nl; (nl = text.find('\n', start)) != std::string::npos; start = nl + 1)
    if (nl > start) lines.push_back(text.substr(start, nl - start));
  return lines;
}

std::string format_duration(double s) {
  if (!(s >= 0) || s > 1e7) return "?";
  const long t = static_cast<long>(s + 0.5);
  return t >= 3600 ? fmt::format("{}h{:02}m", t / 3600, t / 60 % 60)
                   : fmt::format("{}m{:02}s", t / 60, t % 60);
}

// Progress on a terminal (a bar with an ETA, redrawn), or plain log lines.
class Progress {
 public:
  enum Mode { Bar, Lines, Quiet };
  Progress(std::string what, long total, Mode mode, std::string prefix)
      : what_(std::move(what)), total_(total), mode_(mode), prefix_(std::move(prefix)) {}
  void step(long n, const std::string& note) {
    std::lock_guard<std::mutex> lock(mutex_);
    done_ += n;
    const double elapsed = std::chrono::duration<double>(Clock::now() - start_).count();
    const double eta = done_ > 0 ? elapsed / done_ * (total_ - done_) : -1;
    if (mode_ == Quiet) return;
    if (mode_ == Bar) {
      const int width = 30;
      const int filled = total_ > 0 ? static_cast<int>(width * done_ / total_) : width;
      fmt::print(stderr, "\r{}{} [{}{}] {}/{} ETA {}   ", prefix_, what_, std::string(filled, '#'),
                 std::string(width - filled, ' '), done_, total_, format_duration(eta));
    } else {
      fmt::print(stderr, "{}{} {}/{} ({}) elapsed {} ETA {}\n", prefix_, what_, done_, total_, note,
                 format_duration(elapsed), format_duration(eta));
    }
  }
  void finish() {
    if (mode_ == Bar) fmt::print(stderr, "\n");
  }

 private:
  std::string what_;
  long total_, done_ = 0;
  Mode mode_;
  std::string prefix_;
  std::mutex mutex_;
  Clock::time_point start_ = Clock::now();
};

// Runs body(i) for every i in items on `jobs` threads, dynamically; the first exception is
// rethrown after all threads stop.
template <class Body>
void run_parallel(const std::vector<int>& items, int jobs, Body&& body) {
  std::atomic<std::size_t> next{0};
  std::exception_ptr error;
  std::mutex error_mutex;
  std::vector<std::thread> pool;
  for (int t = 0; t < std::max(1, jobs); ++t)
    pool.emplace_back([&] {
      for (std::size_t k; (k = next++) < items.size();) {
        try {
          body(items[k]);
        } catch (...) {
          std::lock_guard<std::mutex> lock(error_mutex);
          if (!error) error = std::current_exception();
          next = items.size();
        }
      }
    });
  for (auto& t : pool) t.join();
  if (error) std::rethrow_exception(error);
}

// Models are read once per process, on first use.
class ModelCache {
 public:
  explicit ModelCache(const CampaignConfig& c)
      : config_(c), meshes_(c.models.size()), flags_(new std::once_flag[c.models.size()]) {}
  const Mesh& get(int m) {
    std::call_once(flags_[m], [&] {
      meshes_[m] = std::make_shared<const Mesh>(read_input(config_.models[m].path, {}));
    });
    return *meshes_[m];
  }

 private:
  const CampaignConfig& config_;
  std::vector<std::shared_ptr<const Mesh>> meshes_;
  std::unique_ptr<std::once_flag[]> flags_;
};

int run(const BenchArgs& a) {
  World world;
  CampaignConfig config;
  try {
    config = load_campaign(a.config);
  } catch (const IOError& e) {
    throw InputFailure(e.what());  // a missing campaign file is bad input, not a failed write
  }
  const fs::path out = a.out.empty() ? fs::path("bench-results") / config.name : fs::path(a.out);
  const std::string rows_path = (out / "rows.jsonl").string();
  const std::string calib_path = (out / "calibration.jsonl").string();
  const std::string stamp_path = (out / "campaign.json").string();
  // On a terminal rank 0 draws a bar and the other ranks stay quiet; otherwise log lines.
  const bool tty = isatty(STDERR_FILENO);
  const std::string prefix = world.size() > 1 ? fmt::format("[rank {}] ", world.rank()) : "";
  const Progress::Mode mode = !tty                ? Progress::Lines
                              : world.rank() == 0 ? Progress::Bar
                                                  : Progress::Quiet;
  int local = 1;
  if (const char* s = std::getenv("OMPI_COMM_WORLD_LOCAL_SIZE")) local = std::max(1, std::atoi(s));
  const int jobs = a.jobs > 0
                       ? a.jobs
                       : std::max(1, static_cast<int>(std::thread::hardware_concurrency()) / local);
  const auto wall_start = Clock::now();

  // Rank 0 prepares the directory: a fresh start, or a check that it holds this campaign.
  bool ok = true;
  std::string problem;
  if (world.rank() == 0) {
    try {
      const std::string stamp = read_file(a.config);
      if (a.fresh) fs::remove_all(out);
      fs::create_directories(out);
      if (fs::exists(stamp_path) && read_file(stamp_path) != stamp)
        throw InvalidArgumentError(fmt::format(
            "{} holds the results of another campaign file: use --fresh to start over, or "
            "--out elsewhere",
            out.string()));
      if (!fs::exists(stamp_path)) write_file_atomically(stamp_path, stamp);
      repair_journal(rows_path);
      repair_journal(calib_path);
    } catch (const std::exception& e) {
      ok = false;
      problem = e.what();
    }
  }
  if (!world.all(ok)) {
    if (world.rank() == 0) throw InvalidArgumentError(problem);
    return kUsage;
  }

  ModelCache models(config);
  // Phase 1: calibrations not yet in the journal, every size-th pair on this rank.
  std::map<std::string, CalibrationRecord> calibrations;
  auto read_calibrations = [&] {
    calibrations.clear();
    for (const std::string& line : journal_lines(calib_path)) {
      try {
        const CalibrationRecord r = calibration_from_json(line);
        calibrations.emplace(r.model + "|" + r.variant + "|" + r.protocol, r);
      } catch (const InvalidInputError&) {
      }
    }
  };
  read_calibrations();
  {
    // Calibration i: model, variant and protocol, protocol-minor.
    const int nv = static_cast<int>(config.variants.size());
    const int np = static_cast<int>(config.protocols.size());
    auto name_of = [&](int i) {
      return config.models[i / (nv * np)].name + "|" + config.variants[i / np % nv] + "|" +
             config.protocols[i % np].name;
    };
    std::vector<int> mine;
    const int pairs = static_cast<int>(config.models.size()) * nv * np;
    for (int i = 0; i < pairs; ++i)
      if (i % world.size() == world.rank() && !calibrations.count(name_of(i))) mine.push_back(i);
    if (!mine.empty()) {
      Journal journal(calib_path);
      Progress progress("calibrating", static_cast<long>(mine.size()), mode, prefix);
      run_parallel(mine, jobs, [&](int i) {
        const int m = i / (nv * np);
        const CalibrationRecord r =
            calibrate_for_campaign(config, m, i / np % nv, models.get(m), i % np);
        journal.append(calibration_to_json(r));
        progress.step(
            1, fmt::format("{} {}{}: alpha {:.4f}, {}", r.model, r.variant,
                           r.protocol.empty() ? "" : " " + r.protocol, r.strength, r.status));
      });
      progress.finish();
    }
  }
  world.barrier();
  read_calibrations();

  // Phase 2: units, every size-th on this rank, skipping trials already in the journal.
  std::set<std::string> done;
  for (const std::string& line : journal_lines(rows_path)) {
    try {
      done.insert(row_from_json(line).key);
    } catch (const InvalidInputError&) {
    }
  }
  const std::vector<CampaignUnit> units = campaign_units(config);
  std::vector<int> mine;
  long todo = 0;
  for (int i = 0; i < static_cast<int>(units.size()); ++i) {
    if (i % world.size() != world.rank()) continue;
    const CampaignUnit& u = units[i];
    long missing = 0;
    for (const std::string& key : unit_trial_keys(config, u)) missing += !done.count(key);
    if (missing > 0) mine.push_back(i), todo += missing;
  }
  {
    Journal journal(rows_path);
    Progress progress("trials", todo, mode, prefix);
    run_parallel(mine, jobs, [&](int i) {
      const CampaignUnit& u = units[i];
      const std::string key = config.models[u.model].name + "|" + config.variants[u.variant] + "|" +
                              config.protocols[u.protocol].name;
      const auto it = calibrations.find(key);
      if (it == calibrations.end()) throw Error(fmt::format("no calibration for {} (a bug)", key));
      long n = 0;
      run_campaign_unit(
          config, u, models.get(u.model), it->second,
          [&](const std::string& k) { return done.count(k) > 0; },
          [&](const TrialRow& row) {
            journal.append(row_to_json(row));
            ++n;
          });
      progress.step(n, fmt::format("{} {} payload {}", config.models[u.model].name,
                                   config.variants[u.variant], u.payload));
    });
    progress.finish();
  }
  world.barrier();
  if (world.rank() != 0) return kOk;

  // Rank 0: merge, in canonical order, one row per key.
  std::map<std::string, TrialRow> by_key;
  int unreadable = 0;
  std::string first_unreadable;
  for (const std::string& line : journal_lines(rows_path)) {
    try {
      TrialRow r = row_from_json(line);
      by_key.emplace(r.key, std::move(r));
    } catch (const InvalidInputError& e) {
      if (unreadable++ == 0)
        first_unreadable = fmt::format("{} ({})", line.substr(0, 200), e.what());
    }
  }
  std::vector<TrialRow> rows;
  std::vector<std::string> missing;
  for (const CampaignUnit& u : units)
    for (const std::string& key : unit_trial_keys(config, u)) {
      auto it = by_key.find(key);
      if (it == by_key.end())
        missing.push_back(key);
      else
        rows.push_back(it->second);
    }
  if (!missing.empty())
    throw Error(fmt::format(
        "{} trials missing after the run, first {} (a bug){}", missing.size(), missing.front(),
        unreadable
            ? fmt::format("; {} journal lines unreadable, first: {}", unreadable, first_unreadable)
            : ""));
  std::string jsonl, csv = csv_header(config.trace) + "\n";
  for (const TrialRow& r : rows)
    jsonl += row_to_json(r) + "\n", csv += row_to_csv(r, config.trace) + "\n";
  write_file_atomically(rows_path, jsonl);
  write_file_atomically((out / "rows.csv").string(), csv);
  std::vector<CalibrationRecord> records;
  for (const auto& [k, r] : calibrations) records.push_back(r);
  // Wall time of this run, and of every run of the campaign (kept beside the rows).
  const double wall = std::chrono::duration<double>(Clock::now() - wall_start).count();
  const std::string wall_path = (out / "wall_seconds.txt").string();
  double total_wall = wall;
  if (fs::exists(wall_path)) {
    try {
      total_wall += std::stod(read_file(wall_path));
    } catch (const std::exception&) {
    }
  }
  write_file_atomically(wall_path, fmt::format("{}\n", total_wall));
  const std::string report = write_campaign_report(out.string(), config, records, rows, total_wall);
  fmt::print(
      "campaign {}: {} trials ({} run now on {} process(es) x {} threads) in {:.1f} s ({:.1f} s "
      "over all runs)\n",
      config.name, rows.size(), todo, world.size(), jobs, wall, total_wall);
  fmt::print("rows     {}\nsummary  {}\nreport   {}\n", (out / "rows.csv").string(),
             (out / "summary.csv").string(), report);
  if (config.trace) {
    for (const TraceSummaryRow& s : summarize_trace(config, rows))
      fmt::print("  {:<34} trace right/none/wrong {}/{}/{}, blind {}/{}/{}\n",
                 fmt::format("{}{}:{:g}", s.colluders == 2 ? "average of 2, " : "", s.attack,
                             s.attack_strength),
                 s.trace_right, s.trace_none, s.trace_wrong, s.blind_right, s.blind_none,
                 s.blind_wrong);
    return kOk;
  }
  for (const SummaryRow& s : summarize(config, rows))
    if (s.attack != "none")
      fmt::print("  {}{} {:<12} {:<8g} median BER {:.3f} ({} trials)\n", s.variant,
                 s.protocol.empty() ? "" : " " + s.protocol, s.attack, s.attack_strength,
                 s.median_ber, s.trials);
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
  sub->callback([args, &exit_code] { exit_code = run(*args); });
}

}  // namespace meshmark::cli
