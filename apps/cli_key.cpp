// --key, --key-file, --id and --id-bits: how the commands turn an ID or a payload into the bits
// written in the bins, and back.

#include <fmt/format.h>

#include "cli.h"
#include "meshmark/error.h"

namespace meshmark::cli {

void add_key_options(CLI::App& app, KeyArgs& args) {
  app.add_option("--key", args.passphrase,
                 "secret passphrase: keyed layout of the bits (visible to other users of this "
                 "machine in the process list; prefer --key-file)");
  app.add_option("--key-file", args.file, "secret key file (its bytes, hashed)")->excludes("--key");
  app.add_option("--id-bits", args.id_bits, "length of a coded ID in bits (1..32)")
      ->check(CLI::Range(1, 32));
}

std::optional<Key> resolve_key(const KeyArgs& args) {
  if (args.passphrase) return key_from_passphrase(*args.passphrase);  // refuses an empty one
  if (args.file) return key_from_file(*args.file);                    // ReadError: exit 2
  return std::nullopt;
}

IdCode id_code(const KeyArgs& args, int nb) {
  IdCodeOptions o;
  o.bits = nb;
  o.id_bits = args.id_bits;
  return IdCode(o);
}

}  // namespace meshmark::cli
