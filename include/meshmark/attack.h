#pragma once
/// \file attack.h
/// Attacks of the mesh watermarking literature (Wang et al., SMI 2010 benchmark; the TIFS 2014
/// paper's section V), deterministic for a seed. Each returns a new mesh; those that keep the
/// connectivity keep the file image too, so the result can be written back in its format.

#include <cstdint>

#include "meshmark/mesh.h"

namespace meshmark {

/// Similarity transform: a uniformly random rotation, a translation of up to `translation`
/// times the bounding-box diagonal in each axis, and a uniform scale drawn in
/// [1 / max_scale, max_scale]. Distance ratios are preserved.
struct SimilarityOptions {
  double translation = 1.0;  ///< fraction of the bounding-box diagonal
  double max_scale = 2.0;    ///< >= 1
};

/// Applies a random similarity. Keeps the file image (connectivity unchanged).
Mesh attack_similarity(const Mesh& mesh, std::uint64_t seed, const SimilarityOptions& options = {});

/// Randomly permutes the vertices and the faces (and rotates each face's corner list
/// cyclically, keeping its orientation). The file image is dropped.
Mesh attack_reorder(const Mesh& mesh, std::uint64_t seed);

/// Uniformly random rotation matrix (Shoemake's quaternion method).
Eigen::Matrix3d random_rotation(std::uint64_t seed);

}  // namespace meshmark
