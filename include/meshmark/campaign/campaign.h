#pragma once
/// \file campaign.h
/// Benchmark campaigns (docs/method.md section 6): models x variants x payloads,
/// each embedding at its calibrated strength, then attacked at every strength of every attack
/// (several draws for random attacks) and decoded blind. One row per trial.
///
/// A campaign is described by a JSON file:
///
///     {"name": "quick", "bits": 64, "payloads": 6, "draws": 10, "seed": 1,
///      "models": ["${data}/meshes/spot.obj", {"name": "fandisk", "path":
///      "${cgal}/fandisk.off"}], "variants": ["DRS", "SRS", "VRS"], "calibration": {"max_rms":
///      0.04, "max_msdm": 0.25, "iterations": 10}, "attacks": [{"kind": "noise", "strengths":
///      [0.001, 0.003]}, {"kind": "loop", "strengths": [1]}]}
///
/// "${data}" is meshmark's data folder (the environment variable MESHMARK_DATA_DIR, else the
/// installed one, CMake's MESHMARK_DATA_DIR), whose meshes/ holds the project's own meshes;
/// "${cgal}" is libcgal-demo's unpacked data/meshes (MESHMARK_CGAL_DATA, else ${data}/cgal);
/// other relative paths are relative to the file.
/// "strength": A instead of "calibration" embeds every model at alpha = A. Deterministic
/// attacks (quantization, smoothing, simplification, subdivision, format changes) run one draw.
/// Every trial is named by a key (model|variant|payload|attack|strength|draw) and seeded from
/// it, so a trial gives the same row whichever process, thread or order runs it.
///
/// An attack's "kind" may be a chain (attack.h, parse_attack_chain) whose last step takes the
/// strengths: {"kind": "similarity:2,simplify", "strengths": [0.3, 0.5]} runs
/// "similarity:2,simplify:0.3" and "similarity:2,simplify:0.5" (the earlier steps carry their
/// own strengths; a chain is deterministic when all its steps are).
///
/// Attacks whose definition the literature varies take parameters (attack.h, AttackParams)
/// beside "kind": {"kind": "smooth", "lambda": 0.03, "fixed_boundary": true, "strengths": [5,
/// 10]}, {"kind": "taubin", "lambda": 0.5, "mu": -0.53, "weighting": "inverse-distance", ...},
/// {"kind": "quant", "convention": "benchmark", ...}; they go to every step of a chain that
/// reads them. Rows name such a series by series_label ("smooth [lambda=0.03 fixed_boundary]").
///
/// Several calibration protocols (blind mode): "protocols": [{"name": "perceptual", "max_rms":
/// 0.008, "max_msdm": 0.19}, {"name": "geometric", "max_rms": 0.012, "max_msdm": 0.29}]; each
/// (model, variant) is calibrated once per protocol (its keys are those of "calibration",
/// whose values it overrides) and every embedding runs once per protocol; rows, keys (a last
/// "|NAME") and calibrations name the protocol.
///
/// Variants may name Cho et al.'s methods (method.h, MarkScheme: "cho-mean", "cho-variance",
/// "cho-mean/VRS"), which then run beside the QP framework's variants on the same trials.
/// In blind mode every embedding (model, variant, payload, protocol) is calibrated for itself,
/// as `embed --fidelity` calibrates a copy: its row's strength is its own, and its distortion
/// is within the protocol's limits (the (model, variant) calibration of one payload does not
/// hold for another: on spot, other payloads at its strength measured up to 1.3 times the RMS
/// limit). A model and variant whose calibration finds no strength embed nothing.
///
/// Trace mode ("mode": "trace"; trace.h) measures tracing with the original against the blind
/// decoder. Per model and variant, "copies" (1000 by default) coded IDs are issued under the
/// campaign's key (campaign_key) to consecutive IDs from campaign_first_id, as registry
/// records; each payload index p picks a leaker among them (campaign_leaker) whose copy alone is
/// embedded (keyed, at the strength with "spread", 0.25 by default). Every attack of every
/// trial is then traced (the original and the issued records) and decoded blind (read_id) on
/// the same attacked mesh; each gives right (only leakers named), none, or wrong (an innocent
/// named). "collusion" repeats every attack on leaks merged by coalitions of buyers with
/// consecutive IDs (CampaignCoalition, attack_collude): a list of "average:K" (the vertex-wise
/// mean of K copies), "weighted:K" (a mean with flat Dirichlet weights drawn per trial) and
/// "splice:K" (K regions, each pasted from one copy), K in 2..64; true is ["average:2"]. A
/// coalition of K is the leaker and the K - 1 IDs after it (shifted down at the end of the
/// range). Right is then at least one colluder named and no innocent; rows and summaries also
/// count the trials that named every colluder. Rows carry both outcomes; keys of merged trials
/// end in "|avg2" (an average of 2) or "|" and the coalition's name. "remarks" repeats every
/// attack on the leaker's copy re-marked with meshmark (CampaignRemark: "remark:VRS",
/// "remark-key:DNL:0.1", "remark:cho-mean"), another ID drawn per model, variant and payload;
/// their rows carry the re-marking's name in `coalition`, with 1 colluder, and keys end in "|"
/// and that name. "innocents" repeats every attack on leaks nobody in the registry leaked
/// (CampaignInnocent: "unmarked", "other-key", "without-leaker"), where any name is wrong; their
/// rows carry innocent_name in `coalition`, with 0 colluders. "fingerprint": true issues
/// every copy with the fingerprint (the leakers' copies get theirs, the records mark format 5).
/// bits and the 32-bit ID must make an IdCode (coding.h).
///
/// This header holds what a user of campaigns calls: the configuration, the rows and
/// calibrations a run writes (and their JSON lines), the statistics and the report;
/// run_campaign (campaign_run.h) runs a whole campaign into a results directory. The planning
/// and one unit's trials are the library's own (src/campaign/campaign_parts.h).

