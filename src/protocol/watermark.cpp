#include "meshmark/protocol/watermark.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <set>
#include <tuple>

#include "meshmark/core/error.h"

namespace meshmark {

BitLayout mark_layout(const std::optional<Key>& key, int nb, bool coded) {
  if (key) return BitLayout::keyed(*key, nb);
  return coded ? BitLayout::keyed(public_key(), nb) : BitLayout::canonical(nb);
}

const Key& id_key(const std::optional<Key>& key) {
  return key ? *key : public_key();
}

BinWord id_bins(const IdCode& code, std::uint64_t id, const std::optional<Key>& key) {
  return mark_layout(key, code.bits(), true).to_bins(code.encode(id, id_key(key)));
}

MarkReading read_mark(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                      const ExtractOptions& options, const BitLayout& layout) {
  MarkReading r;
  r.extract = extract(V, F, options);
  r.bits = layout.from_bins(r.extract.bits);
  r.margins = layout.values_from_bins(r.extract.margins);
  r.means = layout.values_from_bins(r.extract.means);
  return r;
}

IdReading read_id(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                  const ExtractOptions& options, const IdCode& code,
                  const std::optional<Key>& key) {
  if (options.bits != code.bits())
    throw InvalidArgumentError(
        fmt::format("reading {} bits for a code of {} bits", options.bits, code.bits()));
  const BitLayout layout = mark_layout(key, code.bits(), true);
  IdReading out;
  out.reading = read_mark(V, F, options, layout);
  out.id = code.decode(out.reading.bits, out.reading.margins, id_key(key));
  if (out.id.valid) return out;
  // Further readings, fewest vertices left out first.
  std::vector<std::pair<int, int>> skips;
  for (int total = 1; total <= 6; ++total)
    for (int nearest = std::min(total, 3); nearest >= 0 && total - nearest <= 3; --nearest)
      skips.emplace_back(nearest, total - nearest);
  if (static_cast<int>(skips.size()) > code.retries()) skips.resize(code.retries());
  std::optional<IdReading> found;
  bool ambiguous = false;
  for (const auto& [nearest, farthest] : skips) {
    ExtractOptions o = options;
    o.skip_nearest = nearest;
    o.skip_farthest = farthest;
    IdReading r;
    r.reading = read_mark(V, F, o, layout);
    r.id = code.decode(r.reading.bits, r.reading.margins, id_key(key), true);
    ++out.readings;
    if (!r.id.valid) continue;
    r.skip_nearest = nearest, r.skip_farthest = farthest;
    if (found && found->id.id != r.id.id) ambiguous = true;
    if (!found) found = std::move(r);
  }
  if (ambiguous) {
    out.id = IdDecodeResult{};
    out.id.message = "readings without outliers give different IDs (ambiguous): no ID";
    return out;
  }
  if (found) {
    found->readings = out.readings;
    found->id.message += fmt::format(" (after leaving out {} nearest and {} farthest vertices)",
                                     found->skip_nearest, found->skip_farthest);
    return *found;
  }
  return out;
}

MarkDetection detect_mark(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                          const ExtractOptions& options, const MarkExpectation& expect,
                          const std::optional<Key>& key, const DetectOptions& detect_options) {
  const bool coded = expect.id.has_value();
  std::optional<IdCode> code;
  MarkDetection out;
  if (coded) {
    IdCodeOptions co;
    co.bits = options.bits;
    co.id_bits = expect.id_bits;
    code.emplace(co);
    // One codeword among 2^k: no match can be rarer than 2^-k.
    if (std::exp2(-code->message_bits()) >= detect_options.threshold)
      throw InvalidArgumentError(fmt::format(
          "a code of {} message bits ({} payload bits, {}-bit IDs) can never give a p-value below "
          "2^-{} = {:.2g}, above the threshold {:g}: use more payload bits or a larger threshold",
          code->message_bits(), options.bits, expect.id_bits, code->message_bits(),
          std::exp2(-code->message_bits()), detect_options.threshold));
    out.expected = code->encode(*expect.id, id_key(key));
  } else {
    if (static_cast<int>(expect.payload.size()) != options.bits)
      throw InvalidArgumentError(fmt::format("the expected payload has {} bits, not {}",
                                             expect.payload.size(), options.bits));
    out.expected = expect.payload;
  }
  const BitLayout layout = mark_layout(key, options.bits, coded);
  out.extract = extract(V, F, options);
  const std::vector<std::uint8_t> bits = layout.from_bins(out.extract.bits);
  if (!coded) {
    out.detection = detect(bits, out.expected, detect_options);
    return out;
  }
  const IdDecodeResult decoded =
      code->decode(bits, layout.values_from_bins(out.extract.margins), id_key(key));
  out.detection = detect_id(bits, out.expected, CodewordNull(*code, bits, id_key(key)),
                            detect_options, &decoded, *expect.id);
  return out;
}

std::vector<double> mark_strengths(const std::optional<Key>& key, int nb, bool coded,
                                   double strength, double spread) {
  if (!key && !coded) return {};
  const std::vector<double> per_bit = keyed_strengths(id_key(key), nb, strength, spread);
  const BitLayout layout = mark_layout(key, nb, coded);
  std::vector<double> out(per_bit.size(), strength);
  for (int j = 0; j < layout.size(); ++j) out[layout.bin_of[j]] = per_bit[j];
  return out;
}

WrittenCheck write_marked_mesh(const std::string& path, const Mesh& mesh,
                               const WriteOptions& options, const ReadOptions& read_options,
                               const Payload& bins, const ExtractOptions& extract_options,
                               double min_margin) {
  const MeshFiles files = write_mesh_files(path, mesh, options);
  const FileFormat format = files.format;
  ReadOptions ro = read_options;
  ro.keep_image = false;
  ro.resources = &files.resources;
  const Mesh back = read_mesh_from_buffer(files.bytes, format, path, ro);  // no copy of the bytes
  ExtractOptions eo = extract_options;
  eo.bits = bins.size();
  const ExtractResult x = extract(back.V, back.F, eo);
  WrittenCheck check;
  check.min_margin = 1;
  for (int j = 0; j < bins.size(); ++j) {
    const double signed_margin =
        x.bits[j] == kErasure ? -1.0 : (bins.bits[j] ? 1.0 : -1.0) * (x.means[j] - 0.5);
    check.bit_errors += x.bits[j] != bins.bits[j];
    check.min_margin = std::min(check.min_margin, signed_margin);
  }
  check.carried = check.bit_errors == 0 && check.min_margin >= min_margin;
  if (!check.carried) {
    check.message = fmt::format(
        "the {} file as it would be written does not carry the mark: {} of {} bits wrong, "
        "smallest margin {:.3g} (at least {:.3g} needed); nothing written ({})",
        format_name(format), check.bit_errors, bins.size(), check.min_margin, min_margin,
        format == FileFormat::Glb || format == FileFormat::Gltf || format == FileFormat::Draco
            ? "its positions are quantized or compressed: a larger strength, or an output with "
              "float positions such as a .glb converted from a PLY"
            : "a larger strength, or more precise coordinates: --float32 off, binary PLY");
    return check;
  }
  write_mesh_files_atomically(path, files);
  check.message = fmt::format("written and read back: smallest margin {:.4g}", check.min_margin);
  return check;
}

std::vector<double> keyed_strengths(const Key& key, int nb, double strength, double spread) {
  if (!(strength > 0 && strength < 0.5))
    throw InvalidArgumentError(fmt::format("strength {} is outside (0, 1/2)", strength));
  if (!(spread >= 0 && spread <= 4))
    throw InvalidArgumentError(fmt::format("strength spread {} is outside [0, 4]", spread));
  std::vector<double> out(static_cast<std::size_t>(nb), strength);
  const Key k = derive_key(key, "strengths");
  for (int first = 0; first < nb; first += 32) {  // 32 values of 16 bits per hash
    const std::vector<std::uint8_t> data = {static_cast<std::uint8_t>(first / 32 & 0xFF),
                                            static_cast<std::uint8_t>(first / 32 >> 8)};
    const std::vector<std::uint8_t> bits = keyed_hash_bits(k, "strengths", data, 512);
    for (int q = 0; q < 32 && first + q < nb; ++q) {
      unsigned v = 0;
      for (int i = 0; i < 16; ++i) v = v << 1 | bits[16 * q + i];
      out[first + q] = std::max(strength, std::min(strength * (1 + spread * v / 65536.0), 0.49));
    }
  }
  return out;
}

}  // namespace meshmark
