#pragma once
/// \file attack.h
/// Attacks of the mesh watermarking literature (the TIFS 2014 paper's section V; the
/// benchmark of Wang et al., SMI 2010), deterministic for a seed, working on real meshes with
/// their defects. Each returns a new mesh; attacks that keep the connectivity keep the file
/// image too, so the result can be written back in its format.

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "meshmark/core/enum_names.h"
#include "meshmark/core/mesh.h"
#include "meshmark/core/progress.h"

namespace meshmark {

/// Similarity transform: a uniformly random rotation, a translation of up to `translation`
/// times the bounding-box diagonal in each axis, and a uniform scale drawn log-uniformly in
/// [1 / max_scale, max_scale]. Distance ratios are preserved.
struct SimilarityOptions {
  double translation = 1.0;  ///< fraction of the bounding-box diagonal
  double max_scale = 2.0;    ///< >= 1
};

/// Applies a random similarity. Keeps the file image (connectivity unchanged).
Mesh attack_similarity(const Mesh& mesh, std::uint64_t seed, const SimilarityOptions& options = {});

/// Randomly permutes the vertices and the faces (and rotates each face's corner list
/// cyclically, keeping its orientation). The file image is dropped.
Mesh attack_reorder(const Mesh& mesh, std::uint64_t seed);

/// Uniformly random rotation matrix (Shoemake's quaternion method).
Eigen::Matrix3d random_rotation(std::uint64_t seed);

/// What the noise amplitude is relative to.
enum class NoiseReference {
  Diagonal,    ///< the bounding-box diagonal, as in the TIFS 2014 paper
  MeanRadius,  ///< the mean distance of the vertices to their centroid, as in Wang et al.
};

/// Adds uniform noise in [-A, A] to every coordinate of every vertex, A = amplitude times the
/// reference length. Keeps the file image.
Mesh attack_noise(const Mesh& mesh, double amplitude, NoiseReference reference, std::uint64_t seed);

/// The grid step of coordinate quantization to b bits over [min, max] of each axis.
enum class QuantizeConvention {
  Levels,     ///< step (max - min) / (2^b - 1): 2^b values, min and max on the grid (default)
  Benchmark,  ///< step (max - min) / 2^b, ties rounded down: the LIRIS benchmark's (MEPP's
              ///< Various_Processing, Wang et al. 2010); 2^b + 1 values
};

/// The names of QuantizeConvention's values.
template <>
struct EnumTable<QuantizeConvention> {
  static constexpr const char* what = "quantization convention";
  static constexpr NamedValue<QuantizeConvention> values[] = {
      {QuantizeConvention::Levels, "levels"}, {QuantizeConvention::Benchmark, "benchmark"}};
};

/// Rounds every coordinate onto the grid of `convention` spanning the bounding box, from the
/// minimum of each axis. 1 <= bits <= 52. Keeps the file image.
/// \throw InvalidArgumentError for bits outside 1..52.
Mesh attack_quantize(const Mesh& mesh, int bits,
                     QuantizeConvention convention = QuantizeConvention::Levels);

/// How an umbrella (Laplacian) step weights the neighbours of a vertex.
enum class SmoothWeighting {
  Uniform,          ///< each neighbour 1 / degree (Taubin 1995; the LIRIS benchmark's; default)
  InverseDistance,  ///< neighbour j weighted 1 / (|p_j - p_i| + 1e-12), normalized to sum 1
                    ///< (Open3D's filter_smooth_laplacian and filter_smooth_taubin)
};

/// The names of SmoothWeighting's values.
template <>
struct EnumTable<SmoothWeighting> {
  static constexpr const char* what = "weighting";
  static constexpr NamedValue<SmoothWeighting> values[] = {
      {SmoothWeighting::Uniform, "uniform"},
      {SmoothWeighting::InverseDistance, "inverse-distance"}};
};

/// Laplacian smoothing: every iteration p_i += lambda (weighted mean of the one-ring - p_i),
/// all vertices updated together from the previous positions.
struct LaplacianOptions {
  double lambda = 0.3;          ///< deformation factor (the TIFS 2014 paper's 0.3; LIRIS: 0.03)
  bool fixed_boundary = false;  ///< vertices on a boundary edge (one face) stay (LIRIS: true)
  SmoothWeighting weighting = SmoothWeighting::Uniform;  ///< neighbour weights
};

/// Laplacian smoothing, `iterations` steps (vertices without neighbours stay). Keeps the file
/// image. \throw InvalidArgumentError for iterations < 0.
Mesh attack_smooth_laplacian(const Mesh& mesh, int iterations,
                             const LaplacianOptions& options = {});

/// The same with lambda alone (uniform weights, boundary moving).
Mesh attack_smooth_laplacian(const Mesh& mesh, int iterations, double lambda);

/// Taubin smoothing (Taubin, ICCV 1995): each iteration a step of lambda, then one of mu
/// (negative: inflating), both umbrella steps with `weighting`.
struct TaubinOptions {
  double lambda = 0.5;  ///< shrinking factor, > 0
  double mu = 0;        ///< inflating factor, < 0; 0: from k_pb, 1/lambda + 1/mu = k_pb
  double k_pb = 0.1;    ///< pass-band frequency, used when mu is 0 (lambda 0.5: mu = -0.526)
  bool fixed_boundary = false;                           ///< boundary vertices stay
  SmoothWeighting weighting = SmoothWeighting::Uniform;  ///< neighbour weights
};

/// Taubin smoothing, `iterations` pairs of steps. Keeps the file image.
/// \throw InvalidArgumentError for iterations < 0, lambda <= 0 or mu > 0.
Mesh attack_smooth_taubin(const Mesh& mesh, int iterations, const TaubinOptions& options = {});

/// The same with lambda and k_pb alone (uniform weights, boundary moving).
Mesh attack_smooth_taubin(const Mesh& mesh, int iterations, double lambda, double k_pb = 0.1);

/// Repeated smoothing of the positions of one mesh's faces, the one-rings built once: what
/// attack_smooth_laplacian and attack_smooth_taubin do, for a caller that smooths step by step
/// (trace fits the smoothing a leak went through one iteration at a time).
class Smoother {
 public:
  /// For positions of nv vertices on the triangles F. Options' fixed_boundary and weighting are
  /// taken from each call.
  Smoother(const Eigen::MatrixX3i& F, Eigen::Index nv);
  /// `iterations` Laplacian steps on V (nv rows). \throw InvalidArgumentError for iterations < 0,
  /// a lambda that is not finite, or V of another size.
  void laplacian(Eigen::MatrixX3d& V, int iterations, const LaplacianOptions& options = {}) const;
  /// `iterations` Taubin pairs of steps on V. \throw InvalidArgumentError as
  /// attack_smooth_taubin.
  void taubin(Eigen::MatrixX3d& V, int iterations, const TaubinOptions& options = {}) const;

