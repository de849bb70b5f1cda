// The core's side of the attacks the cgal component brings (cgal_attacks.h): their entry
// points, called through the slot the component fills, or MissingComponentError without it;
// and midpoint subdivision, the core's own.

#include <map>

#include <fmt/format.h>

#include "attacks/cgal_attacks.h"
#include "core/component.h"
#include "core/progress_counter.h"
#include "meshmark/core/error.h"

namespace meshmark {

namespace detail {
const CgalAttacks*& cgal_attacks_slot() {
  static const CgalAttacks* attacks = nullptr;
  return attacks;
}
}  // namespace detail

namespace {

const detail::CgalAttacks& cgal(const char* what) {
  return detail::require_component(detail::cgal_attacks_slot(), "cgal", what);
}

// One 1-to-4 split: a vertex at every edge midpoint, shared by the edge's faces.
Mesh midpoint_step(const Mesh& mesh) {
  std::map<std::pair<int, int>, int> midpoint;
  std::vector<Eigen::RowVector3d> added;
  const auto nv = static_cast<int>(mesh.V.rows());
  auto mid = [&](int a, int b) {
    const auto key = std::minmax(a, b);
    auto [it, fresh] = midpoint.try_emplace(key, nv + static_cast<int>(added.size()));
    if (fresh) added.push_back(0.5 * (mesh.V.row(a) + mesh.V.row(b)));
    return it->second;
  };
  Polygons faces;
  for (Eigen::Index t = 0; t < mesh.F.rows(); ++t) {
    const int a = mesh.F(t, 0), b = mesh.F(t, 1), c = mesh.F(t, 2);
    const int ab = mid(a, b), bc = mid(b, c), ca = mid(c, a);
    const int tris[4][3] = {{a, ab, ca}, {ab, b, bc}, {ca, bc, c}, {ab, bc, ca}};
    for (const auto& tri : tris) faces.push_back(tri, 3);
  }
  Mesh out;
  out.format = mesh.format;
  out.encoding = mesh.encoding;
  out.V.resize(nv + static_cast<Eigen::Index>(added.size()), 3);
  out.V.topRows(nv) = mesh.V;
  for (std::size_t k = 0; k < added.size(); ++k)
    out.V.row(nv + static_cast<Eigen::Index>(k)) = added[k];
  set_faces(out, std::move(faces));
  return out;
}

}  // namespace

Mesh attack_simplify(const Mesh& mesh, double ratio, SimplifyCost cost,
                     const ProgressCallback& progress) {
  return cgal("the simplification attack").simplify(mesh, ratio, cost, progress);
}

std::vector<Mesh> attack_simplify_levels(const Mesh& mesh, const std::vector<double>& ratios,
                                         SimplifyCost cost, const ProgressCallback& progress) {
  return cgal("the simplification attack").simplify_levels(mesh, ratios, cost, progress);
}

Mesh attack_remesh(const Mesh& mesh, double edge_factor, int iterations,
                   const ProgressCallback& progress) {
  return cgal("the remeshing attack").remesh(mesh, edge_factor, iterations, progress);
}

Mesh attack_subdivide(const Mesh& mesh, Subdivision scheme, int iterations,
                      const ProgressCallback& progress) {
  if (iterations < 0 || iterations > 8)
    throw InvalidArgumentError(
        fmt::format("{} subdivision iterations (expected 0 to 8)", iterations));
  if (scheme != Subdivision::Midpoint)
    return cgal(scheme == Subdivision::Loop ? "Loop subdivision" : "sqrt(3) subdivision")
        .subdivide(mesh, scheme, iterations, progress);
  Mesh out = mesh;
  detail::ProgressCounter subdividing(progress, "subdividing", iterations);
  for (int k = 0; k < iterations; ++k) {
    out = midpoint_step(out);
    subdividing.step(1, "");
  }
  if (iterations > 0) out.image.reset();
  return out;
}

}  // namespace meshmark
