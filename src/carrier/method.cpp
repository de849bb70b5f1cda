#include "meshmark/carrier/method.h"

#include <algorithm>
#include <cctype>
#include <string>

#include <fmt/format.h>

#include "meshmark/core/error.h"

namespace meshmark {

const char* method_name(Method method) {
  return enum_name(method);
}

Method parse_method(std::string_view name) {
  return parse_enum<Method>(name);
}

std::string MarkScheme::name() const {
  if (method == Method::Qp) return variant.name();
  std::string out = method_name(method);
  if (variant.center != CenterKind::Discrete) out += "/" + variant.name();
  return out;
}

MarkScheme parse_scheme(std::string_view name) {
  MarkScheme s;
  const std::size_t slash = name.find('/');
  const std::string_view head = name.substr(0, slash);
  if (head.size() == 3 && slash == std::string_view::npos) {
    s.variant = parse_variant(head);
    return s;
  }
  s.method = parse_method(head);
  if (s.method == Method::Qp && slash == std::string_view::npos) return s;
  if (slash != std::string_view::npos) s.variant = parse_variant(name.substr(slash + 1));
  if (s.method != Method::Qp &&
      (s.variant.direction != DirectionKind::Radial || s.variant.cost != CostKind::Squared))
    throw InvalidArgumentError(fmt::format(
        "scheme '{}': Cho's methods move vertices radially with no cost: their variant is DRS, "
        "SRS or VRS",
        name));
  return s;
}

}  // namespace meshmark
