// Manifests of copies to issue (issue.h): whitespace-separated lines (INPUT OUTPUT PAYLOAD, or
// INPUT OUTPUT id:N BUYER, N an ID or auto) or CSV with a header row (input, output, id or payload,
// buyer).

#include <fmt/format.h>

#include <algorithm>
#include <map>
#include <sstream>

#include "meshmark/core/error.h"
#include "meshmark/forensics/issue.h"
#include "meshmark/io/io.h"
#include "meshmark/protocol/coding.h"

namespace meshmark {

namespace {

std::vector<CopyRequest> read_whitespace_manifest(const std::string& bytes) {
  std::vector<CopyRequest> requests;
  std::istringstream in(bytes);
  std::string text;
  for (std::size_t line = 1; std::getline(in, text); ++line) {
    const auto hash = text.find('#');
    const std::string comment = hash == std::string::npos ? "" : text.substr(hash);
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
        set_copy_id(r, payload.substr(3));
      } catch (const Error& e) {
        r.refusal = e.what();
      }
      std::string word;
      while (words >> word) r.buyer += (r.buyer.empty() ? "" : " ") + word;
      // A '#' after the buyer's label would cut it silently: a buyer named "Jane (order #12)"
      // must never be recorded as "Jane (order".
      if (!comment.empty() && !r.buyer.empty() && r.refusal.empty())
        r.refusal = fmt::format(
            "'#' starts a comment in this manifest, and would cut the buyer's label to '{}': "
            "use a CSV manifest (.csv, quoted fields) for a label that holds '#'",
            printable(r.buyer));
    } else if (std::string extra; words >> extra) {
      r.refusal = "expected three fields: INPUT OUTPUT PAYLOAD";
    } else {
      r.payload_hex = payload;
    }
    requests.push_back(std::move(r));
  }
  return requests;
}

// One CSV record (RFC 4180: fields separated by commas, quoted fields may hold commas, quotes
// doubled, line breaks); at is advanced past it and line past its line breaks.
std::vector<std::string> csv_record(const std::string& path, const std::string& bytes,
                                    std::size_t& at, std::size_t& line) {
  std::vector<std::string> fields(1);
  const std::size_t first_line = line;
  bool quoted = false, was_quoted = false;
  while (at < bytes.size()) {
    const char c = bytes[at++];
    if (quoted) {
      if (c == '"' && at < bytes.size() && bytes[at] == '"') {
        fields.back() += '"', ++at;
      } else if (c == '"') {
        quoted = false;
      } else {
        if (c == '\n') ++line;
        fields.back() += c;
      }
    } else if (c == '"') {
      if (!fields.back().empty() || was_quoted)
        throw InvalidInputError(path, line, "a quote inside an unquoted CSV field");
      quoted = was_quoted = true;
    } else if (c == ',') {
      fields.emplace_back(), was_quoted = false;
    } else if (c == '\n' || c == '\r') {
      if (c == '\r' && at < bytes.size() && bytes[at] == '\n') ++at;
      ++line;
      return fields;
    } else {
      if (was_quoted)
        throw InvalidInputError(path, line, "characters after a quoted CSV field's closing quote");
      fields.back() += c;
    }
  }
  if (quoted) throw InvalidInputError(path, first_line, "a quoted CSV field is not closed");
  ++line;
  return fields;
}

std::vector<CopyRequest> read_csv_manifest(const std::string& path, const std::string& bytes) {
  std::size_t at = bytes.rfind("\xEF\xBB\xBF", 0) == 0 ? 3 : 0, line = 1;  // a UTF-8 BOM
  const std::vector<std::string> header = csv_record(path, bytes, at, line);
  std::map<std::string, std::size_t> column;
  for (std::size_t k = 0; k < header.size(); ++k) {
    std::string name = header[k];
    std::transform(name.begin(), name.end(), name.begin(), ::tolower);
    if (name != "input" && name != "output" && name != "id" && name != "payload" && name != "buyer")
      throw InvalidInputError(path, 1,
                              fmt::format("unknown column '{}' (the columns are input, "
                                          "output, id or payload, buyer)",
                                          printable(header[k])));
    if (!column.emplace(name, k).second)
      throw InvalidInputError(path, 1, fmt::format("column '{}' given twice", name));
  }
  for (const char* needed : {"input", "output"})
    if (!column.count(needed))
      throw InvalidInputError(path, 1, fmt::format("no '{}' column in the header row", needed));
  if (!column.count("id") && !column.count("payload"))
    throw InvalidInputError(path, 1, "no 'id' or 'payload' column in the header row");
  std::vector<CopyRequest> requests;
  while (at < bytes.size()) {
    const std::size_t first = line;
    const std::vector<std::string> fields = csv_record(path, bytes, at, line);
    if (fields.size() == 1 && fields[0].empty()) continue;  // a blank line
    CopyRequest r;
    r.line = first;
    auto field = [&](const char* name) {
      const auto it = column.find(name);
      return it == column.end() || it->second >= fields.size() ? std::string() : fields[it->second];
    };
    r.input = field("input");
    r.output = field("output");
    r.buyer = field("buyer");
    const std::string id = field("id"), payload = field("payload");
    if (fields.size() != header.size()) {
      r.refusal = fmt::format("{} fields where the header has {}", fields.size(), header.size());
    } else if (r.input.empty() || r.output.empty()) {
      r.refusal = "an empty input or output";
    } else if (id.empty() == payload.empty()) {
      r.refusal = "expected an id or a payload (one of them, not both)";
    } else if (!id.empty()) {
      try {
        set_copy_id(r, id);
      } catch (const Error& e) {
        r.refusal = e.what();
      }
    } else {
      r.payload_hex = payload;
    }
    requests.push_back(std::move(r));
  }
  return requests;
}

}  // namespace

void set_copy_id(CopyRequest& request, const std::string& text) {
  if (text == "auto")
    request.auto_id = true, request.id.reset();
  else
    request.id = parse_id(text), request.auto_id = false;
}

std::vector<CopyRequest> read_manifest(const std::string& path) {
  const std::string bytes = read_file(path, std::size_t(64) << 20, "manifest");
  std::string ext = path.size() >= 4 ? path.substr(path.size() - 4) : "";
  std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
  return ext == ".csv" ? read_csv_manifest(path, bytes) : read_whitespace_manifest(bytes);
}

}  // namespace meshmark