#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "meshmark/attacks/attack.h"
#include "meshmark/core/enum_names.h"
#include "meshmark/core/mesh.h"
#include "meshmark/forensics/registry.h"
#include "meshmark/forensics/trace.h"
#include "meshmark/mark/calibrate.h"
#include "meshmark/protocol/key.h"

namespace meshmark {

/// One attack of a campaign at several strengths.
struct AttackSeries {
  std::string kind;               ///< an attack kind (attack.h), a chain ending in one, or "none"
  std::vector<double> strengths;  ///< at least one
  int draws = 0;                  ///< 0: the campaign's draws (1 for deterministic kinds)
  AttackParams params;            ///< for every step of the chain that reads them
};

/// The series' name in rows and reports: its kind, then its non-default parameters in
/// brackets ("smooth [lambda=0.03 fixed_boundary]").
std::string series_label(const AttackSeries& series);

/// A calibration protocol: a name (empty for a campaign with one "calibration") and limits.
struct CampaignProtocol {
  std::string name;
  CalibrateOptions calibration;
};

/// A coalition of a trace campaign: `size` buyers with consecutive IDs who merge their copies.
struct CampaignCoalition {
  CollusionKind kind = CollusionKind::Average;
  bool weighted = false;  ///< Average: flat Dirichlet weights drawn per trial, else equal
  int size = 2;           ///< colluders, 2..64
};

/// Its name in campaign files and trial keys: "average:3", "weighted:3", "splice:3".
std::string coalition_name(const CampaignCoalition& coalition);

/// Parses coalition_name's form. \throw InvalidArgumentError naming what is wrong.
CampaignCoalition parse_coalition(const std::string& name);

/// Its label in reports: "average of 3", "unequal average of 3", "splice of 3".
std::string coalition_label(const CampaignCoalition& coalition);

/// A trace trial's attack as reports print it: "simplify:0.5", or with its coalition or
/// re-marking first ("average of 3, simplify:0.5", "unequal average of 3, ...", "splice of 3,
/// ...", "re-marked VRS (public key), ..."). coalition: a coalition_name, a remark_name, or ""
/// for a single copy as issued.
std::string trace_attack_label(const std::string& attack, double attack_strength,
                               const std::string& coalition);

/// A re-marking of a trace campaign: the leaker's copy marked again with meshmark by whoever
/// leaks it, as anyone can, before the trial's attack: another ID's histogram mark in `scheme`
/// under the public key (what `meshmark embed COPY OUT --id N` does without a key), or under
/// another secret key with that key's fingerprint too (`embed --key-file OTHER --fingerprint`).
struct CampaignRemark {
  std::string scheme = "VRS";  ///< a variant or a Cho method (MarkScheme: "DNL", "cho-mean")
  double strength = 0;         ///< the re-mark's strength in (0, 1/2); 0: embed's default
  bool other_key = false;      ///< another secret key (with its fingerprint), else the public key
};

/// Its name in campaign files, rows and trial keys: "remark:SCHEME" (public key) or
/// "remark-key:SCHEME" (another key), then ":STRENGTH" when not the default ("remark:VRL:0.1").
std::string remark_name(const CampaignRemark& remark);

/// Parses remark_name's form. \throw InvalidArgumentError naming what is wrong.
CampaignRemark parse_remark(const std::string& name);

/// Its label in reports: "re-marked VRS (public key)", "re-marked VRL at 0.1 (another key)".
std::string remark_label(const CampaignRemark& remark);

/// A trace campaign's innocent leak: a mesh that no candidate of the registry leaked, which trace
/// must answer with nobody ("innocents" in campaign files). Its rows carry innocent_name in
/// `coalition`, 0 colluders and no leaker: a trial is right never, none when nobody is named,
/// and wrong when anyone is. The blind decoder is judged against the ID the leak carries under
/// the campaign's key: the leaker's for WithoutLeaker, nobody's for the others.
enum class CampaignInnocent {
  Unmarked,       ///< "unmarked": the original itself
  OtherKey,       ///< "other-key": the leaker's ID issued, both marks, under another shop's key
  WithoutLeaker,  ///< "without-leaker": the leaker's copy, its row left out of the registry
};

/// The names of CampaignInnocent's values in campaign files.
template <>
struct EnumTable<CampaignInnocent> {
  static constexpr const char* what = "innocent leak";
  static constexpr NamedValue<CampaignInnocent> values[] = {
      {CampaignInnocent::Unmarked, "unmarked"},
      {CampaignInnocent::OtherKey, "other-key"},
      {CampaignInnocent::WithoutLeaker, "without-leaker"}};
};

/// Its name in rows and trial keys: "innocent:" and its name in files ("innocent:other-key").
std::string innocent_name(CampaignInnocent innocent);

/// Its label in reports: "innocent: the original, unmarked", "innocent: the leaker's ID under
/// another key", "innocent: the leaker's copy, its row left out".
std::string innocent_label(CampaignInnocent innocent);

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
  CalibrateOptions calibration;             ///< the first protocol's
  std::vector<CampaignProtocol> protocols;  ///< at least one (the unnamed "calibration")
  std::vector<AttackSeries> attacks;        ///< "none" (strength 0) is always added first
  bool trace = false;                       ///< "mode": "trace" (else "blind", the default)
  int copies = 1000;                        ///< trace: IDs issued per model and variant (>= 2)
  /// trace: every attack also on the leaks these coalitions merge (empty: single copies only)
  std::vector<CampaignCoalition> coalitions;
  /// trace, "remarks": every attack also on the leaker's copy re-marked by each of these
  /// (single copies; rows name the re-marking where coalitions name theirs)
  std::vector<CampaignRemark> remarks;
  /// trace, "innocents": every attack also on these leaks, which nobody in the registry leaked
  std::vector<CampaignInnocent> innocents;
  /// trace: copies issued with the fingerprint (mark format 5, fingerprint.h), as `embed
  /// --registry DB --fingerprint` issues them
  bool fingerprint = false;
  /// trace, "fingerprint_rms": the fingerprint's RMS as a fraction of the diagonal on
  /// originals of kFingerprintFullVertices counted vertices and more, raised on smaller ones
  /// as issued copies are (FingerprintOptions::rms, fingerprint_rms), in (0, 0.01]
  double fingerprint_rms = 1e-4;
  /// trace, "fingerprint_regions": the partitions trace also reads the fingerprint over
  /// (TraceOptions::fingerprint_regions; [] reads the whole surface alone)
  std::vector<int> fingerprint_regions = TraceOptions{}.fingerprint_regions;
  double spread = 0.25;  ///< trace: keyed strength spread (watermark.h)
};

