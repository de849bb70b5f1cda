// The campaign's summary (summary.csv), figures (svg_plot.h, svg_png.h) and Markdown report
// (report.md).

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <map>
#include <set>

#include "campaign/campaign_internal.h"
#include "meshmark/attacks/attack.h"
#include "meshmark/campaign/campaign.h"
#include "meshmark/io/io.h"
#include "plot/svg_plot.h"
#include "plot/svg_png.h"

namespace meshmark {

namespace fs = std::filesystem;
using detail::plot_legend_extra;
using detail::PlotCurve;
using detail::svg_document;
using detail::write_figure;

namespace {

// A median-BER panel's axes: BER from 0 to 0.5 (wider if a median lies above chance).
detail::PlotAxes ber_axes(const std::string& title, const std::string& x_label) {
  return {title, x_label, "median BER", 0.5};
}

std::string strength_label(const AttackSeries& a) {
  if (a.kind == "none") return "no attack: the watermarked mesh decoded as it is";
  const std::string params = attack_params_label(a.params);
  const std::string with = params.empty() ? "" : " (here " + params + ")";
  const AttackKind* kind = find_attack_kind(a.kind);
  return (kind ? std::string(kind->meaning) : a.kind) + with;
}

double median(std::vector<double> v) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// A column of the report: a variant under a protocol.
struct Column {
  std::string protocol, variant, name;
};

std::vector<Column> columns_of(const CampaignConfig& c) {
  std::vector<Column> out;
  for (const CampaignProtocol& p : c.protocols)
    for (const std::string& v : c.variants)
      out.push_back({p.name, v, p.name.empty() ? v : v + " " + p.name});
  return out;
}

// A file name for a series label ("smooth [lambda=0.03 fixed_boundary]" ->
// "smooth-lambda-0.03-fixed_boundary").
std::string file_slug(const std::string& label) {
  std::string out;
  for (const char ch : label) {
    const bool keep = std::isalnum(static_cast<unsigned char>(ch)) || ch == '.' || ch == '_';
    if (keep)
      out += ch;
    else if (!out.empty() && out.back() != '-')
      out += '-';
  }
  while (!out.empty() && out.back() == '-') out.pop_back();
  return out;
}

// The trials the statistics leave out, by model, variant and protocol, with their reason.
std::string left_out(const std::vector<TrialRow>& rows) {
  std::map<std::string, std::pair<int, std::string>> by_unit;
  int total = 0;
  for (const TrialRow& r : rows) {
    if (r.status == "ok") continue;
    ++total;
    auto& [count, reason] = by_unit[fmt::format("{} {}{}", r.model, r.variant,
                                                r.protocol.empty() ? "" : " (" + r.protocol + ")")];
    ++count;
    if (reason.empty()) reason = r.status.substr(0, r.status.find(':'));
  }
  if (total == 0) return "Every trial measured a mark.";
  std::string md =
      fmt::format("Left out, not counted as BER 0.5: {} of {} trials without a mark to measure (",
                  total, rows.size());
  bool first = true;
  for (const auto& [unit, entry] : by_unit) {
    md += fmt::format("{}{}: {} trials, {}", first ? "" : "; ", unit, entry.first, entry.second);
    first = false;
  }
  return md + ").";
}

// What the report's parts read: the campaign, its rows and calibrations, the summary and the
// columns (a variant under a protocol) of its tables.
struct Report {
  const CampaignConfig& c;
  const std::vector<CalibrationRecord>& calibrations;
  const std::vector<TrialRow>& rows;
  std::vector<SummaryRow> summary;
  std::vector<Column> columns;

  const SummaryRow* lookup(const Column& col, const std::string& a, double x) const {
    for (const SummaryRow& s : summary)
      if (s.protocol == col.protocol && s.variant == col.variant && s.attack == a &&
          s.attack_strength == x)
        return &s;
    return nullptr;
  }

