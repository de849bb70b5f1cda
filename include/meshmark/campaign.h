#pragma once
/// \file campaign.h
/// Benchmark campaigns (../shared/spec/WATERMARK.md section 6): models x variants x payloads,
/// each embedding at its calibrated strength, then attacked at every strength of every attack
/// (several draws for random attacks) and decoded blind. One row per trial.
///
/// A campaign is described by a JSON file:
///
///     {"name": "quick", "bits": 64, "payloads": 6, "draws": 10, "seed": 1,
///      "models": ["${shared}/meshes/horse.ply", {"name": "fandisk", "path":
///      "${cgal}/fandisk.off"}], "variants": ["DRS", "SRS", "VRS"], "calibration": {"max_rms":
///      0.04, "max_msdm": 0.25, "iterations": 10}, "attacks": [{"kind": "noise", "strengths":
///      [0.001, 0.003]}, {"kind": "loop", "strengths": [1]}]}
///
/// "${shared}" is ../shared (MESHMARK_SHARED_DIR overrides), "${cgal}" libcgal-demo's unpacked
/// data/meshes (MESHMARK_CGAL_DATA overrides); other relative paths are relative to the file.
/// "strength": A instead of "calibration" embeds every model at alpha = A. Deterministic
/// attacks (quantization, smoothing, simplification, subdivision, format changes) run one draw.
/// Every trial is named by a key (model|variant|payload|attack|strength|draw) and seeded from
/// it, so a trial gives the same row whichever process, thread or order runs it.

#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "meshmark/calibrate.h"
#include "meshmark/mesh.h"

namespace meshmark {

/// One attack of a campaign at several strengths.
struct AttackSeries {
  std::string kind;               ///< an attack kind (attack.h), or "none"
  std::vector<double> strengths;  ///< at least one
  int draws = 0;                  ///< 0: the campaign's draws (1 for deterministic kinds)
};

/// A model of a campaign.
struct CampaignModel {
  std::string name;  ///< short name used in rows (the file's stem by default)
  std::string path;  ///< resolved path
};

/// A parsed campaign file.
struct CampaignConfig {
  std::string name;
  std::string source;  ///< the file it came from
  std::vector<CampaignModel> models;
  std::vector<std::string> variants;
  int bits = 64;
  int payloads = 6;
  int draws = 10;
  std::uint64_t seed = 1;
  bool calibrate = true;  ///< calibrate each (model, variant), else use `strength`
  double strength = 0.05;
  CalibrateOptions calibration;
  std::vector<AttackSeries> attacks;  ///< "none" (strength 0) is always added first
};

/// Reads a campaign file. \throw InvalidInputError naming the file and the bad key or value;
/// IOError when it cannot be read.
CampaignConfig load_campaign(const std::string& path);

/// True for attacks whose output does not depend on the seed.
bool attack_is_deterministic(const std::string& kind);

/// An embedding of the campaign: model, variant and payload indices.
struct CampaignUnit {
  int model = 0, variant = 0, payload = 0;
};

/// The units in a fixed order (model-major).
std::vector<CampaignUnit> campaign_units(const CampaignConfig& config);

/// The payload of index p (random, from the campaign's seed).
Payload campaign_payload(const CampaignConfig& config, int p);

/// The payload calibrations use (one per length and seed; `meshmark calibrate` uses seed 1).
Payload calibration_payload(int bits, std::uint64_t seed);

/// A calibrated strength of a (model, variant).
struct CalibrationRecord {
  std::string model, variant;
  std::string status;  ///< calibrate_status_name, or "fixed"
  double strength = 0, rms_percent = 0, msdm = 0, seconds = 0;
  int evaluations = 0;
};

/// One trial.
struct TrialRow {
  std::string key;  ///< model|variant|payload|attack|attack strength|draw
  std::string model, variant;
  int payload = 0;
  double strength = 0, rms_percent = 0, msdm = 0;  ///< embedding strength and distortions
  std::string attack;
  double attack_strength = 0;
  int draw = 0;
  int vertices = 0;  ///< of the attacked mesh
  double ber = 0;    ///< bit error rate (erasures count as errors); 0.5 when not decodable
  int erasures = 0;
  std::string status;  ///< "ok", or what failed (embedding, attack)
  double embed_seconds = 0, attack_seconds = 0, extract_seconds = 0;
};

/// The key of a trial.
std::string trial_key(const std::string& model, const std::string& variant, int payload,
                      const std::string& attack, double attack_strength, int draw);

/// The keys of a unit's trials, in canonical order (attacks, strengths, draws).
std::vector<std::string> unit_trial_keys(const CampaignConfig& config, const CampaignUnit& unit);

/// Runs every trial of one unit not already done, calling emit for each row (from the calling
/// thread). mesh is the unit's model, record its calibration.
void run_campaign_unit(const CampaignConfig& config, const CampaignUnit& unit, const Mesh& mesh,
                       const CalibrationRecord& record,
                       const std::function<bool(const std::string& key)>& done,
                       const std::function<void(const TrialRow&)>& emit);

/// Calibrates one (model, variant) as the campaign says (or records the fixed strength).
CalibrationRecord calibrate_for_campaign(const CampaignConfig& config, int model, int variant,
                                         const Mesh& mesh);

/// One JSON line (no newline) and back. from_json throws InvalidInputError on a bad line.
std::string row_to_json(const TrialRow& row);
TrialRow row_from_json(const std::string& line);
std::string calibration_to_json(const CalibrationRecord& record);
CalibrationRecord calibration_from_json(const std::string& line);

/// CSV header and one CSV line (no newline) of a row.
std::string csv_header();
std::string row_to_csv(const TrialRow& row);

/// The median bit error rate of one variant, attack and strength, as the paper reports it.
struct SummaryRow {
  std::string variant, attack;
  double attack_strength = 0;
  double median_ber = 0, mean_ber = 0;
  int trials = 0;
};

/// Medians over models, payloads and draws, in the order variants then attacks of the config.
std::vector<SummaryRow> summarize(const CampaignConfig& config, const std::vector<TrialRow>& rows);

/// Writes summary.csv, one SVG (and PNG when rsvg-convert is installed) per attack with the
/// median BER against strength, one curve per variant, a panel figure of all attacks, and
/// report.md (calibrations, distortions, medians, Loop table, timings, the published results
/// of section 8 beside DRS's). Returns the report's path.
std::string write_campaign_report(const std::string& dir, const CampaignConfig& config,
                                  const std::vector<CalibrationRecord>& calibrations,
                                  const std::vector<TrialRow>& rows, double wall_seconds);

}  // namespace meshmark
