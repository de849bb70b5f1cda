// Calibration and benchmark campaigns: limits met and tight, rows complete and unique, medians
// recomputed from the CSV, a killed campaign resumed without a row lost or doubled, and MPI
// ranks giving the rows of one process.

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "campaign/campaign_internal.h"
#include "campaign/campaign_parts.h"
#include "meshmark/campaign/campaign.h"
#include "meshmark/carrier/histogram.h"
#include "meshmark/carrier/method.h"
#include "meshmark/core/error.h"
#include "meshmark/forensics/fingerprint.h"
#include "meshmark/forensics/trace.h"
#include "meshmark/io/io.h"
#include "meshmark/mark/calibrate.h"
#include "meshmark/metrics/metrics.h"
#include "meshmark/protocol/coding.h"
#include "meshmark/protocol/watermark.h"
#include "test_data.h"

namespace meshmark {
namespace {

namespace fs = std::filesystem;

std::string write_text(const std::string& path, const std::string& text) {
  std::ofstream(path) << text;
  return path;
}

// A trace campaign file `name`.json in the scratch folder: spot, DRS at 0.05, 40 copies with
// the fingerprint, one draw, and `settings` (JSON members: the leaks, payloads, attacks).
std::string spot_trace_campaign(const std::string& name, const std::string& settings) {
  return write_text(test::scratch_dir() + "/" + name + ".json",
                    "{\"models\": [\"" + test::data_mesh("spot.obj") +
                        "\"], \"variants\": [\"DRS\"], \"mode\": \"trace\", \"copies\": 40, "
                        "\"fingerprint\": true, \"strength\": 0.05, \"draws\": 1, " +
                        settings + "}");
}

std::string error_of(const std::string& path) {
  try {
    load_campaign(path);
  } catch (const InvalidInputError& e) {
    return e.what();
  }
  return "";
}

TEST(Campaign, RejectsBadFilesNamingFileAndKey) {
  const std::string spot = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(spot, "spot.obj");
  const std::string dir = test::scratch_dir();
  const std::string head = "{\"models\": [\"" + spot + "\"], \"variants\": [\"DRS\"]";
  struct Case {
    std::string text, expect;
  };
  const std::vector<Case> cases = {
      {head + ", \"draw\": 3}", "unknown key \"draw\""},
      {"{\"models\": [\"" + spot + "\"], \"variants\": [\"VRS\", \"DRS\", \"vrs\"]}",
       "\"variants\" lists \"vrs\" twice"},
      {head + ", \"attacks\": [{\"kind\": \"melt\", \"strengths\": [1]}]}",
       "unknown attack 'melt' (the kinds: reorder, similarity, noise"},
      {head + ", \"attacks\": [{\"kind\": \"noise\"}]}", "attacks[0]: \"strengths\""},
      {"{\"models\": [\"" + dir + "/none.off\"], \"variants\": [\"DRS\"]}",
       "none.off does not exist"},
      // A name longer than the file system allows threw std::filesystem_error out of the loader
      // (found by the campaign fuzzer): refused as a model that does not exist.
      {"{\"models\": [\"" + dir + "/" + std::string(300, 'x') + ".off\"], \"variants\": [\"DRS\"]}",
       ".off does not exist (File name too long)"},
      {"{\"models\": [\"" + spot + "\"], \"variants\": [\"DXS\"]}", "variant \"DXS\""},
      {head + ", \"strength\": 0.7}", "strength 0.7 is out of (0, 1/2)"},
      {head + ", \"bits\": \"many\"}", "\"bits\" is \"many\", not an integer"},
      {"{\"models\": [", "not valid JSON"},
      // A number beyond double's range ended the process (found by the fuzzer).
      {head + ", \"seed\": 666666666666e66666666666666667}", "not valid JSON"},
      // An integer given as a float beyond the type's range was converted out of range, undefined
      // behaviour (found by the fuzzer); a fraction was truncated. Both are refused.
      {head + ", \"seed\": 1.66667e+77}", "\"seed\" is 1.66667e+77, not an integer from 0 to"},
      {head + ", \"seed\": -1}", "\"seed\" is -1, not an integer"},
      {head + ", \"draws\": 2.5}", "\"draws\" is 2.5, not an integer"},
      {head + ", \"bits\": 1e10}", "\"bits\" is 10000000000.0, not an integer"},
      {head + ", \"attacks\": [{\"kind\": \"noise\", \"strengths\": [1], \"draws\": 3e9}]}",
       "attacks[0]: \"draws\" is 3000000000.0, not an integer"},
      {head + ", \"calibration\": {\"iterations\": 4.5}}",
       "calibration: \"iterations\" is 4.5, not an integer"},
      {head + ", \"mode\": \"trace\", \"copies\": 1e300}", "\"copies\" is 1e+300, not an integer"},
      // Chains: the last step takes the strengths; every step must be an attack.
      {head + ", \"attacks\": [{\"kind\": \"similarity:2,simplify:0.3\", \"strengths\": [0.5]}]}",
       "attacks[0]: the last step of the chain \"similarity:2,simplify:0.3\" takes the strengths"},
      {head + ", \"attacks\": [{\"kind\": \"melt:2,simplify\", \"strengths\": [0.5]}]}",
       "attacks[0]: strength 0.5: unknown attack 'melt'"},
      {head + ", \"attacks\": [{\"kind\": \"noise,melt\", \"strengths\": [1]}]}",
       "unknown attack 'melt' (the kinds: reorder, similarity, noise"},
      // Trace mode's settings.
      {head + ", \"mode\": \"forensic\"}", "mode \"forensic\" is neither"},
      {head + ", \"copies\": 10}", "\"copies\" needs \"mode\": \"trace\""},
      {head + ", \"collusion\": true}", "\"collusion\" needs \"mode\": \"trace\""},
      {head + ", \"mode\": \"trace\", \"copies\": 1}", "copies 1 is out of 2..1000000"},
      {head + ", \"mode\": \"trace\", \"copies\": 5, \"payloads\": 6}",
       "6 payloads draw as many leakers among 5 copies"},
      {head + ", \"mode\": \"trace\", \"spread\": -1}", "spread -1 is out of [0, 4]"},
      {head + ", \"mode\": \"trace\", \"bits\": 16}", "bits 16 cannot carry a 32-bit ID"},
      {head + ", \"mode\": \"trace\", \"collusion\": 1}",
       "\"collusion\" must be true, false or a list of coalitions"},
      {head + ", \"mode\": \"trace\", \"collusion\": [3]}",
       "\"collusion\" lists 3, not a coalition"},
      {head + ", \"mode\": \"trace\", \"collusion\": [\"mean:3\"]}",
       "coalition \"mean:3\": the kind is \"average\", \"weighted\" or \"splice\""},
      {head + ", \"mode\": \"trace\", \"collusion\": [\"splice\"]}",
       "coalition \"splice\": write KIND:K"},
      {head + ", \"mode\": \"trace\", \"collusion\": [\"average:-2\"]}",
       "coalition \"average:-2\": write KIND:K"},
      {head + ", \"mode\": \"trace\", \"collusion\": [\"average:1\"]}",
       "coalition \"average:1\": 1 colluders is out of 2..64"},
      {head + ", \"mode\": \"trace\", \"collusion\": [\"weighted:3\", \"weighted:03\"]}",
       "\"collusion\" lists the coalition \"weighted:03\" twice"},
      {head +
           ", \"mode\": \"trace\", \"copies\": 4, \"payloads\": 2, \"collusion\": [\"splice:5\"]}",
       "the coalition \"splice:5\" needs more than the 4 copies issued"},
      {head + ", \"fingerprint\": true}", "\"fingerprint\" needs \"mode\": \"trace\""},
      // Re-markings.
      {head + ", \"remarks\": [\"remark:VRS\"]}", "\"remarks\" needs \"mode\": \"trace\""},
      {head + ", \"mode\": \"trace\", \"remarks\": \"remark:VRS\"}",
       "\"remarks\" must be a list of re-markings"},
      {head + ", \"mode\": \"trace\", \"remarks\": [7]}", "\"remarks\" lists 7, not a re-marking"},
      {head + ", \"mode\": \"trace\", \"remarks\": [\"mark:VRS\"]}",
       "re-marking \"mark:VRS\": write remark:SCHEME or remark-key:SCHEME"},
      {head + ", \"mode\": \"trace\", \"remarks\": [\"remark\"]}",
       "re-marking \"remark\": write remark:SCHEME"},
      {head + ", \"mode\": \"trace\", \"remarks\": [\"remark:VXS\"]}",
       "re-marking \"remark:VXS\": "},
      {head + ", \"mode\": \"trace\", \"remarks\": [\"remark-key:VRS:0.7\"]}",
       "re-marking \"remark-key:VRS:0.7\": the strength \"0.7\" is not in (0, 1/2)"},
      {head + ", \"mode\": \"trace\", \"remarks\": [\"remark:VRS:0.05x\"]}",
       "the strength \"0.05x\" is not in"},
      {head + ", \"mode\": \"trace\", \"remarks\": [\"remark:VRS:0.1\", \"remark:VRS:.10\"]}",
       "\"remarks\" lists the re-marking \"remark:VRS:.10\" twice"},
      {head + ", \"innocents\": [\"unmarked\"]}", "\"innocents\" needs \"mode\": \"trace\""},
      {head + ", \"mode\": \"trace\", \"innocents\": \"unmarked\"}",
       "\"innocents\" must be a list of \"unmarked\", \"other-key\", \"without-leaker\""},
      {head + ", \"mode\": \"trace\", \"innocents\": [1]}", "\"innocents\" lists 1, not one of"},
      {head + ", \"mode\": \"trace\", \"innocents\": [\"guilty\"]}",
       "\"innocents\" lists \"guilty\", not one of"},
      {head + ", \"mode\": \"trace\", \"innocents\": [\"unmarked\", \"unmarked\"]}",
       "\"innocents\" lists \"unmarked\" twice"},
      {head + ", \"mode\": \"trace\", \"fingerprint\": \"yes\"}", "wrong type"},
      {head + ", \"mode\": \"trace\", \"fingerprint\": true, \"fingerprint_rms\": 0.02}",
       "fingerprint_rms 0.02 is out of (0, 0.01]"},
      {head + ", \"mode\": \"trace\", \"fingerprint_rms\": 0.0002}",
       "\"fingerprint_rms\" needs \"fingerprint\": true"},
      // Attack parameters and protocols.
      {head + ", \"attacks\": [{\"kind\": \"noise\", \"lambda\": 0.03, \"strengths\": [1]}]}",
       "attacks[0]: no step of the attack reads 'lambda'"},
      {head +
           ", \"attacks\": [{\"kind\": \"taubin\", \"weighting\": \"cot\", \"strengths\": [1]}]}",
       "attacks[0]: unknown weighting 'cot' (one of: uniform, inverse-distance)"},
      {head + ", \"attacks\": [{\"kind\": \"smooth\", \"strengths\": [1]}, {\"kind\": \"smooth\", "
              "\"strengths\": [2]}]}",
       "attacks[1]: a second series \"smooth\""},
      {head + ", \"strength\": 0.05, \"protocols\": [{\"name\": \"p\"}]}",
       "\"protocols\" needs calibration"},
      {head + ", \"protocols\": [{\"name\": \"p\"}, {\"name\": \"p\"}]}",
       "protocols[1]: the name \"p\" is used twice"},
      {head + ", \"protocols\": [{\"max_rms\": 0.01}]}", "protocols[0]: \"name\" must be"},
      {head + ", \"protocols\": [{\"name\": \"p\", \"limit\": 1}]}",
       "protocols[0]: unknown key \"limit\""}};
  for (std::size_t i = 0; i < cases.size(); ++i) {
    const std::string path = write_text(dir + "/c" + std::to_string(i) + ".json", cases[i].text);
    const std::string message = error_of(path);
    EXPECT_NE(message.find(path), std::string::npos) << message;
    EXPECT_NE(message.find(cases[i].expect), std::string::npos) << message;
  }
}

TEST(Campaign, ChainsRunTheirStepsWithTheSeriesStrengthLast) {
  const std::vector<AttackStep> steps = series_chain("similarity:2,simplify", 0.3);
  ASSERT_EQ(steps.size(), 2u);
  EXPECT_EQ(steps[0].kind, "similarity");
  EXPECT_EQ(steps[0].strength, 2);
  EXPECT_EQ(steps[1].kind, "simplify");
  EXPECT_EQ(steps[1].strength, 0.3);
  EXPECT_EQ(series_chain("loop", 1).size(), 1u);
  // Deterministic when every step is.
  EXPECT_TRUE(attack_is_deterministic("quant:8,simplify"));
  EXPECT_TRUE(attack_is_deterministic("remesh"));
  EXPECT_FALSE(attack_is_deterministic("similarity:2,simplify"));
  EXPECT_FALSE(attack_is_deterministic("simplify:0.5,noise"));
}

TEST(Campaign, TraceModeIssuesConsecutiveIdsAndPlansAveragedTrials) {
  const std::string spot = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(spot, "spot.obj");
  const std::string path =
      write_text(test::scratch_dir() + "/trace.json",
                 "{\"models\": [\"" + spot +
                     "\"], \"variants\": [\"VRS\"], \"mode\": \"trace\", \"copies\": 50, "
                     "\"collusion\": true, \"payloads\": 3, \"draws\": 2, \"strength\": 0.05, "
                     "\"attacks\": [{\"kind\": \"similarity:2,quant\", \"strengths\": [8, 10]}, "
                     "{\"kind\": \"loop\", \"strengths\": [1]}]}");
  const CampaignConfig c = load_campaign(path);
  EXPECT_TRUE(c.trace);
  EXPECT_EQ(c.copies, 50);
  ASSERT_EQ(c.coalitions.size(), 1u);  // true: an average of two
  EXPECT_EQ(coalition_name(c.coalitions[0]), "average:2");
  EXPECT_EQ(c.spread, 0.25);
  // none 1 + chain 2 strengths x 2 draws + loop 1 = 6 trials, again on an average of two.
  const std::vector<std::string> keys = unit_trial_keys(c, {0, 0, 1});
  ASSERT_EQ(keys.size(), 12u);
  EXPECT_EQ(keys[1], "spot|VRS|1|similarity:2,quant|8|0");
  EXPECT_EQ(keys[6], "spot|VRS|1|none|0|0|avg2");
  const std::vector<IssuedCopy> copies = campaign_copies(c, "spot", "VRS", 0.05);
  ASSERT_EQ(copies.size(), 50u);
  for (std::size_t i = 0; i < copies.size(); ++i) {
    EXPECT_EQ(copies[i].id, campaign_first_id(c) + i);
    EXPECT_EQ(copies[i].key_fingerprint, key_fingerprint(campaign_key(c)));
    EXPECT_EQ(copies[i].strength_spread, 0.25);
  }
  EXPECT_FALSE(c.fingerprint);
  for (const IssuedCopy& copy : copies) EXPECT_EQ(copy.mark_format, kMarkFormatVersion);
  CampaignConfig f = c;
  f.fingerprint = true;  // "fingerprint": true: the records say mark format 3
  for (const IssuedCopy& copy : campaign_copies(f, "spot", "VRS", 0.05))
    EXPECT_EQ(copy.mark_format, kFingerprintMarkFormat);
  for (int p = 0; p < 3; ++p) {
    EXPECT_GE(campaign_leaker(c, p), campaign_first_id(c));
    EXPECT_LT(campaign_leaker(c, p), campaign_first_id(c) + 50);
  }
}

TEST(Campaign, TraceOutcomeIsRightOnlyWhenEveryoneNamedLeaked) {
  EXPECT_EQ(trace_outcome({}, {5}), TraceOutcome::None);
  EXPECT_EQ(trace_outcome({5}, {5}), TraceOutcome::Right);
  EXPECT_EQ(trace_outcome({6}, {5}), TraceOutcome::Wrong);
  EXPECT_EQ(trace_outcome({5, 6}, {5}), TraceOutcome::Wrong);
  EXPECT_EQ(trace_outcome({6}, {5, 6}), TraceOutcome::Right);  // one colluder of two
  EXPECT_EQ(trace_outcome({6, 5}, {5, 6}), TraceOutcome::Right);
  EXPECT_EQ(trace_outcome({5, 7}, {5, 6}), TraceOutcome::Wrong);
  EXPECT_STREQ(trace_outcome_name(TraceOutcome::Wrong), "wrong");
}

// Rows of a results directory by key, without the times (which differ from run to run).
std::map<std::string, std::string> rows_without_times(const std::string& dir) {
  std::map<std::string, std::string> rows;
  std::ifstream in(dir + "/rows.jsonl");
  for (std::string line; std::getline(in, line);) {
    TrialRow r = row_from_json(line);
    r.embed_seconds = r.attack_seconds = r.extract_seconds = r.trace_seconds = 0;
    EXPECT_TRUE(rows.emplace(r.key, row_to_json(r)).second) << "row twice: " << r.key;
  }
  return rows;
}

std::vector<std::string> split_csv(const std::string& line) {
  std::vector<std::string> cells;
  std::string cell;
  bool quoted = false;
  for (const char c : line) {
    if (c == '"')
      quoted = !quoted;
    else if (c == ',' && !quoted)
      cells.push_back(cell), cell.clear();
    else
      cell += c;
  }
  cells.push_back(cell);
  return cells;
}

TEST(Campaign, QuickCampaignWritesCompleteRowsMediansFiguresAndReport) {
  for (const char* m : {"bunny.ply", "spot.obj"}) MESHMARK_REQUIRE(test::data_mesh(m), m);
  MESHMARK_REQUIRE(test::cgal_mesh("fandisk.off"), "fandisk.off");
  const std::string dir = test::scratch_dir() + "/quick";
  const std::string config = std::string(MESHMARK_SOURCE_DIR) + "/bench/campaigns/quick.json";
  const test::CliRun run = test::run_cli("bench " + config + " --out " + dir);
  ASSERT_EQ(run.code, 0) << run.out;
  // 3 models x 3 variants x 2 payloads, each with: none 1, similarity 1 x 2 draws, noise 3 x 2,
  // quant 3, smooth 2, soup 2 x 2, simplify 2, loop 1 = 21 trials.
  const std::map<std::string, std::string> rows = rows_without_times(dir);
  EXPECT_EQ(rows.size(), 3u * 3 * 2 * 21);
  // Medians recomputed from rows.csv.
  std::ifstream csv(dir + "/rows.csv");
  std::string line;
  std::getline(csv, line);
  const std::vector<std::string> header = split_csv(line);
  auto column = [&](const char* name) {
    return static_cast<std::size_t>(std::find(header.begin(), header.end(), name) - header.begin());
  };
  // Statistics over the trials that measured a mark; the others counted apart.
  std::map<std::string, std::vector<double>> groups;
  std::map<std::string, int> left_out;
  int csv_rows = 0;
  while (std::getline(csv, line)) {
    const std::vector<std::string> c = split_csv(line);
    ASSERT_EQ(c.size(), header.size()) << line;
    ++csv_rows;
    const double ber = std::stod(c[column("ber")]);
    const std::string group = c[column("variant")] + "," + c[column("attack")] + "," +
                              std::to_string(std::stod(c[column("attack_strength")]));
    if (c[column("status")] == "ok")
      groups[group].push_back(ber);
    else
      ++left_out[group];
    if (c[column("attack")] == "none" && c[column("status")] == "ok")
      EXPECT_EQ(ber, 0.0) << "an embedding that does not decode: " << line;
  }
  EXPECT_EQ(csv_rows, static_cast<int>(rows.size()));
  std::ifstream summary(dir + "/summary.csv");
  std::getline(summary, line);
  int checked = 0;
  while (std::getline(summary, line)) {
    const std::vector<std::string> c = split_csv(line);
    const std::string group = c[0] + "," + c[1] + "," + std::to_string(std::stod(c[2]));
    std::vector<double> b = groups[group];
    ASSERT_FALSE(b.empty()) << line;
    EXPECT_EQ(std::stoi(c[7]), left_out[group]) << line;
    std::sort(b.begin(), b.end());
    const double median =
        b.size() % 2 ? b[b.size() / 2] : 0.5 * (b[b.size() / 2 - 1] + b[b.size() / 2]);
    EXPECT_NEAR(std::stod(c[3]), median, 1e-12) << line;
    EXPECT_EQ(std::stoi(c[5]), static_cast<int>(b.size())) << line;
    ++checked;
  }
  EXPECT_EQ(checked, 3 * 15);  // 3 variants x 15 (attack, strength) pairs
  for (const char* f :
       {"figure-noise.svg", "figure-simplify.svg", "figure-all.svg", "fig1.svg", "report.md"})
    EXPECT_TRUE(fs::exists(dir + "/" + f)) << f;
  const std::string report = read_file(dir + "/report.md");
  EXPECT_NE(report.find("## Calibrated strengths"), std::string::npos);
  EXPECT_NE(report.find("Table III"), std::string::npos);
  // Run again: nothing to do, same rows.
  const test::CliRun again = test::run_cli("bench " + config + " --out " + dir);
  ASSERT_EQ(again.code, 0) << again.out;
  EXPECT_NE(again.out.find("(0 run now"), std::string::npos) << again.out;
  EXPECT_EQ(rows_without_times(dir), rows);
}

// Cho's methods beside the QP framework in one campaign: calibrated to the same limits, read
// back with their own statistic, named in the report.
TEST(Campaign, ChoSchemesRunBesideTheQpFrameworkAtTheSameLimits) {
  MESHMARK_REQUIRE(test::data_mesh("spot.obj"), "spot.obj");
  const std::string dir = test::scratch_dir();
  const std::string config = write_text(dir + "/cho.json", R"({
    "name": "cho-side-by-side", "models": ["${data}/meshes/spot.obj"],
    "variants": ["DRS", "cho-mean", "cho-variance/VRS"], "bits": 32, "payloads": 2, "draws": 1,
    "seed": 7, "calibration": {"max_rms": 0.04, "max_msdm": 0.25, "iterations": 6},
    "attacks": [{"kind": "similarity", "strengths": [2]}, {"kind": "noise", "strengths": [0.0005]}]
  })");
  EXPECT_EQ(load_campaign(config).variants[2], "cho-variance/VRS");
  const test::CliRun run = test::run_cli("bench " + config + " --out " + dir + "/out");
  ASSERT_EQ(run.code, 0) << run.out;
  std::map<std::string, int> ok;
  for (const auto& [key, json] : rows_without_times(dir + "/out")) {
    const TrialRow r = row_from_json(json);
    if (r.status != "ok") continue;
    ++ok[r.variant];
    // Each scheme's own embedding, measured by the campaign, within the shared limits (the
    // search stops within 1 % of a limit from below).
    EXPECT_LE(r.rms_percent, 0.04 * (1 + 1e-9)) << key;
    EXPECT_LE(r.msdm, 0.25 * (1 + 1e-9)) << key;
    EXPECT_GT(r.strength, 0) << key;
    if (r.attack == "none" || r.attack == "similarity") EXPECT_EQ(r.ber, 0.0) << key;
  }
  for (const char* scheme : {"DRS", "cho-mean", "cho-variance/VRS"})
    EXPECT_EQ(ok[scheme], 2 * 3) << scheme << ": 2 payloads x (none, similarity, noise)";
  const std::string report = read_file(dir + "/out/report.md");
  EXPECT_NE(report.find("cho-mean"), std::string::npos);
  EXPECT_NE(report.find("cho-variance/VRS"), std::string::npos);
  EXPECT_THROW(load_campaign(write_text(dir + "/bad.json", R"({"name": "b",
    "models": ["${data}/meshes/spot.obj"], "variants": ["cho-mean/VRL"], "strength": 0.05,
    "attacks": [{"kind": "noise", "strengths": [0.001]}]})")),
               InvalidInputError);
}

// The benchmark-quick campaign: rows name their protocol, each embedding stays within its
// protocol's limits, the series' parameters reach the attack, and the report compares with
// the published results at equal distortion.
TEST(Campaign, BenchmarkQuickCampaignCalibratesPerProtocolAndPassesAttackParameters) {
  MESHMARK_REQUIRE(test::cgal_mesh("bunny00.off"), "bunny00.off");
  const std::string config =
      std::string(MESHMARK_SOURCE_DIR) + "/bench/campaigns/benchmark-quick.json";
  const CampaignConfig c = load_campaign(config);
  ASSERT_EQ(c.protocols.size(), 2u);
  EXPECT_EQ(c.protocols[0].name, "perceptual");
  EXPECT_EQ(c.protocols[1].calibration.max_rms_percent, 0.012);
  EXPECT_EQ(c.protocols[1].calibration.max_msdm, 0.29);
  EXPECT_EQ(c.protocols[1].calibration.iterations, 8);  // from "calibration"
  // The smoothing series with lambda 0.03 moves a vertex a tenth as far as lambda 0.3 does in
  // one step (interior vertices of an open grid; the boundary stays in both).
  const AttackSeries* smooth = nullptr;
  for (const AttackSeries& a : c.attacks)
    if (series_label(a) == "smooth [lambda=0.03 fixed_boundary]") smooth = &a;
  ASSERT_NE(smooth, nullptr);
  Eigen::MatrixX3d V(16, 3);
  for (int i = 0; i < 16; ++i) V.row(i) << i % 4, i / 4, 0.2 * ((i * 7) % 5);
  Eigen::MatrixX3i F(18, 3);
  for (int t = 0, y = 0; y < 3; ++y)
    for (int x = 0; x < 3; ++x, t += 2) {
      const int a = 4 * y + x;
      F.row(t) << a, a + 1, a + 5;
      F.row(t + 1) << a, a + 5, a + 4;
    }
  const Mesh grid = make_mesh(V, F);
  detail::PlannedTrial trial{smooth, 1, 0, 0, nullptr, "k"};
  const Mesh weak = detail::attack_for_trial(c, trial, grid);
  LaplacianOptions paper;
  paper.fixed_boundary = true;
  const Mesh strong = attack_smooth_laplacian(grid, 1, paper);
  EXPECT_GT((strong.V - V).norm(), 1e-3);
  EXPECT_NEAR((weak.V - V).norm(), 0.1 * (strong.V - V).norm(), 1e-12);

  const std::string dir = test::scratch_dir() + "/benchmark-quick";
  const test::CliRun run = test::run_cli("bench " + config + " --out " + dir + " --fresh");
  ASSERT_EQ(run.code, 0) << run.out;
  const std::map<std::string, std::string> rows = rows_without_times(dir);
  // 2 payloads x 2 protocols x (none 1 + noise 2 x 2 draws + smooth 2 + smooth 1 + quant 2 +
  // midpoint 1 = 11).
  EXPECT_EQ(rows.size(), 2u * 2 * 11);
  std::set<std::string> protocols, attacks;
  for (const auto& [key, json] : rows) {
    const TrialRow r = row_from_json(json);
    protocols.insert(r.protocol);
    attacks.insert(r.attack);
    EXPECT_EQ(key.substr(key.rfind('|') + 1), r.protocol);
    ASSERT_EQ(r.status, "ok") << key;
    const CalibrateOptions& limits = c.protocols[r.protocol == "perceptual" ? 0 : 1].calibration;
    EXPECT_LE(r.rms_percent, limits.max_rms_percent + 1e-12) << key;
    EXPECT_LE(r.msdm, limits.max_msdm + 1e-12) << key;
    if (r.attack == "none") EXPECT_EQ(r.ber, 0) << key;
  }
  EXPECT_EQ(protocols, (std::set<std::string>{"perceptual", "geometric"}));
  EXPECT_TRUE(attacks.count("quant [convention=benchmark]"));
  EXPECT_TRUE(attacks.count("smooth"));
  const std::string report = read_file(dir + "/report.md");
  EXPECT_NE(report.find("## Beside the published results of the LIRIS benchmark"),
            std::string::npos);
  EXPECT_NE(report.find("At the published distortion of Cho et al., perceptual"),
            std::string::npos);
  EXPECT_NE(report.find("| Cho et al., geometric | DRS |"), std::string::npos);
  // The paper's smoothing (lambda 0.3) is another definition: not compared.
  EXPECT_EQ(report.find("| smooth (umbrella"), std::string::npos);
}

// A campaign on the horse, long enough to be killed in the middle. A fixed strength: these
// tests are about rows surviving kills and ranks, and per-copy calibration (MSDM on the horse
// for every embedding) would only make them slower, under the sanitizers most of all.
std::string resumable_config(const std::string& dir) {
  const std::string horse = test::closed_binary_ply();
  return write_text(dir + "/resume.json",
                    "{\"name\": \"resume\", \"models\": [\"" + horse +
                        "\"], \"variants\": [\"DRS\", \"SRS\"], \"payloads\": 3, \"draws\": 6, "
                        "\"strength\": 0.02, \"attacks\": [{\"kind\": \"noise\", "
                        "\"strengths\": [0.0005, 0.001]}, {\"kind\": \"quant\", \"strengths\": "
                        "[10]}]}");
}

TEST(Campaign, KilledCampaignResumesWithoutLosingOrDoublingRows) {
  MESHMARK_REQUIRE(test::closed_binary_ply(), "bunny00.off");
  const std::string dir = test::scratch_dir();
  const std::string config = resumable_config(dir);
  const test::CliRun whole = test::run_cli("bench " + config + " --out " + dir + "/whole");
  ASSERT_EQ(whole.code, 0) << whole.out;
  const std::map<std::string, std::string> reference = rows_without_times(dir + "/whole");
  ASSERT_EQ(reference.size(), 2u * 3 * (1 + 2 * 6 + 1));

  const std::string out = dir + "/killed";
  int killed = 0;
  for (int attempt = 0; attempt < 12; ++attempt) {
    const test::CliRun r =
        test::run_cli("bench " + config + " --out " + out +
                      " --jobs 2 & pid=$!; "
                      "sleep 0.6; kill -9 $pid 2>/dev/null && echo KILLED; wait");
    if (r.out.find("KILLED") == std::string::npos) break;
    ++killed;
    // A kill can cut a line; simulate the worst case: a partial row at the end.
    if (fs::exists(out + "/rows.jsonl"))
      std::ofstream(out + "/rows.jsonl", std::ios::app) << "{\"key\": \"horse|DR";
  }
  const test::CliRun last = test::run_cli("bench " + config + " --out " + out);
  ASSERT_EQ(last.code, 0) << last.out;
  EXPECT_GT(killed, 0) << "the campaign finished before any kill: nothing was resumed";
  EXPECT_EQ(rows_without_times(out), reference);
}

TEST(Campaign, MpiRanksGiveTheRowsOfOneProcess) {
  MESHMARK_REQUIRE(test::closed_binary_ply(), "bunny00.off");
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "skipped: under AddressSanitizer, which cannot dlopen OpenMPI with "
                  "RTLD_DEEPBIND (see apps/cli_bench.cpp); the regular build runs this test";
#endif
  if (std::system("command -v mpirun >/dev/null 2>&1") != 0)
    GTEST_SKIP() << "skipped: mpirun is not installed (apt-get install openmpi-bin)";
  const std::string dir = test::scratch_dir();
  const std::string config = resumable_config(dir);
  const test::CliRun one = test::run_cli("bench " + config + " --out " + dir + "/one");
  ASSERT_EQ(one.code, 0) << one.out;
  const std::string env =
      "OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 "
      "OMPI_MCA_rmaps_base_oversubscribe=1 "
      "ASAN_OPTIONS=detect_leaks=0 ";
  const std::string cmd = env + "mpirun -np 2 -x ASAN_OPTIONS " + std::string(MESHMARK_CLI) +
                          " bench " + config + " --out " + dir + "/two 2>&1";
  FILE* pipe = popen(cmd.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  std::string out;
  char buf[4096];
  for (std::size_t n; (n = fread(buf, 1, sizeof buf, pipe)) > 0;) out.append(buf, n);
  ASSERT_EQ(pclose(pipe), 0) << out;
  EXPECT_NE(out.find("on 2 process(es)"), std::string::npos) << out;
  EXPECT_EQ(rows_without_times(dir + "/two"), rows_without_times(dir + "/one"));
}

TEST(Campaign, CalibrateCommandSavesAndReusesItsResult) {
  const std::string path = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(path, "spot.obj");
  const std::string cache = test::scratch_dir() + "/calibration.jsonl";
  const test::CliRun first =
      test::run_cli("calibrate " + path + " --variant SRS --iterations 6 --cache " + cache);
  ASSERT_EQ(first.code, 0) << first.out;
  EXPECT_EQ(first.out.find("[cached]"), std::string::npos) << first.out;
  const test::CliRun second =
      test::run_cli("calibrate " + path + " --variant SRS --iterations 6 --cache " + cache);
  ASSERT_EQ(second.code, 0) << second.out;
  EXPECT_NE(second.out.find("[cached]"), std::string::npos) << second.out;
  EXPECT_EQ(first.out.substr(0, first.out.find('(')), second.out.substr(0, second.out.find('(')));
  // Another limit is another calibration.
  const test::CliRun other = test::run_cli(
      "calibrate " + path + " --variant SRS --iterations 6 --max-msdm 0.2 --cache " + cache);
  ASSERT_EQ(other.code, 0) << other.out;
  EXPECT_EQ(other.out.find("[cached]"), std::string::npos) << other.out;
}

// The trace-quick campaign (the one CI runs): trace never names an innocent, nor the blind
// decoder, and trace names the leaker at least as often as the blind decoder decodes it, on
// the same attacked meshes; rows removed from the journal are run again to the same values.
TEST(Campaign, TraceQuickCampaignNamesNoInnocentAndBeatsTheBlindDecoder) {
  MESHMARK_REQUIRE(test::cgal_mesh("bunny00.off"), "bunny00.off");
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "skipped under AddressSanitizer: a 2-minute campaign there takes too long for "
                  "CI; the regular build runs it";
#endif
  const std::string dir = test::scratch_dir() + "/trace-quick";
  const std::string config = std::string(MESHMARK_SOURCE_DIR) + "/bench/campaigns/trace-quick.json";
  const test::CliRun run = test::run_cli("bench " + config + " --out " + dir + " --fresh");
  ASSERT_EQ(run.code, 0) << run.out;
  const std::map<std::string, std::string> rows = rows_without_times(dir);
  int trace_right = 0, blind_right = 0, n = 0;
  for (const auto& [key, json] : rows) {
    const TrialRow r = row_from_json(json);
    ++n;
    EXPECT_EQ(r.status, "ok") << key;
    EXPECT_NE(r.trace_outcome, "wrong") << key << ": trace named " << r.trace_named;
    EXPECT_NE(r.blind_outcome, "wrong") << key << ": blind decoded " << r.blind_id;
    trace_right += r.trace_outcome == "right";
    blind_right += r.blind_outcome == "right";
    if (r.attack == "none" && r.colluders == 1) EXPECT_EQ(r.trace_outcome, "right") << key;
  }
  EXPECT_GE(n, 10);
  EXPECT_GE(trace_right, blind_right);
  RecordProperty("trace_right", trace_right);
  RecordProperty("blind_right", blind_right);
  const std::string report = read_file(dir + "/report.md");
  EXPECT_NE(report.find("## Wrong outcomes: none"), std::string::npos);
  EXPECT_TRUE(fs::exists(dir + "/figure-trace.svg"));
  // Resume: drop every other row of the journal; the rerun gives them back unchanged.
  std::string kept;
  int i = 0;
  for (const auto& [key, json] : rows)
    if (i++ % 2) kept += json + "\n";
  write_text(dir + "/rows.jsonl", kept);
  const test::CliRun again = test::run_cli("bench " + config + " --out " + dir);
  ASSERT_EQ(again.code, 0) << again.out;
  EXPECT_NE(again.out.find(fmt::format("({} run now", n - n / 2)), std::string::npos) << again.out;
  EXPECT_EQ(rows_without_times(dir), rows);
}

// Re-marked leaks: the copy marked again as `embed --id` marks it (the re-mark's ID decodes under
// the public key, or under the other key and not the public one), rows named after the
// re-marking with the leaker alone, and trace names the leaker through the fingerprint (spot's
// copies, 40 issued) and never anyone else.
TEST(Campaign, RemarkedLeaksCarryTheNewMarkAndNameOnlyTheirBuyer) {
  const std::string spot = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(spot, "spot.obj");
  const std::string dir = test::scratch_dir() + "/remarks";
  const std::string config = spot_trace_campaign(
      "remarks",
      "\"remarks\": [\"remark:VRS\", \"remark-key:DRS:0.03\", \"remark:cho-mean\"], "
      "\"payloads\": 2");
  const CampaignConfig c = load_campaign(config);
  ASSERT_EQ(c.remarks.size(), 3u);
  EXPECT_EQ(remark_name(c.remarks[1]), "remark-key:DRS:0.03");
  EXPECT_EQ(remark_label(c.remarks[1]), "re-marked DRS at 0.03 (another key)");
  // A name holds the strength to the last digit: it parses back to the same re-marking.
  const CampaignRemark fine = parse_remark("remark:VRL:0.0123456789");
  EXPECT_EQ(fine.strength, 0.0123456789);
  EXPECT_EQ(parse_remark(remark_name(fine)).strength, fine.strength);

  const Mesh mesh = read_mesh(spot);
  const IdCode code(IdCodeOptions{c.bits});
  for (const CampaignRemark& r : c.remarks) {
    const Mesh leak = detail::remarked_copy(c, r, mesh, 123456);
    const MarkScheme scheme = parse_scheme(r.scheme);
    ExtractOptions xo;
    xo.bits = c.bits;
    xo.center = scheme.variant.center;
    xo.method = scheme.method;
    const std::optional<Key> key =
        r.other_key ? std::optional<Key>(detail::remarker_key(c)) : std::nullopt;
    const IdReading read = read_id(leak.V, leak.F, xo, code, key);
    ASSERT_TRUE(read.id.valid) << remark_name(r);
    EXPECT_EQ(read.id.id, 123456u) << remark_name(r);
    if (r.other_key) {
      const IdReading public_read = read_id(leak.V, leak.F, xo, code, std::nullopt);
      EXPECT_FALSE(public_read.id.valid && public_read.id.id == 123456u);
    }
  }

  const test::CliRun run = test::run_cli("bench " + config + " --out " + dir + " --fresh");
  ASSERT_EQ(run.code, 0) << run.out;
  const std::map<std::string, std::string> json_rows = rows_without_times(dir);
  ASSERT_EQ(json_rows.size(), 2u * 4);  // payloads x (the copy, 3 re-markings), attack none
  int remarked = 0;
  for (const auto& [key, json] : json_rows) {
    const TrialRow r = row_from_json(json);
    ASSERT_EQ(r.status, "ok") << key;
    EXPECT_EQ(r.colluders, 1) << key;
    EXPECT_EQ(r.leakers, std::to_string(campaign_leaker(c, r.payload))) << key;
    EXPECT_NE(r.trace_outcome, "wrong") << key << ": trace named " << r.trace_named;
    EXPECT_NE(r.blind_outcome, "wrong") << key << ": blind decoded " << r.blind_id;
    EXPECT_EQ(r.trace_outcome, "right") << key << ": " << r.trace_status;
    EXPECT_GE(r.innocent_p, 1e-6) << key;
    if (r.coalition.empty()) continue;
    ++remarked;
    EXPECT_TRUE(r.coalition == "remark:VRS" || r.coalition == "remark-key:DRS:0.03" ||
                r.coalition == "remark:cho-mean")
        << key;
    EXPECT_EQ(key.substr(key.size() - r.coalition.size() - 1), "|" + r.coalition) << key;
  }
  EXPECT_EQ(remarked, 6);
  const std::string report = read_file(dir + "/report.md");
  EXPECT_NE(report.find("| re-marked VRS (public key), none | 2 |"), std::string::npos) << report;
}

// Leaks that nobody in the registry leaked: the unmarked original, the leaker's ID issued with
// both marks under another key (which really carries that mark: it decodes under that key), and
// the leaker's copy traced against the registry without its row (which names the leaker with
// the row: the plain copy's trial). Trace names nobody in any of them; the blind decoder reads
// the leaker's ID from the leaker's copy alone.
TEST(Campaign, InnocentLeaksNameNobody) {
  const std::string spot = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(spot, "spot.obj");
  const std::string dir = test::scratch_dir() + "/innocents";
  const std::string config = spot_trace_campaign(
      "innocents",
      "\"innocents\": [\"unmarked\", \"other-key\", \"without-leaker\"], \"payloads\": 2");
  const CampaignConfig c = load_campaign(config);
  ASSERT_EQ(c.innocents.size(), 3u);
  EXPECT_EQ(innocent_name(c.innocents[1]), "innocent:other-key");

  const Mesh mesh = read_mesh(spot);
  const IdCode code(IdCodeOptions{c.bits});
  const Mesh other = detail::remarked_copy(c, CampaignRemark{"DRS", 0.05, true}, mesh, 4321);
  ExtractOptions xo;
  xo.bits = c.bits;
  xo.center = parse_scheme("DRS").variant.center;
  const IdReading read = read_id(other.V, other.F, xo, code, detail::remarker_key(c));
  ASSERT_TRUE(read.id.valid);
  EXPECT_EQ(read.id.id, 4321u);

  const test::CliRun run = test::run_cli("bench " + config + " --out " + dir + " --fresh");
  ASSERT_EQ(run.code, 0) << run.out;
  const std::map<std::string, std::string> json_rows = rows_without_times(dir);
  ASSERT_EQ(json_rows.size(), 2u * 4);  // payloads x (the copy, 3 innocent leaks), attack none
  std::map<std::string, int> seen;
  for (const auto& [key, json] : json_rows) {
    const TrialRow r = row_from_json(json);
    ASSERT_EQ(r.status, "ok") << key;
    const std::string leaker = std::to_string(campaign_leaker(c, r.payload));
    if (r.coalition.empty()) {  // the leaker's copy with its row: named
      EXPECT_EQ(r.trace_outcome, "right") << key << ": " << r.trace_status;
      continue;
    }
    ++seen[r.coalition];
    EXPECT_EQ(key.substr(key.size() - r.coalition.size() - 1), "|" + r.coalition) << key;
    EXPECT_EQ(r.colluders, 0) << key;
    EXPECT_EQ(r.leakers, "") << key;
    EXPECT_EQ(r.trace_outcome, "none") << key << ": trace named " << r.trace_named;
    EXPECT_EQ(r.trace_named, "") << key;
    EXPECT_GE(r.innocent_p, 1e-6) << key;
    const bool without = r.coalition == "innocent:without-leaker";
    EXPECT_EQ(r.innocents, without ? 39 : 40) << key;
    EXPECT_EQ(r.blind_outcome, without ? "right" : "none") << key << ": " << r.blind_id;
    if (without) EXPECT_EQ(r.blind_id, leaker) << key;
  }
  EXPECT_EQ(seen, (std::map<std::string, int>{{"innocent:other-key", 2},
                                              {"innocent:unmarked", 2},
                                              {"innocent:without-leaker", 2}}));
  const std::string report = read_file(dir + "/report.md");
  EXPECT_NE(report.find("| innocent: the original, unmarked, none | 2 | 0.0 % | 100.0 % | 0.0 % |"),
            std::string::npos)
      << report;
}

// A trace campaign on an original whose histogram mark is infeasible at the campaign's strength
// (libcgal-demo's mushroom at 0.05) issues each leaker's copy as issue_copies does: with the
// fingerprint alone (the trial's strength 0, its RMS that of the field alone, measured here
// against 1e-4 min(3, sqrt(32768 / counted)) within [0.5, 1.5]: one copy, 146 signs, the
// classes' lines left out), and trace names its buyer; without the fingerprint the unit is not
// issued, and its trials say why. The innocent leak of another key is issued by that shop the
// same way (the fingerprint alone, under its key) and names nobody here.
TEST(Campaign, AnInfeasibleHistogramMarkLeavesTheFingerprintAlone) {
  const std::string mushroom = test::cgal_mesh("mushroom.off");
  MESHMARK_REQUIRE(mushroom, "libcgal-demo's mushroom.off");
  const Mesh mesh = read_mesh(mushroom);
  const std::vector<std::uint8_t> carrier = carrier_vertices(mesh.V, mesh.F);
  const auto counted = static_cast<double>(std::count(carrier.begin(), carrier.end(), kCounted));
  CampaignConfig c;  // the campaign with the fingerprint
  for (const bool fingerprint : {true, false}) {
    const std::string name = fingerprint ? "mushroom-alone" : "mushroom-without";
    const std::string dir = test::scratch_dir() + "/" + name;
    const std::string config =
        write_text(test::scratch_dir() + "/" + name + ".json",
                   "{\"models\": [\"" + mushroom +
                       "\"], \"variants\": [\"VRS\"], \"mode\": \"trace\", \"copies\": 40, "
                       "\"fingerprint\": " +
                       (fingerprint ? "true" : "false") +
                       ", \"strength\": 0.05, \"draws\": 1, \"payloads\": 2, \"attacks\": [], " +
                       "\"innocents\": [\"other-key\"]}");
    if (fingerprint) c = load_campaign(config);
    const test::CliRun run = test::run_cli("bench " + config + " --out " + dir + " --fresh");
    ASSERT_EQ(run.code, 0) << run.out;
    const std::map<std::string, std::string> rows = rows_without_times(dir);
    ASSERT_EQ(rows.size(), 4u) << name;  // payloads x (the copy, the other key's copy)
    for (const auto& [key, json] : rows) {
      const TrialRow r = row_from_json(json);
      if (!r.coalition.empty()) {    // the other key's copy, issued as that shop would issue it
        if (!fingerprint) continue;  // without a fingerprint the unit is not issued at all
        ASSERT_EQ(r.status, "ok") << key;
        EXPECT_EQ(r.coalition, "innocent:other-key") << key;
        EXPECT_EQ(r.trace_outcome, "none") << key << ": trace named " << r.trace_named;
        EXPECT_EQ(r.innocents, 40) << key;
        continue;
      }
      if (!fingerprint) {
        EXPECT_NE(r.status.find("infeasible"), std::string::npos) << key << ": " << r.status;
        EXPECT_EQ(r.trace_outcome, "none") << key;
        continue;
      }
      ASSERT_EQ(r.status, "ok") << key;
      EXPECT_EQ(r.strength, 0.0) << key;
      const double expected =
          100 * 1e-4 * std::min(3.0, std::sqrt(32768 / counted));  // % of the diagonal
      EXPECT_GT(r.rms_percent, 0.5 * expected) << key;
      EXPECT_LT(r.rms_percent, 1.5 * expected) << key;
      EXPECT_EQ(r.trace_outcome, "right") << key << ": " << r.trace_status;
      EXPECT_EQ(r.trace_named, std::to_string(campaign_leaker(c, r.payload))) << key;
    }
    // Trials that did not run are no "none": the summary counts them apart (every trial of
    // the campaign without the fingerprint failed: 0 trials, 2 failed in each line).
    std::ifstream summary(dir + "/summary.csv");
    std::string line;
    std::getline(summary, line);
    EXPECT_EQ(line.substr(line.rfind(',') + 1), "failed") << line;
    int lines = 0;
    while (std::getline(summary, line)) {
      std::vector<std::string> f;
      std::stringstream fields(line);
      for (std::string x; std::getline(fields, x, ',');) f.push_back(x);
      ASSERT_EQ(f.size(), 17u) << line;
      EXPECT_EQ(f[4], fingerprint ? "2" : "0") << line;   // trials
      EXPECT_EQ(f[16], fingerprint ? "0" : "2") << line;  // failed
      if (!fingerprint) EXPECT_EQ(f[6], "0") << line;     // trace none: not counted
      ++lines;
    }
    EXPECT_EQ(lines, 2) << name;  // the copy and the other key's copy, attack none
  }
  // The other key's copy of such an original carries that key's fingerprint alone: traced
  // against rows of that shop's key (strength 0: no histogram mark), it names its ID alone.
  const Mesh other = detail::remarked_copy(c, CampaignRemark{"VRS", 0.05, true}, mesh, 4321);
  const Key that_key = detail::remarker_key(c);
  std::vector<IssuedCopy> that_shops_rows(20);
  for (int i = 0; i < 20; ++i) {
    IssuedCopy& copy = that_shops_rows[static_cast<std::size_t>(i)];
    copy.id = 4311 + static_cast<std::uint64_t>(i);
    copy.bits = c.bits;
    copy.variant = "VRS";
    copy.strength = 0;
    copy.key_fingerprint = key_fingerprint(that_key);
    copy.mark_format = kFingerprintMarkFormat;
  }
  const TraceResult traced = trace(other, mesh, that_shops_rows, that_key);
  ASSERT_EQ(traced.named.size(), 1u) << traced.message;
  EXPECT_EQ(traced.named[0].copy.id, 4321u);
}

// Coalitions of consecutive IDs: each trial's leakers are the unit's leaker and the K - 1 IDs
// next to it, every merged leak (equal, unequal, spliced; spot with the fingerprint) names
// colluders only, and the summary's counts are those of the rows, recounted here.
TEST(Campaign, CoalitionsOfConsecutiveIdsNameColludersOnly) {
  const std::string spot = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(spot, "spot.obj");
  const std::string dir = test::scratch_dir() + "/coalitions";
  const std::string config = spot_trace_campaign(
      "coalitions",
      "\"collusion\": [\"average:2\", \"weighted:3\", \"splice:3\", \"average:5\"], "
      "\"payloads\": 3, \"attacks\": [{\"kind\": \"noise\", \"strengths\": [0.0005]}]");
  const CampaignConfig c = load_campaign(config);
  const test::CliRun run = test::run_cli("bench " + config + " --out " + dir + " --fresh");
  ASSERT_EQ(run.code, 0) << run.out;
  const std::map<std::string, std::string> json_rows = rows_without_times(dir);
  ASSERT_EQ(json_rows.size(), 3u * 2 * 5);  // payloads x (none, noise) x (a copy, 4 coalitions)
  std::vector<TrialRow> rows;
  std::map<std::string, int> right, all, innocents;
  std::map<std::string, double> innocent_p;
  bool some_innocent_scored = false;  // an innocent_p below 1: recorded, not left as it was
  for (const auto& [key, json] : json_rows) {
    const TrialRow r = row_from_json(json);
    rows.push_back(r);
    ASSERT_EQ(r.status, "ok") << key;
    EXPECT_NE(r.trace_outcome, "wrong") << key << ": trace named " << r.trace_named;
    EXPECT_NE(r.blind_outcome, "wrong") << key << ": blind decoded " << r.blind_id;
    std::vector<std::uint64_t> leakers, named;
    std::istringstream l(r.leakers), n(r.trace_named);
    for (std::uint64_t id; l >> id;) leakers.push_back(id);
    for (std::uint64_t id; n >> id;) named.push_back(id);
    const int size =
        r.coalition.empty() ? 1 : std::stoi(r.coalition.substr(r.coalition.find(':') + 1));
    ASSERT_EQ(leakers.size(), static_cast<std::size_t>(size)) << key;
    EXPECT_EQ(r.colluders, size) << key;
    EXPECT_EQ(leakers.front(), campaign_leaker(c, r.payload)) << key;
    const auto [lo, hi] = std::minmax_element(leakers.begin(), leakers.end());
    EXPECT_EQ(*hi - *lo, static_cast<std::uint64_t>(size - 1)) << key << ": not consecutive";
    EXPECT_GE(*lo, campaign_first_id(c)) << key;
    EXPECT_LT(*hi, campaign_first_id(c) + 40) << key;
    EXPECT_EQ(std::set<std::uint64_t>(leakers.begin(), leakers.end()).size(), leakers.size());
    if (!r.coalition.empty()) {
      const std::string suffix = r.coalition == "average:2" ? "|avg2" : "|" + r.coalition;
      EXPECT_EQ(key.substr(key.size() - suffix.size()), suffix) << key;
    }
    std::sort(leakers.begin(), leakers.end()), std::sort(named.begin(), named.end());
    EXPECT_EQ(r.trace_all_named, r.trace_outcome == "right" && named == leakers) << key;
    // Every candidate but the leakers is an innocent's test, none below the threshold.
    EXPECT_EQ(r.innocents, 40 - size) << key;
    EXPECT_GE(r.innocent_p, 1e-6) << key;
    // trace_p is the best candidate's, so the best innocent's is no smaller.
    EXPECT_GE(r.innocent_p, r.trace_p) << key;
    some_innocent_scored |= r.innocent_p < 1;
    const std::string group = r.attack + "|" + r.coalition;
    right[group] += r.trace_outcome == "right";
    all[group] += r.trace_all_named;
    innocents[group] += r.innocents;
    innocent_p[group] = std::min(innocent_p.count(group) ? innocent_p[group] : 1.0, r.innocent_p);
  }
  EXPECT_TRUE(some_innocent_scored);
  const std::vector<TraceSummaryRow> summary = summarize_trace(c, rows);
  ASSERT_EQ(summary.size(), 10u);
  EXPECT_EQ(summary[0].coalition, "");
  EXPECT_EQ(summary.back().coalition, "average:5");
  for (const TraceSummaryRow& s : summary) {
    const std::string group = s.attack + "|" + s.coalition;
    EXPECT_EQ(s.trials, 3) << group;
    EXPECT_EQ(s.trace_wrong, 0) << group;
    EXPECT_EQ(s.trace_right, right[group]) << group;
    EXPECT_EQ(s.trace_all, all[group]) << group;
    EXPECT_EQ(s.innocents, innocents[group]) << group;
    EXPECT_EQ(s.innocent_p, innocent_p[group]) << group;
    RecordProperty("right_" + group, s.trace_right);
  }
  EXPECT_EQ(summary[0].trace_right, 3) << "an unprocessed copy names its buyer";
  const std::string report = read_file(dir + "/report.md");
  EXPECT_NE(report.find("| unequal average of 3, noise:0.0005 | 3 |"), std::string::npos);
  EXPECT_NE(report.find("splice of 3, average of 5"), std::string::npos);
  // Rows of copies issued in another mark format, with another rule for the field's RMS, or
  // traced by another version of the fingerprint's reading (an older build's) are not resumed:
  // the directory says which format, rule and reading its rows hold.
  const std::string held = "mark format " + std::to_string(kFingerprintMarkFormat) +
                           ", fingerprint reading " + std::to_string(kFingerprintReading) +
                           ", raised below 32768 vertices";
  EXPECT_EQ(read_file(dir + "/mark_format.txt"), held + "\n");
  const test::CliRun again = test::run_cli("bench " + config + " --out " + dir);
  ASSERT_EQ(again.code, 0) << again.out;
  EXPECT_NE(again.out.find("(0 run now"), std::string::npos) << again.out;
  for (const std::string older_build :
       {std::string("mark format 4"), "mark format " + std::to_string(kFingerprintMarkFormat),
        "mark format " + std::to_string(kFingerprintMarkFormat) + ", fingerprint reading " +
            std::to_string(kFingerprintReading)}) {
    write_text(dir + "/mark_format.txt", older_build + "\n");
    const test::CliRun older = test::run_cli("bench " + config + " --out " + dir);
    EXPECT_EQ(older.code, 1) << older.out;
    EXPECT_NE(older.out.find("holds rows of copies issued and traced as " + older_build +
                             ", where this build has " + held),
              std::string::npos)
        << older.out;
  }
  std::filesystem::remove(dir + "/mark_format.txt");  // a directory of an older build
  EXPECT_EQ(test::run_cli("bench " + config + " --out " + dir).code, 1);
}

TEST(Campaign, SummaryLeavesOutTrialsWithoutAMarkInsteadOfCountingThemAsHalf) {
  // Two models: one marked (BER 0.1, 0.2, 0.3), one that no strength could mark within the
  // limits (its rows carry BER 0.5 and a status). The statistics are those of the marked ones.
  CampaignConfig c;
  c.variants = {"DRS"};
  c.protocols = {CampaignProtocol{}};
  c.attacks = {AttackSeries{"noise", {0.001}, 0, {}}};
  std::vector<TrialRow> rows;
  for (const double ber : {0.1, 0.2, 0.3, 0.5, 0.5}) {
    TrialRow r;
    r.variant = "DRS";
    r.attack = "noise";
    r.attack_strength = 0.001;
    r.ber = ber;
    r.status = ber < 0.5 ? "ok" : "no strength meets the calibration limits";
    rows.push_back(r);
  }
  const std::vector<SummaryRow> s = summarize(c, rows);
  ASSERT_EQ(s.size(), 1u);
  EXPECT_EQ(s[0].trials, 3);
  EXPECT_EQ(s[0].excluded, 2);
  EXPECT_NEAR(s[0].median_ber, 0.2, 1e-15);
  EXPECT_NEAR(s[0].mean_ber, 0.2, 1e-15);
  // Nothing measured: no row at all, rather than a made-up 0.5.
  for (TrialRow& r : rows) r.status = "attack failed: x";
  EXPECT_TRUE(summarize(c, rows).empty());
}
}  // namespace
}  // namespace meshmark
