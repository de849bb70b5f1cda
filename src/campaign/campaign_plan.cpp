// Campaign planning: the units (embeddings), their payloads, the trials of a unit with their
// keys and seeds, and the attack series they run.

#include <fmt/format.h>

#include <algorithm>
#include <cstdlib>

#include "campaign/campaign_internal.h"
#include "campaign/campaign_parts.h"
#include "meshmark/attacks/attack.h"
#include "meshmark/campaign/campaign.h"
#include "meshmark/carrier/method.h"
#include "meshmark/core/error.h"
#include "meshmark/core/random.h"

namespace meshmark {

namespace detail {
std::uint64_t seed_of(const std::string& text, std::uint64_t salt) {
  std::uint64_t h = 1469598103934665603ull ^ salt;  // FNV-1a
  for (const unsigned char c : text) h = (h ^ c) * 1099511628211ull;
  return Random(h).next();
}
}  // namespace detail

using detail::seed_of;

bool attack_is_deterministic(const std::string& kind) {
  return kind == "none" || attack_chain_is_deterministic(kind);
}

std::string coalition_name(const CampaignCoalition& k) {
  const char* kind = k.kind == CollusionKind::Splice ? "splice"
                     : k.weighted                    ? "weighted"
                                                     : "average";
  return fmt::format("{}:{}", kind, k.size);
}

CampaignCoalition parse_coalition(const std::string& name) {
  const std::size_t colon = name.find(':');
  const std::string kind = name.substr(0, colon);
  CampaignCoalition k;
  if (kind == "splice")
    k.kind = CollusionKind::Splice;
  else if (kind == "weighted")
    k.weighted = true;
  else if (kind != "average")
    throw InvalidArgumentError(
        fmt::format("coalition \"{}\": the kind is \"average\", \"weighted\" or \"splice\"", name));
  const std::string size = colon == std::string::npos ? "" : name.substr(colon + 1);
  if (size.empty() || size.size() > 2 ||
      !std::all_of(size.begin(), size.end(), [](char c) { return c >= '0' && c <= '9'; }))
    throw InvalidArgumentError(
        fmt::format("coalition \"{}\": write KIND:K, K the number of colluders (2 to 64)", name));
  k.size = std::stoi(size);
  if (k.size < 2 || k.size > 64)
    throw InvalidArgumentError(
        fmt::format("coalition \"{}\": {} colluders is out of 2..64", name, k.size));
  return k;
}

std::string coalition_label(const CampaignCoalition& k) {
  const char* kind = k.kind == CollusionKind::Splice ? "splice"
                     : k.weighted                    ? "unequal average"
                                                     : "average";
  return fmt::format("{} of {}", kind, k.size);
}

std::string remark_name(const CampaignRemark& r) {
  const std::string name =
      fmt::format("{}:{}", r.other_key ? "remark-key" : "remark", parse_scheme(r.scheme).name());
  return r.strength > 0 ? fmt::format("{}:{}", name, r.strength) : name;  // round-trip digits
}

CampaignRemark parse_remark(const std::string& name) {
  const std::size_t colon = name.find(':');
  const std::string kind = name.substr(0, colon);
  if ((kind != "remark" && kind != "remark-key") || colon == std::string::npos)
    throw InvalidArgumentError(fmt::format(
        "re-marking \"{}\": write remark:SCHEME or remark-key:SCHEME (another key), then "
        "optionally :STRENGTH",
        name));
  CampaignRemark r;
  r.other_key = kind == "remark-key";
  const std::string rest = name.substr(colon + 1);
  const std::size_t second = rest.find(':');
  try {
    r.scheme = parse_scheme(rest.substr(0, second)).name();
  } catch (const InvalidArgumentError& e) {
    throw InvalidArgumentError(fmt::format("re-marking \"{}\": {}", name, e.what()));
  }
  if (second != std::string::npos) {
    const std::string x = rest.substr(second + 1);
    char* end = nullptr;
    r.strength = std::strtod(x.c_str(), &end);
    if (x.empty() || end != x.c_str() + x.size() || !(r.strength > 0 && r.strength < 0.5))
      throw InvalidArgumentError(
          fmt::format("re-marking \"{}\": the strength \"{}\" is not in (0, 1/2)", name, x));
  }
  return r;
}

std::string remark_label(const CampaignRemark& r) {
  const std::string at = r.strength > 0 ? fmt::format(" at {}", r.strength) : "";
  return fmt::format("re-marked {}{} ({})", parse_scheme(r.scheme).name(), at,
                     r.other_key ? "another key" : "public key");
}

std::string innocent_name(CampaignInnocent innocent) {
  return fmt::format("innocent:{}", enum_name(innocent));
}

std::string innocent_label(CampaignInnocent innocent) {
  switch (innocent) {
    case CampaignInnocent::Unmarked:
      return "innocent: the original, unmarked";
    case CampaignInnocent::OtherKey:
      return "innocent: the leaker's ID under another key";
    case CampaignInnocent::WithoutLeaker:
      return "innocent: the leaker's copy, its row left out";
  }
  throw InvalidArgumentError("unknown innocent leak");
}

std::string trace_attack_label(const std::string& attack, double x, const std::string& coalition) {
  std::string a = attack == "none" ? "none" : fmt::format("{}:{:g}", attack, x);
  if (coalition.empty()) return a;
  if (coalition.starts_with("remark")) return remark_label(parse_remark(coalition)) + ", " + a;
  if (coalition.starts_with("innocent:"))
    return innocent_label(parse_enum<CampaignInnocent>(coalition.substr(9))) + ", " + a;
  return coalition_label(parse_coalition(coalition)) + ", " + a;
}

std::vector<AttackStep> series_chain(const std::string& kind, double x) {
  return parse_attack_chain(fmt::format("{}:{}", kind, x));
}

std::vector<AttackStep> series_chain(const AttackSeries& series, double x) {
  std::vector<AttackStep> steps = series_chain(series.kind, x);
  set_chain_params(steps, series.params);
  return steps;
}

std::string series_label(const AttackSeries& series) {
  const std::string params = attack_params_label(series.params);
  return params.empty() ? series.kind : fmt::format("{} [{}]", series.kind, params);
}

std::vector<CampaignUnit> campaign_units(const CampaignConfig& c) {
  std::vector<CampaignUnit> units;
  for (int m = 0; m < static_cast<int>(c.models.size()); ++m)
    for (int v = 0; v < static_cast<int>(c.variants.size()); ++v)
      for (int p = 0; p < c.payloads; ++p)
        for (int k = 0; k < static_cast<int>(c.protocols.size()); ++k)
          units.push_back({m, v, p, k});
  return units;
}

namespace {
int draws_of(const CampaignConfig& c, const AttackSeries& s) {
  if (s.draws > 0) return s.draws;
  return attack_is_deterministic(s.kind) ? 1 : c.draws;
}
}  // namespace

Payload campaign_payload(const CampaignConfig& c, int p) {
  return random_payload(c.bits, seed_of(fmt::format("payload {}", p), c.seed));
}

Payload calibration_payload(int bits, std::uint64_t seed) {
  return random_payload(bits, seed_of("calibration", seed));
}

std::string trial_key(const std::string& model, const std::string& variant, int payload,
                      const std::string& attack, double attack_strength, int draw,
                      const std::string& coalition, const std::string& protocol) {
  const std::string merged = coalition.empty()          ? ""
                             : coalition == "average:2" ? "|avg2"
                                                        : "|" + coalition;
  return fmt::format("{}|{}|{}|{}|{}|{}{}{}", model, variant, payload, attack, attack_strength,
                     draw, merged, protocol.empty() ? "" : "|" + protocol);
}

EmbedOptions detail::scheme_options(const std::string& scheme) {
  const MarkScheme s = parse_scheme(scheme);
  EmbedOptions eo;
  eo.method = s.method;
  eo.variant = s.variant;
  return eo;
}

std::vector<detail::PlannedTrial> detail::plan_trials(const CampaignConfig& c,
                                                      const CampaignUnit& u) {
  std::vector<PlannedTrial> trials;
  // nullptr: single copies (colluders 1 in trace mode, 0 in blind mode).
  std::vector<const CampaignCoalition*> leaks{nullptr};
  if (c.trace)
    for (const CampaignCoalition& k : c.coalitions) leaks.push_back(&k);
  const auto plan = [&](const CampaignCoalition* k, const CampaignRemark* r,
                        const CampaignInnocent* innocent) {
    const int colluders = k ? k->size : c.trace && !innocent ? 1 : 0;
    const std::string name = k          ? coalition_name(*k)
                             : r        ? remark_name(*r)
                             : innocent ? innocent_name(*innocent)
                                        : "";
    for (const AttackSeries& s : c.attacks)
      for (const double x : s.strengths)
        for (int d = 0; d < draws_of(c, s); ++d)
          trials.push_back({&s, x, d, colluders, k,
                            trial_key(c.models[u.model].name, c.variants[u.variant], u.payload,
                                      series_label(s), x, d, name, c.protocols[u.protocol].name),
                            r, innocent});
  };
  for (const CampaignCoalition* k : leaks) plan(k, nullptr, nullptr);
  if (c.trace) {
    for (const CampaignRemark& r : c.remarks) plan(nullptr, &r, nullptr);
    for (const CampaignInnocent& innocent : c.innocents) plan(nullptr, nullptr, &innocent);
  }
  return trials;
}

Mesh detail::attack_for_trial(const CampaignConfig& c, const PlannedTrial& t, const Mesh& mesh) {
  const std::uint64_t seed = seed_of(t.key, c.seed);
  if (t.series->kind == "none") return mesh;
  const std::vector<AttackStep> steps = series_chain(*t.series, t.strength);
  if (steps.size() == 1) return apply_attack(mesh, steps[0], seed);
  return apply_attack_chain(mesh, steps, seed);
}

std::vector<std::string> unit_trial_keys(const CampaignConfig& c, const CampaignUnit& u) {
  std::vector<std::string> keys;
  for (detail::PlannedTrial& t : detail::plan_trials(c, u)) keys.push_back(std::move(t.key));
  return keys;
}

}  // namespace meshmark
