#pragma once
// Internal: how an optional component's library gives the core its entry points.
//
// The core calls a component through a table of function pointers (DracoCodec, ...) held in a
// slot the core owns. The component's library fills the slot from a static initializer in the
// same object file as its marker function meshmark_component_NAME(); the CMake target
// meshmark::NAME links with --undefined=meshmark_component_NAME, so that the linker takes that
// object out of a static archive (and keeps a shared library) even though nothing calls it.
// Without the component the slot stays empty and require_component throws
// MissingComponentError.

#include <string_view>

#include "meshmark/core/error.h"

namespace meshmark::detail {

/// Records that the component `name` is linked (linked_components()).
void note_component(std::string_view name);

/// Throws MissingComponentError: `what` ("reading a Draco file") needs component `name`.
[[noreturn]] void missing_component(std::string_view name, std::string_view what);

/// The component's table, or MissingComponentError naming `what` when it is not linked.
template <class Table>
const Table& require_component(const Table* table, std::string_view name, std::string_view what) {
  if (!table) missing_component(name, what);
  return *table;
}

/// Fills a core slot with a component's table at static initialization: in the component's
/// source, `MESHMARK_COMPONENT(draco, draco_codec_slot(), kCodec)`.
#define MESHMARK_COMPONENT(name, slot, table)                             \
  extern "C" void meshmark_component_##name() {}                          \
  namespace {                                                             \
  [[maybe_unused]] const bool meshmark_component_registered_##name = [] { \
    (slot) = &(table);                                                    \
    ::meshmark::detail::note_component(#name);                            \
    return true;                                                          \
  }();                                                                    \
  }

}  // namespace meshmark::detail
