// meshmark embed --batch MANIFEST: issues one copy per manifest line (issue.h) and prints one
// line per copy (or, with --json, one JSON object for the batch).

#include <fmt/format.h>

#include <nlohmann/json.hpp>

#include <set>

#include "cli.h"
#include "meshmark/core/error.h"
#include "meshmark/forensics/issue.h"
#include "progress.h"

namespace meshmark::cli {

int run_batch(const std::string& manifest, IssueSettings settings, bool json) {
  const std::vector<CopyRequest> requests = read_manifest(manifest);  // ReadError: exit 2
  Progress progress(Progress::Bar, "");
  settings.progress = terminal_progress(progress, json);
  const IssueResult result = issue_copies(requests, settings);
  progress.finish();
  const std::size_t skipped = result.count(CopyStatus::Skipped);
  const std::size_t written = result.count(CopyStatus::Written);
  const int rc = written + skipped == requests.size() ? kOk : kNotEmbedded;
  if (json) {
    nlohmann::json copies = nlohmann::json::array();
    for (std::size_t k = 0; k < requests.size(); ++k) {
      const CopyOutcome& c = result.copies[k];
      const std::optional<std::uint64_t> id = requests[k].auto_id && c.record.id
                                                  ? std::optional<std::uint64_t>(c.record.id)
                                                  : requests[k].id;
      copies.push_back({{"line", requests[k].line},
                        {"input", requests[k].input},
                        {"output", requests[k].output},
                        {"id", id ? nlohmann::json(*id) : nlohmann::json(nullptr)},
                        {"buyer", requests[k].buyer},
                        {"status", copy_status_name(c.status)},
                        {"ok", c.ok()},
                        {"message", c.message},
                        {"warnings", c.warnings},
                        {"strength", c.fingerprint_alone ? 0.0 : c.embedding.strength},
                        {"fingerprint_alone", c.fingerprint_alone},
                        {"rms_percent", c.result.rms_percent}});
    }
    fmt::print("{}\n", nlohmann::json{{"manifest", manifest},
                                      {"copies", copies},
                                      {"written", written},
                                      {"skipped", skipped},
                                      {"failed", requests.size() - written - skipped},
                                      {"inputs", result.inputs},
                                      {"threads", result.threads},
                                      {"seconds", result.seconds}}
                           .dump(2));
    return rc;
  }
  std::set<std::string> warned;
  for (std::size_t k = 0; k < requests.size(); ++k) {
    const CopyOutcome& c = result.copies[k];
    for (const std::string& w : c.warnings)
      if (warned.insert(w).second) fmt::print(stderr, "meshmark: warning: {}\n", printable(w));
    fmt::print("{}:{}: {} {} -> {}: {}\n", printable(manifest), requests[k].line,
               c.ok() ? "ok" : "FAILED", printable(requests[k].input),
               printable(requests[k].output), printable(c.message));
  }
  fmt::print("{} of {} copies watermarked from {} distinct inputs on {} threads in {:.2f} s{}\n",
             written, requests.size(), result.inputs, result.threads, result.seconds,
             skipped ? fmt::format("; {} issued before and skipped", skipped) : "");
  return rc;
}

}  // namespace meshmark::cli
