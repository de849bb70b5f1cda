// The registry's spacing rule for coded IDs (spacing.h).

#include "meshmark/forensics/spacing.h"

#include <fmt/format.h>

#include <algorithm>
#include <map>
#include <optional>
#include <set>
#include <tuple>

#include "meshmark/core/error.h"
#include "meshmark/protocol/coding.h"
#include "meshmark/protocol/watermark.h"

namespace meshmark {

namespace {

// The codewords recorded in a registry under one key, per (original, bits, ID length), loaded
// when a group is first asked for, with the copies of this issue added as they are accepted.
class IssuedCodewords {
 public:
  IssuedCodewords(const Registry& registry, const Key& key)
      : registry_(registry), key_(key), fingerprint_(key_fingerprint(key)) {}

  // c's codeword and the nearest issued copy within spacing bits (other than c's own ID), if any.
  std::pair<Payload, std::optional<CloseCodeword>> check(const IssuedCopy& c, int spacing) {
    auto& group = load(c);
    const Payload word = code(c).encode(c.id, key_);
    for (const auto& [other, codeword] : group) {
      if (other.id == c.id) continue;  // the same ID: Registry::conflicts() reports it
      int d = 0;
      for (int j = 0; j < c.bits; ++j) d += word.bits[j] != codeword.bits[j];
      if (d < spacing) return {word, CloseCodeword{c, other, d}};
    }
    return {word, std::nullopt};
  }
  // Whether c's ID is recorded, or accepted earlier, in its group.
  bool taken(const IssuedCopy& c) {
    load(c);
    return ids_[group(c)].count(c.id) > 0;
  }
  void add(const IssuedCopy& c, Payload word) {
    load(c).emplace_back(c, std::move(word));
    ids_[group(c)].insert(c.id);
  }
  // The last ID free_ids() gave in c's group (0 before the first): an ID it skipped stays
  // taken or too close, since the issued codewords only grow.
  std::uint64_t& cursor(const IssuedCopy& c) { return cursors_[group(c)]; }

 private:
  using Group = std::tuple<std::string, int, int>;
  // The original by its geometry when known, else by its file.
  static Group group(const IssuedCopy& c) {
    return {
        c.original_geometry.empty() ? "file " + c.original_hash : "shape " + c.original_geometry,
        c.bits, c.id_bits};
  }
  IdCode code(const IssuedCopy& c) const {
    IdCodeOptions o;
    o.bits = c.bits;
    o.id_bits = c.id_bits;
    return IdCode(o);
  }
  std::vector<std::pair<IssuedCopy, Payload>>& load(const IssuedCopy& c) {
    const Group g = group(c);
    auto it = groups_.find(g);
    if (it != groups_.end()) return it->second;
    it = groups_.emplace(g, std::vector<std::pair<IssuedCopy, Payload>>{}).first;
    RegistryQuery q;  // the copies of this original's file, or of its geometry in another
    q.original_hash = c.original_hash;
    if (!c.original_geometry.empty()) q.original_geometry = c.original_geometry;
    q.key_fingerprint = fingerprint_;
    const IdCode id_code = code(c);
    for (const IssuedCopy& r : registry_.list(q))
      if (r.bits == c.bits && r.id_bits == c.id_bits) {
        it->second.emplace_back(r, id_code.encode(r.id, key_));
        ids_[g].insert(r.id);
      }
    return it->second;
  }
  const Registry& registry_;
  const Key& key_;
  std::string fingerprint_;
  std::map<Group, std::vector<std::pair<IssuedCopy, Payload>>> groups_;
  std::map<Group, std::set<std::uint64_t>> ids_;
  std::map<Group, std::uint64_t> cursors_;
};

}  // namespace

std::vector<CloseCodeword> close_codewords(const Registry& registry,
                                           const std::vector<IssuedCopy>& copies, const Key& key,
                                           int spacing) {
  std::vector<CloseCodeword> out;
  IssuedCodewords issued(registry, key);
  for (const IssuedCopy& c : copies) {
    auto [word, close] = issued.check(c, spacing);
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
  IssuedCodewords issued(registry, key);
  for (const IssuedCopy& c : taken) {
    auto [word, close] = issued.check(c, 0);
    issued.add(c, std::move(word));
  }
  std::vector<std::uint64_t> ids;
  for (IssuedCopy c : wanted) {
    const std::uint64_t last =
        c.id_bits >= 64 ? ~std::uint64_t(0) : (std::uint64_t(1) << c.id_bits) - 1;
    // Random codewords of nb = 64 bits fall within 15 bits of a given one with probability
    // about 1e-5: a free ID is found within a few tries even among millions of copies.
    constexpr std::uint64_t kMaxTries = 1000000;
    std::uint64_t& cursor = issued.cursor(c);
    c.id = cursor;
    bool found = false;
    for (std::uint64_t tries = 0; !found && tries < kMaxTries && c.id < last; ++tries) {
      ++c.id;
      if (issued.taken(c)) continue;
      auto [word, close] = issued.check(c, spacing);
      if (close) continue;
      issued.add(c, std::move(word));
      found = true;
    }
    cursor = c.id;
    if (!found)
      throw InvalidArgumentError(fmt::format(
          "no free ID of {} bits at least {} bits from every issued codeword after ID {}",
          c.id_bits, spacing, c.id));
    ids.push_back(c.id);
  }
  return ids;
}

}  // namespace meshmark
