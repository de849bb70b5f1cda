#include "meshmark/protocol/key.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <sodium.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>

#include "core/lanes.h"
#include "meshmark/core/error.h"
#include "meshmark/io/io.h"

namespace meshmark {

namespace {

// BLAKE2b's compression function (RFC 7693, section 3.2) on one block m of 16 little-endian words,
// t bytes hashed so far (< 2^64 here), final or not. libsodium's generichash computes the same
// function; KeyedHash calls it directly so that the key's block is compressed once, not with
// every message (KeyedHashIsKeyedBlake2bOfDomainZeroAndData checks digests against libsodium).
constexpr std::array<std::uint64_t, 8> kBlake2bIv = {
    0x6a09e667f3bcc908ULL, 0xbb67ae8584caa73bULL, 0x3c6ef372fe94f82bULL, 0xa54ff53a5f1d36f1ULL,
    0x510e527fade682d1ULL, 0x9b05688c2b3e6c1fULL, 0x1f83d9abfb41bd6bULL, 0x5be0cd19137e2179ULL};
constexpr std::uint8_t kBlake2bSigma[12][16] = {
    {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15},
    {14, 10, 4, 8, 9, 15, 13, 6, 1, 12, 0, 2, 11, 7, 5, 3},
    {11, 8, 12, 0, 5, 2, 15, 13, 10, 14, 3, 6, 7, 1, 9, 4},
    {7, 9, 3, 1, 13, 12, 11, 14, 2, 6, 5, 10, 4, 0, 15, 8},
    {9, 0, 5, 7, 2, 4, 10, 15, 14, 1, 11, 12, 6, 8, 3, 13},
    {2, 12, 6, 10, 0, 11, 8, 3, 4, 13, 7, 5, 15, 14, 1, 9},
    {12, 5, 1, 15, 14, 13, 4, 10, 0, 7, 6, 3, 9, 2, 8, 11},
    {13, 11, 7, 14, 12, 1, 3, 9, 5, 0, 15, 4, 8, 6, 2, 10},
    {6, 15, 14, 9, 11, 3, 0, 8, 12, 2, 13, 7, 1, 4, 10, 5},
    {10, 2, 8, 4, 7, 6, 1, 5, 15, 11, 9, 14, 3, 12, 13, 0},
    {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15},
    {14, 10, 4, 8, 9, 15, 13, 6, 1, 12, 0, 2, 11, 7, 5, 3}};

// BLAKE2b's twelve rounds (RFC 7693: G and the message schedule) on the working vector v, for
// the words of one block, or of four blocks on vector lanes (Word a 64-bit integer or a vector
// of four). Always inlined, so that it is compiled for the target of the function calling it.
template <class Word>
[[gnu::always_inline]] inline void rotate_right(Word& x, int n) {
  x = (x >> n) | (x << (64 - n));
}

template <class Word>
[[gnu::always_inline]] inline void blake2b_g(Word (&v)[16], int a, int b, int c, int d,
                                             const Word& x, const Word& y) {
  v[a] += v[b] + x, v[d] ^= v[a], rotate_right(v[d], 32);
  v[c] += v[d], v[b] ^= v[c], rotate_right(v[b], 24);
  v[a] += v[b] + y, v[d] ^= v[a], rotate_right(v[d], 16);
  v[c] += v[d], v[b] ^= v[c], rotate_right(v[b], 63);
}

template <class Word>
[[gnu::always_inline]] inline void blake2b_rounds(Word (&v)[16], const Word (&m)[16]) {
  for (const auto& s : kBlake2bSigma) {
    blake2b_g(v, 0, 4, 8, 12, m[s[0]], m[s[1]]);
    blake2b_g(v, 1, 5, 9, 13, m[s[2]], m[s[3]]);
    blake2b_g(v, 2, 6, 10, 14, m[s[4]], m[s[5]]);
    blake2b_g(v, 3, 7, 11, 15, m[s[6]], m[s[7]]);
    blake2b_g(v, 0, 5, 10, 15, m[s[8]], m[s[9]]);
    blake2b_g(v, 1, 6, 11, 12, m[s[10]], m[s[11]]);
    blake2b_g(v, 2, 7, 8, 13, m[s[12]], m[s[13]]);
    blake2b_g(v, 3, 4, 9, 14, m[s[14]], m[s[15]]);
  }
}

void blake2b_compress(std::array<std::uint64_t, 8>& h, const std::uint8_t* block, std::uint64_t t,
                      bool last) {
  std::uint64_t m[16], v[16];
  for (int i = 0; i < 16; ++i) {
    std::uint64_t w = 0;
    for (int b = 7; b >= 0; --b) w = (w << 8) | block[8 * i + b];
    m[i] = w;
  }
  for (int i = 0; i < 8; ++i) v[i] = h[i], v[i + 8] = kBlake2bIv[i];
  v[12] ^= t;  // the counter's high word is 0
  if (last) v[14] = ~v[14];
  blake2b_rounds(v, m);
  for (int i = 0; i < 8; ++i) h[i] ^= v[i] ^ v[i + 8];
}

// The same compression on four blocks at once, one per lane of a vector of four 64-bit words
// (GCC's vector extension): lane l of h and block[l] are one independent BLAKE2b state and
// block, all four with the same counter t and flag. Built for AVX2 and for the baseline target,
// the processor choosing at load time (target_clones); trace encodes four candidates' rounds of
// the ID permutation with it. PackedEncoderGivesEncodesCodewords and
// KeyedHashDigest4IsFourDigests check it against the one-lane function and libsodium.
using Lanes = std::uint64_t __attribute__((vector_size(32)));

MESHMARK_LANE_TARGETS
void blake2b_compress4(std::array<std::array<std::uint64_t, 4>, 8>& h,
                       const std::array<const std::uint8_t*, 4>& block, std::uint64_t t,
                       bool last) {
  Lanes m[16], v[16];
  for (int i = 0; i < 16; ++i)
    for (int l = 0; l < 4; ++l) {
      std::uint64_t w = 0;
      for (int b = 7; b >= 0; --b) w = (w << 8) | block[l][8 * i + b];
      m[i][l] = w;
    }
  for (int i = 0; i < 8; ++i) {
    v[i] = Lanes{h[i][0], h[i][1], h[i][2], h[i][3]};
    v[i + 8] = Lanes{} + kBlake2bIv[i];
  }
  v[12] ^= t;
  if (last) v[14] = ~v[14];
  blake2b_rounds(v, m);
  for (int i = 0; i < 8; ++i) {
    const Lanes out = v[i] ^ v[i + 8];
    for (int l = 0; l < 4; ++l) h[i][l] ^= out[l];
  }
}
#undef MESHMARK_LANE_TARGETS

void ensure_sodium() {
  static const int status = sodium_init();  // thread-safe once; 1 = already initialized
  if (status < 0) throw Error("libsodium could not be initialized");
}

// BLAKE2b-256 of domain || 0 || data, optionally keyed.
Key hash_under_domain(std::string_view domain, const unsigned char* data, std::size_t size) {
  ensure_sodium();
  crypto_generichash_state state;
  crypto_generichash_init(&state, nullptr, 0, 32);
  crypto_generichash_update(&state, reinterpret_cast<const unsigned char*>(domain.data()),
                            domain.size());
  const unsigned char zero = 0;
  crypto_generichash_update(&state, &zero, 1);
  crypto_generichash_update(&state, data, size);
  Key key;
  crypto_generichash_final(&state, key.bytes.data(), key.bytes.size());
  return key;
}

// The ChaCha20 keystream of (key, nonce) read as 32-bit words; grows its buffer on demand
// (the stream is deterministic, so a longer buffer extends the same sequence).
class KeyStream {
 public:
  KeyStream(const Key& key, std::uint64_t nonce) : key_(key) {
    for (int i = 0; i < 8; ++i) nonce_[i] = static_cast<unsigned char>(nonce >> (8 * i));
  }
  std::uint32_t next() {
    if (pos_ + 4 > buffer_.size()) {
      buffer_.assign(std::max<std::size_t>(256, 2 * buffer_.size()), 0);
      crypto_stream_chacha20(buffer_.data(), buffer_.size(), nonce_, key_.bytes.data());
    }
    std::uint32_t w = 0;
    for (int i = 0; i < 4; ++i) w |= std::uint32_t(buffer_[pos_ + i]) << (8 * i);
    pos_ += 4;
    return w;
  }
  // Uniform in [0, bound), by rejection.
  std::uint32_t below(std::uint32_t bound) {
    const std::uint64_t span = std::uint64_t(1) << 32;
    const std::uint64_t limit = span - span % bound;
    for (;;) {
      const std::uint32_t w = next();
      if (w < limit) return w % bound;
    }
  }

