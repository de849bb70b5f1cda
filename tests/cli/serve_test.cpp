// meshmark serve, run as a user runs it (the built CLI, on 127.0.0.1, a port of its choosing)
// and called over HTTP: the token, originals prepared once, copies issued with their IDs and
// rows, what the registry records of them, traces, bad requests, concurrent clients, a kill.

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <set>
#include <thread>

#include "meshmark/forensics/registry.h"
#include "meshmark/io/io.h"
#include "meshmark/protocol/coding.h"
#include "meshmark/protocol/key.h"
#include "meshmark/protocol/watermark.h"
#include "postgres_server.h"
#include "test_data.h"

// After Eigen's headers: <resolv.h>, which httplib.h includes, defines _res.
#include <httplib.h>

namespace meshmark {
namespace {

namespace fs = std::filesystem;

const std::string kToken = "test-token-0123456789abcdef";

// A server started by the CLI, stopped (SIGTERM) when this goes out of scope.
class Server {
 public:
  // registry: an SQLite file or a postgresql:// URI ("": dir/shop.db); log: where its output
  // goes in dir.
  explicit Server(const std::string& dir, const std::string& registry = "",
                  const std::string& log_name = "serve.log") {
    const std::string log = dir + "/" + log_name;
    const std::string where = registry.empty() ? dir + "/shop.db" : registry;
    std::remove(log.c_str());
    // Everything the child needs is made before fork: it only calls execl.
    const std::string cmd = fmt::format(
        "MESHMARK_TOKEN={} exec {} serve --listen 127.0.0.1:0 --registry '{}' --key-file "
        "{}/shop.key > {} 2>&1",
        kToken, MESHMARK_CLI, where, dir, log);
    pid_ = fork();
    if (pid_ == 0) {
      execl("/bin/sh", "sh", "-c", cmd.c_str(), static_cast<char*>(nullptr));
      _exit(127);
    }
    // The port, from the line it prints when it listens.
    for (int i = 0; i < 200 && port_ == 0; ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
      std::ifstream in(log);
      std::string line;
      while (std::getline(in, line))
        if (const auto at = line.find("http://127.0.0.1:"); at != std::string::npos)
          port_ = std::stoi(line.substr(at + 17));
    }
  }
  ~Server() { stop(SIGTERM); }
  // Sends signal and waits for the process; its exit status.
  int stop(int signal) {
    if (pid_ <= 0) return -1;
    kill(pid_, signal);
    int status = 0;
    waitpid(pid_, &status, 0);
    pid_ = -1;
    return status;
  }
  int port() const { return port_; }
  httplib::Client client(bool with_token = true) const {
    httplib::Client c("127.0.0.1", port_);
    c.set_read_timeout(120, 0);
    if (with_token) c.set_bearer_token_auth(kToken.c_str());
    return c;
  }

