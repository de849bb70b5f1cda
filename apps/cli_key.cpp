// --key, --key-file, --id and --id-bits: how the commands turn an ID or a payload into the bits
// written in the bins, and back.

#include <fmt/format.h>

#include <cstdlib>
#include <memory>
#include <nlohmann/json.hpp>

#include "cli.h"
#include "meshmark/core/error.h"
#include "meshmark/forensics/registry.h"

namespace meshmark::cli {

void add_key_options(CLI::App& app, KeyArgs& args) {
  app.add_option("--key", args.passphrase,
                 "secret passphrase (visible to other users of this machine in the process "
                 "list: prefer --key-file, or the environment variable MESHMARK_KEY, read when "
                 "neither option is given)");
  app.add_option("--key-file", args.file, "secret key file (its bytes, hashed)")->excludes("--key");
  app.add_flag("--legacy-passphrase", args.legacy_passphrase,
               "derive the passphrase's key as meshmark did for the copies issued before "
               "registry schema 4 (one BLAKE2b, fast to guess): to read those copies only");
  app.add_option("--id-bits", args.id_bits, "length of a coded ID in bits (1..32)")
      ->check(CLI::Range(1, 32));
}

namespace {

// The passphrase of --key or, when neither --key nor --key-file is given, MESHMARK_KEY.
std::optional<std::string> passphrase_of(const KeyArgs& args) {
  if (args.passphrase) {
    fmt::print(stderr,
               "meshmark: warning: a passphrase given with --key is visible to every user of "
               "this machine (the process list, the shell's history): set MESHMARK_KEY "
               "instead, or use --key-file\n");
    return args.passphrase;
  }
  if (args.file) return std::nullopt;
  // The documented way to give a passphrase: the environment, never the command line.
  if (const char* env = std::getenv("MESHMARK_KEY"); env && *env) return std::string(env);
  return std::nullopt;
}

}  // namespace

std::optional<Key> resolve_key(const KeyArgs& args) {
  if (args.legacy_passphrase && !args.passphrase && (args.file || !std::getenv("MESHMARK_KEY")))
    throw InvalidArgumentError(
        "--legacy-passphrase derives a passphrase's key: give --key or "
        "MESHMARK_KEY, not a key file");
  if (const std::optional<std::string> passphrase = passphrase_of(args))
    return args.legacy_passphrase ? key_from_passphrase_v1(*passphrase)
                                  : key_from_passphrase(*passphrase);  // refuse an empty one
  if (args.file) {
    const Key key = key_from_file(*args.file);  // ReadError: exit 2
    if (const std::string w = key_file_exposure(*args.file); !w.empty())
      fmt::print(stderr, "meshmark: warning: {}\n", printable(w));
    return key;
  }
  return std::nullopt;
}

std::optional<Key> resolve_key_in(const KeyArgs& args, const std::string& registry) {
  if (args.legacy_passphrase || args.file) return resolve_key(args);
  const std::optional<std::string> passphrase = passphrase_of(args);
  if (!passphrase) return std::nullopt;
  PassphraseKey found;
  try {
    found = passphrase_key_in(registry, *passphrase);
  } catch (const IOError& e) {
    throw InputFailure(e.what());
  }
  if (!found.note.empty()) fmt::print(stderr, "meshmark: note: {}\n", printable(found.note));
  return found.key;
}

void register_keygen(CLI::App& app, int& exit_code) {
  auto path = std::make_shared<std::string>();
  auto json = std::make_shared<bool>(false);
  CLI::App* sub = app.add_subcommand(
      "keygen", "Make a new secret key file: 32 random bytes, readable by its owner only");
  sub->add_option("FILE", *path, "the key file to create (never overwritten)")->required();
  sub->add_flag("--json", *json, "print a JSON report");
  sub->callback([path, json, &exit_code] {
    const Key key = generate_key_file(*path);
    if (*json)
      fmt::print(
          "{}\n",
          nlohmann::json{{"key_file", *path}, {"key_fingerprint", key_fingerprint(key)}}.dump(2));
    else
      fmt::print(
          "key file {} (mode 0600, fingerprint {}): keep it secret and backed up; without "
          "it no copy issued under it can be traced\n",
          printable(*path), key_fingerprint(key));
    exit_code = kOk;
  });
}

IdCode id_code(const KeyArgs& args, int nb) {
  IdCodeOptions o;
  o.bits = nb;
  o.id_bits = args.id_bits;
  return IdCode(o);
}

}  // namespace meshmark::cli