 private:
  void check_size(const Eigen::MatrixX3d& V) const;  // \throw unless V has nv rows
  Adjacency adjacency_;
  std::vector<std::uint8_t> boundary_;
};

/// 1 for every vertex on a boundary edge of F (an edge of exactly one triangle), else 0.
/// Size nv.
std::vector<std::uint8_t> boundary_vertices(const Eigen::MatrixX3i& F, Eigen::Index nv);

/// Triangle soup (TIFS 2014, sec. V-B): faces disconnected (three new vertices each), each
/// triangle scaled about its centroid by `ratio` (every edge rescaled, opening holes or making
/// overlaps), then uniform noise of noise_amplitude times the diagonal (0.01 % by default).
Mesh attack_triangle_soup(const Mesh& mesh, double ratio, std::uint64_t seed,
                          double noise_amplitude = 1e-4);

/// Removes `fraction` of the referenced vertices, those farthest along a random direction
/// (the side of a plane), with the faces that touch them; remaining vertices keep their order.
Mesh attack_crop(const Mesh& mesh, double fraction, std::uint64_t seed);

/// How colluders merge their copies of one original, vertex by vertex.
enum class CollusionKind {
  Average,  ///< every vertex the weighted mean of the copies' positions
  Splice,   ///< every vertex taken whole from one copy, by region (a cut and paste)
};

/// The names of CollusionKind's values.
template <>
struct EnumTable<CollusionKind> {
  static constexpr const char* what = "collusion";
  static constexpr NamedValue<CollusionKind> values[] = {{CollusionKind::Average, "average"},
                                                         {CollusionKind::Splice, "splice"}};
};

/// A collusion of buyers who each hold a copy of one original.
struct CollusionOptions {
  CollusionKind kind = CollusionKind::Average;
  /// Average only: one weight per copy, each >= 0 and finite, summing to more than 0
  /// (normalized to sum 1); empty: equal weights.
  std::vector<double> weights;
};

/// Merges copies of one original (the same vertex count and faces, as every copy `embed`
/// writes): Average gives vertex i the weighted mean of the copies' vertex i; Splice cuts
/// the surface into as many regions as copies (the Voronoi cells, in space, of vertices picked
/// by farthest-point sampling from a random first one on the first copy) and region j keeps
/// copy j's positions. The result has the first copy's faces and file image. Deterministic for
/// a seed (Splice's first vertex; Average does not use it).
/// \throw InvalidArgumentError for fewer than 2 copies, copies whose vertex counts or faces
/// differ (naming the copy), a copy validate_mesh refuses (a non-finite coordinate, a face
/// index out of range), weights not one per copy, negative, not finite or summing to 0,
/// or weights given to a Splice.
Mesh attack_collude(const std::vector<Mesh>& copies, const CollusionOptions& options,
                    std::uint64_t seed = 0);

/// The flat Dirichlet weights of `count` colluders for a seed: independent exponential draws
/// normalized to sum 1 (every split of the total equally likely), for an unequal average.
std::vector<double> random_collusion_weights(int count, std::uint64_t seed);

/// Writes the mesh to bytes in another format/encoding and reads it back (float32 storage
/// rounds the coordinates). single_precision selects float32 for binary PLY.
Mesh attack_format(const Mesh& mesh, const std::string& format, bool single_precision);

/// Edge-collapse costs and placements.
enum class SimplifyCost {
  LindstromTurk,    ///< Lindstrom-Turk (memoryless; the LIRIS benchmark's)
  GarlandHeckbert,  ///< Garland-Heckbert plane quadrics (MeshLab's and most tools' "quadric")
};

/// Edge-collapse simplification to `ratio` of the faces (0 < ratio <= 1), with the cost and
/// placement `cost` (CGAL Surface_mesh_simplification). The input is first turned into a
/// manifold CGAL can collapse: bit-identical positions merged, degenerate triangles (a
/// repeated corner, corners at one position, zero area) and duplicate ones removed, the soup
/// oriented (which splits non-manifold edges and vertices; CGAL's orient_polygon_soup).
/// `ratio` counts the triangles that remain. `progress` is called back in the phases "preparing
/// the mesh" (one step) and "collapsing edges" (faces removed, of those to remove; about every
/// 4,096 collapses): 141 s on 2.1 million vertices.
/// \throw InvalidArgumentError for a ratio outside (0, 1].
/// \throw InvalidInputError when no triangle of non-zero area remains.
Mesh attack_simplify(const Mesh& mesh, double ratio,
                     SimplifyCost cost = SimplifyCost::LindstromTurk,
                     const ProgressCallback& progress = {});

/// attack_simplify at several ratios from one run of collapses: out[k] is the mesh when it
/// first has at most ratios[k] of the faces, which is what attack_simplify(mesh, ratios[k],
/// cost) returns (the collapses are the same; only where a run stops differs). A level of
/// detail chain at the cost of its smallest level alone.
/// Progress as attack_simplify's, to the smallest level. \throw as attack_simplify.
std::vector<Mesh> attack_simplify_levels(const Mesh& mesh, const std::vector<double>& ratios,
                                         SimplifyCost cost = SimplifyCost::LindstromTurk,
                                         const ProgressCallback& progress = {});

/// Isotropic remeshing (CGAL Polygon_mesh_processing::isotropic_remeshing, `iterations`
/// rounds of splits, collapses, flips and tangential relaxation) to edges of `edge_factor`
/// times the mean edge length, after the same repair as attack_simplify. Every vertex moves:
/// the new ones lie on the old surface, not at the old vertices. `progress`: "preparing the
/// mesh", then "remeshing" (one step: CGAL runs the rounds in one call).
/// \throw InvalidArgumentError for edge_factor outside [0.05, 20] or iterations outside [1, 20].
/// \throw InvalidInputError when no triangle of non-zero area remains.
Mesh attack_remesh(const Mesh& mesh, double edge_factor, int iterations = 3,
                   const ProgressCallback& progress = {});

/// Subdivision schemes.
enum class Subdivision { Loop, Midpoint, Sqrt3 };

/// `iterations` steps of Loop, midpoint (linear 1-to-4) or sqrt(3) subdivision (CGAL
/// Subdivision_method_3), after the same repair as attack_simplify (Loop and sqrt(3) only).
/// `progress`: "subdividing", the iterations done of `iterations` (each multiplies the faces by
/// 3 or 4: the last takes most of the time).
/// \throw InvalidInputError (Loop, sqrt(3)) when no triangle of non-zero area remains.
Mesh attack_subdivide(const Mesh& mesh, Subdivision scheme, int iterations,
                      const ProgressCallback& progress = {});

/// Parameters of the attacks whose definition the literature varies. Each kind reads the ones
/// that concern it and refuses the others (check_attack_params); a default AttackParams gives
/// the attack as attack_registry() describes it.
struct AttackParams {
  double lambda = 0;            ///< smooth, taubin: lambda; 0 = the kind's default (0.3, 0.5)
  double mu = 0;                ///< taubin: mu (< 0); 0 = from k_pb 0.1
  bool fixed_boundary = false;  ///< smooth, taubin: boundary vertices stay
  SmoothWeighting weighting = SmoothWeighting::Uniform;        ///< smooth, taubin
  QuantizeConvention convention = QuantizeConvention::Levels;  ///< quant
};

/// True when every parameter has its default value.
bool attack_params_default(const AttackParams& params);

/// The non-default parameters as "lambda=0.03 mu=-0.53 fixed_boundary
/// weighting=inverse-distance convention=benchmark" ("" when all are default), numbers as {:g}.
std::string attack_params_label(const AttackParams& params);

/// Refuses parameters that `kind` (one step, not a chain) does not read, and out-of-range ones.
/// \throw InvalidArgumentError naming the kind and the parameter.
void check_attack_params(const std::string& kind, const AttackParams& params);

/// "uniform", "inverse-distance"; and back (\throw InvalidArgumentError for another name).
const char* smooth_weighting_name(SmoothWeighting weighting);
SmoothWeighting parse_smooth_weighting(const std::string& name);

/// "levels", "benchmark"; and back (\throw InvalidArgumentError for another name).
const char* quantize_convention_name(QuantizeConvention convention);
QuantizeConvention parse_quantize_convention(const std::string& name);

/// One step of an attack chain: a kind, its strength and its parameters.
struct AttackStep {
  std::string kind;  ///< an AttackKind's name (attack_registry())
  double strength = 0;
  AttackParams params;  ///< defaults: the kind as attack_registry() describes it
};

/// Gives every step of a chain the parameters of `params` that its kind reads (the others
/// keep their own). \throw InvalidArgumentError when a non-default parameter is read by no
/// step (a "lambda" for a chain without smoothing), naming it.
void set_chain_params(std::vector<AttackStep>& steps, const AttackParams& params);

/// The AttackParams fields a kind reads (bits of AttackKind::params).
enum AttackParamBits : unsigned {
  kReadsLambda = 1u << 0,         ///< AttackParams::lambda
  kReadsMu = 1u << 1,             ///< AttackParams::mu
  kReadsFixedBoundary = 1u << 2,  ///< AttackParams::fixed_boundary
  kReadsWeighting = 1u << 3,      ///< AttackParams::weighting
  kReadsConvention = 1u << 4,     ///< AttackParams::convention
};

/// One attack kind as chains, campaigns, the CLI and Python name it: the single place that
/// says what a kind is called, means, reads and runs.
struct AttackKind {
  const char* name;         ///< "noise", "quant", ... (a step of a chain: "name:strength")
  const char* meaning;      ///< what STRENGTH means, one line (its default: default_strength)
  bool seeded;              ///< its result depends on the seed (false: deterministic)
  double default_strength;  ///< what a strength of 0 means (0 for most kinds)
  unsigned params;          ///< the AttackParams it reads (AttackParamBits)
  /// Runs it: the mesh, the strength (default_strength when 0 was given), the parameters
  /// (checked), the seed; the long ones (simplify, qsimplify, remesh, the subdivisions) report
  /// their phases to `progress`, the others nothing.
  Mesh (*apply)(const Mesh& mesh, double strength, const AttackParams& params, std::uint64_t seed,
                const ProgressCallback& progress);
  /// For the edge-collapse kinds, every strength of a series from one run of collapses
  /// (attack_simplify_levels: out[k] is apply's result at strengths[k]); nullptr for others.
  std::vector<Mesh> (*levels)(const Mesh& mesh, const std::vector<double>& strengths);
};

/// Every kind apply_attack knows, in the order help texts list them.
const std::vector<AttackKind>& attack_registry();

/// The names of the AttackParams fields in `bits` (AttackParamBits), in AttackParams' order:
/// "lambda", "mu", "fixed_boundary", "weighting", "convention".
std::vector<std::string> attack_param_names(unsigned bits);

/// The kind called `name` (exactly), or nullptr.
const AttackKind* find_attack_kind(std::string_view name);

/// The kind called `name`. \throw InvalidArgumentError for an unknown name, listing the kinds
/// (and naming the chain it is in, when given).
const AttackKind& attack_kind(std::string_view name, std::string_view chain = {});

/// True when every step of a chain ("quant:8,simplify") is a kind whose output does not depend
/// on the seed. \throw InvalidArgumentError for an unknown kind.
bool attack_chain_is_deterministic(const std::string& chain);

/// Parses "noise:0.001,quant:10" into steps. \throw InvalidArgumentError naming the bad step.
std::vector<AttackStep> parse_attack_chain(const std::string& text);

/// The steps of an attack as a command line gives it: `kind` is one kind (then it runs at
/// `strength`) or a chain "noise:0.001,quant:10" (then `strength` is unused), and `params` go
/// to every step that reads them (set_chain_params).
/// \throw InvalidArgumentError for an unknown kind, a strength that is not a finite number, or
/// a parameter no step reads.
std::vector<AttackStep> attack_steps(const std::string& kind, double strength,
                                     const AttackParams& params);

/// Applies one step (seeded). `progress` hears the kind's own phases, or for a kind that has
/// none one phase named after it (0 of 1 when it starts, 1 of 1 when it ends).
/// \throw InvalidArgumentError for an unknown kind or strength, or a parameter the kind does
/// not read.
Mesh apply_attack(const Mesh& mesh, const AttackStep& step, std::uint64_t seed,
                  const ProgressCallback& progress = {});

/// Applies a chain, step k seeded with a value derived from seed and k. With several steps,
/// each phase apply_attack reports is prefixed "step k of n: ".
Mesh apply_attack_chain(const Mesh& mesh, const std::vector<AttackStep>& steps, std::uint64_t seed,
                        const ProgressCallback& progress = {});

}  // namespace meshmark
