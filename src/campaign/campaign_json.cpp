// Campaign serialization: rows and calibrations as JSON lines (the journals' records), rows as
// CSV. The JSON fields are those of TrialRow and CalibrationRecord, by name (nlohmann's type
// macros); a row's protocol and a calibration's protocol and cause only when not empty, the
// trace mode's fields only on trace rows (colluders not 0, or an innocent leak's: a trace outcome
// and no colluder), as the journals have always held.

#include <fmt/format.h>

#include <nlohmann/json.hpp>
#include <sstream>

#include "campaign/campaign_parts.h"
#include "meshmark/campaign/campaign.h"
#include "meshmark/core/error.h"

namespace meshmark {

NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(
    TrialRow, key, model, variant, protocol, payload, strength, rms_percent, msdm, attack,
    attack_strength, draw, vertices, ber, erasures, status, embed_seconds, attack_seconds,
    extract_seconds, colluders, coalition, leakers, trace_outcome, trace_status, trace_named,
    trace_all_named, trace_p, blind_outcome, blind_id, trace_seconds, innocents, innocent_p)

NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(CalibrationRecord, model, variant, protocol, status,
                                                strength, rms_percent, msdm, seconds, bin_offset,
                                                evaluations, cause)

namespace {

using nlohmann::json;

// Fields every row has.
constexpr const char* kRowFields[] = {
    "key",      "model",  "variant",         "payload",        "strength",       "rms_percent",
    "msdm",     "attack", "attack_strength", "draw",           "vertices",       "ber",
    "erasures", "status", "embed_seconds",   "attack_seconds", "extract_seconds"};
// Fields of trace rows only.
constexpr const char* kTraceFields[] = {"colluders",     "leakers",     "trace_outcome",
                                        "trace_status",  "trace_named", "trace_p",
                                        "blind_outcome", "blind_id",    "trace_seconds"};
// Fields every calibration has (bin_offset is read as the paper's 0.05 when absent: records
// written before G was searched).
constexpr const char* kCalibrationFields[] = {"model",       "variant", "status",  "strength",
                                              "rms_percent", "msdm",    "seconds", "evaluations"};

// Throws InvalidInputError(file, 0, "not a WHAT: ...") unless j is an object with every field.
template <std::size_t N>
void require(const json& j, const char* const (&fields)[N], const char* file, const char* what) {
  if (!j.is_object())
    throw InvalidInputError(file, 0, fmt::format("not a {}: not an object", what));
  for (const char* f : fields)
    if (!j.contains(f))
      throw InvalidInputError(file, 0, fmt::format("not a {}: key '{}' not found", what, f));
}

// The IDs of a row's space-separated list (TrialRow::leakers, ::trace_named).
std::vector<std::uint64_t> ids_of(const std::string& list) {
  std::vector<std::uint64_t> ids;
  std::istringstream in(list);
  for (std::uint64_t id = 0; in >> id;) ids.push_back(id);
  return ids;
}

std::string csv_quote(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string out = "\"";
  for (const char c : s) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

}  // namespace

std::string row_to_json(const TrialRow& r) {
  json j = r;
  if (r.protocol.empty()) j.erase("protocol");
  if (r.colluders == 0 && r.trace_outcome.empty()) {  // a blind row
    for (const char* f : kTraceFields) j.erase(f);
    for (const char* f : {"trace_all_named", "innocents", "innocent_p"}) j.erase(f);
  }
  if (r.coalition.empty()) j.erase("coalition");
  if (r.innocents == 0) j.erase("innocents"), j.erase("innocent_p");  // as rows of older builds
  return j.dump();
}

TrialRow row_from_json(const std::string& line) {
  try {
    const json j = json::parse(line);
    require(j, kRowFields, "rows", "campaign row");
    if (j.contains("colluders")) require(j, kTraceFields, "rows", "campaign row");
    TrialRow r = j.get<TrialRow>();
    // Rows written before coalitions had names (and before trace_all_named): colluders 2 was
    // always an average of two; every leaker named is read from the names.
    if (r.colluders == 2 && r.coalition.empty()) r.coalition = "average:2";
    if (r.colluders > 0 && !j.contains("trace_all_named"))
      r.trace_all_named = every_leaker_named(ids_of(r.trace_named), ids_of(r.leakers));
    return r;
  } catch (const json::exception& e) {
    throw InvalidInputError("rows", 0, fmt::format("not a campaign row: {}", e.what()));
  }
}

std::string calibration_to_json(const CalibrationRecord& r) {
  json j = r;
  if (r.protocol.empty()) j.erase("protocol");
  if (r.cause.empty()) j.erase("cause");
  return j.dump();
}

CalibrationRecord calibration_from_json(const std::string& line) {
  try {
    const json j = json::parse(line);
    require(j, kCalibrationFields, "calibrations", "calibration");
    return j.get<CalibrationRecord>();
  } catch (const json::exception& e) {
    throw InvalidInputError("calibrations", 0, fmt::format("not a calibration: {}", e.what()));
  }
}

std::string csv_header(bool trace) {
  return std::string(
             "model,variant,payload,strength,rms_percent,msdm,attack,attack_strength,draw,"
             "vertices,ber,erasures,status,embed_seconds,attack_seconds,extract_seconds,protocol") +
         (trace ? ",colluders,coalition,leakers,trace_outcome,trace_status,trace_named,"
                  "trace_all_named,trace_p,blind_outcome,blind_id,trace_seconds,innocents,"
                  "innocent_p"
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
    line += fmt::format(",{},{},{},{},{},{},{:d},{},{},{},{},{},{}", r.colluders, r.coalition,
                        csv_quote(r.leakers), r.trace_outcome, r.trace_status,
                        csv_quote(r.trace_named), r.trace_all_named, r.trace_p, r.blind_outcome,
                        csv_quote(r.blind_id), r.trace_seconds, r.innocents, r.innocent_p);
  return line;
}

}  // namespace meshmark
