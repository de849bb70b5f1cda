// Attacks: attack (one kind or a chain, the CLI's names and parameters) and attack_kinds.

#include <fmt/format.h>

#include <cmath>
#include <optional>
#include <vector>

#include "bindings.h"
#include "meshmark/attacks/attack.h"
#include "meshmark/core/error.h"

namespace meshmark::python {

void init_attack(py::module_& m) {
  m.def(
      "attack",
      [](py::handle mesh, const std::string& kind, double strength, std::uint64_t seed,
         double lambda, double mu, bool fixed_boundary, const std::string& weighting,
         const std::string& convention, py::handle progress) {
        AttackParams params;
        params.lambda = lambda;
        params.mu = mu;
        params.fixed_boundary = fixed_boundary;
        params.weighting = parse_smooth_weighting(weighting);
        params.convention = parse_quantize_convention(convention);
        const std::vector<AttackStep> steps = attack_steps(kind, strength, params);
        const Mesh input = to_mesh(mesh);
        return with_progress(progress, [&](const ProgressCallback& report) {
          return apply_attack_chain(input, steps, seed, report);
        });
      },
      py::arg("mesh"), py::arg("kind"), py::arg("strength") = 0.0, py::kw_only(),
      py::arg("seed") = 1, py::arg("lambda_") = 0.0, py::arg("mu") = 0.0,
      py::arg("fixed_boundary") = false, py::arg("weighting") = "uniform",
      py::arg("convention") = "levels", py::arg("progress") = py::none(),
      "Applies an attack to a Mesh (or a (V, F) pair) and returns the attacked Mesh, as the "
      "CLI's attack (same kinds, strengths and seed). kind: a name from attack_kinds(), or a "
      "chain 'noise:0.001,quant:10' (then strength is unused). lambda_, mu, fixed_boundary, "
      "weighting ('uniform', 'inverse-distance'): smooth and taubin; convention ('levels', "
      "'benchmark'): quant. progress(phase, done, total, what) is called as the long kinds "
      "(simplify, qsimplify, remesh, the subdivisions) go, and once at the start and end of "
      "the others; an exception it raises (or Ctrl-C) stops the attack and is raised here. "
      "Attacks that keep the connectivity keep the file image.");
  m.def(
      "collude",
      [](const py::sequence& copies, std::optional<std::vector<double>> weights, bool splice,
         std::uint64_t seed) {
        std::vector<Mesh> meshes;
        for (const py::handle c : copies) meshes.push_back(to_mesh(c));
        CollusionOptions o;
        o.kind = splice ? CollusionKind::Splice : CollusionKind::Average;
        if (weights) o.weights = *weights;
        py::gil_scoped_release release;
        return attack_collude(meshes, o, seed);
      },
      py::arg("copies"), py::kw_only(), py::arg("weights") = py::none(), py::arg("splice") = false,
      py::arg("seed") = 1,
      "Merges copies of one original (Meshes or (V, F) pairs with the same vertex count and "
      "faces) as colluding buyers would, as the CLI's collude: their vertex-wise average, with "
      "weights (one per copy, >= 0, normalized to sum 1) or equal ones; or, with splice=True, "
      "the surface cut into one region per copy (Voronoi cells of far-apart vertices, the first "
      "drawn from seed) each pasted from its copy. Returns a Mesh with the first copy's faces. "
      "Raises InvalidArgumentError for fewer than 2 copies, copies that differ in vertices or "
      "faces, or bad weights.");
  m.def(
      "attack_kinds",
      [] {
        py::dict kinds;
        for (const AttackKind& k : attack_registry()) kinds[py::str(k.name)] = k.meaning;
        return kinds;
      },
      "The attack kinds: name -> what its strength means.");
  m.def(
      "attack_registry",
      [] {
        py::list kinds;
        for (const AttackKind& k : attack_registry()) {
          py::dict d;
          d["name"] = k.name;
          d["meaning"] = k.meaning;
          d["seeded"] = k.seeded;
          d["default_strength"] = k.default_strength;
          d["parameters"] = attack_param_names(k.params);
          d["levels"] = k.levels != nullptr;
          kinds.append(d);
        }
        return kinds;
      },
      "The library's table of attack kinds, one dict each: name, meaning (of the strength), "
      "seeded (the result depends on the seed), default_strength (what a strength of 0 means), "
      "parameters (the keywords of attack() it reads: lambda_ is 'lambda'), levels (every "
      "strength of a series from one run, for campaigns).");
}

}  // namespace meshmark::python
