// Trace mode's report: every wrong outcome first, the rates of right / none / wrong per attack
// and strength for trace beside the blind decoder (a table and a bar figure), per model, and
// the trials trace did not name.

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "campaign/campaign_internal.h"
#include "campaign/campaign_parts.h"
#include "meshmark/campaign/campaign.h"
#include "meshmark/forensics/fingerprint.h"
#include "meshmark/forensics/trace.h"
#include "meshmark/io/io.h"
#include "plot/svg_markup.h"
#include "plot/svg_plot.h"
#include "plot/svg_png.h"

namespace meshmark::detail {

namespace fs = std::filesystem;

namespace {

std::string percent(int n, int of) {
  return of > 0 ? fmt::format("{:.1f} %", 100.0 * n / of) : "-";
}

// The coalitions, re-markings and innocent leaks of the campaign, for the report's first
// paragraph ("" without).
std::string coalitions_text(const CampaignConfig& c) {
  std::vector<std::string> names, remarks;
  for (const CampaignCoalition& k : c.coalitions) names.push_back(coalition_label(k));
  for (const CampaignRemark& r : c.remarks) remarks.push_back(remark_label(r));
  std::string text =
      names.empty() ? ""
                    : fmt::format(
                          "; every attack also on the leaks merged by coalitions of consecutive "
                          "IDs' copies ({}; unequal weights and splice regions drawn per trial)",
                          fmt::join(names, ", "));
  if (!remarks.empty())
    text += fmt::format(
        "; every attack also on the leaker's copy re-marked with meshmark by whoever leaks it "
        "({}; another ID drawn per leaker, the default strength unless given; under another key "
        "with that key's fingerprint too)",
        fmt::join(remarks, ", "));
  std::vector<std::string> innocents;
  for (const CampaignInnocent i : c.innocents) innocents.push_back(innocent_label(i));
  if (!innocents.empty())
    text += fmt::format(
        "; every attack also on leaks that no candidate leaked, where naming anyone is wrong ({})",
        fmt::join(innocents, "; "));
  return text;
}

// Two stacked bars per summary row (trace, blind): right green, none grey, wrong red.
std::string outcome_figure(const std::vector<TraceSummaryRow>& summary) {
  const double label = 250, bars = 520, row_h = 34, top = 56, w = label + bars + 30;
  const double h = top + row_h * summary.size() + 30;
  std::string s = fmt::format(
      "<text x='{:.0f}' y='20' font-size='15' font-weight='bold' text-anchor='middle'>Outcomes "
      "per attack: trace (upper bar) and blind decoder (lower bar)</text>\n",
      w / 2);
  const char* colors[] = {"#2ca02c", "#bbbbbb", "#d62728"};
  const char* names[] = {"right", "none", "wrong (an innocent named)"};
  for (int k = 0; k < 3; ++k)
    s += fmt::format(
        "<rect x='{0:.0f}' y='32' width='12' height='12' fill='{1}'/><text x='{2:.0f}' y='43' "
        "font-size='12'>{3}</text>\n",
        label + 150 * k, colors[k], label + 150 * k + 16, names[k]);
  for (std::size_t i = 0; i < summary.size(); ++i) {
    const TraceSummaryRow& r = summary[i];
    const double y = top + row_h * i;
    s += fmt::format("<text x='{:.0f}' y='{:.1f}' font-size='11' text-anchor='end'>{}</text>\n",
                     label - 8, y + 17,
                     xml_escape(trace_attack_label(r.attack, r.attack_strength, r.coalition)));
    const int counts[2][3] = {{r.trace_right, r.trace_none, r.trace_wrong},
                              {r.blind_right, r.blind_none, r.blind_wrong}};
    for (int b = 0; b < 2; ++b) {
      double x = label;
      for (int k = 0; k < 3; ++k) {
        const double width = r.trials > 0 ? bars * counts[b][k] / r.trials : 0;
        if (width > 0)
          s += fmt::format("<rect x='{:.1f}' y='{:.1f}' width='{:.1f}' height='13' fill='{}'/>\n",
                           x, y + 3 + 14 * b, width, colors[k]);
        x += width;
      }
    }
    s += fmt::format("<text x='{:.0f}' y='{:.1f}' font-size='10'>{}</text>\n", label + bars + 4,
                     y + 17, r.trials);
  }
  for (const double t : {0.0, 0.25, 0.5, 0.75, 1.0})
    s += fmt::format(
        "<text x='{:.1f}' y='{:.1f}' font-size='10' text-anchor='middle'>{:g} %</text>\n",
        label + bars * t, h - 10, 100 * t);
  return svg_document(w, h, s);
}

// The rates table of the summary.
std::string rates_table(const std::vector<TraceSummaryRow>& summary) {
  std::string md =
      "| attack | trials | trace right | trace none | trace wrong | every leaker named | blind "
      "right | blind none | blind wrong | worst corrected p (trace right) | trace s (median) | "
      "innocents scored | best innocent's corrected p |\n"
      "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: "
      "|\n";
  for (const TraceSummaryRow& r : summary)
    md += fmt::format(
        "| {} | {} | {} | {} | {}{} | {} | {} | {} | {}{} | {} | {:.2f} | {} | {} |\n",
        trace_attack_label(r.attack, r.attack_strength, r.coalition), r.trials,
        percent(r.trace_right, r.trials), percent(r.trace_none, r.trials),
        r.trace_wrong ? "**" : "", percent(r.trace_wrong, r.trials), percent(r.trace_all, r.trials),
        percent(r.blind_right, r.trials), percent(r.blind_none, r.trials),
        r.blind_wrong ? "**" : "", percent(r.blind_wrong, r.trials),
        r.trace_right ? fmt::format("{:.2g}", r.worst_right_p) : "-", r.median_trace_seconds,
        r.innocents, r.innocents > 0 ? fmt::format("{:.2g}", r.innocent_p) : "-");
  return md;
}

// Per model and variant: strength, distortion of the leaker's copy, and the overall rates.
std::string model_table(const CampaignConfig& c, const std::vector<TrialRow>& rows) {
  std::string md =
      "| model | variant | vertices | alpha | RMS % | MSDM | trials | trace right | blind right "
      "| trace wrong | blind wrong |\n| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | "
      "---: | ---: | ---: |\n";
  for (const CampaignModel& m : c.models)
    for (const std::string& v : c.variants) {
      int n = 0, tr = 0, br = 0, tw = 0, bw = 0, vertices = 0;
      double alpha = 0, rms = 0, msdm = 0;
      for (const TrialRow& r : rows) {
        if (r.model != m.name || r.variant != v) continue;
        if (r.attack == "none" && r.colluders == 1 && r.payload == 0)
          vertices = r.vertices, alpha = r.strength, rms = r.rms_percent, msdm = r.msdm;
        if (r.status != "ok") continue;  // did not run: no outcome (Failed trials)
        ++n, tr += detail::outcome_is(r.trace_outcome, TraceOutcome::Right),
            br += detail::outcome_is(r.blind_outcome, TraceOutcome::Right);
        tw += detail::outcome_is(r.trace_outcome, TraceOutcome::Wrong),
            bw += detail::outcome_is(r.blind_outcome, TraceOutcome::Wrong);
      }
      md += fmt::format("| {} | {} | {} | {:.4f} | {:.4f} | {:.4f} | {} | {} | {} | {} | {} |\n",
                        m.name, v, vertices, alpha, rms, msdm, n, percent(tr, n), percent(br, n),
                        tw, bw);
    }
  return md;
}

// Trace's right count per attack (rows) and model (columns), over variants, payloads, draws.
std::string right_by_model(const CampaignConfig& c, const std::vector<TraceSummaryRow>& summary,
                           const std::vector<TrialRow>& rows) {
  std::string md = "| attack |";
  for (const CampaignModel& m : c.models) md += " " + m.name + " |";
  md += "\n| --- |";
  for (std::size_t k = 0; k < c.models.size(); ++k) md += " ---: |";
  md += "\n";
  for (const TraceSummaryRow& s : summary) {
    md += "| " + trace_attack_label(s.attack, s.attack_strength, s.coalition) + " |";
    for (const CampaignModel& m : c.models) {
      int right = 0, n = 0;
      for (const TrialRow& r : rows)
        if (r.model == m.name && r.attack == s.attack && r.attack_strength == s.attack_strength &&
            r.coalition == s.coalition && r.status == "ok")
          ++n, right += detail::outcome_is(r.trace_outcome, TraceOutcome::Right);
      md += fmt::format(" {}/{} |", right, n);
    }
    md += "\n";
  }
  return md;
}

// One line per listed trial.
std::string trial_lines(const std::vector<const TrialRow*>& trials, std::size_t most) {
  std::string md =
      "| trial | leakers | trace | named | best corrected p | blind | status |\n"
      "| --- | --- | --- | --- | ---: | --- | --- |\n";
  for (std::size_t i = 0; i < trials.size() && i < most; ++i) {
    const TrialRow& r = *trials[i];
    md += fmt::format("| `{}` | {} | {} ({}) | {} | {:.2g} | {} ({}) | {} |\n", r.key, r.leakers,
                      r.trace_outcome, r.trace_status, r.trace_named.empty() ? "-" : r.trace_named,
                      r.trace_p, r.blind_outcome, r.blind_id, r.status);
  }
  if (trials.size() > most) md += fmt::format("\n... and {} more.\n", trials.size() - most);
  return md;
}

}  // namespace

std::string write_trace_report(const std::string& out_dir, const CampaignConfig& c,
                               const std::vector<CalibrationRecord>& calibrations,
                               const std::vector<TrialRow>& rows, double wall_seconds) {
  (void)calibrations;  // the strength of each trial is in its row
  const fs::path dir(out_dir);
  const std::vector<TraceSummaryRow> summary = summarize_trace(c, rows);
  std::string csv =
      "attack,attack_strength,colluders,coalition,trials,trace_right,trace_none,trace_wrong,"
      "trace_all_named,blind_right,blind_none,blind_wrong,worst_right_p,median_trace_seconds,"
      "innocents,innocent_p,failed\n";
  for (const TraceSummaryRow& r : summary)
    csv += fmt::format("\"{}\",{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n", r.attack,
                       r.attack_strength, r.colluders, r.coalition, r.trials, r.trace_right,
                       r.trace_none, r.trace_wrong, r.trace_all, r.blind_right, r.blind_none,
                       r.blind_wrong, r.worst_right_p, r.median_trace_seconds, r.innocents,
                       r.innocent_p, r.failed);
  write_file_atomically((dir / "summary.csv").string(), csv);
  const bool png = write_figure(out_dir, "figure-trace", outcome_figure(summary));

  std::vector<const TrialRow*> wrong, unnamed, failed;
  for (const TrialRow& r : rows) {
    if (detail::outcome_is(r.trace_outcome, TraceOutcome::Wrong) ||
        detail::outcome_is(r.blind_outcome, TraceOutcome::Wrong))
      wrong.push_back(&r);
    // An innocent leak (no colluder) is right to name nobody: not listed as a miss.
    if (detail::outcome_is(r.trace_outcome, TraceOutcome::None) && r.colluders > 0 &&
        r.status == "ok")
      unnamed.push_back(&r);
    if (r.status != "ok") failed.push_back(&r);
  }
  std::string md = fmt::format("# Campaign `{}` (trace)\n\n", c.name);
  md += fmt::format(
      "Configuration `{}`: {} models, variants {}, {} bits with 32-bit coded IDs under one key, "
      "{} copies issued per model and variant to consecutive IDs from {} (registry records; only "
      "the leakers' copies are embedded), {} leakers per model and variant (payloads), {} draws "
      "for random attacks{}, {}, strength spread {}{}, seed {}. Each attacked leak is traced with "
      "the original against every issued copy (threshold 1e-6 on the Bonferroni-corrected p) "
      "and decoded blind (read_id). {} trials in {:.1f} s of wall time (all runs).\n\n",
      c.source, c.models.size(), fmt::join(c.variants, ", "), c.bits, c.copies,
      campaign_first_id(c), c.payloads, c.draws, coalitions_text(c),
      c.calibrate ? "calibrated strengths" : fmt::format("alpha {}", c.strength), c.spread,
      c.fingerprint
          ? fmt::format(
                ", every copy with the fingerprint at an RMS of {:g} % of the diagonal "
                "(raised up to {:g} times that on originals of fewer than {} counted vertices; "
                "mark format {}), read over the whole surface{}",
                100 * c.fingerprint_rms, kFingerprintMaxBoost, kFingerprintFullVertices,
                kFingerprintMarkFormat,
                c.fingerprint_regions.empty() ? ""
                                              : fmt::format(" and over regions (partitions of {})",
                                                            fmt::join(c.fingerprint_regions, ", ")))
          : "",
      c.seed, rows.size(), wall_seconds);
  md +=
      "Right: every buyer named leaked (for a coalition, at least one colluder named); none: "
      "nobody named; wrong: an innocent named. Every leaker named: right, and all the "
      "coalition's colluders named.\n\n";
  std::int64_t innocents = 0;
  double innocent_p = 1;
  std::size_t counted = 0;  // trials that recorded their innocents (not rows of older builds)
  for (const TrialRow& r : rows)
    if (r.innocents > 0)
      ++counted, innocents += r.innocents, innocent_p = std::min(innocent_p, r.innocent_p);
  const std::string innocents_text =
      innocents > 0 ? fmt::format(
                          "In {} of the {} trials, trace scored {} innocent candidates (every "
                          "candidate but the leakers); the smallest corrected p among them was "
                          "{:.2g}, against the threshold of {:g}.\n\n",
                          counted, rows.size(), innocents, innocent_p, TraceOptions{}.threshold)
                    : "";
  if (wrong.empty())
    md += fmt::format(
        "## Wrong outcomes: none\n\nIn {} trials trace never named an innocent, and the blind "
        "decoder never decoded an innocent's ID. {}",
        rows.size(), innocents_text.empty() ? "\n\n" : innocents_text);
  else
    md += fmt::format("## WRONG OUTCOMES: {} trials named an innocent\n\n{}{}\n", wrong.size(),
                      innocents_text, trial_lines(wrong, 200));
  md += "## Right / none / wrong per attack, trace beside the blind decoder\n\n";
  md += "![outcomes](figure-trace.svg)\n\n" + rates_table(summary) + "\n";
  md += "## Per model and variant\n\nThe leaker's copy of payload 0 as issued.\n\n" +
        model_table(c, rows) + "\n";
  md += "Trials where trace named the leaker (right / trials), per attack and model:\n\n" +
        right_by_model(c, summary, rows) + "\n";
  md += fmt::format("## Trials trace named nobody ({}{})\n\n", unnamed.size(),
                    c.innocents.empty() ? "" : ", innocent leaks left out");
  md += unnamed.empty() ? "None.\n\n" : trial_lines(unnamed, 100) + "\n";
  if (!failed.empty())
    md += fmt::format(
        "## Failed trials ({})\n\nThese did not run (their status says why): they are left out "
        "of the counts above (`failed` in summary.csv).\n\n{}\n",
        failed.size(), trial_lines(failed, 50));
  md += fmt::format(
      "Files: `rows.csv` and `rows.jsonl` (one row per trial, both outcomes), `summary.csv`, "
      "`figure-trace.svg`{}.\n",
      png ? " and `.png`" : "");
  std::string path = (dir / "report.md").string();
  write_file_atomically(path, md);
  return path;
}

}  // namespace meshmark::detail
