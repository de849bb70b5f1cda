#pragma once
/// \file payload.h
/// Payloads as bit vectors, their hexadecimal form, and bit error rates.
///
/// Convention (docs/method.md section 1): bit j lives in histogram bin j + 1.
/// The hexadecimal form is a number of nb bits written most significant digit first; bit j is
/// its j-th most significant bit. So the hex string read left to right lists the bits in bin
/// order (bin 1 first): with 8 bits, "80" sets bit 0 (bin 1) and "01" sets bit 7 (bin 8).

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace meshmark {

/// A vector of nb bits, bits[j] in {0, 1}, in one of two orders:
/// - payload order: the bits as the caller gives them (the hex form, an ID's codeword);
/// - bin order: bits[j] is carried by histogram bin j + 1, what embed() writes and extract()
///   reads (spelled BinWord in signatures).
/// Without a key the two coincide; under a key, BitLayout (key.h) maps payload order to bin
/// order (to_bins: a keyed permutation and whitening) and back (from_bins).
struct Payload {
  std::vector<std::uint8_t> bits;
  int size() const { return static_cast<int>(bits.size()); }
  bool operator==(const Payload&) const = default;
};

/// A Payload in bin order (bit j in bin j + 1): the name says which order a signature takes.
using BinWord = Payload;

/// Parses a hexadecimal payload (optional 0x prefix, any case) into nbits bits.
/// \throw InvalidArgumentError when the text is not hexadecimal, nbits < 1, or the value does
///        not fit in nbits bits.
Payload payload_from_hex(std::string_view hex, int nbits);

/// The payload as ceil(nb / 4) hexadecimal digits (lower case), the inverse of
/// payload_from_hex.
std::string payload_to_hex(const Payload& payload);

/// A uniformly random payload of nbits bits from a seed (SplitMix64; same seed, same bits).
Payload random_payload(int nbits, std::uint64_t seed);

/// Fraction of positions where a decoded bit differs from the expected one. decoded may hold
/// erasures (value > 1), counted as errors. Sizes must match.
double bit_error_rate(const std::vector<std::uint8_t>& decoded, const Payload& expected);

}  // namespace meshmark
