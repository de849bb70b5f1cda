#include "meshmark/protocol/coding.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <numeric>
#include <set>

#include "meshmark/core/error.h"

namespace meshmark {

std::uint64_t parse_id(const std::string& text) {
  // Decimal digits (leading zeros are still decimal: "0100" is one hundred, never octal), or 0x
  // and hexadecimal digits; nothing else, not even a space: a mistyped ID must never become
  // another buyer's.
  const bool hex = text.size() > 2 && text[0] == '0' && (text[1] == 'x' || text[1] == 'X');
  const std::string digits = hex ? text.substr(2) : text;
  const auto is_digit = [hex](unsigned char c) { return hex ? std::isxdigit(c) : std::isdigit(c); };
  if (digits.empty() || !std::all_of(digits.begin(), digits.end(), is_digit))
    throw InvalidArgumentError(fmt::format(
        "ID '{}' is not a non-negative integer (decimal digits, or 0x and hexadecimal digits)",
        text));
  errno = 0;
  char* end = nullptr;
  const unsigned long long value = std::strtoull(digits.c_str(), &end, hex ? 16 : 10);
  if (errno != 0 || *end != '\0')
    throw InvalidArgumentError(fmt::format("ID '{}' is out of range (at most 2^64 - 1)", text));
  return value;
}

namespace {

// Primitive polynomials of GF(2^m), m = 3..10 (bit i = coefficient of x^i).
constexpr int kPrimitive[11] = {0, 0, 0, 0xB, 0x13, 0x25, 0x43, 0x89, 0x11D, 0x211, 0x409};

// The exponents of the roots of g: the union of the cyclotomic cosets of 1..2t modulo 2^m - 1.
std::set<int> generator_roots(int m, int t) {
  const int N = (1 << m) - 1;
  std::set<int> roots;
  for (int i = 1; i <= 2 * t; ++i)
    for (int j = i % N; roots.insert(j).second; j = (2 * j) % N) {
    }
  return roots;
}

// Gauss-Jordan elimination over GF(2) on the first `columns` columns of rows (whole rows
// XORed): the pivot rows end first, in column order, each pivot alone in its column. Returns
// their number.
std::size_t eliminate(std::vector<std::vector<std::uint8_t>>& rows, int columns) {
  std::size_t pivots = 0;
  for (int col = 0; col < columns && pivots < rows.size(); ++col) {
    std::size_t p = pivots;
    while (p < rows.size() && !rows[p][col]) ++p;
    if (p == rows.size()) continue;
    std::swap(rows[p], rows[pivots]);
    for (std::size_t q = 0; q < rows.size(); ++q)
      if (q != pivots && rows[q][col])
        for (std::size_t j = col; j < rows[q].size(); ++j) rows[q][j] ^= rows[pivots][j];
    ++pivots;
  }
  return pivots;
}

}  // namespace

double log2_hamming_ball(int n, int t) {
  double sum = 0;
  for (int i = 0; i <= std::min(t, n); ++i)
    sum += std::exp(std::lgamma(n + 1.0) - std::lgamma(i + 1.0) - std::lgamma(n - i + 1.0));
  return std::log2(sum);
}

const char* id_decode_status_name(IdDecodeStatus status) {
  return enum_name(status);
}

int bch_parity_bits(int m, int t) {
  if (m < 3 || m > 10) throw InvalidArgumentError(fmt::format("GF(2^{}) is out of 3..10", m));
  if (t < 0 || 2 * t >= (1 << m) - 1)
    throw InvalidArgumentError(fmt::format("t = {} is out of range for GF(2^{})", t, m));
  return static_cast<int>(generator_roots(m, t).size());
}

IdCode::IdCode(const IdCodeOptions& o) : n_(o.bits), id_bits_(o.id_bits), retries_(o.retries) {
  if (o.retries < 0 || o.retries > 1000)
    throw InvalidArgumentError(fmt::format("{} retries is out of 0..1000", o.retries));
  if (o.bits < 8 || o.bits > 1024)
    throw InvalidArgumentError(fmt::format("a coded payload needs 8..1024 bits, not {}", o.bits));
  if (o.id_bits < 1 || o.id_bits > 32)
    throw InvalidArgumentError(fmt::format("an ID has 1..32 bits, not {}", o.id_bits));
  if (!(o.false_accept > 0 && o.false_accept < 1))
    throw InvalidArgumentError(
        fmt::format("the false-accept bound {} is out of (0, 1)", o.false_accept));
  if (o.min_check_bits < 0 || o.min_check_bits > 512)
    throw InvalidArgumentError(
        fmt::format("the check length {} is out of 0..512", o.min_check_bits));
  const int inner = n_ - 1;  // shortened BCH length; the last bit is the overall parity
  m_ = 3;
  while ((1 << m_) - 1 < inner) ++m_;
  // The largest t whose code leaves k >= id_bits + min_check_bits message bits (or the t asked
  // for). 2t + 1 < 2^m - 1 keeps the code non-trivial.
  const int k_needed = id_bits_ + o.min_check_bits;
  t_ = -1;
  if (o.correction >= 0) {
    if (2 * o.correction + 1 < (1 << m_) - 1 &&
        inner - bch_parity_bits(m_, o.correction) >= k_needed)
      t_ = o.correction;
  } else {
    for (int t = 0; 2 * t + 1 < (1 << m_) - 1; ++t)
      if (inner - bch_parity_bits(m_, t) >= k_needed) t_ = t;
  }
  // Acceptance rules (class comment): the widest first, (0 weak, e0 errors) with e0 <= t as
  // large as the bound allows; then, for fewer errors e, as many weak bits s <= t - e as the
  // remaining budget allows, when that accepts words the earlier rules do not (s + e > e0).
  auto term = [&](int weak, int errors) {
    return std::exp2(id_bits_ - (n_ - weak) + log2_hamming_ball(n_ - weak, errors));
  };
  // The retries' share is reserved first at their strictest rule (0, 0).
  const double reserve = retries_ * term(0, 0);
  const double main_budget = o.false_accept - reserve;
  if (t_ >= 0) {
    int e0 = -1;
    for (int e = 0; e <= t_; ++e)
      if (main_budget > 0 && std::log2(term(0, e)) <= std::log2(main_budget)) e0 = e;
    if (e0 < 0) t_ = -1;
    if (t_ >= 0) {
      double budget = main_budget - term(0, e0);
      rules_.push_back({0, e0});
      int reach = e0;  // s + e of the widest rule so far
      for (int e = e0 - 1; e >= 0; --e)
        for (int s = t_ - e; s + e > reach; --s)
          if (term(s, e) <= budget) {
            rules_.push_back({s, e});
            budget -= term(s, e);
            reach = s + e;
            break;
          }
      // The retry rule: as many errors as the rest of the budget allows.
      double used = 0;
      for (const DecodeRule& r : rules_) used += term(r.weak, r.errors);
      retry_rule_ = {0, 0};
      for (int e = 1; e <= t_; ++e)
        if (used + retries_ * term(0, e) <= o.false_accept) retry_rule_.errors = e;
    }
  }
  if (t_ < 0)
    throw InvalidArgumentError(fmt::format(
        "a {}-bit ID does not fit in {} payload bits{} at a false-accept bound of {:g}; use more "
        "bits or a shorter ID",
        id_bits_, n_,
        o.correction >= 0 ? fmt::format(" with a code correcting {} errors", o.correction) : "",
        o.false_accept));
  const std::set<int> roots = generator_roots(m_, t_);
  r_ = static_cast<int>(roots.size());
  k_ = inner - r_;

  const int N = (1 << m_) - 1;
  exp_.assign(2 * N, 0);
  log_.assign(N + 1, 0);
  for (int i = 0, x = 1; i < N; ++i) {
    exp_[i] = exp_[i + N] = x;
    log_[x] = i;
    x <<= 1;
    if (x & (1 << m_)) x ^= kPrimitive[m_];
  }
  // g(x) = prod over the roots of (x - alpha^j), computed in GF(2^m); its coefficients are 0/1.
  std::vector<int> g = {1};
  for (const int j : roots) {
    std::vector<int> next(g.size() + 1, 0);
    for (std::size_t i = 0; i < g.size(); ++i) {
      next[i + 1] ^= g[i];
      if (g[i]) next[i] ^= exp_[(log_[g[i]] + j) % N];
    }
    g = std::move(next);
  }
  generator_.resize(g.size());
  for (std::size_t i = 0; i < g.size(); ++i) {
    if (g[i] > 1) throw Error("BCH generator has a coefficient outside GF(2) (a bug)");
    generator_[i] = static_cast<std::uint8_t>(g[i]);
  }
}

double IdCode::false_accept_bound() const {
  double sum = 0;
  for (const DecodeRule& r : rules_)
    sum += std::exp2(id_bits_ - (n_ - r.weak) + log2_hamming_ball(n_ - r.weak, r.errors));
  return sum + retries_ * std::exp2(id_bits_ - n_ + log2_hamming_ball(n_, retry_rule_.errors));
}

namespace {

// The Feistel network of IdCode::permute over x = L || R (|L| = a = k/2, |R| = k - a), 8
// rounds; round i replaces one half by itself XOR F_i(the other half), alternately, so it is
// undone by the same rounds in reverse order. F_i = BLAKE2b keyed with the code key, of (i, k,
// id_bits, nb, the half): to_right hashes to k - a bits (the even rounds, which change R from
// L), to_left to a bits (the odd ones); either is null when its half is empty.
constexpr int kFeistelRounds = 8;

// The last input and output of round 0, which consecutive IDs share (its input is the high
// half of the message: check bits and the ID's high bits).
struct FirstRound {
  std::array<std::uint8_t, 6 + 64> data{};
  std::size_t size = 0;
  std::array<std::uint8_t, 64> f{};
};

// Round `round` of the network on x: which half it changes (right: R from L), and its hash's
// input, (round, k, id_bits, nb, the other half packed MSB first) into data; returns its size
// in bytes, or 0 when the half it changes is empty (the round does nothing).
std::size_t round_input(const std::uint8_t* x, int k, int id_bits, int n, int round,
                        std::array<std::uint8_t, 6 + 64>& data) {
  const int a = k / 2;                // k < 1024: a half fits in 64 bytes
  const bool right = round % 2 == 0;  // even rounds change R from L, odd ones L from R
  const int from = right ? 0 : a, from_len = right ? a : k - a;
  if ((right ? k - a : a) == 0) return 0;
  const std::size_t size = 6 + static_cast<std::size_t>(from_len + 7) / 8;
  std::fill(data.begin(), data.begin() + static_cast<std::ptrdiff_t>(size), 0);
  data[0] = static_cast<std::uint8_t>(round);
  data[1] = static_cast<std::uint8_t>(k & 0xFF), data[2] = static_cast<std::uint8_t>(k >> 8);
  data[3] = static_cast<std::uint8_t>(id_bits);
  data[4] = static_cast<std::uint8_t>(n & 0xFF), data[5] = static_cast<std::uint8_t>(n >> 8);
  for (int i = 0; i < from_len; ++i)
    data[6 + i / 8] |= static_cast<std::uint8_t>(x[from + i] << (7 - i % 8));
  return size;
}

// The round's output: the half it changes XOR the hash f (MSB first).
void round_output(std::uint8_t* x, int k, int round, const std::uint8_t* f) {
  const int a = k / 2;
  const bool right = round % 2 == 0;
  const int to = right ? a : 0, to_len = right ? k - a : a;
  for (int i = 0; i < to_len; ++i) x[to + i] ^= (f[i / 8] >> (7 - i % 8)) & 1;
}

// Round 0 of x through memo: hashed only when its input differs from the last one's.
void first_round(std::uint8_t* x, int k, int id_bits, int n, const KeyedHash& to_right,
                 FirstRound& memo) {
  std::array<std::uint8_t, 6 + 64> data{};
  const std::size_t size = round_input(x, k, id_bits, n, 0, data);
  if (size == 0) return;
  if (memo.size != size || !std::equal(data.begin(), data.begin() + size, memo.data.begin())) {
    std::copy(data.begin(), data.begin() + size, memo.data.begin());
    memo.size = size;
    to_right.digest(data.data(), size, memo.f.data());
  }
  round_output(x, k, 0, memo.f.data());
}

void feistel(std::uint8_t* x, int k, int id_bits, int n, const KeyedHash* to_right,
             const KeyedHash* to_left, bool inverse, FirstRound* memo = nullptr) {
  std::array<std::uint8_t, 6 + 64> data{};
  std::array<std::uint8_t, 64> f{};
  for (int step = 0; step < kFeistelRounds; ++step) {
    const int round = inverse ? kFeistelRounds - 1 - step : step;
    if (memo && round == 0) {
      first_round(x, k, id_bits, n, *to_right, *memo);
      continue;
    }
    const std::size_t size = round_input(x, k, id_bits, n, round, data);
    if (size == 0) continue;
    (round % 2 == 0 ? to_right : to_left)->digest(data.data(), size, f.data());
    round_output(x, k, round, f.data());
  }
}

// The forward network on four messages at once: round 0 through memo (consecutive IDs share
// it), the others' hashes four at a time (KeyedHash::digest4). The halves' lengths, so the
// inputs' sizes, are the same for the four.
void feistel4(const std::array<std::uint8_t*, 4>& x, int k, int id_bits, int n,
              const KeyedHash* to_right, const KeyedHash* to_left, FirstRound& memo) {
  std::array<std::array<std::uint8_t, 6 + 64>, 4> data{};
  std::array<std::array<std::uint8_t, 64>, 4> f{};
  const std::array<const std::uint8_t*, 4> in = {data[0].data(), data[1].data(), data[2].data(),
                                                 data[3].data()};
  const std::array<std::uint8_t*, 4> out = {f[0].data(), f[1].data(), f[2].data(), f[3].data()};
  for (int round = 0; round < kFeistelRounds; ++round) {
    if (round == 0) {
      if (to_right)
        for (std::uint8_t* lane : x) first_round(lane, k, id_bits, n, *to_right, memo);
      continue;
    }
    std::size_t size = 0;
    for (int l = 0; l < 4; ++l) size = round_input(x[l], k, id_bits, n, round, data[l]);
    if (size == 0) continue;
    (round % 2 == 0 ? to_right : to_left)->digest4(in, size, out);
    for (int l = 0; l < 4; ++l) round_output(x[l], k, round, f[l].data());
  }
}

}  // namespace

std::vector<std::uint8_t> IdCode::permute(std::vector<std::uint8_t> x, const Key& code_key,
                                          bool inverse) const {
  const int a = k_ / 2;
  const std::optional<KeyedHash> to_right =
      k_ - a > 0 ? std::optional<KeyedHash>(std::in_place, code_key, "id-feistel", k_ - a)
                 : std::nullopt;
  const std::optional<KeyedHash> to_left =
      a > 0 ? std::optional<KeyedHash>(std::in_place, code_key, "id-feistel", a) : std::nullopt;
  feistel(x.data(), k_, id_bits_, n_, to_right ? &*to_right : nullptr,
          to_left ? &*to_left : nullptr, inverse);
  return x;
}

std::vector<std::uint8_t> IdCode::encode_message(const std::vector<std::uint8_t>& message) const {
  // Systematic: message bit i is the coefficient of x^(inner - 1 - i); parity = m(x) x^r mod g.
  const int inner = n_ - 1;
  std::vector<std::uint8_t> c(inner, 0);
  for (int i = 0; i < k_; ++i) c[inner - 1 - i] = message[i] & 1;
  std::vector<std::uint8_t> a = c;
  for (int d = inner - 1; d >= r_; --d)
    if (a[d])
      for (int i = 0; i <= r_; ++i) a[d - r_ + i] ^= generator_[i];
  for (int i = 0; i < r_; ++i) c[i] = a[i];
  std::vector<std::uint8_t> out(n_);
  std::uint8_t parity = 0;
  for (int j = 0; j < inner; ++j) parity ^= out[j] = c[inner - 1 - j];
  out[inner] = parity;
  return out;
}

std::vector<std::uint8_t> IdCode::permuted_message(std::uint64_t id, const Key& key) const {
  if (id_bits_ < 64 && (id >> id_bits_) != 0)
    throw InvalidArgumentError(fmt::format("ID {} does not fit in {} bits", id, id_bits_));
  std::vector<std::uint8_t> x(k_, 0);  // high k - id_bits bits zero, the ID MSB first
  for (int i = 0; i < id_bits_; ++i) x[k_ - id_bits_ + i] = (id >> (id_bits_ - 1 - i)) & 1;
  return permute(std::move(x), derive_key(key, "id-code"), false);
}

std::optional<std::uint64_t> IdCode::message_id(const std::vector<std::uint8_t>& message,
                                                const Key& key) const {
  if (static_cast<int>(message.size()) != k_)
    throw InvalidArgumentError(
        fmt::format("a message of this code has {} bits, not {}", k_, message.size()));
  const std::vector<std::uint8_t> x = permute(message, derive_key(key, "id-code"), true);
  for (int i = 0; i < k_ - id_bits_; ++i)
    if (x[i]) return std::nullopt;
  std::uint64_t id = 0;
  for (int i = 0; i < id_bits_; ++i) id = id << 1 | x[k_ - id_bits_ + i];
  return id;
}

std::vector<std::uint8_t> IdCode::message_codeword(const std::vector<std::uint8_t>& message) const {
  if (static_cast<int>(message.size()) != k_)
    throw InvalidArgumentError(
        fmt::format("a message of this code has {} bits, not {}", k_, message.size()));
  return encode_message(message);
}

std::vector<std::vector<std::uint8_t>> IdCode::spaced_message_basis(int distance) const {
  // The subcode's t': the least with 2t' + 2 >= distance (the overall parity bit makes the
  // inner code's odd minimum 2t' + 1 even).
  const int t2 = std::max(t_, (distance - 1) / 2);
  const int N = (1 << m_) - 1, inner = n_ - 1;
  // Each unit message's syndromes c(alpha^i), 2t < i <= 2t' (m bits each): the messages of
  // the subcode are the kernel of that linear map (its codewords already vanish at i <= 2t).
  const int columns = (2 * t2 - 2 * t_) * m_;
  std::vector<std::vector<std::uint8_t>> rows(k_);  // [syndrome bits | identity]
  std::vector<std::uint8_t> unit(k_, 0);
  for (int l = 0; l < k_; ++l) {
    unit[l] = 1;
    const std::vector<std::uint8_t> c = encode_message(unit);
    unit[l] = 0;
    std::vector<std::uint8_t>& row = rows[l];
    row.assign(columns + k_, 0);
    for (int i = 2 * t_ + 1, col = 0; i <= 2 * t2; ++i, col += m_) {
      int s = 0;
      for (int j = 0; j < inner; ++j)  // coefficient of x^j is payload bit inner - 1 - j
        if (c[inner - 1 - j]) s ^= exp_[(static_cast<long>(i) * j) % N];
      for (int b = 0; b < m_; ++b) row[col + b] = (s >> b) & 1;
    }
    row[columns + l] = 1;
  }
  // Elimination on the syndrome columns: the rows left zero there span the kernel.
  const std::size_t pivots = eliminate(rows, columns);
  std::vector<std::vector<std::uint8_t>> basis;
  for (std::size_t q = pivots; q < rows.size(); ++q)
    basis.emplace_back(rows[q].begin() + columns, rows[q].end());
  eliminate(basis, k_);  // reduced row echelon form over the message bits
  return basis;
}

Payload IdCode::encode(std::uint64_t id, const Key& key) const {
  Payload out;
  out.bits = encode_message(permuted_message(id, key));
  const std::vector<std::uint8_t> offset = mask(key);
  for (int j = 0; j < n_; ++j) out.bits[j] ^= offset[j];
  return out;
}

std::vector<std::uint8_t> IdCode::mask(const Key& key) const {
  const std::vector<std::uint8_t> length = {static_cast<std::uint8_t>(n_ & 0xFF),
                                            static_cast<std::uint8_t>(n_ >> 8)};
  std::vector<std::uint8_t> out;
  for (int done = 0; done < n_; done += 512) {  // keyed_hash_bits gives 512 bits at most
    std::vector<std::uint8_t> data = length;
    data.push_back(static_cast<std::uint8_t>(done / 512));
    const std::vector<std::uint8_t> part =
        keyed_hash_bits(derive_key(key, "id-code"), "id-mask", data, std::min(512, n_ - done));
    out.insert(out.end(), part.begin(), part.end());
  }
  return out;
}

std::vector<std::vector<std::uint8_t>> IdCode::dual_basis() const {
  // The generator in payload order is [I_k | P]; the dual is spanned by [P^T | I_(n-k)].
  std::vector<std::vector<std::uint8_t>> rows(n_ - k_, std::vector<std::uint8_t>(n_, 0));
  std::vector<std::uint8_t> unit(k_, 0);
  for (int i = 0; i < k_; ++i) {
    unit[i] = 1;
    const std::vector<std::uint8_t> g = encode_message(unit);
    unit[i] = 0;
    for (int p = k_; p < n_; ++p) rows[p - k_][i] = g[p];
  }
  for (int p = k_; p < n_; ++p) rows[p - k_][p] = 1;
  return rows;
}

int IdCode::decode_bch(std::vector<std::uint8_t>& c) const {
  if (t_ == 0) return 0;
  const int N = (1 << m_) - 1, inner = static_cast<int>(c.size());
  std::vector<int> S(2 * t_ + 1, 0);
  bool any = false;
  for (int i = 1; i <= 2 * t_; ++i) {
    int s = 0;
    for (int j = 0; j < inner; ++j)
      if (c[j]) s ^= exp_[(static_cast<long>(i) * j) % N];
    S[i] = s;
    any |= s != 0;
  }
  if (!any) return 0;
  auto mul = [&](int a, int b) { return a && b ? exp_[log_[a] + log_[b]] : 0; };
  auto div = [&](int a, int b) { return a ? exp_[(log_[a] - log_[b] + N) % N] : 0; };
  // Berlekamp-Massey: the error locator sigma of least degree L.
  std::vector<int> C(2 * t_ + 2, 0), B(2 * t_ + 2, 0);
  C[0] = B[0] = 1;
  int L = 0, shift = 1, b = 1;
  for (int n = 0; n < 2 * t_; ++n) {
    int d = S[n + 1];
    for (int i = 1; i <= L; ++i) d ^= mul(C[i], S[n + 1 - i]);
    if (d == 0) {
      ++shift;
      continue;
    }
    const std::vector<int> T = C;
    const int coef = div(d, b);
    for (std::size_t i = 0; i + shift < C.size(); ++i) C[i + shift] ^= mul(coef, B[i]);
    if (2 * L <= n) {
      L = n + 1 - L;
      B = T;
      b = d;
      shift = 1;
    } else {
      ++shift;
    }
  }
  if (L > t_) return -1;
  // Chien search over the positions of the shortened code: error at j iff sigma(alpha^-j) = 0.
  std::vector<int> errors;
  for (int j = 0; j < inner; ++j) {
    int v = 0;
    for (int i = 0; i <= L; ++i)
      if (C[i]) v ^= exp_[(log_[C[i]] + static_cast<long>(N - j % N) * i) % N];
    if (v == 0) errors.push_back(j);
  }
  if (static_cast<int>(errors.size()) != L) return -1;  // roots outside the code: too many errors
  for (const int j : errors) c[j] ^= 1;
  return L;
}

IdDecodeResult IdCode::decode(const std::vector<std::uint8_t>& bits,
                              const std::vector<double>& margins, const Key& key,
                              bool retry) const {
  if (static_cast<int>(bits.size()) != n_ || (!margins.empty() && margins.size() != bits.size()))
    throw InvalidArgumentError(fmt::format("{} bits and {} margins read for a code of {} bits",
                                           bits.size(), margins.size(), n_));
  const int inner = n_ - 1;
  IdDecodeResult result;
  std::vector<std::uint8_t> hard(n_);
  std::vector<double> reliability(n_, 1.0);
  const std::vector<std::uint8_t> offset = mask(key);
  for (int j = 0; j < n_; ++j) {
    hard[j] = (bits[j] == 1) ^ offset[j];  // the mask removed: a word of the linear code
    result.erasures += bits[j] > 1;
    if (bits[j] > 1)
      reliability[j] = -1.0;  // before every readable bit
    else if (!margins.empty())
      reliability[j] = std::isfinite(margins[j]) ? std::abs(margins[j]) : 0.0;
  }
  if (result.erasures > t_) {
    result.status = IdDecodeStatus::Unreadable;
    result.message = fmt::format(
        "{} of {} bits are unreadable (empty bins), more than the {} the code can tolerate: the "
        "mesh is collapsed, too coarse, or not this mesh",
        result.erasures, n_, t_);
    return result;
  }
  // The only codeword that can be accepted lies within t of the hard decisions (erasures read
  // as 0 are at most as far as erasures counted as errors), and BCH decoding finds it.
  std::vector<std::uint8_t> c(inner);
  for (int j = 0; j < inner; ++j) c[j] = hard[inner - 1 - j];
  if (decode_bch(c) < 0) {
    result.message = "too many bit errors, or no watermark";
    return result;
  }
  std::vector<std::uint8_t> codeword(n_);
  std::uint8_t parity = 0;
  for (int j = 0; j < inner; ++j) parity ^= codeword[j] = c[inner - 1 - j];
  codeword[inner] = parity;
  std::vector<int> order(n_);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return reliability[a] < reliability[b]; });
  std::vector<std::uint8_t> differs(n_);
  for (int j = 0; j < n_; ++j) {
    differs[j] = bits[j] > 1 || codeword[j] != hard[j];
    if (differs[j]) ++result.corrected, result.soft_distance += std::max(0.0, reliability[j]);
  }
  bool accepted = false;
  const std::vector<DecodeRule> retry_rules = {retry_rule_};
  for (const DecodeRule& rule : retry ? retry_rules : rules_) {
    if (rule.weak > 0 && margins.empty()) continue;
    int errors = 0;
    for (int i = rule.weak; i < n_; ++i) errors += differs[order[i]];
    accepted |= errors <= rule.errors && result.corrected <= t_;
  }
  if (!accepted) {
    result.message = fmt::format(
        "the nearest codeword differs in {} bits, too many of them reliable: too many bit "
        "errors, or no watermark",
        result.corrected);
    return result;
  }
  const std::optional<std::uint64_t> id =
      message_id(std::vector<std::uint8_t>(codeword.begin(), codeword.begin() + k_), key);
  if (!id) {
    result.status = IdDecodeStatus::NotUnderKey;
    result.message = "a codeword, but of no ID under this key: another key, or damage";
    return result;
  }
  result.id = *id;
  result.status = IdDecodeStatus::Found;
  result.valid = true;
  result.message = fmt::format("ID found, {} of {} bits corrected", result.corrected, n_);
  return result;
}

