#pragma once
// Internal: the attacks the cgal component brings (src/cgal, GPL-3.0-or-later through CGAL).
// attack.h's attack_simplify, attack_simplify_levels, attack_remesh and attack_subdivide (Loop,
// sqrt(3)) call them through the core's slot (attack_components.cpp), or throw
// MissingComponentError without the component.

#include <vector>

#include "meshmark/attacks/attack.h"

namespace meshmark::detail {

/// CGAL's edge collapse (attack.h's attack_simplify, progress as it says).
Mesh cgal_simplify(const Mesh& mesh, double ratio, SimplifyCost cost,
                   const ProgressCallback& progress);
/// CGAL's edge collapse at several ratios (attack.h's attack_simplify_levels).
std::vector<Mesh> cgal_simplify_levels(const Mesh& mesh, const std::vector<double>& ratios,
                                       SimplifyCost cost, const ProgressCallback& progress);
/// CGAL's isotropic remeshing (attack.h's attack_remesh).
Mesh cgal_remesh(const Mesh& mesh, double edge_factor, int iterations,
                 const ProgressCallback& progress);
/// CGAL's Loop or sqrt(3) subdivision (attack.h's attack_subdivide, which checked iterations).
Mesh cgal_subdivide(const Mesh& mesh, Subdivision scheme, int iterations,
                    const ProgressCallback& progress);

/// The cgal component's entry points.
struct CgalAttacks {
  decltype(&cgal_simplify) simplify;
  decltype(&cgal_simplify_levels) simplify_levels;
  decltype(&cgal_remesh) remesh;
  decltype(&cgal_subdivide) subdivide;
};

/// The core's slot for them (core/component.h).
const CgalAttacks*& cgal_attacks_slot();

}  // namespace meshmark::detail
