// Trace mode of the campaigns: copies issued to consecutive IDs, the leaker's copy embedded
// (and a colluder's), every attack traced with the original and decoded blind on the same
// attacked mesh, and the outcomes counted.

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <optional>

#include "campaign/campaign_internal.h"
#include "campaign/campaign_parts.h"
#include "meshmark/campaign/campaign.h"
#include "meshmark/carrier/histogram.h"
#include "meshmark/carrier/variant.h"
#include "meshmark/core/error.h"
#include "meshmark/forensics/fingerprint.h"
#include "meshmark/forensics/issue.h"
#include "meshmark/forensics/trace.h"
#include "meshmark/metrics/metrics.h"
#include "meshmark/protocol/coding.h"
#include "meshmark/protocol/watermark.h"

namespace meshmark {

using detail::seed_of;

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

std::string joined(const std::vector<std::uint64_t>& ids) {
  return fmt::format("{}", fmt::join(ids, " "));
}

}  // namespace

const char* trace_outcome_name(TraceOutcome outcome) {
  return enum_name(outcome);
}

TraceOutcome trace_outcome(const std::vector<std::uint64_t>& named,
                           const std::vector<std::uint64_t>& leakers) {
  if (named.empty()) return TraceOutcome::None;
  for (const std::uint64_t id : named)
    if (std::find(leakers.begin(), leakers.end(), id) == leakers.end()) return TraceOutcome::Wrong;
  return TraceOutcome::Right;
}

bool every_leaker_named(const std::vector<std::uint64_t>& named,
                        const std::vector<std::uint64_t>& leakers) {
  return trace_outcome(named, leakers) == TraceOutcome::Right && named.size() == leakers.size();
}

Key campaign_key(const CampaignConfig& c) {
  return key_from_passphrase_v1(fmt::format("meshmark campaign key, seed {}", c.seed));
}

std::uint64_t campaign_first_id(const CampaignConfig& c) {
  return seed_of("first issued ID", c.seed) % (std::uint64_t{1} << 31);
}

std::uint64_t campaign_leaker(const CampaignConfig& c, int p) {
  return campaign_first_id(c) +
         seed_of(fmt::format("leaker {}", p), c.seed) % static_cast<std::uint64_t>(c.copies);
}

std::vector<IssuedCopy> campaign_copies(const CampaignConfig& c, const std::string& model,
                                        const std::string& variant, double strength,
                                        double bin_offset) {
  const std::string fingerprint = key_fingerprint(campaign_key(c));
  std::vector<IssuedCopy> copies(c.copies);
  for (int i = 0; i < c.copies; ++i) {
    IssuedCopy& copy = copies[i];
    copy.id = campaign_first_id(c) + i;
    copy.buyer = fmt::format("buyer {}", copy.id);
    copy.original_path = model;
    copy.bits = c.bits;
    const MarkScheme scheme = parse_scheme(variant);
    copy.variant = scheme.variant.name();
    copy.method = method_name(scheme.method);
    copy.strength = strength;
    copy.bin_offset = bin_offset;
    copy.strength_spread = c.spread;
    copy.key_fingerprint = fingerprint;
    if (c.fingerprint) copy.mark_format = kFingerprintMarkFormat;
  }
  return copies;
}

