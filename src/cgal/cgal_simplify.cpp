// Edge-collapse simplification with CGAL's Lindstrom-Turk or Garland-Heckbert (plane quadric)
// cost and placement.

#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/GarlandHeckbert_plane_policies.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/LindstromTurk_cost.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/LindstromTurk_placement.h>
#include <CGAL/Surface_mesh_simplification/edge_collapse.h>
#include <algorithm>
#include <cmath>
#include <vector>

#include <fmt/format.h>

#include "attacks/cgal_attacks.h"
#include "cgal_mesh.h"
#include "core/progress_counter.h"
#include "meshmark/attacks/attack.h"
#include "meshmark/core/error.h"

namespace meshmark {

namespace {
namespace SMS = CGAL::Surface_mesh_simplification;

// Reports the collapses (faces removed, of those to remove) about every 4,096 of them: CGAL
// asks a stop predicate before every collapse, so the predicates count there.
class CollapseProgress {
 public:
  CollapseProgress(const detail::SurfaceMesh& mesh, std::size_t target,
                   const ProgressCallback& progress)
      : mesh_(mesh),
        last_(mesh.number_of_faces()),
        left_(static_cast<long>(last_ > target ? last_ - target : 0)),
        counter_(progress, "collapsing edges", left_),
        batch_(counter_) {}
  // Faces removed since the last call, up to the total (a collapse removes two faces and may
  // step past the target by one).
  void asked() {
    const std::size_t faces = mesh_.number_of_faces();
    if (faces >= last_) return;
    const long removed = std::min(static_cast<long>(last_ - faces), left_);
    last_ = faces, left_ -= removed;
    batch_.add(removed);
  }
  // The rest, once the run has ended (it may end short of the target: nothing left to collapse).
  void finish() { batch_.flush(); }

 private:
  const detail::SurfaceMesh& mesh_;
  std::size_t last_;
  long left_;
  detail::ProgressCounter counter_;
  detail::ProgressBatch batch_;
};

// Stops once the mesh has at most the last target's faces (CGAL's own ratio predicate counts
// edges), keeping a copy of the mesh each time it first has at most a target's faces: the
// state a run stopping there would end in, since the predicate is asked before each collapse
// and is the only thing that differs between the runs.
struct LevelsStop {
  const detail::SurfaceMesh* mesh;
  const Mesh* original;
  std::vector<std::size_t> targets;  // decreasing
  std::vector<Mesh>* levels;
  CollapseProgress* progress;
  template <class FT, class Profile>
  bool operator()(const FT&, const Profile&, std::size_t, std::size_t) const {
    progress->asked();
    while (levels->size() < targets.size() && mesh->number_of_faces() <= targets[levels->size()]) {
      detail::SurfaceMesh copy = *mesh;  // with its removed elements: compacted as a run's end
      levels->push_back(detail::from_surface_mesh(copy, *original));
    }
    return levels->size() == targets.size();
  }
};

// Stops once the mesh has at most `target` faces.
struct OneTargetStop {
  const detail::SurfaceMesh* mesh;
  std::size_t target;
  CollapseProgress* progress;
  template <class FT, class Profile>
  bool operator()(const FT&, const Profile&, std::size_t, std::size_t) const {
    progress->asked();
    return mesh->number_of_faces() <= target;
  }
};

// The collapses with `cost`'s cost and placement until `stop`.
template <class Stop>
void collapse(detail::SurfaceMesh& sm, const Stop& stop, SimplifyCost cost) {
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
}

// The target face count of ratio: it counts the triangles CGAL was given (degenerate and
// duplicate ones, which the conversion drops, are no surface to simplify).
std::size_t face_target(const detail::SurfaceMesh& sm, double ratio) {
  return static_cast<std::size_t>(std::llround(ratio * static_cast<double>(sm.number_of_faces())));
}

void check_ratio(double ratio) {
  if (!(ratio > 0 && ratio <= 1))
    throw InvalidArgumentError(fmt::format("simplification ratio {} is outside (0, 1]", ratio));
}

}  // namespace

Mesh detail::cgal_simplify(const Mesh& mesh, double ratio, SimplifyCost cost,
                           const ProgressCallback& progress) {
  check_ratio(ratio);
  detail::SurfaceMesh sm = detail::prepared_surface_mesh(mesh, progress);
  const std::size_t target = face_target(sm, ratio);
  CollapseProgress collapses(sm, target, progress);
  collapse(sm, OneTargetStop{&sm, target, &collapses}, cost);
  collapses.finish();
  return detail::from_surface_mesh(sm, mesh);
}

std::vector<Mesh> detail::cgal_simplify_levels(const Mesh& mesh, const std::vector<double>& ratios,
                                               SimplifyCost cost,
                                               const ProgressCallback& progress) {
  for (const double r : ratios) check_ratio(r);
  if (ratios.empty()) return {};
  detail::SurfaceMesh sm = detail::prepared_surface_mesh(mesh, progress);
  std::vector<std::size_t> order(ratios.size());
  for (std::size_t k = 0; k < order.size(); ++k) order[k] = k;
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return ratios[a] > ratios[b]; });
  std::vector<std::size_t> targets;
  targets.reserve(order.size());
  for (const std::size_t k : order) targets.push_back(face_target(sm, ratios[k]));
  std::vector<Mesh> levels;
  CollapseProgress collapses(sm, targets.back(), progress);
  collapse(sm, LevelsStop{&sm, &mesh, targets, &levels, &collapses}, cost);
  collapses.finish();
  // A run that ends without reaching the last targets (no edge left that may collapse) ends
  // there for them too.
  while (levels.size() < targets.size()) levels.push_back(detail::from_surface_mesh(sm, mesh));
  std::vector<Mesh> out(ratios.size());
  for (std::size_t k = 0; k < order.size(); ++k) out[order[k]] = std::move(levels[k]);
  return out;
}

}  // namespace meshmark
