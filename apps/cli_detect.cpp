// meshmark detect IN --expect ID | --expect-payload HEX [--key K | --key-file F]

#include <fmt/format.h>

#include <cmath>
#include <memory>
#include <nlohmann/json.hpp>

#include "cli.h"
#include "meshmark/carrier/variant.h"
#include "meshmark/core/error.h"
#include "meshmark/mark/decode.h"
#include "meshmark/protocol/detect.h"

namespace meshmark::cli {

namespace {

struct DetectArgs {
  std::string input, expect_id, expect_payload, variant = "DRS";
  Method method = Method::Qp;
  int bits = 64;
  double threshold = 1e-6;
  KeyArgs keys;
  InputOptions in;
  bool json = false;
};

int run(const DetectArgs& a) {
  if (a.expect_id.empty() && a.expect_payload.empty())
    throw InvalidArgumentError("detect needs one of --expect ID or --expect-payload HEX");
  const bool coded = !a.expect_id.empty();
  const std::optional<Key> key = resolve_key(a.keys);
  MarkExpectation expect;
  expect.id_bits = a.keys.id_bits;
  if (coded)
    expect.id = parse_id(a.expect_id);
  else
    expect.payload = payload_from_hex(a.expect_payload, a.bits);
  DetectOptions options;
  options.threshold = a.threshold;
  ExtractOptions eo;
  eo.bits = a.bits;
  eo.center = parse_variant(a.variant).center;
  eo.method = a.method;
  const Mesh mesh = read_input(a.input, a.in);
  const MarkDetection found = detect_mark(mesh.V, mesh.F, eo, expect, key, options);
  report_carrier(a.input, found.extract.check);
  const DetectResult& d = found.detection;
  const Payload& expected = found.expected;
  if (a.json) {
    nlohmann::json j = {
        {"input", a.input},
        {"expected", payload_to_hex(expected)},
        {"id", coded ? nlohmann::json(parse_id(a.expect_id)) : nlohmann::json(nullptr)},
        {"keyed", key.has_value()},
        {"bits", d.compared},
        {"matches", d.matches},
        {"erasures", d.erasures},
        {"p_value", d.p_value},
        {"null_model", null_model_name(d.model)},
        {"decodes_to", d.decodes_to_other ? nlohmann::json(d.other_id) : nlohmann::json(nullptr)},
        {"threshold", a.threshold},
        {"detected", d.detected}};
    fmt::print("{}\n", j.dump(2));
  } else {
    fmt::print("{}: {} of {} bits match{}\n", a.input, d.matches, d.compared,
               d.erasures ? fmt::format(" ({} unreadable)", d.erasures) : "");
    if (coded)
      fmt::print(
          "probability that this ID matches as well if it is innocent (its codeword independent "
          "of the mark present: another buyer's copy, an unmarked mesh, another key): {:.3g}{}\n",
          d.p_value, d.model == NullModel::CodewordBound ? " (an upper bound)" : "");
    else
      fmt::print(
          "probability that a mesh without this payload matches as well (fair independent "
          "bits{}): {:.3g}\n",
          key ? "" : "; without a key only indicative", d.p_value);
    if (d.decodes_to_other)
      fmt::print("the mark decodes to another ID, {}: ID {} is not the one present\n", d.other_id,
                 a.expect_id);
    fmt::print("{} (threshold {:g})\n", d.detected ? "DETECTED" : "not detected", a.threshold);
  }
  return d.detected ? kOk : kNoId;
}

}  // namespace

void register_detect(CLI::App& app, int& exit_code) {
  auto args = std::make_shared<DetectArgs>();
  CLI::App* sub = app.add_subcommand(
      "detect", "Test whether a mesh carries an expected ID, with a false-alarm probability");
  sub->add_option("IN", args->input, "mesh to test")->required();
  sub->add_option("--expect", args->expect_id, "expected ID (embed --id): decimal or 0x hex");
  sub->add_option("--expect-payload", args->expect_payload,
                  "expected raw payload (embed --payload), hexadecimal")
      ->excludes("--expect");
  sub->add_option("--bits", args->bits, "payload length in bits")->check(CLI::Range(1, kMaxBits));
  sub->add_option("--variant", args->variant, "the embedding's variant (its center matters)");
  add_method_option(*sub, args->method, "the embedding's method (its bin statistic is read)");
  sub->add_option("--threshold", args->threshold,
                  "declare the mark present below this false-alarm probability")
      ->check(CLI::Range(1e-300, 0.5));
  sub->add_flag("--json", args->json, "print a JSON report");
  add_key_options(*sub, args->keys);
  add_input_options(*sub, args->in);
  sub->callback([args, &exit_code] { exit_code = run(*args); });
}

}  // namespace meshmark::cli
