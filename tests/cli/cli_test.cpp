// The command line as a user runs it: exit codes, messages, files.

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <sys/wait.h>
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <set>

#include "meshmark/core/error.h"
#include "meshmark/forensics/issue.h"
#include "meshmark/forensics/registry.h"
#include "meshmark/io/io.h"
#include "test_data.h"

using namespace meshmark;

namespace {
using test::CliRun;
CliRun run(const std::string& args) {
  return test::run_cli(args);
}
}  // namespace

TEST(Cli, EmbedThenExtractRoundTrips) {
  const std::string in = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(in, "spot.obj");
  const std::string dir = test::scratch_dir();
  const CliRun e = run("embed " + in + " " + dir + "/w.obj --payload 0123456789abcdef");
  ASSERT_EQ(e.code, 0) << e.out;
  EXPECT_NE(e.out.find("RMS displacement"), std::string::npos);
  const CliRun x = run("extract " + dir + "/w.obj --expect 0123456789abcdef");
  EXPECT_EQ(x.code, 0) << x.out;
  EXPECT_NE(x.out.find("payload 0123456789abcdef"), std::string::npos) << x.out;
  EXPECT_NE(x.out.find("bit error rate 0.000000"), std::string::npos) << x.out;
  const CliRun wrong = run("extract " + dir + "/w.obj --expect 0123456789abcdee");
  EXPECT_EQ(wrong.code, 5) << wrong.out;
  const CliRun json = run("extract " + dir + "/w.obj --json");
  EXPECT_EQ(json.code, 0);
  EXPECT_NE(json.out.find("\"payload\": \"0123456789abcdef\""), std::string::npos) << json.out;
}

// A newcomer's mistakes get the list to choose from; a script that asked for --json gets its
// error as JSON on stdout, with the exit code; every --help lists the exit codes.
TEST(Cli, MistakesListTheChoicesAndJsonErrorsAreJson) {
  CliRun r = run("frobnicate");
  EXPECT_EQ(r.code, 1) << r.out;
  for (const char* command : {"keygen", "embed", "extract", "trace", "registry"})
    EXPECT_NE(r.out.find(command), std::string::npos) << r.out;
  r = run("attack melt a.off b.off");
  EXPECT_EQ(r.code, 1) << r.out;
  for (const char* kind : {"noise", "simplify", "remesh", "to-stl"})
    EXPECT_NE(r.out.find(kind), std::string::npos) << r.out;
  const std::string missing = test::scratch_dir() + "/none.ply";
  for (const auto& [args, code] : std::vector<std::pair<std::string, int>>{
           {"extract " + missing + " --json", 2}, {"extract --json", 1}, {"nothing --json", 1}}) {
    const std::string out =
        test::run_command(std::string(MESHMARK_CLI) + " " + args + " 2>/dev/null").out;
    const nlohmann::json j = nlohmann::json::parse(out);  // stdout holds the JSON alone
    EXPECT_EQ(j.at("error").at("exit_code"), code) << args;
    EXPECT_EQ(run(args).code, code) << args;
    EXPECT_FALSE(j.at("error").at("message").get<std::string>().empty()) << args;
  }
  EXPECT_NE(run("extract " + missing + " --json").out.find("none.ply"), std::string::npos);
  // attack --json: the counts of what it wrote, as read back.
  const std::string spot = test::data_mesh("spot.obj"), out = test::scratch_dir() + "/n.obj";
  const nlohmann::json j = nlohmann::json::parse(
      run("attack noise " + spot + " " + out + " --strength 0.001 --json").out);
  EXPECT_EQ(j.at("vertices"), read_mesh(out).V.rows());
  EXPECT_EQ(j.at("faces"), read_mesh(out).F.rows());  // was always 0
  EXPECT_GT(j.at("faces").get<int>(), 0);
  EXPECT_EQ(j.at("kind"), "noise");
  for (const char* help : {"--help", "embed --help", "trace --help", "keygen --help"}) {
    r = run(help);
    EXPECT_EQ(r.code, 0) << help;
    EXPECT_NE(r.out.find("Exit codes: 0 done; 1 bad command line"), std::string::npos) << help;
  }
}

TEST(Cli, MalformedInputExitsWithCodeTwoAndNamesFileAndLine) {
  const std::string dir = test::scratch_dir();
  const std::string bad = dir + "/bad.off";
  std::ofstream(bad) << "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 9\n";
  const CliRun r = run("extract " + bad);
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find(bad + ":6:"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("out of range"), std::string::npos) << r.out;
  EXPECT_EQ(run("extract " + dir + "/missing.obj").code, 2);
}

