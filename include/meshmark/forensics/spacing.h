#pragma once
/// \file spacing.h
/// The registry's spacing rule for coded IDs: codewords issued under one key for one original
/// stay at least kIssuedSpacing bits apart, so that a clean copy of one buyer is never taken
/// for another (docs/forensics.md). Checked when copies are issued (issue.h), and used to pick
/// IDs for `id:auto`.

#include <cstdint>
#include <optional>
#include <vector>

#include "meshmark/forensics/registry.h"
#include "meshmark/protocol/coding.h"
#include "meshmark/protocol/key.h"

namespace meshmark {

/// Issued codewords at least this far apart (bits) when a registry issues them: a clean copy
/// of one buyer then matches another issued buyer's codeword in at most nb - 16 bits, where an
/// innocent's p-value is about 6e-5 (nb = 64), far above any detection threshold.
inline constexpr int kIssuedSpacing = 16;

/// The IDs a registry issues for `id:auto`: those whose permuted message (IdCode) lies in the
/// span of IdCode::spaced_message_basis(spacing), taken place by place in a keyed order of that
/// span (docs/format.md 7.3). Any two of them have codewords at least `spacing` bits apart by
/// the construction of the code (a BCH subcode's designed distance), so a new one needs no
/// comparison with the others: only with the copies recorded outside the span (IDs given by
/// hand, copies recorded before registry schema 5), which the registry finds by index
/// (IssuedCopy::spaced_index). The order is keyed so that, to whoever lacks the key, the
/// codewords of two buyers differ by a uniformly random nonzero codeword of the subcode.
class SpacedIds {
 public:
  /// \throw InvalidArgumentError as IdCode's constructor.
  SpacedIds(const IdCode& code, const Key& key, int spacing = kIssuedSpacing);

  /// log2 of the number of positions (the span's dimension, at most 62).
  int dimension() const { return static_cast<int>(basis_.size()); }
  /// log2 of the expected number of IDs among the positions: a position holds an ID when the
  /// permutation's inverse of its message has zero check bits (probability 2^-check_bits).
  int log2_capacity() const { return dimension() - code_.check_bits(); }
  /// The ID at a place (< 2^dimension()), or none when it holds none (or ID 0, never issued).
  std::optional<std::uint64_t> id_at(std::uint64_t place) const;
  /// 1 + the place of id, or 0 when id lies outside the span.
  std::uint64_t index_of(std::uint64_t id) const;

 private:
  // The keyed permutation of the places onto the span's coordinates (and back).
  std::uint64_t order(std::uint64_t position, bool inverse) const;
  IdCode code_;
  Key key_;
  Key order_key_;                                 // derive_key(key, "spaced-order")
  std::vector<std::vector<std::uint8_t>> basis_;  // reduced row echelon form
  std::vector<int> pivots_;                       // each basis row's leading bit
};

/// One copy too close to another: `copy` (to issue) and `near` (issued, or earlier in the
/// batch), and the distance of their codewords.
struct CloseCodeword {
  IssuedCopy copy, near;
  int distance = 0;
};

/// The copies among `copies` (coded IDs under key, one original) whose codeword is closer than
/// spacing bits to the codeword of a copy recorded in registry for the same original, key,
/// bits and ID length, or of an earlier copy in `copies`.
std::vector<CloseCodeword> close_codewords(const Registry& registry,
                                           const std::vector<IssuedCopy>& copies, const Key& key,
                                           int spacing = kIssuedSpacing);

/// IDs for new copies, chosen by the registry (`id:auto`, `--id auto`): for each copy of
/// `wanted` in order (its id ignored; original, bits and ID length used), an ID >= 1 that is
/// neither recorded in registry for that original, key, bits and ID length nor held by a copy
/// of `taken` (the other copies of this issue) or an earlier one of `wanted`, and whose
/// codeword is at least spacing bits from all of theirs.
/// - spacing <= kIssuedSpacing and a code whose SpacedIds hold at least 2^10 IDs (every code of
///   64 bits and more): the next ID of SpacedIds after the largest position recorded for the
///   group, compared only with the group's copies outside the span. Its cost does not grow
///   with the registry.
/// - Otherwise: the smallest such ID, compared with every copy of the group.
/// Throws InvalidArgumentError when no such ID is found (every position taken, or none among
/// the next 10^6 IDs).
std::vector<std::uint64_t> free_ids(const Registry& registry, const std::vector<IssuedCopy>& taken,
                                    const std::vector<IssuedCopy>& wanted, const Key& key,
                                    int spacing = kIssuedSpacing);

}  // namespace meshmark
