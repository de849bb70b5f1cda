// Tracing a leak against the issued copies: refined_elephant (libcgal-demo, 44,460 vertices), one
// copy embedded (VRS, 64 bits) and 10,000 consecutive IDs issued, the leak processed as named; one
// trace() per iteration, registration included (the leak and the original are read before timing).

#include <benchmark/benchmark.h>

#include <filesystem>

#include "meshmark/attacks/attack.h"
#include "meshmark/carrier/variant.h"
#include "meshmark/forensics/fingerprint.h"
#include "meshmark/forensics/trace.h"
#include "meshmark/io/io.h"
#include "meshmark/mark/embed.h"
#include "meshmark/protocol/coding.h"
#include "meshmark/protocol/watermark.h"

using namespace meshmark;

namespace {

// refined_elephant and the copy of ID 5000 issued from it under the bench's key (64 bits,
// spread 0.25, the variant given); false (the state skipped) when the mesh is missing.
bool elephant_copy(benchmark::State& state, const std::string& variant, Mesh& original, Mesh& copy,
                   Key& key) {
  const std::string path = std::string(MESHMARK_CGAL_DATA) + "/refined_elephant.off";
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) {
    state.SkipWithError("refined_elephant.off not found");
    return false;
  }
  original = read_mesh(path);
  key = key_from_passphrase("bench");
  EmbedOptions o;
  o.variant = parse_variant(variant);
  o.strengths = mark_strengths(key, 64, true, o.strength, 0.25);
  copy = original;
  copy.V = embed(original.V, original.F, id_bins(IdCode(), 5000, key), o).V;
  return true;
}

// The registry's rows of IDs 0 .. n - 1 issued as elephant_copy issues them.
std::vector<IssuedCopy> consecutive_copies(std::size_t n, const Key& key,
                                           const std::string& variant, int mark_format) {
  std::vector<IssuedCopy> issued(n);
  for (std::size_t i = 0; i < n; ++i) {
    issued[i].id = i;
    issued[i].variant = variant;
    issued[i].strength_spread = 0.25;
    issued[i].key_fingerprint = key_fingerprint(key);
    issued[i].mark_format = mark_format;
  }
  return issued;
}

void trace_leak(benchmark::State& state, const std::string& attack) {
  Mesh original, leak;
  Key key;
  if (!elephant_copy(state, "VRS", original, leak, key)) return;
  if (!attack.empty()) leak = apply_attack_chain(leak, parse_attack_chain(attack), 1);
  const std::vector<IssuedCopy> issued = consecutive_copies(10000, key, "VRS", kMarkFormatVersion);
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

namespace {

// Tracing at registry scale: refined_elephant, the copy of ID 5000 issued with both marks
// (mark format 4: DRS histogram mark plus the fingerprint), `candidates` consecutive IDs
// issued, the leak processed as named; one trace() per iteration, registration included.
void trace_scale(benchmark::State& state, const std::string& attack) {
  const std::size_t candidates = static_cast<std::size_t>(state.range(0));
  Mesh original, leak;
  Key key;
  if (!elephant_copy(state, "DRS", original, leak, key)) return;
  const std::optional<FingerprintFrame> frame =
      fingerprint_frame(original.V, original.F, CenterKind::Discrete, 64);
  if (!frame) {
    state.SkipWithError("no fingerprint basis");
    return;
  }
  leak.V = add_fingerprint(leak.V, original.V, frame->basis,
                           fingerprint_coefficients(key, 5000, frame->basis.functions),
                           FingerprintOptions().rms, &frame->histogram, &frame->center_motion);
  if (!attack.empty()) leak = apply_attack_chain(leak, parse_attack_chain(attack), 1);
  const std::vector<IssuedCopy> issued =
      consecutive_copies(candidates, key, "DRS", kFingerprintMarkFormat);
  bool named = true;
  TraceResult r;
  for (auto _ : state) {
    r = trace(leak, original, issued, key);
    named = named && r.status == TraceStatus::Named && r.named[0].copy.id == 5000;
  }
  if (!named) state.counters["not_named"] = 1;
  state.counters["scoring_s"] = r.seconds.scoring;
  state.counters["registration_s"] = r.seconds.registration;
  state.counters["corrected_p"] = r.ranking.empty() ? 1.0 : r.ranking.front().corrected_p;
  for (const CandidateScore& s : r.ranking)
    if (s.copy.id == 5000) {
      state.counters["leaker_z"] = s.fingerprint_z;
      state.counters["leaker_bits"] = s.matches;
    }
}

}  // namespace

BENCHMARK_CAPTURE(trace_scale, copy, "")
    ->Arg(10000)
    ->Arg(100000)
    ->Arg(1000000)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(trace_scale, simplify30, "similarity:2,simplify:0.3")
    ->Arg(10000)
    ->Arg(100000)
    ->Arg(1000000)
    ->Unit(benchmark::kMillisecond);

namespace {

// A candidate's share of trace's scoring, per item: its codeword (64 bits, 32-bit IDs,
// consecutive IDs in batches of 256 as trace encodes them) and its fingerprint score
// (K = 512, two readings), on one thread.
void candidate_codewords(benchmark::State& state) {
  const Key key = key_from_passphrase_v1("bench");
  const CodewordEncoder encoder(IdCode(), key);
  std::vector<std::uint64_t> ids(256), out(256 * static_cast<std::size_t>(encoder.words()));
  std::uint64_t next = 0;
  for (auto _ : state) {
    for (std::uint64_t& id : ids) id = next++;
    encoder.encode(ids.data(), ids.size(), out.data());
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(ids.size()));
}

void candidate_fingerprint(benchmark::State& state) {
  const Key key = key_from_passphrase_v1("bench");
  const FingerprintScorer scorer(key, 512,
                                 {Eigen::VectorXd::Random(512), Eigen::VectorXd::Random(512)});
  const int format = static_cast<int>(state.range(0));
  std::uint64_t next = 0;
  for (auto _ : state) benchmark::DoNotOptimize(scorer.best_z(next++, format));
  state.SetItemsProcessed(state.iterations());
}

}  // namespace

BENCHMARK(candidate_codewords);
BENCHMARK(candidate_fingerprint)->Arg(kFingerprintMarkFormat)->Arg(kGaussianFingerprintFormat);

namespace {

void keyed_hash_digest(benchmark::State& state) {
  const KeyedHash hash(key_from_passphrase_v1("bench"), "id-feistel", 24);
  std::array<std::uint8_t, 9> data{};
  std::array<std::uint8_t, 64> out{};
  for (auto _ : state) {
    ++data[8];
    hash.digest(data.data(), data.size(), out.data());
    benchmark::DoNotOptimize(out.data());
  }
}

}  // namespace

BENCHMARK(keyed_hash_digest);
