#pragma once
// Internal: SVG line plots (the campaign figures): panels of curves with axes, ticks and a
// legend, and the document around them.

#include <string>
#include <utility>
#include <vector>

namespace meshmark::detail {

/// A named curve: (x, y) points in the order they are joined.
struct PlotCurve {
  std::string name;
  std::vector<std::pair<double, double>> points;
};

/// What a panel shows beside its curves.
struct PlotAxes {
  std::string title, x_label, y_label;
  /// The y axis runs from 0 to y_top, raised to the next tenth above the largest y plotted.
  double y_top = 0.5;
};

/// The height a panel of width w (pixels) needs beyond its own for a legend of more than one
/// row (the legend's entries wrap at the frame's width).
double plot_legend_extra(const std::vector<PlotCurve>& curves, double w);

/// SVG elements of one panel at (x0, y0), w x h pixels plus plot_legend_extra(curves, w): the
/// title, the legend below it, the frame with ticks and labels, and the curves (a color and a
/// dash pattern each, a dot per point). x runs over the points' range.
std::string plot_panel(double x0, double y0, double w, double h, const PlotAxes& axes,
                       const std::vector<PlotCurve>& curves);

/// An SVG document of w x h pixels around body, on white.
std::string svg_document(double w, double h, const std::string& body);

}  // namespace meshmark::detail
