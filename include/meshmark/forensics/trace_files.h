#pragma once
/// \file trace_files.h
/// Tracing a leak from files, as `meshmark trace` does: the leaked mesh and the original read
/// from their paths, the original identified by its file's content hash, the copies the
/// registry recorded of it under the key scored (trace.h, trace_issued), and the evidence
/// report (evidence_report.h) written with the files' hashes, the key's fingerprint and the
/// settings. The command line, the Python module and a C++ program share these two calls:
///
///     const TraceFilesRequest request{.leaked = "leak.glb", .original = "bunny.obj",
///                                     .registry = "shop.db", .report = "report.html"};
///     std::cout << trace_files(request, key).trace.message << "\n";  // and report.html

#include <memory>
#include <string>
#include <vector>

#include "meshmark/forensics/trace.h"
#include "meshmark/io/io.h"
#include "meshmark/protocol/key.h"

namespace meshmark {

/// The files of one trace.
struct TraceFilesRequest {
  std::string leaked;    ///< path of the leaked mesh (any format read_mesh reads)
  std::string original;  ///< path of the original the copies were issued from
  /// The leak in memory, or none: then it is not read from `leaked`, which only names it in
  /// the report, and its bytes are not compared with the recorded copies' hashes.
  std::shared_ptr<const Mesh> leaked_mesh;
  /// The original in memory, or none: then it is not read from `original`, which only names
  /// it, and its copies are found by its geometry_hash (registry.h) alone.
  std::shared_ptr<const Mesh> original_mesh;
  std::string registry;      ///< the registry: an SQLite file or a postgresql:// URI
  std::string report;        ///< where to write the HTML evidence report; "" for none
  std::string pdf;           ///< where to print the report as PDF (report_pdf.h); "" for none
  std::string key_file;      ///< the key's file, when the key came from one (never overwritten)
  ReadOptions read;          ///< how both meshes are read (weld tolerance)
  TraceOptions options;      ///< threshold, registration, erase distance
  std::string command;       ///< for the report: a shell command that reproduces it
  std::string command_note;  ///< for the report: what its reader must supply to run it
  std::string case_id;       ///< for the report: the case it belongs to, or ""
  std::string analyst;       ///< for the report: who ran the trace, or ""
  bool redact = false;       ///< the report without buyer labels and folders (EvidenceContext)
};

/// What trace_files read and concluded.
struct TraceFilesResult {
  TraceResult trace;  ///< the verdict, the scores and the registration
  Mesh leaked;        ///< the leak as read, without its file image (trace writes no mesh)
  Mesh original;      ///< the original as read, without its file image
  /// content_hash of the original's file; its geometry_hash for an original in memory
  std::string original_hash;
  std::vector<std::string> warnings;  ///< what the readers noticed, "path: note" each
};

/// Reads both meshes, traces the leak against the registry's copies of the original under key,
/// and writes the evidence report when request.report is set (write_trace_report), and its PDF
/// when request.pdf is (print_pdf). Refuses, before reading anything, a report or PDF path
/// that is the leak, the original, the registry or the key file, and a PDF without a report.
/// \throw InvalidArgumentError for such a path; InvalidInputError or ReadError when a
///        mesh cannot be read; IOError when the registry does not exist or cannot be read;
///        WriteError when the report cannot be written or the PDF printed (the HTML report is
///        written by then).
TraceFilesResult trace_files(const TraceFilesRequest& request, const Key& key);

/// Writes the evidence report of found (trace_files(request, key)'s) to request.report,
/// atomically: the files with their hashes (the registry's as it is now), the key's
/// fingerprint, the threshold and settings, the command, meshmark's version.
/// \throw InvalidArgumentError when request.report is empty; WriteError when it cannot be
///        written.
void write_trace_report(const TraceFilesRequest& request, const TraceFilesResult& found,
                        const Key& key);

}  // namespace meshmark
