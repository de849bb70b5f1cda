// Isotropic remeshing with CGAL's Polygon Mesh Processing.

#include <CGAL/Polygon_mesh_processing/border.h>
#include <CGAL/Polygon_mesh_processing/remesh.h>
#include <cmath>

#include <fmt/format.h>

#include "attacks/cgal_attacks.h"
#include "cgal_mesh.h"
#include "core/progress_counter.h"
#include "meshmark/attacks/attack.h"
#include "meshmark/core/error.h"

namespace meshmark {

Mesh detail::cgal_remesh(const Mesh& mesh, double edge_factor, int iterations,
                         const ProgressCallback& progress) {
  if (!(edge_factor >= 0.05 && edge_factor <= 20))
    throw InvalidArgumentError(
        fmt::format("remeshing edge length {} x the mean is outside [0.05, 20]", edge_factor));
  if (iterations < 1 || iterations > 20)
    throw InvalidArgumentError(
        fmt::format("remeshing iterations {} are outside [1, 20]", iterations));
  namespace PMP = CGAL::Polygon_mesh_processing;
  detail::SurfaceMesh sm = detail::prepared_surface_mesh(mesh, progress);
  double total = 0;
  std::size_t edges = 0;
  for (const auto e : sm.edges()) {
    total +=
        std::sqrt(CGAL::squared_distance(sm.point(sm.vertex(e, 0)), sm.point(sm.vertex(e, 1))));
    ++edges;
  }
  const double target = edge_factor * total / static_cast<double>(edges);
  detail::ProgressCounter remeshing(progress, "remeshing", 1);
  PMP::isotropic_remeshing(faces(sm), target, sm,
                           CGAL::parameters::number_of_iterations(iterations));
  remeshing.step(1, "");
  return detail::from_surface_mesh(sm, mesh);
}

}  // namespace meshmark
