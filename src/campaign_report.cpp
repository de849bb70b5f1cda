// The campaign's summary, figures (SVG, and PNG through rsvg-convert when installed) and
// Markdown report.

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <set>

#include "campaign_internal.h"
#include "meshmark/attack.h"
#include "meshmark/campaign.h"
#include "meshmark/io.h"
#include "svg_markup.h"

namespace meshmark {

namespace fs = std::filesystem;
using detail::svg_document;
using detail::write_figure;

namespace {

struct Curve {
  std::string name;
  std::vector<std::pair<double, double>> points;  // (attack strength, median BER)
};

const char* kColors[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd",
                         "#ff7f0e", "#8c564b", "#e377c2", "#17becf"};
const char* kDashes[] = {"", "6,3", "2,3", "8,3,2,3", "", "6,3", "2,3", "8,3,2,3"};

// The legend's entries (a line sample and the curve's name) flow left to right between the
// title and the frame, wrapping at the frame's width: each entry's (x offset, row).
constexpr double kLegendRow = 14, kLegendLeft = 56, kLegendRight = 12;
std::vector<std::pair<double, int>> legend_layout(const std::vector<Curve>& curves, double w) {
  std::vector<std::pair<double, int>> at;
  double x = 0;
  int row = 0;
  for (const Curve& c : curves) {
    const double width = 30 + 6.2 * static_cast<double>(c.name.size());  // 11 px text
    if (x > 0 && x + width > w - kLegendLeft - kLegendRight) x = 0, ++row;
    at.emplace_back(x, row);
    x += width + 10;
  }
  return at;
}

// The legend's height beyond its first row: what a panel of these curves needs added.
double legend_extra(const std::vector<Curve>& curves, double w) {
  const auto at = legend_layout(curves, w);
  return at.empty() ? 0 : kLegendRow * at.back().second;
}

// One panel: median BER in [0, 0.5] against the attack's strength, a curve per variant. h
// holds the plot and a one-row legend; legend_extra(curves, w) more is taken for the others.
std::string panel(double x0, double y0, double w, double h, const std::string& title,
                  const std::string& xlabel, const std::vector<Curve>& curves) {
  double lo = INFINITY, hi = -INFINITY;
  for (const Curve& c : curves)
    for (const auto& p : c.points) lo = std::min(lo, p.first), hi = std::max(hi, p.first);
  if (!std::isfinite(lo)) lo = 0, hi = 1;
  if (hi == lo) lo -= 0.5, hi += 0.5;
  const auto legend = legend_layout(curves, w);
  const double extra = legend.empty() ? 0 : kLegendRow * legend.back().second;
  h += extra;
  const double ml = kLegendLeft, mr = kLegendRight, mt = 46 + extra, mb = 44;
  const double pw = w - ml - mr, ph = h - mt - mb;
  auto X = [&](double x) { return x0 + ml + (x - lo) / (hi - lo) * pw; };
  double top = 0.5;  // BER axis [0, 0.5], wider if a median lies above chance
  for (const Curve& c : curves)
    for (const auto& p : c.points) top = std::max(top, std::ceil(p.second * 10) / 10);
  auto Y = [&](double y) { return y0 + mt + (1 - y / top) * ph; };
  std::string s;
  s += fmt::format(
      "<text x='{:.1f}' y='{:.1f}' font-size='14' text-anchor='middle' "
      "font-weight='bold'>{}</text>\n",
      x0 + ml + pw / 2, y0 + 18, detail::xml_escape(title));
  s += fmt::format(
      "<rect x='{:.1f}' y='{:.1f}' width='{:.1f}' height='{:.1f}' fill='none' "
      "stroke='#444'/>\n",
      x0 + ml, y0 + mt, pw, ph);
  for (const double t : detail::nice_ticks(0, top)) {
    s += fmt::format("<line x1='{:.1f}' y1='{:.1f}' x2='{:.1f}' y2='{:.1f}' stroke='#ddd'/>\n",
                     x0 + ml, Y(t), x0 + ml + pw, Y(t));
    s += fmt::format("<text x='{:.1f}' y='{:.1f}' font-size='11' text-anchor='end'>{:g}</text>\n",
                     x0 + ml - 4, Y(t) + 4, t);
  }
  for (const double t : detail::nice_ticks(lo, hi))
    s +=
        fmt::format("<text x='{:.1f}' y='{:.1f}' font-size='11' text-anchor='middle'>{:g}</text>\n",
                    X(t), y0 + mt + ph + 16, t);
  s += fmt::format("<text x='{:.1f}' y='{:.1f}' font-size='12' text-anchor='middle'>{}</text>\n",
                   x0 + ml + pw / 2, y0 + h - 8, detail::xml_escape(xlabel));
  s += fmt::format(
      "<text x='{:.1f}' y='{:.1f}' font-size='12' text-anchor='middle' "
      "transform='rotate(-90 {:.1f} {:.1f})'>median BER</text>\n",
      x0 + 14, y0 + mt + ph / 2, x0 + 14, y0 + mt + ph / 2);
  for (std::size_t k = 0; k < curves.size(); ++k) {
    const Curve& c = curves[k];
    const char* color = kColors[k % 8];
    std::string pts;
    for (const auto& p : c.points) pts += fmt::format("{:.1f},{:.1f} ", X(p.first), Y(p.second));
    s += fmt::format(
        "<polyline points='{}' fill='none' stroke='{}' stroke-width='2' "
        "stroke-dasharray='{}'/>\n",
        pts, color, kDashes[(k + k / 8) % 8]);
    for (const auto& p : c.points)
      s += fmt::format("<circle cx='{:.1f}' cy='{:.1f}' r='3' fill='{}'/>\n", X(p.first),
                       Y(p.second), color);
    // Legend: rows between the title and the frame.
    const double lx = x0 + ml + legend[k].first, ly = y0 + 36 + kLegendRow * legend[k].second;
    s += fmt::format(
        "<line x1='{:.1f}' y1='{:.1f}' x2='{:.1f}' y2='{:.1f}' stroke='{}' "
        "stroke-width='2' stroke-dasharray='{}'/>\n",
        lx, ly - 4, lx + 22, ly - 4, color, kDashes[(k + k / 8) % 8]);
    s += fmt::format("<text x='{:.1f}' y='{:.1f}' font-size='11'>{}</text>\n", lx + 26, ly,
                     detail::xml_escape(c.name));
  }
  return s;
}

std::string strength_label(const AttackSeries& a) {
  if (a.kind == "none") return "no attack: the watermarked mesh decoded as it is";
  const std::string params = attack_params_label(a.params);
  const std::string with = params.empty() ? "" : " (here " + params + ")";
  for (const auto& [k, meaning] : attack_kinds())
    if (k == a.kind) return meaning + with;
  return a.kind + with;
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

}  // namespace

std::string detail::svg_document(double w, double h, const std::string& body) {
  return fmt::format(
      "<?xml version='1.0' encoding='UTF-8'?>\n<svg xmlns='http://www.w3.org/2000/svg' "
      "width='{0:.0f}' height='{1:.0f}' viewBox='0 0 {0:.0f} {1:.0f}' "
      "font-family='DejaVu Sans, Helvetica, Arial, sans-serif'>\n<rect width='100%' height='100%' "
      "fill='white'/>\n{2}</svg>\n",
      w, h, body);
}

bool detail::write_figure(const std::string& out, const std::string& name, const std::string& svg) {
  const fs::path dir(out), svg_path = dir / (name + ".svg");
  write_file_atomically(svg_path.string(), svg);
  if (std::system("command -v rsvg-convert >/dev/null 2>&1") != 0) return false;
  const fs::path png = dir / (name + ".png"), tmp = dir / (name + ".png.tmp");
  const std::string cmd =
      fmt::format("rsvg-convert -f png -o '{}' '{}' 2>/dev/null", tmp.string(), svg_path.string());
  if (std::system(cmd.c_str()) != 0) return false;
  fs::rename(tmp, png);
  return true;
}

std::string write_campaign_report(const std::string& out_dir, const CampaignConfig& c,
                                  const std::vector<CalibrationRecord>& calibrations,
                                  const std::vector<TrialRow>& rows, double wall_seconds) {
  if (c.trace) return detail::write_trace_report(out_dir, c, calibrations, rows, wall_seconds);
  const fs::path dir(out_dir);
  const std::vector<SummaryRow> summary = summarize(c, rows);
  std::string csv = "variant,attack,attack_strength,median_ber,mean_ber,trials,protocol,excluded\n";
  auto quote = [](const std::string& t) { return fmt::format("\"{}\"", t); };
  for (const SummaryRow& s : summary)
    csv += fmt::format("{},{},{},{},{},{},{},{}\n", s.variant, quote(s.attack), s.attack_strength,
                       s.median_ber, s.mean_ber, s.trials, s.protocol, s.excluded);
  write_file_atomically((dir / "summary.csv").string(), csv);
  const std::vector<Column> columns = columns_of(c);
  auto lookup = [&](const Column& col, const std::string& a, double x) -> const SummaryRow* {
    for (const SummaryRow& s : summary)
      if (s.protocol == col.protocol && s.variant == col.variant && s.attack == a &&
          s.attack_strength == x)
        return &s;
    return nullptr;
  };

  // Figures: one per attack with more than one strength (a curve per variant), a panel figure
  // of them all, and the paper's Figs. 1 and 2 (its variants, its five attacks) when the
  // campaign has them.
  std::vector<const AttackSeries*> plotted;
  for (const AttackSeries& a : c.attacks)
    if (a.kind != "none" && a.strengths.size() > 1) plotted.push_back(&a);
  auto curves_of = [&](const AttackSeries& a, const std::vector<std::string>& variants) {
    std::vector<Curve> curves;
    std::vector<double> xs = a.strengths;
    std::sort(xs.begin(), xs.end());
    for (const Column& col : columns) {
      if (std::find(variants.begin(), variants.end(), col.variant) == variants.end()) continue;
      Curve curve{col.name, {}};
      for (const double x : xs)
        if (const SummaryRow* s = lookup(col, series_label(a), x))
          curve.points.emplace_back(x, s->median_ber);
      curves.push_back(curve);
    }
    return curves;
  };
  const double pw = 420, ph = 300;
  bool png = false;
  // A grid of panels, three per row; returns the file's name, or "" when nothing to plot.
  auto grid = [&](const std::string& name, const std::vector<const AttackSeries*>& attacks,
                  const std::vector<std::string>& variants) -> std::string {
    if (attacks.empty()) return "";
    std::string panels;
    double extra = 0;  // every panel's legend as tall as the tallest
    for (const AttackSeries* a : attacks)
      extra = std::max(extra, legend_extra(curves_of(*a, variants), pw));
    for (std::size_t i = 0; i < attacks.size(); ++i) {
      const std::vector<Curve> curves = curves_of(*attacks[i], variants);
      panels +=
          panel((i % 3) * pw, (i / 3) * (ph + extra), pw, ph + extra - legend_extra(curves, pw),
                fmt::format("({}) {}", char('a' + i), series_label(*attacks[i])),
                attacks[i]->kind + " strength", curves);
    }
    const std::size_t cols = std::min<std::size_t>(3, attacks.size());
    png |= write_figure(dir, name,
                        svg_document(cols * pw, ((attacks.size() + 2) / 3) * (ph + extra), panels));
    return name;
  };
  std::string md_figures;
  for (std::size_t i = 0; i < plotted.size(); ++i) {
    const AttackSeries& a = *plotted[i];
    const std::vector<Curve> curves = curves_of(a, c.variants);
    png |=
        write_figure(dir, "figure-" + file_slug(series_label(a)),
                     svg_document(pw, ph + legend_extra(curves, pw),
                                  panel(0, 0, pw, ph, series_label(a), strength_label(a), curves)));
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

  // The report.
  std::string md = fmt::format("# Campaign `{}`\n\n", c.name);
  md += fmt::format(
      "Configuration `{}`: {} models, variants {}, {} bits, {} payloads, {} draws for random "
      "attacks, seed {}. {} trials in {:.1f} s of wall time (all runs of the campaign).\n\n",
      c.source, c.models.size(), fmt::join(c.variants, ", "), c.bits, c.payloads, c.draws, c.seed,
      rows.size(), wall_seconds);
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
  md += "## Calibrated strengths\n\nalpha (vertex RMS % of the diagonal, MSDM)\n\n| model |";
  for (const Column& col : columns) md += " " + col.name + " |";
  md += "\n| --- |";
  for (std::size_t k = 0; k < columns.size(); ++k) md += " ---: |";
  md += "\n";
  for (const CampaignModel& m : c.models) {
    md += "| " + m.name + " |";
    for (const Column& col : columns) {
      auto it = std::find_if(calibrations.begin(), calibrations.end(), [&](const auto& r) {
        return r.model == m.name && r.variant == col.variant && r.protocol == col.protocol;
      });
      if (it == calibrations.end())
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

  md +=
      "\n## Distortion and time per variant\n\nMedians over the embeddings (one per model "
      "and payload).\n\n| variant | alpha | RMS % | MSDM | embedding s | failed |\n"
      "| --- | ---: | ---: | ---: | ---: | ---: |\n";
  for (const Column& col : columns) {
    std::vector<double> a, r, m, t;
    int failed = 0;
    for (const TrialRow& row : rows)
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

  md +=
      "\n## Median bit error rate\n\nOver models, payloads and draws, of the trials that "
      "measured a mark. " +
      left_out(rows) + "\n\n";
  md += md_figures + "\n";
  for (const AttackSeries& a : c.attacks) {
    md += fmt::format("### {}\n\n{}\n\n| strength |", series_label(a), strength_label(a));
    for (const Column& col : columns) md += " " + col.name + " |";
    md += "\n| ---: |";
    for (std::size_t k = 0; k < columns.size(); ++k) md += " ---: |";
    md += "\n";
    for (const double x : a.strengths) {
      md += fmt::format("| {:g} |", x);
      for (const Column& col : columns) {
        const SummaryRow* s = lookup(col, series_label(a), x);
        md += s ? fmt::format(" {:.3f} |", s->median_ber) : std::string(" - |");
      }
      md += "\n";
    }
    md += "\n";
  }
  // Table III: Loop subdivision, one iteration.
  if (lookup(columns[0], "loop", 1)) {
    md +=
        "## Loop subdivision, one iteration (the paper's Table III)\n\n| variant | median BER |\n"
        "| --- | ---: |\n";
    for (const Column& col : columns)
      if (const SummaryRow* s = lookup(col, "loop", 1))
        md += fmt::format("| {} | {:.3f} |\n", col.name, s->median_ber);
    md += "\n";
  }
  md += detail::published_comparison(c, summary);
  md +=
      "## Time per trial\n\nMedian seconds of the attack and of the blind extraction, per "
      "attack.\n\n| attack | attack s | extraction s | trials |\n| --- | ---: | ---: | ---: |\n";
  for (const AttackSeries& a : c.attacks) {
    std::vector<double> at, xt;
    for (const TrialRow& row : rows)
      if (row.attack == series_label(a) && row.status == "ok")
        at.push_back(row.attack_seconds), xt.push_back(row.extract_seconds);
    md += fmt::format("| {} | {:.4f} | {:.5f} | {} |\n", series_label(a), median(at), median(xt),
                      at.size());
  }
  md += fmt::format(
      "\nFiles: `rows.csv` and `rows.jsonl` (one row per trial), `summary.csv`, "
      "`calibration.jsonl`, figures as SVG{}.\n",
      png ? " and PNG" : " (PNG needs rsvg-convert from librsvg2-bin)");
  const std::string path = (dir / "report.md").string();
  write_file_atomically(path, md);
  return path;
}

}  // namespace meshmark
