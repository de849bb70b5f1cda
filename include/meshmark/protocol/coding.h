#pragma once
/// \file coding.h
/// Payload coding for forensic IDs (mark format version 2, key.h).
///
/// Encoding: the ID (id_bits bits) is placed in the low bits of a k-bit message whose high
/// bits are zero, the message goes through a keyed pseudo-random permutation of {0,1}^k (an
/// 8-round Feistel network whose round function is BLAKE2b keyed with
/// derive_key(key, "id-code")), the result is encoded by a shortened binary BCH code of
/// length nb - 1 over GF(2^m), extended by an overall parity bit, and a keyed mask is added
/// (so that under another key even an intact codeword reads as a random word). The codewords of two
/// IDs, consecutive or not, are two unrelated-looking words of that linear code: any two differ in
/// at least min_distance() = 2t + 2 bits (t the BCH code's designed correction), and to
/// anyone without the key an innocent ID's codeword is a uniformly random codeword.
///
/// Decoding never returns a wrong ID because of what the code is: a codeword is accepted only
/// if it lies within distance t of the bits read (unreadable bits counted as errors), and
/// 2t < min_distance(), so at most one codeword can ever be accepted, whatever was read. An
/// attack that does not change at least min_distance() - t = t + 2 bits cannot make the
/// decoder name another ID. Within that radius the decoder uses the margins: a rule
/// (weak, errors) accepts a codeword that disagrees with the read bits in at most `errors` of
/// the nb - weak most reliable bits (the weak least reliable ones may be anything). The rules
/// are chosen so that a word independent of the mark (an unmarked mesh, another key, a
/// destroyed mark: uniformly random to whoever lacks the key) is accepted with probability at
/// most
///     sum over the rules of 2^id_bits * V(nb - weak, errors) / 2^(nb - weak)
/// (V: Hamming ball volume), plus, for each of the `retries` further readings a reader may
/// try, 2^id_bits * V(nb, e) / 2^nb for the single retry rule (0 weak, e errors); the total
/// stays below IdCodeOptions::false_accept. With nb = 64 and a 32-bit ID: BCH t = 5 (27
/// parity bits, 4 zero bits checked), min distance 12, rules (0 weak, 2 errors) and (4, 1),
/// retry rule (0, 1) for 15 retries, bound 9.4e-7.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "meshmark/core/enum_names.h"
#include "meshmark/mark/payload.h"
#include "meshmark/protocol/key.h"

