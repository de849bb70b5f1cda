#include <gtest/gtest.h>

#include <array>
#include <map>
#include <set>

#include "meshmark/core/mesh.h"
#include "meshmark/io/io.h"
#include "test_data.h"

using namespace meshmark;

TEST(Mesh, TriangulateFansPolygonsAndSkipsShortFaces) {
  Polygons faces;
  const int quad[] = {0, 1, 2, 3}, edge[] = {4, 5}, tri[] = {2, 4, 5};
  faces.push_back(quad, 4);
  faces.push_back(edge, 2);
  faces.push_back(tri, 3);
  const Eigen::MatrixX3i F = triangulate(faces);
  ASSERT_EQ(F.rows(), 3);  // 2 from the quad, 0 from the edge, 1 from the triangle
  EXPECT_EQ(F.row(0), Eigen::RowVector3i(0, 1, 2));
  EXPECT_EQ(F.row(1), Eigen::RowVector3i(0, 2, 3));
  EXPECT_EQ(F.row(2), Eigen::RowVector3i(2, 4, 5));
}

// The faces as a list of corner lists, read through FaceView.
std::vector<std::vector<int>> viewed(const Mesh& m) {
  const FaceView view(m);
  std::vector<std::vector<int>> out(view.size());
  std::size_t corners = 0;
  for (std::size_t k = 0; k < view.size(); ++k) {
    for (std::size_t c = 0; c < view.size_of(k); ++c) out[k].push_back(view.corner(k, c));
    corners += out[k].size();
  }
  EXPECT_EQ(corners, view.corners());
  return out;
}

TEST(Mesh, TrianglesAreKeptOnceAndPolygonsBesideTheirTriangles) {
  const int t0[] = {0, 1, 2}, t1[] = {2, 1, 3}, quad[] = {0, 1, 3, 4}, edge[] = {4, 2};
  const std::vector<std::vector<int>> triangles = {{0, 1, 2}, {2, 1, 3}};
  Polygons faces;
  faces.push_back(t0, 3);
  faces.push_back(t1, 3);
  Mesh m;
  m.V = Eigen::MatrixX3d::Zero(5, 3);
  set_faces(m, faces);
  EXPECT_EQ(m.faces.size(), 0u) << "triangles only: F holds them, no second copy";
  ASSERT_EQ(m.F.rows(), 2);
  EXPECT_EQ(m.F.row(1), Eigen::RowVector3i(2, 1, 3));
  EXPECT_EQ(viewed(m), triangles);
  EXPECT_EQ(file_faces(m), faces);
  // A quad, or a face too short for a triangle, is not F's rows: the polygons are kept.
  for (const bool with_quad : {true, false}) {
    Polygons mixed = faces;
    if (with_quad)
      mixed.push_back(quad, 4);
    else
      mixed.push_back(edge, 2);
    Mesh p;
    p.V = m.V;
    set_faces(p, mixed);
    EXPECT_EQ(p.faces, mixed);
    EXPECT_EQ(p.F.rows(), with_quad ? 4 : 2);
    std::vector<std::vector<int>> expected = triangles;
    expected.push_back(with_quad ? std::vector<int>{0, 1, 3, 4} : std::vector<int>{4, 2});
    EXPECT_EQ(viewed(p), expected);
    EXPECT_EQ(file_faces(p), mixed);
  }
  // A quad and a face too short for a triangle: as many triangles as faces, and as many
  // corners as triangles have, yet not F's rows.
  Polygons odd;
  odd.push_back(quad, 4);
  odd.push_back(edge, 2);
  Mesh q;
  q.V = m.V;
  set_faces(q, odd);
  EXPECT_EQ(q.F.rows(), 2);
  EXPECT_EQ(q.faces, odd);
  EXPECT_EQ(viewed(q), (std::vector<std::vector<int>>{{0, 1, 3, 4}, {4, 2}}));
  // make_mesh keeps none either, and a write gives F back.
  const Mesh made = make_mesh(m.V, m.F);
  EXPECT_EQ(made.faces.size(), 0u);
  EXPECT_EQ(viewed(made), triangles);
}

TEST(Mesh, ReferencedVerticesMarksOnlyVerticesOfTriangles) {
  Eigen::MatrixX3i F(1, 3);
  F << 0, 2, 3;
  const auto used = referenced_vertices(F, 5);
  EXPECT_EQ(used, (std::vector<std::uint8_t>{1, 0, 1, 1, 0}));
}

