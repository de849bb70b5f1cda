// The registry of issued copies: every field kept, an ID never recorded twice for one original
// and key, all-or-nothing batches, concurrent writers, schema versions, and a batch killed
// halfway.

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <csignal>
#include <filesystem>
#include <fstream>
#include <thread>

#include "meshmark/error.h"
#include "meshmark/io.h"
#include "meshmark/registry.h"
#include "test_data.h"

namespace meshmark {
namespace {

IssuedCopy copy_of(std::uint64_t id, const std::string& buyer) {
  IssuedCopy c;
  c.original_hash = std::string(64, 'a');
  c.original_path = "/shop/originals/statue.ply";
  c.buyer = buyer;
  c.id = id;
  c.variant = "VRS";
  c.strength = 0.031;
  c.strength_spread = 0.25;
  c.bin_offset = 0.04;
  c.key_fingerprint = std::string(32, 'f');
  c.output_path = "/shop/out/" + std::to_string(id) + ".ply";
  c.output_hash = std::string(64, 'b');
  return c;
}

TEST(Registry, RecordsAndListsEveryField) {
  const std::string db = test::scratch_dir() + "/r.db";
  std::filesystem::remove(db);
  {
    Registry r(db);
    EXPECT_EQ(r.schema_version(), kRegistrySchemaVersion);
    const std::vector<IssuedCopy> done =
        r.record({copy_of(7, "Ann, \"the\" buyer"), copy_of(8, "Bo")});
    EXPECT_EQ(done[0].row, 1);
    EXPECT_EQ(done[1].row, 2);
    EXPECT_EQ(done[0].issued_at.size(), 20u);  // YYYY-MM-DDTHH:MM:SSZ
  }
  const Registry again(db);  // reopened: what was recorded is there
  const std::vector<IssuedCopy> all = again.list();
  ASSERT_EQ(all.size(), 2u);
  const IssuedCopy want = copy_of(7, "Ann, \"the\" buyer");
  const IssuedCopy& got = all[0];
  EXPECT_EQ(got.original_hash, want.original_hash);
  EXPECT_EQ(got.original_path, want.original_path);
  EXPECT_EQ(got.buyer, want.buyer);
  EXPECT_EQ(got.id, 7u);
  EXPECT_EQ(got.id_bits, 32);
  EXPECT_EQ(got.bits, 64);
  EXPECT_EQ(got.variant, "VRS");
  EXPECT_EQ(got.strength, 0.031);
  EXPECT_EQ(got.strength_spread, 0.25);
  EXPECT_EQ(got.bin_offset, 0.04);
  EXPECT_EQ(got.key_fingerprint, want.key_fingerprint);
  EXPECT_EQ(got.mark_format, kMarkFormatVersion);
  EXPECT_EQ(got.output_path, want.output_path);
  EXPECT_EQ(got.output_hash, want.output_hash);
  RegistryQuery q;
  q.buyer = "Bo";
  ASSERT_EQ(again.list(q).size(), 1u);
  EXPECT_EQ(again.list(q)[0].id, 8u);
  q = {};
  q.id = 7;
  EXPECT_EQ(again.list(q).size(), 1u);
}

TEST(Registry, AnIdIsIssuedOncePerOriginalAndKeyAndBatchesAreAllOrNothing) {
  const std::string db = test::scratch_dir() + "/r.db";
  std::filesystem::remove(db);
  Registry r(db);
  r.record({copy_of(1, "first")});
  // A batch with one taken ID records nothing, and says who has it.
  try {
    r.record({copy_of(2, "x"), copy_of(1, "second"), copy_of(3, "y")});
    ADD_FAILURE() << "a taken ID was recorded";
  } catch (const InvalidArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("'first'"), std::string::npos) << e.what();
  }
  EXPECT_EQ(r.list().size(), 1u);
  EXPECT_THROW(r.record({copy_of(4, "a"), copy_of(4, "b")}), InvalidArgumentError);
  EXPECT_EQ(r.list().size(), 1u);
  // The same ID under another key, or from another original, is another copy.
  IssuedCopy other_key = copy_of(1, "k"), other_original = copy_of(1, "o");
  other_key.key_fingerprint = std::string(32, 'e');
  other_original.original_hash = std::string(64, 'c');
  r.record({other_key, other_original});
  EXPECT_EQ(r.list().size(), 3u);
}

TEST(Registry, ConcurrentWritersLoseNothing) {
  const std::string db = test::scratch_dir() + "/r.db";
  std::filesystem::remove(db);
  Registry(db).schema_version();  // created before the writers start
  const int writers = 4, batches = 25, per_batch = 10;
  std::vector<std::thread> threads;
  std::atomic<int> failures{0};
  for (int w = 0; w < writers; ++w)
    threads.emplace_back([&, w] {
      try {
        Registry r(db);  // a connection of its own, as another process would have
        for (int b = 0; b < batches; ++b) {
          std::vector<IssuedCopy> batch;
          for (int i = 0; i < per_batch; ++i)
            batch.push_back(copy_of(100000 * w + per_batch * b + i, "w" + std::to_string(w)));
          r.record(batch);
        }
      } catch (const std::exception& e) {
        ++failures;
        ADD_FAILURE() << e.what();
      }
    });
  for (auto& t : threads) t.join();
  EXPECT_EQ(failures, 0);
  const std::vector<IssuedCopy> all = Registry(db).list();
  EXPECT_EQ(all.size(), static_cast<std::size_t>(writers * batches * per_batch));
}

TEST(Registry, RefusesNewerSchemasAndForeignDatabases) {
  const std::string dir = test::scratch_dir();
  const std::string newer = dir + "/newer.db", foreign = dir + "/foreign.db";
  std::filesystem::remove(newer);
  std::filesystem::remove(foreign);
  Registry(newer).schema_version();
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(newer.c_str(), &db), SQLITE_OK);
  sqlite3_exec(db, "PRAGMA user_version = 99", nullptr, nullptr, nullptr);
  sqlite3_close(db);
  try {
    Registry r(newer);
    ADD_FAILURE() << "a newer schema was opened";
  } catch (const IOError& e) {
    EXPECT_NE(std::string(e.what()).find("schema version 99"), std::string::npos) << e.what();
  }
  ASSERT_EQ(sqlite3_open(foreign.c_str(), &db), SQLITE_OK);
  sqlite3_exec(db, "CREATE TABLE t(x)", nullptr, nullptr, nullptr);
  sqlite3_close(db);
  EXPECT_THROW(Registry{foreign}, IOError);
  std::ofstream(dir + "/text.db") << "not a database at all, just text\n";
  EXPECT_THROW(Registry{dir + "/text.db"}, IOError);
}