/// Reads a campaign file. \throw InvalidInputError naming the file and the bad key or value;
/// IOError when it cannot be read.
CampaignConfig load_campaign(const std::string& path);

/// The payload calibrations use (one per length and seed; `meshmark calibrate` uses seed 1).
Payload calibration_payload(int bits, std::uint64_t seed);

/// A calibrated strength of a (model, variant).
struct CalibrationRecord {
  std::string model, variant;
  std::string protocol;  ///< its name ("" for the unnamed one)
  std::string status;    ///< calibrate_status_name, or "fixed"
  double strength = 0, rms_percent = 0, msdm = 0, seconds = 0;
  double bin_offset = 0.05;  ///< G the trials embed with (calibrate.h: BinOffsetRule)
  int evaluations = 0;
  std::string cause;  ///< below minimum: calibrate_cause_name, and the first diagnostic
};

/// What a trial's tracer named, against the copies that were leaked.
enum class TraceOutcome {
  Right,  ///< someone named, and every one named is a leaker
  None,   ///< nobody named
  Wrong,  ///< an innocent named (whoever else is)
};

/// The names of TraceOutcome's values (trace_outcome_name).
template <>
struct EnumTable<TraceOutcome> {
  static constexpr const char* what = "trace outcome";
  static constexpr NamedValue<TraceOutcome> values[] = {
      {TraceOutcome::Right, "right"}, {TraceOutcome::None, "none"}, {TraceOutcome::Wrong, "wrong"}};
};

/// "right", "none", "wrong".
const char* trace_outcome_name(TraceOutcome outcome);