 private:
  Key key_;
  unsigned char nonce_[8]{};
  std::vector<unsigned char> buffer_;
  std::size_t pos_ = 0;
};

}  // namespace

Key key_from_passphrase(std::string_view passphrase) {
  if (passphrase.empty()) throw InvalidArgumentError("the key passphrase is empty");
  ensure_sodium();
  // The salt: the first 16 bytes of BLAKE2b-256 of "meshmark/passphrase/v2/salt" || 0.
  static_assert(crypto_pwhash_SALTBYTES == 16);
  const Key salt = hash_under_domain("meshmark/passphrase/v2/salt",
                                     reinterpret_cast<const unsigned char*>(""), 0);
  constexpr unsigned long long kPasses = 3;
  constexpr std::size_t kMemory = std::size_t{64} << 20;
  Key key{.derivation = std::string(kPassphraseDerivation)};
  if (crypto_pwhash(key.bytes.data(), key.bytes.size(), passphrase.data(), passphrase.size(),
                    salt.bytes.data(), kPasses, kMemory, crypto_pwhash_ALG_ARGON2ID13) != 0)
    throw Error("the passphrase's key could not be derived: Argon2id needs 64 MiB of memory");
  return key;
}

Key key_from_passphrase_v1(std::string_view passphrase) {
  if (passphrase.empty()) throw InvalidArgumentError("the key passphrase is empty");
  Key key = hash_under_domain("meshmark/passphrase/v1",
                              reinterpret_cast<const unsigned char*>(passphrase.data()),
                              passphrase.size());
  key.derivation = kPassphraseDerivationV1;
  return key;
}

Key key_from_file(const std::string& path) {
  // A regular file of at most 1 MiB: a directory, a FIFO or a device such as /dev/zero is
  // refused before anything is read from it.
  constexpr std::size_t kMaxKeyFileBytes = std::size_t{1} << 20;
  const std::string bytes = read_file(path, kMaxKeyFileBytes, "key file");
  if (bytes.empty()) throw InvalidInputError(path, 0, "the key file is empty");
  Key key = hash_under_domain("meshmark/key-file/v1",
                              reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size());
  key.derivation = kKeyFileDerivation;
  return key;
}

std::string key_file_exposure(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) return {};
  if ((st.st_mode & (S_IRGRP | S_IROTH)) == 0) return {};
  return fmt::format(
      "{}: the key file can be read by {} (mode {:04o}): whoever reads it can forge any buyer's "
      "mark; chmod 600 it",
      path, (st.st_mode & S_IROTH) ? "every user of this machine" : "its group",
      st.st_mode & 07777);
}

