// The cgal component (GPL-3.0-or-later through CGAL): fills the core's slot for the attacks
// that need CGAL (attacks/cgal_attacks.h).

#include "attacks/cgal_attacks.h"
#include "core/component.h"

namespace meshmark::detail {

namespace {
const CgalAttacks kCgalAttacks{&cgal_simplify, &cgal_simplify_levels, &cgal_remesh,
                               &cgal_subdivide};
}  // namespace

MESHMARK_COMPONENT(cgal, cgal_attacks_slot(), kCgalAttacks)

}  // namespace meshmark::detail
