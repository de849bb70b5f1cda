// meshmark compare A B [--json] [--map OUT.ply]: distortion between two meshes.

#include <fmt/format.h>

#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>

#include "cli.h"
#include "meshmark/carrier/roughness.h"
#include "meshmark/core/error.h"
#include "meshmark/metrics/metrics.h"
#include "progress.h"

namespace meshmark::cli {

namespace {

struct CompareArgs {
  std::string a, b, map;
  InputOptions in;
  SurfaceDistanceOptions sampling;
  bool json = false;
};

int run(const CompareArgs& args) {
  const Mesh A = read_input(args.a, args.in), B = read_input(args.b, args.in);
  CompareOptions options;
  options.sampling = args.sampling;
  Progress progress(Progress::Bar, "");
  options.progress = terminal_progress(progress, args.json);
  const MeshComparison c = compare_meshes(A, B, options);
  progress.finish();
  const SurfaceDistance& d = c.surface;
  const PerceptualDistance& m2 = c.msdm2;
  nlohmann::json j = {{"a", args.a}, {"b", args.b}, {"same_connectivity", c.same_connectivity}};
  if (c.same_connectivity) {
    j["rms_percent"] = c.rms_percent;
    j["msdm"] = c.msdm;
  }
  j["mrms_percent"] = d.mrms_percent();
  j["hausdorff_percent"] = d.hausdorff_percent();
  j["rms_ab"] = d.rms_ab;
  j["rms_ba"] = d.rms_ba;
  j["hausdorff"] = d.hausdorff;
  j["msdm2"] = m2.global;
  if (!args.map.empty()) {
    write_heat_map(args.map, {args.a, args.b}, A, m2.local / std::max(m2.local.maxCoeff(), 1e-12));
    j["map"] = args.map;
  }
  if (args.json) {
    fmt::print("{}\n", j.dump(2));
    return kOk;
  }
  fmt::print("{} vs {}\n", printable(args.a), printable(args.b));
  if (c.same_connectivity) {
    fmt::print("  vertex RMS   {:.6f} % of the bounding-box diagonal\n",
               j["rms_percent"].get<double>());
    fmt::print("  MSDM         {:.6f}\n", j["msdm"].get<double>());
  }
  fmt::print("  MRMS         {:.6f} % (one-sided RMS {:.3g} and {:.3g})\n", d.mrms_percent(),
             d.rms_ab, d.rms_ba);
  fmt::print("  Hausdorff    {:.6f} % ({:.3g})\n", d.hausdorff_percent(), d.hausdorff);
  fmt::print("  MSDM2        {:.6f}\n", m2.global);
  if (!args.map.empty())
    fmt::print("  local MSDM2 map written to {} (red = most distorted)\n", printable(args.map));
  return kOk;
}

}  // namespace

void register_compare(CLI::App& app, int& exit_code) {
  auto args = std::make_shared<CompareArgs>();
  CLI::App* sub = app.add_subcommand(
      "compare", "Distortion between two meshes: vertex RMS, MRMS, Hausdorff, MSDM, MSDM2");
  sub->add_option("A", args->a, "reference mesh")->required();
  sub->add_option("B", args->b, "distorted mesh")->required();
  sub->add_option("--map", args->map, "write A with its local MSDM2 as vertex colors (PLY)");
  sub->add_option("--samples", args->sampling.samples,
                  "surface samples per mesh besides the vertices (0: auto)");
  sub->add_option("--seed", args->sampling.seed, "sampling seed");
  sub->add_flag("--json", args->json, "print a JSON report");
  add_input_options(*sub, args->in);
  sub->callback([args, &exit_code] { exit_code = run(*args); });
}

}  // namespace meshmark::cli
