#pragma once
// Internal: pieces shared by the SVG and HTML reports (campaign figures, evidence reports).

#include <string>
#include <string_view>
#include <vector>

namespace meshmark::detail {

/// text through printable() (control characters, bidirectional-text controls and invalid
/// UTF-8 written as \xNN), then with &, <, >, " and ' written as entities: safe in HTML and
/// SVG text and in attribute values quoted either way, and shown as it is.
std::string xml_escape(std::string_view text);

/// "Nice" tick values (1, 2, 2.5 or 5 times a power of ten apart, about five) covering
/// [lo, hi]; {lo} when the range is empty.
std::vector<double> nice_ticks(double lo, double hi);

}  // namespace meshmark::detail
