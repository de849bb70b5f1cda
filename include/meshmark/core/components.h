#pragma once
/// \file components.h
/// meshmark's optional components: what a program linked besides the core (meshmark::core).
///
/// The core reads and writes OBJ, PLY, OFF, STL and glTF/GLB, embeds, extracts, detects,
/// issues into and traces against an SQLite registry, and measures distortion; it links no GPL
/// library. Each component is a library of its own (a CMake target meshmark::NAME, found with
/// find_package(meshmark COMPONENTS NAME)) that adds one capability and its dependency:
///
/// | component | adds | library | its licence |
/// | --- | --- | --- | --- |
/// | draco | Draco files (.drc) and glTF's KHR_draco_mesh_compression | Draco | Apache-2.0 |
/// | 3mf | 3MF files | lib3mf | BSD-2-Clause |
/// | postgres | registries at postgresql:// addresses | libpq | PostgreSQL (permissive) |
/// | ipopt | the Ipopt solver (SolverBackend::Ipopt) | Ipopt | EPL-2.0 |
/// | cgal | the attacks simplify, qsimplify, remesh, loop, sqrt3 | CGAL | GPL-3.0-or-later |
///
/// A program that links the cgal component is a work under the GPL as a whole. Asking the core
/// for what a component adds, without it, throws MissingComponentError naming the component.

#include <string>
#include <string_view>
#include <vector>

namespace meshmark {

/// The components linked into this program, in the table's order ("draco", "3mf", ...).
std::vector<std::string> linked_components();

/// Whether the component `name` is linked into this program.
bool has_component(std::string_view name);

}  // namespace meshmark
