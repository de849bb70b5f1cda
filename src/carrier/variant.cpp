#include "meshmark/carrier/variant.h"

#include <fmt/format.h>

#include "meshmark/core/error.h"

namespace meshmark {

std::string Variant::name() const {
  const char d = direction == DirectionKind::Radial   ? 'R'
                 : direction == DirectionKind::Normal ? 'N'
                                                      : 'S';
  const char c = cost == CostKind::Squared ? 'S' : cost == CostKind::Quadric ? 'Q' : 'L';
  return std::string{center_letter(center), d, c};
}

Variant parse_variant(std::string_view name) {
  if (name.size() != 3)
    throw InvalidArgumentError(fmt::format(
        "variant '{}' is not three letters (center D/S/V, direction R/N/S, cost S/Q/L)", name));
  Variant v;
  v.center = center_from_letter(name[0]);
  switch (std::toupper(static_cast<unsigned char>(name[1]))) {
    case 'R':
      v.direction = DirectionKind::Radial;
      break;
    case 'N':
      v.direction = DirectionKind::Normal;
      break;
    case 'S':
      v.direction = DirectionKind::Smooth;
      break;
    default:
      throw InvalidArgumentError(
          fmt::format("variant '{}': unknown direction '{}' (expected R, N or S)", name, name[1]));
  }
  switch (std::toupper(static_cast<unsigned char>(name[2]))) {
    case 'S':
      v.cost = CostKind::Squared;
      break;
    case 'Q':
      v.cost = CostKind::Quadric;
      break;
    case 'L':
      v.cost = CostKind::Laplacian;
      break;
    default:
      throw InvalidArgumentError(
          fmt::format("variant '{}': unknown cost '{}' (expected S, Q or L)", name, name[2]));
  }
  return v;
}

}  // namespace meshmark
