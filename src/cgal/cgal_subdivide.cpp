// Loop and sqrt(3) subdivision with CGAL's Subdivision_method_3 (midpoint subdivision is the
// core's own, attack_components.cpp).

#include <CGAL/subdivision_method_3.h>

#include "attacks/cgal_attacks.h"
#include "cgal_mesh.h"
#include "core/progress_counter.h"

namespace meshmark {

// The iterations were checked by attack_subdivide. Without a callback, one CGAL call; with one,
// one step at a time, as CGAL's number_of_iterations runs them (sqrt(3) refines the border on
// odd steps: its one-step function is told which step it is), so that progress can be
// reported between them: the same mesh either way (Attack.SubdivisionReportsEachIteration).
Mesh detail::cgal_subdivide(const Mesh& mesh, Subdivision scheme, int iterations,
                            const ProgressCallback& progress) {
  detail::SurfaceMesh sm = detail::prepared_surface_mesh(mesh, progress);
  namespace SM3 = CGAL::Subdivision_method_3;
  if (!progress) {
    const auto all = CGAL::parameters::number_of_iterations(static_cast<unsigned>(iterations));
    if (scheme == Subdivision::Loop)
      SM3::Loop_subdivision(sm, all);
    else
      SM3::Sqrt3_subdivision(sm, all);
    return detail::from_surface_mesh(sm, mesh);
  }
  detail::ProgressCounter subdividing(progress, "subdividing", iterations);
  const auto points = get(CGAL::vertex_point, sm);
  for (int k = 0; k < iterations; ++k) {
    if (scheme == Subdivision::Loop) {
      CGAL::Loop_mask_3<detail::SurfaceMesh, decltype(points)> mask(&sm, points);
      SM3::internal::PTQ_1step(sm, points, mask);
    } else {
      CGAL::Sqrt3_mask_3<detail::SurfaceMesh, decltype(points)> mask(&sm, points);
      SM3::internal::Sqrt3_1step(sm, points, mask, k % 2 == 1);
    }
    subdividing.step(1, "");
  }
  return detail::from_surface_mesh(sm, mesh);
}

}  // namespace meshmark
