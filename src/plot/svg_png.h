#pragma once
// Internal: SVG figures written to files, and converted to PNG by rsvg-convert (librsvg2-bin)
// when it is installed.

#include <string>

namespace meshmark::detail {

/// Whether svg_to_png converted, or found no converter.
enum class PngConversion {
  Written,      ///< the PNG is written
  ToolMissing,  ///< rsvg-convert is not installed (not on PATH): nothing written
};

/// Converts the SVG file svg_path to a PNG at png_path (its pixel size the SVG's) by running
/// rsvg-convert directly (posix_spawnp with an argument vector: no shell, so any path works),
/// through png_path + ".tmp" renamed at the end: a failed conversion leaves no partial PNG.
/// \throw IOError naming the file, rsvg-convert's exit status and its first error line when
/// it fails.
PngConversion svg_to_png(const std::string& svg_path, const std::string& png_path);

/// Writes dir/name.svg, and dir/name.png when rsvg-convert is installed; returns whether the
/// PNG was written. \throw IOError when a file cannot be written or rsvg-convert fails.
bool write_figure(const std::string& dir, const std::string& name, const std::string& svg);

}  // namespace meshmark::detail
