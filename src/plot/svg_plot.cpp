// SVG line plots: panels with a frame, ticks, labels, a wrapping legend and curves.

#include "plot/svg_plot.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "plot/svg_markup.h"

namespace meshmark::detail {

namespace {

const char* kColors[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd",
                         "#ff7f0e", "#8c564b", "#e377c2", "#17becf"};
const char* kDashes[] = {"", "6,3", "2,3", "8,3,2,3", "", "6,3", "2,3", "8,3,2,3"};

// The legend's entries (a line sample and the curve's name) flow left to right between the
// title and the frame, wrapping at the frame's width: each entry's (x offset, row).
constexpr double kLegendRow = 14, kLegendLeft = 56, kLegendRight = 12;
std::vector<std::pair<double, int>> legend_layout(const std::vector<PlotCurve>& curves, double w) {
  std::vector<std::pair<double, int>> at;
  double x = 0;
  int row = 0;
  for (const PlotCurve& c : curves) {
    const double width = 30 + 6.2 * static_cast<double>(c.name.size());  // 11 px text
    if (x > 0 && x + width > w - kLegendLeft - kLegendRight) x = 0, ++row;
    at.emplace_back(x, row);
    x += width + 10;
  }
  return at;
}

}  // namespace

double plot_legend_extra(const std::vector<PlotCurve>& curves, double w) {
  const auto at = legend_layout(curves, w);
  return at.empty() ? 0 : kLegendRow * at.back().second;
}

std::string plot_panel(double x0, double y0, double w, double h, const PlotAxes& axes,
                       const std::vector<PlotCurve>& curves) {
  double lo = INFINITY, hi = -INFINITY;
  for (const PlotCurve& c : curves)
    for (const auto& p : c.points) lo = std::min(lo, p.first), hi = std::max(hi, p.first);
  if (!std::isfinite(lo)) lo = 0, hi = 1;
  if (hi == lo) lo -= 0.5, hi += 0.5;
  const auto legend = legend_layout(curves, w);
  const double extra = plot_legend_extra(curves, w);
  h += extra;
  const double ml = kLegendLeft, mr = kLegendRight, mt = 46 + extra, mb = 44;
  const double pw = w - ml - mr, ph = h - mt - mb;
  auto X = [&](double x) { return x0 + ml + (x - lo) / (hi - lo) * pw; };
  double top = axes.y_top;  // wider if a value lies above it
  for (const PlotCurve& c : curves)
    for (const auto& p : c.points) top = std::max(top, std::ceil(p.second * 10) / 10);
  auto Y = [&](double y) { return y0 + mt + (1 - y / top) * ph; };
  std::string s;
  s += fmt::format(
      "<text x='{:.1f}' y='{:.1f}' font-size='14' text-anchor='middle' "
      "font-weight='bold'>{}</text>\n",
      x0 + ml + pw / 2, y0 + 18, xml_escape(axes.title));
  s += fmt::format(
      "<rect x='{:.1f}' y='{:.1f}' width='{:.1f}' height='{:.1f}' fill='none' "
      "stroke='#444'/>\n",
      x0 + ml, y0 + mt, pw, ph);
  for (const double t : nice_ticks(0, top)) {
    s += fmt::format("<line x1='{:.1f}' y1='{:.1f}' x2='{:.1f}' y2='{:.1f}' stroke='#ddd'/>\n",
                     x0 + ml, Y(t), x0 + ml + pw, Y(t));
    s += fmt::format("<text x='{:.1f}' y='{:.1f}' font-size='11' text-anchor='end'>{:g}</text>\n",
                     x0 + ml - 4, Y(t) + 4, t);
  }
  for (const double t : nice_ticks(lo, hi))
    s +=
        fmt::format("<text x='{:.1f}' y='{:.1f}' font-size='11' text-anchor='middle'>{:g}</text>\n",
                    X(t), y0 + mt + ph + 16, t);
  s += fmt::format("<text x='{:.1f}' y='{:.1f}' font-size='12' text-anchor='middle'>{}</text>\n",
                   x0 + ml + pw / 2, y0 + h - 8, xml_escape(axes.x_label));
  s += fmt::format(
      "<text x='{:.1f}' y='{:.1f}' font-size='12' text-anchor='middle' "
      "transform='rotate(-90 {:.1f} {:.1f})'>{}</text>\n",
      x0 + 14, y0 + mt + ph / 2, x0 + 14, y0 + mt + ph / 2, xml_escape(axes.y_label));
  for (std::size_t k = 0; k < curves.size(); ++k) {
    const PlotCurve& c = curves[k];
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
                     xml_escape(c.name));
  }
  return s;
}

std::string svg_document(double w, double h, const std::string& body) {
  return fmt::format(
      "<?xml version='1.0' encoding='UTF-8'?>\n<svg xmlns='http://www.w3.org/2000/svg' "
      "width='{0:.0f}' height='{1:.0f}' viewBox='0 0 {0:.0f} {1:.0f}' "
      "font-family='DejaVu Sans, Helvetica, Arial, sans-serif'>\n<rect width='100%' height='100%' "
      "fill='white'/>\n{2}</svg>\n",
      w, h, body);
}

}  // namespace meshmark::detail