 private:
  pid_t pid_ = -1;
  int port_ = 0;
};

std::string bytes_of(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

std::string fresh_dir(const std::string& name) {
  const std::string dir = test::scratch_dir() + "/" + name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  EXPECT_EQ(test::run_cli("keygen " + dir + "/shop.key").code, 0);
  return dir;
}

// Posts an original; its hash.
std::string post_original(httplib::Client& c, const std::string& path) {
  const httplib::MultipartFormDataItems items = {
      {"mesh", bytes_of(path), fs::path(path).filename().string(), "application/octet-stream"}};
  const auto r = c.Post("/originals", items);
  EXPECT_TRUE(r);
  if (!r) return "";
  EXPECT_TRUE(r->status == 201 || r->status == 200) << r->body;
  return nlohmann::json::parse(r->body).value("original", "");
}

TEST(Serve, IssuesCopiesThatCarryTheirIdsAndTracesALeak) {
  const std::string dir = fresh_dir("serve-basic");
  Server server(dir);
  ASSERT_NE(server.port(), 0) << bytes_of(dir + "/serve.log");
  // The token: /health needs none, everything else a right one.
  httplib::Client anonymous = server.client(false);
  auto r = anonymous.Get("/health");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  EXPECT_EQ(nlohmann::json::parse(r->body)["status"], "ok");
  r = anonymous.Post("/copies", "{}", "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 401);
  httplib::Client wrong("127.0.0.1", server.port());
  wrong.set_bearer_token_auth((kToken + "x").c_str());
  r = wrong.Get("/copies/1");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 401);

  httplib::Client c = server.client();
  const std::string original = test::data_mesh("bunny.ply");
  const std::string hash = post_original(c, original);
  // The hash is the original's geometry hash, computed here from the file.
  const Mesh mesh = read_mesh(original);
  EXPECT_EQ(hash, geometry_hash(mesh.V, mesh.F));
  // Posted again: known, not prepared again.
  r = c.Post("/originals",
             httplib::MultipartFormDataItems{{"mesh", bytes_of(original), "again.ply", ""}});
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  EXPECT_TRUE(nlohmann::json::parse(r->body)["prepared_before"].get<bool>());

  // Three copies: each file's bytes hash to its row's output_hash, and carry its ID.
  std::vector<std::uint64_t> ids;
  for (const std::string buyer : {"ann", "bob", "cid"}) {
    r = c.Post("/copies",
               nlohmann::json{{"original", hash}, {"buyer", buyer}, {"format", "ply"}}.dump(),
               "application/json");
    ASSERT_TRUE(r);
    ASSERT_EQ(r->status, 200) << r->body;
    const std::uint64_t id = std::stoull(r->get_header_value("X-Meshmark-Id"));
    const std::int64_t row = std::stoll(r->get_header_value("X-Meshmark-Row"));
    const std::string copy = dir + "/" + buyer + ".ply";
    std::ofstream(copy, std::ios::binary) << r->body;
    RegistryQuery q;
    q.id = id;
    const std::vector<IssuedCopy> rows = read_registry(dir + "/shop.db", q);
    ASSERT_EQ(rows.size(), 1u);
    EXPECT_EQ(rows[0].row, row);
    EXPECT_EQ(rows[0].buyer, buyer);
    EXPECT_EQ(rows[0].state, "issued");
    EXPECT_EQ(rows[0].output_hash, content_hash(r->body));
    EXPECT_EQ(rows[0].original_geometry, hash);
    const Mesh got = read_mesh(copy);  // the file read back blind carries the ID
    const IdReading read = read_id(got.V, got.F, ExtractOptions{}, IdCode(IdCodeOptions{}),
                                   key_from_file(dir + "/shop.key"));
    EXPECT_TRUE(read.id.valid) << read.id.message;
    EXPECT_EQ(read.id.id, id);
    ids.push_back(id);
  }
  EXPECT_EQ(std::set<std::uint64_t>(ids.begin(), ids.end()).size(), 3u);
  // GET /copies/ID: the row as registry list prints it.
  r = c.Get(fmt::format("/copies/{}", ids[1]).c_str());
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  EXPECT_EQ(nlohmann::json::parse(r->body)[0]["buyer"], "bob");
  // bob's copy simplified to half leaks: POST /trace names bob, as trace --json does.
  ASSERT_EQ(
      test::run_cli("attack simplify " + dir + "/bob.ply " + dir + "/leak.obj --strength 0.5").code,
      0);
  r = c.Post("/trace",
             httplib::MultipartFormDataItems{{"leak", bytes_of(dir + "/leak.obj"), "leak.obj", ""},
                                             {"original", hash, "", ""}});
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200) << r->body;
  const nlohmann::json verdict = nlohmann::json::parse(r->body);
  EXPECT_EQ(verdict["status"], "named");
  ASSERT_EQ(verdict["named"].size(), 1u) << r->body;
  EXPECT_EQ(verdict["named"][0]["buyer"], "bob");
  EXPECT_EQ(verdict["candidates"], 3);
  const test::CliRun cli =
      test::run_cli("trace " + dir + "/leak.obj --original " + original + " --registry " + dir +
                    "/shop.db --key-file " + dir + "/shop.key --json");
  const nlohmann::json by_cli = nlohmann::json::parse(cli.out.substr(cli.out.find('{')));
  EXPECT_EQ(by_cli["named"][0]["corrected_p"], verdict["named"][0]["corrected_p"]);
}

// Bad requests get a 4xx with a JSON error and change nothing in the registry.
TEST(Serve, BadRequestsAreRefusedAndChangeNothing) {
  const std::string dir = fresh_dir("serve-bad");
  Server server(dir);
  ASSERT_NE(server.port(), 0) << bytes_of(dir + "/serve.log");
  httplib::Client c = server.client();
  const std::string hash = post_original(c, test::data_mesh("spot.obj"));
  auto r = c.Post("/copies", nlohmann::json{{"original", hash}, {"buyer", "first"}}.dump(),
                  "application/json");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200);
  const std::string taken = r->get_header_value("X-Meshmark-Id");
  const std::vector<IssuedCopy> before = read_registry(dir + "/shop.db");
  struct Case {
    std::string body;
    int status;
    std::string says;
  };
  const std::vector<Case> cases = {
      {"not json", 400, "not JSON"},
      {"[1, 2]", 400, "not a JSON object"},
      {R"({"buyer": "x"})", 400, "'original'"},
      {nlohmann::json{{"original", hash}}.dump(), 400, "'buyer'"},
      {nlohmann::json{{"original", hash}, {"buyer", ""}}.dump(), 400, "'buyer'"},
      {nlohmann::json{{"original", std::string(64, 'f')}, {"buyer", "x"}}.dump(), 404,
       "no such original"},
      {nlohmann::json{{"original", hash}, {"buyer", "x"}, {"format", "exe"}}.dump(), 400, "format"},
      {nlohmann::json{{"original", hash}, {"buyer", "x"}, {"id", -3}}.dump(), 400, "'id'"},
      {nlohmann::json{{"original", hash}, {"buyer", "x"}, {"id", "12abc"}}.dump(), 400, "12abc"},
      {nlohmann::json{{"original", hash}, {"buyer", "x"}, {"strength", 9}}.dump(), 400,
       "unknown field"},
      {nlohmann::json{{"original", hash}, {"buyer", "x"}, {"id", std::stoull(taken)}}.dump(), 409,
       "already issued"},
  };
  for (const Case& k : cases) {
    SCOPED_TRACE(k.body);
    r = c.Post("/copies", k.body, "application/json");
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, k.status) << r->body;
    const nlohmann::json j = nlohmann::json::parse(r->body);
    EXPECT_NE(j["error"].get<std::string>().find(k.says), std::string::npos) << r->body;
  }
  // Meshes that cannot be read: named by their upload's name, never the server's file.
  r = c.Post("/originals",
             httplib::MultipartFormDataItems{
                 {"mesh", "ply\nformat ascii 1.0\nelement vertex 2\n", "bad.ply", ""}});
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 400);
  EXPECT_NE(r->body.find("bad.ply:"), std::string::npos) << r->body;
  EXPECT_EQ(r->body.find("meshmark-serve"), std::string::npos) << r->body;
  r = c.Post("/originals", httplib::MultipartFormDataItems{{"mesh", "x", "noextension", ""}});
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 400);
  r = c.Post("/originals", httplib::MultipartFormDataItems{{"other", "x", "a.ply", ""}});
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 400);
  r = c.Post("/trace", httplib::MultipartFormDataItems{{"leak", "x", "a.ply", ""}});
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 400);
  r = c.Get("/copies/123456789");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 404);
  r = c.Get("/nowhere");  // the library's own answers are JSON too
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 404);
  EXPECT_NE(r->body.find("no such endpoint"), std::string::npos) << r->body;
  const std::vector<IssuedCopy> after = read_registry(dir + "/shop.db");
  ASSERT_EQ(after.size(), before.size());
  for (std::size_t i = 0; i < after.size(); ++i)
    EXPECT_EQ(after[i].output_hash, before[i].output_hash);
}