namespace meshmark {

/// How to code an ID.
struct IdCodeOptions {
  int bits = 64;               ///< payload length nb (codeword length), 8..1024
  int id_bits = 32;            ///< ID length, 1..32
  double false_accept = 1e-6;  ///< bound on a word independent of the mark decoding to an ID
  int min_check_bits = 0;      ///< message bits beyond the ID (checked to be zero) at least
  int correction = -1;         ///< BCH t; -1 chooses the largest that leaves room for the ID
  /// Further readings of one mesh a reader may try (read_id in watermark.h: outliers left
  /// out), each decoded with the retry rule; the false-accept bound covers all of them.
  int retries = 15;
};

/// One acceptance rule of the decoder: the codeword may disagree with the bits read in at most
/// `errors` of the bits other than the `weak` least reliable ones.
struct DecodeRule {
  int weak = 0;    ///< least reliable bits ignored (erasures are the least reliable)
  int errors = 0;  ///< disagreements allowed among the others
};

/// Why decode_id gave, or did not give, an ID.
enum class IdDecodeStatus {
  Found,          ///< a valid ID within the decoding radius
  Unreadable,     ///< more unreadable bits (empty bins) than the radius: no mark can be read
  TooManyErrors,  ///< no codeword within the radius: a damaged mark, or none
  NotUnderKey,    ///< a codeword, but not of a valid ID under this key (another key or damage)
};

/// The names of IdDecodeStatus's values (id_decode_status_name).
template <>
struct EnumTable<IdDecodeStatus> {
  static constexpr const char* what = "ID decoding status";
  static constexpr NamedValue<IdDecodeStatus> values[] = {
      {IdDecodeStatus::Found, "found"},
      {IdDecodeStatus::Unreadable, "unreadable"},
      {IdDecodeStatus::TooManyErrors, "too-many-errors"},
      {IdDecodeStatus::NotUnderKey, "not-under-key"}};
};

/// A short name for a status ("found", "unreadable", "too-many-errors", "not-under-key").
const char* id_decode_status_name(IdDecodeStatus status);

/// What IdCode::decode found.
struct IdDecodeResult {
  IdDecodeStatus status = IdDecodeStatus::TooManyErrors;  ///< what happened
  bool valid = false;                                     ///< status == Found
  std::uint64_t id = 0;                                   ///< the ID, when valid
  int corrected = 0;         ///< bits read that differ from the ID's codeword (erasures count)
  int erasures = 0;          ///< unreadable bits in what was read
  double soft_distance = 0;  ///< sum of the margins of the corrected bits
  std::string message;       ///< what was found, or why nothing
};

/// Parses a buyer ID: decimal digits (leading zeros included: "0100" is 100, never octal), or
/// 0x and hexadecimal digits.
/// \throw InvalidArgumentError for anything else (a sign, a space, other characters, out of
/// range).
std::uint64_t parse_id(const std::string& text);

/// A code for IDs of IdCodeOptions::id_bits bits in nb-bit payloads.
class IdCode {
 public:
  /// \throw InvalidArgumentError when the ID does not fit (nb too short for the ID at that
  ///        false-accept bound), or an option is out of range.
  explicit IdCode(const IdCodeOptions& options = {});

  int bits() const { return n_; }                   ///< codeword length nb
  int id_bits() const { return id_bits_; }          ///< ID length
  int message_bits() const { return k_; }           ///< k, the BCH code's dimension
  int check_bits() const { return k_ - id_bits_; }  ///< message bits that must be zero
  int parity_bits() const { return r_; }            ///< BCH parity bits (degree of g)
  int correction() const { return t_; }             ///< t: the decoding radius
  int min_distance() const { return 2 * t_ + 2; }   ///< proven minimum distance of the code
  int field_degree() const { return m_; }           ///< m of GF(2^m)
  const std::vector<DecodeRule>& rules() const { return rules_; }  ///< acceptance rules
  DecodeRule retry_rule() const { return retry_rule_; }            ///< the rule of further readings
  int retries() const { return retries_; }                         ///< further readings covered
  /// The false-accept bound of the class comment for this code's rules.
  double false_accept_bound() const;

  /// The codeword of id under key (payload order: BCH message, then parity, then the overall
  /// parity bit). \throw InvalidArgumentError when id does not fit in id_bits.
  Payload encode(std::uint64_t id, const Key& key) const;

  /// Decodes bits read in payload order (0, 1, or an erasure > 1) with their margins (same
  /// size; empty = all equally reliable, only the rules with weak = 0 then apply). retry:
  /// decode a further reading of the same mesh with the retry rule (at most retries() of
  /// them per mesh, or the bound does not hold).
  IdDecodeResult decode(const std::vector<std::uint8_t>& bits, const std::vector<double>& margins,
                        const Key& key, bool retry = false) const;

  /// The keyed mask added to every codeword under key (nb bits, payload order).
  std::vector<std::uint8_t> mask(const Key& key) const;

  /// A basis of the dual code: nb - k words of nb bits (payload order), each orthogonal to
  /// every codeword minus its mask. For the detection's null distribution (detect.h).
  std::vector<std::vector<std::uint8_t>> dual_basis() const;

