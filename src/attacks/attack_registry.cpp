// The attack kinds' table (name, meaning, seeded or not, default strength, parameters read,
// function), and what reads it: the chain parser, apply_attack and the determinism check.

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "core/text_scan.h"
#include "meshmark/attacks/attack.h"
#include "meshmark/core/error.h"
#include "meshmark/core/random.h"

namespace meshmark {

namespace {

// A count given as a strength (iterations, bits): a whole number in [0, 1e6].
int whole(const char* kind, double v) {
  if (v != std::floor(v) || v < 0 || v > 1e6)
    throw InvalidArgumentError(fmt::format("attack '{}' needs a whole number, not {}", kind, v));
  return static_cast<int>(v);
}

LaplacianOptions laplacian_options(const AttackParams& p) {
  LaplacianOptions o;
  if (p.lambda != 0) o.lambda = p.lambda;
  o.fixed_boundary = p.fixed_boundary;
  o.weighting = p.weighting;
  return o;
}

TaubinOptions taubin_options(const AttackParams& p) {
  TaubinOptions o;
  if (p.lambda != 0) o.lambda = p.lambda;
  o.mu = p.mu;
  o.fixed_boundary = p.fixed_boundary;
  o.weighting = p.weighting;
  return o;
}

Mesh subdivided(const Mesh& m, Subdivision scheme, const char* kind, double strength,
                const ProgressCallback& progress) {
  return attack_subdivide(m, scheme, whole(kind, strength), progress);
}

Mesh converted(const Mesh& m, const char* format, bool single_precision) {
  return attack_format(m, format, single_precision);
}

using P = AttackParams;
using Seed = std::uint64_t;
using Progress = ProgressCallback;
constexpr unsigned kSmoothing = kReadsLambda | kReadsFixedBoundary | kReadsWeighting;

const std::vector<AttackKind> kKinds = {
    {"reorder", "random vertex and face order (strength ignored)", true, 0, 0,
     [](const Mesh& m, double, const P&, Seed seed, const Progress&) {
       return attack_reorder(m, seed);
     },
     nullptr},
    {"similarity", "random rotation, translation and uniform scale up to STRENGTH", true, 2, 0,
     [](const Mesh& m, double x, const P&, Seed seed, const Progress&) {
       SimilarityOptions o;
       o.max_scale = x;
       return attack_similarity(m, seed, o);
     },
     nullptr},
    {"noise", "uniform noise, amplitude STRENGTH x bounding-box diagonal (paper)", true, 0, 0,
     [](const Mesh& m, double x, const P&, Seed seed, const Progress&) {
       return attack_noise(m, x, NoiseReference::Diagonal, seed);
     },
     nullptr},
    {"noise-radius",
     "uniform noise, amplitude STRENGTH x mean vertex-to-center distance (benchmark)", true, 0, 0,
     [](const Mesh& m, double x, const P&, Seed seed, const Progress&) {
       return attack_noise(m, x, NoiseReference::MeanRadius, seed);
     },
     nullptr},
    {"quant",
     "coordinates quantized to STRENGTH bits over the bounding box, step (max - min) / "
     "(2^b - 1) (--convention benchmark: / 2^b)",
     false, 0, kReadsConvention,
     [](const Mesh& m, double x, const P& p, Seed, const Progress&) {
       return attack_quantize(m, whole("quant", x), p.convention);
     },
     nullptr},
    {"smooth",
     "Laplacian smoothing, STRENGTH iterations, lambda 0.3 (--lambda), uniform weights, "
     "boundary moving (--fixed-boundary)",
     false, 0, kSmoothing,
     [](const Mesh& m, double x, const P& p, Seed, const Progress&) {
       return attack_smooth_laplacian(m, whole("smooth", x), laplacian_options(p));
     },
     nullptr},
    {"taubin",
     "Taubin smoothing, STRENGTH iterations, lambda 0.5, mu -0.526 (k_pb 0.1), uniform "
     "weights (--weighting inverse-distance: Open3D's)",
     false, 0, kSmoothing | kReadsMu,
     [](const Mesh& m, double x, const P& p, Seed, const Progress&) {
       return attack_smooth_taubin(m, whole("taubin", x), taubin_options(p));
     },
     nullptr},
    {"soup", "triangle soup, edges rescaled by STRENGTH, 0.01 % noise", true, 0, 0,
     [](const Mesh& m, double x, const P&, Seed seed, const Progress&) {
       return attack_triangle_soup(m, x, seed);
     },
     nullptr},
    {"simplify", "Lindstrom-Turk edge collapse down to STRENGTH x the faces", false, 0, 0,
     [](const Mesh& m, double x, const P&, Seed, const Progress& progress) {
       return attack_simplify(m, x, SimplifyCost::LindstromTurk, progress);
     },
     [](const Mesh& m, const std::vector<double>& xs) { return attack_simplify_levels(m, xs); }},
    {"qsimplify", "Garland-Heckbert (quadric) edge collapse down to STRENGTH x the faces", false, 0,
     0,
     [](const Mesh& m, double x, const P&, Seed, const Progress& progress) {
       return attack_simplify(m, x, SimplifyCost::GarlandHeckbert, progress);
     },
     [](const Mesh& m, const std::vector<double>& xs) {
       return attack_simplify_levels(m, xs, SimplifyCost::GarlandHeckbert);
     }},
    {"remesh", "isotropic remeshing (CGAL, 3 rounds) to STRENGTH x the mean edge length", false, 1,
     0,
     [](const Mesh& m, double x, const P&, Seed, const Progress& progress) {
       return attack_remesh(m, x, 3, progress);
     },
     nullptr},
    {"loop", "STRENGTH iterations of Loop subdivision", false, 1, 0,
     [](const Mesh& m, double x, const P&, Seed, const Progress& progress) {
       return subdivided(m, Subdivision::Loop, "loop", x, progress);
     },
     nullptr},
    {"midpoint", "STRENGTH iterations of midpoint subdivision", false, 1, 0,
     [](const Mesh& m, double x, const P&, Seed, const Progress& progress) {
       return subdivided(m, Subdivision::Midpoint, "midpoint", x, progress);
     },
     nullptr},
    {"sqrt3", "STRENGTH iterations of sqrt(3) subdivision", false, 1, 0,
     [](const Mesh& m, double x, const P&, Seed, const Progress& progress) {
       return subdivided(m, Subdivision::Sqrt3, "sqrt3", x, progress);
     },
     nullptr},
    {"crop", "remove the STRENGTH fraction of vertices beyond a random plane", true, 0, 0,
     [](const Mesh& m, double x, const P&, Seed seed, const Progress&) {
       return attack_crop(m, x, seed);
     },
     nullptr},
    {"float32", "binary PLY with float32 coordinates, and back", false, 0, 0,
     [](const Mesh& m, double, const P&, Seed, const Progress&) {
       return converted(m, "ply", true);
     },
     nullptr},
    {"to-obj", "written as OBJ and read back", false, 0, 0,
     [](const Mesh& m, double, const P&, Seed, const Progress&) {
       return converted(m, "obj", false);
     },
     nullptr},
    {"to-off", "written as OFF and read back", false, 0, 0,
     [](const Mesh& m, double, const P&, Seed, const Progress&) {
       return converted(m, "off", false);
     },
     nullptr},
    {"to-stl", "written as binary STL (float32, unwelded) and read back (welded)", false, 0, 0,
     [](const Mesh& m, double, const P&, Seed, const Progress&) {
       return converted(m, "stl", false);
     },
     nullptr},
};

}  // namespace

const std::vector<AttackKind>& attack_registry() {
  return kKinds;
}

const AttackKind* find_attack_kind(std::string_view name) {
  for (const AttackKind& k : kKinds)
    if (name == k.name) return &k;
  return nullptr;
}

const AttackKind& attack_kind(std::string_view name, std::string_view chain) {
  if (const AttackKind* k = find_attack_kind(name)) return *k;
  std::string kinds;
  for (const AttackKind& k : kKinds) kinds += (kinds.empty() ? "" : ", ") + std::string(k.name);
  const std::string in = chain.empty() || chain == name ? "" : fmt::format(" in '{}'", chain);
  throw InvalidArgumentError(fmt::format("unknown attack '{}'{} (the kinds: {})", name, in, kinds));
}

std::vector<AttackStep> parse_attack_chain(const std::string& text) {
  std::vector<AttackStep> steps;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t end = std::min(text.find(',', start), text.size());
    const std::string item = text.substr(start, end - start);
    const std::size_t colon = item.find(':');
    AttackStep step;
    step.kind = attack_kind(item.substr(0, colon), text).name;
    if (colon != std::string::npos &&
        !detail::parse_double(std::string_view(item).substr(colon + 1), step.strength))
      throw InvalidArgumentError(fmt::format("attack '{}': strength '{}' is not a number",
                                             step.kind, item.substr(colon + 1)));
    steps.push_back(step);
    start = end + 1;
  }
  return steps;
}

