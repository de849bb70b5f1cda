#include "meshmark/coding.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <set>

#include "meshmark/error.h"

namespace meshmark {

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

// log2 of the Hamming ball volume sum_{i <= t} C(n, i).
double log2_ball(int n, int t) {
  double sum = 0;
  for (int i = 0; i <= t; ++i)
    sum += std::exp(std::lgamma(n + 1.0) - std::lgamma(i + 1.0) - std::lgamma(n - i + 1.0));
  return std::log2(sum);
}

}  // namespace

int bch_parity_bits(int m, int t) {
  if (m < 3 || m > 10) throw InvalidArgumentError(fmt::format("GF(2^{}) is out of 3..10", m));
  if (t < 0 || 2 * t >= (1 << m) - 1)
    throw InvalidArgumentError(fmt::format("t = {} is out of range for GF(2^{})", t, m));
  return static_cast<int>(generator_roots(m, t).size());
}

IdCode::IdCode(const IdCodeOptions& o) : n_(o.bits), id_bits_(o.id_bits) {
  if (o.bits < 8 || o.bits > 1024)
    throw InvalidArgumentError(fmt::format("a coded payload needs 8..1024 bits, not {}", o.bits));
  if (o.id_bits < 1 || o.id_bits > 32)
    throw InvalidArgumentError(fmt::format("an ID has 1..32 bits, not {}", o.id_bits));
  if (!(o.false_accept > 0 && o.false_accept < 1))
    throw InvalidArgumentError(
        fmt::format("the false-accept bound {} is out of (0, 1)", o.false_accept));
  if (o.max_chase < 0 || o.max_chase > 10)
    throw InvalidArgumentError(fmt::format("the Chase depth {} is out of 0..10", o.max_chase));
  const int inner = n_ - 1;  // shortened BCH length; the last bit is the overall parity
  m_ = 3;
  while ((1 << m_) - 1 < inner) ++m_;
  const double log2_target = std::log2(o.false_accept);
  const int free_bits = inner - id_bits_ - std::max(o.min_check_bits, 1);
  bool found = false;
  for (int t = (o.correction >= 0 ? o.correction : ((1 << m_) - 2) / 2); t >= 0 && !found; --t) {
    if (2 * t >= (1 << m_) - 1) continue;
    if (bch_parity_bits(m_, t) > free_bits) {
      if (o.correction >= 0) break;
      continue;
    }
    for (int p = o.max_chase; p >= 0; --p)
      if (p + log2_ball(n_, t) + id_bits_ - n_ <= log2_target) {
        t_ = t, p_ = p, found = true;
        break;
      }
    if (o.correction >= 0) break;
  }
  if (!found)
    throw InvalidArgumentError(fmt::format(
        "a {}-bit ID does not fit in {} payload bits with a check of {} bits and a false-accept "
        "bound of {:g}{}; use more bits",
        id_bits_, n_, std::max(o.min_check_bits, 1), o.false_accept,
        o.correction >= 0 ? fmt::format(" correcting {} errors", o.correction) : ""));
  const std::set<int> roots = generator_roots(m_, t_);
  r_ = static_cast<int>(roots.size());
  check_bits_ = inner - r_ - id_bits_;

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
  return std::exp2(p_ + log2_ball(n_, t_) + id_bits_ - n_);
}

std::vector<std::uint8_t> IdCode::check_of(std::uint64_t id, const Key& key) const {
  if (check_bits_ == 0) return {};
  std::vector<std::uint8_t> data(11);
  for (int i = 0; i < 8; ++i) data[i] = static_cast<std::uint8_t>(id >> (8 * i));
  data[8] = static_cast<std::uint8_t>(id_bits_);
  data[9] = static_cast<std::uint8_t>(n_ & 0xFF);
  data[10] = static_cast<std::uint8_t>(n_ >> 8);
  return keyed_hash_bits(key, "meshmark/id-check/v1", data, check_bits_);
}

