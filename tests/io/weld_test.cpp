// Welding for decoding: vertices at bit-identical positions count once, for every format.
// A mesh whose every corner is split (each triangle its own three vertices, as glTF and Draco
// exports and OBJ files with per-face normals store it) must read, and be marked, as its
// welded version; copies of a vertex stacked at one point must change nothing.

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <array>
#include <cmath>
#include <map>
#include <numeric>
#include <random>

#include "meshmark/core/mesh.h"
#include "meshmark/io/io.h"
#include "meshmark/mark/decode.h"
#include "meshmark/mark/embed.h"
#include "test_data.h"

using namespace meshmark;
using namespace meshmark::test;

namespace {

// Bin means of one statistic computed twice (order of summation differs): rounding only.
constexpr double kMeanTolerance = 1e-12;

// Welds bit-identical positions with an ordered map (independent of the library's hash):
// vertices numbered in the order of their positions, unreferenced vertices dropped.
Mesh weld(const Mesh& m) {
  std::map<std::array<double, 3>, int> index;
  for (Eigen::Index f = 0; f < m.F.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      const auto i = m.F(f, c);
      index.emplace(std::array<double, 3>{m.V(i, 0) + 0.0, m.V(i, 1) + 0.0, m.V(i, 2) + 0.0}, 0);
    }
  Eigen::MatrixX3d V(static_cast<Eigen::Index>(index.size()), 3);
  int k = 0;
  for (auto& [p, i] : index) {
    i = k;
    V.row(k++) << p[0], p[1], p[2];
  }
  Eigen::MatrixX3i F(m.F.rows(), 3);
  for (Eigen::Index f = 0; f < m.F.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      const auto i = m.F(f, c);
      F(f, c) = index.at({m.V(i, 0) + 0.0, m.V(i, 1) + 0.0, m.V(i, 2) + 0.0});
    }
  return make_mesh(std::move(V), std::move(F));
}

// Every corner split: triangle f (in a shuffled order) gets its own three vertices.
Mesh split_corners(const Mesh& m, unsigned seed) {
  std::vector<Eigen::Index> order(static_cast<std::size_t>(m.F.rows()));
  std::iota(order.begin(), order.end(), 0);
  std::shuffle(order.begin(), order.end(), std::mt19937(seed));
  Eigen::MatrixX3d V(3 * m.F.rows(), 3);
  Eigen::MatrixX3i F(m.F.rows(), 3);
  for (Eigen::Index k = 0; k < m.F.rows(); ++k)
    for (int c = 0; c < 3; ++c) {
      V.row(3 * k + c) = m.V.row(m.F(order[k], c));
      F(k, c) = static_cast<int>(3 * k + c);
    }
  return make_mesh(std::move(V), std::move(F));
}

// The split mesh written as `format` and read back, as a converter's output would be.
Mesh through_file(const Mesh& m, const std::string& name) {
  const std::string path = scratch_dir() + "/" + name;
  write_mesh(path, m);
  return read_mesh(path);
}

struct Named {
  std::string label;
  Mesh mesh;
};

std::vector<Named> real_meshes() {
  std::vector<Named> out;
  for (const std::string& name : {"spot.obj", "spider.obj", "bunny.ply"})
    if (const std::string p = data_mesh(name); !p.empty())
      out.push_back({name, read_mesh(p)});
    else
      ADD_FAILURE() << name << " is missing from data/meshes";
  for (const std::string& name : {"fandisk.off", "elephant.off"})
    if (const std::string p = cgal_mesh(name); !p.empty())
      out.push_back({name, read_mesh(p)});
    else
      ADD_FAILURE() << name << " is missing from libcgal-demo's data (scripts/setup.sh)";
  return out;
}

void expect_same_reading(const ExtractResult& a, const ExtractResult& b) {
  ASSERT_EQ(a.means.size(), b.means.size());
  EXPECT_EQ(a.counts, b.counts);
  EXPECT_EQ(a.bits, b.bits);
  for (std::size_t j = 0; j < a.means.size(); ++j)
    if (a.counts[j] > 0) EXPECT_NEAR(a.means[j], b.means[j], kMeanTolerance) << "bit " << j;
  EXPECT_LE((a.center.point - b.center.point).norm(),
            kMeanTolerance * a.histogram.step * a.histogram.bins);
}

// The discrete-center bin means of a mesh whose faces all have nonzero area, written out from
// the definition: distinct positions of the faces' corners, their mean as the center.
std::vector<double> definition_means(const Mesh& m, int nb, std::vector<int>& counts) {
  std::map<std::array<double, 3>, Eigen::Vector3d> positions;
  for (Eigen::Index f = 0; f < m.F.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      const Eigen::Vector3d p = m.V.row(m.F(f, c)).transpose();
      positions[{p.x() + 0.0, p.y() + 0.0, p.z() + 0.0}] = p;
    }
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  for (const auto& [key, p] : positions) center += p;
  center /= static_cast<double>(positions.size());
  double lo = INFINITY, hi = -INFINITY;
  for (const auto& [key, p] : positions)
    lo = std::min(lo, (p - center).norm()), hi = std::max(hi, (p - center).norm());
  const double s = (hi - lo) / (nb + 2);
  std::vector<double> sums(nb, 0);
  counts.assign(nb, 0);
  for (const auto& [key, p] : positions) {
    const double x = ((p - center).norm() - lo) / s;
    const int b = std::min(static_cast<int>(std::floor(x)), nb + 1);
    if (b < 1 || b > nb) continue;
    sums[b - 1] += x - b;
    ++counts[b - 1];
  }
  for (int j = 0; j < nb; ++j) sums[j] = counts[j] ? sums[j] / counts[j] : NAN;
  return sums;
}

bool all_faces_have_area(const Mesh& m) {
  for (Eigen::Index f = 0; f < m.F.rows(); ++f) {
    const Eigen::Vector3d a = m.V.row(m.F(f, 0)), b = m.V.row(m.F(f, 1)), c = m.V.row(m.F(f, 2));
    const Eigen::Vector3d u = b - a, v = c - a;
    if (!(u.cross(v).squaredNorm() > 1e-18 * u.squaredNorm() * v.squaredNorm())) return false;
  }
  return true;
}

}  // namespace

