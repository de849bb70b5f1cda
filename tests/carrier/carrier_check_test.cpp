// The degenerate-input check before decoding and embedding (carrier_check.h): collapsed,
// duplicated or far too coarse geometry is reported; healthy real meshes are not.

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <array>
#include <cmath>
#include <filesystem>
#include <random>
#include <set>

#include <fmt/format.h>

#include "meshmark/carrier/carrier_check.h"
#include "meshmark/io/io.h"
#include "meshmark/mark/decode.h"
#include "meshmark/mark/embed.h"
#include "test_data.h"

using namespace meshmark;
using namespace meshmark::test;

namespace {

// Every mesh of data/meshes and CGAL's data that reads.
std::vector<std::pair<std::string, Mesh>> all_real_meshes() {
  std::vector<std::string> paths;
  for (const std::string& dir :
       {std::string(MESHMARK_TEST_DATA) + "/meshes", std::string(MESHMARK_CGAL_DATA)}) {
    std::error_code ec;
    for (const auto& e : std::filesystem::directory_iterator(dir, ec)) {
      const std::string ext = e.path().extension().string();
      if (ext == ".off" || ext == ".obj" || ext == ".ply" || ext == ".stl" || ext == ".STL")
        paths.push_back(e.path().string());
    }
  }
  std::sort(paths.begin(), paths.end());
  std::vector<std::pair<std::string, Mesh>> out;
  for (const std::string& p : paths) {
    try {
      out.emplace_back(std::filesystem::path(p).filename().string(), read_mesh(p));
    } catch (const std::exception&) {
      // a file the readers refuse (CGAL's data holds a few on purpose) is not the check's concern
    }
  }
  return out;
}

}  // namespace

namespace {

// The distinct positions among the corners of faces with three distinct corners not on one
// line (the sine of the angle at the first corner above 1e-9): the carrier's definition.
std::size_t distinct_carrier_positions(const Mesh& m) {
  std::set<std::array<double, 3>> out;
  for (Eigen::Index f = 0; f < m.F.rows(); ++f) {
    const Eigen::Vector3d a = m.V.row(m.F(f, 0)), b = m.V.row(m.F(f, 1)), c = m.V.row(m.F(f, 2));
    const Eigen::Vector3d u = b - a, v = c - a;
    if (u.cross(v).squaredNorm() <= 1e-18 * u.squaredNorm() * v.squaredNorm()) continue;
    for (const Eigen::Vector3d& p : {a, b, c}) out.insert({p.x() + 0.0, p.y() + 0.0, p.z() + 0.0});
  }
  return out.size();
}

// Positions snapped to the centers of an L x L x L grid over the bounding box (a converter
// that quantized to a few levels).
Mesh quantized(const Mesh& m, int levels) {
  Mesh q = make_mesh(m.V, m.F);
  const Eigen::RowVector3d lo = m.V.colwise().minCoeff(), hi = m.V.colwise().maxCoeff();
  for (Eigen::Index i = 0; i < m.V.rows(); ++i)
    for (int a = 0; a < 3; ++a) {
      const double cell = (hi(a) - lo(a)) / levels;
      const double k = std::min(std::floor((m.V(i, a) - lo(a)) / cell), levels - 1.0);
      q.V(i, a) = lo(a) + (k + 0.5) * cell;
    }
  return q;
}

// Every vertex moved onto the nearest of k of the mesh's vertices (drawn with a seed).
Mesh collapsed(const Mesh& m, int k, unsigned seed) {
  std::mt19937 gen(seed);
  std::vector<Eigen::RowVector3d> anchors;
  for (int a = 0; a < k; ++a) anchors.push_back(m.V.row(gen() % m.V.rows()));
  Mesh c = make_mesh(m.V, m.F);
  for (Eigen::Index i = 0; i < m.V.rows(); ++i) {
    int best = 0;
    for (int a = 1; a < k; ++a)
      if ((m.V.row(i) - anchors[a]).squaredNorm() < (m.V.row(i) - anchors[best]).squaredNorm())
        best = a;
    c.V.row(i) = anchors[best];
  }
  return c;
}

// The status the documented rule gives for a count of distinct positions alone (the bins'
// contents can only make it worse).
CarrierHealth at_best(std::size_t positions, int nb) {
  if (positions < static_cast<std::size_t>(nb + 2)) return CarrierHealth::Unusable;
  if (positions < static_cast<std::size_t>(kMinPositionsPerBin * nb + 2))
    return CarrierHealth::Weak;
  return CarrierHealth::Healthy;
}

Mesh horse() {
  const std::string path = closed_binary_ply();
  return path.empty() ? Mesh{} : read_mesh(path);
}

}  // namespace

