#pragma once
// The meshmark command line: shared pieces of the subcommands (thin wrappers over the library).

#include <CLI/CLI.hpp>
#include <initializer_list>
#include <stdexcept>
#include <string>
#include <vector>

#include <optional>

#include "meshmark/calibrate.h"
#include "meshmark/carrier_check.h"
#include "meshmark/coding.h"
#include "meshmark/embed.h"
#include "meshmark/io.h"
#include "meshmark/key.h"
#include "meshmark/registry.h"
#include "meshmark/watermark.h"

namespace meshmark::cli {

/// Exit codes, documented in the README.
enum Exit : int {
  kOk = 0,
  kUsage = 1,        ///< bad command line or option value
  kBadInput = 2,     ///< the input mesh cannot be read or is malformed
  kWriteFailed = 3,  ///< the output cannot be written
  kNotEmbedded = 4,  ///< embedding infeasible, not converged, or the mesh has no histogram
  kBitErrors = 5,    ///< extract --expect found bit errors or erasures
  kNoId = 6,         ///< extract --id-bits found no valid ID; detect did not detect
  kInternal = 70,    ///< a bug
};

/// An input file that cannot be read (exit code kBadInput, unlike a failed write).
struct InputFailure : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// Options every command that reads a mesh shares.
struct InputOptions {
  double weld_tolerance = 0;
};

/// Adds --method to a subcommand: the embedding method (method.h), parsed by parse_method.
/// purpose: what the method is for in this command ("the embedding's method").
void add_method_option(CLI::App& app, std::string& method, const std::string& purpose);

/// Adds --weld-tolerance to a subcommand.
void add_input_options(CLI::App& app, InputOptions& options);

/// Output format options: --format, --encoding, --float32.
struct OutputOptions {
  std::string format;    // "" = from the extension
  std::string encoding;  // "" = keep
  bool float32 = false;
  bool float_positions = false;
};
void add_output_options(CLI::App& app, OutputOptions& options);

/// Reads a mesh with the options (throws the library's errors).
Mesh read_input(const std::string& path, const InputOptions& options);

/// Prints a carrier check's findings (library's check_carrier) for the mesh read from path on
/// stderr, one "warning" line each when the carrier is weak.
/// \throw InputFailure (exit kBadInput) naming the file and what is wrong when it is unusable.
void report_carrier(const std::string& path, const CarrierCheck& check);

/// Throws InvalidArgumentError when output names the same file as any of the inputs.
void refuse_overwrite(const std::string& output, std::initializer_list<std::string> inputs);

/// Throws InvalidArgumentError unless path ends in .ply (colored maps are PLY).
void require_ply(const std::string& path);

/// Writes mesh to path as binary PLY with values (one per vertex, in [0, 1]) as heat colors,
/// blue 0 to red 1; refuses a non-PLY path or one of the inputs.
void write_heat_map(const std::string& path, std::initializer_list<std::string> inputs,
                    const Mesh& mesh, const Eigen::VectorXd& values);

/// Writes a mesh; refuses to write over the input file.
void write_output(const std::string& path, const std::string& input_path, const Mesh& mesh,
                  const OutputOptions& options);

/// Writes a watermarked mesh only if the bytes carry bins (every bit right, margins at least
/// half the strength, read with the embedding's center and method): write_marked_mesh;
/// refuses to write over the input file.
WrittenCheck write_marked_output(const std::string& path, const std::string& input_path,
                                 const Mesh& mesh, const OutputOptions& options,
                                 const InputOptions& input, const Payload& bins,
                                 const EmbedOptions& embedding);

/// Largest --bits any command takes (a payload needs at least one vertex per bin).
inline constexpr int kMaxBits = 4096;

/// --key, --key-file, --id-bits.
struct KeyArgs {
  std::optional<std::string> passphrase, file;  // given (even empty) or not
  int id_bits = 32;
};
void add_key_options(CLI::App& app, KeyArgs& args);

/// The key of --key or --key-file, or none (a key file that cannot be read is bad input).
std::optional<Key> resolve_key(const KeyArgs& args);

/// Parses an ID: decimal, or hexadecimal with 0x. \throw InvalidArgumentError otherwise.
std::uint64_t parse_id(const std::string& text);

/// The ID code for nb payload bits and --id-bits.
IdCode id_code(const KeyArgs& args, int nb);

/// The registry record of a copy about to be issued from input (its content hash read from
/// the file), with the settings of options; output fields are filled by record_copies.
IssuedCopy issued_copy(const std::string& input, const std::string& buyer, std::uint64_t id,
                       int id_bits, int bits, const std::string& variant,
                       const EmbedOptions& options, double strength_spread, const Key& key);

/// The copies of an existing registry (a file or a postgresql:// URI) that match query. A
/// registry is input here: one that does not exist is never created, and one that cannot be
/// read is unreadable input (InputFailure: exit 2).
std::vector<IssuedCopy> read_registry(const std::string& where, const RegistryQuery& query);

/// An output path as the registry records it (absolute, normalized).
std::string recorded_path(const std::string& output);

/// Records copies written to outputs (their content hashes read back) in one transaction.
/// When that fails, the outputs are removed (no issued copy goes unrecorded) and the error
/// is thrown again.
void record_copies(Registry& registry, std::vector<IssuedCopy> copies,
                   const std::vector<std::string>& outputs);

void register_embed(CLI::App& app, int& exit_code);
void register_registry(CLI::App& app, int& exit_code);
/// trace; argv: the command line as run (its --report writes it, quoted, in the report).
void register_trace(CLI::App& app, int& exit_code, std::vector<std::string> argv);

/// What embed --batch applies to every line.
struct BatchSettings {
  int bits = 64;
  EmbedOptions options;
  InputOptions in;
  OutputOptions out;
  std::optional<Key> key;      ///< keyed layout (raw payloads), and the key of coded IDs
  IdCodeOptions code;          ///< the ID code of id:N lines
  int id_bits = 32;            ///< recorded with each coded copy
  double strength_spread = 0;  ///< keyed per-bit strengths
  std::string registry;        ///< record coded copies there (one transaction), or ""
  /// Fidelity limits: each copy gets the strongest mark within them (calibrate.h), or none:
  /// every copy at options.strength.
  std::optional<CalibrateOptions> limits;
};

/// embed --batch: runs every line of the manifest (INPUT OUTPUT PAYLOAD, or INPUT OUTPUT id:N
/// BUYER) on all cores, each distinct input read once; prints one line per job; kOk when
/// every job succeeded.
int run_batch(const std::string& manifest, const BatchSettings& settings);
void register_extract(CLI::App& app, int& exit_code);
void register_attack(CLI::App& app, int& exit_code);
void register_roughness(CLI::App& app, int& exit_code);
void register_compare(CLI::App& app, int& exit_code);
void register_detect(CLI::App& app, int& exit_code);
void register_calibrate(CLI::App& app, int& exit_code);
void register_bench(CLI::App& app, int& exit_code);

}  // namespace meshmark::cli
