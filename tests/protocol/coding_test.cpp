// Keys, keyed layouts, the ID code and detection, checked against independent computations:
// published BCH parameters, exhaustive error patterns, Pascal's triangle, uniform random words.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <set>

#include <sodium.h>

#include "meshmark/core/error.h"
#include "meshmark/core/random.h"
#include "meshmark/io/io.h"
#include "meshmark/protocol/coding.h"
#include "meshmark/protocol/detect.h"
#include "meshmark/protocol/key.h"
#include "test_data.h"

namespace meshmark {
namespace {

std::vector<std::uint8_t> random_bits(int n, Random& rng) {
  std::vector<std::uint8_t> bits(n);
  for (auto& b : bits) b = rng.next() >> 63;
  return bits;
}

TEST(Key, PassphraseAndFileKeysAreDeterministicAndDistinct) {
  const Key a = key_from_passphrase("studio secret");
  EXPECT_EQ(a, key_from_passphrase("studio secret"));
  EXPECT_NE(a, key_from_passphrase("studio secreT"));
  const std::string path = test::scratch_dir() + "/key.bin";
  std::ofstream(path, std::ios::binary) << "studio secret";
  // Same bytes, other domain: a key file never collides with a passphrase.
  EXPECT_NE(a, key_from_file(path));
  EXPECT_EQ(key_from_file(path), key_from_file(path));
  EXPECT_THROW(key_from_passphrase(""), InvalidArgumentError);
  EXPECT_THROW(key_from_file(path + ".missing"), IOError);
  const std::string empty = test::scratch_dir() + "/empty.key";
  std::ofstream(empty, std::ios::binary).flush();
  EXPECT_THROW(key_from_file(empty), InvalidInputError);
}

TEST(Key, KeyedLayoutIsAPermutationWithBalancedWhitening) {
  const int nb = 1024;
  const BitLayout layout = BitLayout::keyed(key_from_passphrase("k"), nb);
  std::vector<int> sorted = layout.bin_of;
  std::sort(sorted.begin(), sorted.end());
  for (int j = 0; j < nb; ++j) ASSERT_EQ(sorted[j], j);
  // A fair mask: 1024 fair bits have a standard deviation of 16; allow 5 of them.
  const int ones = std::accumulate(layout.whitening.begin(), layout.whitening.end(), 0);
  EXPECT_NEAR(ones, nb / 2, 80);
  // Fixed points of a uniform permutation: about 1 on average; far fewer than nb.
  int fixed = 0;
  for (int j = 0; j < nb; ++j) fixed += layout.bin_of[j] == j;
  EXPECT_LT(fixed, 10);
  // Another key, another layout; another length, another layout.
  EXPECT_NE(layout.bin_of, BitLayout::keyed(key_from_passphrase("l"), nb).bin_of);
  const BitLayout shorter = BitLayout::keyed(key_from_passphrase("k"), 64);
  EXPECT_EQ(shorter.size(), 64);
}

TEST(Key, LayoutRoundTripsAndKeepsErasures) {
  Random rng(5);
  const BitLayout layout = BitLayout::keyed(key_from_passphrase("round trip"), 64);
  Payload p{random_bits(64, rng)};
  const Payload bins = layout.to_bins(p);
  std::vector<std::uint8_t> back = layout.from_bins(bins.bits);
  EXPECT_EQ(back, p.bits);
  std::vector<std::uint8_t> with_erasure = bins.bits;
  with_erasure[layout.bin_of[7]] = 2;
  back = layout.from_bins(with_erasure);
  EXPECT_EQ(back[7], 2);
  // Bin values follow their bits.
  std::vector<double> values(64);
  for (int b = 0; b < 64; ++b) values[b] = b;
  const std::vector<double> per_bit = layout.values_from_bins(values);
  for (int j = 0; j < 64; ++j) EXPECT_EQ(per_bit[j], layout.bin_of[j]);
  // Canonical: identity, no whitening (the spec's unkeyed layout).
  EXPECT_EQ(BitLayout::canonical(64).to_bins(p), p);
}

TEST(Bch, ParityBitsMatchThePublishedTables) {
  // (n, k, t) of primitive binary BCH codes (Lin & Costello, table 6.1): parity = n - k.
  struct Row {
    int m, t, k;
  };
  const Row rows[] = {{5, 1, 26},  {5, 2, 21},  {5, 3, 16},  {5, 5, 11},  {5, 7, 6},   {6, 1, 57},
                      {6, 2, 51},  {6, 3, 45},  {6, 4, 39},  {6, 5, 36},  {6, 6, 30},  {6, 7, 24},
                      {6, 10, 18}, {6, 11, 16}, {6, 13, 10}, {7, 1, 120}, {7, 2, 113}, {7, 4, 99},
                      {7, 9, 71},  {7, 10, 64}, {8, 1, 247}, {8, 2, 239}, {8, 3, 231}};
  for (const Row& r : rows)
    EXPECT_EQ(bch_parity_bits(r.m, r.t), (1 << r.m) - 1 - r.k) << "m " << r.m << " t " << r.t;
}

// log2 C(n, i) summed for i <= t, by Pascal's rule in long double (independent of lgamma).
double ball(int n, int t) {
  std::vector<long double> row(n + 1, 0);
  row[0] = 1;
  for (int i = 1; i <= n; ++i)
    for (int k = i; k >= 1; --k) row[k] += row[k - 1];
  long double sum = 0;
  for (int i = 0; i <= t; ++i) sum += row[i];
  return static_cast<double>(sum);
}

TEST(IdCode, DefaultCodeMeetsItsFalseAcceptBound) {
  const IdCode code;
  EXPECT_EQ(code.bits(), 64);
  EXPECT_EQ(code.field_degree(), 6);
  // BCH(63, 36) corrects 5 errors (27 parity bits, published table); t = 6 leaves 30 < 32
  // message bits for a 32-bit ID.
  EXPECT_EQ(code.correction(), 5);
  EXPECT_EQ(code.parity_bits(), 27);
  EXPECT_EQ(code.message_bits(), 36);
  EXPECT_EQ(code.check_bits(), 4);
  EXPECT_EQ(code.min_distance(), 12);
  // The rules: every rule's weak + errors within t (so 2 (weak + errors) < 12), and their
  // false-accept terms 2^32 V(64 - s, e) / 2^(64 - s) summed below 1e-6.
  // (5, 0) would accept nothing (4, 1) does not: five errors on the five weakest bits leave one
  // among the 60 most reliable.
  const std::vector<DecodeRule> expected = {{0, 2}, {4, 1}};
  ASSERT_EQ(code.rules().size(), expected.size());
  double bound = 0;
  for (std::size_t i = 0; i < expected.size(); ++i) {
    EXPECT_EQ(code.rules()[i].weak, expected[i].weak) << i;
    EXPECT_EQ(code.rules()[i].errors, expected[i].errors) << i;
    EXPECT_LT(2 * (expected[i].weak + expected[i].errors), code.min_distance());
    bound +=
        ball(64 - expected[i].weak, expected[i].errors) * std::exp2(32 - (64 - expected[i].weak));
  }
  // Fifteen further readings (outliers left out), each with the retry rule (0 weak, 1 error).
  EXPECT_EQ(code.retries(), 15);
  EXPECT_EQ(code.retry_rule().weak, 0);
  EXPECT_EQ(code.retry_rule().errors, 1);
  bound += 15 * ball(64, 1) * std::exp2(32 - 64);
  EXPECT_NEAR(code.false_accept_bound(), bound, 1e-12);
  EXPECT_LE(bound, 1e-6);
  // Three errors would not meet it: V(64, 3) / 2^32 = 1.0e-5.
  EXPECT_GT(ball(64, 3) / std::exp2(32), 1e-6);
}

TEST(IdCode, CorrectsEveryPatternOfAtMostTwoErrors) {
  const IdCode code;
  const Key key = key_from_passphrase("exhaustive");
  for (const std::uint64_t id : {0ull, 0xFFFFFFFFull, 0x1234ABCDull}) {
    const Payload c = code.encode(id, key);
    ASSERT_EQ(code.decode(c.bits, {}, key).id, id);
    int tested = 0;
    for (int a = 0; a < 64; ++a)
      for (int b = a; b < 64; ++b) {  // b == a: a single error
        std::vector<std::uint8_t> word = c.bits;
        word[a] ^= 1;
        if (b != a) word[b] ^= 1;
        const IdDecodeResult r = code.decode(word, {}, key);
        ASSERT_TRUE(r.valid) << "errors at " << a << ", " << b;
        ASSERT_EQ(r.id, id);
        ASSERT_EQ(r.corrected, a == b ? 1 : 2);
        ++tested;
      }
    EXPECT_EQ(tested, 64 + 64 * 63 / 2);
  }
}

TEST(IdCode, WeakBitsExtendTheRadiusUpToT) {
  const IdCode code;
  const Key key = key_from_passphrase("weak bits");
  Random rng(11);
  for (int trial = 0; trial < 200; ++trial) {
    const std::uint64_t id = rng.next() >> 32;
    const std::vector<std::uint8_t> c = code.encode(id, key).bits;
    std::vector<double> margins(64);
    for (auto& m : margins) m = 0.05 + 0.1 * rng.uniform();
    std::vector<int> positions(64);
    std::iota(positions.begin(), positions.end(), 0);
    for (int i = 0; i < 6; ++i) std::swap(positions[i], positions[i + rng.next() % (64 - i)]);
    // Five errors, all on the five weakest bits: rule (4 weak, 1 error) accepts it.
    std::vector<std::uint8_t> word = c;
    std::vector<double> weak = margins;
    for (int i = 0; i < 5; ++i) word[positions[i]] ^= 1, weak[positions[i]] = 0.001 * (i + 1);
    IdDecodeResult r = code.decode(word, weak, key);
    ASSERT_TRUE(r.valid) << trial << " " << r.message;
    ASSERT_EQ(r.id, id);
    EXPECT_EQ(r.corrected, 5);
    EXPECT_FALSE(code.decode(word, {}, key).valid);  // hard decisions alone: 5 > 2
    // Four weak errors and one reliable one: rule (4, 1).
    word = c, weak = margins;
    for (int i = 0; i < 4; ++i) word[positions[i]] ^= 1, weak[positions[i]] = 0.001 * (i + 1);
    word[positions[4]] ^= 1;
    r = code.decode(word, weak, key);
    ASSERT_TRUE(r.valid) << trial;
    ASSERT_EQ(r.id, id);
    // Three weak errors and two reliable ones: within t = 5, but no rule accepts it.
    word = c, weak = margins;
    for (int i = 0; i < 3; ++i) word[positions[i]] ^= 1, weak[positions[i]] = 0.001 * (i + 1);
    word[positions[3]] ^= 1, word[positions[4]] ^= 1;
    weak[positions[3]] = weak[positions[4]] = 0.4;  // the most reliable bits of all
    EXPECT_FALSE(code.decode(word, weak, key).valid) << trial;
    // Six errors: beyond t, never an ID.
    word = c;
    for (int i = 0; i < 6; ++i) word[positions[i]] ^= 1, weak[positions[i]] = 0;
    EXPECT_FALSE(code.decode(word, weak, key).valid) << trial;
  }
}

TEST(IdCode, ErasuresCountAsErrorsAndTooManyAreReportedAsUnreadable) {
  const IdCode code;
  const Key key = key_from_passphrase("erasures");
  const std::vector<std::uint8_t> c = code.encode(77, key).bits;
  std::vector<std::uint8_t> word = c;
  std::vector<double> margins(64, 0.05);
  for (int j = 0; j < 5; ++j) word[3 * j] = 2, margins[3 * j] = 0;
  IdDecodeResult r = code.decode(word, margins, key);
  ASSERT_TRUE(r.valid) << r.message;
  EXPECT_EQ(r.id, 77u);
  EXPECT_EQ(r.erasures, 5);
  EXPECT_EQ(r.corrected, 5);
  word[40] = 2;
  r = code.decode(word, margins, key);
  EXPECT_FALSE(r.valid);
  EXPECT_EQ(r.status, IdDecodeStatus::Unreadable) << r.message;
  const std::vector<std::uint8_t> all_erased(64, 2);
  r = code.decode(all_erased, std::vector<double>(64, 0.0), key);
  EXPECT_EQ(r.status, IdDecodeStatus::Unreadable);
  EXPECT_NE(r.message.find("64 of 64 bits are unreadable"), std::string::npos) << r.message;
}

TEST(IdCode, UniformRandomWordsAlmostNeverDecode) {
  // The rules' bound (without retries) is 7.1e-7 per word: over 300,000 words 0.2 expected.
  const IdCode code;
  const Key key = key_from_passphrase("random words");
  Random rng(17);
  int accepted = 0;
  const int words = 300000;
  for (int i = 0; i < words; ++i) {
    std::vector<std::uint8_t> w = random_bits(64, rng);
    std::vector<double> margins(64);
    for (auto& m : margins) m = rng.uniform() * 0.5;
    accepted += code.decode(w, margins, key).valid;
  }
  EXPECT_LE(accepted, 3) << "of " << words << " uniform words";
}

TEST(IdCode, WrongKeyNeverYieldsAnId) {
  const IdCode code;
  const Key right = key_from_passphrase("right");
  const Payload c = code.encode(0xC0FFEE, right);
  for (int k = 0; k < 100; ++k) {
    const Key wrong = key_from_passphrase_v1("wrong " + std::to_string(k));  // fast
    const IdDecodeResult r = code.decode(c.bits, {}, wrong);
    EXPECT_FALSE(r.valid) << k;
    // The word is a codeword, but of no ID under the wrong key (4 zero bits: 1/16 chance of a
    // wrong ID would be possible only if the permutation gave zeros there, which its keyed
    // inverse does with probability 1/16; then the ID found would be another one). What
    // matters: never the right ID under a wrong key by chance more than that.
    if (r.status == IdDecodeStatus::Found) EXPECT_NE(r.id, 0xC0FFEEu);
  }
}

TEST(IdCode, LongerPayloadsCorrectMore) {
  IdCodeOptions o;
  o.bits = 128;
  const IdCode code(o);
  EXPECT_GE(code.rules().front().errors, 10);
  EXPECT_LE(code.false_accept_bound(), 1e-6);
  const Key key = key_from_passphrase("long");
  Random rng(23);
  for (int trial = 0; trial < 50; ++trial) {
    const std::uint64_t id = rng.next() >> 32;
    std::vector<std::uint8_t> w = code.encode(id, key).bits;
    std::set<int> flipped;
    while (static_cast<int>(flipped.size()) < code.rules().front().errors)
      flipped.insert(rng.next() % 128);
    for (int j : flipped) w[j] ^= 1;
    const IdDecodeResult r = code.decode(w, {}, key);
    ASSERT_TRUE(r.valid);
    EXPECT_EQ(r.id, id);
  }
}

TEST(IdCode, RefusesImpossibleOptions) {
  IdCodeOptions o;
  o.bits = 40;  // 2^32 IDs in 40 bits: a random word is within reach of some ID too often
  EXPECT_THROW(IdCode{o}, InvalidArgumentError);
  o = {};
  o.id_bits = 33;
  EXPECT_THROW(IdCode{o}, InvalidArgumentError);
  EXPECT_THROW(IdCode().encode(1ull << 32, public_key()), InvalidArgumentError);
  EXPECT_THROW(IdCode().decode(std::vector<std::uint8_t>(63), {}, public_key()),
               InvalidArgumentError);
}

TEST(Detect, BinomialTailMatchesPascalsTriangle) {
  for (const int n : {1, 10, 64, 200}) {
    // Row n of Pascal's triangle in long double, independent of lgamma.
    std::vector<long double> row(n + 1, 0);
    row[0] = 1;
    for (int i = 1; i <= n; ++i)
      for (int k = i; k >= 1; --k) row[k] += row[k - 1];
    for (int k = 0; k <= n + 1; ++k) {
      long double tail = 0;
      for (int i = std::max(k, 0); i <= n; ++i) tail += row[i];
      tail = std::ldexp(tail, -n);
      const double got = binomial_tail(n, k);
      EXPECT_NEAR(got, static_cast<double>(tail), 1e-10 * static_cast<double>(tail) + 1e-300)
          << "n " << n << " k " << k;
    }
  }
}

TEST(Detect, CountsMatchesAndErasures) {
  Payload expected{{1, 0, 1, 1, 0, 0, 1, 0}};
  const DetectResult r = detect({1, 0, 1, 2, 0, 1, 1, 0}, expected);
  EXPECT_EQ(r.compared, 8);
  EXPECT_EQ(r.matches, 6);
  EXPECT_EQ(r.erasures, 1);
  EXPECT_NEAR(r.p_value, (28 + 8 + 1) / 256.0, 1e-15);
  EXPECT_FALSE(r.detected);
  EXPECT_THROW(detect({1, 0}, expected), InvalidArgumentError);
}

// A buyer ID as typed: decimal whatever its leading zeros (never octal: "0100" read as 64 would
// issue or name another buyer), or 0x hexadecimal; anything else is refused.
TEST(Coding, IdsParseAsDecimalOrHexAndNothingElse) {
  EXPECT_EQ(parse_id("0100"), 100u);
  EXPECT_EQ(parse_id("08"), 8u);
  EXPECT_EQ(parse_id("0"), 0u);
  EXPECT_EQ(parse_id("1042"), 1042u);
  EXPECT_EQ(parse_id("0x1f"), 31u);
  EXPECT_EQ(parse_id("0X1F"), 31u);
  EXPECT_EQ(parse_id("18446744073709551615"), 18446744073709551615ull);
  for (const char* bad : {"", " 5", "5 ", "+5", "-5", "1e3", "0x", "0x 1", "12a", "0b101",
                          "18446744073709551616", "5\n"})
    EXPECT_THROW(parse_id(bad), InvalidArgumentError) << "'" << bad << "'";
}

// keygen: a new file of 32 random bytes, mode 0600, whose key is key_from_file's; an existing
// file or a link where it goes is refused and left as it was.
// KeyedHash against libsodium's BLAKE2b called here as docs/format.md section 1.1 defines
// keyed_hash_bits: keyed with the key, of domain || 0 || data, max(bytes, 16) bytes long;
// messages of 0 to 300 bytes and domains of 0 to 140 bytes (domain, 0 and message on either side
// of the 128-byte block, where KeyedHash's own compression hands over to libsodium), keys of
// random bytes and lengths of 1 to 512 bits.
TEST(Key, KeyedHashIsKeyedBlake2bOfDomainZeroAndData) {
  ASSERT_GE(sodium_init(), 0);
  Random rng(5);
  for (const std::size_t domain_size : {0, 11, 100, 126, 127, 128, 140}) {
    std::string domain(domain_size, 'd');
    for (char& c : domain) c = static_cast<char>('a' + (rng.next() >> 60));
    Key key;
    for (auto& b : key.bytes) b = static_cast<std::uint8_t>(rng.next() >> 56);
    for (const int nbits : {1, 7, 8, 24, 100, 128, 129, 512})
      for (const std::size_t size : {0, 1, 9, 16, 110, 116, 117, 127, 128, 129, 300}) {
        std::vector<std::uint8_t> data(size);
        for (auto& b : data) b = static_cast<std::uint8_t>(rng.next() >> 56);
        const KeyedHash hash(key, domain, nbits);
        std::array<std::uint8_t, 64> got{};
        hash.digest(data.data(), data.size(), got.data());
        const std::size_t bytes = (static_cast<std::size_t>(nbits) + 7) / 8;
        const std::size_t out_len = std::max<std::size_t>(bytes, crypto_generichash_BYTES_MIN);
        std::vector<std::uint8_t> message(domain.begin(), domain.end());
        message.push_back(0);
        message.insert(message.end(), data.begin(), data.end());
        std::vector<std::uint8_t> want(out_len);
        crypto_generichash(want.data(), out_len, message.data(), message.size(), key.bytes.data(),
                           key.bytes.size());
        ASSERT_TRUE(std::equal(want.begin(), want.begin() + static_cast<std::ptrdiff_t>(bytes),
                               got.begin()))
            << nbits << " bits of " << size << " bytes, domain of " << domain_size;
        // keyed_hash_bits gives the same bits, most significant first.
        const std::vector<std::uint8_t> bits = keyed_hash_bits(key, domain, data, nbits);
        for (int i = 0; i < nbits; ++i) ASSERT_EQ(bits[i], (want[i / 8] >> (7 - i % 8)) & 1);
      }
  }
  const Key key = key_from_passphrase_v1("keyed hash test");
  EXPECT_THROW(KeyedHash(key, "d", 0), InvalidArgumentError);
  EXPECT_THROW(KeyedHash(key, "d", 513), InvalidArgumentError);
}

// KeyedHash::digest4 against libsodium's BLAKE2b of each message (as above): four different
// messages of one length, lengths on either side of the one-block limit (where digest4 hands
// each message to libsodium), digests of 1 to 512 bits.
TEST(Key, KeyedHashDigest4IsFourDigests) {
  ASSERT_GE(sodium_init(), 0);
  Random rng(6);
  Key key;
  for (auto& b : key.bytes) b = static_cast<std::uint8_t>(rng.next() >> 56);
  const std::string domain = "id-feistel";
  for (const int nbits : {1, 16, 100, 256, 512})
    for (const std::size_t size : {0, 1, 10, 38, 64, 116, 117, 118, 200}) {
      const KeyedHash hash(key, domain, nbits);
      std::array<std::vector<std::uint8_t>, 4> data;
      std::array<std::array<std::uint8_t, 64>, 4> got{};
      for (auto& d : data) {
        d.resize(size);
        for (auto& b : d) b = static_cast<std::uint8_t>(rng.next() >> 56);
      }
      hash.digest4({data[0].data(), data[1].data(), data[2].data(), data[3].data()}, size,
                   {got[0].data(), got[1].data(), got[2].data(), got[3].data()});
      const std::size_t bytes = (static_cast<std::size_t>(nbits) + 7) / 8;
      const std::size_t out_len = std::max<std::size_t>(bytes, crypto_generichash_BYTES_MIN);
      for (int l = 0; l < 4; ++l) {
        std::vector<std::uint8_t> message(domain.begin(), domain.end());
        message.push_back(0);
        message.insert(message.end(), data[l].begin(), data[l].end());
        std::vector<std::uint8_t> want(out_len);
        crypto_generichash(want.data(), out_len, message.data(), message.size(), key.bytes.data(),
                           key.bytes.size());
        ASSERT_TRUE(std::equal(want.begin(), want.begin() + static_cast<std::ptrdiff_t>(bytes),
                               got[l].begin()))
            << "lane " << l << ", " << nbits << " bits of " << size << " bytes";
      }
    }
}

// The packed encoder trace scores with against IdCode::encode, bit for bit: several codes,
// consecutive IDs (which share the permutation's first round), decreasing and random IDs (which
// do not), the largest ID, and an ID too long.
TEST(IdCode, PackedEncoderGivesEncodesCodewords) {
  const Key key = key_from_passphrase_v1("packed encoder test");
  Random rng(11);
  for (const auto& [bits, id_bits] :
       std::vector<std::pair<int, int>>{{64, 32}, {48, 16}, {96, 32}, {128, 20}, {600, 32}}) {
    IdCodeOptions o;
    o.bits = bits, o.id_bits = id_bits;
    const IdCode code(o);
    const CodewordEncoder encoder(code, key);
    ASSERT_EQ(encoder.words(), (bits + 63) / 64);
    const std::uint64_t top = (std::uint64_t{1} << id_bits) - 1;
    std::vector<std::uint64_t> ids;
    for (std::uint64_t id = 0; id < 300; ++id) ids.push_back(id);
    for (std::uint64_t id = 5000; id > 4800; --id) ids.push_back(id);
    for (int i = 0; i < 200; ++i) ids.push_back(rng.next() & top);
    ids.push_back(top);
    std::vector<std::uint64_t> packed(ids.size() * static_cast<std::size_t>(encoder.words()));
    encoder.encode(ids.data(), ids.size(), packed.data());
    for (std::size_t c = 0; c < ids.size(); ++c) {
      const Payload want = code.encode(ids[c], key);
      const std::uint64_t* got = packed.data() + c * static_cast<std::size_t>(encoder.words());
      for (int j = 0; j < encoder.words() * 64; ++j)
        ASSERT_EQ((got[j / 64] >> (j % 64)) & 1, j < bits ? want.bits[j] : 0u)
            << "nb " << bits << ", ID " << ids[c] << ", bit " << j;
    }
    // Any count: the encoder takes four IDs at a time and the rest one by one.
    for (std::size_t count = 1; count <= 7; ++count) {
      std::vector<std::uint64_t> few(count * static_cast<std::size_t>(encoder.words()));
      encoder.encode(ids.data() + 301, count, few.data());
      EXPECT_TRUE(std::equal(few.begin(), few.end(),
                             packed.begin() + 301 * static_cast<std::ptrdiff_t>(encoder.words())))
          << "nb " << bits << ", " << count << " IDs";
    }
    const std::uint64_t too_long = top + 1;
    EXPECT_THROW(encoder.encode(&too_long, 1, packed.data()), InvalidArgumentError);
  }
}

TEST(Key, GeneratedKeyFilesAreNewPrivateAndDistinct) {
  namespace fs = std::filesystem;
  const std::string dir = test::scratch_dir();
  const Key a = generate_key_file(dir + "/a.key"), b = generate_key_file(dir + "/b.key");
  EXPECT_EQ(fs::file_size(dir + "/a.key"), 32u);
  EXPECT_EQ(fs::status(dir + "/a.key").permissions() & fs::perms::all,
            fs::perms::owner_read | fs::perms::owner_write);
  EXPECT_EQ(a, key_from_file(dir + "/a.key"));
  EXPECT_NE(a, b);
  const std::string before = read_file(dir + "/a.key");
  EXPECT_THROW(generate_key_file(dir + "/a.key"), IOError);
  EXPECT_EQ(read_file(dir + "/a.key"), before);
  fs::create_symlink(dir + "/planted", dir + "/link.key");
  EXPECT_THROW(generate_key_file(dir + "/link.key"), IOError);
  EXPECT_FALSE(fs::exists(dir + "/planted"));
  EXPECT_THROW(generate_key_file(dir + "/no/such/dir.key"), IOError);
}

}  // namespace
}  // namespace meshmark