CodewordEncoder::CodewordEncoder(const IdCode& code, const Key& key)
    : n_(code.bits()), k_(code.message_bits()), id_bits_(code.id_bits()) {
  const Key code_key = derive_key(key, "id-code");
  const int a = k_ / 2;
  if (k_ - a > 0) to_right_.emplace(code_key, "id-feistel", k_ - a);
  if (a > 0) to_left_.emplace(code_key, "id-feistel", a);
  const int w = words();
  rows_.assign(static_cast<std::size_t>(k_) * w, 0);
  std::vector<std::uint8_t> unit(k_, 0);
  for (int i = 0; i < k_; ++i) {  // the codeword is linear in the message: one row per bit
    unit[i] = 1;
    const std::vector<std::uint8_t> c = code.message_codeword(unit);
    unit[i] = 0;
    for (int j = 0; j < n_; ++j)
      if (c[j]) rows_[static_cast<std::size_t>(i) * w + j / 64] |= std::uint64_t{1} << (j % 64);
  }
  // The codewords of every byte of the message: 8 bits at once (the code is linear).
  const int groups = (k_ + 7) / 8;
  bytes_.assign(static_cast<std::size_t>(groups) * 256 * w, 0);
  for (int g = 0; g < groups; ++g)
    for (int v = 1; v < 256; ++v)
      for (int b = 0; b < 8 && 8 * g + b < k_; ++b)
        if ((v >> b) & 1)
          for (int j = 0; j < w; ++j)
            bytes_[(static_cast<std::size_t>(g) * 256 + v) * w + j] ^=
                rows_[static_cast<std::size_t>(8 * g + b) * w + j];
  mask_.assign(w, 0);
  const std::vector<std::uint8_t> m = code.mask(key);
  for (int j = 0; j < n_; ++j)
    if (m[j] & 1) mask_[j / 64] |= std::uint64_t{1} << (j % 64);
}

