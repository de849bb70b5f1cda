#pragma once
/// \file calibration_cache.h
/// Calibrations of mesh files kept in a cache (JSON lines), keyed by the file's content hash,
/// the variant, the method and every setting of the search, so that asking again for the same
/// file and settings answers at once. The cache only grows: each new calibration is appended
/// as one line; the last line with a key wins; a line that is not JSON is ignored.

#include <string>
#include <vector>

#include "meshmark/carrier/method.h"
#include "meshmark/carrier/variant.h"
#include "meshmark/io/io.h"
#include "meshmark/mark/calibrate.h"

namespace meshmark {

/// What calibrate_file calibrates.
struct FileCalibrationOptions {
  Variant variant;             ///< the embedding's variant (default DRS)
  Method method = Method::Qp;  ///< the embedding's method
  int bits = 64;               ///< payload length; the payload is calibration_payload(bits, 1)
  double bin_offset = 0.05;    ///< G asked for (the rule in limits.bin_offset may lower it)
  CalibrateOptions limits;     ///< the limits and the search's settings
  ReadOptions read;            ///< how the file is read
  std::string cache;           ///< the cache file; "": neither read nor written
};

/// One calibration of a file, as cached.
struct FileCalibration {
  std::string key;                       ///< the cache key: content hash and every setting
  std::string input;                     ///< the file's path as given when it was calibrated
  std::string method;                    ///< method_name
  std::string variant;                   ///< Variant::name
  int bits = 64;                         ///< payload length
  std::string status;                    ///< calibrate_status_name
  double strength = 0;                   ///< the strongest strength within the limits (0: none)
  double bin_offset = 0;                 ///< G of that embedding
  std::string bin_offset_rule;           ///< bin_offset_rule_name
  std::string cause;                     ///< calibrate_cause_name
  std::vector<std::string> diagnostics;  ///< the search's diagnostics
  double rms_percent = 0;  ///< vertex RMS at that strength, % of the bounding-box diagonal
  double msdm = 0;         ///< MSDM at that strength
  int evaluations = 0;     ///< embeddings tried
  int measurements = 0;    ///< full MSDM measurements among them
  int estimates = 0;       ///< MSDM estimates (CalibrateOptions::steer)
  double seconds = 0;      ///< the search's time
  std::string message;     ///< one line for a person
  bool cached = false;     ///< read from the cache instead of computed
  std::string warning;     ///< the calibration could not be saved in the cache, or ""
};

/// The default cache: $XDG_CACHE_HOME/meshmark/calibration.jsonl, else
/// ~/.cache/meshmark/calibration.jsonl, else meshmark-calibration.jsonl.
std::string default_calibration_cache();

/// The calibration of the mesh file at path with options: from the cache when it holds one
/// for the same content and settings, otherwise computed (calibrate_strength) and appended.
/// \throw IOError when the file cannot be read; the reader's errors for a malformed mesh.
FileCalibration calibrate_file(const std::string& path, const FileCalibrationOptions& options);

/// The cached form of a calibration (one JSON object, the cache's line).
std::string file_calibration_to_json(const FileCalibration& calibration);

}  // namespace meshmark
