#include "meshmark/protocol/detect.h"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <cmath>

#include "core/parallel.h"
#include "meshmark/core/error.h"

namespace meshmark {

double binomial_tail(int n, int k) {
  if (k <= 0) return 1.0;
  if (k > n) return 0.0;
  // log C(n, i) - n log 2 for i = k..n, summed with a running maximum (log-sum-exp).
  const double log_half_n = n * std::log(0.5);
  auto log_term = [&](int i) {
    return std::lgamma(n + 1.0) - std::lgamma(i + 1.0) - std::lgamma(n - i + 1.0) + log_half_n;
  };
  // Terms decrease from i = max(k, n/2) on, and k is the largest term when k >= n/2.
  double top = log_term(k);
  for (int i = k; i <= n; ++i) top = std::max(top, log_term(i));
  double sum = 0;
  for (int i = k; i <= n; ++i) sum += std::exp(log_term(i) - top);
  return std::min(1.0, std::exp(top) * sum);
}

const char* null_model_name(NullModel model) {
  return enum_name(model);
}

namespace {

void check_threshold(const DetectOptions& options) {
  if (!(options.threshold > 0 && options.threshold < 1))
    throw InvalidArgumentError(
        fmt::format("the detection threshold {} is out of (0, 1)", options.threshold));
}

DetectResult count_matches(const std::vector<std::uint8_t>& bits, const Payload& expected) {
  if (static_cast<int>(bits.size()) != expected.size())
    throw InvalidArgumentError(fmt::format("{} bits read for an expected payload of {} bits",
                                           bits.size(), expected.size()));
  DetectResult r;
  r.compared = expected.size();
  for (std::size_t j = 0; j < bits.size(); ++j) {
    if (bits[j] > 1)
      ++r.erasures;
    else if (bits[j] == expected.bits[j])
      ++r.matches;
  }
  return r;
}

// 128-bit integers for the exact MacWilliams sums (a GCC/Clang extension).
__extension__ typedef __int128 Int128;

// Largest dual dimension enumerated exactly (2^30 words: a few seconds).
constexpr int kMaxExactDual = 30;

// A basis of the subspace of span(rows) whose words vanish on the positions of erased:
// Gaussian elimination of each erased position.
std::vector<std::uint64_t> shorten(std::vector<std::uint64_t> rows, std::uint64_t erased) {
  for (int bit = 0; bit < 64; ++bit) {
    const std::uint64_t b = std::uint64_t(1) << bit;
    if (!(erased & b)) continue;
    const auto pivot = std::find_if(rows.begin(), rows.end(), [&](auto r) { return r & b; });
    if (pivot == rows.end()) continue;
    const std::uint64_t p = *pivot;
    rows.erase(pivot);
    for (auto& r : rows)
      if (r & b) r ^= p;
  }
  return rows;
}

// Over the words u = a[i] ^ b[j] for j in [first, last): count[2 wt(u) + (wt(u & word) mod 2)].
// Eight interleaved histograms keep the increments independent.
__attribute__((target_clones("popcnt", "default"))) std::vector<std::uint64_t> pair_weight_counts(
    const std::vector<std::uint64_t>& a, const std::vector<std::uint64_t>& b, std::size_t first,
    std::size_t last, std::uint64_t word) {
  std::vector<std::uint32_t> h(8 * 130, 0);
  std::vector<std::uint64_t> count(130, 0);
  for (std::size_t j = first; j < last; ++j) {
    const std::uint64_t hb = b[j];
    std::size_t i = 0;
    for (; i + 8 <= a.size(); i += 8)
      for (int lane = 0; lane < 8; ++lane) {
        const std::uint64_t u = a[i + lane] ^ hb;
        ++h[130 * lane + 2 * std::popcount(u) + (std::popcount(u & word) & 1)];
      }
    for (; i < a.size(); ++i) {
      const std::uint64_t u = a[i] ^ hb;
      ++h[2 * std::popcount(u) + (std::popcount(u & word) & 1)];
    }
    // Flush before a 32-bit lane could overflow (each row of b adds at most |a| per lane).
    for (std::size_t q = 0; q < h.size(); ++q) count[q % 130] += h[q];
    std::fill(h.begin(), h.end(), 0);
  }
  return count;
}

// Over the 2^rows.size() words u of span(rows): count[2 wt(u) + (wt(u & word) mod 2)]. The
// span is split in two halves whose words are listed, then every pair is combined, the second
// half's words cut into chunks on the thread budget (integer counts: the same sums whatever
// the cut).
std::vector<std::uint64_t> dual_weight_counts(const std::vector<std::uint64_t>& rows,
                                              std::uint64_t word) {
  const std::size_t low = rows.size() / 2, high = rows.size() - low;
  auto span = [&](std::size_t first, std::size_t count) {
    std::vector<std::uint64_t> words(std::size_t(1) << count, 0);
    for (std::size_t i = 1; i < words.size(); ++i)
      words[i] = words[i & (i - 1)] ^ rows[first + std::countr_zero(i)];
    return words;
  };
  const std::vector<std::uint64_t> a = span(0, low), b = span(low, high);
  // Enough pairs per chunk to be worth a thread (2^20), at most the budget's chunks.
  const auto pairs = static_cast<std::int64_t>(a.size() * b.size());
  const int chunks = pairs < (std::int64_t{1} << 20)
                         ? 1
                         : static_cast<int>(std::min<std::int64_t>(
                               detail::thread_budget(), static_cast<std::int64_t>(b.size())));
  std::vector<std::vector<std::uint64_t>> parts(static_cast<std::size_t>(chunks));
  const auto n = static_cast<std::int64_t>(b.size());
  (void)detail::parallel_for(chunks, chunks, [&](std::int64_t c) {
    parts[c] = pair_weight_counts(a, b, static_cast<std::size_t>(n * c / chunks),
                                  static_cast<std::size_t>(n * (c + 1) / chunks), word);
  });
  std::vector<std::uint64_t> count(130, 0);
  for (const std::vector<std::uint64_t>& part : parts)
    for (std::size_t q = 0; q < count.size(); ++q) count[q] += part[q];
  return count;
}

}  // namespace

CodewordNull::CodewordNull(const IdCode& code, const std::vector<std::uint8_t>& bits,
                           const Key& key) {
  const int n = code.bits();
  if (static_cast<int>(bits.size()) != n)
    throw InvalidArgumentError(fmt::format("{} bits read for a code of {} bits", bits.size(), n));
  int readable = 0;
  for (const std::uint8_t b : bits) readable += b <= 1;
  tail_.assign(n + 2, 0.0);
  const int dual = n - code.message_bits();
  if (n <= 64 && dual <= kMaxExactDual) {
    model_ = NullModel::CodewordExact;
    // MacWilliams for the coset w + C_P of the code punctured on the readable positions: the
    // number of its words of weight i, divided by |C_P|, is
    //   2^-n' sum over u in C_P^perp of (-1)^(u.w) K_i(wt u),
    // K_i(j) the coefficient of z^i in (1 - z)^j (1 + z)^(n' - j), and C_P^perp is the set of
    // dual codewords that vanish on the unreadable positions.
    const std::vector<std::uint8_t> offset = code.mask(key);
    std::uint64_t word = 0, erased = 0;
    for (int j = 0; j < n; ++j) {
      if (bits[j] <= 1 && (bits[j] ^ offset[j])) word |= std::uint64_t(1) << j;
      if (bits[j] > 1) erased |= std::uint64_t(1) << j;
    }
    std::vector<std::uint64_t> rows;
    for (const std::vector<std::uint8_t>& row : code.dual_basis()) {
      std::uint64_t u = 0;
      for (int j = 0; j < n; ++j)
        if (row[j]) u |= std::uint64_t(1) << j;
      rows.push_back(u);
    }
    const std::vector<std::uint64_t> count = dual_weight_counts(shorten(rows, erased), word);
    // Per weight j: cumulative Krawtchouk sums, exact in 128-bit integers (|sum| <= 2^n').
    const int np = readable;
    std::vector<Int128> poly;
    std::vector<Int128> numerator(np + 1, 0);  // numerator[D]: distance <= D
    for (int j = 0; j <= np; ++j) {
      const Int128 signed_count =
          static_cast<Int128>(count[2 * j]) - static_cast<Int128>(count[2 * j + 1]);
      if (signed_count == 0) continue;
      poly.assign(np + 1, 0);
      poly[0] = 1;
      for (int f = 0; f < np; ++f) {  // times (1 - z) for the first j factors, (1 + z) after
        const int sign = f < j ? -1 : 1;
        for (int i = f + 1; i >= 1; --i) poly[i] += sign * poly[i - 1];
      }
      Int128 cumulative = 0;
      for (int D = 0; D <= np; ++D) numerator[D] += signed_count * (cumulative += poly[D]);
    }
    for (int m = 0; m <= n + 1; ++m) {
      const int D = np - m;  // at least m matches = at most np - m disagreements
      if (D < 0) continue;
      if (numerator[D] < 0) throw Error("negative MacWilliams count (a bug)");
      tail_[m] = std::min(1.0L, std::ldexp(static_cast<long double>(numerator[D]), -np));
    }
  } else {
    model_ = NullModel::CodewordBound;
    int systematic = 0;
    for (int j = 0; j < code.message_bits(); ++j) systematic += bits[j] <= 1;
    for (int m = 0; m <= n + 1; ++m) {
      const int D = readable - m;
      if (D < 0) continue;
      tail_[m] = binomial_tail(systematic, systematic - D);
    }
  }
}

double CodewordNull::p_value(int matches) const {
  if (matches <= 0) return 1.0;
  if (matches >= static_cast<int>(tail_.size())) return 0.0;
  return tail_[matches];
}

DetectResult detect(const std::vector<std::uint8_t>& bits, const Payload& expected,
                    const DetectOptions& options) {
  check_threshold(options);
  DetectResult r = count_matches(bits, expected);
  r.p_value = binomial_tail(r.compared, r.matches);
  r.detected = r.p_value < options.threshold;
  r.model = NullModel::Binomial;
  return r;
}

DetectResult detect_id(const std::vector<std::uint8_t>& bits, const Payload& codeword,
                       const CodewordNull& null, const DetectOptions& options,
                       const IdDecodeResult* decoded, std::uint64_t expected_id) {
  check_threshold(options);
  DetectResult r = count_matches(bits, codeword);
  r.p_value = null.p_value(r.matches);
  r.decodes_to_other = decoded && decoded->valid && decoded->id != expected_id;
  if (r.decodes_to_other) r.other_id = decoded->id;
  r.detected = r.p_value < options.threshold && !r.decodes_to_other;
  r.model = null.model();
  return r;
}

}  // namespace meshmark
