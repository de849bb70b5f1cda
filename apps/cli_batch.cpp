// meshmark embed --batch MANIFEST: one watermarked copy per line (input, output, payload), on
// every core, each distinct input read once.

#include <fmt/format.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <map>
#include <memory>
#include <sstream>
#include <thread>

#include "cli.h"
#include "meshmark/embed.h"
#include "meshmark/error.h"
#include "meshmark/io.h"
#include "meshmark/watermark.h"

namespace meshmark::cli {

namespace {

struct Job {
  std::size_t line = 0;
  std::string input, output, payload;
  bool coded = false;  // payload "id:N": a coded ID, with the buyer's label after it
  std::uint64_t id = 0;
  std::string buyer;
  std::string outcome;  // a refusal found before embedding, or what the worker did
  bool ok = false;
  bool refused = false;  // not run: malformed line, output clash
  bool resumed = false;  // issued and recorded by an earlier run, its file intact: skipped
};

// Every line is a job, malformed ones included (refused, with the reason), so that one bad
// line is reported like any other failure.
std::vector<Job> read_manifest(const std::string& path) {
  std::string bytes;
  try {
    bytes = read_file(path, std::size_t(64) << 20, "manifest");
  } catch (const IOError& e) {
    throw InputFailure(e.what());
  }
  std::vector<Job> jobs;
  std::istringstream in(bytes);
  std::string text;
  for (std::size_t line = 1; std::getline(in, text); ++line) {
    const auto hash = text.find('#');
    if (hash != std::string::npos) text.resize(hash);
    std::istringstream words(text);
    Job job;
    job.line = line;
    if (!(words >> job.input)) continue;  // blank or comment
    if (!(words >> job.output >> job.payload)) {
      job.refused = true, job.outcome = "expected INPUT OUTPUT PAYLOAD or INPUT OUTPUT id:N BUYER";
    } else if (job.payload.rfind("id:", 0) == 0) {
      job.coded = true;
      try {
        job.id = parse_id(job.payload.substr(3));
      } catch (const Error& e) {
        job.refused = true, job.outcome = e.what();
      }
      std::string word;
      while (words >> word) job.buyer += (job.buyer.empty() ? "" : " ") + word;
    } else if (std::string extra; words >> extra) {
      job.refused = true, job.outcome = "expected three fields: INPUT OUTPUT PAYLOAD";
    }
    jobs.push_back(job);
  }
  return jobs;
}

// The same file for two names (an existing file by identity, a new one by its absolute path).
std::string file_identity(const std::string& path) {
  std::error_code ec;
  const auto absolute = std::filesystem::absolute(path, ec);
  if (ec) return path;
  const auto canonical = std::filesystem::weakly_canonical(absolute, ec);
  return ec ? absolute.lexically_normal().string() : canonical.lexically_normal().string();
}

// Before anything is embedded: no two lines write the same file, and no line writes a file
// some line reads. Every line involved is refused (a buyer must never get another's copy).
void refuse_clashes(std::vector<Job>& jobs) {
  std::map<std::string, std::vector<std::size_t>> writers;
  std::map<std::string, std::size_t> readers;
  for (std::size_t k = 0; k < jobs.size(); ++k) {
    if (jobs[k].refused) continue;
    writers[file_identity(jobs[k].output)].push_back(k);
    readers.emplace(file_identity(jobs[k].input), jobs[k].line);
  }
  for (const auto& [file, ks] : writers) {
    if (ks.size() > 1) {
      std::string lines;
      for (const std::size_t k : ks)
        lines += (lines.empty() ? "" : ", ") + std::to_string(jobs[k].line);
      for (const std::size_t k : ks)
        jobs[k].refused = true,
        jobs[k].outcome = fmt::format("lines {} all write this output: none of them is run", lines);
    }
    const auto r = readers.find(file);
    if (r != readers.end())
      for (const std::size_t k : ks)
        if (!jobs[k].refused)
          jobs[k].refused = true,
          jobs[k].outcome = fmt::format("the output is the input of line {}", r->second);
  }
}

// Whether the recorded copy is this line's, issued by an earlier run, with its file as recorded.
// searched: the strength and G were searched within fidelity limits, so the recorded ones are
// whatever the search found for that copy.
bool resumable(const IssuedCopy& taken, IssuedCopy wanted, const std::string& output,
               bool searched) {
  wanted.output_path = recorded_path(output);
  if (searched) wanted.strength = taken.strength, wanted.bin_offset = taken.bin_offset;
  if (!same_copy(taken, wanted)) return false;
  try {
    return content_hash(read_file(output)) == taken.output_hash;
  } catch (const std::exception&) {
    return false;  // gone or unreadable: not resumable, the line is refused as before
  }
}

}  // namespace

int run_batch(const std::string& manifest, const BatchSettings& settings) {
  const auto start = std::chrono::steady_clock::now();
  const int bits = settings.bits;
  const EmbedOptions& options = settings.options;
  const InputOptions& in_options = settings.in;
  const OutputOptions& out_options = settings.out;
  std::vector<Job> jobs = read_manifest(manifest);
  refuse_clashes(jobs);
  // The registry: every coded line's record prepared (each original hashed once), and IDs
  // already issued, or repeated in this manifest, refused before anything is embedded.
  std::optional<Registry> registry;
  std::vector<IssuedCopy> records(jobs.size());
  if (!settings.registry.empty()) {
    registry.emplace(settings.registry);
    std::map<std::string, std::string> hashes;
    std::vector<std::size_t> candidates;
    for (std::size_t k = 0; k < jobs.size(); ++k) {
      Job& job = jobs[k];
      if (job.refused) continue;
      if (!job.coded) {
        job.refused = true, job.outcome = "--registry records coded IDs only (id:N)";
        continue;
      }
      try {
        records[k] = issued_copy(job.input, job.buyer, job.id, settings.id_bits, bits,
                                 options.variant.name(), options, settings.strength_spread,
                                 id_key(settings.key));
        candidates.push_back(k);
      } catch (const std::exception& e) {
        job.refused = true, job.outcome = e.what();
      }
    }
    std::vector<IssuedCopy> wanted;
    for (const std::size_t k : candidates) wanted.push_back(records[k]);
    for (const IssuedCopy& taken : registry->conflicts(wanted))
      for (const std::size_t k : candidates)
        if (!jobs[k].refused && records[k].id == taken.id &&
            records[k].original_hash == taken.original_hash) {
          jobs[k].refused = true;
          if (taken.row &&
              resumable(taken, records[k], jobs[k].output, settings.limits.has_value())) {
            jobs[k].ok = jobs[k].resumed = true;
            jobs[k].outcome =
                fmt::format("already issued to '{}' on {} and its file is intact: skipped",
                            taken.buyer, taken.issued_at);
            continue;
          }
          jobs[k].outcome =
              taken.row ? fmt::format("ID {} already issued from this original to '{}' on {}",
                                      taken.id, taken.buyer, taken.issued_at)
                        : fmt::format("ID {} is given twice for this original", taken.id);
        }
  }
  if (registry) {
    std::vector<IssuedCopy> wanted;
    std::vector<std::size_t> index;
    for (std::size_t k = 0; k < jobs.size(); ++k)
      if (!jobs[k].refused && jobs[k].coded) wanted.push_back(records[k]), index.push_back(k);
    for (const CloseCodeword& c : close_codewords(*registry, wanted, id_key(settings.key)))
      for (const std::size_t k : index)
        if (!jobs[k].refused && records[k].id == c.copy.id &&
            records[k].original_hash == c.copy.original_hash)
          jobs[k].refused = true,
          jobs[k].outcome = fmt::format(
              "ID {}'s codeword is {} bits from that of ID {} ('{}'), closer than {}: choose "
              "another ID",
              c.copy.id, c.distance, c.near.id, c.near.buyer, kIssuedSpacing);
  }
  std::optional<IdCode> code;
  for (const Job& job : jobs)
    if (job.coded && !job.refused && !code) code.emplace(settings.code);
  // Each distinct input is read once, before the work is shared out.
  // Each with its embedder prepared once for every copy made from it.
  struct Input {
    Mesh mesh;
    PreparedEmbedder embedder;
  };
  std::map<std::string, std::shared_ptr<const Input>> meshes;
  std::map<std::string, std::string> unreadable;
  for (const Job& job : jobs) {
    if (job.refused || meshes.count(job.input) || unreadable.count(job.input)) continue;
    try {
      Mesh mesh = read_input(job.input, in_options);
      PreparedEmbedder embedder(mesh.V, mesh.F, options);
      meshes[job.input] =
          std::make_shared<const Input>(Input{std::move(mesh), std::move(embedder)});
    } catch (const std::exception& e) {
      unreadable[job.input] = e.what();
    }
  }
  std::atomic<std::size_t> next{0};
  auto worker = [&] {
    for (std::size_t k = next++; k < jobs.size(); k = next++) {
      Job& job = jobs[k];
      if (job.refused) continue;
      try {
        auto it = meshes.find(job.input);
        if (it == meshes.end()) throw Error(unreadable[job.input]);
        const Payload word = job.coded ? code->encode(job.id, id_key(settings.key))
                                       : payload_from_hex(job.payload, bits);
        const Payload payload = mark_layout(settings.key, bits, job.coded).to_bins(word);
        EmbedOptions o = options;
        o.strengths = mark_strengths(settings.key, bits, job.coded, options.strength,
                                     settings.strength_spread);
        EmbedResult r;
        std::string fidelity;
        if (settings.limits) {
          CalibrateOptions co = *settings.limits;
          co.strengths = [&](double alpha) {
            return mark_strengths(settings.key, bits, job.coded, alpha, settings.strength_spread);
          };
          CalibrateResult c = calibrate_strength(it->second->embedder, payload, o, co);
          if (c.status == CalibrateStatus::BelowMinimum) throw Error(c.message);
          o.strength = c.strength, o.bin_offset = c.bin_offset, o.strengths = c.strengths;
          records[k].strength = o.strength, records[k].bin_offset = o.bin_offset;
          fidelity = fmt::format(", strength {:.5f}, MSDM {:.4f}", c.strength, c.msdm);
          r = std::move(c.embedding);
        } else {
          r = it->second->embedder.embed(payload, o);
        }
        if (r.status != EmbedStatus::Embedded) throw Error(r.message);
        Mesh out = it->second->mesh;
        out.V = r.V;
        const WrittenCheck written =
            write_marked_output(job.output, job.input, out, out_options, in_options, payload, o);
        if (!written.carried) throw Error(written.message);
        job.ok = true;
        job.outcome = fmt::format("{} rounds, RMS {:.5f} %{}, {:.1f} ms", r.rounds, r.rms_percent,
                                  fidelity, 1e3 * r.seconds);
        if (r.check.status == CarrierHealth::Weak)
          job.outcome += fmt::format(" (warning: {})", r.check.summary());
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
  if (registry) {
    // One transaction for the whole batch: every copy written is recorded, or none is and
    // their files are removed.
    std::vector<IssuedCopy> done;
    std::vector<std::string> outputs;
    for (std::size_t k = 0; k < jobs.size(); ++k)
      if (jobs[k].ok && !jobs[k].resumed)
        done.push_back(records[k]), outputs.push_back(jobs[k].output);
    try {
      if (!done.empty()) record_copies(*registry, done, outputs);
    } catch (const std::exception& e) {
      for (Job& job : jobs)
        if (job.ok && !job.resumed)
          job.ok = false, job.outcome = fmt::format("not recorded, removed: {}", e.what());
    }
  }
  std::size_t failed = 0;
  for (const Job& job : jobs) {
    fmt::print("{}:{}: {} {} -> {}: {}\n", printable(manifest), job.line, job.ok ? "ok" : "FAILED",
               printable(job.input), printable(job.output), printable(job.outcome));
    failed += !job.ok;
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::size_t resumed = 0;
  for (const Job& job : jobs) resumed += job.resumed;
  fmt::print("{} of {} copies watermarked from {} distinct inputs on {} threads in {:.2f} s{}\n",
             jobs.size() - failed - resumed, jobs.size(), meshes.size() + unreadable.size(),
             threads, seconds,
             resumed ? fmt::format("; {} issued before and skipped", resumed) : "");
  return failed == 0 ? kOk : kNotEmbedded;
}

}  // namespace meshmark::cli
