// Tracing a leak against the issued copies: refined_elephant (libcgal-demo, 44,460 vertices), one
// copy embedded (VRS, 64 bits) and 10,000 consecutive IDs issued, the leak processed as named; one
// trace() per iteration, registration included (the leak and the original are read before timing).

#include <benchmark/benchmark.h>

#include <filesystem>

#include "meshmark/attacks/attack.h"
#include "meshmark/carrier/variant.h"
#include "meshmark/forensics/trace.h"
#include "meshmark/io/io.h"
#include "meshmark/mark/embed.h"
#include "meshmark/protocol/watermark.h"

using namespace meshmark;

namespace {

void trace_leak(benchmark::State& state, const std::string& attack) {
  const std::string path = std::string(MESHMARK_CGAL_DATA) + "/refined_elephant.off";
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) {
    state.SkipWithError("refined_elephant.off not found");
    return;
  }
  const Mesh original = read_mesh(path);
  const Key key = key_from_passphrase("bench");
  EmbedOptions o;
  o.variant = parse_variant("VRS");
  o.strengths = mark_strengths(key, 64, true, o.strength, 0.25);
  Mesh leak = original;
  leak.V = embed(original.V, original.F, id_bins(IdCode(), 5000, key), o).V;
  if (!attack.empty()) leak = apply_attack_chain(leak, parse_attack_chain(attack), 1);
  std::vector<IssuedCopy> issued(10000);
  for (std::size_t i = 0; i < issued.size(); ++i) {
    issued[i].id = i;
    issued[i].variant = "VRS";
    issued[i].strength_spread = 0.25;
    issued[i].key_fingerprint = key_fingerprint(key);
  }
  bool named = true;
  for (auto _ : state) {
    const TraceResult r = trace(leak, original, issued, key);
    named = named && r.status == TraceStatus::Named && r.named[0].copy.id == 5000;
  }
  if (!named) state.SkipWithError("the leaker was not named");
  state.counters["vertices"] = static_cast<double>(leak.V.rows());
}

}  // namespace

BENCHMARK_CAPTURE(trace_leak, copy_10k_candidates, "")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(trace_leak, similarity_simplify30_10k_candidates, "similarity:2,simplify:0.3")
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(trace_leak, similarity_noise03_10k_candidates, "similarity:2,noise:0.003")
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(trace_leak, remesh_10k_candidates, "remesh:1")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(trace_leak, smooth10_10k_candidates, "smooth:10")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(trace_leak, crop50_10k_candidates, "similarity:2,crop:0.5")
    ->Unit(benchmark::kMillisecond);