Key generate_key_file(const std::string& path) {
  ensure_sodium();
  std::array<unsigned char, 32> bytes;
  randombytes_buf(bytes.data(), bytes.size());
  // O_EXCL: an existing key (or a link planted where it goes) is never replaced.
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC | O_NOFOLLOW, 0600);
  if (fd < 0)
    throw IOError(fmt::format(
        "{}: cannot create the key file: {}", path,
        errno == EEXIST ? "it exists (a key is never overwritten)" : std::strerror(errno)));
  const bool written =
      ::write(fd, bytes.data(), bytes.size()) == static_cast<ssize_t>(bytes.size()) &&
      ::fsync(fd) == 0;
  const int saved = errno;
  ::close(fd);
  sodium_memzero(bytes.data(), bytes.size());
  if (!written) {
    ::unlink(path.c_str());
    throw IOError(fmt::format("{}: cannot write the key file: {}", path, std::strerror(saved)));
  }
  return key_from_file(path);
}

const Key& public_key() {
  static const Key key = key_from_passphrase_v1("meshmark public whitening key");
  return key;
}

BitLayout BitLayout::canonical(int nb) {
  if (nb < 1) throw InvalidArgumentError(fmt::format("a layout needs at least 1 bit, not {}", nb));
  BitLayout layout;
  layout.bin_of.resize(nb);
  for (int j = 0; j < nb; ++j) layout.bin_of[j] = j;
  layout.whitening.assign(nb, 0);
  return layout;
}

