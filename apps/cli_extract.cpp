// meshmark extract IN [--expect HEX]

#include <fmt/format.h>
#include <cmath>
#include <memory>
#include <nlohmann/json.hpp>

#include "cli.h"
#include "meshmark/decode.h"
#include "meshmark/error.h"
#include "meshmark/variant.h"

namespace meshmark::cli {

namespace {

struct ExtractArgs {
  std::string input, expect, variant = "DRS";
  int bits = 64;
  InputOptions in;
  bool json = false;
};

int run(const ExtractArgs& a) {
  if (a.variant.size() != 3)
    throw InvalidArgumentError(fmt::format("variant '{}' is not three letters", a.variant));
  ExtractOptions options;
  options.bits = a.bits;
  options.center = parse_variant(a.variant).center;
  std::optional<Payload> expected;
  if (!a.expect.empty()) expected = payload_from_hex(a.expect, a.bits);
  const Mesh mesh = read_input(a.input, a.in);
  const ExtractResult r = extract(mesh.V, mesh.F, options);
  const std::string hex = payload_to_hex(r.payload());
  double ber = 0;
  if (expected) ber = bit_error_rate(r.bits, *expected);
  if (a.json) {
    nlohmann::json bits = nlohmann::json::array();
    for (std::size_t j = 0; j < r.bits.size(); ++j)
      bits.push_back({{"bit", j},
                      {"value", r.bits[j] == kErasure ? nlohmann::json(nullptr)
                                                      : nlohmann::json(int(r.bits[j]))},
                      {"mean", std::isfinite(r.means[j]) ? nlohmann::json(r.means[j])
                                                         : nlohmann::json(nullptr)},
                      {"margin", r.margins[j]},
                      {"vertices", r.counts[j]}});
    nlohmann::json j = {{"input", a.input},
                        {"payload", hex},
                        {"bits", a.bits},
                        {"erasures", r.erasures},
                        {"min_margin", r.min_margin()},
                        {"per_bit", bits}};
    if (expected) j["expected"] = payload_to_hex(*expected), j["bit_error_rate"] = ber;
    fmt::print("{}\n", j.dump(2));
  } else {
    fmt::print("payload {}\n", hex);
    if (r.erasures > 0) fmt::print("erasures {} (empty bins read as 0)\n", r.erasures);
    fmt::print("smallest margin {:.6f}\n", r.min_margin());
    fmt::print("bit  value  mean      margin    vertices\n");
    for (std::size_t j = 0; j < r.bits.size(); ++j)
      fmt::print("{:>3}  {:>5}  {:<8.6f}  {:<8.6f}  {}\n", j,
                 r.bits[j] == kErasure ? "?" : std::to_string(r.bits[j]), r.means[j], r.margins[j],
                 r.counts[j]);
    if (expected)
      fmt::print("expected {}\nbit error rate {:.6f}\n", payload_to_hex(*expected), ber);
  }
  return expected && ber > 0 ? kBitErrors : kOk;
}

}  // namespace

void register_extract(CLI::App& app, int& exit_code) {
  auto args = std::make_shared<ExtractArgs>();
  CLI::App* sub = app.add_subcommand("extract", "Read the payload back from a mesh (blind)");
  sub->add_option("IN", args->input, "watermarked mesh")->required();
  sub->add_option("--bits", args->bits, "payload length in bits")->check(CLI::Range(1, 1 << 20));
  sub->add_option("--variant", args->variant,
                  "the embedding's variant (its center letter matters)");
  sub->add_option("--expect", args->expect, "expected payload (hex): report the bit error rate");
  sub->add_flag("--json", args->json, "print a JSON report");
  add_input_options(*sub, args->in);
  sub->callback([args, &exit_code] { exit_code = run(*args); });
}

}  // namespace meshmark::cli
