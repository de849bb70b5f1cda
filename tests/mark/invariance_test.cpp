// A watermark read blind must not care about rotation, uniform scale, translation, or the
// order of vertices and faces.

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

#include "meshmark/attacks/attack.h"
#include "meshmark/io/io.h"
#include "meshmark/mark/decode.h"
#include "meshmark/mark/embed.h"
#include "test_data.h"

using namespace meshmark;
using namespace meshmark::test;

namespace {

Mesh watermarked(const std::string& path, const Payload& p) {
  Mesh m = read_mesh(path);
  const EmbedResult r = embed(m.V, m.F, p);
  EXPECT_EQ(r.status, EmbedStatus::Embedded) << r.message;
  m.V = r.V;
  return m;
}

}  // namespace

TEST(Invariance, SimilarityTransformsKeepThePayloadAndTheBinMeans) {
  for (const std::string& path : {data_mesh("bunny.ply"), cgal_mesh("fandisk.off")}) {
    if (path.empty()) continue;
    SCOPED_TRACE(path);
    const Payload p = random_payload(64, 99);
    const Mesh m = watermarked(path, p);
    const ExtractResult reference = extract(m.V, m.F);
    for (std::uint64_t seed = 1; seed <= 5; ++seed) {
      SimilarityOptions so;
      so.max_scale = 10;
      const Mesh t = attack_similarity(m, seed, so);
      // Independent check that this is a similarity: pairwise distance ratios are constant.
      const double ratio = (t.V.row(1) - t.V.row(0)).norm() / (m.V.row(1) - m.V.row(0)).norm();
      EXPECT_NEAR((t.V.row(7) - t.V.row(3)).norm(), ratio * (m.V.row(7) - m.V.row(3)).norm(),
                  1e-9 * ratio);
      const ExtractResult x = extract(t.V, t.F);
      EXPECT_EQ(bit_error_rate(x.bits, p), 0.0);
      for (int j = 0; j < 64; ++j) EXPECT_NEAR(x.means[j], reference.means[j], 1e-9);
    }
  }
}

TEST(Invariance, VertexAndFaceReorderingKeepsThePayload) {
  for (const std::string& path :
       {data_mesh("bunny.ply"), data_mesh("spot.obj"), cgal_mesh("elephant.off")}) {
    if (path.empty()) continue;
    SCOPED_TRACE(path);
    const Payload p = random_payload(64, 7);
    const Mesh m = watermarked(path, p);
    const ExtractResult reference = extract(m.V, m.F);
    for (std::uint64_t seed = 1; seed <= 3; ++seed) {
      const Mesh t = attack_reorder(m, seed);
      ASSERT_EQ(t.V.rows(), m.V.rows());
      EXPECT_NE(t.V, m.V) << "the permutation did something";
      const ExtractResult x = extract(t.V, t.F);
      EXPECT_EQ(bit_error_rate(x.bits, p), 0.0);
      for (int j = 0; j < 64; ++j) EXPECT_NEAR(x.means[j], reference.means[j], 1e-12);
    }
  }
}

TEST(Invariance, RotationAloneChangesNoBinMean) {
  const Mesh m = bumpy_sphere(25, 35, 6);
  const Payload p = random_payload(48, 2);
  const EmbedResult r = embed(m.V, m.F, p);
  ASSERT_EQ(r.status, EmbedStatus::Embedded);
  ExtractOptions eo;
  eo.bits = 48;
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const Eigen::MatrixX3d rotated = r.V * R.transpose();
  const ExtractResult a = extract(r.V, m.F, eo), b = extract(rotated, m.F, eo);
  EXPECT_EQ(bit_error_rate(b.bits, p), 0.0);
  for (int j = 0; j < 48; ++j) EXPECT_NEAR(a.means[j], b.means[j], 1e-9);
}

// Scaling by a power of two is exact in floating point, so embedding a mesh scaled by 2^k must
// give the copy of the unscaled mesh scaled by 2^k, bit for bit, whatever k within double's
// range: the carrier's flatness test underflowed below about 1e-77 (every triangle "flat", the
// mesh refused with "0 distinct positions") and overflowed above about 1e77.
TEST(Invariance, APowerOfTwoScaleGivesTheScaledCopyBitForBit) {
  const std::string path = cgal_mesh("fandisk.off");
  MESHMARK_REQUIRE(path, "fandisk.off");
  const Mesh m = read_mesh(path);
  const Payload p = random_payload(64, 7);
  const EmbedResult reference = embed(m.V, m.F, p);
  ASSERT_EQ(reference.status, EmbedStatus::Embedded) << reference.message;
  for (const int k : {-300, -250, -100, 100, 250, 300}) {
    SCOPED_TRACE(k);
    const double s = std::ldexp(1.0, k);
    const EmbedResult r = embed(m.V * s, m.F, p);
    ASSERT_EQ(r.status, EmbedStatus::Embedded) << r.message;
    EXPECT_TRUE(r.V == reference.V * s) << "not the scaled copy";
    EXPECT_EQ(bit_error_rate(extract(r.V, m.F).bits, p), 0.0);
  }
}
