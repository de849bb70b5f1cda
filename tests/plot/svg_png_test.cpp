// SVG to PNG through rsvg-convert run without a shell: a path with a quote and a space
// converts to a PNG of the SVG's size; a missing converter and a failing one are told apart.

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "meshmark/core/error.h"
#include "meshmark/io/io.h"
#include "plot/svg_plot.h"
#include "plot/svg_png.h"
#include "test_data.h"

namespace meshmark {
namespace {

namespace fs = std::filesystem;

bool have_rsvg_convert() {
  return std::system("command -v rsvg-convert >/dev/null 2>&1") == 0;
}

// The big-endian 32-bit value at offset in bytes.
std::uint32_t be32(const std::string& bytes, std::size_t offset) {
  std::uint32_t v = 0;
  for (std::size_t k = 0; k < 4; ++k) v = v << 8 | static_cast<unsigned char>(bytes[offset + k]);
  return v;
}

TEST(SvgPng, PathWithAQuoteAndASpaceConvertsToAPngOfTheSvgsSize) {
  if (!have_rsvg_convert())
    GTEST_SKIP() << "skipped: rsvg-convert is not installed (apt-get install librsvg2-bin)";
  const fs::path dir = fs::path(test::scratch_dir()) / "it's a dir";
  fs::create_directories(dir);
  const std::string svg = (dir / "fig 'one'.svg").string(), png = (dir / "fig 'one'.png").string();
  write_file_atomically(
      svg,
      detail::svg_document(123, 45, "<rect x='10' y='10' width='50' height='20' fill='red'/>"));
  ASSERT_EQ(detail::svg_to_png(svg, png), detail::PngConversion::Written);
  const std::string bytes = read_file(png);
  ASSERT_GE(bytes.size(), 24u);
  // PNG signature, then the IHDR chunk: length 13, type, width, height (PNG spec, 5.2, 11.2.2).
  EXPECT_EQ(bytes.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
  EXPECT_EQ(be32(bytes, 8), 13u);
  EXPECT_EQ(bytes.substr(12, 4), "IHDR");
  EXPECT_EQ(be32(bytes, 16), 123u);
  EXPECT_EQ(be32(bytes, 20), 45u);
  EXPECT_FALSE(fs::exists(png + ".tmp"));
}

TEST(SvgPng, MissingConverterIsToldApartFromAFailingOne) {
  const fs::path dir = test::scratch_dir();
  const std::string svg = (dir / "broken.svg").string(), png = (dir / "broken.png").string();
  write_file_atomically(svg, "this is not SVG");
  if (have_rsvg_convert()) {
    try {
      detail::svg_to_png(svg, png);
      ADD_FAILURE() << "a file that is not SVG converted";
    } catch (const IOError& e) {
      EXPECT_NE(std::string(e.what()).find("rsvg-convert failed (exit status"), std::string::npos)
          << e.what();
      EXPECT_NE(std::string(e.what()).find(svg), std::string::npos) << e.what();
    }
    EXPECT_FALSE(fs::exists(png));
    EXPECT_FALSE(fs::exists(png + ".tmp"));
  }
  // No rsvg-convert on an empty PATH.
  const std::string path = std::getenv("PATH") ? std::getenv("PATH") : "";
  ::setenv("PATH", dir.c_str(), 1);
  const detail::PngConversion missing = detail::svg_to_png(svg, png);
  ::setenv("PATH", path.c_str(), 1);
  EXPECT_EQ(missing, detail::PngConversion::ToolMissing);
  EXPECT_FALSE(fs::exists(png));
}

}  // namespace
}  // namespace meshmark
