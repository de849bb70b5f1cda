// The registry's spacing rule for coded IDs (spacing.h).

#include "meshmark/forensics/spacing.h"

#include <fmt/format.h>

#include <algorithm>
#include <map>
#include <optional>
#include <set>
#include <tuple>

#include "meshmark/core/error.h"

namespace meshmark {

namespace {

// Positions are stored as 1 + position in a signed 64-bit column.
constexpr std::size_t kMaxSpacedDimension = 62;
// Below this capacity (log2 of the IDs SpacedIds hold) free_ids takes the smallest free ID.
constexpr int kMinSpacedCapacity = 10;

IdCode code_of(const IssuedCopy& c) {
  IdCodeOptions o;
  o.bits = c.bits;
  o.id_bits = c.id_bits;
  return IdCode(o);
}

int hamming(const Payload& a, const Payload& b) {
  int d = 0;
  for (std::size_t j = 0; j < a.bits.size(); ++j) d += a.bits[j] != b.bits[j];
  return d;
}

}  // namespace

SpacedIds::SpacedIds(const IdCode& code, const Key& key, int spacing)
    : code_(code),
      key_(key),
      order_key_(derive_key(key, "spaced-order")),
      basis_(code.spaced_message_basis(spacing)) {
  if (basis_.size() > kMaxSpacedDimension) basis_.resize(kMaxSpacedDimension);
  for (const std::vector<std::uint8_t>& row : basis_)
    pivots_.push_back(static_cast<int>(std::find(row.begin(), row.end(), 1) - row.begin()));
}

std::uint64_t SpacedIds::order(std::uint64_t position, bool inverse) const {
  // A Feistel network on D-bit numbers, x = L || R (|L| = D/2), 8 rounds: even rounds
  // R ^= F(round, L), odd rounds L ^= F(round, R); the inverse runs them in reverse order.
  const int d = dimension(), a = d / 2, b = d - a;
  if (a == 0) return position;
  const auto low = [](int bits) { return bits >= 64 ? ~0ULL : (1ULL << bits) - 1; };
  std::uint64_t left = position >> b, right = position & low(b);
  constexpr int kRounds = 8;
  for (int step = 0; step < kRounds; ++step) {
    const int round = inverse ? kRounds - 1 - step : step;
    const bool even = round % 2 == 0;
    const std::uint64_t from = even ? left : right;
    std::vector<std::uint8_t> data = {static_cast<std::uint8_t>(round),
                                      static_cast<std::uint8_t>(d)};
    for (int i = 7; i >= 0; --i) data.push_back(static_cast<std::uint8_t>(from >> (8 * i)));
    const std::vector<std::uint8_t> f =
        keyed_hash_bits(order_key_, "spaced-order", data, even ? b : a);
    std::uint64_t mixed = 0;
    for (const std::uint8_t bit : f) mixed = mixed << 1 | bit;
    (even ? right : left) ^= mixed;
  }
  return left << b | right;
}

std::optional<std::uint64_t> SpacedIds::id_at(std::uint64_t place) const {
  const std::uint64_t position = order(place, false);
  std::vector<std::uint8_t> message(code_.message_bits(), 0);
  for (std::size_t j = 0; j < basis_.size(); ++j)
    if ((position >> j) & 1)
      for (std::size_t i = 0; i < message.size(); ++i) message[i] ^= basis_[j][i];
  const std::optional<std::uint64_t> id = code_.message_id(message, key_);
  if (id && *id == 0) return std::nullopt;  // ID 0 is never issued
  return id;
}

std::uint64_t SpacedIds::index_of(std::uint64_t id) const {
  const std::vector<std::uint8_t> message = code_.permuted_message(id, key_);
  std::vector<std::uint8_t> spanned(message.size(), 0);
  std::uint64_t position = 0;
  for (std::size_t j = 0; j < basis_.size(); ++j)
    if (message[pivots_[j]]) {
      position |= std::uint64_t(1) << j;
      for (std::size_t i = 0; i < spanned.size(); ++i) spanned[i] ^= basis_[j][i];
    }
  return spanned == message ? order(position, true) + 1 : 0;
}

namespace {

// The codewords recorded in a registry under one key, per (original, bits, ID length), with
// the copies of this issue added as they are accepted. Where SpacedIds apply, a group loads
// only its copies outside the span (few: IDs given by hand, rows recorded before schema 5);
// every copy of the group is loaded only to check an ID outside the span.
class IssuedCodewords {
 public:
  IssuedCodewords(const Registry& registry, const Key& key, int spacing)
      : registry_(registry), key_(key), fingerprint_(key_fingerprint(key)), spacing_(spacing) {}

