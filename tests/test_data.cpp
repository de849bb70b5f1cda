#include "test_data.h"

#include <sys/wait.h>
#include <unistd.h>

#include <Eigen/Geometry>

#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <random>
#include <sstream>

#include "meshmark/core/error.h"
#include "meshmark/io/io.h"

namespace meshmark::test {

namespace {
std::string existing(const std::filesystem::path& p) {
  std::error_code ec;
  return std::filesystem::is_regular_file(p, ec) ? p.string() : std::string();
}

// Campaign files' ${data} and ${cgal}, for the library and the CLI the tests run: this
// checkout's data folder and build tree, unless the environment already names others.
[[maybe_unused]] const bool data_environment = [] {
  setenv("MESHMARK_DATA_DIR", MESHMARK_TEST_DATA, 0);
  setenv("MESHMARK_CGAL_DATA", MESHMARK_CGAL_DATA, 0);
  return true;
}();
}  // namespace

std::string data_mesh(const std::string& name) {
  return existing(std::filesystem::path(MESHMARK_TEST_DATA) / "meshes" / name);
}

std::string cgal_mesh(const std::string& name) {
  return existing(std::filesystem::path(MESHMARK_CGAL_DATA) / name);
}

namespace {

std::filesystem::path checkout_tmp() {
  // One tree per checkout: two checkouts' suites running at once (worktrees) would otherwise
  // remove and write each other's directories (seen: a campaign's rows lost mid-run).
  const std::string checkout =
      std::to_string(std::hash<std::string>{}(MESHMARK_SOURCE_DIR) % 1000000007u);
  return std::filesystem::temp_directory_path() / ("meshmark-tests-" + checkout);
}

// Writes bytes to path through a temporary file and a rename, so that test processes running
// at once never read a half-written fixture.
void write_atomically(const std::filesystem::path& path, const std::string& bytes) {
  std::filesystem::create_directories(path.parent_path());
  const std::filesystem::path tmp = path.string() + "." + std::to_string(getpid()) + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  }
  std::filesystem::rename(tmp, path);
}

template <typename T>
void put(std::string& out, T value) {
  out.append(reinterpret_cast<const char*>(&value), sizeof value);
}

// A fixture file derived from bunny00.off, made once by make(mesh) (the bytes to write).
std::string bunny00_fixture(const std::string& name, std::string (*make)(const Mesh&)) {
  const std::string off = cgal_mesh("bunny00.off");
  if (off.empty()) return {};
  const std::filesystem::path path = checkout_tmp() / "fixtures" / name;
  if (!std::filesystem::is_regular_file(path)) write_atomically(path, make(read_mesh(off)));
  return path.string();
}

std::string ply_header(const Mesh& m, const std::string& vertex_props, const std::string& faces) {
  return "ply\nformat binary_little_endian 1.0\ncomment meshmark tests, from bunny00.off\n"
         "element vertex " +
         std::to_string(m.V.rows()) + "\n" + vertex_props + faces + "end_header\n";
}

std::string binary_ply_with_normals(const Mesh& m) {
  Eigen::MatrixX3d N = Eigen::MatrixX3d::Zero(m.V.rows(), 3);
  for (Eigen::Index t = 0; t < m.F.rows(); ++t) {
    const Eigen::RowVector3d a = m.V.row(m.F(t, 0)), b = m.V.row(m.F(t, 1)), c = m.V.row(m.F(t, 2));
    const Eigen::RowVector3d n = (b - a).cross(c - a);  // twice the area, outwards
    for (int k = 0; k < 3; ++k) N.row(m.F(t, k)) += n;
  }
  N.rowwise().normalize();
  std::string out = ply_header(
      m,
      "property float x\nproperty float y\nproperty float z\n"
      "property float nx\nproperty float ny\nproperty float nz\n",
      "element face " + std::to_string(m.F.rows()) + "\nproperty list uchar int vertex_indices\n");
  for (Eigen::Index i = 0; i < m.V.rows(); ++i) {
    for (int c = 0; c < 3; ++c) put(out, static_cast<float>(m.V(i, c)));
    for (int c = 0; c < 3; ++c) put(out, static_cast<float>(N(i, c)));
  }
  for (Eigen::Index t = 0; t < m.F.rows(); ++t) {
    put(out, static_cast<std::uint8_t>(3));
    for (int c = 0; c < 3; ++c) put(out, static_cast<std::int32_t>(m.F(t, c)));
  }
  return out;
}

// Greedy strips: a strip v0 v1 v2 ... holds triangle i as (v_i, v_i+1, v_i+2) for even i and
// (v_i+1, v_i, v_i+2) for odd i; it grows across its last triangle's edge {v_i+1, v_i+2} while
// the neighbour there is unused.
std::string binary_ply_tristrips(const Mesh& m) {
  std::map<std::pair<int, int>, int> face_of_edge;  // directed edge -> face
  for (Eigen::Index t = 0; t < m.F.rows(); ++t)
    for (int c = 0; c < 3; ++c)
      face_of_edge[{m.F(t, c), m.F(t, (c + 1) % 3)}] = static_cast<int>(t);
  std::vector<char> used(static_cast<std::size_t>(m.F.rows()), 0);
  std::vector<std::int32_t> strips;
  for (Eigen::Index t0 = 0; t0 < m.F.rows(); ++t0) {
    if (used[t0]) continue;
    used[t0] = 1;
    if (!strips.empty()) strips.push_back(-1);
    std::vector<int> s = {m.F(t0, 0), m.F(t0, 1), m.F(t0, 2)};
    while (true) {
      const int a = s[s.size() - 2], b = s[s.size() - 1];
      // The last triangle holds the directed edge a -> b when its index is even, b -> a when odd;
      // its neighbour across that edge holds the reverse.
      const bool even = (s.size() - 3) % 2 == 0;
      const auto it = face_of_edge.find(even ? std::pair{b, a} : std::pair{a, b});
      if (it == face_of_edge.end() || used[it->second]) break;
      int third = -1;
      for (int c = 0; c < 3; ++c)
        if (m.F(it->second, c) != a && m.F(it->second, c) != b) third = m.F(it->second, c);
      used[it->second] = 1;
      s.push_back(third);
    }
    strips.insert(strips.end(), s.begin(), s.end());
  }
  std::string out = ply_header(m, "property float x\nproperty float y\nproperty float z\n",
                               "element tristrips 1\nproperty list int int vertex_indices\n");
  for (Eigen::Index i = 0; i < m.V.rows(); ++i)
    for (int c = 0; c < 3; ++c) put(out, static_cast<float>(m.V(i, c)));
  put(out, static_cast<std::int32_t>(strips.size()));
  for (std::int32_t v : strips) put(out, v);
  return out;
}

}  // namespace

