#include "core/component.h"

#include <algorithm>
#include <array>
#include <mutex>
#include <string>

#include "meshmark/core/components.h"

namespace meshmark {

namespace {

// Every component, in components.h's order, with the CMake target that brings it.
constexpr std::array<std::string_view, 5> kComponents = {"draco", "3mf", "postgres", "ipopt",
                                                         "cgal"};

struct Linked {
  std::mutex mutex;
  std::vector<std::string> names;
};

Linked& linked() {
  static Linked l;
  return l;
}

}  // namespace

std::vector<std::string> linked_components() {
  std::vector<std::string> out;
  {
    std::lock_guard lock(linked().mutex);
    for (std::string_view c : kComponents)
      if (std::find(linked().names.begin(), linked().names.end(), c) != linked().names.end())
        out.emplace_back(c);
  }
  return out;
}

bool has_component(std::string_view name) {
  std::lock_guard lock(linked().mutex);
  return std::find(linked().names.begin(), linked().names.end(), name) != linked().names.end();
}

namespace detail {

void note_component(std::string_view name) {
  std::lock_guard lock(linked().mutex);
  linked().names.emplace_back(name);
}

void missing_component(std::string_view name, std::string_view what) {
  throw MissingComponentError(
      std::string(name),
      std::string(what) + " needs meshmark's optional component '" + std::string(name) +
          "', which this program was built without (link the CMake target meshmark::" +
          std::string(name) + "; meshmark/core/components.h)");
}

}  // namespace detail

}  // namespace meshmark
