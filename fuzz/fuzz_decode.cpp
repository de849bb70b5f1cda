// libFuzzer target for what a user or a mesh feeds the payload layer: hexadecimal payloads and
// words handed to the ID decoder (bits, erasures and margins from the fuzzer's bytes). Either
// may reject its input with meshmark::Error; a crash, a sanitizer report, another exception,
// or a decoded ID that fails its own re-encoding is a bug. Built and run by scripts/fuzz.sh.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "meshmark/coding.h"
#include "meshmark/error.h"
#include "meshmark/key.h"
#include "meshmark/payload.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 2) return 0;
  try {
    if (data[0] % 2 == 0) {
      const std::string text(reinterpret_cast<const char*>(data) + 2, size - 2);
      const meshmark::Payload p = meshmark::payload_from_hex(text, 1 + data[1]);
      if (meshmark::payload_from_hex(meshmark::payload_to_hex(p), p.size()) != p) __builtin_trap();
    } else {
      static const meshmark::IdCode code64;
      meshmark::IdCodeOptions o;
      o.bits = 128;
      static const meshmark::IdCode code128(o);
      const meshmark::IdCode& code = data[1] % 2 ? code128 : code64;
      std::vector<std::uint8_t> bits(code.bits(), 0);
      std::vector<double> margins(code.bits(), 0.0);
      for (int j = 0; j < code.bits() && 2 + j < static_cast<int>(size); ++j) {
        bits[j] = data[2 + j] % 3;  // 0, 1 or an erasure
        margins[j] = bits[j] > 1 ? 0.0 : (data[2 + j] >> 2) / 128.0;
      }
      const meshmark::Key& key = meshmark::public_key();
      const meshmark::IdDecodeResult r = code.decode(bits, margins, key);
      if (r.valid) {
        // A reported ID's codeword lies within t + p of the hard decisions (erasures read 0),
        // and the count reported includes those differences.
        const meshmark::Payload c = code.encode(r.id, key);
        int distance = 0;
        for (int j = 0; j < code.bits(); ++j) distance += c.bits[j] != (bits[j] == 1);
        if (distance > code.correction() + code.chase_depth() || r.corrected < distance)
          __builtin_trap();
      }
    }
  } catch (const meshmark::Error&) {
  }
  return 0;
}
