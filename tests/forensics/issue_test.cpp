// Issuing copies through the library (issue.h), as a program using meshmark would: consecutive
// buyer IDs into one registry, each copy naming its buyer and no neighbour, clashes refused
// before anything is written, a rerun skipping what was issued, and the calibration cache
// (calibration_cache.h) and parallel loop the issue relies on.

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <sodium.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <set>
#include <thread>
#include <tuple>

#include "core/parallel.h"
#include "meshmark/campaign/calibration_cache.h"
#include "meshmark/core/error.h"
#include "meshmark/forensics/issue.h"
#include "meshmark/forensics/spacing.h"
#include "meshmark/io/io.h"
#include "meshmark/protocol/watermark.h"
#include "test_data.h"

namespace meshmark {
namespace {

namespace fs = std::filesystem;

// BLAKE2b-256 of a file's bytes, computed here with libsodium (not through content_hash).
std::string blake2b_hex(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  unsigned char h[32];
  crypto_generichash(h, sizeof h, reinterpret_cast<const unsigned char*>(bytes.data()),
                     bytes.size(), nullptr, 0);
  std::string hex;
  for (unsigned char c : h) hex += fmt::format("{:02x}", c);
  return hex;
}

IssueSettings shop_settings(const std::string& registry) {
  IssueSettings s;
  s.bits = 64;
  s.embedding.strength = 0.05;
  s.key = key_from_passphrase("issue test key");
  s.registry = registry;
  return s;
}

// Consecutive IDs, five copies of one original on two threads: each written copy carries its
// own ID (read back blind by read_id) and its neighbours' are not detected in it; the registry
// holds exactly these copies with the hashes of the bytes on disk.
TEST(Issue, ConsecutiveIdsEachNameTheirBuyerAndAreRecordedWithTheirBytes) {
  const std::string original = test::cgal_mesh("elephant.off");
  MESHMARK_REQUIRE(original, "libcgal-demo's elephant.off");
  const std::string dir = test::scratch_dir() + "/issue-consecutive";
  fs::remove_all(dir);
  fs::create_directories(dir);
  IssueSettings settings = shop_settings(dir + "/shop.db");
  settings.threads = 2;
  std::vector<CopyRequest> requests;
  for (std::uint64_t id = 700; id < 705; ++id) {
    CopyRequest r;
    r.input = original;
    r.output = fmt::format("{}/copy-{}.ply", dir, id);
    r.id = id;
    r.buyer = fmt::format("buyer {}", id);
    requests.push_back(r);
  }
  const IssueResult result = issue_copies(requests, settings);
  ASSERT_EQ(result.copies.size(), requests.size());
  EXPECT_EQ(result.inputs, 1u);
  EXPECT_EQ(result.threads, 2);
  EXPECT_EQ(result.count(CopyStatus::Written), requests.size());
  IdCodeOptions co;
  const IdCode code(co);
  for (std::size_t k = 0; k < requests.size(); ++k) {
    SCOPED_TRACE(requests[k].output);
    const Mesh copy = read_mesh(requests[k].output);
    ExtractOptions eo;
    const IdReading read = read_id(copy.V, copy.F, eo, code, settings.key);
    ASSERT_TRUE(read.id.valid) << read.id.message;
    EXPECT_EQ(read.id.id, *requests[k].id);
    for (const std::uint64_t other : {*requests[k].id - 1, *requests[k].id + 1}) {
      MarkExpectation expect;
      expect.id = other;
      const MarkDetection d = detect_mark(copy.V, copy.F, eo, expect, settings.key);
      EXPECT_FALSE(d.detection.detected) << "ID " << other << " p " << d.detection.p_value;
    }
    MarkExpectation own;
    own.id = requests[k].id;
    EXPECT_TRUE(detect_mark(copy.V, copy.F, eo, own, settings.key).detection.detected);
  }
  const std::vector<IssuedCopy> recorded = read_registry(settings.registry);
  ASSERT_EQ(recorded.size(), requests.size());
  for (const IssuedCopy& c : recorded) {
    const std::string output = fmt::format("{}/copy-{}.ply", dir, c.id);
    EXPECT_EQ(c.output_hash, blake2b_hex(output));
    EXPECT_EQ(c.original_hash, blake2b_hex(original));
    EXPECT_EQ(c.buyer, fmt::format("buyer {}", c.id));
    EXPECT_EQ(c.output_path, fs::absolute(output).lexically_normal().string());
  }
  // Run again: every copy was issued and is intact, so each is skipped, nothing re-recorded.
  const IssueResult again = issue_copies(requests, settings);
  EXPECT_EQ(again.count(CopyStatus::Skipped), requests.size());
  EXPECT_EQ(read_registry(settings.registry).size(), requests.size());
  // Asked for by hand (no resume), an ID issued before is refused, naming its buyer.
  settings.resume = false;
  const IssueResult by_hand = issue_copies({requests[2]}, settings);
  EXPECT_EQ(by_hand.copies[0].status, CopyStatus::Refused);
  EXPECT_NE(by_hand.copies[0].message.find("already issued"), std::string::npos);
  EXPECT_NE(by_hand.copies[0].message.find("buyer 702"), std::string::npos);
}

// Refusals before anything is embedded: two copies writing one file, a copy over its own
// original, an ID given twice (neither copy gets it), a raw payload into a registry, malformed
// manifest lines. None of them writes a file; the one sound copy is written and recorded.
TEST(Issue, ClashesAndMalformedRequestsAreRefusedAndWriteNothing) {
  const std::string original = test::cgal_mesh("fandisk.off");
  MESHMARK_REQUIRE(original, "libcgal-demo's fandisk.off");
  const std::string dir = test::scratch_dir() + "/issue-clashes";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string own = dir + "/original.off";
  fs::copy_file(original, own);
  const std::string manifest = dir + "/jobs.txt";
  std::ofstream(manifest) << fmt::format(
      "{0} {1}/a.ply id:1 Ann\n"
      "{0} {1}/a.ply id:2 Bo\n"  // same output as line 1
      "{0} {0} id:3 Cy\n"        // over its original
      "{0} {1}/d.ply id:4 Di\n"
      "{0} {1}/e.ply id:4 Ed\n"           // ID 4 again: neither gets it
      "{0} {1}/f.ply 0123456789abcdef\n"  // raw payload into a registry
      "{0} {1}/g.ply\n"                   // malformed
      "# a comment\n\n"
      "{0} {1}/h.ply id:-5 Hal\n"  // not an ID
      "{0} {1}/i.ply id:9 Ivy\n",
      own, dir);
  const std::vector<CopyRequest> requests = read_manifest(manifest);
  ASSERT_EQ(requests.size(), 9u);
  EXPECT_EQ(requests[6].line, 7u);
  EXPECT_FALSE(requests[6].refusal.empty());
  EXPECT_EQ(requests[7].line, 10u);
  EXPECT_FALSE(requests[7].refusal.empty());
  const std::string before = blake2b_hex(own);
  const IssueResult r = issue_copies(requests, shop_settings(dir + "/shop.db"));
  const std::vector<CopyStatus> want = {
      CopyStatus::Refused, CopyStatus::Refused, CopyStatus::Refused,
      CopyStatus::Refused, CopyStatus::Refused, CopyStatus::Refused,
      CopyStatus::Refused, CopyStatus::Refused, CopyStatus::Written};
  for (std::size_t k = 0; k < want.size(); ++k)
    EXPECT_EQ(r.copies[k].status, want[k])
        << "line " << requests[k].line << ": " << r.copies[k].message;
  EXPECT_NE(r.copies[0].message.find("line 1, line 2"), std::string::npos) << r.copies[0].message;
  EXPECT_NE(r.copies[2].message.find("overwrite"), std::string::npos) << r.copies[2].message;
  EXPECT_NE(r.copies[4].message.find("given twice"), std::string::npos) << r.copies[4].message;
  EXPECT_NE(r.copies[5].message.find("coded IDs only"), std::string::npos) << r.copies[5].message;
  EXPECT_EQ(blake2b_hex(own), before);  // the original untouched
  for (const char* name : {"a.ply", "d.ply", "e.ply", "f.ply", "g.ply", "h.ply"})
    EXPECT_FALSE(fs::exists(dir + "/" + name)) << name;
  EXPECT_TRUE(fs::exists(dir + "/i.ply"));
  const std::vector<IssuedCopy> recorded = read_registry(dir + "/shop.db");
  ASSERT_EQ(recorded.size(), 1u);
  EXPECT_EQ(recorded[0].id, 9u);
  EXPECT_EQ(recorded[0].buyer, "Ivy");
}

// Progress, as a caller sees it: phase "preparing" counts each distinct original once, one that
// cannot be read included (it ends its phase all the same), then phase "issuing" counts the copies
// made; each phase starts at 0 and ends at its total, one step at a time.
TEST(Issue, ProgressCountsTheOriginalsPreparedThenTheCopiesMade) {
  const std::string spot = test::data_mesh("spot.obj");
  const std::string fandisk = test::cgal_mesh("fandisk.off");
  MESHMARK_REQUIRE(spot, "spot.obj");
  MESHMARK_REQUIRE(fandisk, "libcgal-demo's fandisk.off");
  const std::string dir = test::scratch_dir() + "/issue-progress";
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::vector<CopyRequest> requests;
  for (const auto& [input, name] : std::vector<std::pair<std::string, std::string>>{
           {spot, "a"}, {fandisk, "b"}, {spot, "c"}, {dir + "/missing.obj", "d"}}) {
    CopyRequest r;
    r.input = input, r.output = dir + "/" + name + ".ply";
    r.payload_hex = "0123456789abcdef";
    requests.push_back(r);
  }
  IssueSettings settings;
  std::vector<std::tuple<std::string, long, long>> seen;
  std::mutex mutex;
  settings.progress = [&](const std::string& phase, long done, long total, const std::string&) {
    std::lock_guard<std::mutex> lock(mutex);
    seen.emplace_back(phase, done, total);
  };
  const IssueResult r = issue_copies(requests, settings);
  EXPECT_EQ(r.count(CopyStatus::Written), 3u);
  EXPECT_EQ(r.copies[3].status, CopyStatus::Unreadable);
  const std::vector<std::tuple<std::string, long, long>> want = {
      {"preparing", 0, 3}, {"preparing", 1, 3}, {"preparing", 2, 3}, {"preparing", 3, 3},
      {"issuing", 0, 3},   {"issuing", 1, 3},   {"issuing", 2, 3},   {"issuing", 3, 3}};
  EXPECT_EQ(seen, want);
}

// One copy within fidelity limits reports its strength search (each MSDM measured, named by its
// strength) where "issuing" would have one step; two copies are counted as copies again, their
// searches silent (their phases would interleave). The strength the copy records is measured.
TEST(Issue, OneCopyWithinLimitsReportsItsStrengthSearch) {
  const std::string spot = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(spot, "spot.obj");
  const std::string dir = test::scratch_dir() + "/issue-search-progress";
  fs::remove_all(dir);
  fs::create_directories(dir);
  for (const int copies : {1, 2}) {
    std::vector<CopyRequest> requests;
    for (int k = 0; k < copies; ++k) {
      CopyRequest r;
      r.input = spot, r.output = fmt::format("{}/{}-{}.ply", dir, copies, k);
      r.payload_hex = k == 0 ? "0123456789abcdef" : "fedcba9876543210";
      requests.push_back(r);
    }
    IssueSettings settings;
    settings.limits = CalibrateOptions{};
    std::vector<std::string> phases;
    std::mutex mutex;
    settings.progress = [&](const std::string& phase, long done, long, const std::string&) {
      std::lock_guard<std::mutex> lock(mutex);
      if (done == 0) phases.push_back(phase);
    };
    const IssueResult r = issue_copies(requests, settings);
    ASSERT_EQ(r.count(CopyStatus::Written), static_cast<std::size_t>(copies))
        << r.copies[0].message;
    ASSERT_TRUE(r.copies[0].calibration);
    ASSERT_FALSE(phases.empty());
    EXPECT_EQ(phases.front(), "preparing");
    const bool issuing = std::count(phases.begin(), phases.end(), "issuing") == 1;
    const std::string found =
        fmt::format("strength {:.5f}: measuring MSDM", r.copies[0].calibration->strength);
    const bool measured = std::count(phases.begin(), phases.end(), found) >= 1;
    if (copies == 1) {
      EXPECT_FALSE(issuing);
      EXPECT_TRUE(measured) << "no phase " << found;
      for (std::size_t k = 1; k < phases.size(); ++k)
        EXPECT_EQ(phases[k].rfind("strength ", 0), 0u) << phases[k];
    } else {
      EXPECT_TRUE(issuing);
      EXPECT_EQ(phases.size(), 2u) << "a search reported among several copies";
    }
  }
}

// A CSV manifest keeps every buyer label as written: commas, quotes, '#', line breaks, any
// UTF-8; the whitespace manifest refuses a label that its '#' comment would cut; a CSV record
// with broken quoting or a header without the needed columns is refused, naming the line.
TEST(Issue, CsvManifestsKeepEveryLabelAndRefuseWhatTheyCannotRead) {
  const std::string dir = test::scratch_dir();
  const std::string csv = dir + "/copies.csv";
  std::ofstream(csv, std::ios::binary) << "\xEF\xBB\xBFinput,output,id,buyer\r\n"
                                          "o.obj,a.ply,1,Jane Doe (order #123)\r\n"
                                          "o.obj,b.ply,2,\"Doe, Jane \"\"JD\"\"\"\r\n"
                                          "\"o.obj\",c.ply,0x10,\"two\nlines\"\n"
                                          "o.obj,d.ply,3,Zo\xC3\xAB \xE2\x9C\x93\n"
                                          "\n"
                                          "o.obj,e.ply,,nobody\n"
                                          "o.obj,f.ply,4\n";
  const std::vector<CopyRequest> r = read_manifest(csv);
  ASSERT_EQ(r.size(), 6u);
  EXPECT_EQ(r[0].buyer, "Jane Doe (order #123)");
  EXPECT_EQ(r[1].buyer, "Doe, Jane \"JD\"");
  EXPECT_EQ(r[2].buyer, "two\nlines");
  EXPECT_EQ(r[2].id, 16u);
  EXPECT_EQ(r[3].buyer, "Zo\xC3\xAB \xE2\x9C\x93");
  EXPECT_EQ(r[3].line, 6u);  // the quoted line break counts
  for (int k = 0; k < 4; ++k) EXPECT_TRUE(r[k].refusal.empty()) << k << ": " << r[k].refusal;
  EXPECT_EQ(r[0].input, "o.obj");
  EXPECT_EQ(r[1].output, "b.ply");
  EXPECT_NE(r[4].refusal.find("an id or a payload"), std::string::npos) << r[4].refusal;
  EXPECT_NE(r[5].refusal.find("3 fields where the header has 4"), std::string::npos)
      << r[5].refusal;
  // Broken CSV is refused with its line.
  for (const auto& [bytes, line] : std::vector<std::pair<std::string, std::size_t>>{
           {"input,output,id\no.obj,\"a.ply,1\n", 2},
           {"input,output,id\no.obj,a\"b.ply,1\n", 2},
           {"input,output,buyer\no.obj,a.ply,x\n", 1},
           {"input,output,id,colour\no.obj,a.ply,1,red\n", 1}}) {
    std::ofstream(dir + "/bad.csv", std::ios::binary) << bytes;
    try {
      read_manifest(dir + "/bad.csv");
      ADD_FAILURE() << "read: " << bytes;
    } catch (const InvalidInputError& e) {
      EXPECT_EQ(e.line(), line) << e.what();
    }
  }
  // The whitespace manifest: a '#' that would cut a label refuses the line.
  std::ofstream(dir + "/copies.txt") << "o.obj a.ply id:1 Jane Doe (order #123)\n"
                                        "o.obj b.ply id:2 Bo\n";
  const std::vector<CopyRequest> w = read_manifest(dir + "/copies.txt");
  ASSERT_EQ(w.size(), 2u);
  EXPECT_NE(w[0].refusal.find("CSV"), std::string::npos) << w[0].refusal;
  EXPECT_TRUE(w[1].refusal.empty());
}

// Coded IDs without a secret key are refused unless public-key coding is asked for: anyone can
// read, remove or forge a mark under the public key.
TEST(Issue, CodedIdsWithoutAKeyNeedThePublicKeyAskedFor) {
  const std::string original = test::cgal_mesh("fandisk.off");
  MESHMARK_REQUIRE(original, "libcgal-demo's fandisk.off");
  const std::string dir = test::scratch_dir();
  IssueSettings s;
  CopyRequest copy;
  copy.input = original;
  copy.output = dir + "/a.ply";
  copy.id = 7;
  IssueResult r = issue_copies({copy}, s);
  EXPECT_EQ(r.copies[0].status, CopyStatus::Refused);
  EXPECT_NE(r.copies[0].message.find("public key"), std::string::npos) << r.copies[0].message;
  EXPECT_FALSE(fs::exists(dir + "/a.ply"));
  s.allow_public_key = true;
  r = issue_copies({copy}, s);
  EXPECT_EQ(r.copies[0].status, CopyStatus::Written) << r.copies[0].message;
  // The command line: a batch needs --public-key, a single copy only warns.
  std::ofstream(dir + "/m.txt") << original << " " << dir << "/b.ply id:8 Bo\n";
  test::CliRun run = test::run_cli("embed --batch " + dir + "/m.txt");
  EXPECT_NE(run.code, 0) << run.out;
  EXPECT_FALSE(fs::exists(dir + "/b.ply"));
  run = test::run_cli("embed --batch " + dir + "/m.txt --public-key");
  EXPECT_EQ(run.code, 0) << run.out;
  run = test::run_cli("embed " + original + " " + dir + "/c.ply --id 9");
  EXPECT_EQ(run.code, 0) << run.out;
  EXPECT_NE(run.out.find("warning"), std::string::npos) << run.out;
}

// id:auto: the registry picks IDs. Against copies already recorded (IDs 1 to 40, some closer
// to each other than the spacing: recorded by hand, not issued) and copies of the same issue
// given their ID, every chosen ID is new, and every pair of issued codewords is at least the
// spacing apart (Hamming distances counted here).
// - At the registry's spacing the IDs are those of SpacedIds, in the order of their places.
// - At a wider spacing (no span), each ID skipped below the largest chosen one is taken or too
//   close to a smaller issued one: the choice is the smallest that passes.
TEST(Issue, AutoIdsAreSpacedFromEveryIssuedOne) {
  const std::string dir = test::scratch_dir() + "/issue-auto-ids";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const Key key = key_from_passphrase("auto id test key");
  IssuedCopy like;
  like.original_hash = std::string(64, 'a');
  like.key_fingerprint = key_fingerprint(key);
  like.id_bits = 32;
  like.bits = 64;
  std::vector<IssuedCopy> recorded;
  for (std::uint64_t id = 1; id <= 40; ++id) {
    IssuedCopy c = like;
    c.id = id;
    c.buyer = fmt::format("recorded {}", id);
    c.output_path = fmt::format("{}/r{}.ply", dir, id);
    c.output_hash = std::string(64, 'b');
    recorded.push_back(c);
  }
  IssuedCopy other_original = like;  // another original's rows constrain nothing
  other_original.original_hash = std::string(64, 'c');
  other_original.id = 41;
  other_original.output_path = dir + "/o.ply";
  recorded.push_back(other_original);
  Registry registry(dir + "/shop.db");
  registry.record(recorded);
  recorded.pop_back();
  std::vector<IssuedCopy> given(2, like);
  given[0].id = 45, given[1].id = 60;
  IdCodeOptions co;
  const IdCode code(co);
  const auto distance = [&](std::uint64_t a, std::uint64_t b) {
    const Payload x = code.encode(a, key), y = code.encode(b, key);
    int d = 0;
    for (int j = 0; j < 64; ++j) d += x.bits[j] != y.bits[j];
    return d;
  };
  std::set<std::uint64_t> before;  // recorded and given: taken, not respaced
  for (const IssuedCopy& c : recorded) before.insert(c.id);
  for (const IssuedCopy& c : given) before.insert(c.id);
  const SpacedIds span(code, key);
  // The default spacing, and a wider one under which some IDs are too close to a
  // given one, so that skipping is exercised.
  for (const int spacing : {kIssuedSpacing, 22}) {
    SCOPED_TRACE(fmt::format("spacing {}", spacing));
    const std::vector<IssuedCopy> wanted(spacing == 22 ? 60 : 200, like);
    const std::vector<std::uint64_t> ids = free_ids(registry, given, wanted, key, spacing);
    ASSERT_EQ(ids.size(), wanted.size());
    std::set<std::uint64_t> chosen;
    for (const std::uint64_t id : ids) {
      EXPECT_FALSE(before.count(id)) << "ID " << id << " was taken";
      EXPECT_TRUE(chosen.insert(id).second) << "ID " << id << " chosen twice";
      for (const std::uint64_t other : before) EXPECT_GE(distance(id, other), spacing);
    }
    for (const std::uint64_t a : chosen)
      for (const std::uint64_t b : chosen)
        if (a < b) EXPECT_GE(distance(a, b), spacing) << a << " and " << b;
    if (spacing == kIssuedSpacing) {
      // The span's IDs, each at a later place than the one before.
      std::uint64_t place = 0;
      for (const std::uint64_t id : ids) {
        EXPECT_GT(span.index_of(id), place) << "ID " << id;
        place = span.index_of(id);
      }
      continue;
    }
    EXPECT_TRUE(std::is_sorted(ids.begin(), ids.end()));
    int skipped_as_close = 0;
    for (std::uint64_t x = 1; x < ids.back(); ++x) {
      if (chosen.count(x) || before.count(x)) continue;
      bool close = false;
      for (const std::uint64_t y : before) close = close || distance(x, y) < spacing;
      for (const std::uint64_t y : chosen) close = close || (y < x && distance(x, y) < spacing);
      EXPECT_TRUE(close) << "ID " << x << " was free and spaced, yet skipped";
      skipped_as_close += close;
    }
    EXPECT_GT(skipped_as_close, 3);
  }
  // The registry holds its rows unchanged: free_ids reserves nothing.
  EXPECT_EQ(read_registry(dir + "/shop.db").size(), recorded.size() + 1);
}

// A batch of id:auto lines through issue_copies: each written copy gets its chosen ID, which
// the copy itself carries (read back blind) and the registry records; id:auto without a
// registry is refused before anything is written.
TEST(Issue, AutoIdCopiesCarryAndRecordTheirChosenId) {
  const std::string original = test::cgal_mesh("fandisk.off");
  MESHMARK_REQUIRE(original, "libcgal-demo's fandisk.off");
  const std::string dir = test::scratch_dir() + "/issue-auto-copies";
  fs::remove_all(dir);
  fs::create_directories(dir);
  {
    std::ofstream m(dir + "/manifest.txt");
    m << original << " " << dir << "/a.ply id:7 buyer seven\n";
    for (int k = 0; k < 3; ++k)
      m << original << " " << dir << "/auto-" << k << ".ply id:auto buyer " << k << "\n";
  }
  const std::vector<CopyRequest> requests = read_manifest(dir + "/manifest.txt");
  ASSERT_EQ(requests.size(), 4u);
  EXPECT_TRUE(requests[1].auto_id && !requests[1].id);
  IssueSettings settings = shop_settings(dir + "/shop.db");
  const IssueResult result = issue_copies(requests, settings);
  ASSERT_EQ(result.count(CopyStatus::Written), 4u) << result.copies[1].message;
  const std::vector<IssuedCopy> rows = read_registry(settings.registry);
  ASSERT_EQ(rows.size(), 4u);
  IdCodeOptions co;
  const IdCode code(co);
  std::set<std::uint64_t> ids;
  for (int k = 0; k < 3; ++k) {
    const std::string output = fmt::format("{}/auto-{}.ply", dir, k);
    const auto row = std::find_if(rows.begin(), rows.end(), [&](const IssuedCopy& c) {
      return c.output_path == fs::absolute(output).lexically_normal().string();
    });
    ASSERT_NE(row, rows.end());
    EXPECT_NE(row->id, 7u);
    EXPECT_TRUE(ids.insert(row->id).second);
    EXPECT_NE(result.copies[k + 1].message.find(fmt::format("ID {},", row->id)), std::string::npos)
        << result.copies[k + 1].message;
    const Mesh copy = read_mesh(output);
    const IdReading read = read_id(copy.V, copy.F, ExtractOptions{}, code, settings.key);
    ASSERT_TRUE(read.id.valid) << read.id.message;
    EXPECT_EQ(read.id.id, row->id);
  }
  settings.registry.clear();
  CopyRequest r = requests[1];
  r.output = dir + "/none.ply";
  const IssueResult refused = issue_copies({r}, settings);
  EXPECT_EQ(refused.copies[0].status, CopyStatus::Refused);
  EXPECT_NE(refused.copies[0].message.find("needs a registry"), std::string::npos);
  EXPECT_FALSE(fs::exists(dir + "/none.ply"));
}

TEST(Issue, ReadingARegistryThatDoesNotExistCreatesNothing) {
  const std::string db = test::scratch_dir() + "/no-such-registry.db";
  fs::remove(db);
  EXPECT_THROW(read_registry(db), IOError);
  EXPECT_FALSE(fs::exists(db));
}

// The calibration cache: the second ask answers from the cache with the same figures; other
// limits or another file content compute anew; a line that is not JSON is ignored.
TEST(CalibrationCache, AnswersAgainFromTheCacheOnlyForTheSameContentAndSettings) {
  const std::string original = test::cgal_mesh("elephant.off");
  MESHMARK_REQUIRE(original, "libcgal-demo's elephant.off");
  const std::string dir = test::scratch_dir() + "/calibration-cache";
  fs::remove_all(dir);
  fs::create_directories(dir);
  FileCalibrationOptions o;
  o.variant = parse_variant("SRS");
  o.limits.iterations = 4;
  o.cache = dir + "/sub/cache.jsonl";  // its folder is created
  const FileCalibration first = calibrate_file(original, o);
  EXPECT_FALSE(first.cached);
  EXPECT_GT(first.strength, 0);
  EXPECT_LE(first.rms_percent, o.limits.max_rms_percent * (1 + 1e-9));
  std::ofstream(o.cache, std::ios::app) << "not json\n";
  const FileCalibration second = calibrate_file(original, o);
  EXPECT_TRUE(second.cached);
  EXPECT_EQ(second.strength, first.strength);
  EXPECT_EQ(second.msdm, first.msdm);
  EXPECT_EQ(second.key, first.key);
  FileCalibrationOptions tighter = o;
  tighter.limits.max_msdm = 0.8 * first.msdm;  // elephant: MSDM limits the mark here
  const FileCalibration other = calibrate_file(original, tighter);
  EXPECT_FALSE(other.cached);
  EXPECT_LE(other.msdm, tighter.limits.max_msdm * (1 + 1e-9));
  // The same bytes under another name hit; other bytes (one coordinate changed) miss.
  const std::string renamed = dir + "/renamed.off";
  fs::copy_file(original, renamed);
  EXPECT_TRUE(calibrate_file(renamed, o).cached);
  Mesh m = read_mesh(original);
  m.V(0, 0) += 1e-3;
  const std::string changed = dir + "/changed.off";
  write_mesh(changed, m);
  EXPECT_FALSE(calibrate_file(changed, o).cached);
}

// parallel_for: every index exactly once, never more threads than asked or than items, and a
// loop nested in a worker shares the outer loop's budget (no cores-squared threads;
// parallel_test.cpp counts the threads running at once).
TEST(Parallel, EveryIndexOnceWithinTheBudgetAndNestedLoopsShareIt) {
  for (const std::size_t n : {0u, 1u, 3u, 1000u}) {
    std::vector<std::atomic<int>> seen(n);
    const int used = detail::parallel_for(n, 3, [&](std::size_t i) { ++seen[i]; });
    EXPECT_LE(used, std::max<int>(1, std::min<int>(3, static_cast<int>(n))));
    for (std::size_t i = 0; i < n; ++i) EXPECT_EQ(seen[i].load(), 1) << i;
  }
  std::atomic<int> nested_chunks{0}, nested_threads{0};
  detail::parallel_for(4, 2, [&](std::size_t) {
    nested_chunks += detail::chunk_count(1 << 20);
    nested_threads += detail::parallel_for(8, 0, [](std::size_t) {});
  });
  // The budget is the outer loop's 2 threads: chunks of its size, and a nested loop gets a
  // second thread only from a worker that has finished.
  EXPECT_EQ(nested_chunks.load(), 4 * 2);
  EXPECT_GE(nested_threads.load(), 4);
  EXPECT_LE(nested_threads.load(), 4 * 2);
}

// An issue killed after reserving its IDs leaves rows in state "reserved" (and perhaps a
// temporary file, or the copy itself): the ID cannot be taken by another request meanwhile,
// and the same request run again writes the copy
// and completes that row; a copy that cannot be written gives its reservation back.
TEST(Issue, AnInterruptedIssueIsFinishedByItsRerunAndNobodyElseTakesItsId) {
  const std::string spot = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(spot, "spot.obj");
  const std::string dir = test::scratch_dir() + "/issue-interrupted";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string db = dir + "/shop.db", output = dir + "/copy-41.ply";
  IssueSettings settings = shop_settings(db);
  const Key key = *settings.key;
  {
    // What a run killed while writing leaves: the reserved row, and a temporary file of a
    // process that no longer runs.
    Registry registry(db);
    IssuedCopy c = issued_copy(spot, "buyer 41", 41, settings);
    c.output_path = normalized_path(output);
    const std::vector<IssuedCopy> reserved = registry.reserve({c}, key);
    ASSERT_EQ(reserved.size(), 1u);
    EXPECT_EQ(reserved[0].state, "reserved");
    EXPECT_EQ(check_row(key, reserved[0]), RowAuth::Authentic);
  }
  const pid_t gone = fork();
  if (gone == 0) _exit(0);
  ASSERT_GT(gone, 0);
  waitpid(gone, nullptr, 0);
  const std::string stale = fmt::format("{}/.copy-41.ply.meshmark-{}-abcdef", dir, gone);
  std::ofstream(stale) << "half a copy";
  // Another buyer asking for ID 41 meanwhile is refused, naming the reservation.
  CopyRequest other{.input = spot, .output = dir + "/other.ply", .id = 41, .buyer = "mallory"};
  IssueResult r = issue_copies({other}, settings);
  ASSERT_EQ(r.copies.size(), 1u);
  EXPECT_EQ(r.copies[0].status, CopyStatus::Refused);
  EXPECT_NE(r.copies[0].message.find("is reserved for 'buyer 41'"), std::string::npos)
      << r.copies[0].message;
  EXPECT_FALSE(fs::exists(dir + "/other.ply"));
  // The same request again: written, the reserved row completed (one row, authentic, with the
  // hash of the file on disk), the stale temporary file gone.
  CopyRequest same{.input = spot, .output = output, .id = 41, .buyer = "buyer 41"};
  r = issue_copies({same}, settings);
  ASSERT_EQ(r.copies[0].status, CopyStatus::Written) << r.copies[0].message;
  bool warned = false;
  for (const std::string& w : r.copies[0].warnings) warned |= w.find("was reserved") != w.npos;
  EXPECT_TRUE(warned);
  std::vector<IssuedCopy> rows = read_registry(db);
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0].state, "issued");
  EXPECT_EQ(rows[0].id, 41u);
  EXPECT_EQ(rows[0].output_hash, blake2b_hex(output)) << "the hash of the bytes";
  EXPECT_EQ(check_row(key, rows[0]), RowAuth::Authentic);
  EXPECT_FALSE(fs::exists(stale));
  // A copy that cannot be written (its folder does not exist) leaves no row behind.
  CopyRequest lost{.input = spot, .output = dir + "/no-such-dir/c.ply", .id = 77, .buyer = "b"};
  r = issue_copies({lost}, settings);
  EXPECT_EQ(r.copies[0].status, CopyStatus::WriteFailed) << r.copies[0].message;
  rows = read_registry(db);
  EXPECT_EQ(rows.size(), 1u);
}

}  // namespace
}  // namespace meshmark
