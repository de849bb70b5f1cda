// meshmark attack KIND IN OUT [--strength X] [--seed N]; KIND may be a chain such as
// "noise:0.001,quant:10".

#include <fmt/format.h>

#include <cmath>
#include <memory>

#include "cli.h"
#include "meshmark/attack.h"
#include "meshmark/error.h"

namespace meshmark::cli {

namespace {

struct AttackArgs {
  std::string kind, input, output;
  double strength = 0;
  std::uint64_t seed = 1;
  InputOptions in;
  OutputOptions out;
};

int run(const AttackArgs& a) {
  std::vector<AttackStep> steps;
  if (a.kind.find_first_of(":,") != std::string::npos) {
    steps = parse_attack_chain(a.kind);
  } else {
    steps = parse_attack_chain(a.kind);  // validates the name
    steps[0].strength = a.strength;
  }
  for (const AttackStep& s : steps)
    if (!std::isfinite(s.strength))
      throw InvalidArgumentError(
          fmt::format("attack '{}': strength {} is not a finite number", s.kind, s.strength));
  const Mesh mesh = read_input(a.input, a.in);
  Mesh attacked = apply_attack_chain(mesh, steps, a.seed);
  attacked.source_path = a.input;  // what a failed write (float32 range) names
  write_output(a.output, a.input, attacked, a.out);
  fmt::print("{}: {} -> {} ({} vertices, {} faces, seed {})\n", printable(a.kind),
             printable(a.input), printable(a.output), attacked.V.rows(), attacked.faces.size(),
             a.seed);
  return kOk;
}

std::string kinds_help() {
  std::string s = "attack kinds (STRENGTH is --strength, or KIND:STRENGTH in a chain):\n";
  for (const auto& [name, what] : attack_kinds()) s += fmt::format("  {:<13} {}\n", name, what);
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
  add_input_options(*sub, args->in);
  add_output_options(*sub, args->out);
  sub->callback([args, &exit_code] { exit_code = run(*args); });
}

}  // namespace meshmark::cli
