// The registry of issued copies: every field kept, an ID never recorded twice for one original
// and key, all-or-nothing batches, concurrent writers, schema versions, and a batch killed
// halfway.

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <sqlite3.h>
#include <nlohmann/json.hpp>

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <functional>
#include <set>
#include <thread>

#include "meshmark/core/error.h"
#include "meshmark/forensics/fingerprint.h"
#include "meshmark/forensics/registry.h"
#include "meshmark/io/io.h"
#include "postgres_server.h"
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
  c.original_geometry = std::string(64, 'd');
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
  EXPECT_EQ(got.original_geometry, want.original_geometry);
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
  // The same ID with another code length (ID bits or payload bits) is the same buyer's ID.
  IssuedCopy shorter = copy_of(1, "mallory"), longer = copy_of(1, "mallory");
  shorter.id_bits = 24, longer.bits = 96;
  EXPECT_THROW(r.record({shorter}), InvalidArgumentError);
  EXPECT_THROW(r.record({longer}), InvalidArgumentError);
  EXPECT_THROW(r.record({copy_of(9, "a"),
                         [] {
                           IssuedCopy c = copy_of(9, "b");
                           c.id_bits = 20;
                           return c;
                         }()}),
               InvalidArgumentError);
  EXPECT_EQ(r.list().size(), 1u);
  // The same ID under another key, or from another original, is another copy.
  IssuedCopy other_key = copy_of(1, "k"), other_original = copy_of(1, "o");
  other_key.key_fingerprint = std::string(32, 'e');
  other_original.original_hash = std::string(64, 'c');
  other_original.original_geometry = std::string(64, 'e');
  // Another file of the same geometry is the same original: its ID 1 is taken.
  IssuedCopy same_shape = copy_of(1, "s");
  same_shape.original_hash = std::string(64, 'c');
  EXPECT_THROW(r.record({same_shape}), InvalidArgumentError);
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

TEST(Registry, CopiesMarkedWithinFidelityLimitsRecordTheirOwnStrengthAndResume) {
  // Each copy of a --fidelity batch gets its own strength and G, recorded: embedding its ID
  // again at the recorded settings gives the same file, byte for byte; and the batch run again
  // skips every copy as issued (the settings were searched, not given).
  const std::string spot = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(spot, "spot.obj");
  const std::string dir = test::scratch_dir();
  const std::string db = dir + "/shop.db";
  {
    std::ofstream manifest(dir + "/m.txt");
    for (int id = 7; id < 10; ++id)
      manifest << spot << " " << dir << "/c" << id << ".obj id:" << id << " buyer " << id << "\n";
  }
  const std::string batch =
      "embed --batch " + dir + "/m.txt --key shop --registry " + db + " --fidelity paper";
  test::CliRun r = test::run_cli(batch);
  ASSERT_EQ(r.code, 0) << r.out;
  const std::vector<IssuedCopy> issued = Registry(db).list();
  ASSERT_EQ(issued.size(), 3u);
  for (const IssuedCopy& c : issued) {
    EXPECT_GT(c.strength, 0.001);
    EXPECT_LE(c.bin_offset, c.strength);  // G = min(0.05, alpha)
    const std::string again = dir + "/again" + std::to_string(c.id) + ".obj";
    // A registered copy carries the fingerprint (mark format 5) unless it would have cost the
    // file its histogram mark: asked for here, as the row says.
    r = test::run_cli(fmt::format("embed {} {} --id {} --key shop --strength {} --bin-offset {}{}",
                                  spot, again, c.id, c.strength, c.bin_offset,
                                  c.mark_format == kFingerprintMarkFormat ? " --fingerprint" : ""));
    ASSERT_EQ(r.code, 0) << r.out;
    EXPECT_EQ(read_file(again), read_file(c.output_path)) << c.id;
  }
  r = test::run_cli(batch);
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("3 issued before and skipped"), std::string::npos) << r.out;
  EXPECT_EQ(Registry(db).list().size(), 3u);
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