Payload IdCode::encode(std::uint64_t id, const Key& key) const {
  if (id_bits_ < 64 && (id >> id_bits_) != 0)
    throw InvalidArgumentError(fmt::format("ID {} does not fit in {} bits", id, id_bits_));
  const int inner = n_ - 1, k = inner - r_;
  std::vector<std::uint8_t> message(k);
  for (int i = 0; i < id_bits_; ++i) message[i] = (id >> (id_bits_ - 1 - i)) & 1;
  const std::vector<std::uint8_t> check = check_of(id, key);
  std::copy(check.begin(), check.end(), message.begin() + id_bits_);
  // Systematic: message bit i is the coefficient of x^(inner - 1 - i); parity = m(x) x^r mod g.
  std::vector<std::uint8_t> c(inner, 0);
  for (int i = 0; i < k; ++i) c[inner - 1 - i] = message[i];
  std::vector<std::uint8_t> a = c;
  for (int d = inner - 1; d >= r_; --d)
    if (a[d])
      for (int i = 0; i <= r_; ++i) a[d - r_ + i] ^= generator_[i];
  for (int i = 0; i < r_; ++i) c[i] = a[i];
  Payload out;
  out.bits.resize(n_);
  std::uint8_t parity = 0;
  for (int j = 0; j < inner; ++j) parity ^= out.bits[j] = c[inner - 1 - j];
  out.bits[inner] = parity;
  return out;
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
                              const std::vector<double>& margins, const Key& key) const {
  if (static_cast<int>(bits.size()) != n_ || (!margins.empty() && margins.size() != bits.size()))
    throw InvalidArgumentError(fmt::format("{} bits and {} margins read for a code of {} bits",
                                           bits.size(), margins.size(), n_));
  const int inner = n_ - 1;
  std::vector<std::uint8_t> hard(n_);
  std::vector<double> reliability(n_, 1.0);
  for (int j = 0; j < n_; ++j) {
    hard[j] = bits[j] == 1;
    if (!margins.empty()) reliability[j] = bits[j] > 1 ? 0.0 : std::abs(margins[j]);
  }
  const int p = margins.empty() ? 0 : p_;
  std::vector<int> order(n_);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return reliability[a] < reliability[b]; });

  IdDecodeResult best;
  bool ambiguous = false;
  std::vector<std::uint8_t> word(n_), c(inner);
  for (int pattern = 0; pattern < (1 << p); ++pattern) {
    word = hard;
    for (int i = 0; i < p; ++i)
      if (pattern >> i & 1) word[order[i]] ^= 1;
    for (int j = 0; j < inner; ++j) c[j] = word[inner - 1 - j];
    const int fixed = decode_bch(c);
    if (fixed < 0) continue;
    std::uint8_t parity = word[inner];
    for (int j = 0; j < inner; ++j) parity ^= c[j];
    if (fixed + parity > t_) continue;  // t + 1 errors: detected, not corrected
    std::uint64_t id = 0;
    for (int i = 0; i < id_bits_; ++i) id = id << 1 | c[inner - 1 - i];
    const std::vector<std::uint8_t> check = check_of(id, key);
    bool ok = true;
    for (int i = 0; i < check_bits_ && ok; ++i) ok = check[i] == c[inner - 1 - id_bits_ - i];
    if (!ok) continue;
    // Distance of the ID's codeword to what was read.
    const Payload codeword = encode(id, key);
    int distance = 0;
    double soft = 0;
    for (int j = 0; j < n_; ++j)
      if (codeword.bits[j] != hard[j] || bits[j] > 1) ++distance, soft += reliability[j];
    if (best.valid && best.id != id) ambiguous = true;
    if (!best.valid || soft < best.soft_distance) {
      best.valid = true;
      best.id = id;
      best.corrected = distance;
      best.soft_distance = soft;
    }
  }
  if (ambiguous) {
    IdDecodeResult none;
    none.message = "two different IDs decode (ambiguous)";
    return none;
  }
  if (!best.valid) {
    best.message = "too many bit errors, another key, or no watermark";
    return best;
  }
  best.message = fmt::format("ID found, {} of {} bits corrected", best.corrected, n_);
  return best;
}

}  // namespace meshmark
