// meshmark attack KIND IN OUT [--seed N]

#include <fmt/format.h>
#include <memory>

#include "cli.h"
#include "meshmark/attack.h"
#include "meshmark/error.h"

namespace meshmark::cli {

namespace {

struct AttackArgs {
  std::string kind, input, output;
  double strength = 2.0;
  std::uint64_t seed = 1;
  InputOptions in;
  OutputOptions out;
};

int run(const AttackArgs& a) {
  const Mesh mesh = read_input(a.input, a.in);
  Mesh attacked;
  if (a.kind == "similarity") {
    SimilarityOptions o;
    o.max_scale = a.strength;
    attacked = attack_similarity(mesh, a.seed, o);
  } else if (a.kind == "reorder") {
    attacked = attack_reorder(mesh, a.seed);
  } else {
    throw InvalidArgumentError(
        fmt::format("unknown attack '{}' (available: similarity, reorder)", a.kind));
  }
  write_output(a.output, a.input, attacked, a.out);
  fmt::print("{}: {} -> {} ({} vertices, {} faces, seed {})\n", a.kind, a.input, a.output,
             attacked.V.rows(), attacked.faces.size(), a.seed);
  return kOk;
}

}  // namespace

void register_attack(CLI::App& app, int& exit_code) {
  auto args = std::make_shared<AttackArgs>();
  CLI::App* sub =
      app.add_subcommand("attack", "Apply an attack to a mesh (deterministic for a seed)");
  sub->add_option("KIND", args->kind, "similarity | reorder")->required();
  sub->add_option("IN", args->input, "input mesh")->required();
  sub->add_option("OUT", args->output, "output mesh")->required();
  sub->add_option("--strength", args->strength, "similarity: largest scale factor (>= 1)");
  sub->add_option("--seed", args->seed, "random seed");
  add_input_options(*sub, args->in);
  add_output_options(*sub, args->out);
  sub->callback([args, &exit_code] { exit_code = run(*args); });
}

}  // namespace meshmark::cli