TEST(Cli, RefusesToOverwriteTheInputAndReportsInfeasibleBits) {
  const std::string dir = test::scratch_dir();
  const std::string in = dir + "/tiny.obj";
  write_mesh(in, test::bumpy_sphere(4, 5, 1));
  const std::string before = read_file(in);
  const CliRun same = run("embed " + in + " " + in + " --payload 1 --bits 4");
  EXPECT_EQ(same.code, 1) << same.out;
  EXPECT_EQ(read_file(in), before);
  // 82 positions: enough to fill 66 bins once (fewer are refused before embedding, as
  // unusable), too few to fill them all.
  const std::string sparse = dir + "/sparse.obj";
  write_mesh(sparse, test::bumpy_sphere(8, 10, 1));
  const CliRun infeasible =
      run("embed " + sparse + " " + dir + "/out.obj --payload 0123456789abcdef");
  EXPECT_EQ(infeasible.code, 4) << infeasible.out;
  EXPECT_NE(infeasible.out.find("infeasible bits"), std::string::npos) << infeasible.out;
  EXPECT_FALSE(std::filesystem::exists(dir + "/out.obj"));
  EXPECT_EQ(run("embed " + in + " " + dir + "/o.obj --payload zz").code, 1);
  EXPECT_EQ(run("frobnicate").code, 1);
}

TEST(Cli, RoughnessWritesAColoredPly) {
  const std::string in = test::cgal_mesh("fandisk.off");
  MESHMARK_REQUIRE(in, "libcgal-demo fandisk.off");
  const std::string dir = test::scratch_dir();
  const CliRun r = run("roughness " + in + " " + dir + "/rough.ply");
  ASSERT_EQ(r.code, 0) << r.out;
  const std::string bytes = read_file(dir + "/rough.ply");
  EXPECT_NE(bytes.find("property uchar red\nproperty uchar green\nproperty uchar blue\n"),
            std::string::npos);
  const Mesh back = read_mesh(dir + "/rough.ply");
  const Mesh original = read_mesh(in);
  EXPECT_EQ(back.V, original.V);
  EXPECT_EQ(file_faces(back), file_faces(original));
  EXPECT_EQ(run("roughness " + in + " " + dir + "/rough.obj").code, 1) << "colors need PLY";
}

TEST(Cli, CompareReportsEveryMetricAndWritesAMap) {
  const std::string in = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(in, "spot.obj");
  const std::string dir = test::scratch_dir();
  ASSERT_EQ(run("attack noise " + in + " " + dir + "/noisy.obj --strength 0.002 --seed 3").code, 0);
  const CliRun r = run("compare " + in + " " + dir + "/noisy.obj --json --map " + dir + "/map.ply");
  ASSERT_EQ(r.code, 0) << r.out;
  for (const char* key : {"rms_percent", "mrms_percent", "hausdorff_percent", "msdm", "msdm2"})
    EXPECT_NE(r.out.find(std::string("\"") + key + "\""), std::string::npos) << key;
  EXPECT_EQ(read_mesh(dir + "/map.ply").V.rows(), read_mesh(in).V.rows());
}

TEST(Cli, BatchEmbedsOneCopyPerLineAndReportsFailuresPerLine) {
  const std::string spot = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(spot, "spot.obj");
  const std::string dir = test::scratch_dir();
  const std::string tiny = dir + "/tiny.obj";
  write_mesh(tiny, test::bumpy_sphere(4, 5, 1));  // too small for 64 bits: that line fails
  const char* payloads[] = {"0123456789abcdef", "fedcba9876543210", "00000000ffffffff"};
  {
    std::ofstream manifest(dir + "/manifest.txt");
    manifest << "# buyer copies\n";
    for (int k = 0; k < 3; ++k)
      manifest << spot << " " << dir << "/copy" << k << ".obj " << payloads[k] << "\n";
    manifest << tiny << " " << dir << "/tiny_out.obj 0123456789abcdef\n";
  }
  const CliRun r = run("embed --batch " + dir + "/manifest.txt");
  EXPECT_EQ(r.code, 4) << r.out;
  EXPECT_NE(r.out.find("3 of 4 copies"), std::string::npos) << r.out;
  for (int k = 0; k < 3; ++k) {
    const CliRun x =
        run("extract " + dir + "/copy" + std::to_string(k) + ".obj --expect " + payloads[k]);
    EXPECT_EQ(x.code, 0) << x.out;
  }
  EXPECT_FALSE(std::filesystem::exists(dir + "/tiny_out.obj"));
  std::ofstream(dir + "/bad.txt") << spot << " only-two-fields\n";
  const CliRun bad = run("embed --batch " + dir + "/bad.txt");
  EXPECT_EQ(bad.code, 4);  // a malformed line is one failed copy, reported like the others
  EXPECT_NE(bad.out.find("bad.txt:1: FAILED"), std::string::npos) << bad.out;
  EXPECT_NE(bad.out.find("expected INPUT OUTPUT PAYLOAD"), std::string::npos) << bad.out;
  // An ID of 2^32 on one line of a registered batch: that line fails, the other is issued (the
  // whole batch stopped with exit 1 before).
  ASSERT_EQ(run("keygen " + dir + "/k.key").code, 0);
  std::ofstream(dir + "/ids.txt") << spot << " " << dir << "/id1.obj id:201 ok\n"
                                  << spot << " " << dir << "/id2.obj id:4294967296 big\n";
  const CliRun ids = run("embed --batch " + dir + "/ids.txt --key-file " + dir +
                         "/k.key --registry " + dir + "/ids.db");
  EXPECT_EQ(ids.code, 4) << ids.out;
  EXPECT_NE(ids.out.find("ids.txt:2: FAILED"), std::string::npos) << ids.out;
  EXPECT_NE(ids.out.find("does not fit in 32 bits"), std::string::npos) << ids.out;
  EXPECT_TRUE(std::filesystem::exists(dir + "/id1.obj"));
  EXPECT_FALSE(std::filesystem::exists(dir + "/id2.obj"));
  EXPECT_EQ(Registry(dir + "/ids.db").list().size(), 1u);
}

