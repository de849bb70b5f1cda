// The campaign report's comparison with the published results of the LIRIS watermarking
// benchmark (Wang, Lavoue, Denis, Baskurt, SMI 2010; docs/method.md section 8):
// Cho et al.'s method under its two protocols and Wang et al.'s volume-moment method, beside
// this campaign's variants at the protocol of equal distortion, attack by attack, only for
// series that apply the benchmark's definition of the attack.

#include <fmt/format.h>

#include <cmath>

#include "campaign/campaign_internal.h"
#include "meshmark/campaign/campaign.h"

namespace meshmark {

namespace {

// An attack of the published tables, with the benchmark's definition.
struct PublishedAttack {
  const char* kind;
  AttackParams params;
  double strength;
  const char* definition;
};

AttackParams benchmark_smoothing() {
  AttackParams p;
  p.lambda = 0.03;
  p.fixed_boundary = true;
  return p;
}

AttackParams benchmark_quantization() {
  AttackParams p;
  p.convention = QuantizeConvention::Benchmark;
  return p;
}

const char* kNoise =
    "uniform noise in [-A d, A d] per coordinate, d the mean vertex-to-centroid distance";
const char* kSmooth =
    "umbrella Laplacian (1/degree), lambda 0.03, boundary fixed, all vertices at once";
const char* kQuant = "per axis, step (max - min) / 2^b from the minimum, ties down";
const char* kSubdiv = "one iteration (CGAL Subdivision_method_3; midpoint: linear mask)";

const std::vector<PublishedAttack>& published_attacks() {
  static const std::vector<PublishedAttack> attacks = {
      {"noise-radius", {}, 0.0005, kNoise},
      {"noise-radius", {}, 0.001, kNoise},
      {"noise-radius", {}, 0.003, kNoise},
      {"noise-radius", {}, 0.005, kNoise},
      {"smooth", benchmark_smoothing(), 5, kSmooth},
      {"smooth", benchmark_smoothing(), 10, kSmooth},
      {"smooth", benchmark_smoothing(), 30, kSmooth},
      {"smooth", benchmark_smoothing(), 50, kSmooth},
      {"quant", benchmark_quantization(), 11, kQuant},
      {"quant", benchmark_quantization(), 10, kQuant},
      {"quant", benchmark_quantization(), 9, kQuant},
      {"quant", benchmark_quantization(), 8, kQuant},
      {"quant", benchmark_quantization(), 7, kQuant},
      {"midpoint", {}, 1, kSubdiv},
      {"sqrt3", {}, 1, kSubdiv},
      {"loop", {}, 1, kSubdiv}};
  return attacks;
}

// A published column: a method at one distortion, the mean BER of each published attack.
struct PublishedColumn {
  const char* method;
  const char* protocol;
  double mrms_percent;  // % of the diagonal
  double msdm;          // NaN: not published
  double ber[16];       // in the order of published_attacks()
};

const PublishedColumn kPublished[] = {
    {"Cho et al.",
     "perceptual",
     0.008,
     0.19,
     {0.01, 0.03, 0.13, 0.28, 0.10, 0.23, 0.38, 0.45, 0, 0.04, 0.14, 0.26, 0.46, 0.04, 0.14, 0.16}},
    {"Cho et al.",
     "geometric",
     0.012,
     0.29,
     {0, 0.01, 0.10, 0.24, 0.06, 0.16, 0.34, 0.42, 0, 0.02, 0.06, 0.18, 0.41, 0.02, 0.09, 0.09}},
    {"Wang et al. (volume moments)",
     "",
     0.069,
     NAN,
     {0, 0.01, 0.08, 0.16, 0, 0.01, 0.07, 0.14, 0, 0.01, 0.01, 0.05, 0.17, 0, 0, 0}}};

bool matches(const CampaignProtocol& p, const PublishedColumn& c) {
  const bool rms = std::abs(p.calibration.max_rms_percent - c.mrms_percent) < 1e-9;
  return rms && (std::isnan(c.msdm) || std::abs(p.calibration.max_msdm - c.msdm) < 1e-9);
}

std::string distortion(const PublishedColumn& c) {
  return std::isnan(c.msdm) ? fmt::format("MRMS {:g} %", c.mrms_percent)
                            : fmt::format("MRMS {:g} %, MSDM {:g}", c.mrms_percent, c.msdm);
}

const SummaryRow* find(const std::vector<SummaryRow>& summary, const std::string& protocol,
                       const std::string& variant, const std::string& attack, double x) {
  for (const SummaryRow& s : summary)
    if (s.protocol == protocol && s.variant == variant && s.attack == attack &&
        s.attack_strength == x)
      return &s;
  return nullptr;
}

// The table of one protocol beside the published columns it matches (all when none does).
std::string protocol_table(const CampaignConfig& c, const CampaignProtocol& p,
                           const std::vector<SummaryRow>& summary) {
  std::vector<const PublishedColumn*> columns;
  for (const PublishedColumn& col : kPublished)
    if (matches(p, col)) columns.push_back(&col);
  const bool equal = !columns.empty();
  if (!equal)
    for (const PublishedColumn& col : kPublished) columns.push_back(&col);
  std::string md = fmt::format("### Protocol {}: vertex RMS <= {:g} %, MSDM <= {:g}\n\n",
                               p.name.empty() ? "(the campaign's calibration)" : "`" + p.name + "`",
                               p.calibration.max_rms_percent, p.calibration.max_msdm);
  md += equal ? "At the published distortion of " : "**Not at equal distortion**: published at ";
  for (std::size_t k = 0; k < columns.size(); ++k)
    md += fmt::format("{}{}{} ({})", k ? "; " : "", columns[k]->method,
                      *columns[k]->protocol ? fmt::format(", {}", columns[k]->protocol) : "",
                      distortion(*columns[k]));
  md +=
      ". Published: mean BER over 5 trials on Venus; this campaign: mean (median) BER over "
      "its models, payloads and draws that were marked within this protocol's limits (the "
      "calibration table names the models that were not).\n\n| attack (definition) | strength |";
  for (const PublishedColumn* col : columns)
    md += fmt::format(" {}{} |", col->method,
                      *col->protocol ? fmt::format(", {}", col->protocol) : std::string());
  for (const std::string& v : c.variants) md += " " + v + " |";
  md += "\n| --- | ---: |";
  for (std::size_t k = 0; k < columns.size() + c.variants.size(); ++k) md += " ---: |";
  md += "\n";
  int rows = 0;
  for (std::size_t i = 0; i < published_attacks().size(); ++i) {
    const PublishedAttack& a = published_attacks()[i];
    const std::string label = series_label({a.kind, {}, 0, a.params});
    bool measured = false;
    for (const std::string& v : c.variants)
      measured |= find(summary, p.name, v, label, a.strength) != nullptr;
    if (!measured) continue;
    ++rows;
    md += fmt::format("| {} ({}) | {:g} |", label, a.definition, a.strength);
    for (const PublishedColumn* col : columns) md += fmt::format(" {:.2f} |", col->ber[i]);
    for (const std::string& v : c.variants) {
      const SummaryRow* s = find(summary, p.name, v, label, a.strength);
      md += s ? fmt::format(" {:.3f} ({:.3f}) |", s->mean_ber, s->median_ber) : " - |";
    }
    md += "\n";
  }
  return rows ? md + "\n" : "";
}

}  // namespace

std::string detail::published_comparison(const CampaignConfig& c,
                                         const std::vector<SummaryRow>& summary) {
  std::string body;
  for (const CampaignProtocol& p : c.protocols) body += protocol_table(c, p, summary);
  if (body.empty()) return "";
  return "## Beside the published results of the LIRIS benchmark\n\n"
         "The benchmark of Wang, Lavoue, Denis and Baskurt (SMI 2010; its attacks are MEPP's "
         "Various_Processing component) publishes Cho et al.'s method under two protocols and "
         "Wang et al.'s volume-moment method (docs/method.md section 8). Rows list "
         "only this campaign's series that apply the benchmark's definition of the attack (named "
         "in each row); a series with another definition (smoothing with lambda 0.3, "
         "quantization step (max - min) / (2^b - 1)) is not compared. The campaign calibrates on "
         "the vertex RMS, a stand-in for the published MRMS (README, section \"Calibration and "
         "benchmark campaigns\").\n\n" +
         body;
}

}  // namespace meshmark
