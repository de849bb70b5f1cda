// DRS embedding on real meshes: exact optimality against an independent QP solved by Ipopt,
// round trips through files, and the constraints the paper imposes, checked from the geometry.

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <array>
#include <filesystem>
#include <set>

#include "meshmark/core/error.h"
#include "meshmark/io/io.h"
#include "meshmark/mark/decode.h"
#include "meshmark/mark/embed.h"
#include "solve/ipopt_reference.h"
#include "test_data.h"

using namespace meshmark;
using namespace meshmark::test;

namespace {

struct Named {
  std::string label, path;
  int bits = 64;
  double weld = 0;
};

// Real meshes of different kinds: closed, open, non-manifold, CAD, with UVs, with seams.
std::vector<Named> real_meshes() {
  return {{"elephant-with-holes (holes, seams)", cgal_mesh("elephant-with-holes.off")},
          {"bunny00 (closed, binary PLY)", closed_binary_ply()},
          {"bunny.ply (non-manifold, holes, unreferenced)", data_mesh("bunny.ply")},
          {"spot (UVs)", data_mesh("spot.obj")},
          {"spider (seams, groups, degenerate faces)", data_mesh("spider.obj"), 24},
          {"featuretype (STL CAD, tolerance weld)", data_mesh("featuretype.STL"), 16, 1e-5},
          {"fandisk (CAD)", cgal_mesh("fandisk.off")},
          {"mech-holes-shark (CAD, holes)", cgal_mesh("mech-holes-shark.off")},
          {"elephant", cgal_mesh("elephant.off")},
          {"pig (ascii STL)", cgal_mesh("pig.stl")},
          {"cow", cgal_mesh("cow.off")},
          {"armadillo", cgal_mesh("armadillo.off")}};
}

// Radii of referenced vertices around the discrete center (of their distinct positions),
// computed here from scratch.
struct Radii {
  Eigen::VectorXd rho;  // NaN for unreferenced
  Eigen::Vector3d center;
  double lo = 0, hi = 0;
};
// The carrier from scratch: the corners of faces with three pairwise different positions, not
// on one line.
Radii radii(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F) {
  std::vector<char> used(V.rows(), 0);
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    bool distinct = true;
    for (int a = 0; a < 3; ++a) {
      const int i = F(f, a), j = F(f, (a + 1) % 3);
      distinct &= V(i, 0) != V(j, 0) || V(i, 1) != V(j, 1) || V(i, 2) != V(j, 2);
    }
    // Not flat: |u x v| > 1e-9 |u| |v|, written out.
    const double ux = V(F(f, 1), 0) - V(F(f, 0), 0), uy = V(F(f, 1), 1) - V(F(f, 0), 1),
                 uz = V(F(f, 1), 2) - V(F(f, 0), 2), vx = V(F(f, 2), 0) - V(F(f, 0), 0),
                 vy = V(F(f, 2), 1) - V(F(f, 0), 1), vz = V(F(f, 2), 2) - V(F(f, 0), 2);
    const double cx = uy * vz - uz * vy, cy = uz * vx - ux * vz, cz = ux * vy - uy * vx;
    distinct &= cx * cx + cy * cy + cz * cz >
                1e-18 * (ux * ux + uy * uy + uz * uz) * (vx * vx + vy * vy + vz * vz);
    if (distinct) used[F(f, 0)] = used[F(f, 1)] = used[F(f, 2)] = 1;
  }
  // Used vertices at the position of a carrier vertex join it (quadratic, small meshes only).
  std::vector<char> referenced(V.rows(), 0);
  for (Eigen::Index k = 0; k < F.size(); ++k) referenced[F.data()[k]] = 1;
  std::vector<char> joined = used;
  for (Eigen::Index i = 0; i < V.rows(); ++i)
    if (referenced[i] && !used[i])
      for (Eigen::Index j = 0; j < V.rows() && !joined[i]; ++j)
        if (used[j] && V.row(i) == V.row(j)) joined[i] = 1;
  used = joined;
  Radii r;
  // The discrete center counts each position once (vertices at one position are one point).
  std::set<std::array<double, 3>> seen;
  r.center.setZero();
  for (Eigen::Index i = 0; i < V.rows(); ++i)
    if (used[i] && seen.insert({V(i, 0) + 0.0, V(i, 1) + 0.0, V(i, 2) + 0.0}).second)
      r.center += V.row(i).transpose();
  r.center /= static_cast<double>(seen.size());
  r.rho = Eigen::VectorXd::Constant(V.rows(), std::nan(""));
  r.lo = 1e300;
  r.hi = -1e300;
  for (Eigen::Index i = 0; i < V.rows(); ++i)
    if (used[i]) {
      r.rho(i) = (V.row(i).transpose() - r.center).norm();
      r.lo = std::min(r.lo, r.rho(i));
      r.hi = std::max(r.hi, r.rho(i));
    }
  return r;
}

}  // namespace

