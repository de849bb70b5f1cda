// Running a campaign: a (model, variant) calibrated to a protocol's limits, and the trials of
// one unit (an embedding, then every attack, decoded blind).

#include <fmt/format.h>

#include <chrono>
#include <map>

#include "campaign/campaign_internal.h"
#include "campaign/campaign_parts.h"
#include "meshmark/attacks/attack.h"
#include "meshmark/campaign/campaign.h"
#include "meshmark/core/error.h"
#include "meshmark/mark/decode.h"
#include "meshmark/metrics/metrics.h"

namespace meshmark {

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

}  // namespace

CalibrationRecord calibrate_for_campaign(const CampaignConfig& c, int model, int variant,
                                         const Mesh& mesh, int protocol) {
  CalibrationRecord r;
  r.model = c.models[model].name;
  r.variant = c.variants[variant];
  r.protocol = c.protocols[protocol].name;
  if (!c.calibrate) {
    r.status = "fixed";
    r.strength = c.strength;
    return r;
  }
  EmbedOptions eo = detail::scheme_options(r.variant);
  const CalibrateResult k = calibrate_strength(mesh.V, mesh.F, calibration_payload(c.bits, c.seed),
                                               eo, c.protocols[protocol].calibration);
  r.bin_offset = k.bin_offset;
  if (k.status == CalibrateStatus::BelowMinimum)
    r.cause = fmt::format("{}: {}", calibrate_cause_name(k.cause), k.diagnostics.front());
  r.status = calibrate_status_name(k.status);
  r.strength = k.strength;
  r.rms_percent = k.rms_percent;
  r.msdm = k.msdm;
  r.seconds = k.seconds;
  r.evaluations = k.evaluations;
  return r;
}

void run_campaign_unit(const CampaignConfig& c, const CampaignUnit& u, const Mesh& mesh,
                       const CalibrationRecord& record,
                       const std::function<bool(const std::string& key)>& done,
                       const std::function<void(const TrialRow&)>& emit) {
  if (c.trace) return detail::run_trace_unit(c, u, mesh, record, done, emit);
  const std::string& model = c.models[u.model].name;
  const std::string& variant = c.variants[u.variant];
  std::vector<detail::PlannedTrial> todo;
  for (detail::PlannedTrial& t : detail::plan_trials(c, u))
    if (!done(t.key)) todo.push_back(std::move(t));
  if (todo.empty()) return;
  const Payload payload = campaign_payload(c, u.payload);
  EmbedOptions eo = detail::scheme_options(variant);
  TrialRow base;
  base.model = model;
  base.variant = variant;
  base.payload = u.payload;
  base.protocol = c.protocols[u.protocol].name;
  base.strength = record.strength;
  Mesh marked = mesh;
  bool embedded = record.strength > 0;
  if (!embedded) base.status = "no strength meets the calibration limits";
  if (embedded) {
    eo.strength = record.strength;
    eo.bin_offset = record.bin_offset;
    const auto t0 = Clock::now();
    EmbedResult e;
    if (c.calibrate) {
      // Each copy its own strongest mark within the protocol's limits (as embed --fidelity
      // does): the (model, scheme) calibration of one payload does not hold for another one.
      CalibrateResult k =
          calibrate_strength(mesh.V, mesh.F, payload, eo, c.protocols[u.protocol].calibration);
      base.strength = k.strength;
      if (k.status == CalibrateStatus::BelowMinimum) {
        e.status = EmbedStatus::NotConverged;
        e.message = fmt::format("no strength meets the calibration limits for this payload ({})",
                                calibrate_cause_name(k.cause));
      } else {
        e = std::move(k.embedding);
      }
    } else {
      e = embed(mesh.V, mesh.F, payload, eo);
    }
    base.embed_seconds = since(t0);
    embedded = e.status == EmbedStatus::Embedded;
    if (embedded) {
      marked.V = e.V;
      base.rms_percent = e.rms_percent;
      base.msdm = msdm(mesh.V, e.V, mesh.F).global;
      base.status = "ok";
    } else {
      base.status = fmt::format("embedding {}: {}", embed_status_name(e.status), e.message);
    }
  }
  ExtractOptions xo;
  xo.bits = c.bits;
  xo.center = eo.variant.center;
  xo.method = eo.method;
  // A simplification series runs once for all its strengths (attack_simplify_levels gives
  // each what its own run would): its levels, and the time each one is charged (an equal share).
  std::map<const AttackSeries*, std::map<double, Mesh>> levels;
  std::map<const AttackSeries*, double> level_seconds;
  auto simplified = [&](const detail::PlannedTrial& t) -> const Mesh* {
    const AttackKind* kind = find_attack_kind(t.series->kind);  // nullptr for a chain
    if (!embedded || !kind || !kind->levels) return nullptr;
    auto it = levels.find(t.series);
    if (it == levels.end()) {
      std::vector<double> ratios;
      for (const detail::PlannedTrial& other : todo)
        if (other.series == t.series) ratios.push_back(other.strength);
      const auto t0 = Clock::now();
      std::vector<Mesh> meshes = kind->levels(marked, ratios);
      level_seconds[t.series] = since(t0) / static_cast<double>(ratios.size());
      it = levels.emplace(t.series, std::map<double, Mesh>{}).first;
      for (std::size_t r = 0; r < ratios.size(); ++r) it->second[ratios[r]] = std::move(meshes[r]);
    }
    return &it->second.at(t.strength);
  };
  for (const detail::PlannedTrial& t : todo) {
    TrialRow row = base;
    row.key = t.key;
    row.attack = series_label(*t.series);
    row.attack_strength = t.strength;
    row.draw = t.draw;
    row.ber = 0.5;
    if (embedded) {
      try {
        const auto t0 = Clock::now();
        const Mesh* level = simplified(t);
        const Mesh attacked = level ? *level : detail::attack_for_trial(c, t, marked);
        row.attack_seconds = level ? level_seconds[t.series] : since(t0);
        const auto t1 = Clock::now();
        const ExtractResult r = extract(attacked.V, attacked.F, xo);
        row.extract_seconds = since(t1);
        row.ber = bit_error_rate(r.bits, payload);
        row.erasures = r.erasures;
        row.vertices = static_cast<int>(attacked.V.rows());
      } catch (const Error& e) {
        row.status = fmt::format("attack failed: {}", e.what());
      }
    }
    emit(row);
  }
}

}  // namespace meshmark
