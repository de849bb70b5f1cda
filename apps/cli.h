#pragma once
// The meshmark command line: shared pieces of the subcommands (thin wrappers over the library).

#include <CLI/CLI.hpp>
#include <initializer_list>
#include <nlohmann/json_fwd.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include <optional>
#include <type_traits>

#include "meshmark/carrier/carrier_check.h"
#include "meshmark/forensics/issue.h"
#include "meshmark/forensics/registry.h"
#include "meshmark/forensics/trace.h"
#include "meshmark/io/io.h"
#include "meshmark/mark/calibrate.h"
#include "meshmark/mark/embed.h"
#include "meshmark/protocol/coding.h"
#include "meshmark/protocol/key.h"
#include "meshmark/protocol/watermark.h"

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
  kNotVerified = 7,  ///< registry verify: a row was edited or has no MAC, or the file is unsound
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

/// Adds an option bound to an enum (E, or std::optional<E> for "not given"): it accepts the
/// names of the library's table (enum_names.h; any case) and refuses any other value with the
/// library's message, which lists the names.
template <class E, class Target>
CLI::Option* add_enum_option(CLI::App& app, const std::string& flag, Target& value,
                             const std::string& help) {
  const auto names = enum_names<E>();
  std::string type = "{";
  for (std::size_t i = 0; i < names.size(); ++i) type += (i ? "|" : "") + std::string(names[i]);
  type += "}";
  CLI::Option* option = app.add_option_function<std::string>(
      flag, [&value](const std::string& name) { value = parse_enum<E>(name); }, help);
  option->check(CLI::Validator(
      [](std::string& name) -> std::string {
        try {
          (void)parse_enum<E>(name);
          return {};
        } catch (const std::exception& e) {
          return e.what();
        }
      },
      ""));
  option->type_name(type);
  if constexpr (std::is_same_v<Target, E>) option->default_str(enum_name(value));
  return option;
}

/// Adds --method to a subcommand: the embedding method (method.h's names).
/// purpose: what the method is for in this command ("the embedding's method").
void add_method_option(CLI::App& app, Method& method, const std::string& purpose);

/// Adds --weld-tolerance to a subcommand.
void add_input_options(CLI::App& app, InputOptions& options);

/// Refuses a number that is not finite: CLI11's ranges and PositiveNumber let "nan" through.
const CLI::Validator& finite_number();

/// Output format options: --format, --encoding, --float32.
struct OutputOptions {
  std::optional<FileFormat> format;  // none: from the extension
  std::optional<Encoding> encoding;  // none: keep
  bool float32 = false;
  bool float_positions = false;
};
void add_output_options(CLI::App& app, OutputOptions& options);

/// The library's write options for the output options.
WriteOptions write_options(const OutputOptions& options);

/// The library's read options for the input options.
ReadOptions read_options(const InputOptions& options);

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

/// Largest --bits any command takes (a payload needs at least one vertex per bin).
inline constexpr int kMaxBits = 4096;

/// --key, --key-file, --id-bits.
struct KeyArgs {
  std::optional<std::string> passphrase, file;  // given (even empty) or not
  bool legacy_passphrase = false;               // the passphrase's key before schema 4
  int id_bits = 32;
};
void add_key_options(CLI::App& app, KeyArgs& args);

/// The key of --key, --key-file or MESHMARK_KEY, or none (a key file that cannot be read is
/// bad input).
std::optional<Key> resolve_key(const KeyArgs& args);
/// As resolve_key, but a passphrase stands for the key its copies in the registry were issued
/// under (passphrase_key_in: the earlier derivation for copies issued before schema 4), with
/// a note on stderr when that matters.
std::optional<Key> resolve_key_in(const KeyArgs& args, const std::string& registry);

/// The ID code for nb payload bits and --id-bits.
IdCode id_code(const KeyArgs& args, int nb);

/// What trace --json prints of a trace (docs/tracing.md); also serve's answer to POST /trace.
nlohmann::json trace_json(const TraceResult& result, const TraceOptions& options,
                          const std::vector<std::string>& warnings);
/// One registry row as registry list --format json prints it; also serve's GET /copies/ID.
nlohmann::json registry_row_json(const IssuedCopy& copy);
void register_serve(CLI::App& app, int& exit_code);  ///< meshmark serve (cli_serve.cpp)
void register_embed(CLI::App& app, int& exit_code);
void register_keygen(CLI::App& app, int& exit_code);    ///< meshmark keygen FILE
void register_generate(CLI::App& app, int& exit_code);  ///< the man page, the bash completion
void register_registry(CLI::App& app, int& exit_code);
/// trace; argv: the command line as run (its --report writes it, quoted, in the report).
void register_trace(CLI::App& app, int& exit_code, std::vector<std::string> argv);

/// embed --batch: issues every line of the manifest (issue.h: INPUT OUTPUT PAYLOAD, or INPUT
/// OUTPUT id:N BUYER) with settings; prints one line per copy, or with json one object (the
/// copies, their status and ID, the counts); kOk when every copy was issued.
int run_batch(const std::string& manifest, IssueSettings settings, bool json);
void register_extract(CLI::App& app, int& exit_code);
void register_attack(CLI::App& app, int& exit_code);
void register_collude(CLI::App& app, int& exit_code);  ///< meshmark collude (cli_collude.cpp)
void register_roughness(CLI::App& app, int& exit_code);
void register_compare(CLI::App& app, int& exit_code);
void register_detect(CLI::App& app, int& exit_code);
void register_calibrate(CLI::App& app, int& exit_code);
void register_bench(CLI::App& app, int& exit_code);

}  // namespace meshmark::cli