namespace detail {

namespace {

// The leakers of a unit for coalitions of up to `most`: its leaker first, then the IDs after
// it up to the last issued, then those before it going down. The first K of them, a coalition
// of K, are K consecutive IDs.
std::vector<std::uint64_t> unit_leakers(const CampaignConfig& c, int payload, int most) {
  const std::uint64_t leaker = campaign_leaker(c, payload);
  const std::uint64_t last = campaign_first_id(c) + static_cast<std::uint64_t>(c.copies) - 1;
  std::vector<std::uint64_t> ids{leaker};
  for (std::uint64_t id = leaker + 1; id <= last && static_cast<int>(ids.size()) < most; ++id)
    ids.push_back(id);
  for (std::uint64_t id = leaker - 1; static_cast<int>(ids.size()) < most; --id) ids.push_back(id);
  return ids;
}

// Traces and decodes blind one attacked mesh, filling the row's outcomes: trace against the
// leakers among the copies, the blind decoder against the IDs the leak carries under the key
// (`carried`; the bit error rate against the first of them, or against `ber_id` without any).
void judge(const Mesh& attacked, const Mesh& original, const std::vector<IssuedCopy>& copies,
           const Key& key, const CampaignConfig& c, const EmbedOptions& scheme,
           const std::vector<std::uint64_t>& leakers, const std::vector<std::uint64_t>& carried,
           std::uint64_t ber_id, TrialRow& row) {
  const IdCode code(IdCodeOptions{c.bits});
  auto t0 = Clock::now();
  TraceOptions options;
  options.fingerprint_regions = c.fingerprint_regions;
  const TraceResult t = trace(attacked, original, copies, key, options);
  row.trace_seconds = since(t0);
  std::vector<std::uint64_t> named;
  for (const CandidateScore& s : t.named) named.push_back(s.copy.id);
  row.trace_outcome = trace_outcome_name(trace_outcome(named, leakers));
  row.trace_status = trace_status_name(t.status);
  row.trace_named = joined(named);
  row.trace_all_named = every_leaker_named(named, leakers);
  row.trace_p = t.ranking.empty() ? 1.0 : t.ranking.front().corrected_p;
  // The innocents: every candidate but the leakers (all of them issued, so all candidates), and
  // the best of them, the first innocent of the ranking (best first).
  const auto is_leaker = [&](std::uint64_t id) {
    return std::find(leakers.begin(), leakers.end(), id) != leakers.end();
  };
  // None when trace scored nobody (a failed registration, no candidate).
  const bool scored = t.status == TraceStatus::Named || t.status == TraceStatus::NoBuyer;
  row.innocents = !scored ? 0
                          : static_cast<int>(std::count_if(
                                copies.begin(), copies.end(),
                                [&](const IssuedCopy& copy) { return !is_leaker(copy.id); }));
  row.innocent_p = 1;
  for (const CandidateScore& s : t.ranking)
    if (!is_leaker(s.copy.id)) {
      row.innocent_p = s.corrected_p;
      break;
    }
  t0 = Clock::now();
  const IdReading blind = read_id(
      attacked.V, attacked.F,
      ExtractOptions{.bits = c.bits, .center = scheme.variant.center, .method = scheme.method},
      code, key);
  row.extract_seconds = since(t0);
  row.blind_outcome = trace_outcome_name(trace_outcome(
      blind.id.valid ? std::vector{blind.id.id} : std::vector<std::uint64_t>{}, carried));
  row.blind_id = blind.id.valid ? std::to_string(blind.id.id)
                                : fmt::format("no ID ({})", id_decode_status_name(blind.id.status));
  row.ber = bit_error_rate(blind.reading.bits,
                           code.encode(carried.empty() ? ber_id : carried.front(), key));
  row.erasures = blind.reading.extract.erasures;
}

// The fingerprint's RMS on the original of `frame`, as issue_copies raises it on a small one
// (fingerprint_rms), from the campaign's "fingerprint_rms".
double issued_fingerprint_rms(const CampaignConfig& c, const FingerprintFrame& frame) {
  FingerprintOptions o;
  o.rms = c.fingerprint_rms;
  return fingerprint_rms(
      static_cast<std::size_t>(std::count(frame.counted.begin(), frame.counted.end(), 1)), o);
}

}  // namespace

Key remarker_key(const CampaignConfig& c) {
  return key_from_passphrase_v1(fmt::format("meshmark campaign re-marker's key, seed {}", c.seed));
}

Mesh remarked_copy(const CampaignConfig& c, const CampaignRemark& r, const Mesh& copy,
                   std::uint64_t id) {
  const std::optional<Key> key = r.other_key ? std::optional<Key>(remarker_key(c)) : std::nullopt;
  const IdCode code(IdCodeOptions{c.bits});
  EmbedOptions eo = scheme_options(r.scheme);
  if (r.strength > 0) eo.strength = r.strength;
  eo.strengths = mark_strengths(key, c.bits, true, eo.strength, IssueSettings{}.strength_spread);
  EmbedResult e = embed(copy.V, copy.F, id_bins(code, id, key), eo);
  const std::optional<FingerprintFrame> frame =
      key ? fingerprint_frame(copy.V, copy.F, eo.variant.center, c.bits) : std::nullopt;
  // Another shop issues a copy whose histogram mark is infeasible as issue_copies does: with
  // the fingerprint alone.
  const bool alone = e.status == EmbedStatus::Infeasible && frame;
  if (alone) e.V = copy.V, e.status = EmbedStatus::Embedded;
  if (e.status != EmbedStatus::Embedded)
    throw InvalidArgumentError(fmt::format("re-marking {} with ID {}: {}: {}", remark_name(r), id,
                                           embed_status_name(e.status), e.message));
  Mesh out = copy;
  out.V = e.V;
  if (frame)
    out.V = add_fingerprint(
        e.V, copy.V, frame->basis, fingerprint_coefficients(*key, id, frame->basis.functions),
        issued_fingerprint_rms(c, *frame), &frame->histogram, &frame->center_motion);
  if (alone) {  // issued only when it can name its buyer, as issue_copies does
    IssuedCopy row;
    row.id = id, row.bits = c.bits, row.variant = eo.variant.name();
    row.method = method_name(eo.method);
    const SelfReading self = fingerprint_alone_reading(out, copy, row, *key);
    if (!self.nameable)
      throw InvalidArgumentError(fmt::format("re-marking {} with ID {}: {}: not issued",
                                             remark_name(r), id, self.message));
  }
  return out;
}

void run_trace_unit(const CampaignConfig& c, const CampaignUnit& u, const Mesh& mesh,
                    const CalibrationRecord& record,
                    const std::function<bool(const std::string& key)>& done,
                    const std::function<void(const TrialRow&)>& emit) {
  std::vector<PlannedTrial> todo;
  for (PlannedTrial& t : plan_trials(c, u))
    if (!done(t.key)) todo.push_back(std::move(t));
  if (todo.empty()) return;
  const std::string& model = c.models[u.model].name;
  const std::string& variant = c.variants[u.variant];
  const Key key = campaign_key(c);
  std::vector<IssuedCopy> copies =
      campaign_copies(c, model, variant, record.strength, record.bin_offset);
  int most = 1;
  for (const PlannedTrial& t : todo) most = std::max(most, t.colluders);
  const std::vector<std::uint64_t> pair = unit_leakers(c, u.payload, most);

  // The leaker's copy (and the colluders', when a coalition's trial is to run), keyed and coded
  // as `meshmark embed --id` makes them.
  EmbedOptions eo = scheme_options(variant);
  eo.strength = record.strength;
  eo.bin_offset = record.bin_offset;
  TrialRow base;
  base.model = model;
  base.variant = variant;
  base.payload = u.payload;
  base.strength = record.strength;
  base.status = record.strength > 0 ? "ok" : "no strength meets the calibration limits";
  std::vector<Mesh> marked;
  const IdCode code(IdCodeOptions{c.bits});
  eo.strengths = mark_strengths(key, c.bits, true, eo.strength, c.spread);
  std::optional<FingerprintFrame> frame;
  if (c.fingerprint && base.status == "ok") {
    frame = fingerprint_frame(mesh.V, mesh.F, eo.variant.center, c.bits);
    if (!frame) base.status = "too few vertices for a fingerprint";
  }
  for (std::size_t k = 0; k < pair.size() && base.status == "ok"; ++k) {
    const auto t0 = Clock::now();
    EmbedResult e = embed(mesh.V, mesh.F, id_bins(code, pair[k], key), eo);
    if (k == 0) base.embed_seconds = since(t0);
    const bool alone = e.status == EmbedStatus::Infeasible && frame;
    if (alone) {
      // As issue_copies issues it: the fingerprint alone, its row of strength 0.
      e.V = mesh.V, e.rms_percent = 0, e.status = EmbedStatus::Embedded;
      for (IssuedCopy& copy : copies)
        if (copy.id == pair[k]) copy.strength = 0, copy.bin_offset = 0;
      if (k == 0) base.strength = 0;
    }
    if (e.status != EmbedStatus::Embedded) {
      base.status =
          fmt::format("embedding ID {} {}: {}", pair[k], embed_status_name(e.status), e.message);
      break;
    }
    marked.push_back(mesh);
    marked.back().V = e.V;
    if (frame)  // as issue_copies adds it
      marked.back().V = add_fingerprint(
          e.V, mesh.V, frame->basis, fingerprint_coefficients(key, pair[k], frame->basis.functions),
          issued_fingerprint_rms(c, *frame), &frame->histogram, &frame->center_motion);
    if (alone) {  // and issues it only when it can name its buyer
      const auto row = std::find_if(copies.begin(), copies.end(),
                                    [&](const IssuedCopy& x) { return x.id == pair[k]; });
      const SelfReading self = fingerprint_alone_reading(marked.back(), mesh, *row, key);
      if (!self.nameable) {
        base.status = fmt::format("ID {}: {}: not issued", pair[k], self.message);
        break;
      }
    }
    if (k == 0) {
      base.rms_percent = e.rms_percent;
      if (frame) {  // both marks, as embed measures one (each position once)
        const std::vector<std::uint8_t> carrier = carrier_vertices(mesh.V, mesh.F);
        double sum = 0, n = 0;
        for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
          if (carrier[i] == kCounted)
            sum += (marked.back().V.row(i) - mesh.V.row(i)).squaredNorm(), n += 1;
        base.rms_percent = 100 * std::sqrt(sum / n) / bounding_box_diagonal(mesh.V, carrier);
      }
      base.msdm = msdm(mesh.V, marked.back().V, mesh.F).global;
    }
  }
  // The leak of a trial: the leaker's copy, or its coalition's merge (weights and regions drawn
  // from the trial's key), or an innocent leak.
  std::map<const CampaignRemark*, Mesh> remarked;  // once per re-marking, for all its attacks
  std::optional<Mesh> other_key;                   // the leaker's ID under another key
  Mesh merged;                                     // the last coalition's leak
  const auto leak_of = [&](const PlannedTrial& t) -> const Mesh& {
    if (t.innocent) {
      if (*t.innocent == CampaignInnocent::Unmarked) return mesh;
      if (*t.innocent == CampaignInnocent::WithoutLeaker) return marked[0];
      if (!other_key)  // as another shop would issue it: both marks under its own key
        other_key = remarked_copy(c, CampaignRemark{variant, record.strength, true}, mesh, pair[0]);
      return *other_key;
    }
    if (t.remark) {
      auto it = remarked.find(t.remark);
      if (it == remarked.end()) {
        const std::string name = remark_name(*t.remark);
        it = remarked
                 .emplace(t.remark, remarked_copy(c, *t.remark, marked[0],
                                                  seed_of(fmt::format("{}|{}|{}|{}", model, variant,
                                                                      u.payload, name),
                                                          c.seed) %
                                                      (std::uint64_t{1} << 31)))
                 .first;
      }
      return it->second;
    }
    if (!t.coalition) return marked[0];
    const std::vector<Mesh> coalition(marked.begin(), marked.begin() + t.colluders);
    const std::uint64_t seed = seed_of(t.key + "|coalition", c.seed);
    CollusionOptions o;
    o.kind = t.coalition->kind;
    if (t.coalition->weighted) o.weights = random_collusion_weights(t.colluders, seed);
    merged = attack_collude(coalition, o, seed);
    return merged;
  };
  // The registry without the leaker's row, when a CampaignInnocent::WithoutLeaker trial runs.
  std::vector<IssuedCopy> without;
  if (std::find(c.innocents.begin(), c.innocents.end(), CampaignInnocent::WithoutLeaker) !=
      c.innocents.end())
    for (const IssuedCopy& copy : copies)
      if (copy.id != pair[0]) without.push_back(copy);

  for (const PlannedTrial& t : todo) {
    TrialRow row = base;
    row.key = t.key;
    row.attack = series_label(*t.series);
    row.attack_strength = t.strength;
    row.draw = t.draw;
    row.colluders = t.colluders;
    row.coalition = t.coalition  ? coalition_name(*t.coalition)
                    : t.remark   ? remark_name(*t.remark)
                    : t.innocent ? innocent_name(*t.innocent)
                                 : "";
    const std::vector<std::uint64_t> leakers(pair.begin(), pair.begin() + t.colluders);
    row.leakers = joined(leakers);
    row.ber = 0.5;
    row.trace_outcome = row.blind_outcome = trace_outcome_name(TraceOutcome::None);
    if (base.status == "ok") {
      try {
        const auto t0 = Clock::now();
        const Mesh attacked = attack_for_trial(c, t, leak_of(t));
        row.attack_seconds = since(t0);
        row.vertices = static_cast<int>(attacked.V.rows());
        const bool without_leaker = t.innocent && *t.innocent == CampaignInnocent::WithoutLeaker;
        judge(attacked, mesh, without_leaker ? without : copies, key, c, eo, leakers,
              without_leaker ? std::vector<std::uint64_t>{pair[0]} : leakers, pair[0], row);
      } catch (const Error& e) {
        row.status = fmt::format("attack or trace failed: {}", e.what());
      }
    }
    emit(row);
  }
}

}  // namespace detail

