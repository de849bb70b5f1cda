// glTF and GLB: files made by gltfpack (Debian's) from real meshes and glTF sample files from
// Debian's assimp-testmodels; positions checked against tinygltf (an independent reader), the
// written files against the Khronos validator (npm gltf-validator), every non-position byte
// against the source.

#include <gtest/gtest.h>
#include <tiny_gltf.h>
#include <nlohmann/json.hpp>

#include <meshoptimizer.h>
#include <Eigen/Geometry>
#include <array>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>

#include "meshmark/core/error.h"
#include "meshmark/io/io.h"
#include "test_data.h"

namespace meshmark {
namespace {

using Json = nlohmann::json;

using Run = test::CliRun;

Run sh(const std::string& cmd) {
  return test::run_command(cmd);
}

// Base64 as RFC 4648 writes it, the test's own (the library's encoder is what is tested).
std::string test_base64(const std::string& bin) {
  static const char* digits = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string b64;
  for (std::size_t i = 0; i < bin.size(); i += 3) {
    std::uint32_t n = static_cast<unsigned char>(bin[i]) << 16;
    if (i + 1 < bin.size()) n |= static_cast<unsigned char>(bin[i + 1]) << 8;
    if (i + 2 < bin.size()) n |= static_cast<unsigned char>(bin[i + 2]);
    b64 += digits[n >> 18 & 63];
    b64 += digits[n >> 12 & 63];
    b64 += i + 1 < bin.size() ? digits[n >> 6 & 63] : '=';
    b64 += i + 2 < bin.size() ? digits[n & 63] : '=';
  }
  return b64;
}

std::string spot_obj() {
  return test::data_mesh("spot.obj");
}

bool have(const std::string& tool) {
  return sh("command -v " + tool + " >/dev/null").code == 0;
}

std::string slurp(const std::string& path) {
  return read_file(path);
}

// The validator's report on a file: number of errors, or -1 when it cannot run.
int validator_errors(const std::string& file, std::string* messages = nullptr) {
  const std::string dir = std::string(MESHMARK_SOURCE_DIR) + "/tests/gltf-validator";
  if (!std::filesystem::exists(dir + "/node_modules/gltf-validator")) return -1;
  const Run r = sh("node " + dir + "/validate.mjs '" + file + "'");
  if (messages) *messages = r.out;
  const auto first = r.out.find('{');
  if (first == std::string::npos) return -1;
  return Json::parse(r.out.substr(first)).at("errors").get<int>();
}

bool validator_installed() {
  return have("node") &&
         std::filesystem::exists(std::string(MESHMARK_SOURCE_DIR) +
                                 "/tests/gltf-validator/node_modules/gltf-validator");
}

#define REQUIRE_VALIDATOR()                                                                       \
  do {                                                                                            \
    if (!validator_installed() && std::getenv("CI") == nullptr)                                   \
      GTEST_SKIP() << "skipped: the Khronos validator is not installed (cd tests/gltf-validator " \
                      "&& npm ci)";                                                               \
  } while (0)

// A GLB's JSON and BIN chunk, split by the test's own reading of the container.
struct Glb {
  Json json;
  std::string json_text, bin;
};
Glb split_glb(const std::string& bytes) {
  Glb g;
  std::uint32_t jl = 0, bl = 0;
  std::memcpy(&jl, bytes.data() + 12, 4);
  g.json_text = bytes.substr(20, jl);
  g.json = Json::parse(g.json_text);
  if (bytes.size() > 28 + jl) {
    std::memcpy(&bl, bytes.data() + 20 + jl, 4);
    g.bin = bytes.substr(28 + jl, bl);
  }
  return g;
}

// Bytes of buffer view v holding POSITION components, per the JSON: mask[i] = 1.
std::vector<std::uint8_t> position_mask(const Json& doc, int view, std::size_t size) {
  std::vector<std::uint8_t> mask(size, 0);
  std::set<int> positions;
  for (const Json& m : doc["meshes"])
    for (const Json& p : m["primitives"]) positions.insert(p["attributes"]["POSITION"].get<int>());
  for (const int a : positions) {
    const Json& acc = doc["accessors"][static_cast<std::size_t>(a)];
    if (acc["bufferView"].get<int>() != view) continue;
    const std::size_t csize = acc["componentType"].get<int>() == 5126   ? 4
                              : acc["componentType"].get<int>() >= 5122 ? 2
                                                                        : 1;
    const Json& bv = doc["bufferViews"][static_cast<std::size_t>(view)];
    const std::size_t stride = bv.value("byteStride", 3 * csize);
    for (std::size_t k = 0; k < acc["count"].get<std::size_t>(); ++k)
      for (std::size_t b = 0; b < 3 * csize; ++b)
        mask[acc.value("byteOffset", std::size_t{0}) + k * stride + b] = 1;
  }
  return mask;
}

struct Packed {
  std::string dir, path, report;
};

// gltfpack's output for a shared mesh (OBJ) with the given flags.
Packed pack(const std::string& obj, const std::string& flags, const std::string& out_name) {
  Packed p;
  p.dir = test::scratch_dir();
  p.path = p.dir + "/" + out_name;
  const Run r = sh("gltfpack -v -i '" + obj + "' -o '" + p.path + "' " + flags);
  p.report = r.out;
  EXPECT_EQ(r.code, 0) << r.out;
  return p;
}

// Positions in world space as tinygltf reads them (node TRS applied by the test), per primitive.
std::vector<Eigen::Vector3d> tinygltf_positions(const std::string& path) {
  tinygltf::TinyGLTF loader;
  tinygltf::Model model;
  std::string err, warn;
  loader.SetImageLoader([](tinygltf::Image*, const int, std::string*, std::string*, int, int,
                           const unsigned char*, int, void*) { return true; },
                        nullptr);
  const bool ok = path.ends_with(".glb") ? loader.LoadBinaryFromFile(&model, &err, &warn, path)
                                         : loader.LoadASCIIFromFile(&model, &err, &warn, path);
  EXPECT_TRUE(ok) << err;
  std::vector<Eigen::Vector3d> out;
  for (const tinygltf::Node& node : model.nodes) {
    if (node.mesh < 0) continue;
    Eigen::Affine3d m = Eigen::Affine3d::Identity();
    if (!node.translation.empty())
      m.translate(Eigen::Vector3d(node.translation[0], node.translation[1], node.translation[2]));
    if (!node.rotation.empty())
      m.rotate(Eigen::Quaterniond(node.rotation[3], node.rotation[0], node.rotation[1],
                                  node.rotation[2]));
    if (!node.scale.empty()) m.scale(Eigen::Vector3d(node.scale[0], node.scale[1], node.scale[2]));
    for (const tinygltf::Primitive& prim :
         model.meshes[static_cast<std::size_t>(node.mesh)].primitives) {
      const tinygltf::Accessor& acc =
          model.accessors[static_cast<std::size_t>(prim.attributes.at("POSITION"))];
      const tinygltf::BufferView& bv = model.bufferViews[static_cast<std::size_t>(acc.bufferView)];
      const auto& data = model.buffers[static_cast<std::size_t>(bv.buffer)].data;
      const std::size_t stride = acc.ByteStride(bv);
      for (std::size_t k = 0; k < acc.count; ++k) {
        const unsigned char* e = data.data() + bv.byteOffset + acc.byteOffset + k * stride;
        Eigen::Vector3d p;
        for (int c = 0; c < 3; ++c) {
          if (acc.componentType == TINYGLTF_COMPONENT_TYPE_FLOAT) {
            float f;
            std::memcpy(&f, e + 4 * c, 4);
            p[c] = f;
          } else {
            std::uint16_t u;
            std::memcpy(&u, e + 2 * c, 2);
            p[c] = u;
          }
        }
        out.push_back(m * p);
      }
    }
  }
  return out;
}

// Every meshmark vertex is one of tinygltf's world positions (to a relative 1e-12, the
// arithmetic order differs), and every tinygltf position is one of meshmark's vertices.
void expect_same_positions(const Mesh& mesh, const std::vector<Eigen::Vector3d>& ref) {
  const double scale = mesh.V.cwiseAbs().maxCoeff();
  const double tol = 1e-12 * scale;
  auto key = [&](const Eigen::Vector3d& p) {
    return std::array<long long, 3>{std::llround(p[0] / (1e-9 * scale)),
                                    std::llround(p[1] / (1e-9 * scale)),
                                    std::llround(p[2] / (1e-9 * scale))};
  };
  std::map<std::array<long long, 3>, std::vector<Eigen::Vector3d>> grid;
  for (const auto& p : ref) grid[key(p)].push_back(p);
  auto near = [&](const Eigen::Vector3d& p) {
    const auto k = key(p);
    for (long long dx = -1; dx <= 1; ++dx)
      for (long long dy = -1; dy <= 1; ++dy)
        for (long long dz = -1; dz <= 1; ++dz) {
          const auto it = grid.find({k[0] + dx, k[1] + dy, k[2] + dz});
          if (it == grid.end()) continue;
          for (const auto& q : it->second)
            if ((q - p).norm() <= tol) return true;
        }
    return false;
  };
  for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    ASSERT_TRUE(near(mesh.V.row(i).transpose())) << "vertex " << i << " is not a file position";
  // Welded: one vertex per distinct position.
  std::set<std::array<long long, 3>> distinct;
  for (const auto& p : ref) distinct.insert(key(p));
  EXPECT_NEAR(static_cast<double>(mesh.V.rows()), static_cast<double>(distinct.size()),
              0.001 * static_cast<double>(distinct.size()));
}

TEST(Gltf, GltfpackFilesReadAsTinygltfReadsThem) {
  const std::string obj = spot_obj();
  MESHMARK_REQUIRE(obj, "spot.obj");
  if (!have("gltfpack")) GTEST_SKIP() << "skipped: gltfpack is not installed";
  const Mesh source = read_mesh(obj);
  for (const auto& [flags, name] : {std::pair{"", "q.glb"}, {"-noq", "noq.glb"}, {"", "q.gltf"}}) {
    SCOPED_TRACE(name);
    const Packed p = pack(obj, flags, name);
    const Mesh m = read_mesh(p.path);
    // gltfpack reports its output triangles; meshmark must read that many.
    std::smatch match;
    ASSERT_TRUE(std::regex_search(p.report, match,
                                  std::regex(R"(output: \d+ mesh primitives \((\d+) triangles)")));
    EXPECT_EQ(m.F.rows(), std::stol(match[1]));
    EXPECT_EQ(m.F.rows(), source.F.rows());
    expect_same_positions(m, tinygltf_positions(p.path));
  }
}

TEST(Gltf, SimplifiedByGltfpackIsReadWithItsTriangleCount) {
  const std::string obj = spot_obj();
  MESHMARK_REQUIRE(obj, "spot.obj");
  if (!have("gltfpack")) GTEST_SKIP() << "skipped: gltfpack is not installed";
  const Packed p = pack(obj, "-si 0.5", "half.glb");
  std::smatch match;
  ASSERT_TRUE(std::regex_search(
      p.report, match,
      std::regex(R"(output: \d+ mesh primitives \((\d+) triangles, (\d+) vertices)")));
  const Mesh m = read_mesh(p.path);
  EXPECT_EQ(m.F.rows(), std::stol(match[1]));
  // gltfpack's vertex count is the accessor's (seams split); meshmark welds identical positions.
  EXPECT_LE(m.V.rows(), std::stol(match[2]));
  EXPECT_LT(m.F.rows(), 0.6 * static_cast<double>(read_mesh(obj).F.rows()));
  expect_same_positions(m, tinygltf_positions(p.path));
}

// Embeds through the CLI, extracts, and returns the marked file's path.
std::string mark(const std::string& in, const std::string& out) {
  const test::CliRun e =
      test::run_cli("embed '" + in + "' '" + out + "' --payload deadbeefcafef00d --bits 64");
  EXPECT_EQ(e.code, 0) << e.out;
  const test::CliRun x = test::run_cli("extract '" + out + "' --bits 64");
  EXPECT_NE(x.out.find("payload deadbeefcafef00d"), std::string::npos) << x.out;
  return out;
}

// Everything but POSITION components and the POSITION accessors' min/max is the same.
void expect_only_positions_differ(const Glb& a, const Glb& b, bool compressed) {
  Json ja = a.json, jb = b.json;
  std::set<int> positions;
  for (const Json& m : ja["meshes"])
    for (const Json& p : m["primitives"]) positions.insert(p["attributes"]["POSITION"].get<int>());
  for (const int i : positions)
    for (Json* j : {&ja, &jb}) {
      (*j)["accessors"][static_cast<std::size_t>(i)].erase("min");
      (*j)["accessors"][static_cast<std::size_t>(i)].erase("max");
    }
  if (compressed)
    for (Json* j : {&ja, &jb}) {
      for (Json& bv : (*j)["bufferViews"])
        if (bv.contains("extensions")) {
          bv["extensions"]["EXT_meshopt_compression"].erase("byteOffset");
          bv["extensions"]["EXT_meshopt_compression"].erase("byteLength");
        }
      (*j)["buffers"][0].erase("byteLength");
    }
  EXPECT_EQ(ja, jb);
  if (compressed) return;  // the compressed bytes differ; see the decoded comparison
  ASSERT_EQ(a.bin.size(), b.bin.size());
  std::vector<std::uint8_t> is_position(a.bin.size(), 0);
  for (std::size_t v = 0; v < a.json["bufferViews"].size(); ++v) {
    const Json& bv = a.json["bufferViews"][v];
    const std::size_t off = bv.value("byteOffset", std::size_t{0});
    const auto mask =
        position_mask(a.json, static_cast<int>(v), bv["byteLength"].get<std::size_t>());
    for (std::size_t i = 0; i < mask.size(); ++i) is_position[off + i] |= mask[i];
  }
  std::size_t changed = 0, changed_elsewhere = 0;
  for (std::size_t i = 0; i < a.bin.size(); ++i) {
    if (a.bin[i] == b.bin[i]) continue;
    ++changed;
    if (!is_position[i]) ++changed_elsewhere;
  }
  EXPECT_GT(changed, 0u);
  EXPECT_EQ(changed_elsewhere, 0u);
}

TEST(Gltf, MarkedGlbChangesPositionsOnlyAndValidates) {
  const std::string obj = spot_obj();
  MESHMARK_REQUIRE(obj, "spot.obj");
  if (!have("gltfpack")) GTEST_SKIP() << "skipped: gltfpack is not installed";
  REQUIRE_VALIDATOR();
  for (const auto& [flags, name] : {std::pair{"", "q.glb"}, {"-noq", "noq.glb"}}) {
    SCOPED_TRACE(name);
    const Packed p = pack(obj, flags, name);
    const std::string out = mark(p.path, p.dir + "/marked-" + name);
    expect_only_positions_differ(split_glb(slurp(p.path)), split_glb(slurp(out)), false);
    std::string report;
    EXPECT_EQ(validator_errors(out, &report), 0) << report;
  }
}

// The decoded bytes of every meshopt-compressed view (the test decodes with meshoptimizer).
std::vector<std::string> decoded_views(const Glb& g) {
  std::vector<std::string> out;
  for (const Json& bv : g.json["bufferViews"]) {
    const Json& e = bv["extensions"]["EXT_meshopt_compression"];
    const std::size_t count = e["count"], stride = e["byteStride"];
    std::string d(count * stride, '\0');
    const auto* src = reinterpret_cast<const unsigned char*>(g.bin.data() +
                                                             e.value("byteOffset", std::size_t{0}));
    const std::size_t len = e["byteLength"];
    const int rc = e["mode"] == "ATTRIBUTES"
                       ? meshopt_decodeVertexBuffer(d.data(), count, stride, src, len)
                       : meshopt_decodeIndexBuffer(d.data(), count, stride, src, len);
    EXPECT_EQ(rc, 0);
    out.push_back(d);
  }
  return out;
}

TEST(Gltf, MarkedMeshoptGlbIsReencodedWithOnlyPositionsChanged) {
  const std::string obj = spot_obj();
  MESHMARK_REQUIRE(obj, "spot.obj");
  if (!have("gltfpack")) GTEST_SKIP() << "skipped: gltfpack is not installed";
  const Packed p = pack(obj, "-cc", "cc.glb");
  const std::string out = mark(p.path, p.dir + "/marked-cc.glb");
  const Glb a = split_glb(slurp(p.path)), b = split_glb(slurp(out));
  expect_only_positions_differ(a, b, true);
  const auto da = decoded_views(a), db = decoded_views(b);
  ASSERT_EQ(da.size(), db.size());
  std::size_t changed = 0;
  for (std::size_t v = 0; v < da.size(); ++v) {
    ASSERT_EQ(da[v].size(), db[v].size());
    const auto mask = position_mask(a.json, static_cast<int>(v), da[v].size());
    for (std::size_t i = 0; i < da[v].size(); ++i) {
      if (da[v][i] == db[v][i]) continue;
      ++changed;
      ASSERT_TRUE(mask[i]) << "view " << v << " byte " << i << " changed and holds no position";
    }
  }
  EXPECT_GT(changed, 0u);
  // gltfpack refuses to read compressed files again ("already been compressed"), so the
  // decoding above (the test's own meshoptimizer calls) and meshmark's extract are the checks.
}

TEST(Gltf, QuantizedGlbMarkedAtItsPrecisionSurvivesASecondGltfpackPass) {
  const std::string obj = spot_obj();
  MESHMARK_REQUIRE(obj, "spot.obj");
  if (!have("gltfpack")) GTEST_SKIP() << "skipped: gltfpack is not installed";
  const Packed p = pack(obj, "", "q.glb");
  const std::string out = mark(p.path, p.dir + "/marked.glb");
  const std::string again = p.dir + "/again.glb";
  ASSERT_EQ(sh("gltfpack -i '" + out + "' -o '" + again + "'").code, 0);
  const test::CliRun x = test::run_cli("extract '" + again + "' --bits 64");
  EXPECT_NE(x.out.find("payload deadbeefcafef00d"), std::string::npos) << x.out;
}

TEST(Gltf, FloatPositionsOptionDropsTheQuantization) {
  const std::string obj = spot_obj();
  MESHMARK_REQUIRE(obj, "spot.obj");
  if (!have("gltfpack")) GTEST_SKIP() << "skipped: gltfpack is not installed";
  REQUIRE_VALIDATOR();
  const Packed p = pack(obj, "", "q.glb");
  const std::string out = p.dir + "/float.glb";
  const test::CliRun e = test::run_cli("embed '" + p.path + "' '" + out +
                                       "' --payload deadbeefcafef00d --bits 64 --float-positions");
  ASSERT_EQ(e.code, 0) << e.out;
  EXPECT_NE(test::run_cli("extract '" + out + "' --bits 64").out.find("payload deadbeefcafef00d"),
            std::string::npos);
  std::string report;
  if (validator_installed()) EXPECT_EQ(validator_errors(out, &report), 0) << report;
  const Glb g = split_glb(slurp(out));
  const int a = g.json["meshes"][0]["primitives"][0]["attributes"]["POSITION"].get<int>();
  EXPECT_EQ(g.json["accessors"][static_cast<std::size_t>(a)]["componentType"], 5126);
  // spot has positions only: nothing needs KHR_mesh_quantization any more.
  EXPECT_EQ(g.json_text.find("KHR_mesh_quantization"), std::string::npos);
  // The positions (tinygltf's reading, node transform applied) moved by the mark only: less
  // than 1 % of the extent, and not snapped back to the 14-bit grid (some local coordinate is
  // not an integer).
  const auto before = tinygltf_positions(p.path), after = tinygltf_positions(out);
  ASSERT_EQ(before.size(), after.size());
  double worst = 0, extent = 0;
  for (std::size_t i = 0; i < before.size(); ++i) {
    worst = std::max(worst, (after[i] - before[i]).norm());
    extent = std::max(extent, (before[i] - before[0]).norm());
  }
  EXPECT_GT(worst, 0);
  EXPECT_LT(worst, 0.01 * extent);
  const Json& acc = g.json["accessors"][static_cast<std::size_t>(a)];
  const Json& bv = g.json["bufferViews"][acc["bufferView"].get<std::size_t>()];
  bool off_grid = false;
  for (std::size_t k = 0; k < 3 * acc["count"].get<std::size_t>() && !off_grid; ++k) {
    float f;
    std::memcpy(&f, g.bin.data() + bv.value("byteOffset", std::size_t{0}) + 4 * k, 4);
    off_grid = f != std::nearbyint(f);
  }
  EXPECT_TRUE(off_grid);
}

TEST(Gltf, GltfWithExternalBufferWritesItsOwnBufferBesideIt) {
  const std::string obj = spot_obj();
  MESHMARK_REQUIRE(obj, "spot.obj");
  if (!have("gltfpack")) GTEST_SKIP() << "skipped: gltfpack is not installed";
  REQUIRE_VALIDATOR();
  const Packed p = pack(obj, "", "model.gltf");
  const std::string before = slurp(p.dir + "/model.bin");
  const std::string out = mark(p.path, p.dir + "/marked.gltf");
  EXPECT_EQ(slurp(p.dir + "/model.bin"), before) << "the input's buffer was modified";
  const Json a = Json::parse(slurp(p.path)), b = Json::parse(slurp(out));
  EXPECT_EQ(b["buffers"][0]["uri"], "marked.bin");
  Json a2 = a, b2 = b;
  for (Json* j : {&a2, &b2}) {
    (*j)["buffers"][0].erase("uri");
    (*j)["accessors"][0].erase("min");
    (*j)["accessors"][0].erase("max");
  }
  EXPECT_EQ(a2, b2);
  const std::string bin = slurp(p.dir + "/marked.bin");
  ASSERT_EQ(bin.size(), before.size());
  const auto mask = position_mask(a, 0, a["bufferViews"][0]["byteLength"].get<std::size_t>());
  for (std::size_t i = 0; i < bin.size(); ++i)
    if (i >= mask.size() || !mask[i]) ASSERT_EQ(bin[i], before[i]) << "byte " << i;
  std::string report;
  EXPECT_EQ(validator_errors(out, &report), 0) << report;
}

TEST(Gltf, AnOutputNeverReplacesTheInputsBuffer) {
  const std::string obj = spot_obj();
  MESHMARK_REQUIRE(obj, "spot.obj");
  if (!have("gltfpack")) GTEST_SKIP() << "skipped: gltfpack is not installed";
  const Packed p = pack(obj, "-noq", "a2.gltf");  // buffer a2.bin
  std::filesystem::rename(p.path, p.dir + "/a.gltf");
  const std::string before = slurp(p.dir + "/a2.bin");
  // a2.gltf's buffer would be a2.bin: the input's own buffer.
  const test::CliRun e = test::run_cli("embed '" + p.dir + "/a.gltf' '" + p.dir +
                                       "/a2.gltf' --payload deadbeefcafef00d --bits 64");
  EXPECT_NE(e.code, 0) << e.out;
  EXPECT_NE(e.out.find("refusing to overwrite"), std::string::npos) << e.out;
  EXPECT_EQ(slurp(p.dir + "/a2.bin"), before);
  EXPECT_FALSE(std::filesystem::exists(p.dir + "/a2.gltf"));
  // A directory where OUT's buffer goes: refused before anything is written.
  std::filesystem::create_directory(p.dir + "/b.bin");
  const test::CliRun d = test::run_cli("embed '" + p.dir + "/a.gltf' '" + p.dir +
                                       "/b.gltf' --payload deadbeefcafef00d --bits 64");
  EXPECT_NE(d.code, 0) << d.out;
  EXPECT_FALSE(std::filesystem::exists(p.dir + "/b.gltf"));
  // A .gltf that starts with a byte-order mark is marked, and keeps it.
  std::ofstream(p.dir + "/bom.gltf", std::ios::binary)
      << "\xEF\xBB\xBF" << slurp(p.dir + "/a.gltf");
  const std::string out = mark(p.dir + "/bom.gltf", p.dir + "/bom-marked.gltf");
  EXPECT_EQ(slurp(out).substr(0, 3), "\xEF\xBB\xBF");
}

// The review's reproduction: a buffer linked out of the asset's folder (pw -> /etc/passwd) was
// read and written into the marked copy's .bin. The same buffer moved out of the folder and
// linked back is refused by name; linked from within the folder it is read.
TEST(Gltf, ABufferLinkedOutOfItsFolderIsRefused) {
  const std::string obj = spot_obj();
  MESHMARK_REQUIRE(obj, "spot.obj");
  if (!have("gltfpack")) GTEST_SKIP() << "skipped: gltfpack is not installed";
  const Packed p = pack(obj, "-noq", "linked.gltf");  // buffer linked.bin
  const std::filesystem::path dir(p.dir);
  const Mesh direct = read_mesh(p.path);
  // Inside the folder: a link to a file beside it is fine.
  std::filesystem::create_directories(dir / "store");
  std::filesystem::rename(dir / "linked.bin", dir / "store" / "real.bin");
  std::filesystem::create_symlink("store/real.bin", dir / "linked.bin");
  EXPECT_EQ(read_mesh(p.path).V, direct.V);
  // Out of the folder: the asset sits in a subfolder, its buffer a link to the parent's file.
  std::filesystem::create_directories(dir / "asset");
  std::filesystem::copy_file(p.path, dir / "asset" / "linked.gltf");
  std::filesystem::create_symlink("../store/real.bin", dir / "asset" / "linked.bin");
  const std::string escaped = (dir / "asset" / "linked.gltf").string();
  try {
    (void)read_mesh(escaped);
    ADD_FAILURE() << "a buffer outside the asset's folder was read";
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find("leads out of the file's folder"), std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("linked.bin"), std::string::npos) << e.what();
  }
  const test::CliRun e = test::run_cli("embed '" + escaped + "' '" + p.dir +
                                       "/asset/out.gltf' --payload deadbeefcafef00d --bits 64");
  EXPECT_EQ(e.code, 2) << e.out;
  EXPECT_FALSE(std::filesystem::exists(dir / "asset" / "out.gltf"));
  EXPECT_FALSE(std::filesystem::exists(dir / "asset" / "out.bin"));
}

TEST(Gltf, WeldToleranceMarksEveryStoredVertexByItsVertexDisplacement) {
  const std::string obj = spot_obj();
  MESHMARK_REQUIRE(obj, "spot.obj");
  if (!have("gltfpack")) GTEST_SKIP() << "skipped: gltfpack is not installed";
  const Packed p = pack(obj, "-noq", "w.glb");
  const std::string out = p.dir + "/w-marked.glb";
  const std::string args = " --bits 64 --weld-tolerance 1e-4";
  ASSERT_EQ(
      test::run_cli("embed '" + p.path + "' '" + out + "' --payload deadbeefcafef00d" + args).code,
      0);
  EXPECT_NE(test::run_cli("extract '" + out + "'" + args).out.find("payload deadbeefcafef00d"),
            std::string::npos);
  // Every stored vertex moved by the displacement of the vertex it was welded into (found by
  // the test as the welded vertex nearest to it in the source, within the tolerance), to
  // float32 rounding (1e-6 of the extent).
  ReadOptions ro;
  ro.weld_tolerance = 1e-4;
  const Mesh a = read_mesh(p.path, ro), b = read_mesh(out, ro);
  ASSERT_EQ(a.V.rows(), b.V.rows());
  const std::vector<Eigen::Vector3d> pa = tinygltf_positions(p.path), pb = tinygltf_positions(out);
  ASSERT_EQ(pa.size(), pb.size());
  const double extent = (a.V.colwise().maxCoeff() - a.V.colwise().minCoeff()).norm();
  std::map<std::array<long long, 3>, std::vector<Eigen::Index>> grid;
  auto cell = [](const Eigen::Vector3d& q) {
    return std::array<long long, 3>{std::llround(std::floor(q[0] / 1e-3)),
                                    std::llround(std::floor(q[1] / 1e-3)),
                                    std::llround(std::floor(q[2] / 1e-3))};
  };
  for (Eigen::Index i = 0; i < a.V.rows(); ++i) grid[cell(a.V.row(i).transpose())].push_back(i);
  double worst = 0;
  std::size_t checked = 0;
  for (std::size_t i = 0; i < pa.size(); ++i) {
    const auto c = cell(pa[i]);
    Eigen::Index best = -1;
    double best_d = 1e-4;
    for (long long dx = -1; dx <= 1; ++dx)
      for (long long dy = -1; dy <= 1; ++dy)
        for (long long dz = -1; dz <= 1; ++dz) {
          const auto it = grid.find({c[0] + dx, c[1] + dy, c[2] + dz});
          if (it == grid.end()) continue;
          for (const Eigen::Index r : it->second) {
            const double d = (a.V.row(r).transpose() - pa[i]).norm();
            if (d <= best_d) best_d = d, best = r;
          }
        }
    if (best < 0) continue;  // unreferenced: not welded, not moved
    ++checked;
    const Eigen::Vector3d expected = (b.V.row(best) - a.V.row(best)).transpose();
    worst = std::max(worst, ((pb[i] - pa[i]) - expected).norm());
  }
  EXPECT_GT(checked, pa.size() / 2);
  EXPECT_LT(worst, 1e-6 * extent);
}

TEST(Gltf, EmbeddedDataUriBufferIsPatchedInPlace) {
  const std::string obj = spot_obj();
  MESHMARK_REQUIRE(obj, "spot.obj");
  if (!have("gltfpack")) GTEST_SKIP() << "skipped: gltfpack is not installed";
  const Packed p = pack(obj, "-noq", "model.gltf");
  // The same file with its buffer as a base64 data URI (made by the test).
  Json doc = Json::parse(slurp(p.path));
  const std::string bin = slurp(p.dir + "/model.bin");
  const std::string b64 = test_base64(bin);
  doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + b64;
  const std::string embedded = p.dir + "/embedded.gltf";
  std::ofstream(embedded) << doc.dump(1);
  std::filesystem::remove(p.dir + "/model.bin");
  const Mesh a = read_mesh(embedded);
  const std::string out = mark(embedded, p.dir + "/marked.gltf");
  const Mesh b = read_mesh(out);
  ASSERT_EQ(a.V.rows(), b.V.rows());
  EXPECT_GT((a.V - b.V).norm(), 0);
  EXPECT_LT((a.V - b.V).cwiseAbs().maxCoeff(),
            0.01 * (a.V.colwise().maxCoeff() - a.V.colwise().minCoeff()).norm());
}

TEST(Gltf, ConvertedFromObjIsAValidGlbAndGltf) {
  const std::string obj = spot_obj();
  MESHMARK_REQUIRE(obj, "spot.obj");
  REQUIRE_VALIDATOR();
  const Mesh m = read_mesh(obj);
  const std::string dir = test::scratch_dir();
  for (const char* ext : {"glb", "gltf"}) {
    SCOPED_TRACE(ext);
    const std::string out = dir + "/spot." + ext;
    write_mesh(out, m);
    std::string report;
    const int errors = validator_errors(out, &report);
    if (errors >= 0) EXPECT_EQ(errors, 0) << report;
    const Mesh back = read_mesh(out);
    EXPECT_EQ(back.F.rows(), m.F.rows());
    // Every position is the float32 of the source's (welded duplicates aside).
    std::set<std::array<float, 3>> source;
    for (Eigen::Index i = 0; i < m.V.rows(); ++i)
      source.insert({static_cast<float>(m.V(i, 0)), static_cast<float>(m.V(i, 1)),
                     static_cast<float>(m.V(i, 2))});
    for (Eigen::Index i = 0; i < back.V.rows(); ++i)
      ASSERT_TRUE(source.count({static_cast<float>(back.V(i, 0)), static_cast<float>(back.V(i, 1)),
                                static_cast<float>(back.V(i, 2))}))
          << i;
    EXPECT_EQ(static_cast<std::size_t>(back.V.rows()), source.size());
  }
}

TEST(Gltf, NodeTransformsAreAppliedAndUndone) {
  const std::string obj = spot_obj();
  MESHMARK_REQUIRE(obj, "spot.obj");
  if (!have("gltfpack")) GTEST_SKIP() << "skipped: gltfpack is not installed";
  REQUIRE_VALIDATOR();
  const Packed p = pack(obj, "-noq", "flat.glb");
  Glb g = split_glb(slurp(p.path));
  // A rotation, a non-uniform scale and a translation under a parent node (the test's edit).
  const Eigen::Matrix3d r =
      Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  Eigen::Matrix4d local = Eigen::Matrix4d::Identity();
  local.topLeftCorner<3, 3>() = r * Eigen::Vector3d(2.0, 0.5, 1.25).asDiagonal();
  local.topRightCorner<3, 1>() = Eigen::Vector3d(10, -3, 0.25);
  Json matrix = Json::array();
  for (int c = 0; c < 4; ++c)
    for (int row = 0; row < 4; ++row) matrix.push_back(local(row, c));
  Json& node = g.json["nodes"][0];
  node.erase("translation");
  node.erase("scale");
  node["matrix"] = matrix;
  g.json["nodes"].push_back({{"children", {0}}, {"translation", {1, 2, 3}}});
  g.json["scenes"][0]["nodes"] = {1};
  std::string json = g.json.dump();
  json.append((4 - json.size() % 4) % 4, ' ');
  std::string glb;
  auto u32 = [&](std::uint32_t v) { glb.append(reinterpret_cast<const char*>(&v), 4); };
  u32(0x46546C67);
  u32(2);
  u32(static_cast<std::uint32_t>(28 + json.size() + g.bin.size()));
  u32(static_cast<std::uint32_t>(json.size()));
  u32(0x4E4F534A);
  glb += json;
  u32(static_cast<std::uint32_t>(g.bin.size()));
  u32(0x004E4942);
  glb += g.bin;
  const std::string moved = p.dir + "/moved.glb";
  std::ofstream(moved, std::ios::binary) << glb;
  const Mesh flat = read_mesh(p.path), placed = read_mesh(moved);
  ASSERT_EQ(flat.V.rows(), placed.V.rows());
  Eigen::Matrix4d world = Eigen::Matrix4d::Identity();
  world.topRightCorner<3, 1>() = Eigen::Vector3d(1, 2, 3);
  world = world * local;
  double err = 0;
  for (Eigen::Index i = 0; i < flat.V.rows(); ++i) {
    const Eigen::Vector4d w = world * Eigen::Vector4d(flat.V(i, 0), flat.V(i, 1), flat.V(i, 2), 1);
    err = std::max(err, (w.head<3>() - placed.V.row(i).transpose()).norm());
  }
  EXPECT_LT(err, 1e-12 * 20);
  EXPECT_FALSE(placed.notes.empty()) << "the non-uniform scale is not reported";
  const std::string out = mark(moved, p.dir + "/moved-marked.glb");
  std::string report;
  EXPECT_EQ(validator_errors(out, &report), 0) << report;
  // Written back through the inverse: the local positions moved by less than the mark's size.
  const Mesh back_flat = read_mesh_from_bytes(slurp(out), FileFormat::Glb, "x.glb");
  EXPECT_EQ(back_flat.V.rows(), flat.V.rows());
}

// A GLB whose one primitive is Draco-compressed (KHR_draco_mesh_compression), built by the
// test around draco_encoder's output; counts from draco_decoder's PLY, read independently.
TEST(Gltf, DracoCompressedPrimitiveIsReadAndReencoded) {
  const std::string bunny = test::data_mesh("bunny.ply");
  MESHMARK_REQUIRE(bunny, "bunny.ply");
  if (!have("draco_encoder")) GTEST_SKIP() << "skipped: draco_encoder is not installed";
  const std::string dir = test::scratch_dir();
  ASSERT_EQ(sh("draco_encoder -i '" + bunny + "' -o '" + dir + "/b.drc' -qp 14").code, 0);
  ASSERT_EQ(sh("draco_decoder -i '" + dir + "/b.drc' -o '" + dir + "/b.ply'").code, 0);
  const Mesh decoded = read_mesh(dir + "/b.ply");  // meshmark's PLY reader, not its Draco one
  const std::string drc = slurp(dir + "/b.drc");
  std::string bin = drc;
  bin.append((4 - bin.size() % 4) % 4, '\0');
  Json doc = {
      {"asset", {{"version", "2.0"}}},
      {"extensionsUsed", {"KHR_draco_mesh_compression"}},
      {"extensionsRequired", {"KHR_draco_mesh_compression"}},
      {"buffers", {{{"byteLength", bin.size()}}}},
      {"bufferViews", {{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", drc.size()}}}},
      {"accessors",
       {{{"componentType", 5126},
         {"count", decoded.V.rows()},
         {"type", "VEC3"},
         {"min",
          {decoded.V.col(0).minCoeff(), decoded.V.col(1).minCoeff(), decoded.V.col(2).minCoeff()}},
         {"max",
          {decoded.V.col(0).maxCoeff(), decoded.V.col(1).maxCoeff(), decoded.V.col(2).maxCoeff()}}},
        {{"componentType", 5125}, {"count", 3 * decoded.F.rows()}, {"type", "SCALAR"}}}},
      {"meshes",
       {{{"primitives",
          {{{"attributes", {{"POSITION", 0}}},
            {"indices", 1},
            {"extensions",
             {{"KHR_draco_mesh_compression",
               {{"bufferView", 0}, {"attributes", {{"POSITION", 0}}}}}}}}}}}}},
      {"nodes", {{{"mesh", 0}, {"translation", {1, 2, 3}}}}},
      {"scenes", {{{"nodes", {0}}}}},
      {"scene", 0}};
  std::string json = doc.dump();
  json.append((4 - json.size() % 4) % 4, ' ');
  std::string glb;
  auto u32 = [&](std::uint32_t v) { glb.append(reinterpret_cast<const char*>(&v), 4); };
  u32(0x46546C67);
  u32(2);
  u32(static_cast<std::uint32_t>(28 + json.size() + bin.size()));
  u32(static_cast<std::uint32_t>(json.size()));
  u32(0x4E4F534A);
  glb += json;
  u32(static_cast<std::uint32_t>(bin.size()));
  u32(0x004E4942);
  glb += bin;
  const std::string in = dir + "/draco.glb";
  std::ofstream(in, std::ios::binary) << glb;
  const Mesh m = read_mesh(in);
  EXPECT_EQ(m.F.rows(), decoded.F.rows());
  // Every vertex is a decoded point moved by the node's translation (float32 + double sum).
  std::set<std::array<double, 3>> points;
  for (Eigen::Index i = 0; i < decoded.V.rows(); ++i)
    points.insert({decoded.V(i, 0) + 1, decoded.V(i, 1) + 2, decoded.V(i, 2) + 3});
  for (Eigen::Index i = 0; i < m.V.rows(); ++i)
    ASSERT_TRUE(points.count({m.V(i, 0), m.V(i, 1), m.V(i, 2)})) << i;
  const std::string out = mark(in, dir + "/draco-marked.glb");
  // The JSON is the source's but for the view's length and the POSITION accessor's bounds.
  const Glb a = split_glb(glb), b = split_glb(slurp(out));
  Json ja = a.json, jb = b.json;
  for (Json* j : {&ja, &jb}) {
    (*j)["bufferViews"][0].erase("byteLength");
    (*j)["buffers"][0].erase("byteLength");
    (*j)["accessors"][0].erase("min");
    (*j)["accessors"][0].erase("max");
  }
  EXPECT_EQ(ja, jb);
  EXPECT_TRUE(jb.dump().find("KHR_draco_mesh_compression") != std::string::npos);
  std::string report;
  if (validator_installed()) EXPECT_EQ(validator_errors(out, &report), 0) << report;
}

TEST(Gltf, SampleAssetsFromDebianReadOrFailClearly) {
  const std::string root = "/usr/share/assimp/models/glTF2";
  if (!std::filesystem::exists(root))
    GTEST_FAIL() << "assimp-testmodels is not installed (scripts/setup.sh)";
  // Files that are valid glTF with triangles: read; instanced ones refuse a marked write.
  const Mesh engine = read_mesh(root + "/2CylinderEngine-glTF-Binary/2CylinderEngine.glb");
  EXPECT_GT(engine.F.rows(), 100000 / 10);
  bool instanced = false;
  for (const auto& n : engine.notes) instanced |= n.find("instanced") != std::string::npos;
  EXPECT_TRUE(instanced);
  // Instanced geometry is read once per stored primitive: the triangles are those of the
  // distinct (POSITION, indices) pairs of the JSON, counted by the test.
  {
    const Glb g = split_glb(slurp(root + "/2CylinderEngine-glTF-Binary/2CylinderEngine.glb"));
    std::set<std::pair<int, int>> distinct;
    for (const Json& m : g.json["meshes"])
      for (const Json& p : m["primitives"])
        distinct.insert({p["attributes"]["POSITION"].get<int>(), p["indices"].get<int>()});
    long triangles = 0;
    for (const auto& [pos, ind] : distinct)
      triangles += g.json["accessors"][static_cast<std::size_t>(ind)]["count"].get<long>() / 3;
    EXPECT_EQ(engine.F.rows(), triangles);
  }
  // ... and marked once: every instance shows the marked stored vertices.
  const std::string engine_out = test::scratch_dir() + "/engine.glb";
  const test::CliRun e =
      test::run_cli("embed " + root + "/2CylinderEngine-glTF-Binary/2CylinderEngine.glb " +
                    engine_out + " --payload a5c3 --bits 16");
  EXPECT_EQ(e.code, 0) << e.out;
  EXPECT_NE(test::run_cli("extract " + engine_out + " --bits 16").out.find("payload a5c3"),
            std::string::npos);
  const Mesh morph =
      read_mesh(root + "/glTF-Sample-Models/AnimatedMorphCube-glTF/AnimatedMorphCube.gltf");
  EXPECT_FALSE(morph.notes.empty());
  const Mesh skin = read_mesh(root + "/simple_skin/simple_skin.gltf");
  EXPECT_FALSE(skin.notes.empty());
  // Files the glTF rules forbid: errors naming the file and what is wrong.
  const std::pair<std::string, std::string> bad[] = {
      {"/IndexOutOfRange/IndexOutOfRange.gltf", "out of range"},
      {"/RecursiveNodes/RecursiveNodes.gltf", "reached twice"},
      {"/BoxWithInfinites-glTF-Binary/BoxWithInfinites.glb", "not finite"},
      {"/IncorrectVertexArrays/Cube.gltf", "outside buffer"},
      {"/MissingBin/BoxTextured.gltf", "cannot open"},
  };
  for (const auto& [file, words] : bad) {
    SCOPED_TRACE(file);
    try {
      (void)read_mesh(root + file);
      ADD_FAILURE() << "read";
    } catch (const Error& err) {
      EXPECT_NE(std::string(err.what()).find(words), std::string::npos) << err.what();
    }
    const test::CliRun x = test::run_cli("extract '" + root + file + "' --bits 8");
    EXPECT_EQ(x.code, 2) << x.out;
  }
}

TEST(Gltf, MalformedContainersAndJsonAreRefusedByName) {
  const std::string obj = spot_obj();
  MESHMARK_REQUIRE(obj, "spot.obj");
  const std::string good = write_mesh_to_bytes(read_mesh(obj), FileFormat::Glb);
  const Glb g = split_glb(good);
  auto expect_refused = [](const std::string& bytes, FileFormat f, const std::string& words) {
    try {
      (void)read_mesh_from_bytes(bytes, f, "bad.glb");
      ADD_FAILURE() << "accepted; expected: " << words;
    } catch (const InvalidInputError& e) {
      EXPECT_NE(std::string(e.what()).find("bad.glb"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  };
  expect_refused(good.substr(0, good.size() / 2), FileFormat::Glb, "header says");
  expect_refused("glTF", FileFormat::Glb, "not a GLB");
  std::string v1 = good;
  v1[4] = 1;
  expect_refused(v1, FileFormat::Glb, "version 1");
  expect_refused("{\"asset\": {\"version\": \"2.0\"", FileFormat::Gltf, "does not parse");
  // A number beyond double's range (found by the fuzzer in a campaign file): not a type error.
  expect_refused("{\"asset\": {\"version\": \"2.0\"}, \"x\": 1e999}", FileFormat::Gltf,
                 "does not parse");
  expect_refused("{\"asset\": {\"version\": \"1.0\"}}", FileFormat::Gltf, "not glTF 2.0");
  auto edited = [&](const std::function<void(Json&)>& edit) {
    Json j = g.json;
    // Whole 3-byte groups only: no padding, byteLength a multiple of 3.
    const std::string b64 = test_base64(g.bin.substr(0, g.bin.size() / 3 * 3));
    j["buffers"][0]["uri"] = "data:application/octet-stream;base64," + b64;
    j["buffers"][0]["byteLength"] = b64.size() / 4 * 3;
    edit(j);
    return j.dump();
  };
  expect_refused(edited([](Json& j) { j["accessors"][0]["count"] = 1u << 30; }), FileFormat::Gltf,
                 "overrun");
  expect_refused(edited([](Json& j) { j["accessors"][0]["componentType"] = 5125; }),
                 FileFormat::Gltf, "POSITION of componentType 5125");
  expect_refused(edited([](Json& j) { j["bufferViews"][0]["byteOffset"] = 1u << 31; }),
                 FileFormat::Gltf, "outside buffer");
  expect_refused(
      edited([](Json& j) { j["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = 7; }),
      FileFormat::Gltf, "names no element");
  expect_refused(edited([](Json& j) { j["extensionsRequired"] = {"KHR_unknown"}; }),
                 FileFormat::Gltf, "KHR_unknown");
  expect_refused(edited([](Json& j) { j["buffers"][0]["uri"] = "../../etc/passwd"; }),
                 FileFormat::Gltf, "not a relative path below");
  expect_refused(edited([](Json& j) { j["nodes"][0]["children"] = {0}; }), FileFormat::Gltf,
                 "reached twice");
  expect_refused(edited([](Json& j) { j["accessors"][0]["count"] = "many"; }), FileFormat::Gltf,
                 "accessors[0]");
  expect_refused(edited([](Json& j) { j["accessors"][0]["type"] = 3; }), FileFormat::Gltf,
                 "wrong type");
  expect_refused(edited([](Json& j) { j["bufferViews"][0]["byteStride"] = 4; }), FileFormat::Gltf,
                 "shorter than an element");
  expect_refused(edited([](Json& j) { j["accessors"][0]["normalized"] = true; }), FileFormat::Gltf,
                 "'normalized'");
  expect_refused(edited([](Json& j) {
                   j["nodes"][0]["matrix"] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
                   j["nodes"][0]["translation"] = {1, 2, 3};
                 }),
                 FileFormat::Gltf, "both 'matrix'");
  expect_refused(edited([](Json& j) {
                   j["nodes"][0]["rotation"] = {0, 0, 0, 0};
                 }),
                 FileFormat::Gltf, "unit quaternion");
}

}  // namespace
}  // namespace meshmark
