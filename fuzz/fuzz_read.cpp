// libFuzzer target for every mesh reader: the first byte picks the format, the rest is the
// file. A reader may accept the input or throw meshmark::Error; anything else (a crash, a
// sanitizer report, another exception, a hang) is a bug. Built and run by scripts/fuzz.sh.

#include <cstddef>
#include <cstdint>
#include <string>

#include "meshmark/core/error.h"
#include "meshmark/io/io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  using meshmark::FileFormat;
  const FileFormat formats[] = {FileFormat::Off,   FileFormat::Obj,    FileFormat::Ply,
                                FileFormat::Stl,   FileFormat::Gltf,   FileFormat::Glb,
                                FileFormat::Draco, FileFormat::ThreeMf};
  const FileFormat format = formats[data[0] % 8];
  std::string bytes(reinterpret_cast<const char*>(data) + 1, size - 1);
  try {
    const meshmark::Mesh mesh = meshmark::read_mesh_from_bytes(std::move(bytes), format, "fuzz");
    // What a caller does next must hold too: triangles index existing vertices, and writing
    // back through the file image works.
    for (Eigen::Index t = 0; t < mesh.F.rows(); ++t)
      for (int c = 0; c < 3; ++c)
        if (mesh.F(t, c) < 0 || mesh.F(t, c) >= mesh.V.rows()) __builtin_trap();
    // A .gltf naming external buffers reads them beside "fuzz" (none exist: refused by name).
    const std::string written = meshmark::write_mesh_to_bytes(mesh, format);
    // Nothing moved: OFF, OBJ, PLY and STL write the file back byte for byte through its image
    // (a binary PLY's plain records encoded again from the mesh, not kept).
    const bool faithful = format == FileFormat::Off || format == FileFormat::Obj ||
                          format == FileFormat::Ply || format == FileFormat::Stl;
    if (faithful && written.size() != size - 1) __builtin_trap();
    if (faithful &&
        written.compare(0, written.size(), reinterpret_cast<const char*>(data) + 1, size - 1) != 0)
      __builtin_trap();
  } catch (const meshmark::Error&) {
  }
  return 0;
}
