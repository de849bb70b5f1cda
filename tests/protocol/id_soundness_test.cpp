// The ID code never names a wrong buyer and detection's p-values are what they claim, tested on
// structured inputs: consecutive IDs, words between two close codewords, and the null
// distribution against brute force and against the empirical distribution of innocent IDs.

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <map>
#include <numeric>

#include "core/parallel.h"
#include "meshmark/core/random.h"
#include "meshmark/protocol/coding.h"
#include "meshmark/protocol/detect.h"
#include "meshmark/protocol/key.h"

namespace meshmark {
namespace {

std::uint64_t pack(const std::vector<std::uint8_t>& bits) {
  std::uint64_t w = 0;
  for (std::size_t j = 0; j < bits.size(); ++j)
    if (bits[j] & 1) w |= std::uint64_t(1) << j;
  return w;
}

// The packed codewords of IDs 0 .. count - 1 under key.
std::vector<std::uint64_t> codewords(const IdCode& code, const Key& key, int count) {
  std::vector<std::uint64_t> words(count);
  for (int id = 0; id < count; ++id) words[id] = pack(code.encode(id, key).bits);
  return words;
}

// Smallest pairwise distance among words, and how many pairs reach each distance up to 16.
__attribute__((target("popcnt"))) int smallest_distance(const std::vector<std::uint64_t>& words,
                                                        std::map<int, long>& low) {
  int smallest = 64;
  std::vector<long> count(17, 0);
  for (std::size_t a = 0; a < words.size(); ++a) {
    const std::uint64_t wa = words[a];
    for (std::size_t b = a + 1; b < words.size(); ++b) {
      const int d = std::popcount(wa ^ words[b]);
      if (d <= 16) ++count[d];
    }
  }
  for (int d = 0; d <= 16; ++d)
    if (count[d]) low[d] = count[d], smallest = std::min(smallest, d);
  return smallest;
}

TEST(IdSoundness, EveryPairOf100000ConsecutiveIdsIsAtLeastTheMinimumDistanceApart) {
  const IdCode code;
  const Key key = key_from_passphrase("studio-secret");
  const int ids = 100000;
  const std::vector<std::uint64_t> words = codewords(code, key, ids);
  std::map<int, long> low;
  const int smallest = smallest_distance(words, low);
  for (const auto& [d, n] : low)
    RecordProperty("pairs_at_distance_" + std::to_string(d), static_cast<int>(n));
  RecordProperty("smallest_distance", smallest);
  // The decoder's proof rests on this: any two codewords at least 2t + 2 = 12 apart.
  EXPECT_GE(smallest, code.min_distance());
  EXPECT_GE(code.min_distance(), 2 * code.correction() + 2);
  // Consecutive IDs are no closer than random pairs: the mean distance of neighbours is about
  // nb / 2 (a random codeword's weight), not the 6 of a systematic code.
  double mean = 0;
  for (int id = 1; id < ids; ++id) mean += std::popcount(words[id] ^ words[id - 1]);
  mean /= ids - 1;
  EXPECT_NEAR(mean, 32.0, 0.2);
}

TEST(IdSoundness, WordsBetweenTwoCloseCodewordsNeverDecodeToTheFartherOne) {
  const IdCode code;
  const Key key = key_from_passphrase("studio-secret");
  // The closest pair among the first 20,000 IDs.
  const int ids = 20000;
  const std::vector<std::uint64_t> words = codewords(code, key, ids);
  int best = 65, id1 = 0, id2 = 0;
  for (int a = 0; a < ids; ++a)
    for (int b = a + 1; b < ids; ++b) {
      const int d = std::popcount(words[a] ^ words[b]);
      if (d < best) best = d, id1 = a, id2 = b;
    }
  ASSERT_GE(best, code.min_distance());
  const std::vector<std::uint8_t> c1 = code.encode(id1, key).bits, c2 = code.encode(id2, key).bits;
  std::vector<int> between, outside;
  for (int j = 0; j < 64; ++j) (c1[j] != c2[j] ? between : outside).push_back(j);
  Random rng(99);
  int decoded1 = 0, decoded2 = 0, tried = 0;
  for (int a = 0; a <= best; ++a)             // bits moved from c1 towards c2
    for (int extra = 0; extra <= 2; ++extra)  // bits moved away from both
      for (int margins_kind = 0; margins_kind < 4; ++margins_kind)
        for (int draw = 0; draw < 8; ++draw) {
          std::vector<int> order = between;
          for (std::size_t i = 0; i + 1 < order.size(); ++i)
            std::swap(order[i], order[i + rng.next() % (order.size() - i)]);
          std::vector<std::uint8_t> w = c1;
          std::vector<double> m(64);
          for (auto& x : m) x = 0.02 + 0.1 * rng.uniform();
          for (int i = 0; i < a; ++i) w[order[i]] ^= 1;
          for (int i = 0; i < extra; ++i) w[outside[rng.next() % outside.size()]] ^= 1;
          // Adversarial margins: the moved bits weakest (helps the nearer codeword c2 when a is
          // large), the unmoved differing bits weakest (helps c1), random, or none at all.
          if (margins_kind == 0)
            for (int i = 0; i < a; ++i) m[order[i]] = 1e-4 * (i + 1);
          if (margins_kind == 1)
            for (int i = a; i < best; ++i) m[order[i]] = 1e-4 * (i + 1);
          const std::vector<double> margins = margins_kind == 3 ? std::vector<double>{} : m;
          const IdDecodeResult r = code.decode(w, margins, key);
          int d1 = 0, d2 = 0;
          for (int j = 0; j < 64; ++j) d1 += w[j] != c1[j], d2 += w[j] != c2[j];
          ++tried;
          if (!r.valid) continue;
          ASSERT_TRUE(r.id == static_cast<std::uint64_t>(id1) ||
                      r.id == static_cast<std::uint64_t>(id2))
              << "a third ID " << r.id;
          const int d = r.id == static_cast<std::uint64_t>(id1) ? d1 : d2;
          const int other = r.id == static_cast<std::uint64_t>(id1) ? d2 : d1;
          ASSERT_LE(d, code.correction()) << "a " << a << " extra " << extra;
          ASSERT_LT(d, other) << "decoded to the farther codeword: a " << a << " extra " << extra;
          (r.id == static_cast<std::uint64_t>(id1) ? decoded1 : decoded2)++;
        }
  // Both sides decode where they are within reach: every radius was exercised.
  EXPECT_GT(decoded1, 0);
  EXPECT_GT(decoded2, 0);
  RecordProperty("closest_pair_distance", best);
  RecordProperty("words", tried);
}

TEST(IdSoundness, EveryDistanceUpToTheRadiusDecodesWhenTheErrorsAreTheWeakestBits) {
  const IdCode code;
  const Key key = key_from_passphrase("radius");
  Random rng(5);
  for (int errors = 0; errors <= code.correction(); ++errors)
    for (int trial = 0; trial < 50; ++trial) {
      const std::uint64_t id = rng.next() >> 32;
      std::vector<std::uint8_t> w = code.encode(id, key).bits;
      std::vector<double> m(64);
      for (auto& x : m) x = 0.02 + 0.1 * rng.uniform();
      std::vector<int> pos(64);
      std::iota(pos.begin(), pos.end(), 0);
      for (int i = 0; i < errors; ++i) std::swap(pos[i], pos[i + rng.next() % (64 - i)]);
      for (int i = 0; i < errors; ++i) w[pos[i]] ^= 1, m[pos[i]] = 1e-3;
      const IdDecodeResult r = code.decode(w, m, key);
      ASSERT_TRUE(r.valid) << errors;
      EXPECT_EQ(r.id, id);
      EXPECT_EQ(r.corrected, errors);
    }
}

TEST(IdSoundness, NullDistributionEqualsBruteForceOnASmallCode) {
  // nb = 16, 4-bit IDs: a code small enough to list every codeword and count matches directly.
  IdCodeOptions o;
  o.bits = 16;
  o.id_bits = 4;
  o.false_accept = 1e-2;
  const IdCode code(o);
  const Key key = key_from_passphrase("small");
  const std::vector<std::vector<std::uint8_t>> dual = code.dual_basis();
  ASSERT_EQ(static_cast<int>(dual.size()), 16 - code.message_bits());
  std::vector<std::uint16_t> rows;
  for (const auto& row : dual) rows.push_back(static_cast<std::uint16_t>(pack(row)));
  // The code: every word orthogonal to the dual basis.
  std::vector<std::uint16_t> codewords;
  for (int w = 0; w < (1 << 16); ++w) {
    bool orthogonal = true;
    for (const std::uint16_t r : rows) orthogonal &= std::popcount(unsigned(w & r)) % 2 == 0;
    if (orthogonal) codewords.push_back(static_cast<std::uint16_t>(w));
  }
  ASSERT_EQ(codewords.size(), std::size_t(1) << code.message_bits());
  // Every ID's codeword, its mask removed, is one of them.
  const std::uint16_t mask = static_cast<std::uint16_t>(pack(code.mask(key)));
  for (std::uint64_t id = 0; id < 16; ++id) {
    const std::uint16_t c = static_cast<std::uint16_t>(pack(code.encode(id, key).bits)) ^ mask;
    EXPECT_TRUE(std::binary_search(codewords.begin(), codewords.end(), c)) << id;
  }
  Random rng(8);
  for (int trial = 0; trial < 200; ++trial) {
    std::vector<std::uint8_t> read(16);
    for (auto& b : read) b = rng.next() % 5 == 0 ? 2 : (rng.next() >> 63);  // ~20 % erasures
    const CodewordNull null(code, read, key);
    EXPECT_EQ(null.model(), NullModel::CodewordExact);
    for (int matches = 0; matches <= 17; ++matches) {
      int at_least = 0;
      for (const std::uint16_t c : codewords) {
        int agree = 0;
        for (int j = 0; j < 16; ++j) agree += read[j] <= 1 && read[j] == (((c ^ mask) >> j) & 1);
        at_least += agree >= matches;
      }
      EXPECT_NEAR(null.p_value(matches), at_least / double(codewords.size()), 1e-12)
          << "trial " << trial << " matches " << matches;
    }
  }
}

TEST(IdSoundness, InnocentIdsFollowTheNullDistribution) {
  // A QQ check of the default code: read words (uniform, a codeword, a codeword with errors and
  // erasures), 100,000 innocent IDs each; the frequency of each match count agrees with the
  // null's prediction within 5 standard deviations where at least 50 are expected, and the
  // empirical P(p <= alpha) stays at most alpha (plus 5 sigma).
  const IdCode code;
  const Key key = key_from_passphrase("qq");
  Random rng(31);
  std::vector<std::vector<std::uint8_t>> reads;
  reads.push_back(std::vector<std::uint8_t>(64));
  for (auto& b : reads.back()) b = rng.next() >> 63;
  reads.push_back(code.encode(123456, key).bits);
  reads.push_back(code.encode(654321, key).bits);
  for (int j = 0; j < 64; j += 9) reads.back()[j] ^= 1;
  reads.back()[5] = 2, reads.back()[50] = 2;
  for (const auto& read : reads) {
    const CodewordNull null(code, read, key);
    ASSERT_EQ(null.model(), NullModel::CodewordExact);
    const int innocents = 100000;
    std::vector<int> histogram(66, 0);
    for (int i = 0; i < innocents; ++i) {
      const std::uint64_t id = 1000000 + i;  // consecutive innocents
      const std::vector<std::uint8_t> c = code.encode(id, key).bits;
      int matches = 0;
      for (int j = 0; j < 64; ++j) matches += read[j] <= 1 && read[j] == c[j];
      ++histogram[matches];
    }
    int at_least = 0;
    for (int m = 65; m >= 0; --m) {
      const double expected = (null.p_value(m) - null.p_value(m + 1)) * innocents;
      if (expected >= 50)
        EXPECT_NEAR(histogram[m], expected, 5 * std::sqrt(expected)) << "matches " << m;
      at_least += histogram[m];
      const double p = null.p_value(m);
      EXPECT_LE(at_least, p * innocents + 5 * std::sqrt(p * innocents) + 1) << "matches " << m;
    }
  }
}

TEST(IdSoundness, NullIsExactForTheDefaultCodeAndBoundedForLongOnes) {
  const IdCode code;
  std::vector<std::uint8_t> read(64, 0);
  const Key key = key_from_passphrase("models");
  EXPECT_EQ(CodewordNull(code, read, key).model(), NullModel::CodewordExact);
  // The dual code's weights are counted in chunks on the thread budget: integer counts, so
  // the null is the same to the last bit on one thread and on four, for reads with erasures.
  Random rng(17);
  for (int trial = 0; trial < 4; ++trial) {
    std::vector<std::uint8_t> r(64);
    for (auto& bit : r) bit = rng.next() % 8 == 0 ? 2 : (rng.next() >> 63);
    std::vector<double> one, four;
    {
      const detail::ThreadBudgetScope scope(1);
      const CodewordNull null(code, r, key);
      for (int m = 0; m <= 65; ++m) one.push_back(null.p_value(m));
    }
    {
      const detail::ThreadBudgetScope scope(4);
      const CodewordNull null(code, r, key);
      for (int m = 0; m <= 65; ++m) four.push_back(null.p_value(m));
    }
    EXPECT_EQ(one, four) << "trial " << trial;
  }
  IdCodeOptions o;
  o.bits = 128;
  const IdCode longer(o);
  const CodewordNull bound(longer, std::vector<std::uint8_t>(128, 0), key);
  EXPECT_EQ(bound.model(), NullModel::CodewordBound);
  // The bound from the k message bits: all 128 matching means all k message bits match.
  EXPECT_NEAR(bound.p_value(128), std::exp2(-longer.message_bits()), 1e-20);
}

}  // namespace
}  // namespace meshmark
