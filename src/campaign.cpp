#include "meshmark/campaign.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <set>

#include "campaign_internal.h"
#include "meshmark/attack.h"
#include "meshmark/coding.h"
#include "meshmark/decode.h"
#include "meshmark/error.h"
#include "meshmark/io.h"
#include "meshmark/metrics.h"
#include "meshmark/random.h"
#include "meshmark/variant.h"

#ifndef MESHMARK_DEFAULT_SHARED_DIR
#define MESHMARK_DEFAULT_SHARED_DIR "../shared"
#endif
#ifndef MESHMARK_DEFAULT_CGAL_DATA
#define MESHMARK_DEFAULT_CGAL_DATA "build/cgal-data/data/meshes"
#endif

namespace meshmark {

namespace detail {
std::uint64_t seed_of(const std::string& text, std::uint64_t salt) {
  std::uint64_t h = 1469598103934665603ull ^ salt;  // FNV-1a
  for (const unsigned char c : text) h = (h ^ c) * 1099511628211ull;
  return Random(h).next();
}
}  // namespace detail

namespace fs = std::filesystem;
using detail::seed_of;
using nlohmann::json;

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

std::string expand(std::string path, const fs::path& base) {
  auto replace = [&](const std::string& token, const char* env, const char* fallback) {
    const char* value = std::getenv(env);
    const std::string with = value && *value ? value : fallback;
    for (std::size_t at; (at = path.find(token)) != std::string::npos;)
      path.replace(at, token.size(), with);
  };
  replace("${shared}", "MESHMARK_SHARED_DIR", MESHMARK_DEFAULT_SHARED_DIR);
  replace("${cgal}", "MESHMARK_CGAL_DATA", MESHMARK_DEFAULT_CGAL_DATA);
  fs::path p(path);
  if (p.is_relative()) p = base / p;
  return p.lexically_normal().string();
}

[[noreturn]] void bad(const std::string& file, const std::string& what) {
  throw InvalidInputError(file, 0, what);
}

void check_keys(const std::string& file, const json& object, const std::string& where,
                std::initializer_list<const char*> allowed) {
  for (auto it = object.begin(); it != object.end(); ++it)
    if (std::none_of(allowed.begin(), allowed.end(), [&](const char* k) { return it.key() == k; }))
      bad(file, fmt::format("{}: unknown key \"{}\"", where, it.key()));
}

std::string csv_quote(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string out = "\"";
  for (const char c : s) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

// A series' kind is an attack kind, or a chain whose last step is one without a strength (the
// series' strengths go there); every strength must make a valid chain.
void check_series(const std::string& file, const std::string& where, const AttackSeries& s) {
  const std::string last = s.kind.substr(s.kind.rfind(',') + 1);
  const auto& kinds = attack_kinds();
  if (last.find(':') != std::string::npos)
    bad(file, fmt::format("{}: the last step of the chain \"{}\" takes the strengths: write it "
                          "without \":\"",
                          where, s.kind));
  if (std::none_of(kinds.begin(), kinds.end(), [&](const auto& k) { return k.first == last; }))
    bad(file, fmt::format("{}: unknown attack kind \"{}\"", where, last));
  for (const double x : s.strengths) try {
      (void)series_chain(s.kind, x);
    } catch (const Error& e) {
      bad(file, fmt::format("{}: strength {}: {}", where, x, e.what()));
    }
}

// An attack series' parameters (AttackParams) beside its kind.
void read_series_params(const std::string& file, const std::string& where, const json& a,
                        AttackSeries& s) {
  AttackParams& p = s.params;
  p.lambda = a.value("lambda", 0.0);
  p.mu = a.value("mu", 0.0);
  p.fixed_boundary = a.value("fixed_boundary", false);
  try {
    if (a.contains("weighting"))
      p.weighting = parse_smooth_weighting(a["weighting"].get<std::string>());
    if (a.contains("convention"))
      p.convention = parse_quantize_convention(a["convention"].get<std::string>());
    for (const double x : s.strengths) (void)series_chain(s, x);
  } catch (const InvalidArgumentError& e) {
    bad(file, fmt::format("{}: {}", where, e.what()));
  }
}

// The calibration limits: "calibration", and "protocols" each overriding it.
void read_protocols(const std::string& file, const json& j, CampaignConfig& c) {
  auto limits = [&](const json& k, const std::string& where, CalibrateOptions o) {
    check_keys(file, k, where,
               {"name", "max_rms", "max_msdm", "iterations", "min", "max", "bin_offset"});
    const std::string rule = k.value("bin_offset", bin_offset_rule_name(o.bin_offset));
    if (rule != "fixed" && rule != "at-most-strength")
      bad(file, fmt::format("{}: bin_offset '{}' is not fixed or at-most-strength", where, rule));
    o.bin_offset = rule == "fixed" ? BinOffsetRule::Fixed : BinOffsetRule::AtMostStrength;
    o.max_rms_percent = k.value("max_rms", o.max_rms_percent);
    o.max_msdm = k.value("max_msdm", o.max_msdm);
    o.iterations = k.value("iterations", o.iterations);
    o.min_strength = k.value("min", o.min_strength);
    o.max_strength = k.value("max", o.max_strength);
    return o;
  };
  if (j.contains("calibration")) {
    if (j["calibration"].contains("name")) bad(file, "calibration: unknown key \"name\"");
    c.calibration = limits(j["calibration"], "calibration", c.calibration);
  }
  if (!j.contains("protocols")) {
    c.protocols = {{"", c.calibration}};
    return;
  }
  if (!c.calibrate) bad(file, "\"protocols\" needs calibration, not a fixed \"strength\"");
  if (j.value("mode", "blind") == "trace") bad(file, "\"protocols\" needs \"mode\": \"blind\"");
  const json& list = j["protocols"];
  if (!list.is_array() || list.empty()) bad(file, "\"protocols\" must be a non-empty array");
  std::set<std::string> names;
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::string where = fmt::format("protocols[{}]", i);
    if (!list[i].is_object()) bad(file, where + " is not an object");
    CampaignProtocol p{list[i].value("name", ""), limits(list[i], where, c.calibration)};
    if (p.name.empty() || p.name.find_first_of("|,\"") != std::string::npos)
      bad(file, where + ": \"name\" must be non-empty, without | , or \"");
    if (!names.insert(p.name).second)
      bad(file, fmt::format("{}: the name \"{}\" is used twice", where, p.name));
    c.protocols.push_back(p);
  }
  c.calibration = c.protocols.front().calibration;
}

// The trace mode's settings ("mode", "copies", "collusion", "spread"), refused in blind mode.
void read_trace_settings(const std::string& file, const json& j, CampaignConfig& c) {
  const std::string mode = j.value("mode", "blind");
  if (mode != "blind" && mode != "trace")
    bad(file, fmt::format("mode \"{}\" is neither \"blind\" nor \"trace\"", mode));
  c.trace = mode == "trace";
  for (const char* k : {"copies", "collusion", "spread"})
    if (!c.trace && j.contains(k)) bad(file, fmt::format("\"{}\" needs \"mode\": \"trace\"", k));
  if (!c.trace) return;
  c.copies = j.value("copies", c.copies);
  c.collusion = j.value("collusion", c.collusion);
  c.spread = j.value("spread", c.spread);
  if (c.copies < 2 || c.copies > 1000000)
    bad(file, fmt::format("copies {} is out of 2..1000000", c.copies));
  if (!(c.spread >= 0 && c.spread <= 4))
    bad(file, fmt::format("spread {} is out of [0, 4]", c.spread));
  try {
    (void)IdCode(IdCodeOptions{c.bits});
  } catch (const InvalidArgumentError& e) {
    bad(file, fmt::format("bits {} cannot carry a 32-bit ID: {}", c.bits, e.what()));
  }
}

}  // namespace

