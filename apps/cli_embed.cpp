// meshmark embed IN OUT --payload HEX

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <memory>
#include <nlohmann/json.hpp>

#include "cli.h"
#include "meshmark/core/error.h"
#include "meshmark/forensics/issue.h"
#include "meshmark/forensics/registry.h"
#include "meshmark/mark/calibrate.h"
#include "meshmark/mark/embed.h"
#include "progress.h"

namespace meshmark::cli {

namespace {

struct EmbedArgs {
  std::string input, output, payload, id, variant = "DRS", batch;
  std::string registry, buyer, fidelity;
  BinOffsetRule bin_offset_rule = BinOffsetRule::AtMostStrength;
  Method method = Method::Qp;
  double max_rms = 0, max_msdm = 0;  // 0: not given
  KeyArgs keys;
  int bits = 64;
  double strength_spread = 0.25;
  EmbedOptions embed;
  InputOptions in;
  OutputOptions out;
  bool json = false;
  bool public_key = false;      // --public-key: coded IDs without a secret key
  bool fingerprint = false;     // --fingerprint: every coded copy carries the fingerprint
  bool no_fingerprint = false;  // --no-fingerprint: none does
};

// The limits of --fidelity, --max-rms and --max-msdm, or none (a fixed --strength).
std::optional<CalibrateOptions> fidelity_limits(const EmbedArgs& a) {
  if (a.fidelity.empty() && a.max_rms == 0 && a.max_msdm == 0) return std::nullopt;
  CalibrateOptions c;
  if (a.fidelity == "paper") {
    c.max_rms_percent = kPaperMaxRmsPercent;
    c.max_msdm = kPaperMaxMsdm;
  } else if (!a.fidelity.empty()) {
    throw InvalidArgumentError(fmt::format("unknown fidelity '{}' (known: paper)", a.fidelity));
  }
  if (a.max_rms > 0) c.max_rms_percent = a.max_rms;
  if (a.max_msdm > 0) c.max_msdm = a.max_msdm;
  c.bin_offset = a.bin_offset_rule;
  return c;
}

// Exit code and stderr line of a copy that was not issued.
[[noreturn]] void fail(const CopyOutcome& c, const std::string& input) {
  if (c.status == CopyStatus::Refused) throw InvalidArgumentError(c.message);
  if (c.status == CopyStatus::Unreadable) throw InputFailure(c.message);
  if (c.status == CopyStatus::WriteFailed) throw IOError(c.message);
  throw IOError(fmt::format("{}: {}", input, c.message));  // NotRecorded
}

int run(const EmbedArgs& a) {
  IssueSettings settings;
  EmbedOptions& options = settings.embedding;
  options = a.embed;
  settings.limits = fidelity_limits(a);
  options.variant = parse_variant(a.variant);
  options.method = a.method;
  settings.bits = a.bits;
  settings.read = read_options(a.in);
  settings.write = write_options(a.out);
  if (a.keys.legacy_passphrase)
    throw InvalidArgumentError(
        "--legacy-passphrase reads copies issued before registry schema 4; new copies are "
        "issued under the passphrase's Argon2id key");
  settings.key = resolve_key(a.keys);
  settings.id_bits = a.keys.id_bits;
  settings.strength_spread = a.strength_spread;
  settings.registry = a.registry;
  settings.allow_public_key = a.public_key;
  if (a.fingerprint || a.no_fingerprint) settings.fingerprint = a.fingerprint;
  if (a.keys.file) settings.kept_files.emplace_back("the key file", *a.keys.file);
  if (!a.batch.empty()) settings.kept_files.emplace_back("the manifest", a.batch);
  if (!a.batch.empty()) {
    if (!a.input.empty())
      throw InvalidArgumentError("--batch takes its inputs and outputs from the manifest");
    return run_batch(a.batch, settings, a.json);
  }
  if (a.input.empty() || a.output.empty() || a.payload.empty() == a.id.empty())
    throw InvalidArgumentError(
        "embed needs IN, OUT and one of --payload or --id (or --batch MANIFEST)");
  if (a.registry.empty() && !a.buyer.empty())
    throw InvalidArgumentError("--buyer is recorded in a registry: give --registry DB");
  const std::optional<Key>& key = settings.key;
  const bool coded = !a.id.empty();
  if (coded && !key) {
    fmt::print(stderr,
               "meshmark: warning: --id without --key-file or --key codes the ID under the public "
               "key: anyone can read it, remove it, or write any other buyer's ID\n");
    settings.allow_public_key = true;  // one copy by hand: warned; a batch needs --public-key
  }
  CopyRequest request;
  request.input = a.input;
  request.output = a.output;
  if (coded) set_copy_id(request, a.id);
  request.payload_hex = a.payload;
  request.buyer = a.buyer;
  settings.resume = false;  // one copy asked for by hand: an ID issued before is refused
  Progress progress(Progress::Bar, "");  // preparing, then issuing: seconds on a large mesh
  settings.progress = terminal_progress(progress, a.json);
  const IssueResult issued = issue_copies({request}, settings);
  progress.finish();
  const CopyOutcome& c = issued.copies.at(0);
  for (const std::string& w : c.warnings)
    fmt::print(stderr, "meshmark: warning: {}\n", printable(w));
  const bool ran = c.status == CopyStatus::Written || c.status == CopyStatus::NotEmbedded ||
                   c.status == CopyStatus::NotWithinFidelity || c.status == CopyStatus::NotCarried;
  if (!ran) fail(c, a.input);
  const EmbedResult& r = c.result;
  const EmbedOptions& used = c.embedding;
  const std::optional<CalibrateResult>& calibration = c.calibration;
  const std::optional<CalibrateOptions>& limits = settings.limits;
  const Payload& payload = c.word;
  const std::string status =
      c.status == CopyStatus::Written ? embed_status_name(r.status) : copy_status_name(c.status);
  const bool ok = c.status == CopyStatus::Written;
  const std::uint64_t id = request.auto_id ? c.record.id : request.id.value_or(0);
  if (ok && c.fingerprint_alone) {  // no histogram mark in the copy: nothing of it to print
    // Why: the fidelity search's message, or the embedding's at the fixed strength.
    const std::string why = calibration
                                ? calibration->message
                                : fmt::format("at strength {:g}, {}", used.strength, r.message);
    if (a.json) {
      const nlohmann::json j = {{"status", "fingerprint alone"},
                                {"message", c.message},
                                {"input", a.input},
                                {"output", a.output},
                                {"id", id},
                                {"strength", 0.0},
                                {"fingerprint_alone", true},
                                {"histogram_mark", why}};
      fmt::print("{}\n", j.dump(2));
    } else {
      fmt::print("embedded: {}\n", c.message);
      fmt::print("  ID               {} ({} bits, coded)\n", id, a.keys.id_bits);
      fmt::print("  histogram mark   none: {}\n", why);
      fmt::print("  written          {} (the fingerprint alone, which only trace reads)\n",
                 printable(a.output));
    }
    return kOk;
  }
  if (a.json) {
    nlohmann::json j = {
        {"status", status},
        {"message", ok ? r.message : c.message},
        {"input", a.input},
        {"output", ok ? a.output : ""},
        {"fingerprint_alone", false},
        {"method", method_name(used.method)},
        {"variant", a.variant},
        {"solver", enum_name(used.backend)},
        {"payload", payload_to_hex(payload)},
        {"id", coded ? nlohmann::json(id) : nlohmann::json(nullptr)},
        {"keyed", key.has_value()},
        {"bits", a.bits},
        {"strength", used.strength},
        {"strength_spread", key || coded ? a.strength_spread : 0.0},
        {"bin_offset", used.bin_offset},
        {"vertices", c.vertices},
        {"rounds", r.rounds},
        {"solver_iterations", r.solver_iterations},
        {"radial_fallbacks", r.radial_fallbacks},
        {"solver_status", qp_status_name(r.solver_status)},
        {"kkt_residual", r.kkt_residual},
        {"min_margin", r.min_margin},
        {"margins", r.margins},
        {"infeasible_bits", r.infeasible_bits},
        {"squared_displacement", r.squared_displacement},
        {"rms_displacement", r.rms_displacement},
        {"rms_percent", r.rms_percent},
        {"center_drift_bins", r.center_drift},
        {"seconds", calibration ? calibration->seconds : r.seconds},
        {"fidelity",
         calibration ? nlohmann::json{{"status", calibrate_status_name(calibration->status)},
                                      {"cause", calibrate_cause_name(calibration->cause)},
                                      {"max_rms_percent", limits->max_rms_percent},
                                      {"max_msdm", limits->max_msdm},
                                      {"rms_percent", calibration->rms_percent},
                                      {"msdm", calibration->msdm},
                                      {"bin_offset_rule", bin_offset_rule_name(limits->bin_offset)},
                                      {"evaluations", calibration->evaluations},
                                      {"measurements", calibration->measurements},
                                      {"estimates", calibration->estimates},
                                      {"diagnostics", calibration->diagnostics}}
                     : nlohmann::json(nullptr)},
        {"carrier",
         {{"status", carrier_health_name(r.check.status)},
          {"positions", r.check.positions},
          {"vertices", r.check.carrier},
          {"diagnostics", r.check.diagnostics}}}};
    fmt::print("{}\n", j.dump(2));
  } else {
    fmt::print("{}: {}\n", ok ? "embedded" : "NOT embedded", ok ? r.message : c.message);
    if (coded) fmt::print("  ID               {} ({} bits, coded)\n", id, a.keys.id_bits);
    fmt::print(
        "  payload          {} ({} bits, {}, {} {}, strength {}{})\n", payload_to_hex(payload),
        a.bits, key ? "keyed layout" : (coded ? "public whitening" : "canonical layout"),
        used.method == Method::Qp ? "variant" : method_name(used.method), a.variant, used.strength,
        used.method == Method::Qp ? fmt::format(", bin offset {}", used.bin_offset)
                                  : std::string());
    if (used.method == Method::Qp)
      fmt::print("  rounds           {} ({} solver iterations, KKT residual {:.2e})\n", r.rounds,
                 r.solver_iterations, r.kkt_residual);
    else
      fmt::print("  rounds           {} ({} evaluations of the exponent search)\n", r.rounds,
                 r.solver_iterations);
    fmt::print("  smallest margin  {:.6f} (target {})\n", r.min_margin, used.strength);
    fmt::print("  RMS displacement {:.6f} % of the bounding-box diagonal\n", r.rms_percent);
    if (calibration)
      fmt::print(
          "  fidelity         {}: RMS {:.5f} % (limit {}), MSDM {:.4f} (limit {}); {} "
          "embeddings, MSDM measured {} times and estimated {}\n",
          calibrate_status_name(calibration->status), calibration->rms_percent,
          limits->max_rms_percent, calibration->msdm, limits->max_msdm, calibration->evaluations,
          calibration->measurements, calibration->estimates);
    fmt::print("  center drift     {:.3g} bin widths\n", r.center_drift);
    fmt::print("  time             {:.2f} ms (without file I/O{})\n",
               1e3 * (calibration ? calibration->seconds : r.seconds),
               calibration ? ", with the strength search" : "");
    if (!r.infeasible_bits.empty())
      fmt::print("  infeasible bits  {}\n", fmt::join(r.infeasible_bits, " "));
    if (ok)
      fmt::print("  written          {} (read back: every bit decodes)\n", printable(a.output));
  }
  if (!ok) fmt::print(stderr, "meshmark: error: {}: {}\n", a.input, c.message);
  if (!ok && calibration)
    for (std::size_t k = 1; k < calibration->diagnostics.size(); ++k)
      fmt::print(stderr, "meshmark:   {}\n", calibration->diagnostics[k]);
  return ok ? kOk : kNotEmbedded;
}

}  // namespace

void register_embed(CLI::App& app, int& exit_code) {
  auto args = std::make_shared<EmbedArgs>();
  CLI::App* sub =
      app.add_subcommand("embed", "Embed a payload into a mesh and write the watermarked mesh");
  sub->add_option("IN", args->input, "input mesh (.off .obj .ply .stl .gltf .glb .drc .3mf)");
  sub->add_option("OUT", args->output, "output mesh; format from its extension");
  CLI::Option* batch =
      sub->add_option("--batch", args->batch,
                      "manifest: one 'INPUT OUTPUT PAYLOAD' or 'INPUT OUTPUT id:N BUYER' per line, "
                      "run on all cores");
  CLI::Option* payload =
      sub->add_option("--payload", args->payload, "payload in hexadecimal (bin 1's bit first)");
  CLI::Option* id =
      sub->add_option("--id", args->id,
                      "buyer ID to embed with error correction and an integrity check (decimal or "
                      "0x hex; --id-bits long), or auto: the registry picks the smallest ID "
                      "spaced from every issued one");
  sub->add_option("--bits", args->bits, "payload length in bits")->check(CLI::Range(1, kMaxBits));
  add_method_option(*sub, args->method, "who moves the vertices");
  sub->add_option("--variant", args->variant,
                  "center (D S V), direction (R N S), cost (S Q L); default DRS");
  sub->add_option("--lambda", args->embed.lambda,
                  "costs Q and L: weight of the squared error, in [0, 1]")
      ->check(finite_number());
  CLI::Option* strength =
      sub->add_option("--strength", args->embed.strength,
                      "alpha in (0, 1/2): target distance of bin means from 1/2 (default 0.05)")
          ->check(finite_number());
  CLI::Option* fidelity =
      sub->add_option(
             "--fidelity", args->fidelity,
             "search the strongest mark within named limits for this payload: paper (vertex "
             "RMS 0.04 % of the diagonal and MSDM 0.25, TIFS 2014)")
          ->check(CLI::IsMember({"paper"}));
  CLI::Option* max_rms =
      sub->add_option("--max-rms", args->max_rms,
                      "search the strongest mark whose vertex RMS stays within this % of the "
                      "bounding-box diagonal (with --max-msdm; default 0.04 with either)")
          ->check(finite_number() & CLI::PositiveNumber);
  CLI::Option* max_msdm =
      sub->add_option("--max-msdm", args->max_msdm,
                      "search the strongest mark whose MSDM stays within this (default 0.25)")
          ->check(finite_number() & CLI::PositiveNumber);
  add_enum_option<BinOffsetRule>(
      *sub, "--bin-offset-rule", args->bin_offset_rule,
      "with a fidelity search: at-most-strength (G = min(--bin-offset, alpha), the "
      "default) or fixed (G = --bin-offset, the paper's)");
  sub->add_option("--strength-spread", args->strength_spread,
                  "keyed or coded marks: bit j's strength is alpha (1 + spread u_j), u_j drawn "
                  "from the key in [0, 1), so the histogram does not show alpha; 0 = uniform")
      ->check(finite_number() & CLI::Range(0.0, 4.0));
  CLI::Option* fingerprint = sub->add_flag(
      "--fingerprint", args->fingerprint,
      "every coded copy carries the buyer's fingerprint, registered or not (refused for an "
      "original with fewer than 128 counted carrier vertices). Without it, copies recorded in a "
      "registry carry it where their original can: a second mark, which trace reads with the "
      "original (survives averages of copies and smoothing; a further RMS of 0.01 % of the "
      "diagonal, up to 0.03 % on originals under 32,768 vertices, within the fidelity limits; "
      "mark format 5)");
  sub->add_flag("--no-fingerprint", args->no_fingerprint,
                "no copy carries the fingerprint (only the histogram mark: copies are then "
                "easier to defeat by averaging or smoothing)")
      ->excludes(fingerprint);
  sub->add_option("--bin-offset", args->embed.bin_offset,
                  "G in [0, 1/2): vertices stay in [G, 1-G] of their bin")
      ->check(finite_number());
  sub->add_option("--max-rounds", args->embed.max_rounds, "linearize-and-solve rounds at most")
      ->check(CLI::Range(1, 1000));
  add_enum_option<SolverBackend>(
      *sub, "--solver", args->embed.backend,
      "the backend that solves each round's quadratic program (EmbedOptions::backend): "
      "native (the structured solvers: exact dual Newton for costs S and Q, ADMM for "
      "cost L) or ipopt (general-purpose interior point, for comparison)");
  add_enum_option<AdmmXStep>(
      *sub, "--x-step", args->embed.admm.x_step,
      "cost L, native solver: ADMM x-steps by matrix-free conjugate gradients (cg) or "
      "a sparse LDL^T factorization reused across iterations (cholesky)");
  sub->add_option("--registry", args->registry,
                  "record the issued copy (coded ID) in this SQLite registry; an ID already "
                  "issued from this original under this key is refused");
  CLI::Option* buyer =
      sub->add_option("--buyer", args->buyer, "the buyer's label recorded with --registry");
  sub->add_flag("--json", args->json, "print a JSON report");
  sub->add_flag("--public-key", args->public_key,
                "--batch with coded IDs and no key: code them under the public key anyway "
                "(anyone can then read, remove or forge them); refused without it");
  add_key_options(*sub, args->keys);
  add_input_options(*sub, args->in);
  add_output_options(*sub, args->out);
  // Options that cannot go together: CLI11 refuses them (exit 1) naming both.
  payload->excludes(id);
  for (CLI::Option* per_copy : {payload, id, buyer}) batch->excludes(per_copy);
  for (CLI::Option* search : {fidelity, max_rms, max_msdm}) strength->excludes(search);
  sub->callback([args, &exit_code] { exit_code = run(*args); });
}

}  // namespace meshmark::cli