// --json on a batch and on the registry: one object per batch (each copy with its status and
// the ID id:auto chose), the exit code as without it, and `registry list --json` listing the
// same IDs; --json with another --format is refused.
TEST(Cli, BatchAndRegistryTalkJson) {
  const std::string spot = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(spot, "spot.obj");
  const std::string dir = test::scratch_dir() + "/cli-json";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  {
    std::ofstream manifest(dir + "/manifest.txt");
    manifest << spot << " " << dir << "/a.ply id:auto buyer a\n";
    manifest << spot << " " << dir << "/b.ply id:auto buyer b\n";
    manifest << spot << " " << dir << "/a.ply id:9 buyer c\n";  // a.ply twice: both refused
  }
  const std::string db = dir + "/shop.db";
  const CliRun r =
      run("embed --batch " + dir + "/manifest.txt --public-key --registry " + db + " --json");
  EXPECT_EQ(r.code, 4) << r.out;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  ASSERT_EQ(j["copies"].size(), 3u);
  EXPECT_EQ(j["written"], 1);
  EXPECT_EQ(j["failed"], 2);
  EXPECT_EQ(j["copies"][0]["status"], "refused");
  EXPECT_EQ(j["copies"][1]["status"], "written");
  EXPECT_TRUE(j["copies"][1]["id"].is_number_unsigned()) << j.dump();
  const CliRun list = run("registry list " + db + " --json");
  EXPECT_EQ(list.code, 0) << list.out;
  const nlohmann::json rows = nlohmann::json::parse(list.out);
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0]["id"], j["copies"][1]["id"]);
  EXPECT_EQ(rows[0]["buyer"], "buyer b");
  EXPECT_EQ(run("registry list " + db + " --json --format csv").code, 1);
}

// Nothing a command needs is overwritten (the review's reproductions): an output that is the
// registry, the key file (by name or through a symbolic or a hard link) or the manifest is
// refused before anything is written, exit 1 for one copy and 4 for a batch line, and every
// such file keeps its bytes; so is an output that is another row's issued copy.
TEST(Cli, EmbedNeverWritesOverItsRegistryKeyFileOrManifest) {
  const std::string spot = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(spot, "spot.obj");
  const std::string dir = test::scratch_dir() + "/cli-kept-files";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string key = dir + "/shop.key", db = dir + "/existing.obj";
  ASSERT_EQ(run("keygen " + key).code, 0);
  std::filesystem::create_symlink(key, dir + "/key-link.ply");
  std::filesystem::create_hard_link(key, dir + "/key-hard.ply");
  ASSERT_EQ(
      run("embed " + spot + " " + dir + "/first.ply --id 1 --key-file " + key + " --registry " + db)
          .code,
      0);
  const auto bytes = [](const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  };
  const std::string key_bytes = bytes(key);
  for (const std::string& out : {db, key, dir + "/key-link.ply", dir + "/key-hard.ply"}) {
    SCOPED_TRACE(out);
    const CliRun r =
        run("embed " + spot + " " + out + " --id 2 --key-file " + key + " --registry " + db);
    EXPECT_EQ(r.code, 1) << r.out;
    EXPECT_NE(r.out.find("refusing to overwrite"), std::string::npos) << r.out;
  }
  const std::string manifest = dir + "/m.txt";
  {
    std::ofstream m(manifest);
    m << spot << " " << db << " id:3 buyer three\n";
    m << spot << " " << manifest << " id:4 buyer four\n";
  }
  const std::string manifest_bytes = bytes(manifest);
  const CliRun b = run("embed --batch " + manifest + " --key-file " + key + " --registry " + db);
  EXPECT_EQ(b.code, 4) << b.out;
  EXPECT_NE(b.out.find("refusing to overwrite the registry"), std::string::npos) << b.out;
  EXPECT_NE(b.out.find("refusing to overwrite the manifest"), std::string::npos) << b.out;
  EXPECT_EQ(bytes(key), key_bytes);
  EXPECT_EQ(bytes(manifest), manifest_bytes);
  EXPECT_EQ(read_registry(db).size(), 1u);
  EXPECT_EQ(bytes(db).substr(0, 16), std::string("SQLite format 3\0", 16));
  // Nor another buyer's issued copy of the same original: first.ply is ID 1's (hostile pass:
  // ID 2 written there replaced it, and two rows named the file).
  const std::string first = bytes(dir + "/first.ply");
  const CliRun over = run("embed " + spot + " " + dir + "/first.ply --id 2 --key-file " + key +
                          " --registry " + db);
  EXPECT_EQ(over.code, 1) << over.out;
  EXPECT_NE(over.out.find("is the copy issued to"), std::string::npos) << over.out;
  EXPECT_EQ(bytes(dir + "/first.ply"), first);
  EXPECT_EQ(read_registry(db).size(), 1u);
}

