// MSDM on real meshes: the original's side (MsdmReference construction) and one comparison
// against an embedded-like copy (noise of 0.02 % of the diagonal), as calibration calls it.
// Run: build/bench/meshmark_bench --benchmark_filter=msdm_ --benchmark_repetitions=5
// --benchmark_report_aggregates_only=true, and report medians.

#include <benchmark/benchmark.h>

#include <map>
#include <string>

#include "bench_meshes.h"
#include "meshmark/attacks/attack.h"
#include "meshmark/io/io.h"
#include "meshmark/metrics/metrics.h"

using namespace meshmark;

namespace {

// The mesh at path and its noisy copy, read and generated once.
struct Pair {
  Mesh original, copy;
};

const Pair* pair_of(const std::string& path) {
  static std::map<std::string, Pair> cache;
  auto it = cache.find(path);
  if (it != cache.end()) return &it->second;
  const Mesh* m = bench::load(path);
  if (!m) return nullptr;
  Pair p{*m, attack_noise(*m, 0.0002, NoiseReference::Diagonal, 1)};
  return &cache.emplace(path, std::move(p)).first->second;
}

using bench::cgal;
using bench::data;

void msdm_reference(benchmark::State& state, const std::string& path) {
  const Pair* p = pair_of(path);
  if (!p) return state.SkipWithError(("missing " + path).c_str());
  for (auto _ : state) {
    MsdmReference ref(p->original.V, p->original.F);
    benchmark::DoNotOptimize(ref.longest_side());
  }
  state.counters["vertices"] = static_cast<double>(p->original.V.rows());
}

void msdm_compare(benchmark::State& state, const std::string& path) {
  const Pair* p = pair_of(path);
  if (!p) return state.SkipWithError(("missing " + path).c_str());
  const MsdmReference ref(p->original.V, p->original.F);
  double global = 0;
  for (auto _ : state) {
    global = ref.compare(p->copy.V).global;
    benchmark::DoNotOptimize(global);
  }
  state.counters["msdm"] = global;
}

}  // namespace

BENCHMARK_CAPTURE(msdm_reference, elephant_44k, cgal("refined_elephant.off"))
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(msdm_compare, elephant_44k, cgal("refined_elephant.off"))
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(msdm_reference, diplodocus_24k, cgal("diplodocus.off"))
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(msdm_compare, diplodocus_24k, cgal("diplodocus.off"))
    ->Unit(benchmark::kMillisecond);
