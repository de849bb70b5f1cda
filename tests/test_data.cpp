#include "test_data.h"

#include <sys/wait.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <random>
#include <sstream>

#include "meshmark/error.h"
#include "meshmark/io.h"

namespace meshmark::test {

namespace {
std::string existing(const std::filesystem::path& p) {
  std::error_code ec;
  return std::filesystem::is_regular_file(p, ec) ? p.string() : std::string();
}
}  // namespace

std::string shared_mesh(const std::string& name) {
  return existing(std::filesystem::path(MESHMARK_SHARED_DIR) / "meshes" / name);
}

std::string cgal_mesh(const std::string& name) {
  return existing(std::filesystem::path(MESHMARK_CGAL_DATA) / name);
}

std::string scratch_dir() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  // One tree per checkout: two checkouts' suites running at once (worktrees) would otherwise
  // remove and write each other's directories (seen: a campaign's rows lost mid-run).
  const std::string checkout =
      std::to_string(std::hash<std::string>{}(MESHMARK_SOURCE_DIR) % 1000000007u);
  std::filesystem::path dir = std::filesystem::temp_directory_path() /
                              ("meshmark-tests-" + checkout) /
                              (std::string(info->test_suite_name()) + "." + info->name());
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
