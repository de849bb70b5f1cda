#pragma once
/// \file key.h
/// Secret keys and the keyed layout of payload bits over histogram bins.
///
/// A key is 32 bytes: the BLAKE2b hash (libsodium's crypto_generichash) of a key file's bytes,
/// or the Argon2id hash (crypto_pwhash, memory-hard: about 0.18 s and 64 MiB per guess) of a
/// passphrase, so that a passphrase cannot be found by trying a dictionary against the key's
/// published fingerprint at the speed of a plain hash. Passphrase copies issued before schema 4
/// of the registry used one BLAKE2b (key_from_passphrase_v1); each issued copy records how its
/// key was derived (Key::derivation). From a key and the payload length nb, a
/// ChaCha20 keystream draws a permutation of the bits over the bins (bit j is carried by bin
/// bin_of[j] + 1) and a whitening mask (bit j is written XOR whitening[j]). Without the key
/// the bins read as a permuted, whitened word: noise. The canonical layout (identity, no
/// whitening, docs/method.md section 1) stays available and is the default.

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "meshmark/mark/payload.h"

namespace meshmark {

/// The version of the mark format: the keyed layout of the bits over the bins and the coding
/// of IDs (coding.h). Every key meshmark derives from a user's key includes it, so marks of
/// different formats read as noise to each other and can never be confused. Version 1 (up to
/// meshmark 0.3) coded IDs systematically; version 2 maps them through a keyed permutation.
inline constexpr int kMarkFormatVersion = 2;

/// A 256-bit secret key.
struct Key {
  std::array<std::uint8_t, 32> bytes{};
  /// How the key was made from what the user gave, recorded with each copy issued under it
  /// (docs/format.md section 2.2): kKeyFileDerivation, kPassphraseDerivation,
  /// kPassphraseDerivationV1, or "" for a key given as its bytes. Not part of the key: two
  /// keys with the same bytes are equal.
  std::string derivation;
  bool operator==(const Key& other) const { return bytes == other.bytes; }
};

/// Key::derivation of key_from_file and generate_key_file.
inline constexpr std::string_view kKeyFileDerivation = "key-file/blake2b";
/// Key::derivation of key_from_passphrase: Argon2id (version 1.3), 3 passes over 64 MiB, the
/// 16-byte salt in hexadecimal.
inline constexpr std::string_view kPassphraseDerivation =
    "passphrase/argon2id13/t=3/m=64MiB/salt=c9221906c490540cb058155a6f19d6ed";
/// Key::derivation of key_from_passphrase_v1.
inline constexpr std::string_view kPassphraseDerivationV1 = "passphrase/blake2b";

/// The key of a passphrase: Argon2id (libsodium's crypto_pwhash, algorithm ARGON2ID13) of its
/// bytes, 3 passes over 64 MiB of memory, with the salt of kPassphraseDerivation (the first 16
/// bytes of BLAKE2b-256 under the domain "meshmark/passphrase/v2/salt"): about 0.18 s of one
/// core per call, and per guess for whoever tries passphrases against a key's fingerprint.
/// The salt is fixed, so that a passphrase gives its key on any machine with nothing stored:
/// it keeps generic precomputed tables out, not a table made for meshmark; a key file made by
/// generate_key_file (256 random bits) cannot be guessed at all.
/// \throw InvalidArgumentError for an empty passphrase; Error when the 64 MiB cannot be had.
Key key_from_passphrase(std::string_view passphrase);

/// The key a passphrase gave before registry schema 4: BLAKE2b-256 under the domain
/// "meshmark/passphrase/v1", fast to compute and so fast to guess. For reading and tracing the
/// copies issued then (their rows record kPassphraseDerivationV1 or nothing), for the public
/// key, and for keys that are not secret (a campaign's trial keys); never for new copies.
/// \throw InvalidArgumentError for an empty passphrase.
Key key_from_passphrase_v1(std::string_view passphrase);

/// The key of a key file's bytes (BLAKE2b-256 under the domain "meshmark/key-file/v1").
/// \throw IOError when the file cannot be read, is not a regular file (a directory, a FIFO, a
///        device) or holds more than 1 MiB; InvalidInputError when it is empty.
Key key_from_file(const std::string& path);

/// A warning when the key file at path can be read by users other than its owner (its mode
/// grants the group or others read access: anyone who reads it can forge any buyer's mark);
/// "" when it cannot, or cannot be examined.
std::string key_file_exposure(const std::string& path);

/// Makes a new secret key file at path: 32 random bytes (libsodium's randombytes_buf), created
/// with mode 0600 (readable by its owner only) and never over an existing file, written and
/// flushed to disk before this returns. Returns the file's key (key_from_file(path)).
/// \throw IOError when path exists (a file, a link, anything) or cannot be created or written;
///        a partly written file is removed.
Key generate_key_file(const std::string& path);

/// The public key meshmark uses to whiten coded IDs when no secret key is given (so that an
/// unmarked mesh's structured bits do not look like a codeword). Not a secret.
const Key& public_key();

/// A key for one purpose derived from key: BLAKE2b-256 keyed with key, of
/// "meshmark/mark-v<kMarkFormatVersion>/" + purpose. Knowing a derived key reveals nothing of
/// key or of the keys derived for other purposes.
Key derive_key(const Key& key, std::string_view purpose);

/// Which bin carries which bit, and the whitening of each bit.
struct BitLayout {
  std::vector<int> bin_of;              ///< bit j is carried by payload bin bin_of[j] (0-based)
  std::vector<std::uint8_t> whitening;  ///< bit j is written as bit XOR whitening[j]
  int size() const { return static_cast<int>(bin_of.size()); }

