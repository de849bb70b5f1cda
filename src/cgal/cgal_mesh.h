#pragma once
// Internal: conversion between meshmark's Mesh and a CGAL Surface_mesh, with the repair CGAL
// needs for edge collapse and subdivision. Included only by the cgal_*.cpp translation units,
// so that CGAL's templates stay out of the rest of the build.

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Surface_mesh.h>

#include "meshmark/core/mesh.h"
#include "meshmark/core/progress.h"

namespace meshmark::detail {

using CgalKernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using SurfaceMesh = CGAL::Surface_mesh<CgalKernel::Point_3>;

/// The referenced triangles of mesh as a CGAL surface mesh. Bit-identical positions are merged
/// and the degenerate triangles dropped first (a repeated corner, corners at one position, or
/// three collinear corners: zero area), which CGAL's soup repair does not do for triangles;
/// then duplicate triangles are removed (repair_polygon_soup) and the soup oriented, which
/// duplicates the vertices along non-manifold edges and at non-manifold vertices
/// (orient_polygon_soup), and turned into a mesh. Isolated vertices are left out.
/// \throw InvalidInputError when no triangle of non-zero area is left.
SurfaceMesh to_surface_mesh(const Mesh& mesh);

/// to_surface_mesh, reported to `progress` as the phase "preparing the mesh" (0 of 1, then 1 of
/// 1): the repair takes a few seconds on millions of triangles.
SurfaceMesh prepared_surface_mesh(const Mesh& mesh, const ProgressCallback& progress);

/// Back to V and F (garbage collected), with the format of `like` and no file image.
Mesh from_surface_mesh(SurfaceMesh& sm, const Mesh& like);

}  // namespace meshmark::detail
