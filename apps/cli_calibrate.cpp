// meshmark calibrate IN --variant V [--max-rms 0.04] [--max-msdm 0.25]: the largest strength
// within both limits, printed and kept in a cache (JSON lines) keyed by the mesh file's content
// hash, the variant and every setting, so that asking again answers at once.

#include <fmt/format.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>

#include "cli.h"
#include "meshmark/calibrate.h"
#include "meshmark/campaign.h"
#include "meshmark/error.h"
#include "meshmark/key.h"
#include "meshmark/variant.h"

namespace meshmark::cli {

namespace fs = std::filesystem;

namespace {

struct CalibrateArgs {
  std::string input, variant = "DRS", cache, bin_offset_rule = "at-most-strength", method = "qp";
  double bin_offset = 0.05;
  int bits = 64;
  CalibrateOptions options;
  InputOptions in;
  bool no_cache = false, json = false;
};

std::string default_cache() {
  if (const char* d = std::getenv("XDG_CACHE_HOME"); d && *d)
    return (fs::path(d) / "meshmark" / "calibration.jsonl").string();
  if (const char* h = std::getenv("HOME"); h && *h)
    return (fs::path(h) / ".cache" / "meshmark" / "calibration.jsonl").string();
  return "meshmark-calibration.jsonl";
}

// Content hash of the file (BLAKE2b-128 through the public key), hex.
std::string file_hash(const std::string& path) {
  std::string bytes;
  try {
    bytes = read_file(path);
  } catch (const IOError& e) {
    throw InputFailure(e.what());
  }
  const std::vector<std::uint8_t> data(bytes.begin(), bytes.end());
  const std::vector<std::uint8_t> bits =
      keyed_hash_bits(public_key(), "meshmark/file/v1", data, 128);
  return payload_to_hex(Payload{bits});
}

int run(const CalibrateArgs& a) {
  const Variant variant = parse_variant(a.variant);
  const Method method = parse_method(a.method);
  CalibrateOptions options = a.options;
  options.bin_offset =
      a.bin_offset_rule == "fixed" ? BinOffsetRule::Fixed : BinOffsetRule::AtMostStrength;
  const std::string key = fmt::format(
      "{}|{}|{}|rms {}|msdm {}|range {} {}|steps {}|precision {}|G {} {}|{}|v2", file_hash(a.input),
      variant.name(), a.bits, options.max_rms_percent, options.max_msdm, options.min_strength,
      options.max_strength, options.iterations, options.precision, a.bin_offset,
      bin_offset_rule_name(options.bin_offset), method_name(method));
  const std::string cache = a.cache.empty() ? default_cache() : a.cache;
  nlohmann::json found;
  if (!a.no_cache && fs::exists(cache)) {
    std::ifstream in(cache);
    for (std::string line; std::getline(in, line);) {
      try {
        const nlohmann::json j = nlohmann::json::parse(line);
        if (j.value("key", "") == key) found = j;  // the last entry wins
      } catch (const nlohmann::json::exception&) {
      }
    }
  }
  const bool cached = !found.is_null();
  if (!cached) {
    const Mesh mesh = read_input(a.input, a.in);
    EmbedOptions eo;
    eo.variant = variant;
    eo.method = method;
    eo.bin_offset = a.bin_offset;
    const CalibrateResult r =
        calibrate_strength(mesh.V, mesh.F, calibration_payload(a.bits, 1), eo, options);
    found = {{"key", key},
             {"input", a.input},
             {"method", method_name(method)},
             {"variant", variant.name()},
             {"bits", a.bits},
             {"status", calibrate_status_name(r.status)},
             {"strength", r.strength},
             {"bin_offset", r.bin_offset},
             {"bin_offset_rule", bin_offset_rule_name(options.bin_offset)},
             {"cause", calibrate_cause_name(r.cause)},
             {"diagnostics", r.diagnostics},
             {"rms_percent", r.rms_percent},
             {"msdm", r.msdm},
             {"evaluations", r.evaluations},
             {"seconds", r.seconds},
             {"message", r.message}};
    if (!a.no_cache) {
      std::error_code ec;
      fs::create_directories(
          fs::path(cache).parent_path().empty() ? fs::path(".") : fs::path(cache).parent_path(),
          ec);
      std::ofstream out(cache, std::ios::app);
      out << found.dump() << "\n";
      if (!out) fmt::print(stderr, "meshmark: warning: {}: cannot save the calibration\n", cache);
    }
  }
  const double strength = found["strength"].get<double>();
  if (a.json) {
    nlohmann::json j = found;
    j["cached"] = cached;
    j["cache"] = a.no_cache ? "" : cache;
    fmt::print("{}\n", j.dump(2));
  } else {
    fmt::print(
        "strength {:.5f}  bin offset {:.4f}  ({}: RMS {:.5f} % of the diagonal, MSDM {:.4f}; "
        "limits {} % and {}){}\n",
        strength, found.value("bin_offset", 0.0), found["status"].get<std::string>(),
        found["rms_percent"].get<double>(), found["msdm"].get<double>(), options.max_rms_percent,
        options.max_msdm, cached ? " [cached]" : "");
    for (const auto& line : found.value("diagnostics", nlohmann::json::array()))
      fmt::print("  {}\n", line.get<std::string>());
    if (!a.no_cache) fmt::print("cache    {}\n", cache);
  }
  return strength > 0 ? kOk : kNotEmbedded;
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
  sub->add_option("--bin-offset", args->bin_offset,
                  "G in [0, 1/2): vertices stay in [G, 1-G] of their bin (default 0.05)")
      ->check(CLI::Range(0.0, 0.4999));
  sub->add_option("--bin-offset-rule", args->bin_offset_rule,
                  "at-most-strength (G = min(G, alpha), the default) or fixed (the paper's)")
      ->check(CLI::IsMember({"fixed", "at-most-strength"}));
  sub->add_option("--cache", args->cache,
                  "cache file (default $XDG_CACHE_HOME or ~/.cache/meshmark/calibration.jsonl)");
  sub->add_flag("--no-cache", args->no_cache, "neither read nor write the cache");
  sub->add_flag("--json", args->json, "print a JSON report");
  add_input_options(*sub, args->in);
  sub->callback([args, &exit_code] { exit_code = run(*args); });
}

}  // namespace meshmark::cli
