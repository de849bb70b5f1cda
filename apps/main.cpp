// meshmark: blind watermarking of triangle meshes. Parses, calls the library, prints, and maps
// every failure to one line on stderr and a documented exit code (see cli.h and the README).

#include <fmt/format.h>
#include <malloc.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string_view>

#include "cli.h"
#include "meshmark/core/error.h"
#include "meshmark/plot/color.h"
#include "meshmark/version.h"

namespace meshmark::cli {

void add_method_option(CLI::App& app, Method& method, const std::string& purpose) {
  add_enum_option<Method>(app, "--method", method,
                          purpose +
                              ": qp (the QP framework), cho-mean or cho-variance (Cho et al. "
                              "2007's Method I or II, baselines: docs/cho.md)");
}

const CLI::Validator& finite_number() {
  static const CLI::Validator v(
      [](const std::string& text) -> std::string {
        double d = 0;
        if (CLI::detail::lexical_cast(text, d) && !std::isfinite(d))
          return fmt::format("{} is not a finite number", text);
        return {};
      },
      "FINITE");
  return v;
}

void add_input_options(CLI::App& app, InputOptions& options) {
  const CLI::Validator distance(
      [](const std::string& text) -> std::string {
        double d = 0;
        if (!CLI::detail::lexical_cast(text, d) || !std::isfinite(d) || d < 0)
          return fmt::format("{} is not a finite distance >= 0", text);
        return {};
      },
      "DISTANCE >= 0");
  app.add_option("--weld-tolerance", options.weld_tolerance,
                 "weld referenced vertices closer than this distance (model units) for the "
                 "computations, in every format (STL, glTF, Draco and 3MF always weld identical "
                 "positions); writing "
                 "back keeps the file's own vertices")
      ->check(distance);
}

void add_output_options(CLI::App& app, OutputOptions& options) {
  add_enum_option<FileFormat>(app, "--format", options.format,
                              "output format (default: from OUT's extension)");
  add_enum_option<Encoding>(app, "--encoding", options.encoding,
                            "PLY/STL output encoding (default: keep the input's)");
  app.add_flag("--float32", options.float32, "PLY written from scratch: store float32 coordinates");
  app.add_flag("--float-positions", options.float_positions,
               "glTF written back: store quantized positions as float32 (a new buffer view; "
               "KHR_mesh_quantization dropped when no other attribute needs it)");
}

Mesh read_input(const std::string& path, const InputOptions& options) {
  Mesh mesh = read_mesh(path, read_options(options));  // ReadError: exit kBadInput (main)
  for (const std::string& note : mesh.notes)
    fmt::print(stderr, "warning: {}: {}\n", printable(path), printable(note));
  return mesh;
}

void report_carrier(const std::string& path, const CarrierCheck& check) {
  if (check.status == CarrierHealth::Unusable)
    throw InputFailure(fmt::format("{}: {}", path, check.summary()));
  for (const std::string& d : check.diagnostics)
    fmt::print(stderr, "meshmark: warning: {}: {}\n", printable(path), printable(d));
}

void refuse_overwrite(const std::string& output, std::initializer_list<std::string> inputs) {
  for (const std::string& input : inputs) {
    std::error_code ec;
    if (std::filesystem::equivalent(output, input, ec))
      throw InvalidArgumentError(fmt::format("{}: refusing to overwrite an input file", output));
  }
}

void require_ply(const std::string& path) {
  if (format_from_path(path) != FileFormat::Ply)
    throw InvalidArgumentError(fmt::format("{}: colored maps are written as PLY (.ply)", path));
}

void write_heat_map(const std::string& path, std::initializer_list<std::string> inputs,
                    const Mesh& mesh, const Eigen::VectorXd& values) {
  require_ply(path);
  refuse_overwrite(path, inputs);
  const Eigen::Matrix<std::uint8_t, Eigen::Dynamic, 3> colors = heat_colors(values);
  WriteOptions wo;
  wo.vertex_colors = &colors;
  wo.encoding = Encoding::BinaryLittleEndian;
  write_mesh(path, mesh, wo);
}

WriteOptions write_options(const OutputOptions& options) {
  WriteOptions wo;
  wo.format = options.format;
  wo.encoding = options.encoding;
  wo.single_precision = options.float32;
  wo.float_positions = options.float_positions;
  return wo;
}

ReadOptions read_options(const InputOptions& options) {
  ReadOptions ro;
  ro.weld_tolerance = options.weld_tolerance;
  return ro;
}

void write_output(const std::string& path, const std::string& input_path, const Mesh& mesh,
                  const OutputOptions& options) {
  refuse_overwrite(path, {input_path});
  write_mesh(path, mesh, write_options(options));
}

}  // namespace meshmark::cli

