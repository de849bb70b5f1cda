// Loop and sqrt(3) subdivision with CGAL's Subdivision_method_3 (midpoint subdivision is the
// core's own, attack_components.cpp).

#include <CGAL/subdivision_method_3.h>

#include "attacks/cgal_attacks.h"
#include "cgal_mesh.h"

namespace meshmark {

// The iterations were checked by attack_subdivide.
Mesh detail::cgal_subdivide(const Mesh& mesh, Subdivision scheme, int iterations) {
  detail::SurfaceMesh sm = detail::to_surface_mesh(mesh);
  const auto params = CGAL::parameters::number_of_iterations(static_cast<unsigned>(iterations));
  if (scheme == Subdivision::Loop)
    CGAL::Subdivision_method_3::Loop_subdivision(sm, params);
  else
    CGAL::Subdivision_method_3::Sqrt3_subdivision(sm, params);
  return detail::from_surface_mesh(sm, mesh);
}

}  // namespace meshmark