// Four clients issuing at once: no request lost, no ID twice, every body the file its row
// records. Then a kill -9 in the middle of another load: every copy a client received has its
// row, issued; no row is left reserved once the server is started again.
TEST(Serve, ConcurrentClientsLoseNothingAndAKillLeavesNoHalfRecordedCopy) {
  const std::string dir = fresh_dir("serve-load");
  std::vector<std::pair<std::uint64_t, std::string>> received;  // ID, body hash
  std::mutex m;
  std::string hash;
  // per_client copies from each of 4 clients; all of them answered, unless the server dies.
  const auto load = [&](Server& server, int per_client, bool all_answered) {
    std::vector<std::thread> clients;
    for (int k = 0; k < 4; ++k)
      clients.emplace_back([&, k] {
        httplib::Client c = server.client();
        for (int i = 0; i < per_client; ++i) {
          const auto r = c.Post(
              "/copies",
              nlohmann::json{{"original", hash}, {"buyer", fmt::format("c{}-{}", k, i)}}.dump(),
              "application/json");
          if (!r) break;  // the server is gone
          if (all_answered) EXPECT_EQ(r->status, 200) << r->body;
          if (r->status != 200) continue;
          const std::lock_guard<std::mutex> lock(m);
          received.emplace_back(std::stoull(r->get_header_value("X-Meshmark-Id")),
                                content_hash(r->body));
        }
      });
    for (std::thread& t : clients) t.join();
  };
  {
    Server server(dir);
    ASSERT_NE(server.port(), 0);
    httplib::Client c = server.client();
    hash = post_original(c, test::data_mesh("spot.obj"));
    load(server, 15, true);
  }
  ASSERT_EQ(received.size(), 60u);
  const auto check = [&] {
    std::map<std::uint64_t, IssuedCopy> rows;
    for (const IssuedCopy& r : read_registry(dir + "/shop.db")) {
      EXPECT_TRUE(rows.emplace(r.id, r).second) << "ID " << r.id << " twice";
      EXPECT_EQ(r.state, "issued") << "row " << r.row << " left " << r.state;
    }
    for (const auto& [id, body] : received) {
      EXPECT_TRUE(rows.count(id)) << "ID " << id << " was sent and has no row";
      if (rows.count(id)) EXPECT_EQ(rows[id].output_hash, body) << "ID " << id;
    }
    return rows.size();
  };
  EXPECT_EQ(check(), 60u);
  // kill -9 while four clients issue, until a kill leaves a row reserved (the server is inside
  // an issue most of the time); started again, the server gives such rows back.
  RegistryQuery reserved;
  reserved.state = "reserved";
  bool killed_mid_issue = false;
  for (int attempt = 0; attempt < 5 && !killed_mid_issue; ++attempt) {
    {
      Server server(dir);
      ASSERT_NE(server.port(), 0);
      httplib::Client c = server.client();
      hash = post_original(c, test::data_mesh("spot.obj"));
      std::thread killer([&] {
        std::this_thread::sleep_for(std::chrono::milliseconds(400 + 97 * attempt));
        server.stop(SIGKILL);
      });
      load(server, 1000, false);
      killer.join();
    }
    const std::size_t left = read_registry(dir + "/shop.db", reserved).size();
    killed_mid_issue = left > 0;
    Server server(dir);
    ASSERT_NE(server.port(), 0);
    const auto r = server.client(false).Get("/health");
    ASSERT_TRUE(r);
    if (killed_mid_issue)
      EXPECT_NE(bytes_of(dir + "/serve.log").find(fmt::format("gave back {} row(s)", left)),
                std::string::npos)
          << bytes_of(dir + "/serve.log");
    EXPECT_TRUE(read_registry(dir + "/shop.db", reserved).empty());
  }
  EXPECT_TRUE(killed_mid_issue) << "no kill landed inside an issue";
  EXPECT_GT(check(), 60u);
}

