// run_campaign (campaign_run.h): a campaign whose journal was cut by a kill and lost rows
// resumes to the rows of a fresh run, the cut line reported; two processes (rank hooks on
// threads) give the rows of one; a directory of another campaign is refused; the journals'
// JSON lines keep their shape.

#include <gtest/gtest.h>

#include <barrier>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <thread>

#include "campaign/campaign_parts.h"
#include "meshmark/campaign/campaign.h"
#include "meshmark/campaign/campaign_run.h"
#include "meshmark/core/error.h"
#include "meshmark/io/io.h"
#include "test_data.h"

namespace meshmark {
namespace {

namespace fs = std::filesystem;

// Trials per unit of small_campaign: none, 3 noise draws, quant.
constexpr std::size_t kTrialsPerUnit = 1 + 3 + 1;
constexpr std::size_t kUnits = 1 * 2 * 2;  // models x variants x payloads

// A small campaign on spot (2930 vertices) at a fixed strength, as the CLI's resume tests: 20
// trials, under a second.
CampaignConfig small_campaign(const std::string& dir) {
  const std::string path = dir + "/small.json";
  std::ofstream(path) << "{\"name\": \"small\", \"models\": [\"" << test::data_mesh("spot.obj")
                      << "\"], \"variants\": [\"DRS\", \"SRS\"], \"payloads\": 2, \"draws\": 3, "
                         "\"strength\": 0.02, \"attacks\": [{\"kind\": \"noise\", \"strengths\": "
                         "[0.001]}, {\"kind\": \"quant\", \"strengths\": [10]}]}";
  return load_campaign(path);
}

// Rows by key with their times zeroed (the times differ between runs, nothing else may).
std::map<std::string, std::string> rows_by_key(const std::vector<TrialRow>& rows) {
  std::map<std::string, std::string> out;
  for (TrialRow r : rows) {
    r.embed_seconds = r.attack_seconds = r.extract_seconds = r.trace_seconds = 0;
    EXPECT_TRUE(out.emplace(r.key, row_to_json(r)).second) << "row twice: " << r.key;
  }
  return out;
}

// The journal's lines, read back as rows (each must read).
std::vector<TrialRow> journal_rows(const std::string& dir) {
  std::vector<TrialRow> rows;
  for (const std::string& line : test::split_lines(read_file(dir + "/rows.jsonl")))
    if (!line.empty()) rows.push_back(row_from_json(line));
  return rows;
}

CampaignRunOptions options_for(const std::string& out) {
  CampaignRunOptions o;
  o.out_dir = out;
  o.jobs = 2;
  return o;
}

TEST(CampaignRun, CutJournalResumesToTheRowsOfAFreshRunAndReportsTheCutLine) {
  MESHMARK_REQUIRE(test::data_mesh("spot.obj"), "spot.obj");
  const std::string dir = test::scratch_dir();
  const CampaignConfig config = small_campaign(dir);
  const CampaignRunResult fresh = run_campaign(config, options_for(dir + "/fresh"));
  ASSERT_EQ(fresh.status, CampaignRunResult::Status::Complete);
  ASSERT_EQ(fresh.rows.size(), kUnits * kTrialsPerUnit);
  EXPECT_EQ(fresh.trials_run, static_cast<long>(kUnits * kTrialsPerUnit));
  EXPECT_EQ(fresh.dropped_lines, 0);
  const auto reference = rows_by_key(fresh.rows);

  // A second directory run whole, then "killed": the journal keeps 7 rows and a line cut in
  // the middle, the calibrations a line cut too.
  const std::string out = dir + "/killed";
  ASSERT_EQ(run_campaign(config, options_for(out)).rows.size(), reference.size());
  const std::vector<std::string> lines = test::split_lines(read_file(out + "/rows.jsonl"));
  const std::size_t kept = 7;
  std::string cut;
  for (std::size_t i = 0; i < kept; ++i) cut += lines[i] + "\n";
  cut += lines[kept].substr(0, lines[kept].size() / 2);
  write_file_atomically(out + "/rows.jsonl", cut);
  const std::string calibrations = read_file(out + "/calibration.jsonl");
  write_file_atomically(out + "/calibration.jsonl",
                        calibrations.substr(0, calibrations.find('\n') + 1) + "{\"model\": \"ho");

  const CampaignRunResult resumed = run_campaign(config, options_for(out));
  ASSERT_EQ(resumed.status, CampaignRunResult::Status::Complete);
  EXPECT_EQ(resumed.dropped_lines, 2);
  ASSERT_EQ(resumed.diagnostics.size(), 2u);
  EXPECT_NE(resumed.diagnostics[1].find("rows.jsonl: dropped a last line cut short"),
            std::string::npos)
      << resumed.diagnostics[1];
  EXPECT_EQ(resumed.trials_resumed, static_cast<long>(kept));
  EXPECT_EQ(resumed.trials_run, static_cast<long>(reference.size() - kept));
  EXPECT_EQ(resumed.calibrations_resumed, 1);
  EXPECT_EQ(resumed.calibrations_run, 1);
  EXPECT_EQ(rows_by_key(resumed.rows), reference);
  // The journal on disk: every trial once, as the fresh run's.
  const std::vector<TrialRow> on_disk = journal_rows(out);
  EXPECT_EQ(on_disk.size(), reference.size());
  EXPECT_EQ(rows_by_key(on_disk), reference);
}

TEST(CampaignRun, TwoRanksGiveTheRowsOfOneProcess) {
  MESHMARK_REQUIRE(test::data_mesh("spot.obj"), "spot.obj");
  const std::string dir = test::scratch_dir();
  const CampaignConfig config = small_campaign(dir);
  const auto reference = rows_by_key(run_campaign(config, options_for(dir + "/one")).rows);

  // Two "processes" on threads, a barrier and an and-reduction between them.
  std::barrier sync(2);
  std::atomic<int> refusals{0};
  std::atomic<bool> both_ok{true};
  CampaignRunResult results[2];
  auto rank = [&](int r) {
    CampaignRunOptions o = options_for(dir + "/two");
    o.jobs = 1;
    o.ranks.rank = r;
    o.ranks.size = 2;
    o.ranks.barrier = [&] { sync.arrive_and_wait(); };
    o.ranks.all = [&](bool ok) {
      if (!ok) both_ok = false;
      sync.arrive_and_wait();
      const bool all = both_ok;
      sync.arrive_and_wait();
      return all;
    };
    results[r] = run_campaign(config, o);
    refusals += results[r].status == CampaignRunResult::Status::Refused;
  };
  std::thread other(rank, 1);
  rank(0);
  other.join();
  EXPECT_EQ(refusals, 0);
  EXPECT_EQ(results[0].trials_run + results[1].trials_run,
            static_cast<long>(kUnits * kTrialsPerUnit));
  EXPECT_GT(results[1].trials_run, 0);
  EXPECT_TRUE(results[1].rows.empty());  // only rank 0 merges
  EXPECT_EQ(rows_by_key(results[0].rows), reference);
}

TEST(CampaignRun, RefusesADirectoryOfAnotherCampaign) {
  MESHMARK_REQUIRE(test::data_mesh("spot.obj"), "spot.obj");
  const std::string dir = test::scratch_dir();
  const CampaignConfig config = small_campaign(dir);
  fs::create_directories(dir + "/out");
  write_file_atomically(dir + "/out/campaign.json", "{\"name\": \"another\"}");
  try {
    run_campaign(config, options_for(dir + "/out"));
    ADD_FAILURE() << "a directory of another campaign was used";
  } catch (const InvalidArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("holds the results of another campaign file"),
              std::string::npos)
        << e.what();
  }
  EXPECT_FALSE(fs::exists(dir + "/out/rows.jsonl"));
}

// A config built in code is checked as a campaign file is: a coalition larger than the copies
// issued (or than 64) is refused before anything is written.
TEST(CampaignRun, RefusesACoalitionLargerThanTheCopiesIssued) {
  MESHMARK_REQUIRE(test::data_mesh("spot.obj"), "spot.obj");
  const std::string dir = test::scratch_dir();
  CampaignConfig config = small_campaign(dir);
  config.trace = true;
  config.copies = 4;
  for (const int size : {5, 65, 1}) {
    config.coalitions = {CampaignCoalition{CollusionKind::Average, false, size}};
    try {
      run_campaign(config, options_for(dir + "/out"));
      ADD_FAILURE() << "a coalition of " << size << " among 4 copies was run";
    } catch (const InvalidArgumentError& e) {
      EXPECT_NE(std::string(e.what()).find("needs 2 to 64 colluders among the 4 copies issued"),
                std::string::npos)
          << e.what();
    }
    EXPECT_FALSE(fs::exists(dir + "/out")) << size;
  }
}

// Journal lines as earlier versions wrote them, read and written back to the same JSON.
TEST(CampaignRun, JournalLinesKeepTheirShape) {
  const std::string row =
      R"({"attack":"noise","attack_seconds":0.01,"attack_strength":0.001,"ber":0.03125,)"
      R"("draw":2,"embed_seconds":1.5,"erasures":1,"extract_seconds":0.02,)"
      R"("key":"horse|DRS|1|noise|0.001|2","model":"horse","msdm":0.12,"payload":1,)"
      R"("rms_percent":0.004,"status":"ok","strength":0.02,"variant":"DRS","vertices":112642})";
  const TrialRow r = row_from_json(row);
  EXPECT_EQ(r.key, "horse|DRS|1|noise|0.001|2");
  EXPECT_EQ(r.vertices, 112642);
  EXPECT_EQ(r.erasures, 1);
  EXPECT_DOUBLE_EQ(r.ber, 1.0 / 32);
  EXPECT_EQ(r.protocol, "");
  EXPECT_EQ(r.colluders, 0);
  EXPECT_EQ(nlohmann::json::parse(row_to_json(r)), nlohmann::json::parse(row));

  // A calibration from before the bin offset was searched: G is the paper's 0.05.
  const std::string calibration =
      R"({"evaluations":9,"model":"horse","msdm":0.2,"rms_percent":0.03,"seconds":4.5,)"
      R"("status":"converged","strength":0.031,"variant":"VRS"})";
  const CalibrationRecord c = calibration_from_json(calibration);
  EXPECT_EQ(c.evaluations, 9);
  EXPECT_DOUBLE_EQ(c.bin_offset, 0.05);
  nlohmann::json expected = nlohmann::json::parse(calibration);
  expected["bin_offset"] = 0.05;
  EXPECT_EQ(nlohmann::json::parse(calibration_to_json(c)), expected);

  // A row without one of its fields is refused, naming it.
  nlohmann::json partial = nlohmann::json::parse(row);
  partial.erase("ber");
  try {
    row_from_json(partial.dump());
    ADD_FAILURE() << "a row without ber was read";
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find("'ber'"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace meshmark