std::vector<TraceSummaryRow> summarize_trace(const CampaignConfig& c,
                                             const std::vector<TrialRow>& rows) {
  std::map<std::string, std::vector<const TrialRow*>> groups;
  for (const TrialRow& r : rows)
    groups[fmt::format("{}|{}|{}", r.attack, r.attack_strength, r.coalition)].push_back(&r);
  std::vector<TraceSummaryRow> out;
  std::vector<std::string> leaks{""};
  for (const CampaignCoalition& k : c.coalitions) leaks.push_back(coalition_name(k));
  for (const CampaignRemark& r : c.remarks) leaks.push_back(remark_name(r));
  for (const CampaignInnocent i : c.innocents) leaks.push_back(innocent_name(i));
  for (const std::string& coalition : leaks)
    for (const AttackSeries& s : c.attacks)
      for (const double x : s.strengths) {
        const auto it = groups.find(fmt::format("{}|{}|{}", series_label(s), x, coalition));
        if (it == groups.end()) continue;
        TraceSummaryRow row;
        row.attack = series_label(s);
        row.attack_strength = x;
        row.coalition = coalition;
        row.colluders = it->second.front()->colluders;
        std::vector<double> seconds;
        for (const TrialRow* r : it->second) {
          if (r->status != "ok") {  // it did not run: no outcome to count
            ++row.failed;
            continue;
          }
          ++row.trials;
          row.trace_right += detail::outcome_is(r->trace_outcome, TraceOutcome::Right);
          row.trace_none += detail::outcome_is(r->trace_outcome, TraceOutcome::None);
          row.trace_wrong += detail::outcome_is(r->trace_outcome, TraceOutcome::Wrong);
          row.trace_all += r->trace_all_named;
          if (r->innocents > 0) {
            row.innocents += r->innocents;
            row.innocent_p = std::min(row.innocent_p, r->innocent_p);
          }
          row.blind_right += detail::outcome_is(r->blind_outcome, TraceOutcome::Right);
          row.blind_none += detail::outcome_is(r->blind_outcome, TraceOutcome::None);
          row.blind_wrong += detail::outcome_is(r->blind_outcome, TraceOutcome::Wrong);
          if (detail::outcome_is(r->trace_outcome, TraceOutcome::Right))
            row.worst_right_p = std::max(row.worst_right_p, r->trace_p);
          seconds.push_back(r->trace_seconds);
        }
        std::sort(seconds.begin(), seconds.end());
        row.median_trace_seconds = seconds.empty() ? 0 : seconds[seconds.size() / 2];
        out.push_back(row);
      }
  return out;
}

}  // namespace meshmark