std::string closed_binary_ply() {
  return bunny00_fixture("bunny00-normals.ply", binary_ply_with_normals);
}

std::string tristrip_ply() {
  return bunny00_fixture("bunny00-tristrips.ply", binary_ply_tristrips);
}

std::string scratch_dir() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::filesystem::path dir =
      checkout_tmp() / (std::string(info->test_suite_name()) + "." + info->name());
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir.string();
}

Mesh bumpy_sphere(int n_theta, int n_phi, unsigned seed) {
  std::mt19937 gen(seed);
  std::uniform_real_distribution<double> coef(-0.15, 0.15);
  const double a = coef(gen), b = coef(gen), c = coef(gen), d = coef(gen);
  const int nv = n_theta * n_phi + 2;
  Eigen::MatrixX3d V(nv, 3);
  auto radius = [&](double th, double ph) {
    return 1.0 + a * std::sin(3 * th) * std::cos(2 * ph) + b * std::cos(5 * ph) +
           c * std::sin(2 * th + ph) + d * std::cos(4 * th);
  };
  for (int i = 0; i < n_theta; ++i)
    for (int j = 0; j < n_phi; ++j) {
      const double th = M_PI * (i + 1) / (n_theta + 1), ph = 2 * M_PI * j / n_phi;
      const double r = radius(th, ph);
      V.row(i * n_phi + j) << r * std::sin(th) * std::cos(ph), r * std::sin(th) * std::sin(ph),
          r * std::cos(th);
    }
  V.row(nv - 2) << 0, 0, radius(0, 0);
  V.row(nv - 1) << 0, 0, -radius(M_PI, 0);
  std::vector<Eigen::Vector3i> tris;
  for (int i = 0; i + 1 < n_theta; ++i)
    for (int j = 0; j < n_phi; ++j) {
      const int p = i * n_phi + j, q = i * n_phi + (j + 1) % n_phi;
      tris.emplace_back(p, p + n_phi, q);
      tris.emplace_back(q, p + n_phi, q + n_phi);
    }
  for (int j = 0; j < n_phi; ++j) {
    tris.emplace_back(nv - 2, j, (j + 1) % n_phi);
    const int base = (n_theta - 1) * n_phi;
    tris.emplace_back(nv - 1, base + (j + 1) % n_phi, base + j);
  }
  Eigen::MatrixX3i F(static_cast<Eigen::Index>(tris.size()), 3);
  for (std::size_t k = 0; k < tris.size(); ++k)
    F.row(static_cast<Eigen::Index>(k)) = tris[k].transpose();
  return make_mesh(std::move(V), std::move(F));
}

std::vector<std::string> split_lines(const std::string& text) {
  std::vector<std::string> lines;
  std::size_t start = 0;
  while (true) {
    const std::size_t end = text.find('\n', start);
    lines.push_back(text.substr(start, end == std::string::npos ? std::string::npos : end - start));
    if (end == std::string::npos) return lines;
    start = end + 1;
  }
}

std::vector<std::string> words(const std::string& line) {
  std::istringstream in(line);
  std::vector<std::string> w;
  for (std::string t; in >> t;) w.push_back(t);
  return w;
}

CliRun run_cli(const std::string& args) {
  return run_command(std::string(MESHMARK_CLI) + " " + args);
}

CliRun run_command(const std::string& command) {
  const std::string cmd = command + " 2>&1";
  CliRun r;
  FILE* pipe = popen(cmd.c_str(), "r");
  if (!pipe) return r;
  std::array<char, 4096> buf;
  std::size_t n;
  while ((n = fread(buf.data(), 1, buf.size(), pipe)) > 0) r.out.append(buf.data(), n);
  const int status = pclose(pipe);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

void expect_invalid_input(const std::string& path) {
  try {
    read_mesh(path);
    ADD_FAILURE() << path << ": read without an exception";
  } catch (const InvalidInputError& e) {
    EXPECT_EQ(e.file(), path);
    EXPECT_FALSE(e.detail().empty());
    std::cout << "  refused: " << e.what() << "\n";
  }
  const CliRun r = run_cli("extract " + path);
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find(path), std::string::npos) << r.out;
}

}  // namespace meshmark::test
