// Closest points, the library's own tree against CGAL's AABB tree (the reference it replaced so
// that the core links no GPL code): build the tree over a mesh, then query 100,000 points near
// its surface (surface samples moved by Gaussian offsets of 0.1 % to 10 % of the diagonal, what
// registration and trace ask). CGAL's queries run on one thread: run with MESHMARK_THREADS=1
// to compare like with like (bench/README.md, "Closest points"). The `_far` cases move the
// mesh and the queries a million units from the origin, as a scan kept in its survey's
// coordinates lies: the own tree's single-precision boxes are relative to the mesh's center,
// so it should take as long there.

#include <benchmark/benchmark.h>

#include <random>

#include "bench_meshes.h"
#include "meshmark/metrics/metrics.h"
#include "metrics/cgal_closest_reference.h"
#include "metrics/closest_point.h"

using namespace meshmark;

namespace {

Eigen::MatrixX3d near_surface(const Mesh& m, int count) {
  const double diag = bounding_box_diagonal(m.V);
  Eigen::MatrixX3d Q = sample_surface(m.V, m.F, count, 3);
  std::mt19937_64 rng(7);
  std::normal_distribution<double> gauss;
  const double scales[3] = {1e-3, 1e-2, 1e-1};
  for (Eigen::Index i = 0; i < Q.rows(); ++i)
    for (int c = 0; c < 3; ++c) Q(i, c) += scales[i % 3] * diag * gauss(rng);
  return Q;
}

void closest(benchmark::State& state, const std::string& path, bool cgal, double offset = 0) {
  const Mesh* m = bench::load(path);
  if (!m) {
    state.SkipWithError("mesh not found");
    return;
  }
  const Eigen::MatrixX3d V = m->V.array() + offset;
  const Eigen::MatrixX3d Q = near_surface(*m, 100000).array() + offset;
  double sum = 0;
  for (auto _ : state) {
    if (cgal) {
      for (const auto& r : test::cgal_closest_points(V, m->F, Q)) sum += r.distance;
    } else {
      sum += closest_points(V, m->F, Q).distance.sum();
    }
  }
  benchmark::DoNotOptimize(sum);
  state.counters["faces"] = static_cast<double>(m->F.rows());
}

}  // namespace

BENCHMARK_CAPTURE(closest, own_bunny, bench::data("bunny.ply"), false)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(closest, cgal_bunny, bench::data("bunny.ply"), true)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(closest, own_refined_elephant, bench::cgal("refined_elephant.off"), false)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(closest, cgal_refined_elephant, bench::cgal("refined_elephant.off"), true)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(closest, own_refined_elephant_far, bench::cgal("refined_elephant.off"), false,
                  1e6)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(closest, cgal_refined_elephant_far, bench::cgal("refined_elephant.off"), true,
                  1e6)
    ->Unit(benchmark::kMillisecond);
