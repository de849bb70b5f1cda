#pragma once
/// \file spacing.h
/// The registry's spacing rule for coded IDs: codewords issued under one key for one original
/// stay at least kIssuedSpacing bits apart, so that a clean copy of one buyer is never taken
/// for another (docs/forensics.md). Checked when copies are issued (issue.h), and used to pick
/// IDs for `id:auto`.

#include <cstdint>
#include <vector>

#include "meshmark/forensics/registry.h"
#include "meshmark/protocol/key.h"

namespace meshmark {

/// Issued codewords at least this far apart (bits) when a registry issues them: a clean copy
/// of one buyer then matches another issued buyer's codeword in at most nb - 16 bits, where an
/// innocent's p-value is about 6e-5 (nb = 64), far above any detection threshold.
inline constexpr int kIssuedSpacing = 16;

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
/// `wanted` in order (its id ignored; original, bits and ID length used), the smallest ID >= 1
/// that is neither recorded in registry for that original, key, bits and ID length nor held by
/// a copy of `taken` (the other copies of this issue) or an earlier one of `wanted`, and whose
/// codeword is at least spacing bits from all of theirs. Throws InvalidArgumentError when no
/// such ID is found among the next 10^6.
std::vector<std::uint64_t> free_ids(const Registry& registry, const std::vector<IssuedCopy>& taken,
                                    const std::vector<IssuedCopy>& wanted, const Key& key,
                                    int spacing = kIssuedSpacing);

}  // namespace meshmark
