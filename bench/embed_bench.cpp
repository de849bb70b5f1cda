// Embedding and decoding times on real meshes, without file I/O (meshes are read once, before
// timing). Run: build/bench/meshmark_bench --benchmark_repetitions=5
// --benchmark_report_aggregates_only=true, and report medians.

#include <benchmark/benchmark.h>

#include <malloc.h>
#include <algorithm>

#include <filesystem>
#include <map>

#include "bench_meshes.h"
#include "meshmark/attacks/attack.h"
#include "meshmark/carrier/roughness.h"
#include "meshmark/forensics/registry.h"
#include "meshmark/io/io.h"
#include "meshmark/mark/decode.h"
#include "meshmark/mark/embed.h"
#include "meshmark/metrics/metrics.h"

using namespace meshmark;

namespace {

using bench::cgal;
using bench::data;
using bench::load;

// Embeds 64 bits into m with the variant, once per iteration.
void embed_mesh(benchmark::State& state, const Mesh* m, const std::string& path,
                const char* variant) {
  if (!m) return state.SkipWithError(("missing " + path).c_str());
  const Payload p = random_payload(64, 1);
  EmbedOptions o;
  o.variant = parse_variant(variant);
  for (auto _ : state) {
    EmbedResult r = embed(m->V, m->F, p, o);
    if (r.status != EmbedStatus::Embedded) state.SkipWithError(r.message.c_str());
    benchmark::DoNotOptimize(r.V.data());
  }
  state.counters["vertices"] = static_cast<double>(m->V.rows());
  state.SetItemsProcessed(state.iterations() * m->V.rows());
}

void embed_variant(benchmark::State& state, const std::string& path, const char* variant) {
  embed_mesh(state, load(path), path, variant);
}

// A real mesh made larger by Loop subdivision (cached), for the scaling benchmarks.
const Mesh* subdivided(const std::string& path, int times) {
  static std::map<std::pair<std::string, int>, Mesh> cache;
  auto it = cache.find({path, times});
  if (it != cache.end()) return &it->second;
  const Mesh* m = load(path);
  if (!m) return nullptr;
  return &cache.emplace(std::pair{path, times}, attack_subdivide(*m, Subdivision::Loop, times))
              .first->second;
}

void embed_scaling(benchmark::State& state, const std::string& path, const char* variant) {
  embed_mesh(state, subdivided(path, static_cast<int>(state.range(0))), path, variant);
}

// About a million vertices: refined_elephant (44k) after three sqrt(3) subdivisions (1.2M),
// cached.
const Mesh* million() {
  static const Mesh* m = [] {
    const Mesh* base = load(cgal("refined_elephant.off"));
    return base ? new Mesh(attack_subdivide(*base, Subdivision::Sqrt3, 3)) : nullptr;
  }();
  return m;
}

void embed_million(benchmark::State& state, const char* variant) {
  embed_mesh(state, million(), cgal("refined_elephant.off"), variant);
}

// Every attack at a representative strength on refined_elephant (44k vertices), seeded.
void attack(benchmark::State& state, const std::string& path, const std::string& kind,
            double strength) {
  const Mesh* m = load(path);
  if (!m) return state.SkipWithError(("missing " + path).c_str());
  std::uint64_t seed = 1;
  for (auto _ : state) {
    Mesh out = apply_attack(*m, {kind, strength}, seed++);
    benchmark::DoNotOptimize(out.V.data());
  }
  state.SetItemsProcessed(state.iterations() * m->V.rows());
}

void roughness(benchmark::State& state, const std::string& path) {
  const Mesh* m = load(path);
  if (!m) return state.SkipWithError(("missing " + path).c_str());
  for (auto _ : state) {
    RoughnessField f = roughness_field(m->V, m->F);
    benchmark::DoNotOptimize(f.smoothness.data());
  }
  state.SetItemsProcessed(state.iterations() * m->V.rows());
}

// The same embedding by the structured solver and by Ipopt: times (ours the median of five
// runs, Ipopt's of one, as it takes seconds), and the relative difference of the squared
// displacements (objectives).
void versus_ipopt(benchmark::State& state, const std::string& path, const char* variant) {
  const Mesh* m = load(path);
  if (!m) return state.SkipWithError(("missing " + path).c_str());
  const Payload p = random_payload(64, 1);
  EmbedOptions native;
  native.variant = parse_variant(variant);
  EmbedOptions ipopt = native;
  ipopt.backend = SolverBackend::Ipopt;
  double ours = 0, theirs = 0, gap = 0;
  for (auto _ : state) {
    std::vector<double> seconds;
    EmbedResult a;
    for (int run = 0; run < 5; ++run) {
      a = embed(m->V, m->F, p, native);
      seconds.push_back(a.seconds);
    }
    const EmbedResult b = embed(m->V, m->F, p, ipopt);
    if (a.status != EmbedStatus::Embedded || b.status != EmbedStatus::Embedded)
      state.SkipWithError("not embedded");
    std::sort(seconds.begin(), seconds.end());
    ours = seconds[2], theirs = b.seconds;
    gap = std::abs(a.squared_displacement - b.squared_displacement) / b.squared_displacement;
  }
  state.counters["native_ms"] = 1e3 * ours;
  state.counters["ipopt_ms"] = 1e3 * theirs;
  state.counters["speedup"] = theirs / ours;
  state.counters["objective_gap"] = gap;
}

// Metrics on a 44k-vertex pair: refined_elephant against a noisy copy (0.1 % of the diagonal).
void metric(benchmark::State& state, const std::string& path, int which) {
  const Mesh* m = load(path);
  if (!m) return state.SkipWithError(("missing " + path).c_str());
  const Mesh n = attack_noise(*m, 0.001, NoiseReference::Diagonal, 1);
  for (auto _ : state) {
    double v = 0;
    if (which == 0) v = surface_distance(m->V, m->F, n.V, n.F).hausdorff;
    if (which == 1) v = msdm(m->V, n.V, m->F).global;
    if (which == 2) v = msdm2(m->V, m->F, n.V, n.F).global;
    benchmark::DoNotOptimize(v);
  }
}

void extract_drs(benchmark::State& state, const std::string& path) {
  const Mesh* m = load(path);
  if (!m) return state.SkipWithError(("missing " + path).c_str());
  for (auto _ : state) {
    ExtractResult r = extract(m->V, m->F);
    benchmark::DoNotOptimize(r.bits.data());
  }
  state.SetItemsProcessed(state.iterations() * m->V.rows());  // items/s = vertices per second
}

}  // namespace

