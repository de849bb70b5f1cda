// A program linking meshmark's core alone (meshmark::core): issues a copy of MESH carrying a
// buyer ID into an SQLite registry, writes it as glTF, traces it back to that buyer, and checks
// that what the optional components add fails with MissingComponentError naming each
// (components.h). Exit code 0 when all of that holds, 1 otherwise (2 on a usage error).

#include <meshmark/attacks/attack.h>
#include <meshmark/core/components.h>
#include <meshmark/core/error.h>
#include <meshmark/forensics/issue.h>
#include <meshmark/forensics/registry.h>
#include <meshmark/forensics/trace_files.h>
#include <meshmark/io/io.h>
#include <meshmark/mark/embed.h>
#include <meshmark/mark/payload.h>
#include <meshmark/protocol/key.h>

#include <cstdio>
#include <exception>
#include <functional>
#include <string>

namespace {

int failures = 0;

void check(bool ok, const std::string& what) {
  std::printf("%s: %s\n", ok ? "ok" : "FAILED", what.c_str());
  if (!ok) ++failures;
}

// `call` must throw MissingComponentError naming `component`.
void needs(const std::string& component, const std::string& what,
           const std::function<void()>& call) {
  try {
    call();
    check(false, what + " worked without the " + component + " component");
  } catch (const meshmark::MissingComponentError& e) {
    check(e.component() == component && std::string(e.what()).find(component) != std::string::npos,
          what + " -> " + e.what());
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: %s MESH WORK_DIR\n", argv[0]);
    return 2;
  }
  using namespace meshmark;
  const std::string mesh_path = argv[1], dir = argv[2];
  try {
    check(linked_components().empty(), "no component is linked");
    const Key key = key_from_passphrase("a core-only consumer's passphrase");
    IssueSettings settings;
    settings.key = key;
    settings.registry = dir + "/registry.sqlite";
    CopyRequest request;
    request.input = mesh_path;
    request.output = dir + "/copy.glb";
    request.id = 777;
    request.buyer = "buyer 777";
    const IssueResult issued = issue_copies({request}, settings);
    check(issued.copies.at(0).status == CopyStatus::Written,
          "issued ID 777 as glTF: " + issued.copies.at(0).message);

    TraceFilesRequest trace;
    trace.leaked = request.output;
    trace.original = mesh_path;
    trace.registry = settings.registry;
    const TraceFilesResult traced = trace_files(trace, key);
    check(traced.trace.status == TraceStatus::Named && traced.trace.named.size() == 1 &&
              traced.trace.named.at(0).copy.id == 777,
          "trace named ID 777 alone");

    const Mesh mesh = read_mesh(mesh_path);
    needs("draco", "writing a .drc", [&] { write_mesh(dir + "/copy.drc", mesh); });
    needs("3mf", "writing a .3mf", [&] { write_mesh(dir + "/copy.3mf", mesh); });
    needs("cgal", "the simplify attack", [&] { attack_simplify(mesh, 0.5); });
    needs("postgres", "a PostgreSQL registry",
          [&] { Registry r("postgresql://nobody@127.0.0.1:1/none"); });
    EmbedOptions ipopt;
    ipopt.backend = SolverBackend::Ipopt;
    needs("ipopt", "the Ipopt solver",
          [&] { embed(mesh.V, mesh.F, payload_from_hex("a5", 8), ipopt); });
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return failures == 0 ? 0 : 1;
}