TEST(CarrierCheck, EveryHealthyRealMeshPassesWithoutAWarning) {
  // Healthy: the mesh has far more distinct carrier positions than 64 bits need (at least
  // 4 x kMinPositionsPerBin per bin on average) and today's reading has no empty bin.
  int healthy = 0;
  for (const auto& [name, m] : all_real_meshes()) {
    SCOPED_TRACE(name);
    const ExtractResult r = extract(m.V, m.F);
    const std::size_t positions = distinct_carrier_positions(m);
    if (r.erasures > 0 || positions < 4 * static_cast<std::size_t>(kMinPositionsPerBin) * 64)
      continue;
    EXPECT_EQ(r.check.status, CarrierHealth::Healthy) << r.check.summary();
    EXPECT_TRUE(r.check.diagnostics.empty());
    ++healthy;
  }
  if (healthy == 0)
    GTEST_FAIL() << "no real mesh available (data/meshes, libcgal-demo: scripts/setup.sh)";
  EXPECT_GE(healthy, 20) << "fewer real meshes than expected";
}

TEST(CarrierCheck, MeshesCollapsedOntoAFewPointsAreUnusable) {
  const Mesh m = horse();
  MESHMARK_REQUIRE(m.source_path, "bunny00.off");
  for (const int k : {3, 12, 40}) {
    SCOPED_TRACE(k);
    const Mesh c = collapsed(m, k, static_cast<unsigned>(k));
    const std::size_t positions = distinct_carrier_positions(c);
    ASSERT_LE(positions, static_cast<std::size_t>(k));
    const ExtractResult r = extract(c.V, c.F);
    EXPECT_EQ(r.check.status, CarrierHealth::Unusable);
    EXPECT_EQ(r.check.positions, static_cast<std::int64_t>(positions));
    ASSERT_EQ(r.check.diagnostics.size(), 1u);
    EXPECT_NE(r.check.diagnostics[0].find(fmt::format("{} distinct positions", positions)),
              std::string::npos)
        << r.check.diagnostics[0];
    // Embedding stops before solving, and leaves the mesh alone.
    Payload p;
    p.bits.assign(64, 1);
    const EmbedResult e = embed(c.V, c.F, p);
    EXPECT_EQ(e.status, EmbedStatus::InvalidMesh);
    EXPECT_EQ(e.check.status, CarrierHealth::Unusable);
    EXPECT_EQ(e.V, c.V);
  }
}

TEST(CarrierCheck, QuantizedMeshesAreReportedAsTheirDistinctPositionsWarrant) {
  const Mesh m = horse();
  MESHMARK_REQUIRE(m.source_path, "bunny00.off");
  bool saw[3] = {false, false, false};
  for (const int levels : {2, 4, 6, 8, 12, 64, 4096}) {
    SCOPED_TRACE(levels);
    const Mesh q = quantized(m, levels);
    const std::size_t positions = distinct_carrier_positions(q);
    const ExtractResult r = extract(q.V, q.F);
    EXPECT_EQ(r.check.positions, static_cast<std::int64_t>(positions));
    const CarrierHealth best = at_best(positions, 64);
    saw[static_cast<int>(best)] = true;
    if (best == CarrierHealth::Healthy)
      EXPECT_NE(r.check.status, CarrierHealth::Unusable);  // a fine grid: bins decide
    else
      EXPECT_EQ(r.check.status, best) << r.check.summary();
    if (r.erasures > 0) EXPECT_NE(r.check.status, CarrierHealth::Healthy);
  }
  EXPECT_TRUE(saw[0] && saw[1] && saw[2]) << "the grids should span the three regimes";
}