Key derive_key(const Key& key, std::string_view purpose) {
  ensure_sodium();
  const std::string label = fmt::format("meshmark/mark-v{}/{}", kMarkFormatVersion, purpose);
  Key out;
  crypto_generichash(out.bytes.data(), out.bytes.size(),
                     reinterpret_cast<const unsigned char*>(label.data()), label.size(),
                     key.bytes.data(), key.bytes.size());
  return out;
}

BitLayout BitLayout::keyed(const Key& key, int nb) {
  BitLayout layout = canonical(nb);
  ensure_sodium();
  KeyStream stream(derive_key(key, "layout"), static_cast<std::uint64_t>(nb));
  // Fisher-Yates, uniform over the nb! permutations.
  for (int i = nb - 1; i > 0; --i)
    std::swap(layout.bin_of[i], layout.bin_of[stream.below(static_cast<std::uint32_t>(i) + 1)]);
  for (int j = 0; j < nb; ++j) layout.whitening[j] = static_cast<std::uint8_t>(stream.next() >> 31);
  return layout;
}

BinWord BitLayout::to_bins(const Payload& payload) const {
  if (payload.size() != size())
    throw InvalidArgumentError(
        fmt::format("payload of {} bits for a layout of {} bits", payload.size(), size()));
  BinWord out;
  out.bits.resize(size());
  for (int j = 0; j < size(); ++j) out.bits[bin_of[j]] = (payload.bits[j] & 1) ^ whitening[j];
  return out;
}

std::vector<std::uint8_t> BitLayout::from_bins(const std::vector<std::uint8_t>& bin_bits) const {
  if (static_cast<int>(bin_bits.size()) != size())
    throw InvalidArgumentError(
        fmt::format("{} bits read for a layout of {} bits", bin_bits.size(), size()));
  std::vector<std::uint8_t> out(size());
  for (int j = 0; j < size(); ++j) {
    const std::uint8_t b = bin_bits[bin_of[j]];
    out[j] = b > 1 ? b : static_cast<std::uint8_t>(b ^ whitening[j]);
  }
  return out;
}

std::vector<double> BitLayout::values_from_bins(const std::vector<double>& bin_values) const {
  if (static_cast<int>(bin_values.size()) != size())
    throw InvalidArgumentError(
        fmt::format("{} values read for a layout of {} bits", bin_values.size(), size()));
  std::vector<double> out(size());
  for (int j = 0; j < size(); ++j) out[j] = bin_values[bin_of[j]];
  return out;
}

