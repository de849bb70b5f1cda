// Reading and embedding a mesh of about a million vertices stored as GLB against the same mesh
// as binary PLY (issue 16's targets: GLB reads at least as fast as PLY; a GLB embedding costs at
// most PLY's plus 20 %). The files are made in memory before timing; an "embedding" here is
// what `meshmark embed` does between the disk reads and writes: parse, embed 64 bits (DRS),
// write the bytes through the file image, parse them again to check the mark.
// Run: build/bench/meshmark_bench --benchmark_filter=File --benchmark_repetitions=5
//      --benchmark_report_aggregates_only=true, and report medians.

#include <benchmark/benchmark.h>

#include <filesystem>
#include <memory>

#include "meshmark/attacks/attack.h"
#include "meshmark/io/io.h"
#include "meshmark/mark/decode.h"
#include "meshmark/mark/embed.h"

using namespace meshmark;

namespace {

// refined_elephant (libcgal-demo, 44k vertices) after three sqrt(3) subdivisions: 1.2M vertices;
// its bytes per format.
struct Files {
  std::string glb, ply_float, ply_double;
  Eigen::Index vertices = 0;
};

const Files* files() {
  static std::unique_ptr<Files> cached = [] {
    const std::string path = std::string(MESHMARK_CGAL_DATA) + "/refined_elephant.off";
    if (!std::filesystem::exists(path)) return std::unique_ptr<Files>();
    ReadOptions ro;
    ro.keep_image = false;
    const Mesh m = attack_subdivide(read_mesh(path, ro), Subdivision::Sqrt3, 3);
    auto f = std::make_unique<Files>();
    f->vertices = m.V.rows();
    f->glb = write_mesh_to_bytes(m, FileFormat::Glb);
    WriteOptions single;
    single.encoding = Encoding::BinaryLittleEndian;
    single.single_precision = true;
    f->ply_float = write_mesh_to_bytes(m, FileFormat::Ply, single);
    WriteOptions twice = single;
    twice.single_precision = false;
    f->ply_double = write_mesh_to_bytes(m, FileFormat::Ply, twice);
    return f;
  }();
  return cached.get();
}

const std::string& bytes_of(const Files& f, FileFormat format, bool single) {
  if (format == FileFormat::Glb) return f.glb;
  return single ? f.ply_float : f.ply_double;
}

void read_file_bytes(benchmark::State& state, FileFormat format, bool single) {
  const Files* f = files();
  if (!f) return state.SkipWithError("missing libcgal-demo's refined_elephant.off");
  const std::string& bytes = bytes_of(*f, format, single);
  for (auto _ : state) {
    Mesh m = read_mesh_from_bytes(bytes, format, "bench");
    benchmark::DoNotOptimize(m.V.data());
  }
  state.counters["vertices"] = static_cast<double>(f->vertices);
  state.counters["MB"] = static_cast<double>(bytes.size()) / 1e6;
  state.SetItemsProcessed(state.iterations() * f->vertices);
}

void embed_file_bytes(benchmark::State& state, FileFormat format, bool single) {
  const Files* f = files();
  if (!f) return state.SkipWithError("missing libcgal-demo's refined_elephant.off");
  const std::string& bytes = bytes_of(*f, format, single);
  const Payload p = random_payload(64, 1);
  for (auto _ : state) {
    Mesh m = read_mesh_from_bytes(bytes, format, "bench");
    EmbedResult r = embed(m.V, m.F, p, {});
    if (r.status != EmbedStatus::Embedded) return state.SkipWithError(r.message.c_str());
    m.V = std::move(r.V);
    const std::string out = write_mesh_to_bytes(m, format);
    ReadOptions ro;
    ro.keep_image = false;
    const Mesh back = read_mesh_from_bytes(out, format, "bench", ro);
    const ExtractResult x = extract(back.V, back.F, {});
    benchmark::DoNotOptimize(x.means.data());
  }
  state.counters["vertices"] = static_cast<double>(f->vertices);
  state.SetItemsProcessed(state.iterations() * f->vertices);
}

}  // namespace

BENCHMARK_CAPTURE(read_file_bytes, glb, FileFormat::Glb, true)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(read_file_bytes, ply_float32, FileFormat::Ply, true)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(read_file_bytes, ply_float64, FileFormat::Ply, false)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(embed_file_bytes, glb, FileFormat::Glb, true)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(embed_file_bytes, ply_float32, FileFormat::Ply, true)
    ->Unit(benchmark::kMillisecond);
