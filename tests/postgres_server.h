#pragma once
// A PostgreSQL server for the tests that need one (the registry's, serve's).

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <string>

namespace meshmark {

// A PostgreSQL server of this test process's own: initdb and pg_ctl from Debian's postgresql
// package, listening only on a Unix socket in a scratch folder (no TCP), run as the postgres
// user when the tests run as root; stopped when the process ends. `why` says why not when it
// cannot start.
struct PostgresServer {
  std::string uri, why, dir, bin, as;
  bool ok = false;

  static PostgresServer& get() {
    static PostgresServer server;
    return server;
  }
  PostgresServer() {
    for (const auto& entry : std::filesystem::directory_iterator("/usr/lib/postgresql", ec_))
      if (std::filesystem::exists(entry.path() / "bin/initdb"))
        bin = (entry.path() / "bin").string();
    if (bin.empty()) {
      why = "no PostgreSQL server installed (Debian package postgresql)";
      return;
    }
    dir = "/tmp/meshmark-pg-" + std::to_string(::getpid());
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir + "/sock");
    if (::geteuid() == 0) {
      as = "runuser -u postgres -- ";
      if (std::system(("chown -R postgres " + dir).c_str()) != 0) {
        why = "cannot give the scratch folder to the postgres user";
        return;
      }
    }
    const std::string init =
        as + bin + "/initdb -D " + dir + "/data -A trust -U postgres > " + dir + "/initdb.log 2>&1";
    const std::string start = as + bin + "/pg_ctl -D " + dir + "/data -o \"-k " + dir +
                              "/sock -c listen_addresses=''\" -w -t 60 -l " + dir +
                              "/server.log start > /dev/null 2>&1";
    if (std::system(init.c_str()) != 0 || std::system(start.c_str()) != 0) {
      why = "the server did not start (see " + dir + ")";
      return;
    }
    uri = "postgresql:///postgres?host=" + dir + "/sock&user=postgres";
    ok = true;
  }
  ~PostgresServer() {
    if (ok)
      std::system(
          (as + bin + "/pg_ctl -D " + dir + "/data -m immediate stop > /dev/null 2>&1").c_str());
    if (!dir.empty()) std::filesystem::remove_all(dir, ec_);
  }
  // A fresh database on the server for one test.
  std::string fresh_database(const std::string& name) {
    std::system((as + bin + "/psql -q -h " + dir +
                 "/sock -U postgres -d postgres -c 'DROP "
                 "DATABASE IF EXISTS " +
                 name + "' -c 'CREATE DATABASE " + name + "' > /dev/null 2>&1")
                    .c_str());
    return "postgresql:///" + name + "?host=" + dir + "/sock&user=postgres";
  }

 private:
  std::error_code ec_;
};

#define MESHMARK_REQUIRE_POSTGRES() \
  if (!PostgresServer::get().ok)    \
  GTEST_SKIP() << "skipped: no PostgreSQL server for the test: " << PostgresServer::get().why

}  // namespace meshmark