namespace {

// The documented exit code of a failure (cli.h): a file that cannot be read or is malformed is
// bad input, one that cannot be written (or a database that fails) a failed write.
int exit_code_of(const std::exception& e) {
  using namespace meshmark;
  if (dynamic_cast<const cli::InputFailure*>(&e) || dynamic_cast<const InvalidInputError*>(&e) ||
      dynamic_cast<const ReadError*>(&e))
    return cli::kBadInput;
  if (dynamic_cast<const IOError*>(&e)) return cli::kWriteFailed;
  if (dynamic_cast<const InvalidArgumentError*>(&e)) return cli::kUsage;
  return cli::kInternal;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace meshmark;
  // Large temporaries (a vector per vertex) come and go in the solvers' loops: keep them on
  // the heap instead of mapping and unmapping pages each time.
  mallopt(M_MMAP_THRESHOLD, 1 << 30);
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
  CLI::App app{
      "meshmark: blind, robust watermarking of triangle meshes (Rolland-Neviere et al., TIFS "
      "2014)"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "meshmark " MESHMARK_VERSION_STRING);
  int exit_code = cli::kOk;
  cli::register_keygen(app, exit_code);
  cli::register_embed(app, exit_code);
  cli::register_extract(app, exit_code);
  cli::register_attack(app, exit_code);
  cli::register_collude(app, exit_code);
  cli::register_roughness(app, exit_code);
  cli::register_compare(app, exit_code);
  cli::register_detect(app, exit_code);
  cli::register_calibrate(app, exit_code);
  cli::register_bench(app, exit_code);
  cli::register_registry(app, exit_code);
  cli::register_trace(app, exit_code, std::vector<std::string>(argv, argv + argc));
  cli::register_generate(app, exit_code);
#ifdef MESHMARK_HAVE_SERVE
  cli::register_serve(app, exit_code);
#endif
  // Every message printed goes through printable() (idempotent: meshmark's errors are escaped
  // already, the others, parse errors included, may quote input).
  app.failure_message([](const CLI::App* a, const CLI::Error& e) {
    return printable(e.what()) + "\n" +
           (a->get_help_ptr() ? "Run with --help for more information.\n" : "");
  });
  const std::string exit_codes =
      "Exit codes: 0 done; 1 bad command line or option value; 2 an input cannot be read or is "
      "malformed; 3 an output cannot be written; 4 not embedded (infeasible, not within the "
      "limits, no histogram); 5 extract --expect found bit errors; 6 no valid ID, not detected, "
      "no buyer named; 7 registry verify found an edited or unauthenticated row, a damaged file "
      "or no row under the key; 70 a bug. With --json, an error is printed on stdout as "
      "{\"error\": "
      "{\"exit_code\": N, \"message\": ...}}.";
  app.footer(exit_codes);
  for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; }))
    sub->footer(sub->get_footer().empty() ? exit_codes : sub->get_footer() + "\n\n" + exit_codes);
  // --json anywhere: errors go to stdout as JSON too, for the scripts that asked for it.
  const bool json = std::any_of(argv + 1, argv + argc,
                                [](const char* w) { return std::string_view(w) == "--json"; });
  auto fail = [json](int rc, const std::string& message) {
    if (json)
      fmt::print("{}\n",
                 nlohmann::json{{"error", {{"exit_code", rc}, {"message", message}}}}.dump(2));
    else
      fmt::print(stderr, "meshmark: {}: {}\n", rc == cli::kInternal ? "internal error" : "error",
                 printable(message));
    return rc;
  };
  // An unknown command: name the known ones (CLI11 would only say that one is required).
  const auto subs = app.get_subcommands([](const CLI::App*) { return true; });
  const auto is_command = [&](std::string_view w) {
    return std::any_of(subs.begin(), subs.end(),
                       [w](const CLI::App* c) { return c->get_name() == w; });
  };
  if (argc > 1 && argv[1][0] != '-' && !is_command(argv[1])) {
    std::string known;
    for (const CLI::App* sub : subs) known += (known.empty() ? "" : ", ") + sub->get_name();
    return fail(cli::kUsage, fmt::format("unknown command '{}'; the commands are {} (meshmark "
                                         "--help)",
                                         argv[1], known));
  }
  try {
    app.parse(argc, argv);
    return exit_code;
  } catch (const CLI::ParseError& e) {
    if (json && e.get_exit_code() != 0) return fail(cli::kUsage, e.what());
    const int rc = app.exit(e);
    return rc == 0 ? cli::kOk : cli::kUsage;
  } catch (const std::exception& e) {
    return fail(exit_code_of(e), e.what());
  }
}