TEST(Registry, KeyFingerprintsAndHashes) {
  const Key a = key_from_passphrase("a"), b = key_from_passphrase("b");
  EXPECT_EQ(key_fingerprint(a).size(), 32u);
  EXPECT_EQ(key_fingerprint(a), key_fingerprint(a));
  EXPECT_NE(key_fingerprint(a), key_fingerprint(b));
  // Not the key's bytes, nor their prefix.
  std::string key_hex;
  for (const auto byte : a.bytes) key_hex += fmt::format("{:02x}", byte);
  EXPECT_EQ(key_hex.find(key_fingerprint(a)), std::string::npos);
  // BLAKE2b-256 of "abc", as Python's hashlib.blake2b(b"abc", digest_size=32) computes it.
  EXPECT_EQ(content_hash("abc"),
            "bddd813c634239723171ef3fee98579b94964e3bb1cb3e427262c8c068d52319");
}

TEST(Registry, CommandLineIssuesRecordsAndSurvivesAKilledBatch) {
  const std::string spot = test::shared_mesh("spot.obj");
  MESHMARK_REQUIRE(spot, "spot.obj");
  const std::string dir = test::scratch_dir();
  const std::string db = dir + "/shop.db", key = dir + "/k.key";
  std::filesystem::remove(db);
  std::ofstream(key) << "0123456789abcdef0123456789abcdef";
  test::CliRun r = test::run_cli("embed " + spot + " " + dir + "/a.obj --id 10 --key-file " + key +
                                 " --registry " + db + " --buyer Alice");
  ASSERT_EQ(r.code, 0) << r.out;
  r = test::run_cli("embed " + spot + " " + dir + "/b.obj --id 10 --key-file " + key +
                    " --registry " + db + " --buyer Bob");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("Alice"), std::string::npos) << r.out;
  EXPECT_FALSE(std::filesystem::exists(dir + "/b.obj"));
  // A batch of 60 copies killed after a moment records all of them or none, never part; run
  // again, it completes.
  std::ofstream manifest(dir + "/m.txt");
  for (int i = 0; i < 60; ++i)
    manifest << spot << " " << dir << "/c" << i << ".obj id:" << 100 + i << " buyer " << i << "\n";
  manifest.close();
  const std::string batch =
      "embed --batch " + dir + "/m.txt --key-file " + key + " --registry " + db;
  std::system(
      ("timeout -s KILL 0.3 " + std::string(MESHMARK_CLI) + " " + batch + " > /dev/null 2>&1")
          .c_str());
  const std::size_t after_kill = Registry(db).list().size() - 1;
  EXPECT_TRUE(after_kill == 0 || after_kill == 60) << after_kill;
  if (after_kill == 0) {
    r = test::run_cli(batch);
    EXPECT_EQ(r.code, 0) << r.out;
  }
  const std::vector<IssuedCopy> all = Registry(db).list();
  ASSERT_EQ(all.size(), 61u);
  for (const IssuedCopy& c : all) {
    // Each record names a file that exists, with the hash it has.
    EXPECT_EQ(c.output_hash, content_hash(read_file(c.output_path))) << c.output_path;
    EXPECT_EQ(c.original_hash, content_hash(read_file(spot)));
  }
  r = test::run_cli("registry list " + db + " --buyer 'buyer 7'");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("107"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("1 copy"), std::string::npos) << r.out;
}

}  // namespace
}  // namespace meshmark