KeyedHash::KeyedHash(const Key& key, std::string_view domain, int nbits) {
  static_assert(sizeof(crypto_generichash_state) <= sizeof(state_) &&
                alignof(crypto_generichash_state) <= 64);
  if (nbits < 1 || nbits > 512)
    throw InvalidArgumentError(fmt::format("a hash of {} bits is out of 1..512", nbits));
  ensure_sodium();
  bytes_ = (nbits + 7) / 8;
  out_len_ = std::max(bytes_, static_cast<int>(crypto_generichash_BYTES_MIN));
  auto* state = reinterpret_cast<crypto_generichash_state*>(state_.data());
  crypto_generichash_init(state, key.bytes.data(), key.bytes.size(),
                          static_cast<std::size_t>(out_len_));
  crypto_generichash_update(state, reinterpret_cast<const unsigned char*>(domain.data()),
                            domain.size());
  const unsigned char zero = 0;
  crypto_generichash_update(state, &zero, 1);
  // The chaining value after the key's block (the parameter block: digest length, key length,
  // fanout and depth 1), and domain || 0 at the start of the message's block.
  prefix_ = domain.size() + 1;
  if (prefix_ >= kBlock) return;  // a domain this long: libsodium hashes every message
  chain_ = kBlake2bIv;
  chain_[0] ^=
      0x01010000ULL ^ (std::uint64_t{key.bytes.size()} << 8) ^ static_cast<std::uint64_t>(out_len_);
  std::array<std::uint8_t, kBlock> key_block{};
  std::memcpy(key_block.data(), key.bytes.data(), key.bytes.size());
  blake2b_compress(chain_, key_block.data(), kBlock, false);
  std::memcpy(prefix_block_.data(), domain.data(), domain.size());
}

void KeyedHash::digest(const std::uint8_t* data, std::size_t size, std::uint8_t* out) const {
  if (prefix_ < kBlock && prefix_ + size <= kBlock) {  // one block after the key's
    std::array<std::uint8_t, kBlock> block = prefix_block_;
    if (size > 0) std::memcpy(block.data() + prefix_, data, size);
    std::array<std::uint64_t, 8> h = chain_;
    blake2b_compress(h, block.data(), kBlock + prefix_ + size, true);
    for (int i = 0; i < bytes_; ++i) out[i] = static_cast<std::uint8_t>(h[i / 8] >> (8 * (i % 8)));
    return;
  }
  crypto_generichash_state state;
  std::memcpy(&state, state_.data(), sizeof(state));
  crypto_generichash_update(&state, data, size);
  std::array<unsigned char, 64> full;
  crypto_generichash_final(&state, full.data(), static_cast<std::size_t>(out_len_));
  std::memcpy(out, full.data(), static_cast<std::size_t>(bytes_));
}

void KeyedHash::digest4(const std::array<const std::uint8_t*, 4>& data, std::size_t size,
                        const std::array<std::uint8_t*, 4>& out) const {
  if (prefix_ >= kBlock || prefix_ + size > kBlock) {  // libsodium, one message at a time
    for (int l = 0; l < 4; ++l) digest(data[l], size, out[l]);
    return;
  }
  std::array<std::array<std::uint8_t, kBlock>, 4> blocks;
  std::array<const std::uint8_t*, 4> block{};
  std::array<std::array<std::uint64_t, 4>, 8> h;
  for (int l = 0; l < 4; ++l) {
    blocks[l] = prefix_block_;
    if (size > 0) std::memcpy(blocks[l].data() + prefix_, data[l], size);
    block[l] = blocks[l].data();
  }
  for (int i = 0; i < 8; ++i) h[i].fill(chain_[i]);
  blake2b_compress4(h, block, kBlock + prefix_ + size, true);
  for (int l = 0; l < 4; ++l)
    for (int i = 0; i < bytes_; ++i)
      out[l][i] = static_cast<std::uint8_t>(h[i / 8][l] >> (8 * (i % 8)));
}

std::vector<std::uint8_t> keyed_hash_bits(const Key& key, std::string_view domain,
                                          const std::vector<std::uint8_t>& data, int nbits) {
  const KeyedHash hash(key, domain, nbits);
  std::array<std::uint8_t, 64> digest;
  hash.digest(data.data(), data.size(), digest.data());
  std::vector<std::uint8_t> bits(nbits);
  for (int i = 0; i < nbits; ++i) bits[i] = (digest[i / 8] >> (7 - i % 8)) & 1;
  return bits;
}

}  // namespace meshmark
