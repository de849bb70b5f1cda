// meshmark trace LEAKED --original ORIG --registry DB --key-file K

#include <fmt/format.h>

#include <memory>
#include <nlohmann/json.hpp>

#include "cli.h"
#include "meshmark/error.h"
#include "meshmark/trace.h"

namespace meshmark::cli {

namespace {

struct TraceArgs {
  std::string leaked, original, registry;
  KeyArgs keys;
  InputOptions in;
  TraceOptions options;
  bool json = false, no_register = false;
};

int run(const TraceArgs& a) {
  const std::optional<Key> key = resolve_key(a.keys);
  if (!key) throw InvalidArgumentError("trace needs the key the copies were issued under");
  const Mesh leaked = read_input(a.leaked, a.in);
  const Mesh original = read_input(a.original, a.in);
  RegistryQuery q;
  try {
    q.original_hash = content_hash(read_file(a.original));
  } catch (const IOError& e) {
    throw InputFailure(e.what());
  }
  q.key_fingerprint = key_fingerprint(*key);
  const Registry registry(a.registry);
  const std::vector<IssuedCopy> candidates = registry.list(q);
  TraceOptions options = a.options;
  options.register_leak = !a.no_register;
  const TraceResult r = trace(leaked, original, candidates, *key, options);
  auto score = [](const CandidateScore& s) {
    return nlohmann::json{{"buyer", s.copy.buyer},     {"id", s.copy.id},
                          {"matches", s.matches},      {"bits", s.compared},
                          {"p_value", s.p_value},      {"corrected_p", s.corrected_p},
                          {"copy", s.copy.output_path}};
  };
  if (a.json) {
    nlohmann::json named = nlohmann::json::array(), top = nlohmann::json::array();
    for (const CandidateScore& s : r.named) named.push_back(score(s));
    for (std::size_t i = 0; i < r.ranking.size() && i < 5; ++i) top.push_back(score(r.ranking[i]));
    nlohmann::json evidence = nlohmann::json::array();
    for (const BitEvidence& e : r.bits)
      evidence.push_back({{"bit", e.bit > 1 ? nlohmann::json(nullptr) : nlohmann::json(e.bit)},
                          {"shift", e.shift},
                          {"if_one", e.if_one},
                          {"if_zero", e.if_zero},
                          {"vertices", e.vertices}});
    const nlohmann::json j = {{"status", trace_status_name(r.status)},
                              {"message", r.message},
                              {"candidates", r.ranking.size()},
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
                              {"bit_evidence", evidence}};
    fmt::print("{}\n", j.dump(2));
  } else {
    fmt::print("{}\n", printable(r.message));
    fmt::print("  registration     {}\n", r.registration.message);
    fmt::print(
        "  measured         {:.1f} % of the original's vertices (attenuation {:.3f}; "
        "reference: {})\n",
        100 * r.measured_fraction, r.attenuation, r.processing);
    fmt::print("  candidates       {} issued copies of this original under this key\n",
               r.ranking.size());
    for (std::size_t i = 0; i < r.ranking.size() && i < 3; ++i) {
      const CandidateScore& s = r.ranking[i];
      fmt::print("  {:<16} ID {} '{}': {} of {} bits, p = {:.3g}, corrected {:.3g}{}\n",
                 i == 0 ? "best" : (i == 1 ? "runner-up" : ""), s.copy.id, printable(s.copy.buyer),
                 s.matches, s.compared, s.p_value, s.corrected_p,
                 s.corrected_p < options.threshold ? "  NAMED" : "");
    }
  }
  return r.status == TraceStatus::Named ? kOk : kNoId;
}

}  // namespace

void register_trace(CLI::App& app, int& exit_code) {
  auto args = std::make_shared<TraceArgs>();
  CLI::App* sub = app.add_subcommand(
      "trace", "Name the buyer whose copy leaked, with the original and the registry");
  sub->add_option("LEAKED", args->leaked, "the leaked mesh")->required();
  sub->add_option("--original", args->original, "the original the copies were made from")
      ->required();
  sub->add_option("--registry", args->registry, "the registry of issued copies")->required();
  sub->add_option("--threshold", args->options.threshold,
                  "name a buyer below this false-alarm probability, corrected for the number "
                  "of candidates")
      ->check(CLI::Range(1e-300, 0.5));
  sub->add_option("--erase-distance", args->options.erase_distance,
                  "original vertices with no leaked surface within this fraction of the "
                  "diagonal are not measured")
      ->check(CLI::Range(1e-9, 1.0));
  sub->add_flag("--no-register", args->no_register,
                "the leak is in the original's frame: do not register it");
  sub->add_flag("--json", args->json, "print a JSON report");
  add_key_options(*sub, args->keys);
  add_input_options(*sub, args->in);
  sub->callback([args, &exit_code] { exit_code = run(*args); });
}

}  // namespace meshmark::cli
