#pragma once
/// \file evidence_report.h
/// A self-contained HTML evidence report of a trace (trace.h): one file with no script, no
/// network and no external resource, readable in any browser and printable. It shows
///  - the registered leak over the original, as inline SVG: three orthographic views along the
///    original's principal axes (the axes of its vertices' covariance, by decreasing spread),
///    flat Lambert shading, painter's algorithm (the original grey, the leak a translucent
///    orange drawn over it where the surfaces coincide), each with a numbered scale bar in
///    model units; and a map of the leak alone, each triangle coloured by its distance to the
///    original's surface (closest_point.h), with a numbered colour bar in % of the diagonal;
///    each mesh drawn through a vertex-clustering simplification of at most max_triangles
///    triangles, so the file stays small whatever the meshes' size;
///  - the score distribution of every candidate (-log10 of the corrected p-value) with the
///    threshold and the named buyers;
///  - the soft evidence of each payload bit (TraceResult::bits), bits numbered;
///  - the verdict in one plain sentence (what the p-value means for an innocent buyer), and the
///    named copy as the registry recorded it (buyer, ID, issue date, the copy's content hash);
///  - tables: the outcome, the named buyers and the runner-up, registration, measurement,
///    settings, file paths and content hashes, the case and the analyst, and the command that
///    reproduces the report;
///  - the report's own hash: BLAKE2b-256 of the file with those 64 hex digits written as zeros
///    (report_hash_placeholder), so that anyone can check that the file is the one written.
/// Every string from the input (buyer labels, paths, messages, the command) is escaped.
/// The report is a function of its inputs alone (no date, no timing): running the same
/// command on the same files gives the same bytes.

#include <string>
#include <utility>
#include <vector>

#include "meshmark/core/mesh.h"
#include "meshmark/forensics/trace.h"

namespace meshmark {

/// A file the trace read: its path as given and its content hash (registry.h, content_hash).
struct EvidenceFile {
  std::string path;
  std::string hash;  ///< "" when there is none (a PostgreSQL registry)
};

/// What the report states besides the meshes and the result.
struct EvidenceContext {
  double threshold = 1e-6;  ///< the corrected p-value below which buyers are named
  EvidenceFile leaked, original, registry;
  std::string key_fingerprint;  ///< key_fingerprint of the key (never the key, nor its file's hash)
  std::string command;          ///< a shell command that reproduces the report
  std::string command_note;     ///< what the reader must supply to run it, or ""
  std::string version;          ///< meshmark's version
  /// Further settings, (name, value) in display order (erase distance, registration...).
  std::vector<std::pair<std::string, std::string>> settings;
  std::string case_id;  ///< the case this report belongs to (free text), or ""
  std::string analyst;  ///< who ran the trace (free text), or ""
  /// For a report shared outside the shop: buyer labels shown as "the buyer of ID N", file
  /// paths as their file names, the command without its folder (hashes stay).
  bool redact = false;
};

/// The 64 zeros that stand for the report's own hash while it is computed: the report's hash
/// is content_hash of the file with its hash replaced by these.
inline constexpr const char* report_hash_placeholder =
    "0000000000000000000000000000000000000000000000000000000000000000";

/// The sentence that states a trace's verdict, for a reader who is not a statistician: who is
/// named, and how often an innocent buyer's copy would match as well (the corrected p-value).
std::string verdict_sentence(const TraceResult& result, double threshold, bool redact = false);

/// Options of the report's drawing.
struct EvidenceReportOptions {
  int max_triangles = 6000;  ///< per mesh as drawn (in every view); at least 100
  int view_size = 380;       ///< width and height of each of the four views (CSS pixels)
};

/// The report as one HTML document. leaked as read (the registration in result is applied to
/// it), original as read; result from trace(leaked, original, ...).
/// \pre options.max_triangles >= 100, options.view_size >= 100.
std::string evidence_report_html(const Mesh& leaked, const Mesh& original,
                                 const TraceResult& result, const EvidenceContext& context,
                                 const EvidenceReportOptions& options = {});

/// Writes evidence_report_html to path atomically (io.h, write_file_atomically).
/// \throw IOError when it cannot be written; the destination is then untouched.
void write_evidence_report(const std::string& path, const Mesh& leaked, const Mesh& original,
                           const TraceResult& result, const EvidenceContext& context,
                           const EvidenceReportOptions& options = {});

/// The mesh with its vertices clustered on a uniform grid (each cell's vertices replaced by
/// their mean, degenerate and repeated triangles dropped: Rossignac and Borrel, 1993), the
/// grid as fine as keeps at most max_triangles triangles; the mesh itself when it has no more.
/// What the report draws. \pre max_triangles >= 1.
Mesh cluster_for_display(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F, int max_triangles);

}  // namespace meshmark
