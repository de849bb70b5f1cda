#pragma once
// Internal: the trials of a campaign unit, shared by the blind engine (campaign_plan.cpp,
// campaign_unit.cpp, campaign_report.cpp) and the trace mode (campaign_trace.cpp,
// campaign_trace_report.cpp).

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "campaign/campaign_parts.h"
#include "meshmark/mark/embed.h"

namespace meshmark::detail {

/// True when a row's outcome text (TrialRow::trace_outcome, ::blind_outcome) names `outcome`.
inline bool outcome_is(const std::string& text, TraceOutcome outcome) {
  return text == trace_outcome_name(outcome);
}

/// A seed per text (a trial's key): FNV-1a finished by SplitMix64, salted with the campaign's.
std::uint64_t seed_of(const std::string& text, std::uint64_t salt);

/// One trial to run: an attack series at one strength, one draw, on one copy or (trace mode)
/// the leak a coalition merges.
struct PlannedTrial {
  const AttackSeries* series = nullptr;
  double strength = 0;
  int draw = 0;
  int colluders = 0;                             ///< 0 in blind mode, else 1 or the coalition's
  const CampaignCoalition* coalition = nullptr;  ///< trace mode's merged leaks
  std::string key;
  const CampaignRemark* remark = nullptr;      ///< trace mode's re-marked leaks
  const CampaignInnocent* innocent = nullptr;  ///< trace mode's innocent leaks
};

/// The unit's trials in canonical order: attacks, strengths, draws, then (trace mode) every one
/// again for each coalition of the config, in its order, then for each re-marking, then for
/// each innocent leak.
std::vector<PlannedTrial> plan_trials(const CampaignConfig& config, const CampaignUnit& unit);

/// The trial's attack applied to mesh (a copy of it for "none"), seeded from its key.
Mesh attack_for_trial(const CampaignConfig& config, const PlannedTrial& trial, const Mesh& mesh);

/// The other key of "remark-key" re-markings (CampaignRemark::other_key), from the seed.
Key remarker_key(const CampaignConfig& config);

/// The leaker's copy re-marked as whoever leaks it would with meshmark (CampaignRemark): the
/// ID `id` coded into a histogram mark of the re-marking's scheme under the public key (as
/// `embed COPY OUT --id ID`), or under remarker_key with that key's fingerprint too (as `embed
/// --key-file OTHER --fingerprint`, the copy taken for the original). \throw
/// InvalidArgumentError when the re-mark cannot be embedded.
Mesh remarked_copy(const CampaignConfig& config, const CampaignRemark& remark, const Mesh& copy,
                   std::uint64_t id);

/// Trace mode's run_campaign_unit.
void run_trace_unit(const CampaignConfig& config, const CampaignUnit& unit, const Mesh& mesh,
                    const CalibrationRecord& record,
                    const std::function<bool(const std::string& key)>& done,
                    const std::function<void(const TrialRow&)>& emit);

/// The report's section comparing the campaign with the LIRIS benchmark's published results
/// (campaign_published.cpp): per protocol, the published columns of equal distortion beside
/// the variants' mean and median BER, for the series with the benchmark's attack definitions;
/// "" when the campaign has none of them.
std::string published_comparison(const CampaignConfig& config,
                                 const std::vector<SummaryRow>& summary);

/// Trace mode's write_campaign_report.
std::string write_trace_report(const std::string& dir, const CampaignConfig& config,
                               const std::vector<CalibrationRecord>& calibrations,
                               const std::vector<TrialRow>& rows, double wall_seconds);

/// The embedding options of a campaign's scheme name (a variant, or a Cho method: MarkScheme).
EmbedOptions scheme_options(const std::string& scheme);

}  // namespace meshmark::detail
