#include "cgal_mesh.h"

#include <CGAL/Polygon_mesh_processing/orient_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/repair_polygon_soup.h>

namespace meshmark::detail {

namespace PMP = CGAL::Polygon_mesh_processing;

SurfaceMesh to_surface_mesh(const Mesh& mesh) {
  std::vector<CgalKernel::Point_3> points;
  points.reserve(static_cast<std::size_t>(mesh.V.rows()));
  for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    points.emplace_back(mesh.V(i, 0), mesh.V(i, 1), mesh.V(i, 2));
  std::vector<std::array<std::size_t, 3>> triangles;
  triangles.reserve(static_cast<std::size_t>(mesh.F.rows()));
  for (Eigen::Index t = 0; t < mesh.F.rows(); ++t)
    triangles.push_back({static_cast<std::size_t>(mesh.F(t, 0)),
                         static_cast<std::size_t>(mesh.F(t, 1)),
                         static_cast<std::size_t>(mesh.F(t, 2))});
  PMP::repair_polygon_soup(points, triangles);
  PMP::orient_polygon_soup(points, triangles);
  SurfaceMesh sm;
  PMP::polygon_soup_to_polygon_mesh(points, triangles, sm);
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
  std::vector<int> face;
  for (auto f : sm.faces()) {
    face.clear();
    for (auto v : CGAL::vertices_around_face(sm.halfedge(f), sm))
      face.push_back(static_cast<int>(v.idx()));
    out.faces.push_back(face.data(), face.size());
  }
  out.F = triangulate(out.faces);
  return out;
}

}  // namespace meshmark::detail
