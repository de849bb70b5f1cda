// Edge-collapse simplification with CGAL's Lindstrom-Turk or Garland-Heckbert (plane quadric)
// cost and placement.

#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/GarlandHeckbert_plane_policies.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/LindstromTurk_cost.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/LindstromTurk_placement.h>
#include <CGAL/Surface_mesh_simplification/edge_collapse.h>
#include <cmath>

#include <fmt/format.h>

#include "cgal_mesh.h"
#include "meshmark/attack.h"
#include "meshmark/error.h"

namespace meshmark {

namespace {
namespace SMS = CGAL::Surface_mesh_simplification;

// Stops once the mesh has at most `target` faces (CGAL's own ratio predicate counts edges).
struct FaceCountStop {
  const detail::SurfaceMesh* mesh;
  std::size_t target;
  template <class FT, class Profile>
  bool operator()(const FT&, const Profile&, std::size_t, std::size_t) const {
    return mesh->number_of_faces() <= target;
  }
};
}  // namespace

Mesh attack_simplify(const Mesh& mesh, double ratio, SimplifyCost cost) {
  if (!(ratio > 0 && ratio <= 1))
    throw InvalidArgumentError(fmt::format("simplification ratio {} is outside (0, 1]", ratio));
  detail::SurfaceMesh sm = detail::to_surface_mesh(mesh);
  // The target counts the triangles CGAL was given: degenerate and duplicate ones, which the
  // conversion drops, are no surface to simplify.
  const auto target =
      static_cast<std::size_t>(std::llround(ratio * static_cast<double>(sm.number_of_faces())));
  const FaceCountStop stop{&sm, target};
  if (cost == SimplifyCost::GarlandHeckbert) {
    const SMS::GarlandHeckbert_plane_policies<detail::SurfaceMesh, detail::CgalKernel> quadrics(sm);
    SMS::edge_collapse(
        sm, stop,
        CGAL::parameters::get_cost(quadrics.get_cost()).get_placement(quadrics.get_placement()));
  } else {
    SMS::edge_collapse(sm, stop,
                       CGAL::parameters::get_cost(SMS::LindstromTurk_cost<detail::SurfaceMesh>())
                           .get_placement(SMS::LindstromTurk_placement<detail::SurfaceMesh>()));
  }
  return detail::from_surface_mesh(sm, mesh);
}

}  // namespace meshmark
