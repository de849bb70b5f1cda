#include "plot/svg_markup.h"

#include <cmath>

#include "meshmark/core/error.h"

namespace meshmark::detail {

std::string xml_escape(std::string_view raw) {
  const std::string text = printable(raw);  // no control or bidirectional-text bytes
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&#39;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

std::vector<double> nice_ticks(double lo, double hi) {
  if (!(hi > lo)) return {lo};
  const double raw = (hi - lo) / 5;
  const double mag = std::pow(10, std::floor(std::log10(raw)));
  double step = mag;
  for (const double f : {1.0, 2.0, 2.5, 5.0, 10.0})
    if (f * mag >= raw) {
      step = f * mag;
      break;
    }
  std::vector<double> t;
  for (double x = std::ceil(lo / step - 1e-9) * step; x <= hi + 1e-9 * step; x += step)
    t.push_back(std::abs(x) < 1e-12 * step ? 0.0 : x);
  return t;
}

}  // namespace meshmark::detail