std::vector<AttackStep> attack_steps(const std::string& kind, double strength,
                                     const AttackParams& params) {
  std::vector<AttackStep> steps = parse_attack_chain(kind);
  if (kind.find_first_of(":,") == std::string::npos) steps[0].strength = strength;
  for (const AttackStep& s : steps)
    if (!std::isfinite(s.strength))
      throw InvalidArgumentError(
          fmt::format("attack '{}': strength {} is not a finite number", s.kind, s.strength));
  set_chain_params(steps, params);
  return steps;
}

bool attack_chain_is_deterministic(const std::string& chain) {
  const std::vector<AttackStep> steps = parse_attack_chain(chain);
  return std::none_of(steps.begin(), steps.end(),
                      [](const AttackStep& s) { return find_attack_kind(s.kind)->seeded; });
}

Mesh apply_attack(const Mesh& mesh, const AttackStep& s, std::uint64_t seed,
                  const ProgressCallback& progress) {
  validate_mesh(mesh);
  const AttackKind& kind = attack_kind(s.kind);
  check_attack_params(s.kind, s.params);
  // A kind that reports nothing is one phase of its own, so a chain's bar moves past it.
  bool reported = false;
  const ProgressCallback heard = progress
                                     ? ProgressCallback([&](const std::string& phase, long done,
                                                            long total, const std::string& what) {
                                         reported = true;
                                         progress(phase, done, total, what);
                                       })
                                     : ProgressCallback();
  if (progress) progress(s.kind, 0, 1, "");
  Mesh out =
      kind.apply(mesh, s.strength == 0 ? kind.default_strength : s.strength, s.params, seed, heard);
  if (progress && !reported) progress(s.kind, 1, 1, "");
  return out;
}

Mesh apply_attack_chain(const Mesh& mesh, const std::vector<AttackStep>& steps, std::uint64_t seed,
                        const ProgressCallback& progress) {
  Mesh out = mesh;
  Random seeds(seed);
  for (std::size_t k = 0; k < steps.size(); ++k) {
    const std::string prefix =
        steps.size() > 1 ? fmt::format("step {} of {}: ", k + 1, steps.size()) : std::string();
    const ProgressCallback step_progress =
        progress && !prefix.empty() ? ProgressCallback([&](const std::string& phase, long done,
                                                           long total, const std::string& what) {
          progress(prefix + phase, done, total, what);
        })
                                    : progress;
    out = apply_attack(out, steps[k], seeds.next(), step_progress);
  }
  return out;
}

}  // namespace meshmark
