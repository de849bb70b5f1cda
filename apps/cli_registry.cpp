// meshmark registry list|show|export DB, and the registry records embed writes.

#include <fmt/format.h>

#include <cstdio>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>

#include "cli.h"
#include "meshmark/core/error.h"

namespace meshmark::cli {

namespace {

// A registry is input here: one that cannot be read is unreadable input (exit 2).
std::vector<IssuedCopy> read_registry_input(const std::string& where, const RegistryQuery& query) {
  try {
    return meshmark::read_registry(where, query);
  } catch (const IOError& e) {
    throw InputFailure(e.what());
  }
}

}  // namespace

nlohmann::json registry_row_json(const IssuedCopy& c) {
  return {{"row", c.row},
          {"original_hash", c.original_hash},
          {"original_geometry", c.original_geometry},
          {"original_path", c.original_path},
          {"buyer", c.buyer},
          {"id", c.id},
          {"id_bits", c.id_bits},
          {"bits", c.bits},
          {"variant", c.variant},
          {"strength", c.strength},
          {"strength_spread", c.strength_spread},
          {"bin_offset", c.bin_offset},
          {"key_fingerprint", c.key_fingerprint},
          {"mark_format", c.mark_format},
          {"issued_at", c.issued_at},
          {"output_path", c.output_path},
          {"output_hash", c.output_hash},
          {"method", c.method},
          {"mac", c.mac},
          {"key_derivation", c.key_derivation},
          {"state", c.state},
          {"spaced_index", c.spaced_index}};
}

namespace {

// A CSV field: quoted when it holds a comma, a quote or a line break.
std::string csv(const std::string& raw) {
  std::string s = printable(raw);
  if (s.find_first_of(",\"\n\r") == std::string::npos) return s;
  std::string out = "\"";
  for (const char c : s) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

struct RegistryArgs {
  std::string db, original, buyer, id, format = "table";
  bool json = false;  // --json: --format json
};

RegistryQuery query_of(const RegistryArgs& a) {
  RegistryQuery q;
  if (!a.buyer.empty()) q.buyer = a.buyer;
  if (!a.id.empty()) q.id = parse_id(a.id);
  if (!a.original.empty()) q.original_hash = content_hash(read_file(a.original));
  return q;
}

int run_list(const RegistryArgs& a) {
  const std::vector<IssuedCopy> copies = read_registry_input(a.db, query_of(a));
  if (a.format == "json" || a.format == "jsonl") {
    nlohmann::json all = nlohmann::json::array();
    for (const IssuedCopy& c : copies) {
      if (a.format == "jsonl")
        fmt::print("{}\n", registry_row_json(c).dump());
      else
        all.push_back(registry_row_json(c));
    }
    if (a.format == "json") fmt::print("{}\n", all.dump(2));
  } else if (a.format == "csv") {
    fmt::print(
        "row,original_hash,original_path,buyer,id,id_bits,bits,variant,strength,"
        "strength_spread,bin_offset,key_fingerprint,mark_format,issued_at,output_path,"
        "output_hash,method,original_geometry,mac,key_derivation,state,spaced_index\n");
    for (const IssuedCopy& c : copies)
      fmt::print("{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n", c.row,
                 c.original_hash, csv(c.original_path), csv(c.buyer), c.id, c.id_bits, c.bits,
                 c.variant, c.strength, c.strength_spread, c.bin_offset, c.key_fingerprint,
                 c.mark_format, c.issued_at, csv(c.output_path), c.output_hash, c.method,
                 c.original_geometry, c.mac, csv(c.key_derivation), c.state, c.spaced_index);
  } else {
    // The columns say what they hold: the variant (Cho's methods: method/variant), the key
    // fingerprint's first 8 hex digits, the copy's path.
    fmt::print("{:>6}  {:>10}  {:<20}  {:<20}  {:<14}  {:<8}  {}\n", "row", "id", "buyer",
               "issued (UTC)", "variant", "key fpr.", "copy's path");
    for (const IssuedCopy& c : copies)
      fmt::print(
          "{:>6}  {:>10}  {:<20}  {:<20}  {:<14}  {:<8}  {}\n", c.row, c.id, printable(c.buyer),
          c.issued_at,
          c.method == method_name(Method::Qp) ? c.variant : c.method + "/" + c.variant.substr(0, 1),
          c.key_fingerprint.substr(0, 8), printable(c.output_path));
    fmt::print("{} cop{}\n", copies.size(), copies.size() == 1 ? "y" : "ies");
  }
  // What was read is printed; a damaged file says so and does not exit 0.
  std::string integrity;
  try {
    integrity = Registry(a.db, true).integrity_check();
  } catch (const IOError& e) {
    integrity = e.what();
  }
  if (integrity != "ok") {
    fmt::print(stderr,
               "meshmark: error: {}: the registry file is DAMAGED (SQLite integrity check: {}); "
               "the rows above are what could be read: restore it from a backup "
               "(meshmark registry verify checks it)\n",
               printable(registry_display_name(a.db)), printable(integrity));
    return kNotVerified;
  }
  return kOk;
}

struct VerifyArgs {
  std::string db;
  KeyArgs keys;
  bool json = false;
};

int run_verify(const VerifyArgs& a) {
  const std::optional<Key> key = resolve_key_in(a.keys, a.db);
  RegistryCheck check;
  try {
    check = verify_registry(a.db, id_key(key));
  } catch (const IOError& e) {
    throw InputFailure(e.what());
  }
  const auto row_json = [](const IssuedCopy& c) {
    return nlohmann::json{{"row", c.row}, {"id", c.id}, {"buyer", c.buyer}};
  };
  if (a.json) {
    nlohmann::json edited = nlohmann::json::array(), bare = nlohmann::json::array();
    for (const IssuedCopy& c : check.edited) edited.push_back(row_json(c));
    for (const IssuedCopy& c : check.unauthenticated) bare.push_back(row_json(c));
    nlohmann::json reserved = nlohmann::json::array();
    for (const IssuedCopy& c : check.reserved) reserved.push_back(row_json(c));
    fmt::print("{}\n", nlohmann::json{{"registry", registry_display_name(a.db)},
                                      {"ok", check.ok()},
                                      {"integrity", check.integrity},
                                      {"rows", check.rows},
                                      {"authentic", check.authentic},
                                      {"edited", edited},
                                      {"unauthenticated", bare},
                                      {"other_key", check.other_key},
                                      {"reserved", reserved}}
                           .dump(2));
  } else {
    fmt::print("{}: {}\n", printable(registry_display_name(a.db)),
               check.ok() ? "verified" : "NOT verified");
    fmt::print("  file             {}\n", check.integrity == "ok"
                                              ? std::string("sound (SQLite integrity check)")
                                              : "DAMAGED: " + printable(check.integrity));
    fmt::print("  rows             {} ({} under this key, {} under other keys)\n", check.rows,
               check.rows - check.other_key, check.other_key);
    fmt::print("  authentic        {}\n", check.authentic);
    if (check.rows > 0 && check.other_key == check.rows)
      fmt::print(
          "  no row is under this key: nothing was checked (give the key the copies were "
          "issued under)\n");
    for (const IssuedCopy& c : check.edited)
      fmt::print("  EDITED           row {}: ID {}, '{}': fails its authentication code\n", c.row,
                 c.id, printable(c.buyer));
    for (const IssuedCopy& c : check.unauthenticated)
      fmt::print("  unauthenticated  row {}: ID {}, '{}': carries no authentication code\n", c.row,
                 c.id, printable(c.buyer));
    for (const IssuedCopy& c : check.reserved)
      fmt::print("  reserved         row {}: ID {}, '{}': its issue did not complete (rerun it)\n",
                 c.row, c.id, printable(c.buyer));
  }
  return check.ok() ? kOk : kNotVerified;
}

}  // namespace

void register_registry(CLI::App& app, int& exit_code) {
  CLI::App* sub = app.add_subcommand("registry", "The registry of issued copies (SQLite)");
  sub->require_subcommand(1);
  auto add = [&](const char* name, const char* help, const char* default_format) {
    auto args = std::make_shared<RegistryArgs>();
    args->format = default_format;
    CLI::App* cmd = sub->add_subcommand(name, help);
    cmd->add_option("DB", args->db, "the registry file")->required();
    cmd->add_option("--buyer", args->buyer, "only copies issued to this buyer");
    cmd->add_option("--id", args->id, "only copies carrying this ID");
    cmd->add_option("--original", args->original, "only copies of this original (its file)");
    CLI::Option* format = cmd->add_option("--format", args->format, "table, csv, json or jsonl")
                              ->check(CLI::IsMember({"table", "csv", "json", "jsonl"}));
    cmd->add_flag("--json", args->json, "the same as --format json")->excludes(format);
    cmd->callback([args, &exit_code] {
      if (args->json) args->format = "json";
      exit_code = run_list(*args);
    });
  };
  add("list", "List the issued copies", "table");
  add("show", "Every field of the matching copies (give --id or --buyer)", "json");
  add("export", "The matching copies as CSV (or --format jsonl)", "csv");
  auto verify = std::make_shared<VerifyArgs>();
  CLI::App* cmd = sub->add_subcommand(
      "verify",
      "Check the file and every row's authentication code under the key (exit 7 when "
      "a row was edited or carries none)");
  cmd->add_option("DB", verify->db, "the registry file or postgresql:// URI")->required();
  add_key_options(*cmd, verify->keys);
  cmd->add_flag("--json", verify->json, "print a JSON report");
  cmd->callback([verify, &exit_code] { exit_code = run_verify(*verify); });
}

}  // namespace meshmark::cli
