// Manifests of copies to issue (issue.h): INPUT OUTPUT PAYLOAD, or INPUT OUTPUT id:N BUYER.

#include <sstream>

#include "meshmark/coding.h"
#include "meshmark/error.h"
#include "meshmark/issue.h"

namespace meshmark {

std::vector<CopyRequest> read_manifest(const std::string& path) {
  const std::string bytes = read_file(path, std::size_t(64) << 20, "manifest");
  std::vector<CopyRequest> requests;
  std::istringstream in(bytes);
  std::string text;
  for (std::size_t line = 1; std::getline(in, text); ++line) {
    const auto hash = text.find('#');
    if (hash != std::string::npos) text.resize(hash);
    std::istringstream words(text);
    CopyRequest r;
    r.line = line;
    std::string payload;
    if (!(words >> r.input)) continue;  // blank or comment
    if (!(words >> r.output >> payload)) {
      r.refusal = "expected INPUT OUTPUT PAYLOAD or INPUT OUTPUT id:N BUYER";
    } else if (payload.rfind("id:", 0) == 0) {
      try {
        r.id = parse_id(payload.substr(3));
      } catch (const Error& e) {
        r.refusal = e.what();
      }
      std::string word;
      while (words >> word) r.buyer += (r.buyer.empty() ? "" : " ") + word;
    } else if (std::string extra; words >> extra) {
      r.refusal = "expected three fields: INPUT OUTPUT PAYLOAD";
    } else {
      r.payload_hex = payload;
    }
    requests.push_back(std::move(r));
  }
  return requests;
}

}  // namespace meshmark
