#include "meshmark/mark/payload.h"

#include <fmt/format.h>

#include "meshmark/core/error.h"
#include "meshmark/core/random.h"

namespace meshmark {

Payload payload_from_hex(std::string_view hex, int nbits) {
  if (nbits < 1)
    throw InvalidArgumentError(fmt::format("the payload needs at least 1 bit, not {}", nbits));
  const std::string original(hex);
  if (hex.starts_with("0x") || hex.starts_with("0X")) hex.remove_prefix(2);
  if (hex.empty()) throw InvalidArgumentError("empty payload");
  // Little-endian bits of the number: value bit k is the k-th least significant.
  std::vector<std::uint8_t> value_bits;
  for (auto it = hex.rbegin(); it != hex.rend(); ++it) {
    const char c = *it;
    int d = -1;
    if (c >= '0' && c <= '9')
      d = c - '0';
    else if (c >= 'a' && c <= 'f')
      d = c - 'a' + 10;
    else if (c >= 'A' && c <= 'F')
      d = c - 'A' + 10;
    if (d < 0)
      throw InvalidArgumentError(
          fmt::format("payload '{}': '{}' is not a hexadecimal digit", original, c));
    for (int k = 0; k < 4; ++k) value_bits.push_back(static_cast<std::uint8_t>((d >> k) & 1));
  }
  for (std::size_t k = static_cast<std::size_t>(nbits); k < value_bits.size(); ++k)
    if (value_bits[k])
      throw InvalidArgumentError(
          fmt::format("payload '{}' does not fit in {} bits", original, nbits));
  value_bits.resize(static_cast<std::size_t>(nbits), 0);
  Payload p;
  p.bits.assign(value_bits.rbegin(), value_bits.rend());  // most significant first
  return p;
}

std::string payload_to_hex(const Payload& payload) {
  const int nb = payload.size();
  const int digits = (nb + 3) / 4;
  std::string out(static_cast<std::size_t>(digits), '0');
  // Value bit k (least significant first) is payload bit nb - 1 - k.
  for (int k = 0; k < nb; ++k) {
    if (!payload.bits[static_cast<std::size_t>(nb - 1 - k)]) continue;
    char& c = out[static_cast<std::size_t>(digits - 1 - k / 4)];
    const int d = (c <= '9' ? c - '0' : c - 'a' + 10) | (1 << (k % 4));
    c = static_cast<char>(d < 10 ? '0' + d : 'a' + d - 10);
  }
  return out;
}

Payload random_payload(int nbits, std::uint64_t seed) {
  Random rng(seed);
  Payload p;
  std::uint64_t word = 0;
  for (int j = 0; j < nbits; ++j) {
    if (j % 64 == 0) word = rng.next();
    p.bits.push_back(static_cast<std::uint8_t>((word >> (j % 64)) & 1));
  }
  return p;
}

double bit_error_rate(const std::vector<std::uint8_t>& decoded, const Payload& expected) {
  if (decoded.size() != expected.bits.size())
    throw InvalidArgumentError(fmt::format("cannot compare {} decoded bits with a {}-bit payload",
                                           decoded.size(), expected.bits.size()));
  if (decoded.empty()) return 0;
  std::size_t errors = 0;
  for (std::size_t j = 0; j < decoded.size(); ++j) errors += decoded[j] != expected.bits[j];
  return static_cast<double>(errors) / static_cast<double>(decoded.size());
}

}  // namespace meshmark