  /// The k-bit message id's codeword encodes: (0...0 || id) through the keyed permutation.
  /// \throw InvalidArgumentError when id does not fit in id_bits.
  std::vector<std::uint8_t> permuted_message(std::uint64_t id, const Key& key) const;
  /// The ID whose permuted_message is message (k bits), or none when the permutation's inverse
  /// has a nonzero check bit (the message is no ID's under key).
  std::optional<std::uint64_t> message_id(const std::vector<std::uint8_t>& message,
                                          const Key& key) const;
  /// The codeword of a k-bit message, without the mask (payload order): linear in message.
  std::vector<std::uint8_t> message_codeword(const std::vector<std::uint8_t>& message) const;
  /// A basis (k-bit messages, reduced row echelon form) of the messages whose codewords lie
  /// in the extended narrow-sense BCH subcode of designed distance 2t' + 2 >= distance: two
  /// messages of its span give codewords at least `distance` bits apart. The subcode of a
  /// primitive BCH code is the one whose generator also has the roots alpha^i for
  /// 2t < i <= 2t'; the span has dimension k - (r' - r) (r' the subcode's parity bits), or
  /// is every message when min_distance() >= distance already, or {0} when no such subcode
  /// exists at this length.
  std::vector<std::vector<std::uint8_t>> spaced_message_basis(int distance) const;

 private:
  // Inner BCH decoding of c (n_ - 1 bits, coefficient order) in place; returns the number of
  // errors corrected, or -1.
  int decode_bch(std::vector<std::uint8_t>& c) const;
  // Systematic encoding of a k-bit message into an nb-bit codeword (payload order).
  std::vector<std::uint8_t> encode_message(const std::vector<std::uint8_t>& message) const;
  // The keyed permutation of {0,1}^k and its inverse.
  std::vector<std::uint8_t> permute(std::vector<std::uint8_t> x, const Key& code_key,
                                    bool inverse) const;

  int n_ = 0, id_bits_ = 0, k_ = 0, r_ = 0, t_ = 0, m_ = 0, retries_ = 0;
  std::vector<DecodeRule> rules_;
  DecodeRule retry_rule_;
  std::vector<std::uint8_t> generator_;  // g(x), coefficients of x^0..x^r
  std::vector<int> exp_, log_;           // GF(2^m) tables
};

/// The codewords of many IDs under one code and key, packed 64 bits to a word, at a few
/// microseconds each: the keyed permutation's round hashes prepared once (KeyedHash), the
/// message encoded as the XOR of one precomputed codeword per set bit (the code is linear),
/// the mask added. Gives IdCode::encode's bits: payload bit j is bit j % 64 of word j / 64
/// (the bits past nb are 0). trace scores its candidates with it.
class CodewordEncoder {
 public:
  CodewordEncoder(const IdCode& code, const Key& key);
  /// Words of 64 bits a codeword takes: (nb + 63) / 64.
  int words() const { return (n_ + 63) / 64; }
  /// The codewords of ids[0 .. count) into out, words() words each. The permutation's first
  /// round depends on the IDs' high bits alone: IDs in increasing order share its hash.
  /// \throw InvalidArgumentError when an ID does not fit in the code's id_bits.
  void encode(const std::uint64_t* ids, std::size_t count, std::uint64_t* out) const;

 private:
  int n_ = 0, k_ = 0, id_bits_ = 0;
  std::optional<KeyedHash> to_right_, to_left_;  // the permutation's round functions
  std::vector<std::uint64_t> rows_;              // k x words(): unit messages' codewords
  std::vector<std::uint64_t> bytes_;             // k/8 x 256 x words(): each byte's codewords
  std::vector<std::uint64_t> mask_;              // words()
};

/// Degree of the generator polynomial of the primitive narrow-sense binary BCH code of
/// length 2^m - 1 correcting t errors (the number of parity bits). 3 <= m <= 10.
int bch_parity_bits(int m, int t);

/// log2 of the Hamming ball volume sum_{i <= t} C(n, i).
double log2_hamming_ball(int n, int t);

}  // namespace meshmark