  // The median BER curves of attack a, one per column whose variant is in `variants`.
  std::vector<PlotCurve> curves_of(const AttackSeries& a,
                                   const std::vector<std::string>& variants) const {
    std::vector<PlotCurve> curves;
    std::vector<double> xs = a.strengths;
    std::sort(xs.begin(), xs.end());
    for (const Column& col : columns) {
      if (std::find(variants.begin(), variants.end(), col.variant) == variants.end()) continue;
      PlotCurve curve{col.name, {}};
      for (const double x : xs)
        if (const SummaryRow* s = lookup(col, series_label(a), x))
          curve.points.emplace_back(x, s->median_ber);
      curves.push_back(curve);
    }
    return curves;
  }
};

void write_summary_csv(const fs::path& dir, const std::vector<SummaryRow>& summary) {
  std::string csv = "variant,attack,attack_strength,median_ber,mean_ber,trials,protocol,excluded\n";
  auto quote = [](const std::string& t) { return fmt::format("\"{}\"", t); };
  for (const SummaryRow& s : summary)
    csv += fmt::format("{},{},{},{},{},{},{},{}\n", s.variant, quote(s.attack), s.attack_strength,
                       s.median_ber, s.mean_ber, s.trials, s.protocol, s.excluded);
  write_file_atomically((dir / "summary.csv").string(), csv);
}

// The figures: one per attack with more than one strength (a curve per variant), a panel
// figure of them all, and the paper's Figs. 1 and 2 (its variants, its five attacks) when the
// campaign has them. Returns the report's paragraphs that show them; `png` says whether PNG
// copies were written too.
std::string write_figures(const fs::path& dir, const Report& rep, bool& png) {
  const CampaignConfig& c = rep.c;
  std::vector<const AttackSeries*> plotted;
  for (const AttackSeries& a : c.attacks)
    if (a.kind != "none" && a.strengths.size() > 1) plotted.push_back(&a);
  const double pw = 420, ph = 300;
  png = false;
  // A grid of panels, three per row; returns the file's name, or "" when nothing to plot.
  auto grid = [&](const std::string& name, const std::vector<const AttackSeries*>& attacks,
                  const std::vector<std::string>& variants) -> std::string {
    if (attacks.empty()) return "";
    std::string panels;
    double extra = 0;  // every panel's legend as tall as the tallest
    for (const AttackSeries* a : attacks)
      extra = std::max(extra, plot_legend_extra(rep.curves_of(*a, variants), pw));
    for (std::size_t i = 0; i < attacks.size(); ++i) {
      const std::vector<PlotCurve> curves = rep.curves_of(*attacks[i], variants);
      const auto column = static_cast<double>(i % 3), row = std::floor(static_cast<double>(i) / 3);
      panels += detail::plot_panel(
          column * pw, row * (ph + extra), pw, ph + extra - plot_legend_extra(curves, pw),
          ber_axes(fmt::format("({}) {}", char('a' + i), series_label(*attacks[i])),
                   attacks[i]->kind + " strength"),
          curves);
    }
    const std::size_t cols = std::min<std::size_t>(3, attacks.size());
    png |= write_figure(
        dir, name,
        svg_document(static_cast<double>(cols) * pw,
                     std::ceil(static_cast<double>(attacks.size()) / 3) * (ph + extra), panels));
    return name;
  };
  std::string md_figures;
  for (const AttackSeries* a : plotted) {
    const std::vector<PlotCurve> curves = rep.curves_of(*a, c.variants);
    png |= write_figure(
        dir, "figure-" + file_slug(series_label(*a)),
        svg_document(pw, ph + plot_legend_extra(curves, pw),
                     detail::plot_panel(0, 0, pw, ph,
                                        ber_axes(series_label(*a), strength_label(*a)), curves)));
  }
  const std::string all = grid("figure-all", plotted, c.variants);
  if (!all.empty()) md_figures += "All attacks, every variant:\n\n![all](figure-all.svg)\n\n";
  std::vector<const AttackSeries*> five;
  for (const char* kind : {"noise", "quant", "smooth", "soup", "simplify"})
    for (const AttackSeries* a : plotted)
      if (series_label(*a) == kind) five.push_back(a);
  auto has = [&](std::initializer_list<const char*> vs) {
    return std::all_of(vs.begin(), vs.end(), [&](const char* v) {
      return std::find(c.variants.begin(), c.variants.end(), v) != c.variants.end();
    });
  };
  if (has({"DRS", "SRS", "VRS"}) && !grid("fig1", five, {"DRS", "SRS", "VRS"}).empty())
    md_figures += "The paper's Fig. 1 (DRS, SRS, VRS):\n\n![Fig. 1](fig1.svg)\n\n";
  if (has({"VRS", "VRQ", "VRL", "VNS", "VSS"}) &&
      !grid("fig2", five, {"VRS", "VRQ", "VRL", "VNS", "VSS"}).empty())
    md_figures += "The paper's Fig. 2 (VRS, VRQ, VRL, VNS, VSS):\n\n![Fig. 2](fig2.svg)\n\n";
  return md_figures;
}

// The report's opening: the configuration and how strengths were chosen.
std::string report_header(const CampaignConfig& c, std::size_t rows, double wall_seconds) {
  std::string md = fmt::format("# Campaign `{}`\n\n", c.name);
  md += fmt::format(
      "Configuration `{}`: {} models, variants {}, {} bits, {} payloads, {} draws for random "
      "attacks, seed {}. {} trials in {:.1f} s of wall time (all runs of the campaign).\n\n",
      c.source, c.models.size(), fmt::join(c.variants, ", "), c.bits, c.payloads, c.draws, c.seed,
      rows, wall_seconds);
  for (const CampaignProtocol& p : c.protocols)
    md +=
        c.calibrate
            ? fmt::format(
                  "Strengths calibrated per model and variant{}: the largest alpha with vertex "
                  "RMS <= {} % of the diagonal and MSDM <= {} (calibrate.h's search, precision "
                  "{}), bin offset G {}.\n\n",
                  p.name.empty() ? "" : " under protocol `" + p.name + "`",
                  p.calibration.max_rms_percent, p.calibration.max_msdm, p.calibration.precision,
                  p.calibration.bin_offset == BinOffsetRule::Fixed
                      ? "fixed at the paper's 0.05"
                      : "= min(0.05, alpha) (at-most-strength)")
            : fmt::format("Fixed strength alpha = {} for every model and variant.\n\n", c.strength);
  return md;
}

// The calibrated strengths, a row per model and a column per variant and protocol.
std::string calibration_table(const Report& rep) {
  std::string md =
      "## Calibrated strengths\n\nalpha (vertex RMS % of the diagonal, MSDM)\n\n| model |";
  for (const Column& col : rep.columns) md += " " + col.name + " |";
  md += "\n| --- |";
  for (std::size_t k = 0; k < rep.columns.size(); ++k) md += " ---: |";
  md += "\n";
  for (const CampaignModel& m : rep.c.models) {
    md += "| " + m.name + " |";
    for (const Column& col : rep.columns) {
      auto it = std::find_if(rep.calibrations.begin(), rep.calibrations.end(), [&](const auto& r) {
        return r.model == m.name && r.variant == col.variant && r.protocol == col.protocol;
      });
      if (it == rep.calibrations.end())
        md += " - |";
      else if (it->strength <= 0)
        md +=
            fmt::format(" none ({}) |",
                        it->cause.empty() ? it->status : it->cause.substr(0, it->cause.find(':')));
      else
        md += fmt::format(" {:.4f} ({:.4f}, {:.3f}) |", it->strength, it->rms_percent, it->msdm);
    }
    md += "\n";
  }
  return md;
}

// Medians of the embeddings' strength, distortion and time per column.
std::string distortion_table(const Report& rep) {
  std::string md =
      "\n## Distortion and time per variant\n\nMedians over the embeddings (one per model "
      "and payload).\n\n| variant | alpha | RMS % | MSDM | embedding s | failed |\n"
      "| --- | ---: | ---: | ---: | ---: | ---: |\n";
  for (const Column& col : rep.columns) {
    std::vector<double> a, r, m, t;
    int failed = 0;
    for (const TrialRow& row : rep.rows)
      if (row.variant == col.variant && row.protocol == col.protocol && row.attack == "none") {
        if (row.status != "ok") {
          ++failed;
          continue;
        }
        a.push_back(row.strength), r.push_back(row.rms_percent), m.push_back(row.msdm),
            t.push_back(row.embed_seconds);
      }
    md += fmt::format("| {} | {:.4f} | {:.5f} | {:.4f} | {:.4f} | {} |\n", col.name, median(a),
                      median(r), median(m), median(t), failed);
  }
  return md;
}

// The median BER per attack and strength, and the paper's Table III when there is Loop.
std::string ber_tables(const Report& rep) {
  std::string md;
  for (const AttackSeries& a : rep.c.attacks) {
    md += fmt::format("### {}\n\n{}\n\n| strength |", series_label(a), strength_label(a));
    for (const Column& col : rep.columns) md += " " + col.name + " |";
    md += "\n| ---: |";
    for (std::size_t k = 0; k < rep.columns.size(); ++k) md += " ---: |";
    md += "\n";
    for (const double x : a.strengths) {
      md += fmt::format("| {:g} |", x);
      for (const Column& col : rep.columns) {
        const SummaryRow* s = rep.lookup(col, series_label(a), x);
        md += s ? fmt::format(" {:.3f} |", s->median_ber) : std::string(" - |");
      }
      md += "\n";
    }
    md += "\n";
  }
  if (rep.lookup(rep.columns[0], "loop", 1)) {
    md +=
        "## Loop subdivision, one iteration (the paper's Table III)\n\n| variant | median BER |\n"
        "| --- | ---: |\n";
    for (const Column& col : rep.columns)
      if (const SummaryRow* s = rep.lookup(col, "loop", 1))
        md += fmt::format("| {} | {:.3f} |\n", col.name, s->median_ber);
    md += "\n";
  }
  return md;
}

// Median seconds of the attack and of the extraction, per attack.
std::string time_table(const Report& rep) {
  std::string md =
      "## Time per trial\n\nMedian seconds of the attack and of the blind extraction, per "
      "attack.\n\n| attack | attack s | extraction s | trials |\n| --- | ---: | ---: | ---: |\n";
  for (const AttackSeries& a : rep.c.attacks) {
    std::vector<double> at, xt;
    for (const TrialRow& row : rep.rows)
      if (row.attack == series_label(a) && row.status == "ok")
        at.push_back(row.attack_seconds), xt.push_back(row.extract_seconds);
    md += fmt::format("| {} | {:.4f} | {:.5f} | {} |\n", series_label(a), median(at), median(xt),
                      at.size());
  }
  return md;
}

}  // namespace

std::string write_campaign_report(const std::string& out_dir, const CampaignConfig& c,
                                  const std::vector<CalibrationRecord>& calibrations,
                                  const std::vector<TrialRow>& rows, double wall_seconds) {
  if (c.trace) return detail::write_trace_report(out_dir, c, calibrations, rows, wall_seconds);
  const fs::path dir(out_dir);
  const Report rep{c, calibrations, rows, summarize(c, rows), columns_of(c)};
  write_summary_csv(dir, rep.summary);
  bool png = false;
  const std::string md_figures = write_figures(dir, rep, png);
  std::string md = report_header(c, rows.size(), wall_seconds);
  md += calibration_table(rep);
  md += distortion_table(rep);
  md +=
      "\n## Median bit error rate\n\nOver models, payloads and draws, of the trials that "
      "measured a mark. " +
      left_out(rows) + "\n\n";
  md += md_figures + "\n";
  md += ber_tables(rep);
  md += detail::published_comparison(c, rep.summary);
  md += time_table(rep);
  md += fmt::format(
      "\nFiles: `rows.csv` and `rows.jsonl` (one row per trial), `summary.csv`, "
      "`calibration.jsonl`, figures as SVG{}.\n",
      png ? " and PNG" : " (PNG needs rsvg-convert from librsvg2-bin)");
  std::string path = (dir / "report.md").string();
  write_file_atomically(path, md);
  return path;
}

}  // namespace meshmark
