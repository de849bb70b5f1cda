// meshmark trace LEAKED --original ORIG --registry DB --key-file K [--report FILE.html]

#include <fmt/format.h>

#include <cmath>

#include <algorithm>

#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>

#include "cli.h"
#include "meshmark/core/error.h"
#include "meshmark/forensics/trace_files.h"
#include "progress.h"

namespace meshmark::cli {

namespace {

struct TraceArgs {
  std::string leaked, original, registry, report, pdf, case_id, analyst;
  bool redact = false;
  KeyArgs keys;
  InputOptions in;
  TraceOptions options;
  bool json = false, no_register = false;
  std::vector<std::string> argv;  // the command line as run, for the report
};

// A word for a shell: as it is when every character is plain, else single-quoted (a quote
// inside written '\''), or ANSI-C quoted when it holds a control byte.
std::string shell_quote(const std::string& word) {
  const bool plain = !word.empty() && word.find_first_not_of(
                                          "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                                          "0123456789_-+=/.,:@%") == std::string::npos;
  if (plain) return word;
  const bool control = std::any_of(word.begin(), word.end(), [](char c) {
    return static_cast<unsigned char>(c) < 0x20 || c == 0x7f;
  });
  if (!control) {
    std::string q = "'";
    for (const char c : word) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
    return q + "'";
  }
  // A newline or another control byte: ANSI-C quoting ($'...', bash, zsh, ksh), every such
  // byte as \xHH, so that the command stays one printable line and names the same file.
  std::string q = "$'";
  for (const char c : word) {
    const auto u = static_cast<unsigned char>(c);
    if (c == '\\' || c == '\'')
      q += '\\', q += c;
    else if (u < 0x20 || u == 0x7f)
      q += fmt::format("\\x{:02x}", u);
    else
      q += c;
  }
  return q + "'";
}

// The command that reproduces the report: cd to this directory, then the arguments as run,
// quoted; a passphrase given with --key is replaced by "$MESHMARK_KEY" and a registry URL's
// password by *** (never written).
std::string reproducing_command(const std::vector<std::string>& argv, bool& redacted) {
  std::error_code ec;
  std::string cmd = "cd " + shell_quote(std::filesystem::current_path(ec).string()) + " &&";
  redacted = false;
  for (std::size_t i = 0; i < argv.size(); ++i) {
    cmd += ' ';
    if (i > 0 && argv[i - 1] == "--key") {
      cmd += "\"$MESHMARK_KEY\"", redacted = true;
    } else if (argv[i].starts_with("--key=")) {
      cmd += "--key=\"$MESHMARK_KEY\"", redacted = true;
    } else if (const std::string shown = registry_display_name(argv[i]); shown != argv[i]) {
      cmd += shell_quote(shown), redacted = true;  // a registry URL's password
    } else {
      cmd += shell_quote(argv[i]);
    }
  }
  return cmd;
}

// One candidate's score as trace --json prints it.
nlohmann::json score_json(const CandidateScore& s) {
  nlohmann::json j{
      {"buyer", s.copy.buyer},      {"id", s.copy.id},      {"matches", s.matches},
      {"bits", s.compared},         {"p_value", s.p_value}, {"corrected_p", s.corrected_p},
      {"copy", s.copy.output_path}, {"row", s.copy.row},    {"row_auth", enum_name(s.auth)}};
  if (std::isfinite(s.fingerprint_z))  // a copy issued with the fingerprint
    j["fingerprint"] = {{"z", s.fingerprint_z}, {"p_value", s.fingerprint_p}};
  return j;
}

}  // namespace

nlohmann::json trace_json(const TraceResult& r, const TraceOptions& options,
                          const std::vector<std::string>& warnings) {
  nlohmann::json named = nlohmann::json::array(), top = nlohmann::json::array();
  for (const CandidateScore& s : r.named) named.push_back(score_json(s));
  for (std::size_t i = 0; i < r.ranking.size() && i < 5; ++i)
    top.push_back(score_json(r.ranking[i]));
  nlohmann::json evidence = nlohmann::json::array();
  for (const BitEvidence& e : r.bits)
    evidence.push_back({{"bit", e.bit > 1 ? nlohmann::json(nullptr) : nlohmann::json(e.bit)},
                        {"shift", e.shift},
                        {"if_one", e.if_one},
                        {"if_zero", e.if_zero},
                        {"vertices", e.vertices}});
  return {{"status", trace_status_name(r.status)},
          {"message", r.message},
          {"candidates", r.candidates},
          {"threshold", options.threshold},
          {"named", named},
          {"best", top},
          {"registration", r.registration.message},
          {"registration_residual", r.registration.residual},
          {"overlap", r.registration.overlap},
          {"scale", r.registration.transform.scale},
          {"measured_fraction", r.measured_fraction},
          {"attenuation", r.attenuation},
          {"processing", r.processing},
          {"fingerprint_processing", r.fingerprint_processing},
          {"bit_evidence", evidence},
          {"warnings", warnings},
          {"identical_row", r.identical_row}};
}

namespace {

int run(const TraceArgs& a) {
  const std::optional<Key> key = resolve_key_in(a.keys, a.registry);
  if (!key) throw InvalidArgumentError("trace needs the key the copies were issued under");
  TraceFilesRequest request;
  request.leaked = a.leaked;
  request.original = a.original;
  request.registry = a.registry;
  request.report = a.report;
  request.pdf = a.pdf;
  request.key_file = a.keys.file.value_or("");
  request.case_id = a.case_id;
  request.analyst = a.analyst;
  request.redact = a.redact;
  request.read = read_options(a.in);
  request.options = a.options;
  request.options.register_leak = !a.no_register;
  bool redacted = false;
  request.command = reproducing_command(a.argv, redacted);
  if (redacted)
    request.command_note =
        "Secrets are not written: set MESHMARK_KEY to the passphrase given with --key, and "
        "give a registry's password in PGPASSFILE or PGPASSWORD.";
  Progress progress(Progress::Bar, "");
  request.options.progress = terminal_progress(progress, a.json);
  TraceFilesResult found;
  try {
    found = trace_files(request, *key);
  } catch (const WriteError&) {
    throw;  // the report: exit kWriteFailed
  } catch (const IOError& e) {
    throw InputFailure(e.what());  // the meshes and the registry are input here
  }
  progress.finish();
  const TraceOptions& options = request.options;
  const TraceResult& r = found.trace;
  std::vector<std::string> warnings = found.warnings;
  warnings.insert(warnings.end(), r.warnings.begin(), r.warnings.end());
  for (const std::string& w : warnings) fmt::print(stderr, "warning: {}\n", printable(w));
  auto is_named = [&](const CandidateScore& s) {
    for (const CandidateScore& n : r.named)
      if (n.copy.row == s.copy.row) return true;
    return false;
  };
  if (a.json) {
    nlohmann::json j = trace_json(r, options, warnings);
    if (!a.report.empty()) j["report"] = a.report;
    if (!a.pdf.empty()) j["pdf"] = a.pdf;
    fmt::print("{}\n", j.dump(2));
  } else {
    fmt::print("{}\n", printable(r.message));
    fmt::print("  registration     {}\n", r.registration.message);
    fmt::print(
        "  measured         {:.1f} % of the original's vertices (attenuation {:.3f}; "
        "reference: {})\n",
        100 * r.measured_fraction, r.attenuation, r.processing);
    if (!r.fingerprint_processing.empty())
      fmt::print("  fingerprint      read at the leak's vertices (smoothing taken out: {})\n",
                 r.fingerprint_processing);
    fmt::print("  candidates       {} issued copies of this original under this key\n",
               r.candidates);
    for (std::size_t i = 0; i < r.ranking.size() && i < 3; ++i) {
      const CandidateScore& s = r.ranking[i];
      fmt::print("  {:<16} ID {} '{}': {} of {} bits{}, p = {:.3g}, corrected {:.3g}{}\n",
                 i == 0 ? "best" : (i == 1 ? "runner-up" : ""), s.copy.id, printable(s.copy.buyer),
                 s.matches, s.compared,
                 std::isfinite(s.fingerprint_z)
                     ? fmt::format(", fingerprint z = {:.2f} (p = {:.3g})", s.fingerprint_z,
                                   s.fingerprint_p)
                     : "",
                 s.p_value, s.corrected_p,
                 is_named(s) ? "  NAMED" : (s.auth == RowAuth::Edited ? "  EDITED ROW" : ""));
    }
    if (!a.report.empty()) fmt::print("  report           {}\n", printable(a.report));
    if (!a.pdf.empty()) fmt::print("  pdf              {}\n", printable(a.pdf));
  }
  return r.status == TraceStatus::Named ? kOk : kNoId;
}

}  // namespace

void register_trace(CLI::App& app, int& exit_code, std::vector<std::string> argv) {
  auto args = std::make_shared<TraceArgs>();
  args->argv = std::move(argv);
  CLI::App* sub = app.add_subcommand(
      "trace", "Name the buyer whose copy leaked, with the original and the registry");
  sub->add_option("LEAKED", args->leaked, "the leaked mesh")->required();
  sub->add_option("--original", args->original, "the original the copies were made from")
      ->required();
  sub->add_option("--registry", args->registry, "the registry of issued copies")->required();
  sub->add_option("--threshold", args->options.threshold,
                  "name a buyer below this false-alarm probability, corrected for the number "
                  "of candidates (default 1e-6; at most 1e-3: a looser one names innocents "
                  "too often to be evidence)")
      ->check(CLI::Range(1e-300, 1e-3));
  sub->add_option("--erase-distance", args->options.erase_distance,
                  "original vertices with no leaked surface within this fraction of the "
                  "diagonal are not measured")
      ->check(CLI::Range(1e-9, 1.0));
  sub->add_flag("--no-register", args->no_register,
                "the leak is in the original's frame: do not register it");
  sub->add_flag("--json", args->json, "print a JSON report");
  sub->add_option("--report", args->report,
                  "write a self-contained HTML evidence report there (views of the registered "
                  "leak, the scores, the bits, the settings, hashes and command)");
  sub->add_option("--pdf", args->pdf,
                  "also print the report as PDF there (headless Chromium; needs --report)");
  sub->add_option("--case", args->case_id, "the report: the case it belongs to (free text)");
  sub->add_option("--analyst", args->analyst, "the report: who ran the trace (free text)");
  sub->add_flag("--redact", args->redact,
                "the report for sharing: buyer labels as 'the buyer of ID N', file names "
                "without their folders (the hashes stay)");
  add_key_options(*sub, args->keys);
  add_input_options(*sub, args->in);
  sub->callback([args, &exit_code] { exit_code = run(*args); });
}

}  // namespace meshmark::cli