// The review: a key file readable by others and --key on the command line were used without a
// word. Both now warn; MESHMARK_KEY gives the passphrase's key with no warning.
TEST(Cli, ExposedKeysWarnAndTheEnvironmentGivesThePassphrase) {
  const std::string spot = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(spot, "spot.obj");
  const std::string dir = test::scratch_dir() + "/key-warnings";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string copy = dir + "/c.ply";
  test::CliRun r = test::run_cli("embed " + spot + " " + copy + " --id 9 --key 'open sesame'");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("visible to every user of this machine"), std::string::npos) << r.out;
  // The same passphrase from the environment: no warning, and the same key (ID 9 read back).
  r = test::run_command("MESHMARK_KEY='open sesame' " + std::string(MESHMARK_CLI) + " extract " +
                        copy + " --coded --json");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(r.out.find("meshmark: warning"), std::string::npos) << r.out;
  EXPECT_EQ(nlohmann::json::parse(r.out)["id"], 9);
  // Another passphrase in the environment reads no ID (the key really came from it).
  r = test::run_command("MESHMARK_KEY='closed' " + std::string(MESHMARK_CLI) + " extract " + copy +
                        " --coded");
  EXPECT_EQ(r.code, 6) << r.out;
  // keygen's file (0600) is quiet; made readable by everyone, it warns, naming it and its mode.
  const std::string key = dir + "/k.key";
  ASSERT_EQ(test::run_cli("keygen " + key).code, 0);
  r = test::run_cli("extract " + copy + " --coded --key-file " + key);
  EXPECT_EQ(r.out.find("meshmark: warning"), std::string::npos) << r.out;
  std::filesystem::permissions(key, std::filesystem::perms::others_read,
                               std::filesystem::perm_options::add);
  r = test::run_cli("extract " + copy + " --coded --key-file " + key);
  EXPECT_NE(
      r.out.find(key + ": the key file can be read by every user of this machine (mode 0604)"),
      std::string::npos)
      << r.out;
  EXPECT_EQ(key_file_exposure(key).empty(), false);
  std::filesystem::permissions(key, std::filesystem::perms::owner_read);
  EXPECT_EQ(key_file_exposure(key), "");
}

