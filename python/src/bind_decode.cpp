// Reading marks back: extract (the blind decoder), read_mark (the layout undone), read_id
// (coded IDs) and detect (a p-value for an expected payload or ID).

#include <fmt/format.h>

#include <cmath>

#include "bindings.h"
#include "meshmark/carrier/variant.h"
#include "meshmark/core/error.h"
#include "meshmark/mark/decode.h"
#include "meshmark/protocol/detect.h"
#include "meshmark/protocol/watermark.h"

namespace meshmark::python {

namespace {

void bind_extract_types(py::module_& m) {
  py::class_<ExtractOptions> o(m, "ExtractOptions", "Options of extract (C++ ExtractOptions).");
  Fields<ExtractOptions>(o)
      .rw("bits", &ExtractOptions::bits, "payload length nb (nb + 2 bins)")
      .rw("center", &ExtractOptions::center, "CenterKind: the embedding variant's center")
      .rw("skip_nearest", &ExtractOptions::skip_nearest,
          "carrier positions left out near the center")
      .rw("skip_farthest", &ExtractOptions::skip_farthest, "and farthest from it")
      .rw("method", &ExtractOptions::method, "Method: the embedding's (its bin statistic)")
      .done(true);
  py::class_<ExtractResult> r(m, "ExtractResult", "What extract read, in bin order.");
  Fields<ExtractResult>(r)
      .ro("erasures", &ExtractResult::erasures, "number of empty bins")
      .array(
          "bits", [](const ExtractResult& x) { return vector_array(x.bits); },
          "(nb,) uint8: 0, 1, or ERASURE (2) for an empty bin")
      .array(
          "means", [](const ExtractResult& x) { return vector_array(x.means); },
          "(nb,) float64 mean position in bin j + 1 (NaN when empty)")
      .array(
          "margins", [](const ExtractResult& x) { return vector_array(x.margins); },
          "(nb,) float64 |mean - 1/2| (0 when erased)")
      .array(
          "counts", [](const ExtractResult& x) { return vector_array(x.counts); },
          "(nb,) int32 distinct carrier positions in bin j + 1")
      .array(
          "center", [](const ExtractResult& x) { return x.center; }, "Center")
      .array(
          "histogram", [](const ExtractResult& x) { return x.histogram; }, "Histogram")
      .array(
          "check", [](const ExtractResult& x) { return x.check; }, "CarrierCheck")
      .done(false);
  r.def(
      "word", [](const ExtractResult& x) { return vector_array(x.word().bits); },
      "The bits read, in bin order, as a uint8 array, erasures read as 0.");
  r.def("min_margin", &ExtractResult::min_margin, "Smallest margin (0 with an erasure).");
  m.attr("ERASURE") = kErasure;
}

void bind_reading_types(py::module_& m) {
  py::class_<MarkReading> mr(m, "MarkReading", "What read_mark found, in payload order.");
  Fields<MarkReading>(mr)
      .array(
          "extract", [](const MarkReading& x) { return x.extract; }, "ExtractResult (bin order)")
      .array(
          "bits", [](const MarkReading& x) { return vector_array(x.bits); },
          "(nb,) uint8 payload order: 0, 1 or ERASURE")
      .array(
          "margins", [](const MarkReading& x) { return vector_array(x.margins); },
          "(nb,) float64 payload order")
      .array(
          "means", [](const MarkReading& x) { return vector_array(x.means); },
          "(nb,) float64 payload order (NaN when erased)")
      .array(
          "payload_hex",
          [](const MarkReading& x) {
            Payload p;
            for (const std::uint8_t b : x.bits) p.bits.push_back(b == 1);
            return payload_to_hex(p);
          },
          "the bits in hexadecimal, erasures read as 0 (what the CLI's extract prints)")
      .done(false);
  py::enum_<IdDecodeStatus>(m, "IdDecodeStatus", "Why decoding gave, or did not give, an ID.")
      .value("Found", IdDecodeStatus::Found)
      .value("Unreadable", IdDecodeStatus::Unreadable)
      .value("TooManyErrors", IdDecodeStatus::TooManyErrors)
      .value("NotUnderKey", IdDecodeStatus::NotUnderKey);
  py::class_<IdDecodeResult> id(m, "IdDecodeResult", "A decoded ID, or why none.");
  Fields<IdDecodeResult>(id)
      .ro("status", &IdDecodeResult::status, "IdDecodeStatus")
      .ro("valid", &IdDecodeResult::valid, "status == Found")
      .ro("id", &IdDecodeResult::id, "the ID, when valid")
      .ro("corrected", &IdDecodeResult::corrected, "bits read that differ from its codeword")
      .ro("erasures", &IdDecodeResult::erasures, "unreadable bits")
      .ro("soft_distance", &IdDecodeResult::soft_distance, "sum of the corrected bits' margins")
      .ro("message", &IdDecodeResult::message, "what was found, or why nothing")
      .done(false);
  py::class_<IdReading> ir(m, "IdReading", "What read_id found.");
  Fields<IdReading>(ir)
      .ro("id", &IdReading::id, "IdDecodeResult")
      .ro("skip_nearest", &IdReading::skip_nearest, "outliers left out of the reading used")
      .ro("skip_farthest", &IdReading::skip_farthest, "outliers left out of the reading used")
      .ro("readings", &IdReading::readings, "readings decoded")
      .array(
          "reading", [](const IdReading& x) { return x.reading; }, "MarkReading")
      .done(false);
  py::enum_<NullModel>(m, "NullModel", "How a p-value was computed.")
      .value("Binomial", NullModel::Binomial)
      .value("CodewordExact", NullModel::CodewordExact)
      .value("CodewordBound", NullModel::CodewordBound);
  py::class_<DetectResult> d(m, "DetectResult", "What detect found (C++ DetectResult).");
  Fields<DetectResult>(d)
      .ro("compared", &DetectResult::compared, "bits compared")
      .ro("matches", &DetectResult::matches, "bits read equal to the expected ones")
      .ro("erasures", &DetectResult::erasures, "unreadable bits")
      .ro("p_value", &DetectResult::p_value, "false-alarm probability of this many matches")
      .ro("detected", &DetectResult::detected, "p_value < threshold")
      .ro("model", &DetectResult::model, "NullModel")
      .ro("decodes_to_other", &DetectResult::decodes_to_other, "the mark decodes to another ID")
      .ro("other_id", &DetectResult::other_id, "that ID")
      .done(false);
}

// ExtractOptions from `options` and keywords (its fields, or variant='VRS' for its center).
ExtractOptions extract_options(py::handle options, const py::kwargs& kwargs) {
  ExtractOptions o = options.is_none() ? ExtractOptions{} : options.cast<ExtractOptions>();
  py::kwargs rest;
  for (const auto& [key, value] : kwargs) {
    if (key.cast<std::string>() == "variant")
      o.center = to_variant(value).center;
    else
      rest[key] = value;
  }
  apply_keywords(py::cast(&o, py::return_value_policy::reference), rest);
  return o;
}

IdCode id_code(int bits, int id_bits) {
  IdCodeOptions o;
  o.bits = bits;
  o.id_bits = id_bits;
  return IdCode(o);
}

void bind_functions(py::module_& m) {
  m.def(
      "extract",
      [](py::handle V, py::handle F, py::handle options, const py::kwargs& kwargs) {
        const Eigen::MatrixX3d v = to_positions(V);
        const Eigen::MatrixX3i f = to_faces(F, v.rows());
        const ExtractOptions o = extract_options(options, kwargs);
        py::gil_scoped_release unlocked;
        return extract(v, f, o);
      },
      py::arg("V"), py::arg("F"), py::arg("options") = py::none(),
      "The blind decoder: nb bits in bin order (for a raw payload without a key, the payload "
      "itself). Keywords set ExtractOptions fields (bits=64, center=...), or variant='VRS' its "
      "center.");
  m.def(
      "read_mark",
      [](py::handle V, py::handle F, py::handle options, py::handle key, py::handle key_file,
         bool coded, const py::kwargs& kwargs) {
        const Eigen::MatrixX3d v = to_positions(V);
        const Eigen::MatrixX3i f = to_faces(F, v.rows());
        const ExtractOptions o = extract_options(options, kwargs);
        const BitLayout layout = mark_layout(resolve_key(key, key_file), o.bits, coded);
        py::gil_scoped_release unlocked;
        return read_mark(v, f, o, layout);
      },
      py::arg("V"), py::arg("F"), py::arg("options") = py::none(), py::kw_only(),
      py::arg("key") = py::none(), py::arg("key_file") = py::none(), py::arg("coded") = false,
      "Reads the bits and undoes the layout (keyed with key, or the canonical one; coded: the "
      "whitening of coded IDs), as the CLI's extract does without --coded.");
  m.def(
      "read_id",
      [](py::handle V, py::handle F, py::handle options, py::handle key, py::handle key_file,
         int id_bits, const py::kwargs& kwargs) {
        const Eigen::MatrixX3d v = to_positions(V);
        const Eigen::MatrixX3i f = to_faces(F, v.rows());
        const ExtractOptions o = extract_options(options, kwargs);
        const std::optional<Key> k = resolve_key(key, key_file);
        const IdCode code = id_code(o.bits, id_bits);
        py::gil_scoped_release unlocked;
        return read_id(v, f, o, code, k);
      },
      py::arg("V"), py::arg("F"), py::arg("options") = py::none(), py::kw_only(),
      py::arg("key") = py::none(), py::arg("key_file") = py::none(), py::arg("id_bits") = 32,
      "Reads a coded ID (the CLI's extract --coded): the normal reading, then readings without "
      "outliers. result.id.valid says whether an ID was found.");
  m.def(
      "detect",
      [](py::handle V, py::handle F, py::handle expect, py::handle expect_payload, int bits,
         py::handle variant, double threshold, py::handle key, py::handle key_file, int id_bits) {
        if (expect.is_none() == expect_payload.is_none())
          throw InvalidArgumentError("detect needs one of expect (an ID) or expect_payload");
        if (!(threshold > 0 && threshold < 1))
          throw InvalidArgumentError(fmt::format("threshold {} is not in (0, 1)", threshold));
        const Eigen::MatrixX3d v = to_positions(V);
        const Eigen::MatrixX3i f = to_faces(F, v.rows());
        ExtractOptions eo;
        eo.bits = bits;
        eo.center = to_variant(variant).center;
        MarkExpectation expected;
        expected.id_bits = id_bits;
        if (!expect.is_none())
          expected.id = to_id(expect, "expect");
        else
          expected.payload = to_payload(expect_payload, py::int_(bits), "expect_payload");
        const std::optional<Key> k = resolve_key(key, key_file);
        DetectOptions options;
        options.threshold = threshold;
        py::gil_scoped_release unlocked;
        return detect_mark(v, f, eo, expected, k, options).detection;
      },
      py::arg("V"), py::arg("F"), py::kw_only(), py::arg("expect") = py::none(),
      py::arg("expect_payload") = py::none(), py::arg("bits") = 64, py::arg("variant") = "DRS",
      py::arg("threshold") = 1e-6, py::arg("key") = py::none(), py::arg("key_file") = py::none(),
      py::arg("id_bits") = 32,
      "Tests whether (V, F) carries an expected ID (expect) or raw payload (expect_payload: hex "
      "or 0/1 bits), with the false-alarm probability, as the CLI's detect.");
}

}  // namespace

void init_decode(py::module_& m) {
  bind_extract_types(m);
  bind_reading_types(m);
  bind_functions(m);
}

}  // namespace meshmark::python
