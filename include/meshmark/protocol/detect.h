#pragma once
/// \file detect.h
/// Detection of an expected payload with a false-alarm probability: the number of bits read
/// that match the expected ones (an unreadable bit never matches), and the probability that
/// they would match at least as well if the expected payload were not the one present.
///
/// For a coded ID (coding.h) the null hypothesis is "the expected ID is innocent": its
/// codeword is independent of the bits read, that is, to whoever made the mesh it is a
/// uniformly random codeword of the ID code (the keyed permutation of IDs makes it so for
/// anyone without the key, consecutive IDs and averaged copies included). The p-value is then
/// exact: the fraction of codewords that match the bits read at least as well, counted with
/// the MacWilliams identity over the dual code (the coset weight distribution of what was
/// read), for codes whose dual has at most 30 dimensions (nb = 64 with a 32-bit ID: 28). For
/// larger duals it is bounded instead: a uniform codeword is uniform on the k message bits,
/// so P(matches >= m) <= P(Binomial(readable message bits, 1/2) >= readable message bits -
/// allowed disagreements), which is valid but conservative. The binomial model of
/// fair independent bits would not do: codewords are not independent words (any two differ in
/// at least min_distance() bits, and most in about nb/2).
///
/// For a raw payload the null is "a mesh without this mark": under a key its whitened bits
/// read as fair coin flips and the p-value is P(Binomial(nb, 1/2) >= matches); without a key
/// the bits of an unmarked mesh can be structured, and the p-value is only indicative.

#include <cstdint>
#include <vector>

#include "meshmark/core/enum_names.h"
#include "meshmark/mark/payload.h"
#include "meshmark/protocol/coding.h"

namespace meshmark {

/// P(X >= k) for X ~ Binomial(n, 1/2), accurate in relative terms far into the tail (computed
/// with logarithms; returns 1 for k <= 0 and 0 for k > n).
double binomial_tail(int n, int k);

/// Options of detect.
struct DetectOptions {
  double threshold = 1e-6;  ///< declare the payload present when the p-value is below this
};

/// How a p-value was computed.
enum class NullModel {
  Binomial,       ///< fair independent bits (raw payloads)
  CodewordExact,  ///< exact, over the codewords of the ID code (MacWilliams)
  CodewordBound,  ///< an upper bound from the code's message bits (large duals)
};

/// The names of NullModel's values (null_model_name).
template <>
struct EnumTable<NullModel> {
  static constexpr const char* what = "null model";
  static constexpr NamedValue<NullModel> values[] = {{NullModel::Binomial, "binomial"},
                                                     {NullModel::CodewordExact, "codeword-exact"},
                                                     {NullModel::CodewordBound, "codeword-bound"}};
};

/// A short name for a null model ("binomial", "codeword-exact", "codeword-bound").
const char* null_model_name(NullModel model);

/// What detect found.
struct DetectResult {
  int compared = 0;       ///< bits compared (the payload's length)
  int matches = 0;        ///< bits read equal to the expected ones (erasures never match)
  int erasures = 0;       ///< bits that could not be read (empty bins)
  double p_value = 1;     ///< false-alarm probability of at least this many matches
  bool detected = false;  ///< p_value < threshold
  NullModel model = NullModel::Binomial;  ///< how p_value was computed
  /// The mark decodes (coding.h, uniquely by construction) to another valid ID: the expected
  /// one is then not detected whatever its p-value (a clean copy of a buyer whose codeword is
  /// near the expected one's would otherwise confirm it).
  bool decodes_to_other = false;
  std::uint64_t other_id = 0;  ///< that ID, when decodes_to_other
};

/// The null distribution of the matches between the bits read and an innocent ID's codeword:
/// computed once per word read (about 0.3 s for nb = 64 on one core), then any number of IDs
/// can be tested against it.
class CodewordNull {
 public:
  /// bits: read in payload order (0, 1, or an erasure > 1), bits.size() == code.bits(); key:
  /// the key the IDs are tested under (its codeword mask is removed first).
  /// \throw InvalidArgumentError when the sizes differ.
  CodewordNull(const IdCode& code, const std::vector<std::uint8_t>& bits, const Key& key);
  /// P(an innocent codeword matches the bits read in at least `matches` bits).
  double p_value(int matches) const;
  NullModel model() const { return model_; }  ///< exact or bound

 private:
  NullModel model_ = NullModel::CodewordExact;
  std::vector<double> tail_;  // tail_[m] = P(matches >= m), m = 0..nb + 1
};

/// Compares bits read (payload order; 0, 1, or an erasure > 1) with an expected raw payload,
/// under the binomial null.
/// \throw InvalidArgumentError when the sizes differ or the threshold is not in (0, 1).
DetectResult detect(const std::vector<std::uint8_t>& bits, const Payload& expected,
                    const DetectOptions& options = {});

/// Compares bits read with the codeword of an expected ID (code.encode(id, key)), under the
/// codeword null (the class comment). null must have been built from the same bits. When
/// `decoded` (the decoder's result on the same reading) holds a valid ID other than the
/// expected one, the result is not detected (decodes_to_other).
/// \throw InvalidArgumentError when the sizes differ or the threshold is not in (0, 1).
DetectResult detect_id(const std::vector<std::uint8_t>& bits, const Payload& codeword,
                       const CodewordNull& null, const DetectOptions& options = {},
                       const IdDecodeResult* decoded = nullptr, std::uint64_t expected_id = 0);

}  // namespace meshmark