void CodewordEncoder::encode(const std::uint64_t* ids, std::size_t count,
                             std::uint64_t* out) const {
  FirstRound memo;
  const int w = words();
  // The messages (k < 1024 bits each: high k - id_bits bits 0, the ID MSB first), four at a
  // time through the permutation, the rest one by one.
  std::array<std::array<std::uint8_t, 1024>, 4> x;
  for (std::size_t c = 0; c < count; c += 4) {
    const int lanes = static_cast<int>(std::min<std::size_t>(4, count - c));
    for (int l = 0; l < lanes; ++l) {
      const std::uint64_t id = ids[c + l];
      if (id_bits_ < 64 && (id >> id_bits_) != 0)
        throw InvalidArgumentError(fmt::format("ID {} does not fit in {} bits", id, id_bits_));
      std::fill_n(x[l].begin(), k_ - id_bits_, std::uint8_t{0});
      for (int i = 0; i < id_bits_; ++i) x[l][k_ - id_bits_ + i] = (id >> (id_bits_ - 1 - i)) & 1;
    }
    const KeyedHash* right = to_right_ ? &*to_right_ : nullptr;
    const KeyedHash* left = to_left_ ? &*to_left_ : nullptr;
    if (lanes == 4)
      feistel4({x[0].data(), x[1].data(), x[2].data(), x[3].data()}, k_, id_bits_, n_, right, left,
               memo);
    else
      for (int l = 0; l < lanes; ++l)
        feistel(x[l].data(), k_, id_bits_, n_, right, left, false, right ? &memo : nullptr);
    for (int l = 0; l < lanes; ++l, out += w) {
      for (int j = 0; j < w; ++j) out[j] = mask_[j];
      for (int g = 0; 8 * g < k_; ++g) {
        int v = 0;
        for (int b = 0; b < 8 && 8 * g + b < k_; ++b) v |= x[l][8 * g + b] << b;
        const std::uint64_t* row = bytes_.data() + (static_cast<std::size_t>(g) * 256 + v) * w;
        for (int j = 0; j < w; ++j) out[j] ^= row[j];
      }
    }
  }
}

}  // namespace meshmark
