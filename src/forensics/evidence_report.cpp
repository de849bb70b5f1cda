// The HTML evidence report of a trace: views of the registered leak over the original, the
// score distribution, the per-bit evidence and the tables, all inline (SVG and CSS).

#include "meshmark/forensics/evidence_report.h"

#include <fmt/format.h>

#include <filesystem>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <set>
#include <unordered_map>

#include "meshmark/core/error.h"
#include "meshmark/forensics/registry.h"
#include "meshmark/io/io.h"
#include "metrics/closest_point.h"
#include "plot/svg_markup.h"

namespace meshmark {

using detail::xml_escape;

namespace {

// ---------------------------------------------------------------- simplification for display

// One clustering of the referenced vertices on a grid of g cells along the longest side.
// values (optional, one per vertex of V): averaged over each cluster into *averaged.
Mesh cluster_once(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F, int g,
                  const Eigen::VectorXd* values = nullptr, Eigen::VectorXd* averaged = nullptr) {
  const std::vector<std::uint8_t> used = referenced_vertices(F, V.rows());
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(INFINITY), hi = -lo;
  for (Eigen::Index i = 0; i < V.rows(); ++i)
    if (used[i]) lo = lo.cwiseMin(V.row(i).transpose()), hi = hi.cwiseMax(V.row(i).transpose());
  const double cell = std::max((hi - lo).maxCoeff(), 1e-300) / g;
  std::unordered_map<std::int64_t, int> index;  // cell -> new vertex
  std::vector<int> of(static_cast<std::size_t>(V.rows()), -1);
  std::vector<Eigen::Vector3d> sum;
  std::vector<double> value_sum;
  std::vector<int> count;
  for (Eigen::Index i = 0; i < V.rows(); ++i) {
    if (!used[i]) continue;
    std::array<std::int64_t, 3> c{};
    for (int a = 0; a < 3; ++a)
      c[a] = std::clamp<std::int64_t>(static_cast<std::int64_t>((V(i, a) - lo(a)) / cell), 0, g);
    const std::int64_t key = c[0] + (g + 1) * (c[1] + (g + 1) * c[2]);
    const auto [it, fresh] = index.emplace(key, static_cast<int>(sum.size()));
    if (fresh)
      sum.emplace_back(Eigen::Vector3d::Zero()), count.push_back(0), value_sum.push_back(0);
    of[i] = it->second;
    sum[it->second] += V.row(i).transpose();
    if (values) value_sum[it->second] += (*values)[i];
    ++count[it->second];
  }
  std::set<std::array<int, 3>> faces;  // rotated so that the smallest index comes first
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    std::array<int, 3> t{of[F(f, 0)], of[F(f, 1)], of[F(f, 2)]};
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) continue;
    std::rotate(t.begin(), std::min_element(t.begin(), t.end()), t.end());
    faces.insert(t);
  }
  Eigen::MatrixX3d CV(static_cast<Eigen::Index>(sum.size()), 3);
  for (std::size_t k = 0; k < sum.size(); ++k) CV.row(k) = sum[k].transpose() / count[k];
  if (values && averaged) {
    averaged->resize(static_cast<Eigen::Index>(sum.size()));
    for (std::size_t k = 0; k < sum.size(); ++k) (*averaged)[k] = value_sum[k] / count[k];
  }
  Eigen::MatrixX3i CF(static_cast<Eigen::Index>(faces.size()), 3);
  Eigen::Index k = 0;
  for (const auto& t : faces) CF.row(k++) << t[0], t[1], t[2];
  return make_mesh(std::move(CV), std::move(CF));
}

// ---------------------------------------------------------------- mesh views

