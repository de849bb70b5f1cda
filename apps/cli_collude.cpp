// meshmark collude IN1 IN2 [IN...] --out OUT [--weights W1,W2,...] [--splice] [--seed N]
// [--json]: what colluding buyers make of their copies of one original (attack.h,
// attack_collude), to test tracing against it.

#include <fmt/format.h>

#include <memory>

#include <nlohmann/json.hpp>

#include "cli.h"
#include "meshmark/attacks/attack.h"
#include "meshmark/core/error.h"

namespace meshmark::cli {

namespace {

struct ColludeArgs {
  std::vector<std::string> inputs;
  std::string output;
  std::vector<double> weights;
  bool splice = false;
  std::uint64_t seed = 1;
  InputOptions in;
  OutputOptions out;
  bool json = false;
};

int run(const ColludeArgs& a) {
  for (const std::string& input : a.inputs) refuse_overwrite(a.output, {input});
  CollusionOptions o;
  o.kind = a.splice ? CollusionKind::Splice : CollusionKind::Average;
  o.weights = a.weights;
  std::vector<Mesh> copies;
  for (const std::string& input : a.inputs) copies.push_back(read_input(input, a.in));
  Mesh merged = attack_collude(copies, o, a.seed);
  copies.clear();
  merged.source_path = a.inputs.front();
  write_output(a.output, a.inputs.front(), merged, a.out);
  const char* kind = a.splice ? "spliced" : a.weights.empty() ? "averaged" : "weighted average";
  if (a.json)
    fmt::print("{}\n", nlohmann::json{{"kind", a.splice ? "splice" : "average"},
                                      {"inputs", a.inputs},
                                      {"weights", a.weights},
                                      {"output", a.output},
                                      {"vertices", merged.V.rows()},
                                      {"seed", a.seed}}
                           .dump(2));
  else
    fmt::print("{} {} copies -> {} ({} vertices{})\n", kind, a.inputs.size(), printable(a.output),
               merged.V.rows(), a.splice ? fmt::format(", seed {}", a.seed) : "");
  return kOk;
}

}  // namespace

void register_collude(CLI::App& app, int& exit_code) {
  auto args = std::make_shared<ColludeArgs>();
  CLI::App* sub = app.add_subcommand(
      "collude",
      "Merge copies of one original as colluding buyers would: their vertex-wise average "
      "(equal or given weights) or a splice of regions, one per copy");
  sub->add_option("IN", args->inputs,
                  "two or more copies of one original (same vertices and faces)")
      ->required()
      ->expected(2, 1 << 16);
  sub->add_option("-o,--out", args->output,
                  "the merged mesh (written in the first copy's format "
                  "when the extension matches)")
      ->required();
  sub->add_option("--weights", args->weights,
                  "one weight per copy, comma-separated (W1,W2,...), >= 0, normalized to sum 1 "
                  "(default: equal)")
      ->delimiter(',')
      ->allow_extra_args(false);  // one argument, split at the commas: the copies after it stay
  sub->add_flag("--splice", args->splice,
                "cut the surface into one region per copy (Voronoi cells of far-apart vertices) "
                "and paste each from its copy, instead of averaging");
  sub->add_option("--seed", args->seed, "random seed (--splice: where the first region lies)");
  sub->add_flag("--json", args->json, "print a JSON report");
  add_input_options(*sub, args->in);
  add_output_options(*sub, args->out);
  sub->callback([args, &exit_code] { exit_code = run(*args); });
}

}  // namespace meshmark::cli