TEST(Weld, SplitCornersReadAsTheWeldedMeshInEveryCenterAndFormat) {
  const auto meshes = real_meshes();
  if (meshes.empty())
    GTEST_FAIL() << "no real mesh available (data/meshes, libcgal-demo: scripts/setup.sh)";
  for (const auto& [label, m] : meshes) {
    SCOPED_TRACE(label);
    const Mesh welded = weld(m);
    const Mesh split = split_corners(m, 3);
    ASSERT_GT(split.V.rows(), 2 * welded.V.rows());  // really split: ~6 copies per position
    for (const char* file : {"split.obj", "split.ply"}) {
      SCOPED_TRACE(file);
      const Mesh read = through_file(split, file);
      for (CenterKind center : {CenterKind::Discrete, CenterKind::Surface, CenterKind::Volume}) {
        SCOPED_TRACE(center_letter(center));
        ExtractOptions o;
        o.center = center;
        const ExtractResult w = extract(welded.V, welded.F, o);
        if (!w.center.well_defined) continue;  // an open mesh's volume center: rounding rules it
        expect_same_reading(extract(read.V, read.F, o), w);
        expect_same_reading(extract(m.V, m.F, o), w);  // the file as it came, seams and all
      }
    }
  }
}

TEST(Weld, DiscreteBinMeansFollowTheDefinitionOverDistinctPositions) {
  int checked = 0;
  for (const auto& [label, m] : real_meshes()) {
    if (!all_faces_have_area(m)) continue;  // then the carrier is every face corner
    SCOPED_TRACE(label);
    std::vector<int> counts;
    const std::vector<double> expected = definition_means(m, 64, counts);
    for (const Mesh& version : {m, split_corners(m, 5)}) {
      const ExtractResult r = extract(version.V, version.F);
      EXPECT_EQ(r.counts, counts);
      for (int j = 0; j < 64; ++j)
        if (counts[j] > 0) EXPECT_NEAR(r.means[j], expected[j], kMeanTolerance) << "bit " << j;
    }
    ++checked;
  }
  if (checked == 0) GTEST_FAIL() << "no real mesh without zero-area faces available";
}

