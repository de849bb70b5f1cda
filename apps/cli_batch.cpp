// meshmark embed --batch MANIFEST: one watermarked copy per line (input, output, payload), on
// every core, each distinct input read once.

#include <fmt/format.h>

#include <atomic>
#include <chrono>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <thread>

#include "cli.h"
#include "meshmark/embed.h"
#include "meshmark/error.h"

namespace meshmark::cli {

namespace {

struct Job {
  std::size_t line = 0;
  std::string input, output, payload;
  std::string outcome;  // filled by the worker
  bool ok = false;
};

std::vector<Job> read_manifest(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputFailure(fmt::format("{}: cannot open the manifest", path));
  std::vector<Job> jobs;
  std::string text;
  for (std::size_t line = 1; std::getline(in, text); ++line) {
    const auto hash = text.find('#');
    if (hash != std::string::npos) text.resize(hash);
    std::istringstream words(text);
    Job job;
    job.line = line;
    if (!(words >> job.input)) continue;  // blank or comment
    std::string extra;
    if (!(words >> job.output >> job.payload) || (words >> extra))
      throw InvalidInputError(path, line, "expected three fields: INPUT OUTPUT PAYLOAD");
    jobs.push_back(job);
  }
  return jobs;
}

}  // namespace

int run_batch(const std::string& manifest, int bits, const EmbedOptions& options,
              const InputOptions& in_options, const OutputOptions& out_options) {
  const auto start = std::chrono::steady_clock::now();
  std::vector<Job> jobs = read_manifest(manifest);
  // Each distinct input is read once, before the work is shared out.
  std::map<std::string, std::shared_ptr<const Mesh>> meshes;
  std::map<std::string, std::string> unreadable;
  for (const Job& job : jobs) {
    if (meshes.count(job.input) || unreadable.count(job.input)) continue;
    try {
      meshes[job.input] = std::make_shared<const Mesh>(read_input(job.input, in_options));
    } catch (const std::exception& e) {
      unreadable[job.input] = e.what();
    }
  }
  std::atomic<std::size_t> next{0};
  auto worker = [&] {
    for (std::size_t k = next++; k < jobs.size(); k = next++) {
      Job& job = jobs[k];
      try {
        auto it = meshes.find(job.input);
        if (it == meshes.end()) throw Error(unreadable[job.input]);
        const Payload payload = payload_from_hex(job.payload, bits);
        const EmbedResult r = embed(it->second->V, it->second->F, payload, options);
        if (r.status != EmbedStatus::Embedded) throw Error(r.message);
        Mesh out = *it->second;
        out.V = r.V;
        write_output(job.output, job.input, out, out_options);
        job.ok = true;
        job.outcome = fmt::format("{} rounds, RMS {:.5f} %, {:.1f} ms", r.rounds, r.rms_percent,
                                  1e3 * r.seconds);
      } catch (const std::exception& e) {
        job.outcome = e.what();
      }
    }
  };
  const unsigned threads = std::max(1u, std::min<unsigned>(std::thread::hardware_concurrency(),
                                                           static_cast<unsigned>(jobs.size())));
  std::vector<std::thread> pool;
  for (unsigned t = 0; t < threads; ++t) pool.emplace_back(worker);
  for (auto& t : pool) t.join();
  std::size_t failed = 0;
  for (const Job& job : jobs) {
    fmt::print("{}:{}: {} {} -> {}: {}\n", manifest, job.line, job.ok ? "ok" : "FAILED", job.input,
               job.output, job.outcome);
    failed += !job.ok;
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  fmt::print("{} of {} copies watermarked from {} distinct inputs on {} threads in {:.2f} s\n",
             jobs.size() - failed, jobs.size(), meshes.size() + unreadable.size(), threads,
             seconds);
  return failed == 0 ? kOk : kNotEmbedded;
}

}  // namespace meshmark::cli
