// libFuzzer target for what users feed meshmark besides meshes: the first byte picks the kind,
// the rest is the file. 0: a key file; 1: a batch manifest (text); 2: a batch manifest (CSV);
// 3: a registry file (SQLite), listed and verified; 4: a .gltf whose external buffer is
// "buffer.bin", the bytes after the first NUL. A reader may accept the input or throw
// meshmark::Error; anything else (a crash, a sanitizer report, another exception, a hang) is a
// bug. Built and run by scripts/fuzz.sh.

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <map>
#include <string>

#include "meshmark/core/error.h"
#include "meshmark/forensics/issue.h"
#include "meshmark/forensics/registry.h"
#include "meshmark/io/io.h"
#include "meshmark/protocol/key.h"

namespace {

// A scratch file of this process holding bytes, with the given extension.
std::string scratch(const std::string& bytes, const char* extension) {
  const std::string path = "/tmp/meshmark-fuzz-" + std::to_string(::getpid()) + extension;
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
  return path;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const int kind = data[0] % 5;
  const std::string bytes(reinterpret_cast<const char*>(data) + 1, size - 1);
  std::string path;
  try {
    switch (kind) {
      case 0:
        path = scratch(bytes, ".key");
        (void)meshmark::key_from_file(path);
        break;
      case 1:
      case 2: {
        path = scratch(bytes, kind == 1 ? ".txt" : ".csv");
        (void)meshmark::read_manifest(path);
        break;
      }
      case 3: {
        path = scratch(bytes, ".db");
        (void)meshmark::read_registry(path);
        const meshmark::RegistryCheck check =
            meshmark::verify_registry(path, meshmark::key_from_passphrase("fuzz"));
        if (check.authentic + check.edited.size() + check.unauthenticated.size() +
                check.other_key !=
            check.rows)
          __builtin_trap();
        break;
      }
      default: {
        const std::size_t nul = bytes.find('\0');
        const std::map<std::string, std::string> resources = {
            {"buffer.bin", nul == std::string::npos ? std::string() : bytes.substr(nul + 1)}};
        meshmark::ReadOptions options;
        options.resources = &resources;
        const meshmark::Mesh mesh = meshmark::read_mesh_from_bytes(
            bytes.substr(0, nul), meshmark::FileFormat::Gltf, "fuzz.gltf", options);
        for (Eigen::Index t = 0; t < mesh.F.rows(); ++t)
          for (int c = 0; c < 3; ++c)
            if (mesh.F(t, c) < 0 || mesh.F(t, c) >= mesh.V.rows()) __builtin_trap();
      }
    }
  } catch (const meshmark::Error&) {
  }
  if (!path.empty())
    for (const char* suffix : {"", "-wal", "-shm", "-journal"})
      std::remove((path + suffix).c_str());
  return 0;
}
