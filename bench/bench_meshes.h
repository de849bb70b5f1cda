#pragma once
// The benchmarks' meshes (the project's data/meshes and libcgal-demo's), read once, without
// file images.

#include <filesystem>
#include <map>
#include <string>

#include "meshmark/io/io.h"

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

/// Path of a mesh of the project's data/meshes.
inline std::string data(const char* name) {
  return std::string(MESHMARK_BENCH_DATA) + "/meshes/" + name;
}

/// Path of a mesh of libcgal-demo's data/meshes (unpacked into the build tree).
inline std::string cgal(const char* name) {
  return std::string(MESHMARK_CGAL_DATA) + "/" + name;
}

}  // namespace meshmark::bench