  /// The canonical unkeyed layout of nb bits: bin_of[j] = j, no whitening.
  static BitLayout canonical(int nb);
  /// The keyed layout of nb bits: a permutation and a mask drawn from the keystream of
  /// derive_key(key, "layout"), nb as the stream's nonce (so each length has its own layout).
  static BitLayout keyed(const Key& key, int nb);

  /// The word to embed (bin order, whitened) of a payload in payload order.
  /// payload.size() must equal size().
  BinWord to_bins(const Payload& payload) const;
  /// Bits read in bin order (0, 1 or an erasure > 1) back in payload order, unwhitened
  /// (erasures stay erasures).
  std::vector<std::uint8_t> from_bins(const std::vector<std::uint8_t>& bin_bits) const;
  /// Any per-bin values (margins, counts) in payload order.
  std::vector<double> values_from_bins(const std::vector<double>& bin_values) const;
};

/// BLAKE2b of data keyed with key, truncated to nbits bits (MSB-first of the digest), as bits.
/// The integrity check of coded IDs. 1 <= nbits <= 512.
std::vector<std::uint8_t> keyed_hash_bits(const Key& key, std::string_view domain,
                                          const std::vector<std::uint8_t>& data, int nbits);

/// keyed_hash_bits for one key, domain and length, prepared once for many messages: the key's
/// block is compressed once, and a message that fits in one block with the domain (every round
/// of the ID code's permutation) costs one compression of BLAKE2b, no key setup and no
/// allocation (trace scores a million candidates with it); longer messages go through
/// libsodium. Its digests are keyed_hash_bits' bytes: bit i of keyed_hash_bits is bit
/// 7 - i % 8 of byte i / 8.
class KeyedHash {
 public:
  /// \throw InvalidArgumentError when nbits is outside 1..512.
  KeyedHash(const Key& key, std::string_view domain, int nbits);
  /// The digest of data (size bytes) into out: bytes() bytes.
  void digest(const std::uint8_t* data, std::size_t size, std::uint8_t* out) const;
  /// The digests of four messages of one length (size bytes each) into out[0..3]: digest()'s
  /// bytes for each, the four compressed together on vector lanes (AVX2 where the processor
  /// has it) when they fit in one block.
  void digest4(const std::array<const std::uint8_t*, 4>& data, std::size_t size,
               const std::array<std::uint8_t*, 4>& out) const;
  /// The digest's length in bytes: nbits rounded up to whole bytes.
  int bytes() const { return bytes_; }

 private:
  static constexpr std::size_t kBlock = 128;            // BLAKE2b's block, in bytes
  alignas(64) std::array<unsigned char, 384> state_{};  // crypto_generichash_state
  int bytes_ = 0, out_len_ = 0;
  std::array<std::uint64_t, 8> chain_{};             // BLAKE2b's state after the key's block
  std::array<std::uint8_t, kBlock> prefix_block_{};  // domain || 0, then zeros
  std::size_t prefix_ = 0;                           // domain.size() + 1
};

}  // namespace meshmark
