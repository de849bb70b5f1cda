// meshmark calibrate IN --variant V [--max-rms 0.04] [--max-msdm 0.25]: the largest strength
// within both limits, printed and kept in a cache (JSON lines) keyed by the mesh file's content
// hash, the variant and every setting, so that asking again answers at once.

#include <fmt/format.h>

#include <memory>
#include <nlohmann/json.hpp>

#include "cli.h"
#include "meshmark/campaign/calibration_cache.h"
#include "meshmark/carrier/variant.h"
#include "meshmark/core/error.h"
#include "progress.h"

namespace meshmark::cli {

namespace {

struct CalibrateArgs {
  std::string input, variant = "DRS", cache;
  Method method = Method::Qp;
  BinOffsetRule bin_offset_rule = BinOffsetRule::AtMostStrength;
  double bin_offset = 0.05;
  int bits = 64;
  CalibrateOptions options;
  InputOptions in;
  bool no_cache = false, json = false;
};

int run(const CalibrateArgs& a) {
  FileCalibrationOptions o;
  o.variant = parse_variant(a.variant);
  o.method = a.method;
  o.bits = a.bits;
  o.bin_offset = a.bin_offset;
  o.limits = a.options;
  o.limits.bin_offset = a.bin_offset_rule;
  o.read = read_options(a.in);
  o.cache = a.no_cache ? "" : a.cache.empty() ? default_calibration_cache() : a.cache;
  Progress progress(Progress::Bar, "");
  o.limits.progress = terminal_progress(progress, a.json);
  // An unreadable mesh is a ReadError (exit 2); a cache that cannot be written, a warning.
  const FileCalibration c = calibrate_file(a.input, o);
  progress.finish();
  if (!c.warning.empty()) fmt::print(stderr, "meshmark: warning: {}\n", printable(c.warning));
  if (a.json) {
    nlohmann::json j = nlohmann::json::parse(file_calibration_to_json(c));
    j["cached"] = c.cached;
    j["cache"] = o.cache;
    fmt::print("{}\n", j.dump(2));
  } else {
    fmt::print(
        "strength {:.5f}  bin offset {:.4f}  ({}: RMS {:.5f} % of the diagonal, MSDM {:.4f}; "
        "limits {} % and {}){}\n",
        c.strength, c.bin_offset, c.status, c.rms_percent, c.msdm, o.limits.max_rms_percent,
        o.limits.max_msdm, c.cached ? " [cached]" : "");
    for (const std::string& line : c.diagnostics) fmt::print("  {}\n", line);
    if (!o.cache.empty()) fmt::print("cache    {}\n", o.cache);
  }
  return c.strength > 0 ? kOk : kNotEmbedded;
}

}  // namespace

void register_calibrate(CLI::App& app, int& exit_code) {
  auto args = std::make_shared<CalibrateArgs>();
  CLI::App* sub = app.add_subcommand(
      "calibrate", "The largest strength whose distortion stays within RMS and MSDM limits");
  sub->add_option("IN", args->input, "mesh to calibrate on")->required();
  sub->add_option("--variant", args->variant, "variant (default DRS)");
  add_method_option(*sub, args->method, "who moves the vertices");
  sub->add_option("--bits", args->bits, "payload length in bits")->check(CLI::Range(1, kMaxBits));
  sub->add_option("--max-rms", args->options.max_rms_percent,
                  "vertex RMS limit, % of the bounding-box diagonal (default 0.04)")
      ->check(CLI::PositiveNumber);
  sub->add_option("--max-msdm", args->options.max_msdm, "MSDM limit (default 0.25)")
      ->check(CLI::PositiveNumber);
  sub->add_option("--iterations", args->options.iterations,
                  "search steps at most after the first two (default 12)")
      ->check(CLI::Range(1, 60));
  sub->add_option("--precision", args->options.precision,
                  "stop when the strength is known to this ratio, or the distortion is this "
                  "close to a limit (default 0.01)")
      ->check(CLI::Range(1e-4, 0.49));
  sub->add_flag(
      "--no-steer", [args](std::int64_t) { args->options.steer = false; },
      "measure every trial's MSDM in full (by default, on meshes of 16,384 vertices "
      "or more, the search steers on estimates and measures in full where it ends)");
  sub->add_option("--bin-offset", args->bin_offset,
                  "G in [0, 1/2): vertices stay in [G, 1-G] of their bin (default 0.05)")
      ->check(CLI::Range(0.0, 0.4999));
  add_enum_option<BinOffsetRule>(
      *sub, "--bin-offset-rule", args->bin_offset_rule,
      "at-most-strength (G = min(G, alpha), the default) or fixed (the paper's)");
  sub->add_option("--cache", args->cache,
                  "cache file (default $XDG_CACHE_HOME or ~/.cache/meshmark/calibration.jsonl)");
  sub->add_flag("--no-cache", args->no_cache, "neither read nor write the cache");
  sub->add_flag("--json", args->json, "print a JSON report");
  add_input_options(*sub, args->in);
  sub->callback([args, &exit_code] { exit_code = run(*args); });
}

}  // namespace meshmark::cli