#define EMBED(variant, name, file)                                         \
  BENCHMARK_CAPTURE(embed_variant, variant##_##name, cgal(file), #variant) \
      ->Unit(benchmark::kMillisecond)
EMBED(DRS, bunny00_38k, "bunny00.off");
EMBED(DRS, elephant_44k, "refined_elephant.off");
EMBED(DRS, diplodocus_24k, "diplodocus.off");
EMBED(VRS, bunny00_38k, "bunny00.off");
EMBED(VRS, elephant_44k, "refined_elephant.off");
EMBED(SRS, elephant_44k, "refined_elephant.off");
EMBED(VRQ, elephant_44k, "refined_elephant.off");
EMBED(VRL, elephant_44k, "refined_elephant.off");
EMBED(VNS, elephant_44k, "refined_elephant.off");
EMBED(VSS, elephant_44k, "refined_elephant.off");
BENCHMARK_CAPTURE(roughness, elephant_44k, cgal("refined_elephant.off"))
    ->Unit(benchmark::kMillisecond);
// refined_elephant subdivided 0, 1, 2 times: 44k, 178k, 711k vertices.
BENCHMARK_CAPTURE(embed_scaling, DRS_elephant_loop, cgal("refined_elephant.off"), "DRS")
    ->DenseRange(0, 2)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(embed_scaling, VRS_elephant_loop, cgal("refined_elephant.off"), "VRS")
    ->DenseRange(0, 2)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(versus_ipopt, DRS_bunny00_38k, cgal("bunny00.off"), "DRS")
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(versus_ipopt, VRS_bunny00_38k, cgal("bunny00.off"), "VRS")
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(versus_ipopt, VRL_spot_3k, data("spot.obj"), "VRL")
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(versus_ipopt, VRL_bunny_8k, data("bunny.ply"), "VRL")
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(embed_million, DRS_elephant_sqrt3x3_1200k, "DRS")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(embed_million, VRS_elephant_sqrt3x3_1200k, "VRS")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(metric, hausdorff_and_mrms_elephant_44k, cgal("refined_elephant.off"), 0)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(metric, msdm_elephant_44k, cgal("refined_elephant.off"), 1)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(metric, msdm2_elephant_44k, cgal("refined_elephant.off"), 2)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(extract_drs, bunny00_38k, cgal("bunny00.off"))->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(extract_drs, diplodocus_24k, cgal("diplodocus.off"))
    ->Unit(benchmark::kMillisecond);

// The registry: one batch of 10,000 issued copies recorded in one transaction into a fresh
// SQLite file (WAL), as `embed --batch --registry` does; copies per second.
void registry_batch(benchmark::State& state) {
  const std::string db = std::filesystem::temp_directory_path() / "meshmark-bench-registry.db";
  std::vector<IssuedCopy> batch(10000);
  for (std::size_t i = 0; i < batch.size(); ++i) {
    batch[i].original_hash = std::string(64, 'a');
    batch[i].original_path = "/shop/original.ply";
    batch[i].buyer = "buyer " + std::to_string(i);
    batch[i].id = i;
    batch[i].key_fingerprint = std::string(32, 'f');
    batch[i].output_path = "/shop/out/" + std::to_string(i) + ".ply";
    batch[i].output_hash = std::string(64, 'b');
  }
  for (auto _ : state) {
    state.PauseTiming();
    for (const char* suffix : {"", "-wal", "-shm"}) std::filesystem::remove(db + suffix);
    Registry registry(db);
    state.ResumeTiming();
    benchmark::DoNotOptimize(registry.record(batch));
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(batch.size()));
}
BENCHMARK(registry_batch)->Unit(benchmark::kMillisecond);

int main(int argc, char** argv) {
  // As the CLI does: keep large temporaries on the heap instead of mapping pages each time.
  mallopt(M_MMAP_THRESHOLD, 1 << 30);
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
  // One benchmark per attack kind, at a strength typical of the campaigns.
  const std::map<std::string, double> strengths = {
      {"noise", 0.001}, {"noise-radius", 0.001}, {"quant", 10},     {"smooth", 10},
      {"taubin", 10},   {"soup", 0.95},          {"simplify", 0.5}, {"qsimplify", 0.5},
      {"loop", 1},      {"midpoint", 1},         {"sqrt3", 1},      {"crop", 0.1},
      {"similarity", 2}};
  for (const AttackKind& k : attack_registry()) {
    const std::string kind = k.name;
    const auto it = strengths.find(kind);
    const double x = it == strengths.end() ? 0.0 : it->second;
    benchmark::RegisterBenchmark(("attack/" + kind + "_elephant_44k").c_str(), attack,
                                 cgal("refined_elephant.off"), kind, x)
        ->Unit(benchmark::kMillisecond);
  }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
