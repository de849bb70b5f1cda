// Calibrations of mesh files cached in JSON lines (calibration_cache.h).

#include "meshmark/campaign/calibration_cache.h"

#include <fmt/format.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "meshmark/campaign/campaign.h"
#include "meshmark/forensics/registry.h"
#include "meshmark/protocol/key.h"

namespace meshmark {

NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(FileCalibration, key, input, method, variant, bits,
                                                status, strength, bin_offset, bin_offset_rule,
                                                cause, diagnostics, rms_percent, msdm, evaluations,
                                                measurements, estimates, seconds, message)

namespace fs = std::filesystem;

std::string default_calibration_cache() {
  if (const char* d = std::getenv("XDG_CACHE_HOME"); d && *d)
    return (fs::path(d) / "meshmark" / "calibration.jsonl").string();
  if (const char* h = std::getenv("HOME"); h && *h)
    return (fs::path(h) / ".cache" / "meshmark" / "calibration.jsonl").string();
  return "meshmark-calibration.jsonl";
}

std::string file_calibration_to_json(const FileCalibration& calibration) {
  return nlohmann::json(calibration).dump();
}

FileCalibration calibrate_file(const std::string& path, const FileCalibrationOptions& options) {
  const CalibrateOptions& limits = options.limits;
  const std::string hash = content_hash(read_file(path)).substr(0, 32);
  const std::string key =
      fmt::format("{}|{}|{}|rms {}|msdm {}|range {} {}|steps {}|precision {}|G {} {}|{}|{}v4", hash,
                  options.variant.name(), options.bits, limits.max_rms_percent, limits.max_msdm,
                  limits.min_strength, limits.max_strength, limits.iterations, limits.precision,
                  options.bin_offset, bin_offset_rule_name(limits.bin_offset),
                  method_name(options.method), limits.steer ? "" : "full|");
  FileCalibration found;
  bool cached = false;
  if (!options.cache.empty() && fs::exists(options.cache)) {
    std::ifstream in(options.cache);
    for (std::string line; std::getline(in, line);) {
      try {
        const nlohmann::json j = nlohmann::json::parse(line);
        if (j.value("key", "") == key) found = j.get<FileCalibration>(), cached = true;
      } catch (const nlohmann::json::exception&) {
        // not a line of this cache: ignored
      }
    }
  }
  if (cached) {
    found.cached = true;
    return found;
  }
  const Mesh mesh = read_mesh(path, options.read);
  EmbedOptions eo;
  eo.variant = options.variant;
  eo.method = options.method;
  eo.bin_offset = options.bin_offset;
  const CalibrateResult r =
      calibrate_strength(mesh.V, mesh.F, calibration_payload(options.bits, 1), eo, limits);
  found.key = key;
  found.input = path;
  found.method = method_name(options.method);
  found.variant = options.variant.name();
  found.bits = options.bits;
  found.status = calibrate_status_name(r.status);
  found.strength = r.strength;
  found.bin_offset = r.bin_offset;
  found.bin_offset_rule = bin_offset_rule_name(limits.bin_offset);
  found.cause = calibrate_cause_name(r.cause);
  found.diagnostics = r.diagnostics;
  found.rms_percent = r.rms_percent;
  found.msdm = r.msdm;
  found.evaluations = r.evaluations;
  found.measurements = r.measurements;
  found.estimates = r.estimates;
  found.seconds = r.seconds;
  found.message = r.message;
  if (!options.cache.empty()) {
    std::error_code ec;
    const fs::path dir = fs::path(options.cache).parent_path();
    if (!dir.empty()) fs::create_directories(dir, ec);
    std::ofstream out(options.cache, std::ios::app);
    out << file_calibration_to_json(found) + "\n" << std::flush;
    if (!out) found.warning = fmt::format("{}: cannot save the calibration", options.cache);
  }
  return found;
}

}  // namespace meshmark
