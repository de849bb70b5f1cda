// meshmark embed --batch MANIFEST: issues one copy per manifest line (issue.h) and prints one
// line per copy.

#include <fmt/format.h>

#include <set>

#include "cli.h"
#include "meshmark/error.h"
#include "meshmark/issue.h"

namespace meshmark::cli {

int run_batch(const std::string& manifest, const IssueSettings& settings) {
  const std::vector<CopyRequest> requests = read_manifest(manifest);  // ReadError: exit 2
  const IssueResult result = issue_copies(requests, settings);
  std::set<std::string> warned;
  for (std::size_t k = 0; k < requests.size(); ++k) {
    const CopyOutcome& c = result.copies[k];
    for (const std::string& w : c.warnings)
      if (warned.insert(w).second) fmt::print(stderr, "meshmark: warning: {}\n", printable(w));
    fmt::print("{}:{}: {} {} -> {}: {}\n", printable(manifest), requests[k].line,
               c.ok() ? "ok" : "FAILED", printable(requests[k].input),
               printable(requests[k].output), printable(c.message));
  }
  const std::size_t skipped = result.count(CopyStatus::Skipped);
  const std::size_t written = result.count(CopyStatus::Written);
  fmt::print("{} of {} copies watermarked from {} distinct inputs on {} threads in {:.2f} s{}\n",
             written, requests.size(), result.inputs, result.threads, result.seconds,
             skipped ? fmt::format("; {} issued before and skipped", skipped) : "");
  return written + skipped == requests.size() ? kOk : kNotEmbedded;
}

}  // namespace meshmark::cli