TEST(Registry, ASchemaOneStoreIsMigratedAndItsCopiesReadAsQp) {
  // A registry as schema version 1 wrote it (its statements written out here), with one copy.
  const std::string path = test::scratch_dir() + "/v1.db";
  std::filesystem::remove(path);
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  const char* v1 =
      "CREATE TABLE copies (row INTEGER PRIMARY KEY, original_hash TEXT NOT NULL, original_path "
      "TEXT NOT NULL, buyer TEXT NOT NULL, id INTEGER NOT NULL, id_bits INTEGER NOT NULL, bits "
      "INTEGER NOT NULL, variant TEXT NOT NULL, strength REAL NOT NULL, strength_spread REAL NOT "
      "NULL, bin_offset REAL NOT NULL, key_fingerprint TEXT NOT NULL, mark_format INTEGER NOT "
      "NULL, issued_at TEXT NOT NULL, output_path TEXT NOT NULL, output_hash TEXT NOT NULL, "
      "UNIQUE (original_hash, key_fingerprint, bits, id_bits, id));"
      "CREATE INDEX copies_by_buyer ON copies (buyer);"
      "INSERT INTO copies VALUES (1, 'h', '/o.obj', 'Ann', 7, 32, 64, 'DRS', 0.03, 0.25, 0.03, "
      "'f', 2, '2026-01-01T00:00:00Z', '/c.obj', 'ch');"
      "PRAGMA user_version = 1;";
  ASSERT_EQ(sqlite3_exec(db, v1, nullptr, nullptr, nullptr), SQLITE_OK);
  sqlite3_close(db);
  {  // read as it is, without migrating: trace's columns as list() reads them
    const Registry old(path, true);
    EXPECT_EQ(old.schema_version(), 1);
    const std::vector<CandidateRow> c = old.candidates({}, "ch");
    ASSERT_EQ(c.size(), 1u);
    EXPECT_EQ(c[0].id, 7u);
    EXPECT_EQ(c[0].method, "qp");
    EXPECT_EQ(c[0].strength, 0.03);
    EXPECT_TRUE(c[0].same_bytes);
    EXPECT_EQ(old.rows({1})[0].buyer, "Ann");
  }
  Registry r(path);
  EXPECT_EQ(r.schema_version(), kRegistrySchemaVersion);  // through every migration
  std::vector<IssuedCopy> all = r.list();
  ASSERT_EQ(all.size(), 1u);
  EXPECT_EQ(all[0].buyer, "Ann");
  EXPECT_EQ(all[0].method, "qp");
  EXPECT_EQ(all[0].original_geometry, "");  // known by its file alone
  IssuedCopy cho = copy_of(8, "Bo");
  cho.method = "cho-variance";
  r.record({cho});
  all = Registry(path).list();
  ASSERT_EQ(all.size(), 2u);
  EXPECT_EQ(all[1].method, "cho-variance");
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

// geometry_hash: the same for the same shape through every writer the project has (OBJ, PLY,
// binary STL, GLB with float32 positions), and whatever the order of vertices and faces, the
// corner a face starts at, an unreferenced vertex or a duplicated position; another for a
// vertex moved by 1e-4 of the diagonal, a face turned over or a face left out.
TEST(Registry, GeometryHashIsTheShapeAloneWhateverTheFile) {
  const std::string spot = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(spot, "spot.obj");
  const Mesh m = read_mesh(spot);
  const std::string h = geometry_hash(m.V, m.F);
  EXPECT_EQ(h.size(), 64u);
  const std::string dir = test::scratch_dir() + "/geometry-hash";
  std::filesystem::create_directories(dir);
  for (const char* ext : {"obj", "ply", "stl", "glb", "off"}) {
    const std::string path = dir + "/spot." + ext;
    write_mesh(path, m);
    const Mesh back = read_mesh(path);
    EXPECT_EQ(geometry_hash(back.V, back.F), h) << ext;
  }
  // Reordered: vertices reversed, faces reversed, every face started at its second corner, an
  // unreferenced vertex appended, and vertex 0's position duplicated for the first face.
  const Eigen::Index n = m.V.rows();
  Eigen::MatrixX3d V(n + 2, 3);
  for (Eigen::Index i = 0; i < n; ++i) V.row(n - 1 - i) = m.V.row(i);
  V.row(n) << 1e9, 1e9, 1e9;
  V.row(n + 1) = m.V.row(0);
  Eigen::MatrixX3i F(m.F.rows(), 3);
  for (Eigen::Index f = 0; f < m.F.rows(); ++f) {
    const Eigen::Index g = m.F.rows() - 1 - f;
    for (int c = 0; c < 3; ++c) F(g, c) = static_cast<int>(n - 1 - m.F(f, (c + 1) % 3));
  }
  for (int c = 0; c < 3; ++c)
    if (F(0, c) == n - 1) F(0, c) = static_cast<int>(n + 1);  // vertex 0 by its duplicate
  EXPECT_EQ(geometry_hash(V, F), h);
  Eigen::MatrixX3d moved = m.V;
  const double diagonal = (m.V.colwise().maxCoeff() - m.V.colwise().minCoeff()).norm();
  moved(10, 0) += 1e-4 * diagonal;
  EXPECT_NE(geometry_hash(moved, m.F), h);
  Eigen::MatrixX3i flipped = m.F;
  std::swap(flipped(5, 1), flipped(5, 2));
  EXPECT_NE(geometry_hash(m.V, flipped), h);
  EXPECT_NE(geometry_hash(m.V, m.F.topRows(m.F.rows() - 1)), h);
}

// The review's reproduction: ID 1042 issued from O.obj to b-1042, then the same geometry as
// O.glb (and as O.obj with one comment line added) asked for ID 1042 for mallory. Both are
// refused, naming b-1042 and the same geometry, with nothing written; and trace with O.glb as
// the original finds b-1042's row and names b-1042.
TEST(Registry, TheSameIdIsNeverIssuedTwiceForOneGeometry) {
  const std::string spot = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(spot, "spot.obj");
  const std::string dir = test::scratch_dir() + "/one-id-per-geometry";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string o = dir + "/O.obj", glb = dir + "/O.glb", commented = dir + "/O2.obj";
  std::filesystem::copy_file(spot, o);
  write_mesh(glb, read_mesh(o));
  {
    std::ifstream in(o, std::ios::binary);
    std::ofstream out(commented, std::ios::binary);
    out << "# re-saved\n" << in.rdbuf();
  }
  const std::string db = dir + "/reg.db", key = dir + "/k.key";
  ASSERT_EQ(test::run_cli("keygen " + key).code, 0);
  const std::string keyed = " --key-file " + key + " --registry " + db;
  test::CliRun r =
      test::run_cli("embed " + o + " " + dir + "/b.ply --id 1042 --buyer b-1042" + keyed);
  ASSERT_EQ(r.code, 0) << r.out;
  for (const std::string& other : {glb, commented}) {
    SCOPED_TRACE(other);
    r = test::run_cli("embed " + other + " " + dir + "/mallory.glb --id 1042 --buyer mallory" +
                      keyed);
    EXPECT_EQ(r.code, 1) << r.out;
    EXPECT_NE(r.out.find("b-1042"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("the same geometry"), std::string::npos) << r.out;
    EXPECT_FALSE(std::filesystem::exists(dir + "/mallory.glb"));
  }
  EXPECT_EQ(read_registry(db).size(), 1u);
  // id:auto from the GLB avoids b-1042's ID and codeword.
  r = test::run_cli("embed " + glb + " " + dir + "/c.glb --id auto --buyer carol" + keyed);
  ASSERT_EQ(r.code, 0) << r.out;
  const std::vector<IssuedCopy> rows = read_registry(db);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_NE(rows[1].id, 1042u);
  EXPECT_EQ(rows[0].original_geometry, rows[1].original_geometry);
  EXPECT_NE(rows[0].original_hash, rows[1].original_hash);
  // Traced with the GLB as the original, b-1042's copy is found and named.
  r = test::run_cli("trace " + dir + "/b.ply --original " + glb + keyed + " --json");
  ASSERT_EQ(r.code, 0) << r.out;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["candidates"], 2);
  ASSERT_EQ(j["named"].size(), 1u) << r.out;
  EXPECT_EQ(j["named"][0]["buyer"], "b-1042");
}

// Reading never changes a registry (the review: trace switched a DELETE-journal registry to
// WAL, changing the hash its report records, and could not read a read-only one): list,
// export and trace leave its bytes as they were, on a registry in DELETE journal mode, on a
// read-only file, and on a schema-2 registry (read as it is, not migrated).
TEST(Registry, ReadingLeavesItsBytesAsTheyWere) {
  const std::string spot = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(spot, "spot.obj");
  const std::string dir = test::scratch_dir() + "/read-only";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string db = dir + "/reg.db", key = dir + "/k.key";
  ASSERT_EQ(test::run_cli("keygen " + key).code, 0);
  ASSERT_EQ(test::run_cli("embed " + spot + " " + dir + "/c.ply --id 7 --buyer ann --key-file " +
                          key + " --registry " + db)
                .code,
            0);
  {  // the journal mode a registry copied or written by another tool may have
    sqlite3* h = nullptr;
    ASSERT_EQ(sqlite3_open(db.c_str(), &h), SQLITE_OK);
    ASSERT_EQ(sqlite3_exec(h, "PRAGMA journal_mode = DELETE", nullptr, nullptr, nullptr),
              SQLITE_OK);
    sqlite3_close(h);
  }
  const auto bytes = [](const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  };
  const std::string before = bytes(db);
  const std::string reads[] = {
      "registry list " + db, "registry export " + db, "registry show " + db + " --id 7",
      "trace " + dir + "/c.ply --original " + spot + " --registry " + db + " --key-file " + key};
  for (const std::string& command : reads) {
    const test::CliRun r = test::run_cli(command);
    EXPECT_EQ(r.code, 0) << command << "\n" << r.out;
    EXPECT_EQ(bytes(db), before) << command;
  }
  EXPECT_FALSE(std::filesystem::exists(db + "-wal"));
  // Read-only: the file, and then the folder too.
  std::filesystem::permissions(db, std::filesystem::perms::owner_read);
  EXPECT_EQ(read_registry(db).size(), 1u);
  const test::CliRun ro = test::run_cli(reads[3]);
  EXPECT_EQ(ro.code, 0) << ro.out;
  std::filesystem::permissions(
      db, std::filesystem::perms::owner_read | std::filesystem::perms::owner_write);
  // A schema-2 registry is read as it is: its rows have no geometry, its version stays 2.
  {
    sqlite3* h = nullptr;
    ASSERT_EQ(sqlite3_open(db.c_str(), &h), SQLITE_OK);
    ASSERT_EQ(sqlite3_exec(h,
                           "DROP INDEX copies_by_geometry; DROP INDEX copies_spaced_by_shape; "
                           "DROP INDEX copies_spaced_by_file; ALTER TABLE copies DROP COLUMN "
                           "spaced_index; ALTER TABLE copies DROP COLUMN original_geometry; "
                           "PRAGMA user_version = 2",
                           nullptr, nullptr, nullptr),
              SQLITE_OK)
        << sqlite3_errmsg(h);
    sqlite3_close(h);
  }
  const std::string v2 = bytes(db);
  const std::vector<IssuedCopy> rows = read_registry(db);
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0].buyer, "ann");
  EXPECT_EQ(rows[0].original_geometry, "");
  EXPECT_EQ(bytes(db), v2);
}

