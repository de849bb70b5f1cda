// The spacing rule's index: SpacedIds (IDs whose codewords lie in a BCH subcode), the registry's
// spaced_index, and id:auto drawing from it against IDs given by hand.

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <sqlite3.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <random>
#include <set>

#include "meshmark/forensics/registry.h"
#include "meshmark/forensics/spacing.h"
#include "meshmark/protocol/coding.h"
#include "test_data.h"

namespace meshmark {
namespace {

int distance(const IdCode& code, const Key& key, std::uint64_t a, std::uint64_t b) {
  const Payload x = code.encode(a, key), y = code.encode(b, key);
  int d = 0;
  for (std::size_t j = 0; j < x.bits.size(); ++j) d += x.bits[j] != y.bits[j];
  return d;
}

IdCode code_of(int bits, int id_bits) {
  IdCodeOptions o;
  o.bits = bits, o.id_bits = id_bits;
  return IdCode(o);
}

// The span is the BCH subcode's messages: its dimension is k minus the extra parity bits of the
// subcode's generator, counted from the cyclotomic cosets (bch_parity_bits, checked against the
// published tables in coding_test), or k when the code's own distance is the spacing already.
TEST(SpacedIds, SpanHasTheDimensionOfTheBchSubcode) {
  const Key key = key_from_passphrase("spacing");
  for (const auto& [bits, id_bits] :
       std::vector<std::pair<int, int>>{{64, 32}, {64, 24}, {64, 16}, {96, 32}, {128, 32}}) {
    SCOPED_TRACE(fmt::format("nb {} ID {}", bits, id_bits));
    const IdCode code = code_of(bits, id_bits);
    const int t2 = (kIssuedSpacing - 1) / 2;  // 2t' + 2 >= 16
    const int m = code.field_degree(), inner = bits - 1;
    int expected = code.message_bits();
    if (code.correction() < t2)
      expected = std::max(0, inner - bch_parity_bits(m, t2));  // k of the shortened subcode
    const SpacedIds span(code, key);
    EXPECT_EQ(span.dimension(), std::min(expected, 62));
  }
  // The default code: 24 of 36 message bits, 4 check bits, so about 2^20 IDs.
  const SpacedIds span(code_of(64, 32), key);
  EXPECT_EQ(span.dimension(), 24);
  EXPECT_EQ(span.log2_capacity(), 20);
}

// Every nonzero codeword of the span, all 2^24 of them for the default code (a Gray-code walk
// over the basis rows' codewords, the code being linear), weighs at least the spacing: the
// BCH bound checked exhaustively. The weight-16 count is recorded (docs/forensics.md).
TEST(SpacedIds, EveryCodewordOfTheSpanWeighsAtLeastTheSpacing) {
  const IdCode code = code_of(64, 32);
  const std::vector<std::vector<std::uint8_t>> basis = code.spaced_message_basis(kIssuedSpacing);
  ASSERT_EQ(basis.size(), 24u);
  std::vector<std::uint64_t> rows;
  for (const std::vector<std::uint8_t>& m : basis) {
    const std::vector<std::uint8_t> c = code.message_codeword(m);
    std::uint64_t packed = 0;
    for (int j = 0; j < 64; ++j) packed |= std::uint64_t(c[j] & 1) << j;
    rows.push_back(packed);
  }
  std::uint64_t word = 0;
  int lightest = 64;
  std::uint64_t at_16 = 0, odd = 0;
  for (std::uint64_t i = 1; i < (std::uint64_t(1) << rows.size()); ++i) {
    word ^= rows[__builtin_ctzll(i)];
    const int w = __builtin_popcountll(word);
    lightest = std::min(lightest, w);
    at_16 += w == 16;
    odd += w % 2;
  }
  EXPECT_EQ(lightest, kIssuedSpacing);
  EXPECT_EQ(odd, 0u);  // the overall parity bit makes every weight even
  ::testing::Test::RecordProperty("weight_16_codewords", static_cast<int>(at_16));
  std::printf("the span's code: minimum weight %d, %llu codewords of weight 16\n", lightest,
              static_cast<unsigned long long>(at_16));
}

// Any two IDs of the span, at consecutive positions or far apart, have codewords at least the
// spacing apart (Hamming distances counted here from IdCode::encode); consecutive IDs, which
// the span does not constrain, do not. Positions and IDs correspond both ways.
TEST(SpacedIds, AnyTwoIdsOfTheSpanAreAtLeastTheSpacingApart) {
  const Key key = key_from_passphrase("spacing");
  for (const auto& [bits, id_bits] : std::vector<std::pair<int, int>>{{64, 32}, {64, 24}}) {
    SCOPED_TRACE(fmt::format("nb {} ID {}", bits, id_bits));
    const IdCode code = code_of(bits, id_bits);
    const SpacedIds span(code, key);
    std::vector<std::uint64_t> ids;
    std::mt19937_64 rng(7);
    for (std::uint64_t p = 0; ids.size() < 150; ++p)  // consecutive positions
      if (const auto id = span.id_at(p)) {
        EXPECT_EQ(span.index_of(*id), p + 1);
        ids.push_back(*id);
      }
    const std::uint64_t end = std::uint64_t(1) << span.dimension();
    for (int found = 0; found < 150;) {  // random positions across the span
      const std::uint64_t p = rng() % end;
      if (const auto id = span.id_at(p)) {
        EXPECT_EQ(span.index_of(*id), p + 1);
        ids.push_back(*id), ++found;
      }
    }
    std::sort(ids.begin(), ids.end());
    ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
    int closest = bits;
    for (std::size_t a = 0; a < ids.size(); ++a)
      for (std::size_t b = a + 1; b < ids.size(); ++b)
        closest = std::min(closest, distance(code, key, ids[a], ids[b]));
    EXPECT_GE(closest, kIssuedSpacing);
    // Consecutive IDs 1..2000 are not spaced by the default code: the property is the span's,
    // not chance's.
    std::vector<Payload> plain;
    for (std::uint64_t a = 1; a <= 2000; ++a) plain.push_back(code.encode(a, key));
    int plain_closest = bits;
    for (std::size_t a = 0; a < plain.size(); ++a)
      for (std::size_t b = a + 1; b < plain.size(); ++b) {
        int d = 0;
        for (int j = 0; j < bits; ++j) d += plain[a].bits[j] != plain[b].bits[j];
        plain_closest = std::min(plain_closest, d);
      }
    if (code.min_distance() < kIssuedSpacing)
      EXPECT_LT(plain_closest, kIssuedSpacing);
    else  // a code spaced by itself (24-bit IDs): its span is every message
      EXPECT_EQ(span.dimension(), code.message_bits());
    // index_of says 0 exactly for the IDs no position gives.
    for (std::uint64_t id = 1; id <= 3000; ++id) {
      const std::uint64_t index = span.index_of(id);
      if (index) EXPECT_EQ(span.id_at(index - 1), id);
    }
  }
}

// A registry records each copy's place in the span when given the key, and nothing without
// it; verify_registry catches a place edited by hand (it would exempt a row from the checks).
TEST(SpacedIds, RegistryRecordsEachPlaceAndVerifyCatchesAnEditedOne) {
  const std::string dir = test::scratch_dir() + "/spaced-index";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string db = dir + "/shop.db";
  const Key key = key_from_passphrase("spaced index key");
  const IdCode code = code_of(64, 32);
  const SpacedIds span(code, key);
  IssuedCopy like;
  like.original_hash = std::string(64, 'a');
  like.key_fingerprint = key_fingerprint(key);
  std::vector<IssuedCopy> copies;
  std::vector<std::uint64_t> expected;
  for (std::uint64_t p = 0; copies.size() < 5; ++p)
    if (const auto id = span.id_at(p)) {
      IssuedCopy c = like;
      c.id = *id, c.buyer = fmt::format("spaced {}", p), c.spaced_index = 999;
      copies.push_back(c), expected.push_back(p + 1);
    }
  for (std::uint64_t id : {3u, 4u}) {
    IssuedCopy c = like;
    c.id = id, c.buyer = fmt::format("by hand {}", id), c.spaced_index = 7;
    copies.push_back(c), expected.push_back(span.index_of(id));
  }
  {
    Registry registry(db);
    registry.record(copies, key);
    IssuedCopy unkeyed = like;  // recorded without the key: outside every span
    unkeyed.id = *span.id_at(expected[4]);
    unkeyed.original_hash = std::string(64, 'b');
    unkeyed.spaced_index = 5;
    registry.record({unkeyed});
    EXPECT_EQ(registry.last_spaced_index(like), expected[4]);
    EXPECT_EQ(registry.last_spaced_index(unkeyed), 0u);
  }
  std::vector<IssuedCopy> rows = read_registry(db);
  ASSERT_EQ(rows.size(), 8u);
  for (std::size_t i = 0; i < expected.size(); ++i) EXPECT_EQ(rows[i].spaced_index, expected[i]);
  EXPECT_EQ(rows[7].spaced_index, 0u);
  RegistryQuery outside;
  outside.spaced = false;
  EXPECT_EQ(read_registry(db, outside).size(), 1u + (expected[5] == 0) + (expected[6] == 0));
  RegistryCheck check = verify_registry(db, key);
  EXPECT_TRUE(check.edited.empty());
  EXPECT_EQ(check.unauthenticated.size(), 1u);  // the row recorded without the key
  // A hand-issued row made to look spaced.
  sqlite3* h = nullptr;
  ASSERT_EQ(sqlite3_open(db.c_str(), &h), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(h, "UPDATE copies SET spaced_index = 12345 WHERE id = 3", nullptr, nullptr,
                         nullptr),
            SQLITE_OK);
  sqlite3_close(h);
  check = verify_registry(db, key);
  EXPECT_FALSE(check.ok());
  ASSERT_EQ(check.edited.size(), 1u);
  EXPECT_EQ(check.edited[0].id, 3u);
}

// id:auto draws the span's next ID, and still keeps clear of an ID given by hand whose codeword
// was chosen, by search, within the spacing of that next ID: the hand-given row is found by
// index and compared, and the next ID after it is chosen instead.
TEST(SpacedIds, AutoIdsKeepClearOfIdsGivenByHandNearThem) {
  const std::string dir = test::scratch_dir() + "/spaced-auto";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const Key key = key_from_passphrase("spaced auto key");
  const IdCode code = code_of(64, 32);
  IssuedCopy like;
  like.original_hash = std::string(64, 'a');
  like.original_geometry = std::string(64, 'g');
  like.key_fingerprint = key_fingerprint(key);
  Registry registry(dir + "/shop.db");
  const std::vector<std::uint64_t> first = free_ids(registry, {}, {like}, key);
  ASSERT_EQ(first.size(), 1u);
  const SpacedIds span(code, key);
  std::optional<std::uint64_t> span_first;
  for (std::uint64_t p = 0; !span_first; ++p) span_first = span.id_at(p);
  EXPECT_EQ(first[0], *span_first);  // an empty registry: the span's first ID
  // An ID within the spacing of the would-be next one, by search over small IDs.
  std::uint64_t near = 0;
  for (std::uint64_t id = 1; id < 3000000 && !near; ++id)
    if (id != first[0] && distance(code, key, id, first[0]) < kIssuedSpacing) near = id;
  ASSERT_NE(near, 0u) << "no ID within the spacing found";
  IssuedCopy by_hand = like;
  by_hand.id = near, by_hand.buyer = "by hand";
  by_hand.original_hash = std::string(64, 'z');  // another file of the same geometry
  registry.record({by_hand}, key);
  // 40 IDs for the same geometry: none is the one near the hand-given ID, all are spaced.
  const std::vector<std::uint64_t> ids = free_ids(registry, {}, std::vector(40, like), key);
  EXPECT_EQ(std::count(ids.begin(), ids.end(), first[0]), 0);
  std::set<std::uint64_t> all(ids.begin(), ids.end());
  EXPECT_EQ(all.size(), ids.size());
  all.insert(near);
  for (const std::uint64_t a : all)
    for (const std::uint64_t b : all)
      if (a < b) EXPECT_GE(distance(code, key, a, b), kIssuedSpacing) << a << " and " << b;
  // Recorded, they continue after the last recorded place on the next call.
  std::vector<IssuedCopy> issued;
  for (const std::uint64_t id : ids) {
    IssuedCopy c = like;
    c.id = id, c.buyer = fmt::format("auto {}", id);
    issued.push_back(c);
  }
  registry.record(issued, key);
  const std::vector<std::uint64_t> next = free_ids(registry, {}, {like}, key);
  EXPECT_GT(span.index_of(next[0]), span.index_of(ids.back()));
  // close_codewords agrees: the hand-given ID's neighbour is refused, the chosen ones are not.
  IssuedCopy probe = like;
  probe.id = first[0];
  EXPECT_EQ(close_codewords(registry, {probe}, key).size(), 1u);
  probe.id = next[0];
  EXPECT_TRUE(close_codewords(registry, {probe}, key).empty());
}

}  // namespace
}  // namespace meshmark
