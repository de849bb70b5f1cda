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

#include "meshmark/core/error.h"
#include "meshmark/io/io.h"

namespace meshmark {

namespace {

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
}

void KeyedHash::digest(const std::uint8_t* data, std::size_t size, std::uint8_t* out) const {
  crypto_generichash_state state;
  std::memcpy(&state, state_.data(), sizeof(state));
  crypto_generichash_update(&state, data, size);
  std::array<unsigned char, 64> full;
  crypto_generichash_final(&state, full.data(), static_cast<std::size_t>(out_len_));
  std::memcpy(out, full.data(), static_cast<std::size_t>(bytes_));
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