/// One trial.
struct TrialRow {
  std::string key;  ///< model|variant|payload|attack|attack strength|draw[|protocol]
  std::string model, variant;
  std::string protocol;  ///< the calibration protocol's name ("" for the unnamed one)
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
  // Trace mode only (otherwise colluders 0 and trace_outcome empty; an innocent leak's row has
  // colluders 0 and a trace outcome). ber is then the blind reading's against the (first)
  // leaker's codeword (the unit's leaker's for an innocent leak), and extract_seconds read_id's.
  /// copies merged into the leak: 1, the coalition's size, or 0 (an innocent leak)
  int colluders = 0;
  std::string coalition;         ///< coalition_name, "" for a single copy
  std::string leakers;           ///< their IDs, space-separated
  std::string trace_outcome;     ///< trace_outcome_name of trace()'s named buyers
  std::string trace_status;      ///< trace_status_name
  std::string trace_named;       ///< the IDs trace named, space-separated, best first
  bool trace_all_named = false;  ///< every leaker named (and no innocent)
  double trace_p = 1;            ///< corrected p of trace's best candidate
  std::string blind_outcome;     ///< trace_outcome_name of read_id's ID (none when no ID)
  std::string blind_id;          ///< the ID read_id decoded, or why none
  double trace_seconds = 0;      ///< trace(), registration included
  /// Candidates trace scored that are not leakers (0: not recorded, rows written before
  /// 2026-12-07): each an innocent's test, none of which may be named.
  int innocents = 0;
  double innocent_p = 1;  ///< the smallest corrected p among them (1 when there are none)
};

/// One JSON line (no newline) and back. from_json throws InvalidInputError on a bad line.
std::string row_to_json(const TrialRow& row);
TrialRow row_from_json(const std::string& line);
std::string calibration_to_json(const CalibrationRecord& record);
CalibrationRecord calibration_from_json(const std::string& line);

/// The median bit error rate of one variant, attack and strength, as the paper reports it.
struct SummaryRow {
  std::string protocol, variant, attack;  ///< attack: the series' label
  double attack_strength = 0;
  double median_ber = 0, mean_ber = 0;
  int trials = 0;    ///< trials that measured a mark (status "ok"): the statistics' sample
  int excluded = 0;  ///< trials left out: no mark within the limits, or the attack failed
};

/// Medians over models, payloads and draws of the trials that measured a mark, in the order
/// protocols, variants, then attacks of the config; the others (a model the calibration could
/// not mark within the limits, a failed embedding or attack) are counted in `excluded`, not as
/// BER 0.5. A group with no measured trial has no row.
std::vector<SummaryRow> summarize(const CampaignConfig& config, const std::vector<TrialRow>& rows);

/// Trace mode: the outcomes of one attack, strength and coalition (or single copy), over models,
/// variants, payloads and draws, for trace and for the blind decoder on the same trials.
struct TraceSummaryRow {
  std::string attack;
  double attack_strength = 0;
  int colluders = 1;
  std::string coalition;  ///< coalition_name, "" for single copies
  int trials = 0;
  int trace_right = 0, trace_none = 0, trace_wrong = 0;
  int trace_all = 0;  ///< trials where trace named every leaker (and no innocent)
  int blind_right = 0, blind_none = 0, blind_wrong = 0;
  double worst_right_p = 0;  ///< largest corrected p among trace's right trials (0: none)
  double median_trace_seconds = 0;
  std::int64_t innocents = 0;  ///< innocent candidates scored over the trials (TrialRow)
  double innocent_p = 1;       ///< the smallest corrected p among them (1: none recorded)
  int failed = 0;  ///< trials that did not run (their status is not "ok"), not in `trials`
};

/// The outcome counts, in the config's order of attacks and strengths, single copies first,
/// then each coalition in the config's order.
std::vector<TraceSummaryRow> summarize_trace(const CampaignConfig& config,
                                             const std::vector<TrialRow>& rows);

/// Writes summary.csv, one SVG (and PNG when rsvg-convert is installed) per attack with the
/// median BER against strength, one curve per variant, a panel figure of all attacks, and
/// report.md (calibrations, distortions, medians, Loop table, timings, the published results
/// of section 8 beside DRS's). Returns the report's path. In trace mode: summary.csv of
/// summarize_trace, figure-trace.svg (right / none / wrong bars, trace beside blind, per
/// attack and strength) and a report.md that lists every wrong outcome first. \throw IOError
/// when a file cannot be written or rsvg-convert fails on a figure (its message quoted).
std::string write_campaign_report(const std::string& dir, const CampaignConfig& config,
                                  const std::vector<CalibrationRecord>& calibrations,
                                  const std::vector<TrialRow>& rows, double wall_seconds);

}  // namespace meshmark
