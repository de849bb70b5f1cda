// meshmark_cho_rms OUT.jsonl MESH...: at the same strength on the same meshes and payloads,
// the displacement of the QP framework (DRS) beside Cho et al.'s Method I and II (the TIFS
// paper claims the QP's is smaller: this measures it). The QP runs with the paper's bin offset
// G = 0.05 ("qp") and, where alpha < 0.05, also with G = alpha ("qp G=alpha", the fidelity
// search's rule): G keeps every vertex at least G from its bin's edges, which moves vertices
// the mark itself would not move; Cho's mapping has no such constraint. Per mesh, strength and
// payload: each method's status, rounds, vertex RMS (% of the bounding-box diagonal) and MSDM, one
// JSON line each; a Markdown table of medians per strength on stdout.
//
// Options: --strengths A,B,... (0.02,0.05,0.1), --payloads N (3), --bits N (64), --seed S.

#include <fmt/format.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "meshmark/io/io.h"
#include "meshmark/mark/embed.h"
#include "meshmark/mark/payload.h"
#include "meshmark/metrics/metrics.h"

using namespace meshmark;

namespace {

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

std::vector<double> parse_list(const std::string& text) {
  std::vector<double> out;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');) out.push_back(std::stod(item));
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<double> strengths = {0.02, 0.05, 0.1};
  int payloads = 3, bits = 64;
  std::uint64_t seed = 2007;
  std::string out_path;
  std::vector<std::string> meshes;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--strengths" && i + 1 < argc)
      strengths = parse_list(argv[++i]);
    else if (a == "--payloads" && i + 1 < argc)
      payloads = std::stoi(argv[++i]);
    else if (a == "--bits" && i + 1 < argc)
      bits = std::stoi(argv[++i]);
    else if (a == "--seed" && i + 1 < argc)
      seed = std::stoull(argv[++i]);
    else if (out_path.empty())
      out_path = a;
    else
      meshes.push_back(a);
  }
  if (out_path.empty() || meshes.empty()) {
    std::fprintf(stderr, "usage: meshmark_cho_rms OUT.jsonl MESH... [--strengths 0.02,0.05]\n");
    return 1;
  }
  std::ofstream out(out_path);
  // Labels: the QP at G = 0.05 (index 0), at G = alpha (3), Cho's two methods (1, 2).
  const Method methods[] = {Method::Qp, Method::ChoMean, Method::ChoVariance, Method::Qp};
  const char* labels[] = {"qp", "cho-mean", "cho-variance", "qp G=alpha"};
  // (strength, method) -> RMS and MSDM of the embedded copies; failures counted.
  std::map<std::pair<double, int>, std::vector<double>> rms, msdms;
  std::map<std::pair<double, int>, int> failed;
  // Per mesh and strength, the ratio of Cho's RMS to the QP's on the same payload.
  std::map<std::pair<double, int>, std::vector<double>> ratio;
  for (const std::string& path : meshes) {
    Mesh mesh;
    try {
      mesh = read_mesh(path);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "%s: %s\n", path.c_str(), e.what());
      continue;
    }
    const std::string name = path.substr(path.find_last_of('/') + 1);
    for (const double alpha : strengths) {
      for (int p = 0; p < payloads; ++p) {
        const Payload payload = random_payload(bits, seed + static_cast<std::uint64_t>(p));
        double qp_rms = 0;
        for (int mi = 0; mi < 4; ++mi) {
          const Method m = methods[mi];
          if (mi == 3 && alpha >= 0.05) continue;  // the same as G = 0.05
          EmbedOptions o;
          o.method = m;
          o.strength = alpha;
          if (mi == 3) o.bin_offset = alpha;
          const EmbedResult r = embed(mesh.V, mesh.F, payload, o);
          nlohmann::json row = {{"mesh", name},         {"vertices", mesh.V.rows()},
                                {"method", labels[mi]}, {"strength", alpha},
                                {"payload", p},         {"status", embed_status_name(r.status)},
                                {"rounds", r.rounds},   {"seconds", r.seconds}};
          const auto k = std::make_pair(alpha, mi);
          if (r.status == EmbedStatus::Embedded) {
            const double d = msdm(mesh.V, r.V, mesh.F).global;
            row["rms_percent"] = r.rms_percent;
            row["msdm"] = d;
            rms[k].push_back(r.rms_percent);
            msdms[k].push_back(d);
            if (mi == 0) qp_rms = r.rms_percent;
            if (mi != 0 && qp_rms > 0) ratio[k].push_back(r.rms_percent / qp_rms);
          } else {
            ++failed[k];
            row["message"] = r.message;
          }
          out << row.dump() << "\n";
        }
      }
      std::fprintf(stderr, "%s alpha %g done\n", name.c_str(), alpha);
    }
  }
  fmt::print(
      "| strength | method | embedded | median RMS (% diag) | median MSDM | RMS / QP's (G = "
      "0.05): median [min, max] |\n");
  fmt::print("| ---: | --- | ---: | ---: | ---: | ---: |\n");
  for (const double alpha : strengths)
    for (int mi : {0, 3, 1, 2}) {
      const auto k = std::make_pair(alpha, mi);
      const std::size_t ok = rms[k].size();
      if (ok + static_cast<std::size_t>(failed[k]) == 0) continue;
      std::vector<double> r = ratio[k];
      std::sort(r.begin(), r.end());
      fmt::print("| {} | {} | {}/{} | {:.5f} | {:.4f} | {} |\n", alpha, labels[mi], ok,
                 ok + static_cast<std::size_t>(failed[k]), median(rms[k]), median(msdms[k]),
                 mi == 0 || r.empty()
                     ? std::string("1")
                     : fmt::format("{:.3f} [{:.3f}, {:.3f}]", median(r), r.front(), r.back()));
    }
  return 0;
}