  // c's codeword and the nearest issued copy within spacing bits (other than c's own ID), if any.
  std::pair<Payload, std::optional<CloseCodeword>> check(const IssuedCopy& c) {
    Group& g = group(c);
    const Payload word = g.code.encode(c.id, key_);
    const bool spaced = g.spaced && g.spaced->index_of(c.id) > 0;
    if (!spaced && !g.all_loaded) load_all(g, c);
    const auto near = [&](const Entry& e) -> std::optional<CloseCodeword> {
      if (e.copy.id == c.id) return std::nullopt;   // the same ID: Registry::conflicts() says so
      if (spaced && e.spaced) return std::nullopt;  // two IDs of the span: spaced by the code
      const int d = hamming(word, e.word);
      if (d < spacing_) return CloseCodeword{c, e.copy, d};
      return std::nullopt;
    };
    for (const Entry& e : spaced ? g.unspaced : g.all)
      if (auto close = near(e)) return {word, close};
    for (const Entry& e : g.batch)
      if (auto close = near(e)) return {word, close};
    return {word, std::nullopt};
  }
  // Whether c's ID is recorded for its original and key, or accepted earlier in this issue.
  bool taken(const IssuedCopy& c) {
    return group(c).batch_ids.count(c.id) > 0 || !registry_.conflicts({c}).empty();
  }
  void add(const IssuedCopy& c) { add(c, group(c).code.encode(c.id, key_)); }
  void add(const IssuedCopy& c, Payload word) {
    Group& g = group(c);
    const bool spaced = g.spaced && g.spaced->index_of(c.id) > 0;
    g.batch.push_back({c, std::move(word), spaced});
    g.batch_ids.insert(c.id);
  }
  // The ID free_ids() gives next in c's group.
  std::uint64_t next_id(const IssuedCopy& c) {
    Group& g = group(c);
    if (g.spaced && g.spaced->log2_capacity() >= kMinSpacedCapacity) return next_spaced(g, c);
    return next_smallest(g, c);
  }

 private:
  struct Entry {
    IssuedCopy copy;
    Payload word;
    bool spaced = false;  // its ID lies in the group's SpacedIds
  };
  struct Group {
    IdCode code;
    std::optional<SpacedIds> spaced;  // when spacing <= kIssuedSpacing
    std::vector<Entry> unspaced;      // the recorded copies outside the span
    std::vector<Entry> all;           // every recorded copy, once all_loaded
    bool all_loaded = false;
    std::vector<Entry> batch;  // the copies of this issue accepted so far
    std::set<std::uint64_t> batch_ids;
    std::uint64_t cursor = 0;  // spaced: the next position; else the last ID tried
  };
  using GroupKey = std::tuple<std::string, int, int>;

