#pragma once
// Where the tests find real meshes: the project's data/meshes and Debian's libcgal-demo data
// unpacked into the build tree (scripts/setup.sh installs it). A test whose mesh is missing
// fails, naming the file: data is part of the project, never a reason to skip.

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "meshmark/core/mesh.h"

namespace meshmark::test {

/// Path of a file in the project's data/meshes (data/meshes/MANIFEST.md), or "" when absent.
std::string data_mesh(const std::string& name);

/// Path of a file in libcgal-demo's data/meshes, or "" when absent.
std::string cgal_mesh(const std::string& name);

/// libcgal-demo's bunny00.off (37,706 vertices, 75,408 faces, closed, genus 0) written as a
/// binary little-endian PLY with float positions and unit area-weighted vertex normals (x y z nx
/// ny nz, faces as uchar/int lists), the layout scanners and MeshLab write; written once per
/// checkout by a writer of the tests' own, "" when bunny00.off is absent.
std::string closed_binary_ply();

/// The same mesh with its faces stored as one binary PLY TRISTRIPS element (strips of
/// consistently oriented neighbours, separated by -1), "" when bunny00.off is absent.
std::string tristrip_ply();

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

/// Fails the current test when path is empty, naming the missing mesh and where it comes from.
#define MESHMARK_REQUIRE(path, what)                                                          \
  do {                                                                                        \
    if ((path).empty())                                                                       \
      GTEST_FAIL() << (what) << " is missing: the project's data/meshes, or libcgal-demo's "  \
                   << "data (scripts/setup.sh installs it; CMake unpacks it into the build)"; \
  } while (0)
