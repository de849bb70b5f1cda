// Loop and sqrt(3) subdivision with CGAL's Subdivision_method_3; midpoint (linear 1-to-4)
// subdivision is done here directly (CGAL's linear mask leaves border vertices unset).

#include <CGAL/subdivision_method_3.h>
#include <map>

#include <fmt/format.h>

#include "cgal_mesh.h"
#include "meshmark/attacks/attack.h"
#include "meshmark/core/error.h"

namespace meshmark {

namespace {

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
  out.F = triangulate(faces);
  out.faces = std::move(faces);
  return out;
}

}  // namespace

Mesh attack_subdivide(const Mesh& mesh, Subdivision scheme, int iterations) {
  if (iterations < 0 || iterations > 8)
    throw InvalidArgumentError(
        fmt::format("{} subdivision iterations (expected 0 to 8)", iterations));
  if (scheme == Subdivision::Midpoint) {
    Mesh out = mesh;
    for (int k = 0; k < iterations; ++k) out = midpoint_step(out);
    if (iterations > 0) out.image.reset();
    return out;
  }
  detail::SurfaceMesh sm = detail::to_surface_mesh(mesh);
  const auto params = CGAL::parameters::number_of_iterations(static_cast<unsigned>(iterations));
  if (scheme == Subdivision::Loop)
    CGAL::Subdivision_method_3::Loop_subdivision(sm, params);
  else
    CGAL::Subdivision_method_3::Sqrt3_subdivision(sm, params);
  return detail::from_surface_mesh(sm, mesh);
}

}  // namespace meshmark
