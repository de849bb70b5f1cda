// The preconditions mesh.h states (finite coordinates, face indices in [0, #V)) are checked
// where the library is entered: a broken mesh gets an InvalidArgumentError naming the element,
// at every entry point, instead of a crash or a silent misreading.

#include <gtest/gtest.h>

#include <fmt/format.h>

#include <filesystem>
#include <functional>
#include <limits>

#include "meshmark/attacks/attack.h"
#include "meshmark/core/error.h"
#include "meshmark/io/io.h"
#include "meshmark/mark/decode.h"
#include "meshmark/mark/embed.h"
#include "meshmark/metrics/metrics.h"
#include "test_data.h"

namespace meshmark {
namespace {

struct Broken {
  std::string name;      // what was broken
  Mesh mesh;             // the broken mesh
  std::string expected;  // the message's part that names the element
};

std::vector<Broken> broken_meshes() {
  const Mesh good = test::bumpy_sphere(16, 12, 3);
  const auto nv = good.V.rows();
  std::vector<Broken> cases;
  Mesh m = good;
  m.F(12, 1) = static_cast<int>(nv + 400);
  cases.push_back(
      {"index past the end", m,
       fmt::format("face 12 has vertex index {} but the mesh has {} vertices", nv + 400, nv)});
  m = good;
  m.F(3, 2) = -1;
  cases.push_back({"negative index", m,
                   fmt::format("face 3 has vertex index -1 but the mesh has {} vertices", nv)});
  m = good;
  m.V(5, 1) = std::numeric_limits<double>::quiet_NaN();
  cases.push_back({"NaN coordinate", m, "vertex 5 has a non-finite coordinate"});
  m = good;
  m.V(7, 2) = std::numeric_limits<double>::infinity();
  cases.push_back({"infinite coordinate", m, "vertex 7 has a non-finite coordinate"});
  return cases;
}

// Calls f and expects an InvalidArgumentError whose message contains `expected`.
void expect_refused(const std::function<void()>& f, const std::string& expected,
                    const std::string& where) {
  try {
    f();
    ADD_FAILURE() << where << ": accepted";
  } catch (const InvalidArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find(expected), std::string::npos)
        << where << ": " << e.what() << "\n  expected: " << expected;
  }
}

TEST(ValidateMesh, EveryEntryPointNamesTheBrokenElement) {
  const Mesh good = test::bumpy_sphere(16, 12, 3);
  const Payload payload = payload_from_hex("a5", 8);
  const std::string dir = test::scratch_dir();
  for (const Broken& b : broken_meshes()) {
    const Mesh& m = b.mesh;
    const std::string& x = b.expected;
    expect_refused([&] { embed(m.V, m.F, payload); }, x, b.name + ", embed");
    expect_refused([&] { PreparedEmbedder(m.V, m.F); }, x, b.name + ", PreparedEmbedder");
    expect_refused([&] { extract(m.V, m.F); }, x, b.name + ", extract");
    expect_refused([&] { surface_distance(good.V, good.F, m.V, m.F); }, x,
                   b.name + ", surface_distance");
    expect_refused([&] { vertex_rms_percent(good.V, m.V, m.F); }, x, b.name + ", vertex RMS");
    expect_refused([&] { msdm(good.V, m.V, m.F); }, x, b.name + ", msdm");
    expect_refused([&] { msdm2(m.V, m.F, good.V, good.F); }, x, b.name + ", msdm2");
    expect_refused([&] { apply_attack(m, parse_attack_chain("noise:0.001").front(), 1); }, x,
                   b.name + ", apply_attack");
    expect_refused([&] { write_mesh(dir + "/out.ply", m); }, x, b.name + ", write_mesh");
  }
  EXPECT_FALSE(std::filesystem::exists(dir + "/out.ply"));  // nothing written
}

TEST(ValidateMesh, AWellFormedMeshPassesAndPolygonsAreChecked) {
  Mesh m = test::bumpy_sphere(8, 6, 1);
  EXPECT_NO_THROW(validate_mesh(m));
  m.faces = polygons_from_triangles(m.F);
  m.faces.indices[4] = static_cast<int>(m.V.rows());
  expect_refused([&] { validate_mesh(m); },
                 fmt::format("polygon 1 has vertex index {} but the mesh has {} vertices",
                             m.V.rows(), m.V.rows()),
                 "polygons");
}

}  // namespace
}  // namespace meshmark