// Copies issued under a passphrase before its key went through Argon2id (their key is
// key_from_passphrase_v1's) still trace with the passphrase alone, saying so; extract reads
// them with --legacy-passphrase; embed refuses that option; new copies record Argon2id.
TEST(Cli, PassphraseCopiesIssuedBeforeArgon2idStillTrace) {
  const std::string spot = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(spot, "spot.obj");
  const std::string dir = test::scratch_dir() + "/legacy-passphrase";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string db = dir + "/shop.db", err = dir + "/stderr.txt";
  // A command line in a subshell: its own "2>err" holds, or stderr joins the output.
  const auto run_quiet = [](const std::string& command) {
    return test::run_command("(" + command + ")");
  };
  IssueSettings s;
  s.key = key_from_passphrase_v1("old shop");
  s.registry = db;
  std::vector<CopyRequest> requests(2);
  for (int i = 0; i < 2; ++i) {
    requests[i].input = spot;
    requests[i].output = dir + "/c" + std::to_string(30 + i) + ".ply";
    requests[i].id = 30 + i;
    requests[i].buyer = "b" + std::to_string(30 + i);
  }
  ASSERT_EQ(issue_copies(requests, s).count(CopyStatus::Written), 2u);
  for (const IssuedCopy& c : read_registry(db))
    EXPECT_EQ(c.key_derivation, kPassphraseDerivationV1) << c.row;
  const std::string cli = std::string(MESHMARK_CLI);
  test::CliRun r =
      run_quiet("MESHMARK_KEY='old shop' " + cli + " trace " + dir + "/c31.ply --original " + spot +
                " --registry " + db + " --json 2>" + err);
  ASSERT_EQ(r.code, 0) << r.out;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  ASSERT_EQ(j["named"].size(), 1u) << r.out;
  EXPECT_EQ(j["named"][0]["id"], 31);
  EXPECT_NE(read_file(err).find("were issued before registry schema 4"), std::string::npos)
      << read_file(err);
  // The Argon2id key of the same passphrase reads nothing in the copy; the earlier one does.
  r = run_quiet("MESHMARK_KEY='old shop' " + cli + " extract " + dir + "/c30.ply --coded");
  EXPECT_EQ(r.code, 6) << r.out;
  r = run_quiet("MESHMARK_KEY='old shop' " + cli + " extract " + dir +
                "/c30.ply --coded --legacy-passphrase --json 2>" + err);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(nlohmann::json::parse(r.out)["id"], 30);
  r = run_quiet("MESHMARK_KEY='old shop' " + cli + " embed " + spot + " " + dir +
                "/new.ply --id 32 --legacy-passphrase --registry " + db);
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("new copies are issued under the passphrase's Argon2id key"),
            std::string::npos)
      << r.out;
  EXPECT_FALSE(std::filesystem::exists(dir + "/new.ply"));
  // Issued now, the copy records the Argon2id derivation, and trace picks its key.
  r = run_quiet("MESHMARK_KEY='old shop' " + cli + " embed " + spot + " " + dir +
                "/new.ply --id 32 --registry " + db);
  ASSERT_EQ(r.code, 0) << r.out;
  std::size_t argon = 0;
  for (const IssuedCopy& c : read_registry(db)) argon += c.key_derivation == kPassphraseDerivation;
  EXPECT_EQ(argon, 1u);
  r = run_quiet("MESHMARK_KEY='old shop' " + cli + " trace " + dir + "/new.ply --original " + spot +
                " --registry " + db + " --json 2>" + err);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(nlohmann::json::parse(r.out)["named"][0]["id"], 32);
  EXPECT_NE(read_file(err).find("2 copies were issued under this passphrase's earlier key"),
            std::string::npos)
      << read_file(err);
}

// embed --batch killed (SIGKILL) at several moments: every copy on disk has its row (reserved
// or issued; an issued one with the hash of the file), and the batch run again issues every
// copy once, completes every row and leaves no temporary file. The key is fixed: under about
// 1 key in 300, two of 30 consecutive IDs have codewords closer than the registry's spacing
// and one is refused (docs/issuing.md), which failed this test now and then when each run
// made a new key with keygen. Under this one, IDs 100 to 129 are spaced.
TEST(Cli, AKilledBatchLeavesNoCopyWithoutARowAndItsRerunFinishesIt) {
  const std::string mesh = test::cgal_mesh("refined_elephant.off");
  MESHMARK_REQUIRE(mesh, "libcgal-demo's refined_elephant.off");
  const std::string cli = std::string(MESHMARK_CLI);
  constexpr int kCopies = 30;  // about 0.7 s in all on 2 threads
  for (const char* delay : {"0.1", "0.3", "0.5"}) {
    SCOPED_TRACE(std::string("killed after ") + delay + " s");
    const std::string dir = test::scratch_dir() + "/killed-batch-" + delay;
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    const std::string db = dir + "/shop.db", key = dir + "/k.key", manifest = dir + "/m.txt";
    std::ofstream(key, std::ios::binary) << "meshmark test: killed batch\n";
    std::filesystem::permissions(
        key, std::filesystem::perms::owner_read | std::filesystem::perms::owner_write);
    {
      std::ofstream m(manifest);
      for (int n = 100; n < 100 + kCopies; ++n)
        m << mesh << " " << dir << "/copy-" << n << ".ply id:" << n << " buyer-" << n << "\n";
    }
    const std::string batch =
        cli + " embed --batch " + manifest + " --key-file " + key + " --registry " + db;
    test::run_command("(" + batch + " >/dev/null 2>&1 & p=$!; sleep " + delay +
                      "; kill -9 $p; wait $p) 2>/dev/null; true");
    // Killed while creating the registry, the file may hold no schema yet: unreadable then,
    // which is right only if no copy was written (a copy is written after its row).
    std::map<std::string, IssuedCopy> rows;
    bool unreadable = false;
    try {
      if (std::filesystem::exists(db))
        for (const IssuedCopy& c : read_registry(db)) rows[c.output_path] = c;
    } catch (const meshmark::IOError& e) {
      unreadable = true;
      SCOPED_TRACE(e.what());
    }
    for (int n = 100; n < 100 + kCopies; ++n) {
      EXPECT_FALSE(unreadable &&
                   std::filesystem::exists(dir + "/copy-" + std::to_string(n) + ".ply"))
          << "a copy was written and the registry has no schema";
      const std::string copy = dir + "/copy-" + std::to_string(n) + ".ply";
      if (!std::filesystem::exists(copy)) continue;
      const auto row = rows.find(normalized_path(copy));
      ASSERT_NE(row, rows.end()) << copy << " was written and has no row";
      EXPECT_EQ(row->second.id, static_cast<std::uint64_t>(n));
      if (row->second.state == "issued")
        EXPECT_EQ(row->second.output_hash, content_hash(read_file(copy))) << copy;
    }
    const test::CliRun again =
        test::run_cli("embed --batch " + manifest + " --key-file " + key + " --registry " + db);
    ASSERT_EQ(again.code, 0) << again.out;
    const std::vector<IssuedCopy> after = read_registry(db);
    ASSERT_EQ(after.size(), static_cast<std::size_t>(kCopies));
    std::set<std::uint64_t> ids;
    for (const IssuedCopy& c : after) {
      ids.insert(c.id);
      EXPECT_EQ(c.state, "issued") << c.row;
      EXPECT_EQ(c.output_hash, content_hash(read_file(c.output_path))) << c.row;
    }
    EXPECT_EQ(ids.size(), static_cast<std::size_t>(kCopies));
    for (const auto& entry : std::filesystem::directory_iterator(dir))
      EXPECT_EQ(entry.path().filename().string().find(".meshmark-"), std::string::npos)
          << entry.path() << " survived the rerun";
  }
}

