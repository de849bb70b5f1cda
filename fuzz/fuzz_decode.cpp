// libFuzzer target for what a user or a mesh feeds the payload layer: hexadecimal payloads and
// words handed to the ID decoder (bits, erasures and margins from the fuzzer's bytes), and words
// crafted between the codewords of two nearby IDs. Either
// may reject its input with meshmark::Error; a crash, a sanitizer report, another exception,
// or a decoded ID that fails its own re-encoding is a bug. Built and run by scripts/fuzz.sh.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "meshmark/core/error.h"
#include "meshmark/mark/payload.h"
#include "meshmark/protocol/coding.h"
#include "meshmark/protocol/key.h"

namespace {

int distance(const std::vector<std::uint8_t>& word, const std::vector<std::uint8_t>& c) {
  int d = 0;
  for (std::size_t j = 0; j < c.size(); ++j) d += word[j] > 1 || word[j] != c[j];
  return d;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 2) return 0;
  try {
    static const meshmark::IdCode code64;
    static const meshmark::IdCode code128 = [] {
      meshmark::IdCodeOptions o;
      o.bits = 128;
      return meshmark::IdCode(o);
    }();
    const meshmark::Key& key = meshmark::public_key();
    if (data[0] % 3 == 0) {
      const std::string text(reinterpret_cast<const char*>(data) + 2, size - 2);
      const meshmark::Payload p = meshmark::payload_from_hex(text, 1 + data[1]);
      if (meshmark::payload_from_hex(meshmark::payload_to_hex(p), p.size()) != p) __builtin_trap();
    } else if (data[0] % 3 == 1) {
      // An arbitrary word: any ID reported lies within t of it (erasures counted), and the
      // count reported is that distance.
      const meshmark::IdCode& code = data[1] % 2 ? code128 : code64;
      std::vector<std::uint8_t> bits(code.bits(), 0);
      std::vector<double> margins(code.bits(), 0.0);
      for (int j = 0; j < code.bits() && 2 + j < static_cast<int>(size); ++j) {
        bits[j] = data[2 + j] % 3;  // 0, 1 or an erasure
        margins[j] = bits[j] > 1 ? 0.0 : (data[2 + j] >> 2) / 128.0;
      }
      const meshmark::IdDecodeResult r = code.decode(bits, margins, key);
      if (r.valid) {
        const int d = distance(bits, code.encode(r.id, key).bits);
        if (d > code.correction() || r.corrected != d) __builtin_trap();
      }
    } else if (size >= 8) {
      // A word crafted between two codewords (IDs id1 and id1 + delta, consecutive-like):
      // bits of c1 moved to c2's values and other bits flipped as the input says, margins
      // from the input. Whatever is decoded must be strictly nearer than any other codeword
      // tried, and within t.
      const std::uint32_t id1 =
          data[1] | data[2] << 8 | data[3] << 16 | std::uint32_t(data[4]) << 24;
      const std::uint32_t id2 = id1 + 1 + data[5] % 64;
      const std::vector<std::uint8_t> c1 = code64.encode(id1, key).bits;
      const std::vector<std::uint8_t> c2 = code64.encode(id2, key).bits;
      std::vector<std::uint8_t> word = c1;
      std::vector<double> margins(64, 0.1);
      int pos = 0;
      for (std::size_t i = 6; i < size; ++i) {
        const int j = data[i] % 64;
        if (data[i] & 0x40) word[j] = c2[j];         // towards c2
        if ((data[i] & 0xC0) == 0xC0) word[j] ^= 1;  // away from both
        margins[(j + pos++) % 64] = (data[i] >> 1 & 31) / 256.0;
      }
      const meshmark::IdDecodeResult r = code64.decode(word, margins, key);
      if (r.valid) {
        const int d1 = distance(word, c1), d2 = distance(word, c2);
        const int d = r.id == id1   ? d1
                      : r.id == id2 ? d2
                                    : distance(word, code64.encode(r.id, key).bits);
        if (d > code64.correction()) __builtin_trap();
        if (r.id == id1 && d1 >= d2) __builtin_trap();
        if (r.id == id2 && d2 >= d1) __builtin_trap();
      }
    }
  } catch (const meshmark::Error&) {
  }
  return 0;
}
