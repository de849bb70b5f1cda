#pragma once
// Internal: the parts run_campaign (campaign_run.h) is made of: planning (units, payloads,
// trial keys, the chains of a series), one unit's trials, calibration, trace mode's copies and
// the CSV lines. The tests call them one by one; users call campaign.h and campaign_run.h.

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "meshmark/campaign/campaign.h"

namespace meshmark {

/// True for "none" and for attacks (or chains, every step) whose output does not depend on the
/// seed (AttackKind::seeded). \throw InvalidArgumentError for an unknown kind or bad strength.
bool attack_is_deterministic(const std::string& kind);

/// The attack chain a series runs at strength x ("similarity:2,simplify" at 0.3:
/// "similarity:2,simplify:0.3"). \throw InvalidArgumentError naming a bad step.
std::vector<AttackStep> series_chain(const std::string& kind, double x);

/// The same with the series' parameters set on the steps that read them.
std::vector<AttackStep> series_chain(const AttackSeries& series, double x);

/// An embedding of the campaign: model, variant, payload and protocol indices.
struct CampaignUnit {
  int model = 0, variant = 0, payload = 0, protocol = 0;
};

/// The units in a fixed order (model-major, protocol-minor).
std::vector<CampaignUnit> campaign_units(const CampaignConfig& config);

/// The payload of index p (random, from the campaign's seed).
Payload campaign_payload(const CampaignConfig& config, int p);

/// The outcome of naming `named` when `leakers` leaked.
TraceOutcome trace_outcome(const std::vector<std::uint64_t>& named,
                           const std::vector<std::uint64_t>& leakers);

/// Whether naming `named` names every one of `leakers` (distinct IDs) and no innocent.
bool every_leaker_named(const std::vector<std::uint64_t>& named,
                        const std::vector<std::uint64_t>& leakers);

/// Trace mode: the key copies are issued under (from the campaign's seed).
Key campaign_key(const CampaignConfig& config);

/// Trace mode: the first of the consecutive IDs issued (from the seed, below 2^31).
std::uint64_t campaign_first_id(const CampaignConfig& config);

/// Trace mode: the leaker of payload index p, one of the issued IDs (from the seed).
std::uint64_t campaign_leaker(const CampaignConfig& config, int p);

/// Trace mode: the records of the copies issued from a model in variant at strength (alpha)
/// and bin offset G, as a registry would list them: config.copies consecutive IDs from
/// campaign_first_id, keyed with campaign_key, config.bits bits, 32-bit IDs, config.spread.
std::vector<IssuedCopy> campaign_copies(const CampaignConfig& config, const std::string& model,
                                        const std::string& variant, double strength,
                                        double bin_offset = 0.05);

/// The key of a trial; a coalition (trace mode, its coalition_name) appends "|avg2" for
/// "average:2" (as keys always had), else "|" and its name; a named protocol "|" and its name.
std::string trial_key(const std::string& model, const std::string& variant, int payload,
                      const std::string& attack, double attack_strength, int draw,
                      const std::string& coalition = "", const std::string& protocol = "");

/// The keys of a unit's trials, in canonical order (attacks, strengths, draws).
std::vector<std::string> unit_trial_keys(const CampaignConfig& config, const CampaignUnit& unit);

/// Runs every trial of one unit not already done, calling emit for each row (from the calling
/// thread). mesh is the unit's model, record its calibration.
void run_campaign_unit(const CampaignConfig& config, const CampaignUnit& unit, const Mesh& mesh,
                       const CalibrationRecord& record,
                       const std::function<bool(const std::string& key)>& done,
                       const std::function<void(const TrialRow&)>& emit);

/// Calibrates one (model, variant) to the limits of protocol (an index into config.protocols),
/// or records the fixed strength.
CalibrationRecord calibrate_for_campaign(const CampaignConfig& config, int model, int variant,
                                         const Mesh& mesh, int protocol = 0);

/// CSV header and one CSV line (no newline) of a row (its protocol last); trace adds the trace
/// mode's columns.
std::string csv_header(bool trace = false);
std::string row_to_csv(const TrialRow& row, bool trace = false);

}  // namespace meshmark
