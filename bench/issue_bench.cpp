// The registry's share of issuing one copy, against registries already holding 0, 10^4, 10^5
// and 10^6 copies of the same original under the same key (issue #31: a copy per download in
// constant time). One copy per iteration, as issue_copies (src/forensics/issue.cpp) asks the
// registry: the ID chosen (free_ids, id:auto) or given, the duplicate check (conflicts), the
// spacing check (close_codewords) and the row reserved (reserve). Embedding and writing the
// file, the same whatever the registry holds, are left out.
//
// The registries are built once, by id:auto's own order (SpacedIds), and kept in the temporary
// folder (meshmark-bench-registry-N.db) for the next run: a million rows take minutes to build.
// Each repetition works on a fresh copy of that file.

#include <benchmark/benchmark.h>
#include <fmt/format.h>

#include <filesystem>
#include <string>
#include <vector>

#include "meshmark/forensics/registry.h"
#include "meshmark/forensics/spacing.h"
#include "meshmark/protocol/coding.h"

using namespace meshmark;
namespace fs = std::filesystem;

namespace {

const Key& bench_key() {
  static const Key key = derive_key(public_key(), "issue bench");
  return key;
}

IssuedCopy bench_copy() {
  IssuedCopy c;
  c.original_hash = std::string(64, 'a');
  c.original_geometry = std::string(64, 'b');
  c.original_path = "/shop/originals/asset.glb";
  c.key_fingerprint = key_fingerprint(bench_key());
  c.output_path = "/shop/copies/asset.glb";
  c.output_hash = std::string(64, 'c');
  return c;
}

// The path of a registry holding `rows` copies issued by id:auto, built when missing.
std::string registry_with(std::size_t rows) {
  const fs::path path = fs::temp_directory_path() / fmt::format("meshmark-bench-registry-v{}-{}.db",
                                                                kRegistrySchemaVersion, rows);
  if (fs::exists(path)) return path.string();
  const fs::path partial = path.string() + ".partial";
  fs::remove(partial);
  {
    Registry registry(partial.string());
    const SpacedIds span(IdCode(IdCodeOptions{}), bench_key());
    std::vector<IssuedCopy> batch;
    std::uint64_t position = 0;
    for (std::size_t done = 0; done < rows;) {
      const std::optional<std::uint64_t> id = span.id_at(position++);
      if (!id) continue;
      IssuedCopy c = bench_copy();
      c.id = *id;
      c.buyer = fmt::format("buyer {}", done);
      batch.push_back(c);
      if (++done % 10000 == 0 || done == rows)
        registry.record(std::move(batch), bench_key()), batch.clear();
    }
  }
  for (const char* suffix : {"-wal", "-shm"}) fs::remove(partial.string() + suffix);
  fs::rename(partial, path);
  return path.string();
}

// A fresh copy of the registry of `rows` copies, for one repetition.
std::string working_copy(std::size_t rows) {
  const std::string from = registry_with(rows);
  const std::string to = (fs::temp_directory_path() / "meshmark-bench-registry-work.db").string();
  for (const char* suffix : {"", "-wal", "-shm"}) fs::remove(to + suffix);
  fs::copy_file(from, to);
  return to;
}

// One copy issued with id:auto per iteration.
void issue_auto_id(benchmark::State& state) {
  const std::size_t rows = static_cast<std::size_t>(state.range(0));
  const std::string path = working_copy(rows);
  Registry registry(path);
  std::size_t n = 0;
  for (auto _ : state) {
    IssuedCopy c = bench_copy();
    c.buyer = fmt::format("new buyer {}", n++);
    c.id = free_ids(registry, {}, {c}, bench_key()).at(0);
    if (!registry.conflicts({c}).empty() || !close_codewords(registry, {c}, bench_key()).empty())
      state.SkipWithError("the chosen ID is refused");
    benchmark::DoNotOptimize(registry.reserve({c}, bench_key()));
  }
  state.counters["rows"] = static_cast<double>(rows);
}

// One copy issued with an ID given by hand per iteration: the spacing check compares it with
// every copy of the group (an ID given by hand lies outside the span, but for 1 in 4,096).
void issue_given_id(benchmark::State& state) {
  const std::size_t rows = static_cast<std::size_t>(state.range(0));
  const std::string path = working_copy(rows);
  Registry registry(path);
  std::uint64_t id = 4000000000u;
  for (auto _ : state) {
    IssuedCopy c = bench_copy();
    c.id = id++;
    c.buyer = fmt::format("buyer by hand {}", c.id);
    if (!registry.conflicts({c}).empty() || !close_codewords(registry, {c}, bench_key()).empty())
      continue;  // too close to an issued one: refused, as issue_copies would
    benchmark::DoNotOptimize(registry.reserve({c}, bench_key()));
  }
  state.counters["rows"] = static_cast<double>(rows);
}

}  // namespace

BENCHMARK(issue_auto_id)
    ->Name("issue_registry/auto_id")
    ->Arg(0)
    ->Arg(10000)
    ->Arg(100000)
    ->Arg(1000000)
    ->Unit(benchmark::kMillisecond);
BENCHMARK(issue_given_id)
    ->Name("issue_registry/given_id")
    ->Arg(0)
    ->Arg(10000)
    ->Arg(100000)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(5);
