// For fuzz_campaign alone: the attacks that need CGAL, absent. The campaign loader checks attack
// chains against the table of kinds, which names every attack's function, but it never applies
// one; linking these instead of src/cgal keeps CGAL's templates out of the fuzz build (the whole
// library under clang's sanitizers takes most of an hour on two cores). Reaching one of them is
// a bug of the loader, and traps.

#include "meshmark/attacks/attack.h"

namespace meshmark {

Mesh attack_simplify(const Mesh&, double, SimplifyCost) {
  __builtin_trap();
}

std::vector<Mesh> attack_simplify_levels(const Mesh&, const std::vector<double>&, SimplifyCost) {
  __builtin_trap();
}

Mesh attack_remesh(const Mesh&, double, int) {
  __builtin_trap();
}

Mesh attack_subdivide(const Mesh&, Subdivision, int) {
  __builtin_trap();
}

}  // namespace meshmark