constexpr char kStyle[] = R"(
body{font-family:"DejaVu Sans",Helvetica,Arial,sans-serif;margin:24px;color:#222;max-width:1200px}
h1{font-size:22px;margin:0 0 4px}h2{font-size:17px;margin:26px 0 8px;border-bottom:1px solid #ccc}
.status{font-size:16px;padding:8px 12px;border-radius:4px;margin:10px 0}
.named{background:#fde2e1;border:1px solid #d62728}.none{background:#e8f0fb;border:1px solid #1f77b4}
table{border-collapse:collapse;font-size:13px;margin:6px 0}
td,th{border:1px solid #ccc;padding:3px 8px;text-align:left;vertical-align:top}
th{background:#f2f2f2}td.num{text-align:right;font-variant-numeric:tabular-nums}
.hash{font-family:"DejaVu Sans Mono",monospace;font-size:12px;word-break:break-all}
pre{background:#f6f6f6;border:1px solid #ccc;padding:8px;white-space:pre-wrap;word-break:break-all}
figure{display:inline-block;margin:0 12px 8px 0;vertical-align:top}figcaption{font-size:12px;color:#555}
svg{background:#fff}
.warnings{background:#fff4d6;border:1px solid #c98a00;padding:6px 12px;border-radius:4px;font-size:14px}
@media print{body{margin:0;max-width:none}svg{max-width:100%;height:auto}
figure{width:32%!important;margin:0 1% 8px 0}figure svg{width:100%}h2{break-after:avoid}
figure,table{break-inside:avoid}}
)";

constexpr int kShades = 32;

// CSS classes o0..o31 (the original, opaque, stroked against seams) and l0..l31 (the leak,
// translucent), from dark to light.
std::string shade_classes() {
  std::string s;
  for (int k = 0; k < kShades; ++k) {
    const double t = (k + 0.5) / kShades;
    const int grey = static_cast<int>(70 + 150 * t);
    s += fmt::format(
        ".o{0}{{fill:#{1:02x}{1:02x}{2:02x};stroke:#{1:02x}{1:02x}{2:02x};stroke-width:.6;"
        "stroke-linejoin:round}}\n",
        k, grey, grey + 4);
    s += fmt::format(".l{}{{fill:#{:02x}{:02x}{:02x};fill-opacity:.6}}\n", k,
                     static_cast<int>(110 + 145 * t), static_cast<int>(40 + 110 * t),
                     static_cast<int>(10 + 40 * t));
  }
  return s;
}

struct Triangle {
  double depth;              // larger: nearer the viewer
  std::array<double, 6> xy;  // screen coordinates
  bool leak;
  int shade;
};

// The original's principal axes: the columns of a rotation, by decreasing spread of its
// vertices, each signed so that its largest component is positive (the same mesh gives the
// same views), the third the cross product of the first two.
Eigen::Matrix3d principal_axes(const Eigen::MatrixX3d& V) {
  const Eigen::RowVector3d mean = V.colwise().mean();
  const Eigen::MatrixX3d X = V.rowwise() - mean;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(X.transpose() * X);
  Eigen::Matrix3d A;
  for (int k = 0; k < 2; ++k) {
    Eigen::Vector3d a = es.eigenvectors().col(2 - k);  // eigenvalues ascending
    Eigen::Index at = 0;
    a.cwiseAbs().maxCoeff(&at);
    A.col(k) = a[at] < 0 ? Eigen::Vector3d(-a) : a;
  }
  A.col(2) = A.col(0).cross(A.col(1));
  return A;
}

// One of the three views along the principal axes: which axes run right and up, and the
// rotation from world to camera (rows: right, up, towards the viewer).
struct AxisView {
  Eigen::Matrix3d R;
  const char* caption;
};

std::array<AxisView, 3> axis_views(const Eigen::Matrix3d& A) {
  auto rows = [](const Eigen::Vector3d& x, const Eigen::Vector3d& y, const Eigen::Vector3d& z) {
    Eigen::Matrix3d R;
    R.row(0) = x.transpose(), R.row(1) = y.transpose(), R.row(2) = z.transpose();
    return R;
  };
  return {AxisView{rows(A.col(0), A.col(1), A.col(2)),
                   "principal axes 1 (right) and 2 (up), seen along axis 3"},
          AxisView{rows(A.col(0), A.col(2), -A.col(1)),
                   "principal axes 1 (right) and 3 (up), seen along axis 2"},
          AxisView{rows(A.col(1), A.col(2), A.col(0)),
                   "principal axes 2 (right) and 3 (up), seen along axis 1"}};
}

// The triangles of mesh seen through R (camera coordinates, not yet on screen), shaded.
void add_triangles(const Mesh& m, const Eigen::Matrix3d& R, bool leak, double bias,
                   std::vector<Triangle>& out, std::vector<Eigen::Vector3d>& points) {
  const Eigen::Vector3d light = Eigen::Vector3d(-0.4, 0.5, 1).normalized();
  const Eigen::MatrixX3d C = m.V * R.transpose();
  for (Eigen::Index f = 0; f < m.F.rows(); ++f) {
    const Eigen::Vector3d a = C.row(m.F(f, 0)), b = C.row(m.F(f, 1)), c = C.row(m.F(f, 2));
    const Eigen::Vector3d n = (b - a).cross(c - a);
    const double len = n.norm();
    const double lambert = len > 0 ? std::abs(n.dot(light)) / len : 0;  // two-sided
    Triangle t;
    t.depth = (a.z() + b.z() + c.z()) / 3 + (leak ? bias : 0);
    t.xy = {a.x(), a.y(), b.x(), b.y(), c.x(), c.y()};
    t.leak = leak;
    t.shade = std::min(kShades - 1, static_cast<int>((0.25 + 0.75 * lambert) * kShades));
    out.push_back(t);
    points.insert(points.end(), {a, b, c});  // the view frames what is drawn
  }
}

// A scale bar in a view's lower left corner: a round length in model units, numbered.
std::string scale_bar(double pixels_per_unit, int size) {
  const double target = 0.25 * size / pixels_per_unit;  // about a quarter of the view
  const double p10 = std::pow(10, std::floor(std::log10(target)));
  double length = p10;
  for (const double m : {2.0, 5.0, 10.0})
    if (m * p10 <= target) length = m * p10;
  const double w = length * pixels_per_unit, x = 14, y = size - 14;
  return fmt::format(
      "<path d='M{0} {1}v-5M{0} {1}h{2:.1f}v-5' fill='none' stroke='#222' stroke-width='1.5'/>"
      "<text x='{0}' y='{3}' font-size='12' text-anchor='middle'>0</text><text x='{4:.1f}' "
      "y='{1}' font-size='12'>{5:g} (model units)</text>\n",
      x, y, w, y - 8, x + w + 5, length);
}

// One view: the meshes rotated by R (camera looks along -z), fitted into a size x size square,
// painted far to near, with a numbered scale bar. Each triangle of leak is drawn with the
// class its index gets from leak_class (the leak over the original), or the original alone.
template <typename LeakClass>
std::string mesh_view(const Mesh* original, const Mesh& leak, const Eigen::Matrix3d& R, int size,
                      double diagonal, LeakClass leak_class) {
  std::vector<Triangle> tris;
  std::vector<Eigen::Vector3d> points;
  if (original) add_triangles(*original, R, false, 0, tris, points);
  const std::size_t first_leak = tris.size();
  add_triangles(leak, R, true, 0.01 * diagonal, tris, points);
  std::vector<std::string> classes(tris.size());
  for (std::size_t k = 0; k < tris.size(); ++k)
    classes[k] = k < first_leak ? fmt::format("o{}", tris[k].shade)
                                : leak_class(k - first_leak, tris[k].shade);
  Eigen::Vector2d lo(INFINITY, INFINITY), hi = -lo;
  for (const Eigen::Vector3d& p : points)
    lo = lo.cwiseMin(p.head<2>()), hi = hi.cwiseMax(p.head<2>());
  const double margin = 10, extent = std::max((hi - lo).maxCoeff(), 1e-300);
  const double s = (size - 2 * margin - 24) / extent;  // room for the scale bar below
  const Eigen::Vector2d mid = (lo + hi) / 2;
  std::vector<std::size_t> order(tris.size());
  for (std::size_t k = 0; k < order.size(); ++k) order[k] = k;
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return tris[a].depth < tris[b].depth; });
  std::string svg = fmt::format(
      "<svg xmlns='http://www.w3.org/2000/svg' width='{0}' height='{0}' viewBox='0 0 {0} {0}'>\n"
      "<rect width='100%' height='100%' fill='white' stroke='#ccc'/>\n",
      size);
  auto X = [&](double x) { return size / 2.0 + s * (x - mid.x()); };
  auto Y = [&](double y) { return (size - 24) / 2.0 - s * (y - mid.y()); };
  for (const std::size_t k : order) {
    const Triangle& t = tris[k];
    svg += fmt::format("<path class='{}' d='M{:.1f} {:.1f}L{:.1f} {:.1f}L{:.1f} {:.1f}z'/>\n",
                       classes[k], X(t.xy[0]), Y(t.xy[1]), X(t.xy[2]), Y(t.xy[3]), X(t.xy[4]),
                       Y(t.xy[5]));
  }
  return svg + scale_bar(s, size) + "</svg>\n";
}

// The distance map's colours, d0..d15 from near (dark blue) to far (yellow), viridis-like.
constexpr int kDistanceShades = 16;

std::array<int, 3> distance_colour(double t) {
  static constexpr double stops[5][3] = {
      {68, 1, 84}, {59, 82, 139}, {33, 145, 140}, {94, 201, 98}, {253, 231, 37}};
  const double x = std::clamp(t, 0.0, 1.0) * 4;
  const int k = std::min(3, static_cast<int>(x));
  const double f = x - k;
  std::array<int, 3> c{};
  for (int i = 0; i < 3; ++i)
    c[i] = static_cast<int>(std::lround(stops[k][i] + f * (stops[k + 1][i] - stops[k][i])));
  return c;
}

std::string distance_classes() {
  std::string s;
  for (int k = 0; k < kDistanceShades; ++k) {
    const auto [r, g, b] = distance_colour((k + 0.5) / kDistanceShades);
    s += fmt::format(
        ".d{0}{{fill:#{1:02x}{2:02x}{3:02x};stroke:#{1:02x}{2:02x}{3:02x};"
        "stroke-width:.4}}\n",
        k, r, g, b);
  }
  return s;
}

// The colour bar of the distance map, numbered in % of the original's diagonal, 0 to top.
std::string distance_bar(double top_percent, int width) {
  const double W = width, H = 46, ml = 14, pw = W - 2 * ml;
  std::string s = fmt::format(
      "<svg xmlns='http://www.w3.org/2000/svg' width='{0}' height='{1}' viewBox='0 0 {0} {1}' "
      "font-size='12'>\n",
      W, H);
  for (int k = 0; k < kDistanceShades; ++k)
    s += fmt::format("<rect class='d{}' x='{:.1f}' y='4' width='{:.1f}' height='12'/>\n", k,
                     ml + pw * k / kDistanceShades, pw / kDistanceShades + 0.5);
  for (const double t : detail::nice_ticks(0, top_percent))
    if (t <= top_percent * (1 + 1e-9))
      s += fmt::format(
          "<line x1='{0:.1f}' y1='16' x2='{0:.1f}' y2='20' stroke='#222'/><text x='{0:.1f}' "
          "y='32' text-anchor='middle'>{1:g}</text>\n",
          ml + pw * t / top_percent, t);
  return s + fmt::format(
                 "<text x='{}' y='44' text-anchor='middle'>distance of the leak to the "
                 "original's surface, % of the diagonal</text>\n</svg>\n",
                 ml + pw / 2);
}

// ---------------------------------------------------------------- plots

// A plot's <svg> opening tag and white background, W x H pixels.
std::string plot_begin(double W, double H) {
  return fmt::format(
      "<svg xmlns='http://www.w3.org/2000/svg' width='{0}' height='{1}' viewBox='0 0 {0} {1}' "
      "font-size='12'>\n<rect width='100%' height='100%' fill='white'/>\n",
      W, H);
}

// The frame of a plot area.
std::string plot_frame(double x, double y, double w, double h) {
  return fmt::format("<rect x='{}' y='{}' width='{}' height='{}' fill='none' stroke='#444'/>\n", x,
                     y, w, h);
}

double score_of(const CandidateScore& s) {
  return -std::log10(std::max(s.corrected_p, 1e-300));
}

// Histogram of -log10(corrected p) over every candidate, bar heights on a square-root scale,
// the threshold a dashed line, the named buyers and the runner-up marked.
std::string score_plot(const TraceResult& r, double threshold, bool redact) {
  const double W = 1000, H = 300, ml = 60, mr = 20, mt = 40, mb = 46;
  const double pw = W - ml - mr, ph = H - mt - mb;
  std::string s = plot_begin(W, H);
  if (r.ranking.empty())
    return s + fmt::format("<text x='{}' y='{}'>no candidates</text>\n</svg>\n", ml, H / 2);
  const double line = -std::log10(threshold);
  // Every candidate's score (the ranking may keep only the best), or the ranking's.
  std::vector<double> all(r.log_scores.begin(), r.log_scores.end());
  if (all.empty())
    for (const CandidateScore& c : r.ranking) all.push_back(score_of(c));
  double top = std::max(1.0, 1.15 * line);
  for (const double v : all) top = std::max(top, 1.05 * v);
  const int bins = 50;
  std::vector<int> count(bins, 0);
  for (const double v : all) ++count[std::clamp(static_cast<int>(v / top * bins), 0, bins - 1)];
  const double most = *std::max_element(count.begin(), count.end());
  auto X = [&](double x) { return ml + x / top * pw; };
  auto Y = [&](double n) { return mt + ph - std::sqrt(n / most) * ph; };
  s += plot_frame(ml, mt, pw, ph);
  for (int k = 0; k < bins; ++k)
    if (count[k] > 0)
      s += fmt::format(
          "<rect x='{:.1f}' y='{:.1f}' width='{:.1f}' height='{:.1f}' fill='#7f9fc6'>"
          "<title>{} candidates</title></rect>\n",
          X(k * top / bins), Y(count[k]), pw / bins - 1, mt + ph - Y(count[k]), count[k]);
  for (const double t : detail::nice_ticks(0, top))
    s += fmt::format("<text x='{:.1f}' y='{}' text-anchor='middle'>{:g}</text>\n", X(t),
                     mt + ph + 16, t);
  for (const double n : std::set<double>{1.0, most})
    s +=
        fmt::format("<text x='{}' y='{:.1f}' text-anchor='end'>{:g}</text>\n", ml - 6, Y(n) + 4, n);
  s += fmt::format(
      "<text x='{}' y='{}' text-anchor='middle'>-log10(corrected p-value) of each of the {} "
      "candidates (higher: stronger evidence)</text>\n"
      "<text x='16' y='{}' text-anchor='middle' transform='rotate(-90 16 {})'>candidates "
      "(square-root scale)</text>\n",
      ml + pw / 2, H - 8, all.size(), mt + ph / 2, mt + ph / 2);
  s += fmt::format(
      "<line x1='{0:.1f}' y1='{1}' x2='{0:.1f}' y2='{2}' stroke='#d62728' stroke-width='2' "
      "stroke-dasharray='6,3'/>\n<text x='{3:.1f}' y='{4}' fill='#d62728'>threshold "
      "{5:.3g}</text>\n",
      X(line), mt - 4, mt + ph, X(line) + 4, mt - 8, threshold);
  // Markers: the named (red, labelled) and the best candidate not named (grey).
  std::vector<std::pair<const CandidateScore*, bool>> marks;
  for (std::size_t i = 0; i < r.named.size() && i < 8; ++i) marks.push_back({&r.named[i], true});
  if (r.ranking.size() > r.named.size()) marks.push_back({&r.ranking[r.named.size()], false});
  for (std::size_t i = 0; i < marks.size(); ++i) {
    const auto& [c, named] = marks[i];
    const double x = X(score_of(*c)), y = mt + 14 + 14 * static_cast<double>(i);
    const bool left = x > ml + pw / 2;  // the label on the side with room
    s += fmt::format(
        "<path d='M{0:.1f} {1:.1f}l-5 -9h10z' fill='{2}'/>\n<text x='{3:.1f}' y='{1:.1f}' "
        "text-anchor='{4}' fill='{2}'>{5}ID {6}{7}{8}</text>\n",
        x, y, named ? "#d62728" : "#777", left ? x - 8 : x + 8, left ? "end" : "start",
        redact ? "" : xml_escape(c->copy.buyer) + " (", c->copy.id, redact ? "" : ")",
        named ? "" : ", the best not named");
  }
  return s + "</svg>\n";
}

// Each payload bit: the shift a 0 (red tick) and a 1 (blue tick) would give, joined, and the
// measured shift (a dot coloured by the bit read; grey and hollow when erased).
std::string bit_plot(const std::vector<BitEvidence>& bits) {
  const double W = 1000, H = 220, ml = 60, mr = 20, mt = 12, mb = 36;
  const double pw = W - ml - mr, ph = H - mt - mb;
  std::string s = plot_begin(W, H);
  if (bits.empty())
    return s + fmt::format("<text x='{}' y='{}'>no bits read</text>\n</svg>\n", ml, H / 2);
  double lo = 0, hi = 0;
  for (const BitEvidence& e : bits)
    for (const double v : {e.shift, e.if_one, e.if_zero})
      if (std::isfinite(v)) lo = std::min(lo, v), hi = std::max(hi, v);
  if (hi - lo < 1e-12) lo -= 1, hi += 1;
  const double pad = 0.08 * (hi - lo);
  lo -= pad, hi += pad;
  const double step = pw / static_cast<double>(bits.size());
  auto X = [&](std::size_t j) { return ml + (static_cast<double>(j) + 0.5) * step; };
  auto Y = [&](double v) { return mt + (hi - std::clamp(v, lo, hi)) / (hi - lo) * ph; };
  s += plot_frame(ml, mt, pw, ph);
  for (const double t : detail::nice_ticks(lo, hi))
    s += fmt::format(
        "<line x1='{0}' y1='{1:.1f}' x2='{2}' y2='{1:.1f}' stroke='{3}'/><text x='{4}' "
        "y='{5:.1f}' text-anchor='end'>{6:g}</text>\n",
        ml, Y(t), ml + pw, t == 0 ? "#999" : "#eee", ml - 6, Y(t) + 4, t);
  const double tick = std::max(1.5, std::min(6.0, 0.35 * step));
  for (std::size_t j = 0; j < bits.size(); ++j) {
    const BitEvidence& e = bits[j];
    const double x = X(j);
    const char* dot = e.bit == 1 ? "#1f77b4" : e.bit == 0 ? "#d62728" : "none";
    s += fmt::format(
        "<g><title>bit {}: shift {:.4g}, a 1 {:.4g}, a 0 {:.4g}, {} vertices</title>"
        "<line x1='{x:.1f}' y1='{:.1f}' x2='{x:.1f}' y2='{:.1f}' stroke='#ccc'/>"
        "<line x1='{:.1f}' y1='{one:.1f}' x2='{:.1f}' y2='{one:.1f}' stroke='#1f77b4' "
        "stroke-width='2'/><line x1='{:.1f}' y1='{zero:.1f}' x2='{:.1f}' y2='{zero:.1f}' "
        "stroke='#d62728' stroke-width='2'/><circle cx='{x:.1f}' cy='{:.1f}' r='{:.1f}' "
        "fill='{}' stroke='{}'/></g>\n",
        j, e.shift, e.if_one, e.if_zero, e.vertices, Y(e.if_zero), Y(e.if_one), x - tick, x + tick,
        x - tick, x + tick, Y(e.shift), std::min(3.5, 0.3 * step + 1), dot,
        e.bit > 1 ? "#777" : dot, fmt::arg("x", x), fmt::arg("one", Y(e.if_one)),
        fmt::arg("zero", Y(e.if_zero)));
  }
  const std::size_t every = bits.size() <= 16 ? 1 : bits.size() <= 64 ? 8 : 16;
  for (std::size_t j = 0; j < bits.size(); j += every)
    s += fmt::format("<text x='{:.1f}' y='{}' text-anchor='middle'>{}</text>\n", X(j), mt + ph + 14,
                     j);
  s += fmt::format("<text x='{}' y='{}' text-anchor='middle'>payload bit</text>\n", ml + pw / 2,
                   H - 8);
  return s + "</svg>\n";
}

// ---------------------------------------------------------------- tables

// A buyer's label, or "the buyer of ID N" in a redacted report.
std::string buyer_label(const IssuedCopy& c, bool redact) {
  return redact ? fmt::format("the buyer of ID {}", c.id) : c.buyer;
}

// A path, or its file name alone in a redacted report.
std::string shown_path(const std::string& path, bool redact) {
  return redact ? std::filesystem::path(path).filename().string() : path;
}

std::string row(const std::string& name, const std::string& value_html) {
  return fmt::format("<tr><th>{}</th><td>{}</td></tr>\n", xml_escape(name), value_html);
}

std::string candidate_rows(const TraceResult& r, double threshold, bool redact) {
  std::string s =
      "<table><tr><th>rank</th><th>buyer</th><th>ID</th><th>matching bits</th><th>p-value</th>"
      "<th>corrected p</th><th>copy</th><th></th></tr>\n";
  const std::size_t shown = std::max<std::size_t>(r.named.size() + 1, 5);
  for (std::size_t i = 0; i < r.ranking.size() && i < shown; ++i) {
    const CandidateScore& c = r.ranking[i];
    const bool named = c.corrected_p < threshold;
    s += fmt::format(
        "<tr><td class='num'>{}</td><td>{}</td><td class='num'>{}</td><td class='num'>{} of "
        "{}</td><td class='num'>{:.3g}</td><td class='num'>{:.3g}</td><td>{}</td><td>{}</td>"
        "</tr>\n",
        i + 1, xml_escape(buyer_label(c.copy, redact)), c.copy.id, c.matches, c.compared, c.p_value,
        c.corrected_p, xml_escape(shown_path(c.copy.output_path, redact)),
        named ? "<b>named</b>" : (i == r.named.size() ? "runner-up" : ""));
  }
  return s + "</table>\n";
}

std::string file_row(const std::string& what, const EvidenceFile& f, bool redact) {
  if (f.path.empty()) return {};
  return row(what, fmt::format(
                       "{}<br><span class='hash'>{}</span>", xml_escape(shown_path(f.path, redact)),
                       f.hash.empty() ? "(no content hash)" : "BLAKE2b-256 " + xml_escape(f.hash)));
}

std::string registration_rows(const TraceResult& r) {
  const Similarity& t = r.registration.transform;
  const double angle = Eigen::AngleAxisd(t.rotation).angle() * 180 / M_PI;
  std::string s;
  s += row("registration", xml_escape(r.registration.message));
  s += row("residual", fmt::format("{:.4g} % of the original's diagonal (trimmed RMS)",
                                   100 * r.registration.residual));
  s += row("overlap", fmt::format("{:.1f} % of the leak's samples", 100 * r.registration.overlap));
  s += row("transform",
           fmt::format("rotation {:.3f} degrees, scale {:.6f}, translation ({:.4g}, "
                       "{:.4g}, {:.4g})",
                       angle, t.scale, t.translation.x(), t.translation.y(), t.translation.z()));
  s += row("measured",
           fmt::format("{:.1f} % of the original's carrier vertices", 100 * r.measured_fraction));
  s += row("attenuation", fmt::format("{:.4f} (fitted; 1: the mark as embedded)", r.attenuation));
  s += row("reference", xml_escape(r.processing.empty() ? "none" : r.processing));
  return s;
}

std::string context_rows(const EvidenceContext& c) {
  std::string s;
  s += row("threshold",
           fmt::format("{:.3g} (corrected p-value, Bonferroni over the candidates)", c.threshold));
  for (const auto& [name, value] : c.settings) s += row(name, xml_escape(value));
  s += row("key fingerprint", "<span class='hash'>" + xml_escape(c.key_fingerprint) + "</span>");
  s += file_row("leaked mesh", c.leaked, c.redact);
  s += file_row("original", c.original, c.redact);
  s += file_row("registry", c.registry, c.redact);
  if (!c.case_id.empty()) s += row("case", xml_escape(c.case_id));
  if (!c.analyst.empty()) s += row("analyst", xml_escape(c.analyst));
  s += row("meshmark", xml_escape(c.version));
  return s;
}

// The mark settings of the best candidate, as issued (the registry's record).
std::string mark_row(const TraceResult& r) {
  if (r.ranking.empty()) return {};
  const IssuedCopy& c = r.ranking.front().copy;
  return row("mark (best candidate)",
             fmt::format("{}, {} bits, {}-bit IDs, strength {:g}, spread {:g}, bin offset {:g}, "
                         "mark format {}",
                         xml_escape(c.variant), c.bits, c.id_bits, c.strength, c.strength_spread,
                         c.bin_offset, c.mark_format));
}

// Each named copy as the registry recorded it: who, when, and the hash of the file issued.
std::string named_rows(const TraceResult& r, bool redact) {
  std::string s;
  for (const CandidateScore& c : r.named)
    s += row(fmt::format("named copy, ID {}", c.copy.id),
             fmt::format("{}; issued {} as {}<br><span class='hash'>recorded BLAKE2b-256 {}</span>",
                         xml_escape(buyer_label(c.copy, redact)), xml_escape(c.copy.issued_at),
                         xml_escape(shown_path(c.copy.output_path, redact)),
                         xml_escape(c.copy.output_hash)));
  return s.empty() ? s : "<table>" + s + "</table>\n";
}

// The command without the folder it ran in and with file names for paths, when redacted.
std::string shown_command(const EvidenceContext& c) {
  if (!c.redact) return c.command;
  std::string cmd = c.command;
  if (cmd.rfind("cd ", 0) == 0)
    if (const std::size_t amp = cmd.find(" && "); amp != std::string::npos)
      cmd = cmd.substr(amp + 4);
  for (const EvidenceFile* f : {&c.leaked, &c.original, &c.registry}) {
    if (f->path.empty()) continue;
    const std::string name = shown_path(f->path, true);
    for (std::size_t at = cmd.find(f->path); at != std::string::npos;
         at = cmd.find(f->path, at + name.size()))
      cmd.replace(at, f->path.size(), name);
  }
  return cmd;
}

std::string mesh_row(const std::string& what, const Mesh& m, const Mesh& drawn) {
  return row(what, fmt::format("{} vertices, {} triangles (drawn: {} triangles)", m.V.rows(),
                               m.F.rows(), drawn.F.rows()));
}

}  // namespace

namespace {

// cluster_for_display, with values per vertex averaged as the positions are (into *averaged).
Mesh cluster_with_values(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F, int max_triangles,
                         const Eigen::VectorXd* values, Eigen::VectorXd* averaged) {
  assert(max_triangles >= 1);
  if (F.rows() <= max_triangles) {
    if (values && averaged) *averaged = *values;
    return make_mesh(V, F);
  }
  // A closed surface on a g-cell grid keeps about 6 g^2 triangles: start finer, then shrink the
  // grid by the square root of the excess until the budget holds.
  double g = 2 * std::sqrt(static_cast<double>(max_triangles));
  for (int attempt = 0;; ++attempt) {
    Mesh m = cluster_once(V, F, std::max(1, static_cast<int>(g)), values, averaged);
    if (m.F.rows() <= max_triangles || g <= 1 || attempt == 30) return m;
    g *= 0.97 * std::sqrt(static_cast<double>(max_triangles) / static_cast<double>(m.F.rows()));
  }
}

}  // namespace

Mesh cluster_for_display(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F, int max_triangles) {
  return cluster_with_values(V, F, max_triangles, nullptr, nullptr);
}

namespace {

// The leak (moved by the registration) alone, each vertex's distance to the original's surface
// measured on the leak as it is, then drawn through the display's simplification (each drawn
// triangle coloured by its corners' averaged distances) in the first principal view, with a
// numbered colour bar; the caption states the median and largest over the leak's vertices.
std::string distance_map(const Mesh& original, const Mesh& moved, const AxisView& view,
                         const EvidenceReportOptions& options, double diagonal) {
  std::string h = "<h2>Where the leak departs from the original</h2>\n";
  const std::vector<std::uint8_t> used = referenced_vertices(moved.F, moved.V.rows());
  std::vector<Eigen::Index> rows;
  for (Eigen::Index i = 0; i < moved.V.rows(); ++i)
    if (used[i]) rows.push_back(i);
  Eigen::MatrixX3d Q(static_cast<Eigen::Index>(rows.size()), 3);
  for (std::size_t k = 0; k < rows.size(); ++k) Q.row(k) = moved.V.row(rows[k]);
  ClosestPoints cp;
  try {
    cp = closest_points(original.V, original.F, Q);
  } catch (const InvalidArgumentError& e) {
    return h + "<p>No map: " + xml_escape(e.what()) + "</p>\n";
  }
  Eigen::VectorXd distance = Eigen::VectorXd::Zero(moved.V.rows());
  std::vector<double> sorted(rows.size());
  for (std::size_t k = 0; k < rows.size(); ++k)
    sorted[k] = distance[rows[k]] = 100 / diagonal * cp.distance[k];
  std::sort(sorted.begin(), sorted.end());
  const double largest = sorted.empty() ? 0 : sorted.back();
  const double median = sorted.empty() ? 0 : sorted[sorted.size() / 2];
  Eigen::VectorXd drawn_distance;
  const Mesh l =
      cluster_with_values(moved.V, moved.F, options.max_triangles, &distance, &drawn_distance);
  const double top = std::max(largest, 1e-9);
  const auto by_distance = [&](std::size_t f, int) {
    const double d =
        (drawn_distance[l.F(f, 0)] + drawn_distance[l.F(f, 1)] + drawn_distance[l.F(f, 2)]) / 3;
    return fmt::format(
        "d{}", std::clamp(static_cast<int>(d / top * kDistanceShades), 0, kDistanceShades - 1));
  };
  h += "<figure>" + mesh_view(nullptr, l, view.R, options.view_size, diagonal, by_distance) +
       "<br>" + distance_bar(top, options.view_size) +
       fmt::format(
           "<figcaption class='distance-map'>the leak alone, {}; coloured by the "
           "distance of its vertices to the original's surface: median {:.3g} %, "
           "largest {:.3g} % of the diagonal, over its {} vertices</figcaption></figure>\n",
           view.caption, median, largest, rows.size());
  return h;
}

}  // namespace

std::string evidence_report_html(const Mesh& leaked, const Mesh& original,
                                 const TraceResult& result, const EvidenceContext& context,
                                 const EvidenceReportOptions& options) {
  assert(options.max_triangles >= 100 && options.view_size >= 100);
  const TraceResult& r = result;
  // The meshes as drawn: the leak moved by the registration, both simplified to the budget.
  Mesh moved = leaked;
  moved.V = r.registration.transform.apply(leaked.V);
  const Mesh o = cluster_for_display(original.V, original.F, options.max_triangles);
  const Mesh l = cluster_for_display(moved.V, moved.F, options.max_triangles);
  const double diagonal =
      bounding_box_diagonal(original.V, referenced_vertices(original.F, original.V.rows()));
  const bool named = r.status == TraceStatus::Named;
  std::string h = "<!DOCTYPE html>\n<html lang='en'>\n<head>\n<meta charset='utf-8'>\n";
  h += "<title>meshmark trace evidence</title>\n<style>" + std::string(kStyle) + shade_classes() +
       distance_classes() + fmt::format("figure{{width:{}px}}\n", options.view_size) +
       "</style>\n</head>\n<body>\n<h1>Trace evidence</h1>\n";
  // Outcome: the verdict in a sentence, then the program's own summary.
  h += fmt::format("<div class='status {}'><p class='verdict'>{}</p><b>{}</b>: {}</div>\n",
                   named ? "named" : "none",
                   xml_escape(verdict_sentence(r, context.threshold, context.redact)),
                   trace_status_name(r.status),
                   xml_escape(context.redact ? "(redacted: see the tables)" : r.message));
  if (!r.warnings.empty()) {
    h += "<div class='warnings'><b>Warnings</b><ul>";
    for (const std::string& w : r.warnings) h += "<li>" + xml_escape(w) + "</li>";
    h += "</ul></div>\n";
  }
  h += named_rows(r, context.redact);
  h += "<h2>Candidates</h2>\n" + candidate_rows(r, context.threshold, context.redact);
  h += score_plot(r, context.threshold, context.redact);
  // Views: three along the original's principal axes, then where the leak departs from it.
  const std::array<AxisView, 3> views = axis_views(principal_axes(original.V));
  h += "<h2>The registered leak over the original</h2>\n";
  const auto over = [](std::size_t, int shade) { return fmt::format("l{}", shade); };
  for (const AxisView& v : views)
    h += "<figure>" + mesh_view(&o, l, v.R, options.view_size, diagonal, over) +
         fmt::format(
             "<figcaption>{}; grey: the original, orange: the leak moved by the registration "
             "(grey alone: no leaked surface there)</figcaption></figure>\n",
             v.caption);
  h += distance_map(original, moved, views[0], options, diagonal);
  h += "<table>" + mesh_row("leaked mesh", leaked, l) + mesh_row("original", original, o) +
       registration_rows(r) + "</table>\n";
  // Bits.
  h += "<h2>Evidence of each payload bit</h2>\n<p>The shift of each bit's bin mean from the "
       "reference (bin widths): the blue tick is what a 1 would give, the red tick a 0 (the "
       "mark as embedded, times the fitted attenuation); the dot is what was measured, coloured "
       "by the bit read (hollow: erased, nothing measured in the bin).</p>\n" +
       bit_plot(r.bits);
  // Settings, files, command.
  h += "<h2>Settings and files</h2>\n<table>" + context_rows(context) + mark_row(r) + "</table>\n";
  h += "<h2>Command</h2>\n<pre>" + xml_escape(shown_command(context)) + "</pre>\n";
  if (!context.command_note.empty()) h += "<p>" + xml_escape(context.command_note) + "</p>\n";
  h += "<p>This report depends on the files above and nothing else (no date, no timing): the "
       "command gives the same bytes again.</p>\n";
  // The report's own hash H, over the file P written with zeros Z in the three places below:
  // the file holds H in the first two, so `sed 's/H/Z/g'` gives P back and b2sum prints H.
  const std::string z = report_hash_placeholder;
  const std::size_t tail = h.size();
  h += fmt::format(
      "<p class='hash'>Report BLAKE2b-256: {0}</p>\n<p>To check that this file is the one "
      "written, write that hash as zeros and hash it again: <code>sed 's/{0}/{0}/g' report.html | "
      "b2sum -l 256</code> prints the same hash.</p>\n</body>\n</html>\n",
      z);
  const std::string own = content_hash(h);
  for (int k = 0; k < 2; ++k) h.replace(h.find(z, tail), z.size(), own);
  return h;
}

std::string verdict_sentence(const TraceResult& r, double threshold, bool redact) {
  auto chance = [](double p) {
    return p > 0 ? fmt::format("{:.2g} (about 1 in {:.2g})", p, 1 / p) : std::string("0");
  };
  switch (r.status) {
    case TraceStatus::Named: {
      const CandidateScore& c = r.named.front();
      const std::string who = redact ? fmt::format("the buyer of ID {}", c.copy.id)
                                     : fmt::format("{} (ID {})", c.copy.buyer, c.copy.id);
      return fmt::format(
          "The leaked mesh carries the mark of the copy issued to {}{}. If that buyer's copy were "
          "not its source, a match at least this strong with one of the {} copies issued would "
          "occur with probability at most {}, below the threshold of {:g}.",
          who, r.named.size() > 1 ? fmt::format(" and {} other buyer(s)", r.named.size() - 1) : "",
          r.candidates, chance(c.corrected_p), threshold);
    }
    case TraceStatus::NoBuyer:
      return fmt::format(
          "No buyer is named: the best match among the {} copies issued (corrected p = {:.2g}) "
          "could arise by chance too often to be evidence (the threshold is {:g}); this says "
          "nothing against any buyer.",
          r.candidates, r.ranking.empty() ? 1.0 : r.ranking.front().corrected_p, threshold);
    case TraceStatus::RegistrationFailed:
      return "No buyer is named: the leak could not be brought onto the original, so no mark was "
             "measured; this says nothing against any buyer.";
    case TraceStatus::NoCandidates:
      return "No buyer is named: the registry holds no copy of this original under this key; "
             "this says nothing against any buyer.";
  }
  return {};
}

void write_evidence_report(const std::string& path, const Mesh& leaked, const Mesh& original,
                           const TraceResult& result, const EvidenceContext& context,
                           const EvidenceReportOptions& options) {
  write_file_atomically(path, evidence_report_html(leaked, original, result, context, options));
}

}  // namespace meshmark
