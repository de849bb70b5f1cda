// Issuing copies (issue.h: the CLI's embed and embed --batch) and tracing a leak through the
// registry (trace.h's trace_issued: the CLI's trace), with the same rules as the command line.

#include <fmt/format.h>

#include <cmath>
#include <map>
#include <memory>

#include "bindings.h"
#include "meshmark/core/error.h"
#include "meshmark/forensics/issue.h"
#include "meshmark/forensics/trace.h"
#include "meshmark/forensics/trace_files.h"
#include "meshmark/protocol/coding.h"

namespace meshmark::python {

namespace {

// Whether a value names a file (str, bytes, os.PathLike) rather than holding a mesh.
bool is_path(py::handle value) {
  return py::isinstance<py::str>(value) || py::isinstance<py::bytes>(value) ||
         py::hasattr(value, "__fspath__");
}

// A mesh given in memory (a meshmark.Mesh or a (V, F) pair), converted once per Python object.
using MeshCache = std::map<PyObject*, std::shared_ptr<const Mesh>>;
std::shared_ptr<const Mesh> mesh_in_memory(py::handle value, const char* what, MeshCache& seen) {
  auto it = seen.find(value.ptr());
  if (it == seen.end())
    it = seen.emplace(value.ptr(), std::make_shared<const Mesh>(to_mesh(value, what))).first;
  return it->second;
}

// The name a mesh in memory goes by in messages, the registry and the report: the file it was
// read from, if any.
std::string memory_name(const Mesh& mesh) {
  return mesh.source_path.empty() ? std::string("(in memory)") : mesh.source_path;
}

// One request from a dict with keys input (a path, or a mesh in memory: a meshmark.Mesh or a
// (V, F) pair), output, and id (int, or "auto": the registry picks it) or payload (hex str), and
// optionally buyer.
CopyRequest to_request(py::handle item, std::size_t k, MeshCache& seen) {
  if (!py::isinstance<py::dict>(item))
    throw InvalidArgumentError(fmt::format("copies[{}] is not a dict", k));
  const py::dict d = py::reinterpret_borrow<py::dict>(item);
  for (const auto& [name, value] : d) {
    const std::string key = py::str(name);
    if (key != "input" && key != "output" && key != "id" && key != "payload" && key != "buyer")
      throw InvalidArgumentError(fmt::format(
          "copies[{}] has key '{}' (known: input, output, id, payload, buyer)", k, key));
  }
  if (!d.contains("input") || !d.contains("output"))
    throw InvalidArgumentError(fmt::format("copies[{}] needs 'input' and 'output'", k));
  if (d.contains("id") == d.contains("payload"))
    throw InvalidArgumentError(fmt::format("copies[{}] needs one of 'id' or 'payload'", k));
  CopyRequest r;
  const py::object input = d["input"];
  if (is_path(input)) {
    r.input = to_path(input);
  } else {
    r.mesh = mesh_in_memory(input, fmt::format("copies[{}]['input']", k).c_str(), seen);
    r.input = memory_name(*r.mesh);
  }
  r.output = to_path(d["output"]);
  if (d.contains("id") && py::isinstance<py::str>(d["id"]) &&
      py::str(d["id"]).cast<std::string>() == "auto")
    r.auto_id = true;  // the registry picks it
  else if (d.contains("id"))
    r.id = to_id(d["id"], "id");
  if (d.contains("payload")) r.payload_hex = py::str(d["payload"]);
  if (d.contains("buyer")) r.buyer = py::str(d["buyer"]);
  return r;
}

py::dict to_dict(const CopyRequest& r, const CopyOutcome& c) {
  py::dict out;
  out["id"] = r.auto_id ? (c.record.id ? py::cast(c.record.id) : py::none())
                        : (r.id ? py::cast(*r.id) : py::none());
  out["status"] = copy_status_name(c.status);
  out["ok"] = c.ok();
  out["message"] = c.message;
  out["warnings"] = c.warnings;
  out["fingerprint_alone"] = c.fingerprint_alone;
  out["strength"] = c.fingerprint_alone ? 0.0 : c.embedding.strength;
  out["bin_offset"] = c.fingerprint_alone ? 0.0 : c.embedding.bin_offset;
  out["rms_percent"] = c.result.rms_percent;
  out["min_margin"] = c.result.min_margin;
  out["rounds"] = c.result.rounds;
  out["msdm"] = c.calibration ? py::cast(c.calibration->msdm) : py::none();
  return out;
}

py::dict score_dict(const CandidateScore& s) {
  py::dict d;
  d["buyer"] = s.copy.buyer;
  d["id"] = s.copy.id;
  d["matches"] = s.matches;
  d["bits"] = s.compared;
  d["p_value"] = s.p_value;
  d["corrected_p"] = s.corrected_p;
  d["copy"] = s.copy.output_path;
  d["row"] = s.copy.row;
  d["row_auth"] = enum_name(s.auth);
  // For a copy issued with the fingerprint: its score (standard normal for an innocent) and
  // p-value; None otherwise.
  d["fingerprint_z"] = std::isfinite(s.fingerprint_z) ? py::cast(s.fingerprint_z) : py::none();
  d["fingerprint_p"] = std::isfinite(s.fingerprint_z) ? py::cast(s.fingerprint_p) : py::none();
  return d;
}

// The settings issue() and Issuer take, from their keywords; further keywords set the
// embedding's fields, as embed() takes them (variant="VRS", ...).
IssueSettings issue_settings(const std::string& registry, py::handle key, py::handle key_file,
                             int bits, int id_bits, double strength_spread, py::handle options,
                             bool public_key, py::handle fingerprint, const py::kwargs& kwargs) {
  IssueSettings s;
  s.allow_public_key = public_key;
  if (!fingerprint.is_none()) s.fingerprint = fingerprint.cast<bool>();
  s.registry = registry;
  s.key = resolve_key(key, key_file);
  s.bits = bits;
  if (!key_file.is_none()) s.kept_files.emplace_back("the key file", to_path(key_file));
  s.id_bits = id_bits;
  s.strength_spread = strength_spread;
  if (!options.is_none()) s.embedding = options.cast<EmbedOptions>();
  apply_keywords(py::cast(&s.embedding, py::return_value_policy::reference), kwargs);
  return s;
}

}  // namespace

void init_issue(py::module_& m) {
  py::class_<Issuer>(
      m, "Issuer",
      "A long-running issuer (docs/serving.md): it holds the registry open and up to "
      "`originals` prepared originals, so that a copy of a prepared original costs its "
      "embedding and writing alone. The same rules as issue().")
      .def(py::init([](const std::string& registry, py::handle key, py::handle key_file, int bits,
                       int id_bits, double strength_spread, py::handle options, bool public_key,
                       py::handle fingerprint, std::size_t originals, const py::kwargs& kwargs) {
             IssueSettings s =
                 issue_settings(registry, key, key_file, bits, id_bits, strength_spread, options,
                                public_key, fingerprint, kwargs);
             s.threads = 1;  // one copy per call; calls from several threads run side by side
             return std::make_unique<Issuer>(std::move(s), originals);
           }),
           py::kw_only(), py::arg("registry") = "", py::arg("key") = py::none(),
           py::arg("key_file") = py::none(), py::arg("bits") = 64, py::arg("id_bits") = 32,
           py::arg("strength_spread") = 0.25, py::arg("options") = py::none(),
           py::arg("public_key") = false, py::arg("fingerprint") = py::none(),
           py::arg("originals") = 16)
      .def(
          "prepare",
          [](Issuer& self, py::handle original) {
            std::string name;
            Mesh mesh;
            if (is_path(original)) {
              name = to_path(original);
              mesh = read_mesh(name, self.settings().read);
            } else {
              mesh = to_mesh(original, "original");
              name = memory_name(mesh);
            }
            PreparedOriginal p;
            {
              py::gil_scoped_release unlocked;
              p = self.prepare(std::move(mesh), name);
            }
            py::dict d;
            d["original"] = p.geometry;
            d["name"] = p.name;
            d["vertices"] = p.vertices;
            d["faces"] = p.faces;
            d["prepared_before"] = p.prepared_before;
            return d;
          },
          py::arg("original"),
          "Prepares an original (a path, a meshmark.Mesh or a (V, F) pair) once. Returns a dict: "
          "original (its geometry hash, which issue() takes), name, vertices, faces, "
          "prepared_before.")
      .def(
          "issue",
          [](Issuer& self, const std::string& original, py::handle output, const std::string& buyer,
             py::handle id) {
            const std::optional<PreparedOriginal> p = self.find(original);
            if (!p)
              throw InvalidArgumentError(fmt::format(
                  "original {} is not prepared (prepare() it first; the least recently used "
                  "are dropped beyond the issuer's bound)",
                  original));
            CopyRequest r;
            r.input = p->name;
            r.mesh = p->mesh;
            r.output = to_path(output);
            r.buyer = buyer;
            if (py::isinstance<py::str>(id) && id.cast<std::string>() == "auto")
              r.auto_id = true;
            else
              r.id = to_id(id, "id");
            IssueResult result;
            {
              py::gil_scoped_release unlocked;
              result = self.issue({r});
            }
            py::dict d = to_dict(r, result.copies.at(0));
            d["row"] = result.copies.at(0).record.row;
            return d;
          },
          py::arg("original"), py::arg("output"), py::kw_only(), py::arg("buyer") = "",
          py::arg("id") = "auto",
          "Issues one copy of a prepared original (its geometry hash) to output, for buyer, "
          "with id ('auto': the registry picks it). Returns issue()'s dict for it, and row.");

  m.def(
      "issue",
      [](const py::iterable& copies, const std::string& registry, py::handle key,
         py::handle key_file, int bits, int id_bits, double strength_spread, py::handle options,
         int threads, bool resume, bool public_key, py::handle fingerprint, py::handle progress,
         const py::kwargs& kwargs) {
        std::vector<CopyRequest> requests;
        std::size_t k = 0;
        MeshCache seen;
        for (py::handle item : copies) requests.push_back(to_request(item, k++, seen));
        IssueSettings s = issue_settings(registry, key, key_file, bits, id_bits, strength_spread,
                                         options, public_key, fingerprint, kwargs);
        s.threads = threads;
        s.resume = resume;
        const IssueResult r = with_progress(
            progress,
            [&](const ProgressCallback& report) {
              s.progress = report;
              return issue_copies(requests, s);
            },
            /*stops=*/false);
        py::list out;
        for (std::size_t c = 0; c < r.copies.size(); ++c)
          out.append(to_dict(requests[c], r.copies[c]));
        return out;
      },
      py::arg("copies"), py::kw_only(), py::arg("registry") = "", py::arg("key") = py::none(),
      py::arg("key_file") = py::none(), py::arg("bits") = 64, py::arg("id_bits") = 32,
      py::arg("strength_spread") = 0.25, py::arg("options") = py::none(), py::arg("threads") = 0,
      py::arg("resume") = true, py::arg("public_key") = false, py::arg("fingerprint") = py::none(),
      py::arg("progress") = py::none(),
      "Issues watermarked copies as the CLI's embed --batch does: copies is a list of dicts "
      "{input (a path, or a meshmark.Mesh or (V, F) pair in memory: the registry then "
      "knows the original by its geometry), output, id (a coded buyer ID, or 'auto': the "
      "registry picks the next ID of its "
      "spaced set, docs/issuing.md) or payload (hex), buyer}; with a registry, IDs "
      "issued before, given twice or with codewords too close are refused and the copies "
      "reserved in one transaction before any is written, and the rows of those written "
      "completed in another; coded IDs without a key are refused unless "
      "public_key=True (anyone can read, remove or forge them). fingerprint: None (the "
      "default) gives copies recorded in a registry the buyer's fingerprint, a second mark "
      "which trace reads with the original (mark format 5), where their original has enough "
      "vertices for one; True gives it to every coded copy (refused for an original too "
      "small); False to none. options: an "
      "EmbedOptions "
      "(strength, variant, method); further keywords set its fields, as embed() takes them "
      "(variant='VRS', strength=0.05, ...). Returns one dict per copy: id, status, ok, "
      "message, warnings, strength, bin_offset, "
      "rms_percent, min_margin, rounds, msdm (with fidelity limits). progress(phase, done, total, "
      "what) is called as originals are prepared and copies made; an exception it raises (or "
      "Ctrl-C) is raised here once the issue is done: it does not stop the issue halfway "
      "(every copy is written and recorded as without it), and progress is not called again.");
  m.def(
      "trace",
      [](py::handle leaked, py::handle original, const std::string& registry, py::handle key,
         py::handle key_file, double threshold, bool register_leak, py::handle report,
         py::handle pdf, const std::string& case_id, const std::string& analyst, bool redact,
         py::handle progress) {
        // A passphrase stands for the key its copies in the registry were issued under (the
        // earlier derivation for copies issued before schema 4), as the CLI's trace.
        std::optional<Key> k;
        std::string key_note;
        if (py::isinstance<py::str>(key) && key_file.is_none()) {
          PassphraseKey found = passphrase_key_in(registry, key.cast<std::string>());
          k = std::move(found.key), key_note = std::move(found.note);
        } else {
          k = resolve_key(key, key_file);
        }
        if (!k) throw InvalidArgumentError("trace needs the key the copies were issued under");
        TraceFilesRequest request;
        MeshCache seen;
        if (is_path(leaked)) {
          request.leaked = to_path(leaked);
        } else {
          request.leaked_mesh = mesh_in_memory(leaked, "leaked", seen);
          request.leaked = memory_name(*request.leaked_mesh);
        }
        if (is_path(original)) {
          request.original = to_path(original);
        } else {
          request.original_mesh = mesh_in_memory(original, "original", seen);
          request.original = memory_name(*request.original_mesh);
        }
        request.registry = registry;
        if (!report.is_none()) request.report = to_path(report);
        if (!pdf.is_none()) request.pdf = to_path(pdf);
        if (!key_file.is_none()) request.key_file = to_path(key_file);
        request.options.threshold = threshold;
        request.options.register_leak = register_leak;
        request.case_id = case_id;
        request.analyst = analyst;
        request.redact = redact;
        const TraceFilesResult found =
            with_progress(progress, [&](const ProgressCallback& on_step) {
              request.options.progress = on_step;
              return trace_files(request, *k);
            });
        const TraceResult& r = found.trace;
        py::dict out;
        out["status"] = trace_status_name(r.status);
        out["message"] = r.message;
        out["candidates"] = r.candidates;
        py::list named, ranking;
        for (const CandidateScore& s : r.named) named.append(score_dict(s));
        for (const CandidateScore& s : r.ranking) ranking.append(score_dict(s));
        out["named"] = named;
        out["ranking"] = ranking;
        out["registration"] = r.registration.message;
        py::list warnings;
        if (!key_note.empty()) warnings.append(key_note);
        for (const std::string& w : found.warnings) warnings.append(w);
        for (const std::string& w : r.warnings) warnings.append(w);
        out["warnings"] = warnings;
        out["identical_row"] = r.identical_row;
        out["report"] = request.report.empty() ? py::object(py::none()) : py::str(request.report);
        out["pdf"] = request.pdf.empty() ? py::object(py::none()) : py::str(request.pdf);
        return out;
      },
      py::arg("leaked"), py::arg("original"), py::arg("registry"), py::kw_only(),
      py::arg("key") = py::none(), py::arg("key_file") = py::none(), py::arg("threshold") = 1e-6,
      py::arg("register") = true, py::arg("report") = py::none(), py::arg("pdf") = py::none(),
      py::arg("case") = "", py::arg("analyst") = "", py::arg("redact") = false,
      py::arg("progress") = py::none(),
      "Names the buyers whose copies the leaked mesh came from, as the CLI's trace does: "
      "leaked and original are paths, or meshes in memory (a meshmark.Mesh or a (V, F) pair; "
      "an original in memory finds its copies by geometry, whatever file they were issued "
      "from); the copies the registry recorded of the original under the key, each scored with "
      "an exact p-value, family-wise below threshold; with report (a path), writes the HTML "
      "evidence report there (with case and analyst; redact: no buyer labels, no folders), and "
      "with pdf (a path) the same as PDF, printed by headless Chromium. "
      "Returns a dict: status, message, candidates, named and ranking (dicts: buyer, id, "
      "matches, bits, p_value, corrected_p, copy, row, row_auth: authentic, edited (never "
      "named), unauthenticated), registration, warnings (rows that fail their MAC or carry "
      "none, a leak whose bytes are another row's copy), identical_row (the row whose "
      "recorded file the leak's bytes are, 0 if none), report, pdf. progress(phase, done, total, "
      "what) is called as the trace goes (registration, then the candidates); an exception it "
      "raises (or Ctrl-C) stops the trace, which then writes no report, and is raised here.");
}

}  // namespace meshmark::python