TEST(Cli, OptionValuesThatAreNotFiniteAreRefusedAndNamedSo) {
  const std::string in = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(in, "spot.obj");
  const std::string dir = test::scratch_dir();
  for (const char* bad : {"nan", "inf", "-1"}) {
    const CliRun r = run("attack reorder " + in + " " + dir + "/o.obj --weld-tolerance " + bad);
    EXPECT_EQ(r.code, 1) << bad << "\n" << r.out;
    EXPECT_NE(r.out.find("not a finite distance >= 0"), std::string::npos) << r.out;
  }
  for (const std::string& args : {std::string("noise ") + in + " " + dir + "/o.obj --strength nan",
                                  std::string("noise:nan ") + in + " " + dir + "/o.obj",
                                  std::string("noise:inf,quant:8 ") + in + " " + dir + "/o.obj"}) {
    const CliRun r = run("attack " + args);
    EXPECT_EQ(r.code, 1) << args << "\n" << r.out;
    EXPECT_NE(r.out.find("is not a finite number"), std::string::npos) << r.out;
    EXPECT_EQ(r.out.find("negative"), std::string::npos) << r.out;
  }
  EXPECT_FALSE(std::filesystem::exists(dir + "/o.obj"));
  // embed into a registry: "nan" reached the registry's NOT NULL columns (strength, spread,
  // bin offset), or was replaced by the default limit (--max-rms, --max-msdm).
  ASSERT_EQ(run("keygen " + dir + "/k.key").code, 0);
  for (const char* option :
       {"--strength", "--strength-spread", "--bin-offset", "--max-rms", "--max-msdm", "--lambda"}) {
    const CliRun r =
        run(fmt::format("embed {} {}/c.obj --id 5 --key-file {}/k.key --registry "
                        "{}/r.db {} nan",
                        in, dir, dir, dir, option));
    EXPECT_EQ(r.code, 1) << option << "\n" << r.out;
    EXPECT_NE(r.out.find(std::string(option) + ": nan is not a finite number"), std::string::npos)
        << r.out;
  }
  EXPECT_FALSE(std::filesystem::exists(dir + "/c.obj"));
  if (std::filesystem::exists(dir + "/r.db")) EXPECT_TRUE(Registry(dir + "/r.db").list().empty());
  // The library refuses them too, before any ID is reserved (Python and serve go there).
  IssueSettings settings;
  settings.embedding.strength = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(issue_copies({}, settings), InvalidArgumentError);
  settings.embedding.strength = 0.05;
  settings.limits = CalibrateOptions{};
  settings.limits->max_rms_percent = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(issue_copies({}, settings), InvalidArgumentError);
}

// A mesh whose surface cannot be measured (every triangle collinear, or coordinates whose
// squares overflow) is bad input: exit 2, the file named (exit 1 and no file before).
TEST(Cli, CompareNamesAMeshWhoseSurfaceCannotBeMeasured) {
  const std::string spot = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(spot, "spot.obj");
  const std::string dir = test::scratch_dir();
  std::ofstream(dir + "/line.off") << "OFF\n3 1 0\n0 0 0\n1 0 0\n2 0 0\n3 0 1 2\n";
  std::ofstream(dir + "/huge.off") << "OFF\n3 1 0\n1e300 0 0\n0 1e300 0\n0 0 1e300\n3 0 1 2\n";
  for (const std::string bad : {"line.off", "huge.off"}) {
    for (const bool first : {true, false}) {
      const std::string a = first ? dir + "/" + bad : spot, b = first ? spot : dir + "/" + bad;
      const CliRun r = run("compare " + a + " " + b);
      EXPECT_EQ(r.code, 2) << bad << "\n" << r.out;
      EXPECT_NE(r.out.find(bad + ": no triangle has a finite, non-zero area"), std::string::npos)
          << r.out;
    }
  }
}