TEST(Weld, AMarkEmbeddedOnTheSplitMeshReadsOnTheWeldedOneAndViceVersa) {
  const auto meshes = real_meshes();
  if (meshes.empty())
    GTEST_FAIL() << "no real mesh available (data/meshes, libcgal-demo: scripts/setup.sh)";
  std::mt19937 gen(11);
  for (const auto& [label, m] : meshes) {
    SCOPED_TRACE(label);
    Payload p;
    // The spider's 762 vertices carry 24 bits (64 leave some bins too thin to reach).
    const int bits = m.V.rows() < 1000 ? 24 : 64;
    for (int j = 0; j < bits; ++j) p.bits.push_back(static_cast<std::uint8_t>(gen() & 1));
    const Mesh welded = weld(m);
    const Mesh split = through_file(split_corners(m, 7), "split.ply");
    EmbedOptions o;  // DRS
    const EmbedResult on_split = embed(split.V, split.F, p, o);
    const EmbedResult on_welded = embed(welded.V, welded.F, p, o);
    ASSERT_EQ(on_split.status, EmbedStatus::Embedded) << on_split.message;
    ASSERT_EQ(on_welded.status, EmbedStatus::Embedded) << on_welded.message;
    // Split corners moved together (the mesh stays closed), and with a radial direction and a
    // cost per position the two problems are the same one: every split vertex moved as the
    // welded vertex at its original position did.
    std::map<std::array<double, 3>, Eigen::Index> welded_index;
    for (Eigen::Index i = 0; i < welded.V.rows(); ++i)
      welded_index[{welded.V(i, 0), welded.V(i, 1), welded.V(i, 2)}] = i;
    double worst = 0;
    for (Eigen::Index k = 0; k < split.V.rows(); ++k) {
      const Eigen::Index i =
          welded_index.at({split.V(k, 0) + 0.0, split.V(k, 1) + 0.0, split.V(k, 2) + 0.0});
      worst = std::max(worst, (on_split.V.row(k) - on_welded.V.row(i)).norm());
    }
    EXPECT_LE(worst, 1e-9 * on_welded.bin_width);
    EXPECT_NEAR(on_split.rms_displacement, on_welded.rms_displacement,
                1e-9 * on_welded.rms_displacement);
    const Mesh split_result = weld(make_mesh(on_split.V, split.F));
    EXPECT_EQ(split_result.V.rows(), welded.V.rows());
    // Cross readings: embedded on one, read on the other.
    Mesh welded_marked = welded;
    welded_marked.V = on_welded.V;
    const Mesh split_of_welded = split_corners(welded_marked, 9);
    ExtractOptions read;
    read.bits = bits;
    for (const ExtractResult& r : {extract(split_result.V, split_result.F, read),
                                   extract(split_of_welded.V, split_of_welded.F, read)}) {
      EXPECT_EQ(r.erasures, 0);
      for (int j = 0; j < bits; ++j) {
        EXPECT_EQ(r.bits[j], p.bits[j]) << "bit " << j;
        EXPECT_GE(r.margins[j], 0.5 * o.strength) << "bit " << j;
      }
    }
  }
}

TEST(Weld, CopiesOfOneVertexStackedAtAPointDoNotMoveTheHistogram) {
  const std::string path = data_mesh("spot.obj");
  MESHMARK_REQUIRE(path, "spot.obj");
  const Mesh m = read_mesh(path);
  const ExtractResult clean = extract(m.V, m.F);
  // The attacker's vertex: one in the middle of a data bin, where extra weight moves the mean.
  int v = -1;
  for (Eigen::Index i = 0; i < m.V.rows() && v < 0; ++i)
    if (clean.histogram.bin[i] == 20) v = static_cast<int>(i);
  ASSERT_GE(v, 0);
  const int copies = 200;
  for (const bool with_area : {false, true}) {
    SCOPED_TRACE(with_area ? "copies on copies of v's faces" : "copies on collapsed faces");
    Eigen::MatrixX3d V(m.V.rows() + copies, 3);
    V << m.V, m.V.row(v).replicate(copies, 1);
    std::vector<Eigen::RowVector3i> extra;
    for (int k = 0; k < copies; ++k) {
      const int c = static_cast<int>(m.V.rows()) + k;
      if (!with_area) {
        extra.emplace_back(v, c, c);  // zero area: only the discrete center could see it
      } else {
        for (Eigen::Index f = 0; f < m.F.rows(); ++f)  // a copy of one face around v
          for (int a = 0; a < 3; ++a)
            if (m.F(f, a) == v && extra.size() <= static_cast<std::size_t>(k)) {
              Eigen::RowVector3i t = m.F.row(f);
              t(a) = c;
              extra.push_back(t);
            }
      }
    }
    Eigen::MatrixX3i F(m.F.rows() + static_cast<Eigen::Index>(extra.size()), 3);
    F.topRows(m.F.rows()) = m.F;
    for (std::size_t k = 0; k < extra.size(); ++k) F.row(m.F.rows() + k) = extra[k];
    // The discrete center counts positions, not vertices; duplicated faces would move the
    // surface and volume centers (they are surface, not vertices), so only D is compared.
    const ExtractResult attacked = extract(V, F);
    expect_same_reading(attacked, clean);
    EXPECT_EQ(attacked.counts[19], clean.counts[19]);
  }
}