TEST(EmbedDrs, OptimumMatchesIpoptOnSmallMeshes) {
  struct Small {
    std::string label;
    Mesh mesh;
  };
  std::vector<Small> meshes;
  meshes.push_back({"generated bumpy sphere", bumpy_sphere(40, 60, 4)});
  for (const std::string name : {"elephant.off", "cow.off", "mech-holes-shark.off"})
    if (!cgal_mesh(name).empty()) meshes.push_back({name, read_mesh(cgal_mesh(name))});
  if (!data_mesh("spot.obj").empty())
    meshes.push_back({"spot.obj", read_mesh(data_mesh("spot.obj"))});
  ASSERT_GE(meshes.size(), 1u);
  for (const Small& s : meshes) {
    SCOPED_TRACE(s.label);
    const Payload p = random_payload(64, 42);
    EmbedOptions o;
    o.max_rounds = 1;
    const EmbedResult ours = embed(s.mesh.V, s.mesh.F, p, o);
    ASSERT_EQ(ours.status, EmbedStatus::Embedded) << ours.message;
    std::vector<int> referenced;
    Eigen::MatrixX3d dirs;
    const std::vector<int> bits(p.bits.begin(), p.bits.end());
    const GeneralQp qp =
        drs_reference_problem(s.mesh.V, s.mesh.F, bits, 0.05, 0.05, referenced, dirs);
    const GeneralQpSolution ref = solve_general_qp_with_ipopt(qp);
    ASSERT_TRUE(ref.ok) << "Ipopt status " << ref.status;
    // Our displacement is feasible for the independently built problem and radial, and as
    // cheap as its optimum (each position's displacement counted once).
    Eigen::VectorXd r(referenced.size());
    for (std::size_t k = 0; k < referenced.size(); ++k) {
      const Eigen::RowVector3d d = ours.V.row(referenced[k]) - s.mesh.V.row(referenced[k]);
      r(k) = d.dot(dirs.row(k));
      EXPECT_LE((d - r(k) * dirs.row(k)).norm(), 1e-12 * (1 + std::abs(r(k))))
          << "displacement is radial";
      EXPECT_GE(r(k), qp.x_lo(k) - 1e-12);
      EXPECT_LE(r(k), qp.x_hi(k) + 1e-12);
    }
    Eigen::VectorXd Ar = Eigen::VectorXd::Zero(qp.row_lo.size());
    for (const auto& t : qp.A) Ar(t.row()) += t.value() * r(t.col());
    for (Eigen::Index j = 0; j < Ar.size(); ++j) EXPECT_GE(Ar(j), qp.row_lo(j) - 1e-9);
    for (Eigen::Index j = 64; j < Ar.size(); ++j)
      EXPECT_NEAR(Ar(j), 0, 1e-9 * r.cwiseAbs().maxCoeff());
    EXPECT_NEAR(r.squaredNorm(), ref.objective, 1e-6 * ref.objective);
  }
}

TEST(EmbedDrs, RoundTripThroughFilesOnRealMeshes) {
  int ran = 0;
  const std::string dir = scratch_dir();
  for (const Named& n : real_meshes()) {
    SCOPED_TRACE(n.label);
    MESHMARK_REQUIRE(n.path, n.label);
    ReadOptions ro;
    ro.weld_tolerance = n.weld;
    Mesh m = read_mesh(n.path, ro);
    const Payload p = random_payload(n.bits, 1234 + ran);
    const EmbedResult r = embed(m.V, m.F, p);
    ASSERT_EQ(r.status, EmbedStatus::Embedded) << r.message;

    // Constraints, from scratch: the center, the range and every vertex's bin are unchanged,
    // vertices outside the carrier (unreferenced, or only in degenerate faces) do not move.
    const Radii before = radii(m.V, m.F), after = radii(r.V, m.F);
    const double s = (before.hi - before.lo) / (n.bits + 2);
    EXPECT_LE((after.center - before.center).norm(), 1e-9 * s);
    EXPECT_NEAR(after.lo, before.lo, 1e-9 * s);
    EXPECT_NEAR(after.hi, before.hi, 1e-9 * s);
    for (Eigen::Index i = 0; i < m.V.rows(); ++i) {
      if (std::isnan(before.rho(i))) {
        EXPECT_EQ(r.V.row(i), m.V.row(i)) << "unreferenced vertex " << i << " moved";
        continue;
      }
      // Each histogram as a decoder builds it, from its own mesh.
      const auto bin = [&](const Radii& h, double rho) {
        return std::min<int>(std::floor((rho - h.lo) / ((h.hi - h.lo) / (n.bits + 2))), n.bits + 1);
      };
      ASSERT_EQ(bin(before, before.rho(i)), bin(after, after.rho(i)))
          << "vertex " << i << " changed bin";
    }

    // Through a file in the input's own format and encoding, then blind extraction.
    const std::string out = dir + "/wm_" + std::filesystem::path(n.path).filename().string();
    Mesh w = m;
    w.V = r.V;
    write_mesh(out, w);
    const Mesh back = read_mesh(out, ro);
    ExtractOptions eo;
    eo.bits = n.bits;
    const ExtractResult x = extract(back.V, back.F, eo);
    EXPECT_EQ(x.erasures, 0);
    EXPECT_EQ(bit_error_rate(x.bits, p), 0.0);
    EXPECT_GE(x.min_margin(), 0.05 - 1e-3) << "float32 storage may shave a little off the margin";
    ++ran;
  }
  if (ran == 0)
    GTEST_FAIL() << "no real mesh available (data/meshes, libcgal-demo: scripts/setup.sh)";
  EXPECT_GE(ran, 10) << "fewer than 10 real meshes were available";
}

