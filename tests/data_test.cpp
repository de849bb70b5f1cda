// The project's own meshes (data/meshes): each file listed in the manifest with its SHA-256,
// vertex and face counts, and each listed file there, as read by an independent hash.

#include <gtest/gtest.h>
#include <sodium.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>

#include "meshmark/io/io.h"
#include "test_data.h"

namespace meshmark {
namespace {

std::string file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string sha256_hex(const std::string& bytes) {
  unsigned char h[crypto_hash_sha256_BYTES];
  crypto_hash_sha256(h, reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size());
  char hex[2 * crypto_hash_sha256_BYTES + 1];
  sodium_bin2hex(hex, sizeof hex, h, sizeof h);
  return hex;
}

long count(const std::string& text) {  // "2,930" -> 2930
  std::string digits;
  for (char c : text)
    if (std::isdigit(static_cast<unsigned char>(c))) digits += c;
  return std::stol(digits);
}

TEST(Data, ManifestMatchesTheFiles) {
  ASSERT_EQ(sodium_init() < 0, false);
  const std::string dir = std::string(MESHMARK_TEST_DATA) + "/meshes";
  const std::string manifest = file_bytes(dir + "/MANIFEST.md");
  ASSERT_FALSE(manifest.empty()) << dir << "/MANIFEST.md";
  // The hash list: "    <64 hex>  <file>".
  std::map<std::string, std::string> listed;
  const std::regex hash_line(R"(^ {4}([0-9a-f]{64})  (\S+)$)");
  std::istringstream lines(manifest);
  for (std::string line; std::getline(lines, line);)
    if (std::smatch m; std::regex_match(line, m, hash_line)) listed[m[2]] = m[1];
  // Every file of the folder but the two texts is listed, and its bytes hash as listed.
  int meshes = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    if (name == "MANIFEST.md" || name == "LICENSES.md") continue;
    ++meshes;
    ASSERT_TRUE(listed.count(name)) << name << " is not in the manifest";
    EXPECT_EQ(sha256_hex(file_bytes(entry.path().string())), listed[name]) << name;
  }
  EXPECT_EQ(meshes, static_cast<int>(listed.size())) << "a listed file is missing";
  // The table's vertex and face counts, as read (featuretype welded exactly, as stated).
  const std::regex row(
      R"(^\| ([^ |,]+)(?:, \S+)? \| [^|]+ \| [^|]+ \| ([0-9,]+)[^|]* \| ([0-9,]+) \|)");
  int rows = 0;
  std::istringstream table(manifest);
  for (std::string line; std::getline(table, line);) {
    std::smatch m;
    if (!std::regex_search(line, m, row)) continue;
    ++rows;
    SCOPED_TRACE(m[1].str());
    const Mesh mesh = read_mesh(dir + "/" + m[1].str());
    EXPECT_EQ(mesh.V.rows(), count(m[2]));
    EXPECT_EQ(mesh.F.rows(), count(m[3]));
  }
  EXPECT_EQ(rows, 4);  // spot, spider, bunny, featuretype
}

}  // namespace
}  // namespace meshmark
