// Tracing from files (trace_files.h): what the command line's trace and the Python module's
// trace share.

#include "meshmark/forensics/trace_files.h"

#include <fmt/format.h>

#include <filesystem>

#include "meshmark/core/error.h"
#include "meshmark/forensics/evidence_report.h"
#include "meshmark/forensics/registry.h"
#include "meshmark/forensics/report_pdf.h"
#include "meshmark/version.h"

namespace meshmark {

namespace {

std::string hash_of(const std::string& path) {
  try {
    return content_hash(read_file(path));
  } catch (const IOError&) {
    return {};  // a PostgreSQL URI, or a file that went away: the report says no hash
  }
}

Mesh read_noting(const std::string& path, const ReadOptions& read,
                 std::vector<std::string>& warnings) {
  Mesh mesh = read_mesh(path, read);
  for (const std::string& note : mesh.notes) warnings.push_back(fmt::format("{}: {}", path, note));
  return mesh;
}

}  // namespace

TraceFilesResult trace_files(const TraceFilesRequest& request, const Key& key) {
  if (!request.pdf.empty() && request.report.empty())
    throw InvalidArgumentError("a PDF is printed from the HTML report: give the report's path too");
  for (const std::string& output : {request.report, request.pdf})
    for (const std::string& input :
         {request.leaked, request.original, request.registry, request.key_file}) {
      std::error_code ec;
      if (!output.empty() && !input.empty() && std::filesystem::equivalent(output, input, ec))
        throw InvalidArgumentError(
            fmt::format("{}: refusing to overwrite an input file with the report", output));
    }
  TraceFilesResult found;
  // trace writes no mesh: the files' images (their bytes and where each coordinate sits, about
  // 150 bytes a vertex for each file) are not kept.
  ReadOptions read = request.read;
  read.keep_image = false;
  if (request.leaked_mesh) {
    validate_mesh(request.leaked_mesh->V, request.leaked_mesh->F, "the leak");
    found.leaked = *request.leaked_mesh;
  } else {
    found.leaked = read_noting(request.leaked, read, found.warnings);
  }
  if (request.original_mesh) {
    validate_mesh(request.original_mesh->V, request.original_mesh->F, "the original");
    found.original = *request.original_mesh;
    found.original_hash = geometry_hash(found.original.V, found.original.F);
  } else {
    found.original = read_noting(request.original, read, found.warnings);
    found.original_hash = content_hash(read_file(request.original));
  }
  TraceOptions options = request.options;
  if (!request.leaked_mesh) options.leaked_hash = hash_of(request.leaked);
  found.trace = trace_issued(found.leaked, found.original, found.original_hash, request.registry,
                             key, options);
  if (!request.leaked_mesh) compare_with_issued_files(found.trace, options.leaked_hash);
  if (!request.report.empty()) write_trace_report(request, found, key);
  if (!request.pdf.empty()) print_pdf(request.report, request.pdf);
  return found;
}

void write_trace_report(const TraceFilesRequest& request, const TraceFilesResult& found,
                        const Key& key) {
  if (request.report.empty()) throw InvalidArgumentError("no path for the evidence report");
  EvidenceContext c;
  c.threshold = request.options.threshold;
  c.leaked = {request.leaked, request.leaked_mesh ? std::string() : hash_of(request.leaked)};
  c.original = {request.original, request.original_mesh ? std::string() : found.original_hash};
  c.registry = {registry_display_name(request.registry), hash_of(request.registry)};
  c.key_fingerprint = key_fingerprint(key);
  c.command = request.command;
  c.command_note = request.command_note;
  c.case_id = request.case_id;
  c.analyst = request.analyst;
  c.redact = request.redact;
  c.version = "meshmark " MESHMARK_VERSION_STRING;
  c.settings = {
      {"erase distance", fmt::format("{:g} of the diagonal", request.options.erase_distance)},
      {"registration", request.options.register_leak ? "similarity (ICP)" : "none (--no-register)"},
      {"weld tolerance", fmt::format("{:g}", request.read.weld_tolerance)}};
  write_evidence_report(request.report, found.leaked, found.original, found.trace, c);
}

}  // namespace meshmark