bool attack_is_deterministic(const std::string& kind) {
  static const std::set<std::string> fixed = {
      "none",  "quant",   "smooth", "taubin", "simplify", "loop",   "midpoint",
      "sqrt3", "float32", "to-obj", "to-off", "to-stl",   "remesh", "qsimplify"};
  for (std::size_t start = 0; start <= kind.size();) {  // every step of a chain
    const std::size_t end = std::min(kind.find(',', start), kind.size());
    const std::string step = kind.substr(start, end - start);
    if (!fixed.count(step.substr(0, step.find(':')))) return false;
    start = end + 1;
  }
  return true;
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

CampaignConfig load_campaign(const std::string& path) {
  const std::string text = read_file(path);
  json j;
  try {
    j = json::parse(text);
  } catch (const json::parse_error& e) {
    bad(path, fmt::format("not valid JSON (byte {}): {}", e.byte, e.what()));
  }
  if (!j.is_object()) bad(path, "a campaign is a JSON object");
  check_keys(
      path, j, "campaign",
      {"name", "description", "models", "variants", "bits", "payloads", "draws", "seed",
       "calibration", "protocols", "strength", "attacks", "mode", "copies", "collusion", "spread"});
  const fs::path base = fs::absolute(path).parent_path();
  CampaignConfig c;
  c.source = path;
  try {
    c.name = j.value("name", fs::path(path).stem().string());
    c.bits = j.value("bits", 64);
    c.payloads = j.value("payloads", 6);
    c.draws = j.value("draws", 10);
    c.seed = j.value("seed", std::uint64_t{1});
    if (c.bits < 1 || c.bits > 4096) bad(path, fmt::format("bits {} is out of 1..4096", c.bits));
    if (c.payloads < 1) bad(path, "payloads must be at least 1");
    if (c.draws < 1) bad(path, "draws must be at least 1");
    if (!j.contains("models") || !j["models"].is_array() || j["models"].empty())
      bad(path, "\"models\" must be a non-empty array");
    std::set<std::string> names;
    for (std::size_t i = 0; i < j["models"].size(); ++i) {
      const json& m = j["models"][i];
      CampaignModel model;
      if (m.is_string()) {
        model.path = expand(m.get<std::string>(), base);
      } else if (m.is_object()) {
        check_keys(path, m, fmt::format("models[{}]", i), {"name", "path"});
        if (!m.contains("path")) bad(path, fmt::format("models[{}] has no \"path\"", i));
        model.path = expand(m["path"].get<std::string>(), base);
        model.name = m.value("name", "");
      } else {
        bad(path, fmt::format("models[{}] is neither a path nor an object", i));
      }
      if (model.name.empty()) model.name = fs::path(model.path).stem().string();
      if (!fs::is_regular_file(model.path))
        bad(path, fmt::format("models[{}]: {} does not exist", i, model.path));
      if (!names.insert(model.name).second)
        bad(path, fmt::format("models[{}]: the name \"{}\" is used twice", i, model.name));
      c.models.push_back(model);
    }
    if (!j.contains("variants") || !j["variants"].is_array() || j["variants"].empty())
      bad(path, "\"variants\" must be a non-empty array");
    for (const json& v : j["variants"]) {
      const std::string name = v.get<std::string>();
      try {
        c.variants.push_back(parse_scheme(name).name());
      } catch (const InvalidArgumentError& e) {
        bad(path, fmt::format("variant \"{}\": {}", name, e.what()));
      }
    }
    if (j.contains("strength") && j.contains("calibration"))
      bad(path, "give \"strength\" or \"calibration\", not both");
    if (j.contains("strength")) {
      c.calibrate = false;
      c.strength = j["strength"].get<double>();
      if (!(c.strength > 0 && c.strength < 0.5))
        bad(path, fmt::format("strength {} is out of (0, 1/2)", c.strength));
    }
    read_protocols(path, j, c);
    c.attacks.push_back({"none", {0.0}, 1, {}});
    if (j.contains("attacks")) {
      if (!j["attacks"].is_array()) bad(path, "\"attacks\" must be an array");
      for (std::size_t i = 0; i < j["attacks"].size(); ++i) {
        const json& a = j["attacks"][i];
        const std::string where = fmt::format("attacks[{}]", i);
        if (!a.is_object()) bad(path, where + " is not an object");
        check_keys(path, a, where,
                   {"kind", "strengths", "draws", "lambda", "mu", "fixed_boundary", "weighting",
                    "convention"});
        AttackSeries s;
        s.kind = a.value("kind", "");
        if (s.kind == "none") continue;  // always there
        if (!a.contains("strengths") || !a["strengths"].is_array() || a["strengths"].empty())
          bad(path, where + ": \"strengths\" must be a non-empty array");
        s.strengths = a["strengths"].get<std::vector<double>>();
        s.draws = a.value("draws", 0);
        check_series(path, where, s);
        read_series_params(path, where, a, s);
        if (std::any_of(c.attacks.begin(), c.attacks.end(),
                        [&](const AttackSeries& o) { return series_label(o) == series_label(s); }))
          bad(path, fmt::format("{}: a second series \"{}\"", where, series_label(s)));
        c.attacks.push_back(s);
      }
    }
    read_trace_settings(path, j, c);
  } catch (const json::exception& e) {
    bad(path, fmt::format("a value has the wrong type: {}", e.what()));
  }
  return c;
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
                      const std::string& attack, double attack_strength, int draw, int colluders,
                      const std::string& protocol) {
  return fmt::format("{}|{}|{}|{}|{}|{}{}{}", model, variant, payload, attack, attack_strength,
                     draw, colluders == 2 ? "|avg2" : "", protocol.empty() ? "" : "|" + protocol);
}

EmbedOptions detail::scheme_options(const std::string& scheme) {
  const MarkScheme s = parse_scheme(scheme);
  EmbedOptions eo;
  eo.method = s.method;
  eo.variant = s.variant;
  return eo;
}

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

std::vector<detail::PlannedTrial> detail::plan_trials(const CampaignConfig& c,
                                                      const CampaignUnit& u) {
  std::vector<PlannedTrial> trials;
  const std::vector<int> colluders = !c.trace      ? std::vector<int>{0}
                                     : c.collusion ? std::vector<int>{1, 2}
                                                   : std::vector<int>{1};
  for (const int n : colluders)
    for (const AttackSeries& s : c.attacks)
      for (const double x : s.strengths)
        for (int d = 0; d < draws_of(c, s); ++d)
          trials.push_back({&s, x, d, n,
                            trial_key(c.models[u.model].name, c.variants[u.variant], u.payload,
                                      series_label(s), x, d, n, c.protocols[u.protocol].name)});
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
    const std::string& k = t.series->kind;
    if (!embedded || (k != "simplify" && k != "qsimplify")) return nullptr;
    auto it = levels.find(t.series);
    if (it == levels.end()) {
      std::vector<double> ratios;
      for (const detail::PlannedTrial& u : todo)
        if (u.series == t.series) ratios.push_back(u.strength);
      const auto t0 = Clock::now();
      std::vector<Mesh> meshes = attack_simplify_levels(
          marked, ratios,
          k == "simplify" ? SimplifyCost::LindstromTurk : SimplifyCost::GarlandHeckbert);
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

std::string row_to_json(const TrialRow& r) {
  const json j = {{"key", r.key},
                  {"model", r.model},
                  {"variant", r.variant},
                  {"payload", r.payload},
                  {"strength", r.strength},
                  {"rms_percent", r.rms_percent},
                  {"msdm", r.msdm},
                  {"attack", r.attack},
                  {"attack_strength", r.attack_strength},
                  {"draw", r.draw},
                  {"vertices", r.vertices},
                  {"ber", r.ber},
                  {"erasures", r.erasures},
                  {"status", r.status},
                  {"embed_seconds", r.embed_seconds},
                  {"attack_seconds", r.attack_seconds},
                  {"extract_seconds", r.extract_seconds}};
  json t = j;
  if (!r.protocol.empty()) t["protocol"] = r.protocol;
  if (r.colluders == 0) return t.dump();
  t.update({{"colluders", r.colluders},
            {"leakers", r.leakers},
            {"trace_outcome", r.trace_outcome},
            {"trace_status", r.trace_status},
            {"trace_named", r.trace_named},
            {"trace_p", r.trace_p},
            {"blind_outcome", r.blind_outcome},
            {"blind_id", r.blind_id},
            {"trace_seconds", r.trace_seconds}});
  return t.dump();
}

TrialRow row_from_json(const std::string& line) {
  try {
    const json j = json::parse(line);
    TrialRow r;
    r.key = j.at("key").get<std::string>();
    r.model = j.at("model").get<std::string>();
    r.variant = j.at("variant").get<std::string>();
    r.payload = j.at("payload").get<int>();
    r.strength = j.at("strength").get<double>();
    r.rms_percent = j.at("rms_percent").get<double>();
    r.msdm = j.at("msdm").get<double>();
    r.attack = j.at("attack").get<std::string>();
    r.attack_strength = j.at("attack_strength").get<double>();
    r.draw = j.at("draw").get<int>();
    r.vertices = j.at("vertices").get<int>();
    r.ber = j.at("ber").get<double>();
    r.erasures = j.at("erasures").get<int>();
    r.status = j.at("status").get<std::string>();
    r.embed_seconds = j.at("embed_seconds").get<double>();
    r.attack_seconds = j.at("attack_seconds").get<double>();
    r.extract_seconds = j.at("extract_seconds").get<double>();
    r.protocol = j.value("protocol", "");
    if (!j.contains("colluders")) return r;
    r.colluders = j.at("colluders").get<int>();
    r.leakers = j.at("leakers").get<std::string>();
    r.trace_outcome = j.at("trace_outcome").get<std::string>();
    r.trace_status = j.at("trace_status").get<std::string>();
    r.trace_named = j.at("trace_named").get<std::string>();
    r.trace_p = j.at("trace_p").get<double>();
    r.blind_outcome = j.at("blind_outcome").get<std::string>();
    r.blind_id = j.at("blind_id").get<std::string>();
    r.trace_seconds = j.at("trace_seconds").get<double>();
    return r;
  } catch (const json::exception& e) {
    throw InvalidInputError("rows", 0, fmt::format("not a campaign row: {}", e.what()));
  }
}

std::string calibration_to_json(const CalibrationRecord& r) {
  json j{{"model", r.model},       {"variant", r.variant},         {"status", r.status},
         {"strength", r.strength}, {"rms_percent", r.rms_percent}, {"msdm", r.msdm},
         {"seconds", r.seconds},   {"evaluations", r.evaluations}, {"bin_offset", r.bin_offset}};
  if (!r.protocol.empty()) j["protocol"] = r.protocol;
  if (!r.cause.empty()) j["cause"] = r.cause;
  return j.dump();
}

CalibrationRecord calibration_from_json(const std::string& line) {
  try {
    const json j = json::parse(line);
    CalibrationRecord r;
    r.model = j.at("model").get<std::string>();
    r.variant = j.at("variant").get<std::string>();
    r.status = j.at("status").get<std::string>();
    r.strength = j.at("strength").get<double>();
    r.rms_percent = j.at("rms_percent").get<double>();
    r.msdm = j.at("msdm").get<double>();
    r.seconds = j.at("seconds").get<double>();
    r.evaluations = j.at("evaluations").get<int>();
    r.protocol = j.value("protocol", "");
    r.bin_offset = j.value("bin_offset", 0.05);  // records before G was searched: the paper's
    r.cause = j.value("cause", "");
    return r;
  } catch (const json::exception& e) {
    throw InvalidInputError("calibrations", 0, fmt::format("not a calibration: {}", e.what()));
  }
}

std::string csv_header(bool trace) {
  return std::string(
             "model,variant,payload,strength,rms_percent,msdm,attack,attack_strength,draw,"
             "vertices,ber,erasures,status,embed_seconds,attack_seconds,extract_seconds,protocol") +
         (trace ? ",colluders,leakers,trace_outcome,trace_status,trace_named,trace_p,"
                  "blind_outcome,blind_id,trace_seconds"
                : "");
}

std::string row_to_csv(const TrialRow& r, bool trace) {
  std::string line =
      fmt::format("{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}", csv_quote(r.model),
                  csv_quote(r.variant), r.payload, r.strength, r.rms_percent, r.msdm,
                  csv_quote(r.attack), r.attack_strength, r.draw, r.vertices, r.ber, r.erasures,
                  csv_quote(r.status), r.embed_seconds, r.attack_seconds, r.extract_seconds);
  line += "," + csv_quote(r.protocol);
  if (trace)
    line += fmt::format(",{},{},{},{},{},{},{},{},{}", r.colluders, csv_quote(r.leakers),
                        r.trace_outcome, r.trace_status, csv_quote(r.trace_named), r.trace_p,
                        r.blind_outcome, csv_quote(r.blind_id), r.trace_seconds);
  return line;
}

std::vector<SummaryRow> summarize(const CampaignConfig& c, const std::vector<TrialRow>& rows) {
  // Only trials that measured a mark: one without a mark within the limits (no strength met
  // them, the embedding failed) or whose attack failed says nothing of the mark's robustness.
  std::map<std::string, std::vector<double>> groups;
  std::map<std::string, int> excluded;
  for (const TrialRow& r : rows) {
    const std::string key =
        fmt::format("{}|{}|{}|{}", r.protocol, r.variant, r.attack, r.attack_strength);
    if (r.status == "ok")
      groups[key].push_back(r.ber);
    else
      ++excluded[key];
  }
  std::vector<SummaryRow> out;
  for (const CampaignProtocol& p : c.protocols)
    for (const std::string& v : c.variants)
      for (const AttackSeries& s : c.attacks)
        for (const double x : s.strengths) {
          const std::string key = fmt::format("{}|{}|{}|{}", p.name, v, series_label(s), x);
          auto it = groups.find(key);
          if (it == groups.end()) continue;
          std::vector<double> b = it->second;
          std::sort(b.begin(), b.end());
          SummaryRow row;
          row.protocol = p.name;
          row.variant = v;
          row.attack = series_label(s);
          row.attack_strength = x;
          row.trials = static_cast<int>(b.size());
          row.excluded = excluded.count(key) ? excluded[key] : 0;
          const std::size_t n = b.size();
          row.median_ber = n % 2 ? b[n / 2] : 0.5 * (b[n / 2 - 1] + b[n / 2]);
          double sum = 0;
          for (const double e : b) sum += e;
          row.mean_ber = sum / n;
          out.push_back(row);
        }
  return out;
}

}  // namespace meshmark
