#include "cgal_mesh.h"

#include "core/progress_counter.h"

#include <CGAL/Polygon_mesh_processing/orient_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/repair_polygon_soup.h>

#include <fmt/format.h>

#include "meshmark/core/error.h"

namespace meshmark::detail {

namespace PMP = CGAL::Polygon_mesh_processing;

namespace {

using Triangle = std::array<std::size_t, 3>;

// The soup CGAL may be given: one point per distinct referenced position (bit-identical
// positions merged), and the triangles whose three corners are distinct, non-collinear points.
// CGAL's repair_polygon_soup cannot do this itself for triangles stored as std::array: it skips
// simplify_polygons_in_polygon_soup for them (CGAL 5.5), so a triangle such as (0, 0, 1), or
// one whose corners merge into one position, would reach polygon_soup_to_polygon_mesh as an
// edge from a vertex to itself, around which CGAL's circulators never stop.
void clean_soup(const Mesh& mesh, std::vector<CgalKernel::Point_3>& points,
                std::vector<Triangle>& triangles) {
  const PositionGroups groups =
      group_identical_positions(mesh.V, referenced_vertices(mesh.F, mesh.V.rows()));
  points.reserve(static_cast<std::size_t>(groups.count()));
  for (int g = 0; g < groups.count(); ++g) {
    const int i = groups.members[groups.offsets[g]];
    points.emplace_back(mesh.V(i, 0), mesh.V(i, 1), mesh.V(i, 2));
  }
  triangles.reserve(static_cast<std::size_t>(mesh.F.rows()));
  for (Eigen::Index t = 0; t < mesh.F.rows(); ++t) {
    Triangle tri;
    for (int c = 0; c < 3; ++c) tri[c] = static_cast<std::size_t>(groups.group_of[mesh.F(t, c)]);
    if (tri[0] == tri[1] || tri[1] == tri[2] || tri[2] == tri[0]) continue;
    // Exact predicate: a zero-area triangle has no surface and no normal for CGAL to use.
    if (CGAL::collinear(points[tri[0]], points[tri[1]], points[tri[2]])) continue;
    triangles.push_back(tri);
  }
}

}  // namespace

SurfaceMesh to_surface_mesh(const Mesh& mesh) {
  std::vector<CgalKernel::Point_3> points;
  std::vector<Triangle> triangles;
  clean_soup(mesh, points, triangles);
  if (triangles.empty())
    throw InvalidInputError(mesh.source_path.empty() ? "the attacked mesh" : mesh.source_path, 0,
                            fmt::format("none of its {} triangle(s) has a non-zero area: "
                                        "nothing to simplify or subdivide",
                                        mesh.F.rows()));
  PMP::repair_polygon_soup(points, triangles);  // duplicate triangles, unused points
  PMP::orient_polygon_soup(points, triangles);
  if (!PMP::is_polygon_soup_a_polygon_mesh(triangles))
    throw Error("CGAL: the oriented triangle soup is still not a polygon mesh");
  SurfaceMesh sm;
  PMP::polygon_soup_to_polygon_mesh(points, triangles, sm);
  return sm;
}

SurfaceMesh prepared_surface_mesh(const Mesh& mesh, const ProgressCallback& progress) {
  ProgressCounter preparing(progress, "preparing the mesh", 1);
  SurfaceMesh sm = to_surface_mesh(mesh);
  preparing.step(1, "");
  return sm;
}

Mesh from_surface_mesh(SurfaceMesh& sm, const Mesh& like) {
  sm.collect_garbage();
  Mesh out;
  out.format = like.format;
  out.encoding = like.encoding;
  out.V.resize(static_cast<Eigen::Index>(sm.number_of_vertices()), 3);
  for (auto v : sm.vertices()) {
    const auto& p = sm.point(v);
    out.V.row(static_cast<Eigen::Index>(v.idx())) << p.x(), p.y(), p.z();
  }
  Polygons faces;
  std::vector<int> face;
  for (auto f : sm.faces()) {
    face.clear();
    for (auto v : CGAL::vertices_around_face(sm.halfedge(f), sm))
      face.push_back(static_cast<int>(v.idx()));
    faces.push_back(face.data(), face.size());
  }
  set_faces(out, std::move(faces));
  return out;
}

}  // namespace meshmark::detail