  // The original by its geometry when known, else by its file.
  static GroupKey key_of(const IssuedCopy& c) {
    return {
        c.original_geometry.empty() ? "file " + c.original_hash : "shape " + c.original_geometry,
        c.bits, c.id_bits};
  }
  RegistryQuery query(const IssuedCopy& c) const {
    RegistryQuery q;  // the copies of this original's file, or of its geometry in another
    q.original_hash = c.original_hash;
    if (!c.original_geometry.empty()) q.original_geometry = c.original_geometry;
    q.key_fingerprint = fingerprint_;
    q.bits = c.bits;
    q.id_bits = c.id_bits;
    return q;
  }
  std::vector<Entry> load(const Group& g, const RegistryQuery& q) const {
    std::vector<Entry> out;
    for (IssuedCopy& r : registry_.list(q)) {
      Payload word = g.code.encode(r.id, key_);
      const bool spaced = r.spaced_index > 0;
      out.push_back({std::move(r), std::move(word), spaced});
    }
    return out;
  }
  void load_all(Group& g, const IssuedCopy& c) {
    g.all = load(g, query(c));
    g.all_loaded = true;
  }
  Group& group(const IssuedCopy& c) {
    const GroupKey k = key_of(c);
    auto it = groups_.find(k);
    if (it != groups_.end()) return it->second;
    Group g{code_of(c), std::nullopt, {}, {}, false, {}, {}, 0};
    if (spacing_ <= kIssuedSpacing) {
      g.spaced.emplace(g.code, key_);
      RegistryQuery q = query(c);
      q.spaced = false;
      g.unspaced = load(g, q);
      IssuedCopy like = c;
      like.key_fingerprint = fingerprint_;
      g.cursor = registry_.last_spaced_index(like);
    }
    return groups_.emplace(k, std::move(g)).first->second;
  }

  // The next free position of the span, after the last one recorded; past the end, the first
  // free one from the start.
  std::uint64_t next_spaced(Group& g, IssuedCopy c) {
    const std::uint64_t end = std::uint64_t(1) << g.spaced->dimension();
    for (std::uint64_t tried = 0; tried < end; ++tried) {
      if (g.cursor >= end) g.cursor = 0;
      const std::optional<std::uint64_t> id = g.spaced->id_at(g.cursor++);
      if (!id) continue;
      c.id = *id;
      if (taken(c)) continue;
      auto [word, close] = check(c);
      if (close) continue;
      add(c, std::move(word));
      return c.id;
    }
    throw InvalidArgumentError(fmt::format(
        "every one of the about 2^{} IDs of {} bits spaced by {} bits in {}-bit codewords is "
        "issued for this original under this key: issue further copies with more payload "
        "bits or under another key",
        g.spaced->log2_capacity(), c.id_bits, kIssuedSpacing, c.bits));
  }

  // The smallest free ID after the last one tried, compared with every issued copy.
  std::uint64_t next_smallest(Group& g, IssuedCopy c) {
    const std::uint64_t last =
        c.id_bits >= 64 ? ~std::uint64_t(0) : (std::uint64_t(1) << c.id_bits) - 1;
    // Random codewords of nb = 64 bits fall within 15 bits of a given one with probability
    // about 1e-5: a free ID is found within a few tries even among millions of copies.
    constexpr std::uint64_t kMaxTries = 1000000;
    c.id = g.cursor;
    for (std::uint64_t tries = 0; tries < kMaxTries && c.id < last; ++tries) {
      ++c.id;
      if (taken(c)) continue;
      auto [word, close] = check(c);
      if (close) continue;
      add(c, std::move(word));
      g.cursor = c.id;
      return c.id;
    }
    g.cursor = c.id;
    throw InvalidArgumentError(
        fmt::format("no free ID of {} bits at least {} bits from every issued codeword after ID {}",
                    c.id_bits, spacing_, c.id));
  }

  const Registry& registry_;
  const Key& key_;
  std::string fingerprint_;
  int spacing_;
  std::map<GroupKey, Group> groups_;
};

}  // namespace

std::vector<CloseCodeword> close_codewords(const Registry& registry,
                                           const std::vector<IssuedCopy>& copies, const Key& key,
                                           int spacing) {
  std::vector<CloseCodeword> out;
  IssuedCodewords issued(registry, key, spacing);
  for (const IssuedCopy& c : copies) {
    auto [word, close] = issued.check(c);
    if (close)
      out.push_back(*close);
    else
      issued.add(c, std::move(word));
  }
  return out;
}

std::vector<std::uint64_t> free_ids(const Registry& registry, const std::vector<IssuedCopy>& taken,
                                    const std::vector<IssuedCopy>& wanted, const Key& key,
                                    int spacing) {
  IssuedCodewords issued(registry, key, spacing);
  for (const IssuedCopy& c : taken) issued.add(c);
  std::vector<std::uint64_t> ids;
  ids.reserve(wanted.size());
  for (const IssuedCopy& c : wanted) ids.push_back(issued.next_id(c));
  return ids;
}

}  // namespace meshmark
