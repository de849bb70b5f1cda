// Every input the fuzzer ever crashed on reads cleanly now: a mesh or a typed error. The
// hand-made hostile inputs (named refuse-*) must be refused with an error naming the input.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>

#include "meshmark/core/error.h"
#include "meshmark/io/io.h"

using namespace meshmark;

TEST(FuzzRegressions, EveryKeptInputReadsOrFailsCleanly) {
  const std::filesystem::path dir =
      std::filesystem::path(MESHMARK_SOURCE_DIR) / "fuzz" / "regressions";
  int checked = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    if (entry.path().extension() == ".md") continue;
    std::ifstream in(entry.path(), std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (bytes.empty()) continue;
    // The first byte picks the format as fuzz/fuzz_read.cpp does.
    const FileFormat formats[] = {FileFormat::Off,   FileFormat::Obj,    FileFormat::Ply,
                                  FileFormat::Stl,   FileFormat::Gltf,   FileFormat::Glb,
                                  FileFormat::Draco, FileFormat::ThreeMf};
    SCOPED_TRACE(entry.path().string());
    const bool must_refuse = entry.path().filename().string().rfind("refuse-", 0) == 0;
    try {
      const Mesh m = read_mesh_from_bytes(
          bytes.substr(1), formats[static_cast<unsigned char>(bytes[0]) % 8], "regression");
      EXPECT_FALSE(must_refuse) << "a hostile input was read as a mesh of " << m.V.rows()
                                << " vertices";
      EXPECT_TRUE(m.F.rows() == 0 || m.F.maxCoeff() < m.V.rows());
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("regression"), std::string::npos)
          << "the error does not name the input: " << e.what();
    }
    ++checked;
  }
  // The hand-made hostile inputs alone are 10 files: fewer means the folder was not found.
  EXPECT_GE(checked, 10);
}