TEST(Cli, CompareAcceptsTheSameFileTwice) {
  const std::string in = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(in, "spot.obj");
  const CliRun r = run("compare " + in + " " + in + " --json");
  ASSERT_EQ(r.code, 0) << r.out;
  const std::size_t at = r.out.find("\"hausdorff\": ");
  ASSERT_NE(at, std::string::npos) << r.out;
  const Mesh m = read_mesh(in);
  EXPECT_LE(std::stod(r.out.substr(at + 13)), 1e-12 * bounding_box_diagonal(m.V))
      << "Hausdorff(M, M) = 0 up to rounding";
}

TEST(Cli, AGivenFormatNeedsNoExtensionOnOut) {
  const std::string in = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(in, "spot.obj");
  const std::string dir = test::scratch_dir();
  const CliRun r = run("attack reorder " + in + " " + dir + "/copy --format ply");
  ASSERT_EQ(r.code, 0) << r.out;
  const Mesh back = read_mesh_from_bytes(read_file(dir + "/copy"), FileFormat::Ply, "copy");
  EXPECT_EQ(back.V.rows(), read_mesh(in).V.rows());
}

TEST(Cli, Float32ConversionOfHugeCoordinatesNamesTheInputAndTheReason) {
  const std::string dir = test::scratch_dir();
  const std::string in = dir + "/huge.obj";
  std::ofstream(in) << "v 0 0 0\nv 1e308 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 3 4\nf 1 4 2\n";
  for (const char* kind : {"float32", "to-stl"}) {
    const CliRun r = run(std::string("attack ") + kind + " " + in + " " + dir + "/out.obj");
    EXPECT_EQ(r.code, 1) << r.out;
    EXPECT_NE(r.out.find(in + ": coordinates do not fit in float32"), std::string::npos) << r.out;
    EXPECT_EQ(r.out.find("converted"), std::string::npos) << r.out;
  }
}

TEST(Cli, MessagesQuotingInputOrArgumentsCarryNoEscapeSequences) {
  const std::string dir = test::scratch_dir();
  const std::string esc = "$(printf '\\033')";  // the shell makes the byte
  std::ofstream(dir + "/evil.obj") << "v 0 0 0\nv 1 0 \x1b]0;pwned\x07\nv 0 1 0\nf 1 2 3\n";
  const CliRun cases[] = {
      run("extract " + dir + "/evil.obj"),
      run("extract \"" + dir + "/" + esc + "[2Jmissing.obj\""),
      run("attack reorder " + dir + "/evil.obj " + dir + "/o.obj --format \"" + esc + "[31m\""),
      run("attack \"" + esc + "[31m\" " + dir + "/evil.obj " + dir + "/o.obj"),
  };
  for (const CliRun& r : cases) {
    EXPECT_NE(r.code, 0) << r.out;
    EXPECT_EQ(r.out.find('\x1b'), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("\\x1b"), std::string::npos) << r.out;
  }
}

// The distortion `compare --json` reports for key (a number after "key": ).
double reported(const std::string& json, const std::string& key) {
  const std::size_t at = json.find("\"" + key + "\": ");
  EXPECT_NE(at, std::string::npos) << key << " in " << json;
  return at == std::string::npos ? -1 : std::stod(json.substr(at + key.size() + 4));
}

TEST(Cli, EmbedAtThePapersFidelityMeetsItsLimitsForEveryCopy) {
  // Each copy, its own ID, its own strongest mark: compare (an independent command) measures
  // the written files within the paper's limits, and extract reads each ID back.
  const std::string in = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(in, "spot.obj");
  const std::string dir = test::scratch_dir();
  // Text output keeps 17 significant digits: the file's distortion equals the computed one
  // to rounding.
  constexpr double kFileRounding = 1e-9;
  {
    std::ofstream manifest(dir + "/copies.txt");
    for (int id = 41; id < 44; ++id)
      manifest << in << " " << dir << "/c" << id << ".obj id:" << id << " buyer" << id << "\n";
  }
  const CliRun b = run("embed --batch " + dir + "/copies.txt --fidelity paper --public-key");
  ASSERT_EQ(b.code, 0) << b.out;
  const CliRun one = run("embed " + in + " " + dir + "/c44.obj --id 44 --fidelity paper --json");
  ASSERT_EQ(one.code, 0) << one.out;
  EXPECT_NE(one.out.find("\"fidelity\": {"), std::string::npos) << one.out;
  for (int id = 41; id < 45; ++id) {
    const std::string copy = dir + "/c" + std::to_string(id) + ".obj";
    const CliRun c = run("compare " + in + " " + copy + " --json");
    ASSERT_EQ(c.code, 0) << c.out;
    EXPECT_LE(reported(c.out, "rms_percent"), 0.04 + kFileRounding) << id;
    EXPECT_LE(reported(c.out, "msdm"), 0.25 + kFileRounding) << id;
    const CliRun x = run("extract " + copy + " --coded");
    EXPECT_EQ(x.code, 0) << x.out;
    EXPECT_NE(x.out.find("id " + std::to_string(id) + " "), std::string::npos) << x.out;
  }
  // A fixed strength and a searched one exclude each other.
  EXPECT_EQ(run("embed " + in + " " + dir + "/x.obj --id 3 --strength 0.03 --fidelity paper").code,
            1);
  // Limits no mark can meet: exit 4, the cause named, nothing written.
  const CliRun tight =
      run("embed " + in + " " + dir + "/t.obj --id 3 --max-rms 0.0000001 --max-msdm 0.25");
  EXPECT_EQ(tight.code, 4) << tight.out;
  EXPECT_NE(tight.out.find("RMS"), std::string::npos) << tight.out;
  EXPECT_FALSE(std::filesystem::exists(dir + "/t.obj"));
}