// Executes sql on the SQLite file at path, as someone editing a registry by hand would.
void edit_registry(const std::string& path, const std::string& sql) {
  sqlite3* h = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &h), SQLITE_OK);
  char* message = nullptr;
  EXPECT_EQ(sqlite3_exec(h, sql.c_str(), nullptr, nullptr, &message), SQLITE_OK)
      << (message ? message : "") << "\n"
      << sql;
  sqlite3_free(message);
  sqlite3_close(h);
}

TEST(Registry, RowMacsChangeWithEveryFieldAndTheKey) {
  const Key k = key_from_passphrase("shop"), other = key_from_passphrase("other");
  IssuedCopy c = copy_of(7, "Ann");
  c.key_fingerprint = key_fingerprint(k);
  c.issued_at = "2026-01-01T00:00:00Z";
  c.mac = row_mac(k, c);
  EXPECT_EQ(c.mac.size(), 64u);
  EXPECT_EQ(check_row(k, c), RowAuth::Authentic);
  EXPECT_EQ(check_row(other, c), RowAuth::OtherKey);
  // Each field a forger could change, one at a time: the MAC no longer matches.
  const std::vector<std::function<void(IssuedCopy&)>> edits = {
      [](IssuedCopy& e) { e.id = 8; },
      [](IssuedCopy& e) { e.buyer = "Bo"; },
      [](IssuedCopy& e) { e.output_hash = std::string(64, 'c'); },
      [](IssuedCopy& e) { e.original_hash = std::string(64, 'e'); },
      [](IssuedCopy& e) { e.original_geometry = ""; },
      [](IssuedCopy& e) { e.strength = 0.0310000001; },
      [](IssuedCopy& e) { e.id_bits = 31; },
      [](IssuedCopy& e) { e.issued_at = "2026-01-01T00:00:01Z"; },
      [](IssuedCopy& e) { e.output_path += "x"; },
      [](IssuedCopy& e) { e.method = "cho-mean"; },
      [](IssuedCopy& e) { e.mac[0] = e.mac[0] == '0' ? '1' : '0'; },
  };
  for (std::size_t i = 0; i < edits.size(); ++i) {
    IssuedCopy e = c;
    edits[i](e);
    EXPECT_EQ(check_row(k, e), RowAuth::Edited) << "edit " << i;
  }
  // Bytes moved between adjacent fields keep their concatenation: the lengths tell them apart.
  IssuedCopy split = c;  // "Ann" + "/shop/out/7.ply" as "An" + "n/shop/out/7.ply"
  split.buyer = "An", split.output_path = "n" + c.output_path;
  IssuedCopy joined = c;
  joined.buyer = "Ann/shop", joined.output_path = c.output_path.substr(5);
  EXPECT_NE(row_mac(k, split), c.mac);
  EXPECT_NE(row_mac(k, joined), c.mac);
  c.mac.clear();
  EXPECT_EQ(check_row(k, c), RowAuth::Unauthenticated);
  // record() with the key fills the MAC; a copy of another key is refused.
  const std::string db = test::scratch_dir() + "/mac.db";
  std::filesystem::remove(db);
  Registry r(db);
  IssuedCopy fresh = copy_of(9, "Cy");
  fresh.key_fingerprint = key_fingerprint(k);
  EXPECT_THROW(r.record({fresh}, other), InvalidArgumentError);
  const std::vector<IssuedCopy> done = r.record({fresh}, k);
  EXPECT_EQ(check_row(k, Registry(db).list().at(0)), RowAuth::Authentic);
  EXPECT_EQ(done.at(0).mac, Registry(db).list().at(0).mac);
}