TEST(Mesh, GroupsIdenticalPositionsIncludingSignedZero) {
  Eigen::MatrixX3d V(6, 3);
  V << 0, 0, 0,                  //
      1, 2, 3,                   //
      -0.0, 0, 0,                // same as vertex 0
      1, 2, 3,                   // same as vertex 1
      1, 2, 3.0000001, 0, 0, 0;  // vertex 5 unreferenced below
  const std::vector<std::uint8_t> referenced = {1, 1, 1, 1, 1, 0};
  const PositionGroups g = group_identical_positions(V, referenced);
  ASSERT_EQ(g.count(), 3);
  EXPECT_EQ(g.group_of[0], g.group_of[2]);
  EXPECT_EQ(g.group_of[1], g.group_of[3]);
  EXPECT_NE(g.group_of[1], g.group_of[4]);
  EXPECT_EQ(g.group_of[5], -1);
  EXPECT_EQ(g.group_of[0], 0);  // numbered by first vertex
  EXPECT_EQ(g.members.size(), 5u);
}

TEST(Mesh, GroupsOnARealMeshMatchAnOrderedMap) {
  const std::string path = test::data_mesh("spider.obj");
  MESHMARK_REQUIRE(path, "spider.obj");
  const Mesh mesh = read_mesh(path);
  const std::vector<std::uint8_t> referenced = referenced_vertices(mesh.F, mesh.V.rows());
  const PositionGroups g = group_identical_positions(mesh.V, referenced);
  // Independently: the first index of each position in an ordered map.
  std::map<std::array<double, 3>, int> first;
  int groups = 0;
  for (Eigen::Index i = 0; i < mesh.V.rows(); ++i) {
    if (!referenced[i]) continue;
    const std::array<double, 3> key = {mesh.V(i, 0) + 0.0, mesh.V(i, 1) + 0.0, mesh.V(i, 2) + 0.0};
    const auto [it, inserted] = first.emplace(key, static_cast<int>(i));
    groups += inserted;
    ASSERT_EQ(g.group_of[i], g.group_of[it->second]) << i;
  }
  EXPECT_EQ(g.count(), groups);
  EXPECT_LT(groups, mesh.V.rows());  // the spider has unwelded seams
}

TEST(Mesh, BoundingBoxDiagonalOfMaskedVertices) {
  Eigen::MatrixX3d V(3, 3);
  V << 0, 0, 0, 3, 4, 0, 100, 100, 100;
  EXPECT_DOUBLE_EQ(bounding_box_diagonal(V, {1, 1, 0}), 5.0);
  EXPECT_DOUBLE_EQ(bounding_box_diagonal(V, {0, 0, 0}), 0.0);
}

TEST(Mesh, AdjacencyOnARealMeshMatchesOrderedSetsOfEdges) {
  const std::string path = test::data_mesh("spider.obj");
  MESHMARK_REQUIRE(path, "spider.obj");
  Mesh mesh = read_mesh(path);
  // A degenerate face (a repeated vertex) and a duplicated face must add no loop, no repeat.
  Eigen::MatrixX3i F(mesh.F.rows() + 2, 3);
  F << mesh.F, Eigen::RowVector3i(0, 0, 1), mesh.F.row(0);
  const Adjacency adj = vertex_adjacency(F, mesh.V.rows() + 1);  // one isolated vertex
  std::vector<std::set<int>> expected(static_cast<std::size_t>(mesh.V.rows()) + 1);
  for (Eigen::Index t = 0; t < F.rows(); ++t)
    for (int c = 0; c < 3; ++c) {
      const int a = F(t, c), b = F(t, (c + 1) % 3);
      if (a != b) expected[a].insert(b), expected[b].insert(a);
    }
  ASSERT_EQ(adj.offsets.size(), expected.size() + 1);
  for (std::size_t i = 0; i < expected.size(); ++i) {
    const std::vector<int> got(adj.indices.begin() + adj.offsets[i],
                               adj.indices.begin() + adj.offsets[i + 1]);
    ASSERT_EQ(got, std::vector<int>(expected[i].begin(), expected[i].end())) << "vertex " << i;
  }
  EXPECT_EQ(adj.degree(static_cast<int>(mesh.V.rows())), 0);
}
