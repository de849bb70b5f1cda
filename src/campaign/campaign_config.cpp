// Campaign files: parsing and checking a campaign's JSON into a CampaignConfig.

#include <fmt/format.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <nlohmann/json.hpp>
#include <set>
#include <system_error>
#include <utility>

#include "campaign/campaign_parts.h"
#include "meshmark/attacks/attack.h"
#include "meshmark/campaign/campaign.h"
#include "meshmark/carrier/method.h"
#include "meshmark/core/error.h"
#include "meshmark/forensics/fingerprint.h"
#include "meshmark/io/io.h"
#include "meshmark/protocol/coding.h"

// The installed data folder (CMake's MESHMARK_DATA_DIR): meshes/ holds the project's meshes,
// cgal/ libcgal-demo's.
#ifndef MESHMARK_DEFAULT_DATA_DIR
#define MESHMARK_DEFAULT_DATA_DIR "/usr/local/share/meshmark"
#endif

namespace meshmark {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

std::string expand(std::string path, const fs::path& base) {
  auto from_env = [](const char* env, const std::string& fallback) {
    const char* value = std::getenv(env);
    return value && *value ? std::string(value) : fallback;
  };
  auto replace = [&](const std::string& token, const std::string& with) {
    for (std::size_t at; (at = path.find(token)) != std::string::npos;)
      path.replace(at, token.size(), with);
  };
  const std::string data = from_env("MESHMARK_DATA_DIR", MESHMARK_DEFAULT_DATA_DIR);
  replace("${data}", data);
  replace("${cgal}", from_env("MESHMARK_CGAL_DATA", data + "/cgal"));
  fs::path p(path);
  if (p.is_relative()) p = base / p;
  return p.lexically_normal().string();
}

[[noreturn]] void bad(const std::string& file, const std::string& what) {
  throw InvalidInputError(file, 0, what);
}

// An integer setting: a JSON integer within T's range. A fraction (3.5), a float (3.0) or a
// number beyond T (1e77) is refused, never truncated or converted out of range.
template <class T>
T integer(const std::string& file, const json& object, const char* key, const std::string& where,
          T fallback) {
  if (!object.contains(key)) return fallback;
  const json& v = object[key];
  if (v.is_number_unsigned()) {
    if (const auto u = v.get<std::uint64_t>(); std::in_range<T>(u)) return static_cast<T>(u);
  } else if (v.is_number_integer()) {
    if (const auto i = v.get<std::int64_t>(); std::in_range<T>(i)) return static_cast<T>(i);
  }
  bad(file, fmt::format("{}\"{}\" is {}, not an integer from {} to {}", where, key, v.dump(),
                        std::numeric_limits<T>::min(), std::numeric_limits<T>::max()));
}

void check_keys(const std::string& file, const json& object, const std::string& where,
                std::initializer_list<const char*> allowed) {
  for (auto it = object.begin(); it != object.end(); ++it)
    if (std::none_of(allowed.begin(), allowed.end(), [&](const char* k) { return it.key() == k; }))
      bad(file, fmt::format("{}: unknown key \"{}\"", where, it.key()));
}

// A series' kind is an attack kind, or a chain whose last step is one without a strength (the
// series' strengths go there); every strength must make a valid chain.
void check_series(const std::string& file, const std::string& where, const AttackSeries& s) {
  const std::string last = s.kind.substr(s.kind.rfind(',') + 1);
  if (last.find(':') != std::string::npos)
    bad(file, fmt::format("{}: the last step of the chain \"{}\" takes the strengths: write it "
                          "without \":\"",
                          where, s.kind));
  try {
    (void)attack_kind(last);
  } catch (const InvalidArgumentError& e) {
    bad(file, fmt::format("{}: {}", where, e.what()));
  }
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
    try {
      o.bin_offset = parse_enum<BinOffsetRule>(k.value("bin_offset", enum_name(o.bin_offset)));
    } catch (const InvalidArgumentError& e) {
      bad(file, fmt::format("{}: bin_offset: {}", where, e.what()));
    }
    o.max_rms_percent = k.value("max_rms", o.max_rms_percent);
    o.max_msdm = k.value("max_msdm", o.max_msdm);
    o.iterations = integer(file, k, "iterations", where + ": ", o.iterations);
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

// The trace mode's settings ("mode", "copies", "collusion", "remarks", "innocents", "spread",
// "fingerprint", "fingerprint_rms", "fingerprint_regions"), refused in blind mode.
void read_trace_settings(const std::string& file, const json& j, CampaignConfig& c) {
  const std::string mode = j.value("mode", "blind");
  if (mode != "blind" && mode != "trace")
    bad(file, fmt::format("mode \"{}\" is neither \"blind\" nor \"trace\"", mode));
  c.trace = mode == "trace";
  for (const char* k : {"copies", "collusion", "remarks", "innocents", "spread", "fingerprint",
                        "fingerprint_rms", "fingerprint_regions"})
    if (!c.trace && j.contains(k)) bad(file, fmt::format("\"{}\" needs \"mode\": \"trace\"", k));
  if (!c.trace) return;
  c.copies = integer(file, j, "copies", "", c.copies);
  if (j.contains("collusion")) {
    const json& k = j["collusion"];
    std::vector<std::string> names;
    if (k.is_boolean()) {
      if (k.get<bool>()) names.push_back("average:2");
    } else if (k.is_array()) {
      for (const json& n : k) {
        if (!n.is_string())
          bad(file, fmt::format("\"collusion\" lists {}, not a coalition name", n.dump()));
        names.push_back(n.get<std::string>());
      }
    } else {
      bad(file,
          "\"collusion\" must be true, false or a list of coalitions (\"average:3\", "
          "\"weighted:3\", \"splice:3\")");
    }
    std::set<std::string> seen;
    for (const std::string& name : names) {
      try {
        c.coalitions.push_back(parse_coalition(name));
      } catch (const InvalidArgumentError& e) {
        bad(file, e.what());
      }
      if (!seen.insert(coalition_name(c.coalitions.back())).second)
        bad(file, fmt::format("\"collusion\" lists the coalition \"{}\" twice", name));
    }
  }
  if (j.contains("remarks")) {
    const json& list = j["remarks"];
    if (!list.is_array())
      bad(file,
          "\"remarks\" must be a list of re-markings (\"remark:VRS\", \"remark-key:DNL:0.1\")");
    std::set<std::string> seen;
    for (const json& n : list) {
      if (!n.is_string())
        bad(file, fmt::format("\"remarks\" lists {}, not a re-marking", n.dump()));
      try {
        c.remarks.push_back(parse_remark(n.get<std::string>()));
      } catch (const InvalidArgumentError& e) {
        bad(file, e.what());
      }
      if (!seen.insert(remark_name(c.remarks.back())).second)
        bad(file,
            fmt::format("\"remarks\" lists the re-marking \"{}\" twice", n.get<std::string>()));
    }
  }
  if (j.contains("innocents")) {
    const json& list = j["innocents"];
    const std::string kinds = "\"unmarked\", \"other-key\", \"without-leaker\"";
    if (!list.is_array()) bad(file, fmt::format("\"innocents\" must be a list of {}", kinds));
    for (const json& n : list) {
      if (!n.is_string())
        bad(file, fmt::format("\"innocents\" lists {}, not one of {}", n.dump(), kinds));
      const std::string name = n.get<std::string>();
      const auto names = enum_names<CampaignInnocent>();
      const auto it = std::find(names.begin(), names.end(), name);
      if (it == names.end())
        bad(file, fmt::format("\"innocents\" lists \"{}\", not one of {}", name, kinds));
      const auto innocent = static_cast<CampaignInnocent>(it - names.begin());
      if (std::find(c.innocents.begin(), c.innocents.end(), innocent) != c.innocents.end())
        bad(file, fmt::format("\"innocents\" lists \"{}\" twice", name));
      c.innocents.push_back(innocent);
    }
  }
  c.fingerprint = j.value("fingerprint", c.fingerprint);
  c.fingerprint_rms = j.value("fingerprint_rms", c.fingerprint_rms);
  if (!(c.fingerprint_rms > 0 && c.fingerprint_rms <= 0.01))
    bad(file, fmt::format("fingerprint_rms {} is out of (0, 0.01]", c.fingerprint_rms));
  if (j.contains("fingerprint_rms") && !c.fingerprint)
    bad(file, "\"fingerprint_rms\" needs \"fingerprint\": true");
  if (j.contains("fingerprint_regions")) {
    const json& r = j["fingerprint_regions"];
    if (!r.is_array()) bad(file, "\"fingerprint_regions\" must be a list of region counts");
    c.fingerprint_regions.clear();
    for (const json& n : r) {
      if (!n.is_number_integer() || n.get<std::int64_t>() < 2 ||
          n.get<std::int64_t>() > kMaxFingerprintRegions)
        bad(file, fmt::format("\"fingerprint_regions\" lists {}, not a count of 2 to {} regions",
                              n.dump(), kMaxFingerprintRegions));
      c.fingerprint_regions.push_back(n.get<int>());
    }
    try {
      check_fingerprint_partitions(c.fingerprint_regions);
    } catch (const InvalidArgumentError& e) {
      bad(file, fmt::format("\"fingerprint_regions\": {}", e.what()));
    }
    if (!c.fingerprint) bad(file, "\"fingerprint_regions\" needs \"fingerprint\": true");
  }
  c.spread = j.value("spread", c.spread);
  if (c.copies < 2 || c.copies > 1000000)
    bad(file, fmt::format("copies {} is out of 2..1000000", c.copies));
  if (c.payloads > c.copies)
    bad(file, fmt::format("{} payloads draw as many leakers among {} copies: some would be the "
                          "same buyer; give at most {}",
                          c.payloads, c.copies, c.copies));
  if (!(c.spread >= 0 && c.spread <= 4))
    bad(file, fmt::format("spread {} is out of [0, 4]", c.spread));
  for (const CampaignCoalition& k : c.coalitions)
    if (k.size > c.copies)
      bad(file, fmt::format("the coalition \"{}\" needs more than the {} copies issued",
                            coalition_name(k), c.copies));
  try {
    (void)IdCode(IdCodeOptions{c.bits});
  } catch (const InvalidArgumentError& e) {
    bad(file, fmt::format("bits {} cannot carry a 32-bit ID: {}", c.bits, e.what()));
  }
}

}  // namespace

CampaignConfig load_campaign(const std::string& path) {
  const std::string text = read_file(path);
  json j;
  try {
    j = json::parse(text);
  } catch (const json::parse_error& e) {
    bad(path, fmt::format("not valid JSON (byte {}): {}", e.byte, e.what()));
  } catch (const json::exception& e) {  // a number beyond double's range: out_of_range
    bad(path, fmt::format("not valid JSON: {}", e.what()));
  }
  if (!j.is_object()) bad(path, "a campaign is a JSON object");
  check_keys(path, j, "campaign",
             {"name",
              "description",
              "models",
              "variants",
              "bits",
              "payloads",
              "draws",
              "seed",
              "calibration",
              "protocols",
              "strength",
              "attacks",
              "mode",
              "copies",
              "collusion",
              "remarks",
              "innocents",
              "spread",
              "fingerprint",
              "fingerprint_rms",
              "fingerprint_regions"});
  const fs::path base = fs::absolute(path).parent_path();
  CampaignConfig c;
  c.source = path;
  try {
    c.name = j.value("name", fs::path(path).stem().string());
    c.bits = integer(path, j, "bits", "", c.bits);
    c.payloads = integer(path, j, "payloads", "", c.payloads);
    c.draws = integer(path, j, "draws", "", c.draws);
    c.seed = integer(path, j, "seed", "", c.seed);
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
      std::error_code unreadable;  // a name too long for the file system, say: not a file
      if (!fs::is_regular_file(model.path, unreadable))
        bad(path, fmt::format("models[{}]: {} does not exist{}", i, model.path,
                              unreadable ? " (" + unreadable.message() + ")" : ""));
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
      if (std::count(c.variants.begin(), c.variants.end(), c.variants.back()) > 1)
        bad(path, fmt::format("\"variants\" lists \"{}\" twice", name));
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
        s.draws = integer(path, a, "draws", where + ": ", 0);
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

}  // namespace meshmark
