#pragma once
/// \file enum_names.h
/// One table of names per enum: the single place where an enum's values get the names that
/// files, reports, command lines and Python use. A header that declares a named enum E
/// specializes EnumTable<E> right below it:
///
///     template <> struct EnumTable<Method> {
///       static constexpr const char* what = "method";  // for messages
///       static constexpr NamedValue<Method> values[] = {{Method::Qp, "qp"}, ...};
///     };
///
/// The values are listed in declaration order, 0, 1, 2, ... (checked at compile time when a
/// name is asked): an enumerator inserted without a name fails to compile. One appended last
/// without a name compiles and is named "?": tests/core/enum_names_test.cpp counts each enum's
/// enumerators (update it with the enum) and checks the names round-trip.

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace meshmark {

/// A value of an enum and its name.
template <class E>
struct NamedValue {
  E value;
  const char* name;
};

/// An enum's names; specialized next to each named enum (see the file comment).
template <class E>
struct EnumTable;

namespace detail {
/// True when a and b are equal ignoring ASCII case.
bool same_name(std::string_view a, std::string_view b);
/// Throws InvalidArgumentError: "unknown <what> '<name>' (one of: a, b, c)".
[[noreturn]] void throw_unknown_name(std::string_view what, std::string_view name,
                                     const std::vector<std::string_view>& names);

template <class E>
constexpr bool dense_in_order() {
  std::size_t i = 0;
  for (const NamedValue<E>& v : EnumTable<E>::values)
    if (static_cast<std::size_t>(v.value) != i++) return false;
  return true;
}
}  // namespace detail

/// The names of E's values, in declaration order.
template <class E>
std::vector<std::string_view> enum_names() {
  static_assert(detail::dense_in_order<E>(), "EnumTable lists the values 0, 1, 2, ... in order");
  std::vector<std::string_view> out;
  for (const NamedValue<E>& v : EnumTable<E>::values) out.emplace_back(v.name);
  return out;
}

/// The name of value ("?" for a value outside the enum's enumerators).
template <class E>
constexpr const char* enum_name(E value) {
  static_assert(detail::dense_in_order<E>(), "EnumTable lists the values 0, 1, 2, ... in order");
  const auto i = static_cast<std::size_t>(value);
  return i < std::size(EnumTable<E>::values) ? EnumTable<E>::values[i].name : "?";
}

/// The value called `name` (any ASCII case).
/// \throw InvalidArgumentError naming what E is, the name, and the names there are.
template <class E>
E parse_enum(std::string_view name) {
  for (const NamedValue<E>& v : EnumTable<E>::values)
    if (detail::same_name(name, v.name)) return v.value;
  detail::throw_unknown_name(EnumTable<E>::what, name, enum_names<E>());
}

}  // namespace meshmark
