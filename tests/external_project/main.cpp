// An external program using the installed meshmark: reads a mesh, embeds a 64-bit payload with
// the public API, writes the marked mesh, reads the file back, and checks every bit; then issues
// a copy carrying buyer ID 4242 under the key in KEY_FILE (issue.h), which the installed
// command line must read back (tests/external_project.cmake). Exit code 0 only when all 64 bits
// read back right and the copy was issued, 1 otherwise (2 on a usage error).

#include <meshmark/core/error.h>
#include <meshmark/forensics/issue.h>
#include <meshmark/io/io.h>
#include <meshmark/mark/embed.h>
#include <meshmark/mark/payload.h>
#include <meshmark/protocol/watermark.h>
#include <meshmark/version.h>

#include <cstdio>
#include <exception>
#include <optional>
#include <string>

namespace {

/// The payload, chosen here (not by the library): 64 bits, both values in every nibble position.
constexpr const char* kPayloadHex = "c0ffee0123456789";
constexpr int kBits = 64;

/// Issues one copy of input carrying ID 4242 under the key file's key to output.
int issue(const std::string& input, const std::string& key_file, const std::string& output) {
  using namespace meshmark;
  IssueSettings settings;
  settings.key = key_from_file(key_file);
  CopyRequest request;
  request.input = input;
  request.output = output;
  request.id = 4242;
  const IssueResult result = issue_copies({request}, settings);
  const CopyOutcome& copy = result.copies.at(0);
  std::printf("issued %s: %s: %s\n", output.c_str(), copy_status_name(copy.status),
              copy.message.c_str());
  return copy.status == CopyStatus::Written ? 0 : 1;
}

int run(const std::string& input, const std::string& output) {
  using namespace meshmark;
  if (std::string(MESHMARK_VERSION_STRING) != CONSUMER_FOUND_VERSION) {
    std::fprintf(stderr, "version.h says %s, the package %s\n", MESHMARK_VERSION_STRING,
                 CONSUMER_FOUND_VERSION);
    return 1;
  }
  if (MESHMARK_WITH_IPOPT != CONSUMER_FOUND_IPOPT) {
    std::fprintf(stderr, "version.h says Ipopt %d, the package's component %d\n",
                 MESHMARK_WITH_IPOPT, CONSUMER_FOUND_IPOPT);
    return 1;
  }
  const Payload payload = payload_from_hex(kPayloadHex, kBits);
  const BitLayout layout = mark_layout(std::nullopt, kBits, /*coded=*/false);

  Mesh mesh = read_mesh(input);
  const EmbedResult marked = embed(mesh.V, mesh.F, layout.to_bins(payload));
  if (marked.status != EmbedStatus::Embedded) {
    std::fprintf(stderr, "embed: %s: %s\n", embed_status_name(marked.status),
                 marked.message.c_str());
    return 1;
  }
  mesh.V = marked.V;
  write_mesh(output, mesh);

  const Mesh reread = read_mesh(output);
  ExtractOptions options;
  options.bits = kBits;
  const MarkReading reading = read_mark(reread.V, reread.F, options, layout);
  int wrong = 0;
  for (int j = 0; j < kBits; ++j)
    if (reading.bits[static_cast<std::size_t>(j)] != payload.bits[static_cast<std::size_t>(j)])
      ++wrong;
  std::printf("meshmark %s: %s: %d of %d bits read back wrong (rms displacement %.4f %%)\n",
              MESHMARK_VERSION_STRING, input.c_str(), wrong, kBits, marked.rms_percent);
  return wrong == 0 ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 5) {
    std::fprintf(stderr, "usage: %s MESH OUT KEY_FILE ISSUED_OUT\n", argv[0]);
    return 2;
  }
  try {
    const int marked = run(argv[1], argv[2]);
    return marked != 0 ? marked : issue(argv[1], argv[3], argv[4]);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
}
