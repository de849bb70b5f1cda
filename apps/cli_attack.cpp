// meshmark attack KIND IN OUT [--strength X] [--seed N] [--lambda L] [--mu M]
// [--fixed-boundary] [--weighting W] [--convention C]; KIND may be a chain such as
// "noise:0.001,quant:10" (the parameters go to every step that reads them).

#include <fmt/format.h>

#include <cmath>
#include <memory>

#include <nlohmann/json.hpp>

#include "cli.h"
#include "meshmark/attacks/attack.h"
#include "meshmark/core/error.h"
#include "progress.h"

namespace meshmark::cli {

namespace {

struct AttackArgs {
  std::string kind, input, output;
  double strength = 0;
  std::uint64_t seed = 1;
  AttackParams params;
  InputOptions in;
  OutputOptions out;
  bool json = false;
};

int run(const AttackArgs& a) {
  const std::vector<AttackStep> steps = attack_steps(a.kind, a.strength, a.params);
  const Mesh mesh = read_input(a.input, a.in);
  Progress progress(Progress::Bar, "");
  Mesh attacked = apply_attack_chain(mesh, steps, a.seed, terminal_progress(progress, a.json));
  progress.finish();
  attacked.source_path = a.input;  // what a failed write (float32 range) names
  write_output(a.output, a.input, attacked, a.out);
  if (a.json)
    fmt::print("{}\n", nlohmann::json{{"kind", a.kind},
                                      {"input", a.input},
                                      {"output", a.output},
                                      {"vertices", attacked.V.rows()},
                                      {"faces", attacked.F.rows()},
                                      {"seed", a.seed}}
                           .dump(2));
  else
    fmt::print("{}: {} -> {} ({} vertices, {} faces, seed {})\n", printable(a.kind),
               printable(a.input), printable(a.output), attacked.V.rows(), attacked.F.rows(),
               a.seed);
  return kOk;
}

std::string kinds_help() {
  std::string s =
      "attack kinds (STRENGTH is --strength, or KIND:STRENGTH in a chain; [seeded]: the result "
      "depends on --seed):\n";
  for (const AttackKind& k : attack_registry()) {
    const std::vector<std::string> params = attack_param_names(k.params);
    s += fmt::format(
        "  {:<13} {}{}{}{}\n", k.name, k.meaning,
        k.default_strength != 0 ? fmt::format(" (default {:g})", k.default_strength) : "",
        k.seeded ? " [seeded]" : "",
        params.empty() ? "" : fmt::format(" [reads {}]", fmt::join(params, ", ")));
  }
  return s;
}

}  // namespace

void register_attack(CLI::App& app, int& exit_code) {
  auto args = std::make_shared<AttackArgs>();
  CLI::App* sub = app.add_subcommand(
      "attack", "Apply an attack or a chain of attacks (deterministic for a seed)");
  sub->footer(kinds_help());
  sub->add_option("KIND", args->kind, "an attack kind, or a chain like noise:0.001,quant:10")
      ->required();
  sub->add_option("IN", args->input, "input mesh")->required();
  sub->add_option("OUT", args->output, "output mesh")->required();
  sub->add_option("--strength", args->strength, "the attack's strength (see the kinds below)");
  sub->add_option("--seed", args->seed, "random seed");
  sub->add_flag("--json", args->json, "print a JSON report");
  sub->add_option("--lambda", args->params.lambda,
                  "smooth, taubin: the deformation factor per step (default 0.3 for smooth, the "
                  "TIFS 2014 paper's; 0.5 for taubin; the LIRIS benchmark smooths with 0.03)");
  sub->add_option("--mu", args->params.mu,
                  "taubin: the inflating factor, negative (default from k_pb 0.1: -0.526)");
  sub->add_flag("--fixed-boundary", args->params.fixed_boundary,
                "smooth, taubin: vertices on a boundary edge stay (the LIRIS benchmark's)");
  add_enum_option<SmoothWeighting>(*sub, "--weighting", args->params.weighting,
                                   "smooth, taubin: neighbour weights, 'uniform' (1/degree; the "
                                   "benchmark's) or 'inverse-distance' (1/length, Open3D's)");
  add_enum_option<QuantizeConvention>(*sub, "--convention", args->params.convention,
                                      "quant: grid step (max - min) / (2^b - 1) 'levels' or / "
                                      "2^b 'benchmark' (the LIRIS benchmark's)");
  add_input_options(*sub, args->in);
  add_output_options(*sub, args->out);
  sub->callback([args, &exit_code] { exit_code = run(*args); });
}

}  // namespace meshmark::cli