// The reproduction of the review: two rows' IDs swapped with sqlite3 made trace name the other
// buyer. Now verify finds both rows, trace names neither, and a damaged index page is found.
TEST(Registry, AnEditedRowIsFoundByVerifyAndNeverNamed) {
  const std::string spot = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(spot, "spot.obj");
  const std::string dir = test::scratch_dir() + "/edited";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string db = dir + "/reg.db", key = dir + "/k.key";
  ASSERT_EQ(test::run_cli("keygen " + key).code, 0);
  for (const int id : {11, 40, 77}) {
    const test::CliRun r = test::run_cli(
        fmt::format("embed {} {}/c{}.ply --id {} --buyer b{} --key-file {} --registry {}", spot,
                    dir, id, id, id, key, db));
    ASSERT_EQ(r.code, 0) << r.out;
  }
  const auto bytes = [](const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  };
  const std::string verify = "registry verify " + db + " --key-file " + key + " --json";
  const std::string before = bytes(db);
  test::CliRun v = test::run_cli(verify);
  EXPECT_EQ(v.code, 0) << v.out;
  EXPECT_EQ(bytes(db), before);  // verify reads, never writes
  nlohmann::json j = nlohmann::json::parse(v.out);
  EXPECT_EQ(j["authentic"], 3);
  EXPECT_TRUE(j["ok"].get<bool>());
  // Under another key, nothing can be checked: three rows of another key, none authentic.
  ASSERT_EQ(test::run_cli("keygen " + dir + "/other.key").code, 0);
  v = test::run_cli("registry verify " + db + " --key-file " + dir + "/other.key --json");
  j = nlohmann::json::parse(v.out);
  EXPECT_EQ(j["other_key"], 3);
  EXPECT_EQ(j["authentic"], 0);
  EXPECT_FALSE(j["ok"].get<bool>());  // nothing checked is nothing verified
  EXPECT_EQ(v.code, 7) << v.out;
  // The forgery: b11's and b40's IDs swapped, so that b11's leak reads as "b40's ID".
  edit_registry(db,
                "UPDATE copies SET id = -1 WHERE id = 11; UPDATE copies SET id = 11 WHERE id = 40; "
                "UPDATE copies SET id = 40 WHERE id = -1;");
  v = test::run_cli(verify);
  EXPECT_EQ(v.code, 7) << v.out;
  j = nlohmann::json::parse(v.out);
  EXPECT_FALSE(j["ok"].get<bool>());
  EXPECT_EQ(j["authentic"], 1);
  ASSERT_EQ(j["edited"].size(), 2u) << v.out;
  std::set<std::string> edited;
  for (const auto& row : j["edited"]) edited.insert(row["buyer"].get<std::string>());
  EXPECT_EQ(edited, (std::set<std::string>{"b11", "b40"}));
  // b11's copy leaks unprocessed: the mark reads ID 11, whose row now says b40. Nobody named.
  const std::string trace =
      "trace " + dir + "/c11.ply --original " + spot + " --registry " + db + " --key-file " + key;
  test::CliRun t = test::run_cli(trace + " --json");
  EXPECT_EQ(t.code, 6) << t.out;
  const std::size_t brace = t.out.find('{');
  ASSERT_NE(brace, std::string::npos) << t.out;
  j = nlohmann::json::parse(t.out.substr(brace));
  EXPECT_EQ(j["status"], "no-buyer");
  EXPECT_TRUE(j["named"].empty());
  std::string warnings = j["warnings"].dump();
  EXPECT_NE(warnings.find("reads as the leaker"), std::string::npos) << warnings;
  EXPECT_NE(warnings.find("ID 11"), std::string::npos) << warnings;
  // b77's row is intact: its leak is still named, and is byte for byte its recorded file.
  t = test::run_cli("trace " + dir + "/c77.ply --original " + spot + " --registry " + db +
                    " --key-file " + key + " --json");
  EXPECT_EQ(t.code, 0) << t.out;
  j = nlohmann::json::parse(t.out.substr(t.out.find('{')));
  ASSERT_EQ(j["named"].size(), 1u) << t.out;
  EXPECT_EQ(j["named"][0]["buyer"], "b77");
  EXPECT_EQ(j["named"][0]["row_auth"], "authentic");
  EXPECT_EQ(j["identical_row"], 3);
  // A row whose MAC is removed is not named either: whoever can edit the registry can blank
  // MACs. Here b77's row and b11's (ID 40 since the swap above) trade IDs, both MACs removed:
  // the mark reads ID 77, now b11's row, and nobody is named; then b77's row alone, its own ID
  // back and its MAC still removed, is not named either.
  edit_registry(db,
                "UPDATE copies SET id = 1000001 WHERE buyer = 'b77'; "
                "UPDATE copies SET id = 77, mac = '' WHERE buyer = 'b11'; "
                "UPDATE copies SET id = 40, mac = '' WHERE buyer = 'b77'");
  const std::string trace77 = "trace " + dir + "/c77.ply --original " + spot + " --registry " + db +
                              " --key-file " + key + " --json";
  for (int edit = 0; edit < 2; ++edit) {
    t = test::run_cli(trace77);
    EXPECT_EQ(t.code, 6) << t.out;
    j = nlohmann::json::parse(t.out.substr(t.out.find('{')));
    EXPECT_TRUE(j["named"].empty()) << t.out;
    EXPECT_NE(j["warnings"].dump().find("no authentication code"), std::string::npos) << t.out;
    EXPECT_NE(j["message"].get<std::string>().find("authentication code"), std::string::npos)
        << t.out;
    if (edit == 0) EXPECT_NE(j["warnings"].dump().find("'b11'"), std::string::npos) << t.out;
    // Back to b77's own row, its MAC alone removed.
    edit_registry(db,
                  "UPDATE copies SET id = 1000001 WHERE buyer = 'b11'; "
                  "UPDATE copies SET id = 77 WHERE buyer = 'b77'; "
                  "UPDATE copies SET id = 40 WHERE buyer = 'b11'");
  }
  v = test::run_cli(verify);
  EXPECT_EQ(v.code, 7);
  EXPECT_EQ(nlohmann::json::parse(v.out)["unauthenticated"].size(), 2u) << v.out;
  // A damaged index page: list still reads the table, verify says the file is damaged.
  int page_size = 0, root = 0;
  {
    sqlite3* h = nullptr;
    ASSERT_EQ(sqlite3_open(db.c_str(), &h), SQLITE_OK);
    sqlite3_stmt* s = nullptr;
    sqlite3_prepare_v2(h, "SELECT rootpage FROM sqlite_master WHERE name = 'copies_by_buyer'", -1,
                       &s, nullptr);
    ASSERT_EQ(sqlite3_step(s), SQLITE_ROW);
    root = sqlite3_column_int(s, 0);
    sqlite3_finalize(s);
    sqlite3_prepare_v2(h, "PRAGMA page_size", -1, &s, nullptr);
    ASSERT_EQ(sqlite3_step(s), SQLITE_ROW);
    page_size = sqlite3_column_int(s, 0);
    sqlite3_finalize(s);
    sqlite3_exec(h, "PRAGMA journal_mode = DELETE", nullptr, nullptr, nullptr);
    sqlite3_close(h);
  }
  ASSERT_GT(root, 1);
  {
    std::fstream f(db, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(static_cast<std::streamoff>(root - 1) * page_size + 8);  // past the page header
    const std::string junk(64, '\x5a');
    f.write(junk.data(), static_cast<std::streamsize>(junk.size()));
  }
  v = test::run_cli("registry verify " + db + " --key-file " + key);
  EXPECT_EQ(v.code, 7) << v.out;
  EXPECT_NE(v.out.find("DAMAGED"), std::string::npos) << v.out;
  // Listing prints what it reads and says the file is damaged, exit 7 (it exited 0).
  for (const char* command : {"list", "show", "export"}) {
    v = test::run_cli(std::string("registry ") + command + " " + db);
    EXPECT_EQ(v.code, 7) << command << "\n" << v.out;
    EXPECT_NE(v.out.find("the registry file is DAMAGED"), std::string::npos) << v.out;
  }
}

// A row edited to values no copy is issued with (a layout of 10^8 bits, an unknown variant, an
// ID longer than its length) made every trace of the original hang or stop with exit 1. Such a
// row is counted among the candidates but not read; the intact row's leak is still named, and
// when no row can be read nobody is named (exit 6).
TEST(Registry, RowsHoldingValuesNoCopyIsIssuedWithAreCountedButNotRead) {
  const std::string spot = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(spot, "spot.obj");
  const std::string dir = test::scratch_dir();
  const std::string db = dir + "/reg.db", key = dir + "/k.key";
  ASSERT_EQ(test::run_cli("keygen " + key).code, 0);
  for (const int id : {1, 2}) {
    const test::CliRun r =
        test::run_cli(fmt::format("embed {} {}/c{}.ply --id {} --buyer b{} --key-file {} "
                                  "--registry {}",
                                  spot, dir, id, id, id, key, db));
    ASSERT_EQ(r.code, 0) << r.out;
  }
  const std::string trace = "trace " + dir + "/c1.ply --original " + spot + " --registry " + db +
                            " --key-file " + key + " --json";
  struct Edit {
    std::string sql, said;
  };
  for (const Edit& e :
       {Edit{"bits = 100000000", "100000000 bits"}, Edit{"variant = 'ZZZ'", "unknown center"},
        Edit{"id = -1", "does not fit in its 32 bits"}, Edit{"strength = 1e999", "strength inf"}}) {
    SCOPED_TRACE(e.sql);
    edit_registry(db, "UPDATE copies SET " + e.sql + " WHERE buyer = 'b2'");
    const test::CliRun t = test::run_cli(trace);
    EXPECT_EQ(t.code, 0) << t.out;
    const nlohmann::json j = nlohmann::json::parse(t.out.substr(t.out.find('{')));
    ASSERT_EQ(j["named"].size(), 1u) << t.out;
    EXPECT_EQ(j["named"][0]["buyer"], "b1");
    EXPECT_EQ(j["candidates"], 2);  // the edited row still counts in the correction
    const std::string warnings = j["warnings"].dump();
    EXPECT_NE(warnings.find("row 2 (ID "), std::string::npos) << warnings;
    EXPECT_NE(warnings.find(e.said), std::string::npos) << warnings;
    edit_registry(db, "DELETE FROM copies WHERE buyer = 'b2'");
    const test::CliRun r =
        test::run_cli(fmt::format("embed {} {}/c2.ply --id 2 --buyer b2 --key-file {} "
                                  "--registry {}",
                                  spot, dir, key, db));
    ASSERT_EQ(r.code, 0) << r.out;
  }
  edit_registry(db, "UPDATE copies SET bits = 0");
  const test::CliRun t = test::run_cli(trace);
  EXPECT_EQ(t.code, 6) << t.out;
  const nlohmann::json j = nlohmann::json::parse(t.out.substr(t.out.find('{')));
  EXPECT_TRUE(j["named"].empty());
  EXPECT_NE(j["message"].get<std::string>().find("no candidate row can be read"), std::string::npos)
      << t.out;
}

TEST(Registry, CommandLineIssuesRecordsAndSurvivesAKilledBatch) {
  const std::string spot = test::data_mesh("spot.obj");
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
  // again, it completes (resuming past the copies already recorded, if it had).
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
  r = test::run_cli(batch);
  EXPECT_EQ(r.code, 0) << r.out;
  std::vector<IssuedCopy> all = Registry(db).list();
  ASSERT_EQ(all.size(), 61u);
  // Run once more: every line was issued and its file is intact, so each is skipped, and
  // nothing new is recorded.
  r = test::run_cli(batch);
  EXPECT_EQ(r.code, 0) << r.out;
  std::size_t skipped = 0;
  for (std::size_t at = r.out.find("intact: skipped"); at != std::string::npos;
       at = r.out.find("intact: skipped", at + 1))
    ++skipped;
  EXPECT_EQ(skipped, 60u) << r.out;
  EXPECT_NE(r.out.find("0 of 60 copies watermarked"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("60 issued before and skipped"), std::string::npos) << r.out;
  EXPECT_EQ(Registry(db).list().size(), 61u);
  all = Registry(db).list();
  for (const IssuedCopy& c : all) {
    // Each record names a file that exists, with the hash it has.
    EXPECT_EQ(c.output_hash, content_hash(read_file(c.output_path))) << c.output_path;
    EXPECT_EQ(c.original_hash, content_hash(read_file(spot)));
  }
  r = test::run_cli("registry list " + db + " --buyer 'buyer 7'");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("107"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("1 copy"), std::string::npos) << r.out;
  // A copy whose file changed since is not taken for issued: its line is refused.
  std::ofstream(dir + "/c7.obj", std::ios::app) << "# edited\n";
  r = test::run_cli(batch);
  EXPECT_NE(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("ID 107 already issued"), std::string::npos) << r.out;
  EXPECT_EQ(Registry(db).list().size(), 61u);
}

TEST(RegistryPostgres, GivesWhatSqliteGivesAndRefusesTheSameIds) {
  MESHMARK_REQUIRE_POSTGRES();
  const std::string pg = PostgresServer::get().fresh_database("same");
  const std::string lite = test::scratch_dir() + "/r.db";
  std::filesystem::remove(lite);
  std::vector<std::vector<IssuedCopy>> lists;
  for (const std::string& where : {pg, lite}) {
    Registry r(where);
    EXPECT_EQ(r.schema_version(), kRegistrySchemaVersion);
    IssuedCopy odd = copy_of(4294967295ull, "O'Brien; DROP TABLE copies; --");
    odd.strength = 0.1 + 0.2;  // not exactly representable in short decimal
    odd.issued_at = "2026-12-01T00:00:00Z";
    r.record({copy_of(1, "a"), odd});
    EXPECT_THROW(r.record({copy_of(5, "b"), copy_of(1, "c")}), InvalidArgumentError);
    lists.push_back(Registry(where).list());
  }
  ASSERT_EQ(lists[0].size(), 2u);
  ASSERT_EQ(lists[1].size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    const IssuedCopy &a = lists[0][i], &b = lists[1][i];
    EXPECT_EQ(a.row, b.row);
    EXPECT_EQ(a.id, b.id);
    EXPECT_EQ(a.buyer, b.buyer);
    EXPECT_EQ(a.strength, b.strength);  // bit for bit
    EXPECT_EQ(a.strength_spread, b.strength_spread);
    EXPECT_EQ(a.bin_offset, b.bin_offset);
    EXPECT_EQ(a.original_hash, b.original_hash);
    EXPECT_EQ(a.key_fingerprint, b.key_fingerprint);
    EXPECT_EQ(a.output_path, b.output_path);
    EXPECT_EQ(a.output_hash, b.output_hash);
    EXPECT_EQ(a.mark_format, b.mark_format);
  }
  EXPECT_EQ(lists[0][1].strength, 0.1 + 0.2);
  EXPECT_EQ(lists[0][1].issued_at, "2026-12-01T00:00:00Z");
}

// The same batch issued into SQLite and into PostgreSQL, and a processed leak of one copy traced
// against each: the two JSON reports are the same, and name that copy's buyer.
TEST(RegistryPostgres, TraceGivesTheSameResultWithEitherRegistry) {
  MESHMARK_REQUIRE_POSTGRES();
  const std::string spot = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(spot, "spot.obj");
  const std::string pg = PostgresServer::get().fresh_database("trace");
  const std::string dir = test::scratch_dir();
  const std::string lite = dir + "/shop.db";
  std::filesystem::remove(lite);
  std::ofstream manifest(dir + "/m.txt");
  for (int i = 0; i < 8; ++i)
    manifest << spot << " " << dir << "/c" << i << ".obj id:" << 500 + i << " buyer" << i << "\n";
  manifest.close();
  std::vector<std::string> reports;
  for (const std::string& where : {lite, pg}) {
    test::CliRun r = test::run_cli("embed --batch " + dir + "/m.txt --key studio --variant VRS " +
                                   "--registry '" + where + "'");
    ASSERT_EQ(r.code, 0) << r.out;
    if (where == lite) {
      r = test::run_cli("attack similarity:2,simplify:0.6 " + dir + "/c5.obj " + dir + "/leak.obj");
      ASSERT_EQ(r.code, 0) << r.out;
    }
    r = test::run_cli("trace " + dir + "/leak.obj --original " + spot + " --registry '" + where +
                      "' --key studio --json");
    EXPECT_EQ(r.code, 0) << r.out;
    EXPECT_NE(r.out.find("\"buyer\": \"buyer5\""), std::string::npos) << r.out;
    reports.push_back(r.out);
  }
  EXPECT_EQ(reports[0], reports[1]);
}

// What trace reads of a registry (Registry::candidates, Registry::rows) against what list()
// reads of it, in SQLite and in PostgreSQL: the scoring fields of the same rows in the same
// order, the row whose file hash was given and no other, whole rows in the order asked for,
// and a row that is not there refused by name.
void check_candidates_against_list(const std::string& where) {
  Registry r(where);
  std::vector<IssuedCopy> batch;
  for (std::uint64_t id = 51; id >= 40; --id) {  // rows and IDs in opposite orders
    IssuedCopy c = copy_of(id, "buyer " + std::to_string(id));
    c.output_hash = std::string(63, 'b') + static_cast<char>('a' + id % 16);
    c.variant = id % 3 == 0 ? "DRS" : "VSS";
    c.method = id % 4 == 0 ? "cho-mean" : "qp";
    c.strength = id % 5 == 0 ? 0.0 : 0.01 + 1e-3 * static_cast<double>(id);  // 0: fingerprint alone
    c.strength_spread = 0.1 + 0.2;                                           // not short in decimal
    c.mark_format = id % 2 == 0 ? 4 : 3;
    c.bits = id == 47 ? 96 : 64;
    c.id_bits = id == 47 ? 40 : 32;
    batch.push_back(c);
  }
  IssuedCopy other = copy_of(60, "another original's");
  other.original_hash = std::string(64, 'e');
  other.original_geometry = std::string(64, 'e');
  batch.push_back(other);
  r.record(batch);
  RegistryQuery q;
  q.original_hash = std::string(64, 'a');
  q.original_geometry = std::string(64, 'd');
  q.key_fingerprint = std::string(32, 'f');
  // First this original's copies are most of the registry (SQLite reads it in one pass), then
  // a few among many others (through the indexes).
  for (const bool crowded : {false, true}) {
    if (crowded) {
      std::vector<IssuedCopy> others;
      for (std::uint64_t id = 100; id < 160; ++id) {
        IssuedCopy o = copy_of(id, "another original's");
        o.original_hash = o.original_geometry = std::string(64, '0' + id % 7);
        others.push_back(o);
      }
      r.record(others);
    }
    SCOPED_TRACE(crowded ? "among many others" : "most of the registry");
    const std::vector<IssuedCopy> listed = r.list(q);
    const std::string wanted = batch[5].output_hash;  // ID 46's file
    const std::vector<CandidateRow> candidates = r.candidates(q, wanted);
    ASSERT_EQ(candidates.size(), 12u);
    ASSERT_EQ(listed.size(), candidates.size());
    for (std::size_t i = 0; i < listed.size(); ++i) {
      const CandidateRow& c = candidates[i];
      const IssuedCopy& l = listed[i];
      EXPECT_EQ(c.row, l.row);
      EXPECT_EQ(c.id, l.id);
      EXPECT_EQ(c.id_bits, l.id_bits);
      EXPECT_EQ(c.bits, l.bits);
      EXPECT_EQ(c.variant, l.variant);
      EXPECT_EQ(c.strength, l.strength);  // bit for bit
      EXPECT_EQ(c.strength_spread, l.strength_spread);
      EXPECT_EQ(c.method, l.method);
      EXPECT_EQ(c.mark_format, l.mark_format);
      EXPECT_EQ(c.same_bytes, l.output_hash == wanted) << "row " << l.row;
      EXPECT_TRUE(same_scoring(c, l));
    }
    EXPECT_EQ(std::count_if(candidates.begin(), candidates.end(),
                            [](const CandidateRow& c) { return c.same_bytes; }),
              1);
    for (const CandidateRow& c : r.candidates(q)) EXPECT_FALSE(c.same_bytes);  // no hash given
  }
  const std::vector<IssuedCopy> listed = r.list(q);
  const std::vector<CandidateRow> candidates = r.candidates(q);
  const std::vector<std::int64_t> asked = {listed[7].row, listed[0].row, listed[11].row};
  const std::vector<IssuedCopy> rows = r.rows(asked);
  ASSERT_EQ(rows.size(), 3u);
  for (std::size_t i = 0; i < asked.size(); ++i) {
    EXPECT_EQ(rows[i].row, asked[i]);
    const IssuedCopy& l = *std::find_if(listed.begin(), listed.end(),
                                        [&](const IssuedCopy& x) { return x.row == asked[i]; });
    EXPECT_EQ(rows[i].buyer, l.buyer);
    EXPECT_EQ(rows[i].output_hash, l.output_hash);
    EXPECT_EQ(rows[i].mac, l.mac);
  }
  try {
    r.rows({listed[0].row, 999999});
    ADD_FAILURE() << "a row that is not there was read";
  } catch (const IOError& e) {
    EXPECT_NE(std::string(e.what()).find("row 999999 is no longer in the registry"),
              std::string::npos)
        << e.what();
  }
  IssuedCopy changed = listed[3];
  CandidateRow read = candidates[3];
  EXPECT_TRUE(same_scoring(read, changed));
  changed.strength *= 1 + 1e-15;  // completed since it was listed
  EXPECT_FALSE(same_scoring(read, changed));
}

TEST(Registry, TraceReadsTheScoringFieldsOfTheRowsListAndWholeRowsByNumber) {
  const std::string db = test::scratch_dir() + "/r.db";
  std::filesystem::remove(db);
  check_candidates_against_list(db);
}

TEST(RegistryPostgres, TraceReadsTheScoringFieldsOfTheRowsListAndWholeRowsByNumber) {
  MESHMARK_REQUIRE_POSTGRES();
  check_candidates_against_list(PostgresServer::get().fresh_database("candidates"));
}

TEST(RegistryPostgres, ConcurrentWritersLoseNothingAndNeverShareAnId) {
  MESHMARK_REQUIRE_POSTGRES();
  const std::string pg = PostgresServer::get().fresh_database("concurrent");
  Registry(pg).schema_version();
  // Four writers, each its own connection (as machines would have); they all try the same
  // 50 IDs in batches of 5, plus 50 IDs of their own: every shared ID goes to exactly one.
  const int writers = 4;
  std::vector<std::thread> threads;
  std::atomic<int> refused{0};
  for (int w = 0; w < writers; ++w)
    threads.emplace_back([&, w] {
      Registry r(pg);
      for (int b = 0; b < 10; ++b) {
        std::vector<IssuedCopy> shared, own;
        for (int i = 0; i < 5; ++i) {
          shared.push_back(copy_of(5 * b + i, "w" + std::to_string(w)));
          own.push_back(copy_of(1000 * (w + 1) + 5 * b + i, "w" + std::to_string(w)));
        }
        try {
          r.record(shared);
        } catch (const InvalidArgumentError&) {
          ++refused;
        }
        r.record(own);
      }
    });
  for (auto& t : threads) t.join();
  const std::vector<IssuedCopy> all = Registry(pg).list();
  std::set<std::uint64_t> ids;
  for (const IssuedCopy& c : all) EXPECT_TRUE(ids.insert(c.id).second) << "ID " << c.id << " twice";
  EXPECT_EQ(all.size(), 50u + writers * 50u);
  EXPECT_EQ(refused, writers * 10 - 10);  // each shared batch recorded exactly once
}

TEST(RegistryPostgres, CommandLineIssuesToPostgres) {
  MESHMARK_REQUIRE_POSTGRES();
  const std::string spot = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(spot, "spot.obj");
  const std::string pg = PostgresServer::get().fresh_database("cli");
  const std::string dir = test::scratch_dir();
  test::CliRun r = test::run_cli("embed " + spot + " " + dir +
                                 "/a.obj --id 3 --key k --registry '" + pg + "' --buyer Zoe");
  ASSERT_EQ(r.code, 0) << r.out;
  r = test::run_cli("registry list '" + pg + "'");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("Zoe"), std::string::npos) << r.out;
  r = test::run_cli("embed " + spot + " " + dir + "/b.obj --id 3 --key k --registry '" + pg +
                    "' --buyer Yann");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_FALSE(std::filesystem::exists(dir + "/b.obj"));
}

}  // namespace
}  // namespace meshmark
