// MSDM on real meshes: the original's side (MsdmReference construction) and one comparison
// against an embedded-like copy (noise of 0.02 % of the diagonal), as calibration calls it.
// Run: build/bench/meshmark_bench --benchmark_filter=msdm_ --benchmark_repetitions=5
// --benchmark_report_aggregates_only=true, and report medians.

#include <benchmark/benchmark.h>

#include <filesystem>
#include <map>
#include <string>

#include "meshmark/attack.h"
#include "meshmark/io.h"
#include "meshmark/metrics.h"

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
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return nullptr;
  ReadOptions ro;
  ro.keep_image = false;
  Mesh m = read_mesh(path, ro);
  Mesh n = attack_noise(m, 0.0002, NoiseReference::Diagonal, 1);
  return &cache.emplace(path, Pair{std::move(m), std::move(n)}).first->second;
}

std::string shared(const char* name) {
  return std::string(MESHMARK_SHARED_DIR) + "/meshes/" + name;
}

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

BENCHMARK_CAPTURE(msdm_reference, horse_48k, shared("horse.ply"))->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(msdm_compare, horse_48k, shared("horse.ply"))->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(msdm_reference, igea_134k, shared("igea.ply"))->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(msdm_compare, igea_134k, shared("igea.ply"))->Unit(benchmark::kMillisecond);