// Two servers on one PostgreSQL registry, two clients each, every copy with id:auto: both
// servers choose from the same spaced set, so they often choose the same next ID at once; the
// registry's transaction refuses the second, and its server takes the next. No request fails,
// no ID is given twice, every file is the one its row records.
TEST(Serve, TwoServersOnOnePostgresRegistryNeverShareAnId) {
  MESHMARK_REQUIRE_POSTGRES();
  const std::string pg = PostgresServer::get().fresh_database("serve");
  const std::string dir = fresh_dir("serve-pg");
  Server a(dir, pg, "a.log"), b(dir, pg, "b.log");
  ASSERT_NE(a.port(), 0) << bytes_of(dir + "/a.log");
  ASSERT_NE(b.port(), 0) << bytes_of(dir + "/b.log");
  std::vector<std::pair<std::uint64_t, std::string>> received;
  std::mutex m;
  std::vector<std::thread> clients;
  for (Server* server : {&a, &b}) {
    httplib::Client c = server->client();
    const std::string hash = post_original(c, test::data_mesh("spot.obj"));
    for (int k = 0; k < 2; ++k)
      clients.emplace_back([&, server, hash, k] {
        httplib::Client c = server->client();
        for (int i = 0; i < 10; ++i) {
          const auto r = c.Post(
              "/copies",
              nlohmann::json{{"original", hash}, {"buyer", fmt::format("{}-{}", k, i)}}.dump(),
              "application/json");
          ASSERT_TRUE(r);
          ASSERT_EQ(r->status, 200) << r->body;
          const std::lock_guard<std::mutex> lock(m);
          received.emplace_back(std::stoull(r->get_header_value("X-Meshmark-Id")),
                                content_hash(r->body));
        }
      });
  }
  for (std::thread& t : clients) t.join();
  ASSERT_EQ(received.size(), 40u);
  std::map<std::uint64_t, IssuedCopy> rows;
  for (const IssuedCopy& r : read_registry(pg)) {
    EXPECT_TRUE(rows.emplace(r.id, r).second) << "ID " << r.id << " twice";
    EXPECT_EQ(r.state, "issued");
  }
  EXPECT_EQ(rows.size(), 40u);
  for (const auto& [id, body] : received) {
    ASSERT_TRUE(rows.count(id)) << "ID " << id;
    EXPECT_EQ(rows[id].output_hash, body);
  }
}

}  // namespace
}  // namespace meshmark
