#pragma once
/// \file coding.h
/// Payload coding for forensic IDs: a buyer ID of up to 32 bits, an integrity check (a keyed
/// BLAKE2b hash of the ID), a shortened binary BCH code over GF(2^m) and an overall parity
/// bit, filling the nb payload bits. Decoding is hard-decision BCH (Berlekamp-Massey and
/// Chien search) inside a Chase-II search over the least reliable bits (smallest margins), and
/// reports either the exact ID or "no valid ID".
///
/// The correction radius t and the Chase depth p are chosen so that a uniformly random word
/// (an unmarked mesh, a wrong key: the whitening makes either look uniform) decodes to some
/// valid ID with probability at most
///     2^p * V(nb, t) * 2^(id_bits - nb)       (V: Hamming ball volume)
/// below IdCodeOptions::false_accept. With nb = 64 and a 32-bit ID that is t = 2, p = 1,
/// bound 9.7e-7; nb = 128 gives t = 12.

#include <cstdint>
#include <string>
#include <vector>

#include "meshmark/key.h"
#include "meshmark/payload.h"

namespace meshmark {

/// How to code an ID.
struct IdCodeOptions {
  int bits = 64;               ///< payload length nb (codeword length), 8..1024
  int id_bits = 32;            ///< ID length, 1..32
  double false_accept = 1e-6;  ///< bound on a random word decoding to a valid ID
  int max_chase = 4;           ///< Chase-II depth p at most (2^p hard decodings)
  int min_check_bits = 8;      ///< integrity check length at least
  int correction = -1;         ///< t; -1 chooses the largest that meets false_accept
};

/// What decode_id found.
struct IdDecodeResult {
  bool valid = false;        ///< an ID was found and passed the integrity check
  std::uint64_t id = 0;      ///< the ID, when valid
  int corrected = 0;         ///< bits of the read word that differ from the ID's codeword
  double soft_distance = 0;  ///< sum of the margins of those bits
  std::string message;       ///< why no ID, or what was corrected
};

/// A code for IDs of IdCodeOptions::id_bits bits in nb-bit payloads.
class IdCode {
 public:
  /// \throw InvalidArgumentError when no (t, p) meets the options (nb too short for the ID
  ///        at that false-accept bound), or an option is out of range.
  explicit IdCode(const IdCodeOptions& options = {});

  int bits() const { return n_; }                 ///< codeword length nb
  int id_bits() const { return id_bits_; }        ///< ID length
  int check_bits() const { return check_bits_; }  ///< integrity check length
  int parity_bits() const { return r_; }          ///< BCH parity bits (degree of g)
  int correction() const { return t_; }           ///< t, errors corrected by hard decoding
  int chase_depth() const { return p_; }          ///< p, least reliable bits tried both ways
  int field_degree() const { return m_; }         ///< m of GF(2^m)
  /// The false-accept bound of the class comment for this code.
  double false_accept_bound() const;

  /// The codeword of id (payload order: ID MSB first, check, BCH parity, overall parity),
  /// its check keyed with key. \throw InvalidArgumentError when id does not fit in id_bits.
  Payload encode(std::uint64_t id, const Key& key) const;

  /// Decodes bits read in payload order (0, 1, or an erasure > 1) with their margins (same
  /// size; erasures should have margin 0; empty margins = all equal, no Chase search).
  IdDecodeResult decode(const std::vector<std::uint8_t>& bits, const std::vector<double>& margins,
                        const Key& key) const;

 private:
  // Inner BCH decoding of c (n_ - 1 bits, coefficient order) in place; returns the number of
  // errors corrected, or -1.
  int decode_bch(std::vector<std::uint8_t>& c) const;
  std::vector<std::uint8_t> check_of(std::uint64_t id, const Key& key) const;

  int n_ = 0, id_bits_ = 0, check_bits_ = 0, r_ = 0, t_ = 0, p_ = 0, m_ = 0;
  std::vector<std::uint8_t> generator_;  // g(x), coefficients of x^0..x^r
  std::vector<int> exp_, log_;           // GF(2^m) tables
};

/// Degree of the generator polynomial of the primitive narrow-sense binary BCH code of
/// length 2^m - 1 correcting t errors (the number of parity bits). 3 <= m <= 10.
int bch_parity_bits(int m, int t);

}  // namespace meshmark