// collude: the average of three noisy copies of bunny.ply (binary PLY, double) is their mean
// at every vertex, computed here from the files; given weights are normalized; a splice takes
// every vertex from one copy; a copy of another mesh is bad input naming its file; the output
// is never one of the inputs.
TEST(Cli, ColludeMergesCopiesOfOneOriginalAndNamesOneThatIsNot) {
  const std::string bunny = test::data_mesh("bunny.ply");
  MESHMARK_REQUIRE(bunny, "bunny.ply");
  const std::string dir = test::scratch_dir();
  std::vector<std::string> copies;
  for (int seed = 1; seed <= 3; ++seed) {
    copies.push_back(dir + "/copy" + std::to_string(seed) + ".ply");
    const CliRun made = run("attack noise " + bunny + " " + copies.back() +
                            " --strength 0.001 --seed " + std::to_string(seed));
    ASSERT_EQ(made.code, 0) << made.out;
  }
  std::vector<Mesh> m;
  for (const std::string& c : copies) m.push_back(read_mesh(c));
  const double scale = m[0].V.cwiseAbs().maxCoeff();
  const std::string list = copies[0] + " " + copies[1] + " " + copies[2];
  const CliRun avg = run("collude " + list + " --out " + dir + "/avg.ply --json");
  ASSERT_EQ(avg.code, 0) << avg.out;
  EXPECT_EQ(nlohmann::json::parse(avg.out)["vertices"], m[0].V.rows());
  const Mesh a = read_mesh(dir + "/avg.ply");
  EXPECT_LE((a.V - (m[0].V + m[1].V + m[2].V) / 3).cwiseAbs().maxCoeff(), 1e-15 * scale);
  // --weights before the copies takes one argument, not the copies after it.
  const CliRun weighted = run("collude --weights 2,1,1 " + list + " -o " + dir + "/w.ply");
  ASSERT_EQ(weighted.code, 0) << weighted.out;
  const Mesh w = read_mesh(dir + "/w.ply");
  EXPECT_LE((w.V - (0.5 * m[0].V + 0.25 * m[1].V + 0.25 * m[2].V)).cwiseAbs().maxCoeff(),
            1e-15 * scale);
  const CliRun spliced = run("collude " + list + " -o " + dir + "/s.ply --splice --seed 4");
  ASSERT_EQ(spliced.code, 0) << spliced.out;
  const Mesh s = read_mesh(dir + "/s.ply");
  for (Eigen::Index i = 0; i < s.V.rows(); ++i)
    ASSERT_TRUE(s.V.row(i) == m[0].V.row(i) || s.V.row(i) == m[1].V.row(i) ||
                s.V.row(i) == m[2].V.row(i))
        << "vertex " << i;
  // Another mesh among the copies: exit 2, naming it.
  const std::string spot = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(spot, "spot.obj");
  const CliRun other = run("collude " + copies[0] + " " + spot + " -o " + dir + "/x.ply");
  EXPECT_EQ(other.code, 2) << other.out;
  EXPECT_NE(other.out.find(spot + ": copy 2 has"), std::string::npos) << other.out;
  EXPECT_FALSE(std::filesystem::exists(dir + "/x.ply"));
  // Usage errors: one copy, a weight per copy, negative weights, the output an input.
  const std::string before = read_file(copies[1]);
  for (const std::string& bad :
       {"collude " + copies[0] + " -o " + dir + "/x.ply",
        "collude " + list + " -o " + dir + "/x.ply --weights 1,1",
        "collude " + list + " -o " + dir + "/x.ply --weights 1,-1,1",
        "collude " + list + " -o " + dir + "/x.ply --splice --weights 1,1,1",
        "collude " + list + " -o " + copies[1]}) {
    const CliRun r = run(bad);
    EXPECT_EQ(r.code, 1) << bad << "\n" << r.out;
  }
  EXPECT_EQ(read_file(copies[1]), before);
  EXPECT_FALSE(std::filesystem::exists(dir + "/x.ply"));
}
