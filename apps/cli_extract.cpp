// meshmark extract IN [--expect HEX] [--coded] [--key K | --key-file F]

#include <fmt/format.h>
#include <cmath>
#include <memory>
#include <nlohmann/json.hpp>

#include "cli.h"
#include "meshmark/carrier/variant.h"
#include "meshmark/core/error.h"
#include "meshmark/mark/decode.h"

namespace meshmark::cli {

namespace {

struct ExtractArgs {
  std::string input, expect, variant = "DRS";
  Method method = Method::Qp;
  int bits = 64;
  InputOptions in;
  KeyArgs keys;
  bool json = false, coded = false;
};

int run(const ExtractArgs& a) {
  if (a.variant.size() != 3)
    throw InvalidArgumentError(fmt::format("variant '{}' is not three letters", a.variant));
  ExtractOptions options;
  options.bits = a.bits;
  options.center = parse_variant(a.variant).center;
  options.method = a.method;
  std::optional<Payload> expected;
  if (!a.expect.empty()) expected = payload_from_hex(a.expect, a.bits);
  const std::optional<Key> key = resolve_key(a.keys);
  const BitLayout layout = mark_layout(key, a.bits, a.coded);
  std::optional<IdCode> code;
  if (a.coded) code.emplace(id_code(a.keys, a.bits));
  const Mesh mesh = read_input(a.input, a.in);
  IdReading reading;
  if (code)
    reading = read_id(mesh.V, mesh.F, options, *code, key);
  else
    reading.reading = read_mark(mesh.V, mesh.F, options, layout);
  const ExtractResult& r = reading.reading.extract;
  report_carrier(a.input, r.check);
  const IdDecodeResult& id = reading.id;
  // Per bit, in payload order (the layout maps bits to bins).
  const std::vector<std::uint8_t>& bits = reading.reading.bits;
  const std::vector<double>& margins = reading.reading.margins;
  const std::vector<double>& means = reading.reading.means;
  Payload read;
  for (const std::uint8_t b : bits) read.bits.push_back(b == 1);
  const std::string hex = payload_to_hex(read);
  double ber = 0;
  if (expected) ber = bit_error_rate(bits, *expected);
  if (a.json) {
    nlohmann::json per_bit = nlohmann::json::array();
    for (std::size_t j = 0; j < bits.size(); ++j) {
      const int bin = layout.bin_of[j];
      per_bit.push_back(
          {{"bit", j},
           {"bin", bin + 1},
           {"value", bits[j] == kErasure ? nlohmann::json(nullptr) : nlohmann::json(int(bits[j]))},
           {"mean", std::isfinite(means[j]) ? nlohmann::json(means[j]) : nlohmann::json(nullptr)},
           {"margin", margins[j]},
           {"vertices", r.counts[bin]}});
    }
    nlohmann::json j = {{"input", a.input},
                        {"payload", hex},
                        {"bits", a.bits},
                        {"keyed", key.has_value()},
                        {"method", method_name(options.method)},
                        {"erasures", r.erasures},
                        {"min_margin", r.min_margin()},
                        {"per_bit", per_bit}};
    j["carrier"] = {{"status", carrier_health_name(r.check.status)},
                    {"positions", r.check.positions},
                    {"vertices", r.check.carrier},
                    {"diagnostics", r.check.diagnostics}};
    if (expected) j["expected"] = payload_to_hex(*expected), j["bit_error_rate"] = ber;
    if (code) {
      j["id_valid"] = id.valid;
      j["id_status"] = id_decode_status_name(id.status);
      j["mark_format"] = kMarkFormatVersion;
      j["min_distance"] = code->min_distance();
      j["readings"] = reading.readings;
      j["skipped_nearest"] = reading.skip_nearest;
      j["skipped_farthest"] = reading.skip_farthest;
      j["id"] = id.valid ? nlohmann::json(id.id) : nlohmann::json(nullptr);
      j["id_message"] = id.message;
      j["id_bits_corrected"] = id.valid ? nlohmann::json(id.corrected) : nlohmann::json(nullptr);
      j["false_accept_bound"] = code->false_accept_bound();
    }
    fmt::print("{}\n", j.dump(2));
  } else {
    if (code) {
      if (id.valid)
        fmt::print(
            "id {} ({} of {} bits corrected{}; codewords differ in {} bits or more; a word "
            "without this mark decodes with probability < {:.1e})\n",
            id.id, id.corrected, a.bits,
            reading.skip_nearest + reading.skip_farthest > 0
                ? fmt::format("; read without the {} nearest and {} farthest vertices",
                              reading.skip_nearest, reading.skip_farthest)
                : "",
            code->min_distance(), code->false_accept_bound());
      else
        fmt::print("no valid ID ({}): {}\n", id_decode_status_name(id.status), id.message);
    }
    fmt::print("payload {}{}\n", hex, key ? " (keyed layout)" : "");
    if (r.erasures > 0) fmt::print("erasures {} (empty bins read as 0)\n", r.erasures);
    fmt::print("smallest margin {:.6f}\n", r.min_margin());
    fmt::print("bit  bin  value  mean      margin    vertices\n");
    for (std::size_t j = 0; j < bits.size(); ++j)
      fmt::print("{:>3}  {:>3}  {:>5}  {:<8.6f}  {:<8.6f}  {}\n", j, layout.bin_of[j] + 1,
                 bits[j] == kErasure ? "?" : std::to_string(bits[j]), means[j], margins[j],
                 r.counts[layout.bin_of[j]]);
    if (expected)
      fmt::print("expected {}\nbit error rate {:.6f}\n", payload_to_hex(*expected), ber);
  }
  if (code && !id.valid) return kNoId;
  return expected && ber > 0 ? kBitErrors : kOk;
}

}  // namespace

void register_extract(CLI::App& app, int& exit_code) {
  auto args = std::make_shared<ExtractArgs>();
  CLI::App* sub = app.add_subcommand("extract", "Read the payload back from a mesh (blind)");
  sub->add_option("IN", args->input, "watermarked mesh")->required();
  sub->add_option("--bits", args->bits, "payload length in bits")->check(CLI::Range(1, kMaxBits));
  sub->add_option("--variant", args->variant,
                  "the embedding's variant (its center letter matters)");
  add_method_option(*sub, args->method, "the embedding's method (its bin statistic is read)");
  sub->add_option("--expect", args->expect, "expected payload (hex): report the bit error rate");
  sub->add_flag("--json", args->json, "print a JSON report");
  sub->add_flag("--coded", args->coded,
                "the payload is a coded ID (embed --id): decode it, or report that none is valid");
  add_key_options(*sub, args->keys);
  add_input_options(*sub, args->in);
  sub->callback([args, &exit_code] { exit_code = run(*args); });
}

}  // namespace meshmark::cli
