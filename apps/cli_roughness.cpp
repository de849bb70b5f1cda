// meshmark roughness IN OUT.ply: the roughness field behind the S direction, as vertex colors.

#include <fmt/format.h>

#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>

#include "cli.h"
#include "meshmark/carrier/roughness.h"
#include "meshmark/core/error.h"

namespace meshmark::cli {

namespace {

struct RoughnessArgs {
  std::string input, output;
  InputOptions in;
  RoughnessOptions field;
  bool json = false;
};

int run(const RoughnessArgs& a) {
  require_ply(a.output);
  const Mesh mesh = read_input(a.input, a.in);
  const RoughnessField f = roughness_field(mesh.V, mesh.F, a.field);
  // Red where rough, blue where smooth.
  write_heat_map(a.output, {a.input}, mesh, Eigen::VectorXd(1 - f.smoothness.array()));
  const double smooth = (f.smoothness.array() > f.smooth_threshold).cast<double>().mean();
  if (a.json) {
    nlohmann::json j = {{"input", a.input},
                        {"output", a.output},
                        {"smooth_threshold", f.smooth_threshold},
                        {"smooth_fraction", smooth},
                        {"mean_smoothness", f.smoothness.mean()},
                        {"max_roughness", f.roughness.maxCoeff()}};
    fmt::print("{}\n", j.dump(2));
  } else {
    fmt::print("roughness field of {} written to {} (red rough, blue smooth)\n", a.input, a.output);
    fmt::print(
        "  smooth vertices  {:.1f} % (smoothness above {:.3f}, the S direction's threshold)\n",
        100 * smooth, f.smooth_threshold);
    fmt::print("  mean smoothness  {:.3f}\n", f.smoothness.mean());
  }
  return kOk;
}

}  // namespace

void register_roughness(CLI::App& app, int& exit_code) {
  auto args = std::make_shared<RoughnessArgs>();
  CLI::App* sub = app.add_subcommand(
      "roughness", "Write the local roughness field (direction S) as vertex colors");
  sub->add_option("IN", args->input, "input mesh")->required();
  sub->add_option("OUT", args->output, "output PLY with red/green/blue vertex colors")->required();
  sub->add_option("--curvature-radius", args->field.curvature_radius,
                  "curvature ball radius, fraction of the diagonal");
  sub->add_option("--smoothing-sigma", args->field.smoothing_sigma,
                  "smoothed copy's Gaussian, fraction of the diagonal");
  sub->add_option("--window-sigma", args->field.window_sigma,
                  "averaging window's Gaussian, fraction of the diagonal");
  sub->add_flag("--json", args->json, "print a JSON report");
  add_input_options(*sub, args->in);
  sub->callback([args, &exit_code] { exit_code = run(*args); });
}

}  // namespace meshmark::cli
