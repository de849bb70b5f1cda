#pragma once
// The benchmarks' meshes: read once from the shared directory, without file images.

#include <filesystem>
#include <map>
#include <string>

#include "meshmark/io.h"

namespace meshmark::bench {

/// The mesh at path, read once and cached; nullptr when the file is missing.
inline const Mesh* load(const std::string& path) {
  static std::map<std::string, Mesh> cache;
  auto it = cache.find(path);
  if (it != cache.end()) return &it->second;
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return nullptr;
  ReadOptions ro;
  ro.keep_image = false;
  return &cache.emplace(path, read_mesh(path, ro)).first->second;
}

/// Path of a mesh of the shared directory.
inline std::string shared(const char* name) {
  return std::string(MESHMARK_SHARED_DIR) + "/meshes/" + name;
}

}  // namespace meshmark::bench
