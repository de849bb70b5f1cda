#pragma once
/// \file watermark.h
/// The watermark protocol: which bits go into which bins for a raw payload or a coded buyer
/// ID, with or without a secret key, and how they are read back. A program using the library
/// and the command line write and read the same marks through these functions.
///
/// - A raw payload without a key uses the canonical layout (docs/method.md section 1), readable
///   by any implementation of the paper.
/// - Under a key, bits are permuted over the bins and whitened (BitLayout::keyed).
/// - A coded ID without a key is whitened with public_key(), not a secret, so that the
///   structured bits of an unmarked mesh do not look like a codeword; its codeword is then
///   also computed under public_key().

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <vector>

#include "meshmark/io/io.h"
#include "meshmark/mark/decode.h"
#include "meshmark/mark/payload.h"
#include "meshmark/protocol/coding.h"
#include "meshmark/protocol/detect.h"
#include "meshmark/protocol/key.h"

namespace meshmark {

/// The layout of nb bits: keyed with key when there is one; without one, coded IDs are
/// whitened with public_key() and raw payloads use the canonical layout.
BitLayout mark_layout(const std::optional<Key>& key, int nb, bool coded);

/// The key coded IDs are encoded and checked under: key, or public_key() without one.
const Key& id_key(const std::optional<Key>& key);

/// The bins' word for the coded id (the codeword, laid out): what embed() takes as payload.
BinWord id_bins(const IdCode& code, std::uint64_t id, const std::optional<Key>& key);

/// What was read from a mesh, per payload bit (the layout undone).
struct MarkReading {
  ExtractResult extract;           ///< the blind decoder's output, in bin order
  std::vector<std::uint8_t> bits;  ///< payload order: 0, 1 or kErasure
  std::vector<double> margins;     ///< payload order: |bin mean - 1/2| (0 when erased)
  std::vector<double> means;       ///< payload order: bin means (NaN when erased)
};

/// Reads nb = options.bits bits from V, F and undoes the layout.
MarkReading read_mark(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                      const ExtractOptions& options, const BitLayout& layout);

/// What read_id found.
struct IdReading {
  MarkReading reading;   ///< the reading the ID came from (the normal one when none did)
  IdDecodeResult id;     ///< the decoded ID, or why none
  int skip_nearest = 0;  ///< outliers left out of the reading the ID came from
  int skip_farthest = 0;
  int readings = 1;  ///< readings decoded (1 + the retries tried)
};

/// Reads a coded ID: the normal reading first; if it gives no ID, up to code.retries()
/// further readings that leave out the 1 to 3 carrier vertices nearest to and farthest from
/// the center (outliers an attacker may have added to move the histogram's range), each
/// decoded with the code's retry rule. Two readings giving different IDs give none
/// ("ambiguous"). The code's false-accept bound covers every reading.
IdReading read_id(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                  const ExtractOptions& options, const IdCode& code, const std::optional<Key>& key);

/// What detect_mark tests for: an expected coded ID, or an expected raw payload.
struct MarkExpectation {
  std::optional<std::uint64_t> id;  ///< the expected coded ID; none: payload is expected
  Payload payload;                  ///< the expected raw payload (payload order), without an ID
  int id_bits = 32;                 ///< the ID code's ID length (1..32)
};

/// What detect_mark found.
struct MarkDetection {
  DetectResult detection;  ///< matches, erasures, p-value and verdict
  Payload expected;        ///< payload order: the expected word (an ID's codeword)
  ExtractResult extract;   ///< the blind decoder's output (its carrier check), bin order
};

/// Tests whether V, F carries the expected mark: the options.bits bits read (options' center
/// and method) through mark_layout(key, ...), compared with the expected raw payload
/// (binomial null) or with the expected ID's codeword under id_key(key) (exact codeword null,
/// and the ID the mark decodes to when it is another), detected below detect.threshold.
/// \throw InvalidArgumentError when the ID code can never give a p-value below the threshold
///        (2^-message bits >= threshold), or the expected payload is not options.bits long.
MarkDetection detect_mark(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                          const ExtractOptions& options, const MarkExpectation& expect,
                          const std::optional<Key>& key, const DetectOptions& detect = {});

/// The per-bin strengths (bin order, as EmbedOptions::strengths takes them) of a mark: keyed
/// ones (keyed_strengths under id_key(key), laid out like the bits) for keyed or coded marks,
/// none (the uniform strength) for a raw payload without a key.
std::vector<double> mark_strengths(const std::optional<Key>& key, int nb, bool coded,
                                   double strength, double spread);

/// What write_marked_mesh found in the bytes it was about to write.
struct WrittenCheck {
  bool carried = false;   ///< every bit decodes right with at least the required margin
  int bit_errors = 0;     ///< bits that decode wrong or not at all
  double min_margin = 0;  ///< smallest signed margin of the written bits (bin-width units)
  std::string message;    ///< one line for a person
};

/// Writes a watermarked mesh only if what is written carries the mark: serializes mesh as
/// write_mesh would (format from options or the path's extension), decodes those bytes as a
/// reader would (read_options, e.g. the weld tolerance; extract for bins.size() bits and
/// the center of extract_options), and writes them atomically (write_file_atomically) only
/// when every bit of bins (the embedded word, bin order) decodes right with a signed margin
/// of at least min_margin. Float32 storage, text rounding or a strength too small for the
/// coordinates' precision are caught here. Nothing is written otherwise.
/// \throw WriteError (an IOError) when the file cannot be written; InvalidArgumentError for an
///        unknown extension.
WrittenCheck write_marked_mesh(const std::string& path, const Mesh& mesh,
                               const WriteOptions& options, const ReadOptions& read_options,
                               const BinWord& bins, const ExtractOptions& extract_options,
                               double min_margin);

/// Per-bit strengths for a keyed mark: bit j gets strength * (1 + spread * u_j), u_j uniform in
/// [0, 1) from derive_key(key, "strengths") (capped below 1/2), so that the bin means do not
/// all sit at exactly 1/2 +- strength: the strength is not written in the histogram for
/// anyone to read. spread = 0 gives the paper's uniform strength.
/// \throw InvalidArgumentError when strength is not in (0, 1/2) or spread not in [0, 4].
std::vector<double> keyed_strengths(const Key& key, int nb, double strength, double spread);

}  // namespace meshmark
