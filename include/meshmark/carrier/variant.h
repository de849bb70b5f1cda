#pragma once
/// \file variant.h
/// The framework's variants (TIFS 2014): a center (D, S, V), a direction of displacement
/// (R radial, N normal, S roughness-adapted) and a cost (S squared error, Q quadric error,
/// L Laplacian), named by their three letters: DRS is the baseline.

#include <string>
#include <string_view>

#include "meshmark/carrier/center.h"

namespace meshmark {

/// Direction of displacement, second letter.
enum class DirectionKind {
  Radial,  ///< R: u_i = (p_i - C) / |p_i - C|
  Normal,  ///< N: unit area-weighted vertex normal
  Smooth,  ///< S: radial where the surface is rough, tangent-projected radial where smooth
};

/// Cost, third letter.
enum class CostKind {
  Squared,    ///< S: sum r_i^2
  Quadric,    ///< Q: lambda sum r_i^2 + (1 - lambda) sum q_i r_i^2
  Laplacian,  ///< L: lambda sum r_i^2 + (1 - lambda) sum |r_i u_i - mean_{N1(i)} r_j u_j|^2
};

/// One variant.
struct Variant {
  CenterKind center = CenterKind::Discrete;
  DirectionKind direction = DirectionKind::Radial;
  CostKind cost = CostKind::Squared;
  /// "DRS", "VRL", ...
  std::string name() const;
  bool operator==(const Variant&) const = default;
};

/// Parses a three-letter name (any case). \throw InvalidArgumentError naming the bad letter.
Variant parse_variant(std::string_view name);

/// The paper's seven: DRS, SRS, VRS, VRQ, VRL, VNS, VSS.
const char* const kPaperVariants[] = {"DRS", "SRS", "VRS", "VRQ", "VRL", "VNS", "VSS"};

}  // namespace meshmark