TEST(CarrierCheck, TheRuleCountsPositionsPerBinOnAHandMadeHistogram) {
  // 64 data bins of 20 positions each, then some made thin or empty.
  auto check = [](int thin, int empty) {
    Histogram h;
    h.bins = 66;
    h.step = 1;
    std::vector<std::uint8_t> carrier;
    auto add = [&](int bin, int n) {
      for (int k = 0; k < n; ++k) h.bin.push_back(bin), carrier.push_back(kCounted);
    };
    add(0, 1), add(65, 1);
    for (int b = 1; b <= 64; ++b)
      add(b, b <= empty ? 0 : b <= empty + thin ? kMinPositionsPerBin - 1 : 20);
    return check_carrier(carrier, h);
  };
  EXPECT_EQ(check(0, 0).status, CarrierHealth::Healthy);
  EXPECT_EQ(check(64 / kThinBinsPerTolerated, 0).status, CarrierHealth::Healthy);
  EXPECT_EQ(check(64 / kThinBinsPerTolerated, 0).thin_bins, 64 / kThinBinsPerTolerated);
  EXPECT_EQ(check(64 / kThinBinsPerTolerated + 1, 0).status, CarrierHealth::Weak);
  EXPECT_EQ(check(0, 1).status, CarrierHealth::Weak);
  EXPECT_EQ(check(0, 1).empty_bins, 1);
  const CarrierCheck c = check(0, 3);
  EXPECT_EQ(c.fewest, 0);
  ASSERT_FALSE(c.diagnostics.empty());
  EXPECT_NE(c.diagnostics[0].find("3 of 64 bins empty"), std::string::npos) << c.summary();
}

TEST(CarrierCheck, TheCommandLineWarnsOrRefusesNamingTheFile) {
  const Mesh m = horse();
  MESHMARK_REQUIRE(m.source_path, "bunny00.off");
  const std::string dir = scratch_dir();
  const std::string broken = dir + "/collapsed.ply", coarse = dir + "/coarse.ply";
  write_mesh(broken, collapsed(m, 12, 1));
  write_mesh(coarse, quantized(m, 8));
  ASSERT_EQ(at_best(distinct_carrier_positions(quantized(m, 8)), 64), CarrierHealth::Weak);
  for (const std::string cmd : {"extract", "detect --expect-payload 0"}) {
    SCOPED_TRACE(cmd);
    const CliRun bad = run_cli(cmd + " " + broken);
    EXPECT_EQ(bad.code, 2) << bad.out;
    EXPECT_NE(bad.out.find("error: " + broken + ": "), std::string::npos) << bad.out;
    EXPECT_NE(bad.out.find("distinct positions for 64 bits"), std::string::npos) << bad.out;
    const CliRun weak = run_cli(cmd + " " + coarse);
    EXPECT_NE(weak.code, 2) << weak.out;
    EXPECT_NE(weak.out.find("warning: " + coarse + ": "), std::string::npos) << weak.out;
    const CliRun good = run_cli(cmd + " " + m.source_path);
    EXPECT_EQ(good.out.find("warning"), std::string::npos) << good.out;
  }
  const CliRun embed_bad = run_cli("embed " + broken + " " + dir + "/out.ply --payload 0");
  EXPECT_EQ(embed_bad.code, 4) << embed_bad.out;
  EXPECT_NE(embed_bad.out.find("distinct positions for 64 bits"), std::string::npos)
      << embed_bad.out;
}
