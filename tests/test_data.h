#pragma once
// Where the tests find real meshes: ../shared/meshes beside the project and Debian's
// libcgal-demo data unpacked into the build tree. Tests skip, saying why, when one is absent.

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "meshmark/mesh.h"

namespace meshmark::test {

/// Path of a file in ../shared/meshes, or "" when that folder or file is absent.
std::string shared_mesh(const std::string& name);

/// Path of a file in libcgal-demo's data/meshes, or "" when absent.
std::string cgal_mesh(const std::string& name);

/// A unique scratch directory for one test (removed by the OS's tmp cleaning, not by us).
std::string scratch_dir();

/// A closed, irregular test surface generated in code: a sphere of n_theta x n_phi vertices
/// whose radius varies smoothly with the direction (so the histogram is spread), seeded.
Mesh bumpy_sphere(int n_theta, int n_phi, unsigned seed);

/// The lines of a text (split at '\n', terminators dropped).
std::vector<std::string> split_lines(const std::string& text);

/// What a run of the meshmark command line printed (stdout and stderr) and its exit code.
struct CliRun {
  int code = -1;
  std::string out;
};

/// Runs the meshmark CLI with args (a shell command line tail).
CliRun run_cli(const std::string& args);

/// Runs a shell command line (stderr merged into the output).
CliRun run_command(const std::string& command);

/// The whitespace-separated words of a line.
std::vector<std::string> words(const std::string& line);

/// Expects a malformed mesh file to be refused: read_mesh throws InvalidInputError naming path
/// with a message (printed, so that a run shows what each refusal says), and the CLI's
/// extract exits 2 naming path.
void expect_invalid_input(const std::string& path);

}  // namespace meshmark::test

/// Skips the current test when path is empty, naming what is missing.
#define MESHMARK_REQUIRE(path, what)                                   \
  do {                                                                 \
    if ((path).empty())                                                \
      GTEST_SKIP() << "skipped: " << (what) << " is not available "    \
                   << "(needs ../shared/meshes or libcgal-demo data)"; \
  } while (0)