TEST(EmbedDrs, UnreachableBitsAreNamedAndTheMeshIsLeftAlone) {
  // 82 vertices: enough to fill the 66 bins once (fewer are refused as unusable before
  // embedding, carrier_check.h), but with 64 bits many bins are empty.
  const Mesh m = bumpy_sphere(8, 10, 2);
  const Payload p = random_payload(64, 3);
  const EmbedResult r = embed(m.V, m.F, p);
  ASSERT_EQ(r.status, EmbedStatus::Infeasible);
  EXPECT_EQ(r.V, m.V);
  // Independently: every empty bin j + 1 must be among the named bits.
  const Radii rr = radii(m.V, m.F);
  const double s = (rr.hi - rr.lo) / 66;
  std::vector<int> count(66, 0);
  for (Eigen::Index i = 0; i < m.V.rows(); ++i)
    ++count[std::min<int>(std::floor((rr.rho(i) - rr.lo) / s), 65)];
  std::vector<int> empty;
  for (int j = 0; j < 64; ++j)
    if (count[j + 1] == 0) empty.push_back(j);
  ASSERT_FALSE(empty.empty());
  for (int j : empty)
    EXPECT_NE(std::find(r.infeasible_bits.begin(), r.infeasible_bits.end(), j),
              r.infeasible_bits.end())
        << j;
}

TEST(EmbedDrs, SeamsStayClosed) {
  const std::string path = data_mesh("spider.obj");
  MESHMARK_REQUIRE(path, "spider.obj");
  const Mesh m = read_mesh(path);
  const EmbedResult r = embed(m.V, m.F, random_payload(24, 5));  // 762 vertices: 24 bits
  ASSERT_EQ(r.status, EmbedStatus::Embedded) << r.message;
  int pairs = 0;
  for (Eigen::Index i = 0; i < m.V.rows(); ++i)
    for (Eigen::Index k = i + 1; k < m.V.rows(); ++k)
      if (m.V.row(i) == m.V.row(k)) {
        ++pairs;
        EXPECT_EQ(r.V.row(i), r.V.row(k)) << "duplicates " << i << " and " << k << " split";
      }
  EXPECT_GT(pairs, 0);
}

TEST(EmbedDrs, StrongerWatermarksCostMore) {
  const Mesh m = bumpy_sphere(30, 40, 8);
  double previous = 0;
  for (double alpha : {0.02, 0.05, 0.1, 0.2}) {
    EmbedOptions o;
    o.strength = alpha;
    const EmbedResult r = embed(m.V, m.F, random_payload(32, 1), o);
    ASSERT_EQ(r.status, EmbedStatus::Embedded);
    EXPECT_GT(r.squared_displacement, previous);
    EXPECT_NEAR(r.min_margin, alpha, 1e-9);
    previous = r.squared_displacement;
  }
}

TEST(EmbedDrs, OptionsOutOfRangeThrow) {
  const Mesh m = bumpy_sphere(8, 8, 1);
  const Payload p = random_payload(8, 1);
  EmbedOptions o;
  o.strength = 0.5;
  EXPECT_THROW(embed(m.V, m.F, p, o), InvalidArgumentError);
  o = {};
  o.bin_offset = -0.1;
  EXPECT_THROW(embed(m.V, m.F, p, o), InvalidArgumentError);
  EXPECT_THROW(embed(m.V, m.F, Payload{}, {}), InvalidArgumentError);
}

TEST(EmbedDrs, WatermarkedObjDiffersFromItsOriginalOnlyInVertexPositions) {
  const std::string path = data_mesh("spider.obj");
  MESHMARK_REQUIRE(path, "spider.obj");
  Mesh m = read_mesh(path);
  const EmbedResult r = embed(m.V, m.F, random_payload(24, 8));
  ASSERT_EQ(r.status, EmbedStatus::Embedded) << r.message;
  m.V = r.V;
  const auto a = split_lines(read_file(path)),
             b = split_lines(write_mesh_to_bytes(m, FileFormat::Obj));
  ASSERT_EQ(a.size(), b.size());
  int changed_vertex_lines = 0;
  for (std::size_t k = 0; k < a.size(); ++k) {
    const auto wa = words(a[k]);
    if (!wa.empty() && wa[0] == "v") {
      changed_vertex_lines += a[k] != b[k];
      EXPECT_EQ(words(b[k]).size(), wa.size());
    } else {
      EXPECT_EQ(a[k], b[k]) << "line " << k + 1 << " is not a vertex line and changed";
    }
  }
  EXPECT_GT(changed_vertex_lines, 0);
}
