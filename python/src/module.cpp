// The meshmark Python module: its exceptions and the types every part shares (variants,
// centers, carrier checks, keys, payloads). The parts are in bind_*.cpp.

#include <fmt/format.h>

#include "bindings.h"
#include "meshmark/carrier/carrier_check.h"
#include "meshmark/carrier/histogram.h"
#include "meshmark/carrier/variant.h"
#include "meshmark/core/error.h"
#include "meshmark/version.h"

namespace meshmark::python {

namespace {

// The module's exception classes (created once, kept for the process's life).
struct ExceptionTypes {
  PyObject* error = nullptr;
  PyObject* invalid_input = nullptr;
  PyObject* io = nullptr;
  PyObject* invalid_argument = nullptr;
};
ExceptionTypes exception_types;

PyObject* new_exception(py::module_& m, const char* name, py::tuple bases, const char* doc) {
  const std::string full = fmt::format("meshmark.{}", name);
  PyObject* type = PyErr_NewExceptionWithDoc(full.c_str(), doc, bases.ptr(), nullptr);
  if (type == nullptr) throw py::error_already_set();
  m.attr(name) = py::reinterpret_borrow<py::object>(type);
  return type;  // the reference PyErr_NewExceptionWithDoc returned is kept
}

// Raises type(message), with `what` adding attributes to the instance.
template <class AddAttributes>
void raise(PyObject* type, const char* message, AddAttributes what) {
  py::object instance = py::reinterpret_borrow<py::object>(type)(message);
  what(instance);
  PyErr_SetObject(type, instance.ptr());
}

void init_exceptions(py::module_& m) {
  ExceptionTypes& t = exception_types;
  const py::handle value_error(PyExc_ValueError), os_error(PyExc_OSError);
  t.error =
      new_exception(m, "Error", py::make_tuple(py::handle(PyExc_Exception)),
                    "Base of the exceptions meshmark raises on purpose (C++ meshmark::Error).");
  const py::handle error(t.error);
  t.invalid_input = new_exception(
      m, "InvalidInputError", py::make_tuple(error, value_error),
      "A mesh (file or arrays) that cannot be read as what it claims to be (C++ "
      "InvalidInputError). Attributes: file (the path, or the argument's name for arrays), line "
      "(1-based, 0 when not tied to a line), detail (the message without file and line).");
  t.io = new_exception(m, "IOError", py::make_tuple(error, os_error),
                       "The operating system refused a read or a write (C++ IOError).");
  t.invalid_argument =
      new_exception(m, "InvalidArgumentError", py::make_tuple(error, value_error),
                    "An argument out of its documented range (C++ InvalidArgumentError).");
  py::register_exception_translator([](std::exception_ptr p) {
    const ExceptionTypes& types = exception_types;
    const auto none = [](py::object&) {};
    try {
      if (p) std::rethrow_exception(p);
    } catch (const InvalidInputError& e) {
      raise(types.invalid_input, e.what(), [&](py::object& x) {
        x.attr("file") = e.file();
        x.attr("line") = e.line();
        x.attr("detail") = e.detail();
      });
    } catch (const IOError& e) {
      raise(types.io, e.what(), none);
    } catch (const InvalidArgumentError& e) {
      raise(types.invalid_argument, e.what(), none);
    } catch (const Error& e) {
      raise(types.error, e.what(), none);
    }
  });
}

void init_variant(py::module_& m) {
  py::enum_<CenterKind>(m, "CenterKind", "Center of mass, a variant's first letter.")
      .value("Discrete", CenterKind::Discrete, "D: the mean of the carrier positions")
      .value("Surface", CenterKind::Surface, "S: the area-weighted centroid of the triangles")
      .value("Volume", CenterKind::Volume, "V: the centroid of the enclosed volume");
  py::enum_<DirectionKind>(m, "DirectionKind", "Direction of displacement, the second letter.")
      .value("Radial", DirectionKind::Radial)
      .value("Normal", DirectionKind::Normal)
      .value("Smooth", DirectionKind::Smooth);
  py::enum_<CostKind>(m, "CostKind", "Cost, the third letter.")
      .value("Squared", CostKind::Squared)
      .value("Quadric", CostKind::Quadric)
      .value("Laplacian", CostKind::Laplacian);
  py::class_<Variant>(m, "Variant",
                      "A variant of the framework (TIFS 2014) by its three letters: center (D S "
                      "V), direction (R N S), cost (S Q L).")
      .def(py::init(&parse_variant), py::arg("name") = "DRS",
           "Parses a three-letter name such as 'DRS' or 'VRL' (any case).")
      .def_readwrite("center", &Variant::center)
      .def_readwrite("direction", &Variant::direction)
      .def_readwrite("cost", &Variant::cost)
      .def("name", &Variant::name, "The three letters.")
      .def("__eq__", [](const Variant& a, const Variant& b) { return a == b; })
      .def("__repr__", [](const Variant& v) { return fmt::format("Variant('{}')", v.name()); });
  m.attr("PAPER_VARIANTS") = py::make_tuple("DRS", "SRS", "VRS", "VRQ", "VRL", "VNS", "VSS");
}

void init_carrier(py::module_& m) {
  py::enum_<CarrierHealth>(m, "CarrierHealth", "What the carrier check concluded.")
      .value("Healthy", CarrierHealth::Healthy)
      .value("Weak", CarrierHealth::Weak, "readable, but some bits are unreliable (a warning)")
      .value("Unusable", CarrierHealth::Unusable, "nothing can be decoded or embedded");
  py::class_<CarrierCheck> check(m, "CarrierCheck",
                                 "Whether the carrier has enough distinct positions for nb bits.");
  Fields<CarrierCheck>(check)
      .ro("status", &CarrierCheck::status, "CarrierHealth")
      .ro("diagnostics", &CarrierCheck::diagnostics, "one line each for a person")
      .ro("bits", &CarrierCheck::bits, "nb, the data bins")
      .ro("carrier", &CarrierCheck::carrier, "carrier vertices")
      .ro("positions", &CarrierCheck::positions, "distinct carrier positions")
      .ro("empty_bins", &CarrierCheck::empty_bins, "data bins with no position (erased bits)")
      .ro("thin_bins", &CarrierCheck::thin_bins, "data bins with 1 to 7 positions")
      .ro("fewest", &CarrierCheck::fewest, "smallest number of positions in a data bin")
      .done(false);
  check.def("summary", &CarrierCheck::summary, "The diagnostics in one line.");
  py::class_<Center> center(m, "Center", "A center of mass and whether it is well defined.");
  Fields<Center>(center)
      .array(
          "point", [](const Center& c) { return vector_array(Eigen::VectorXd(c.point)); },
          "(3,) float64, model units")
      .ro("well_defined", &Center::well_defined, "False for an ill-defined volume center")
      .ro("mass", &Center::mass,
          "total weight: D vertex count; S area (units^2); V signed volume (units^3)")
      .ro("volume_consistency", &Center::volume_consistency,
          "V only: |sum w| / sum |w| in [0, 1] (1 closed and oriented); 1 for D and S")
      .done(false);
  py::class_<Histogram> h(m, "Histogram", "The histogram of distances to the center.");
  Fields<Histogram>(h)
      .ro("rho_min", &Histogram::rho_min, "model units")
      .ro("rho_max", &Histogram::rho_max, "model units")
      .ro("step", &Histogram::step, "bin width s (model units)")
      .ro("bins", &Histogram::bins, "nB = nb + 2")
      .ro("argmin", &Histogram::argmin, "a vertex at rho_min")
      .ro("argmax", &Histogram::argmax, "a vertex at rho_max")
      .array(
          "center", [](const Histogram& x) { return vector_array(Eigen::VectorXd(x.center)); },
          "(3,) float64")
      .array(
          "rho", [](const Histogram& x) { return vector_array(x.rho); },
          "(n,) distance per vertex (NaN for vertices that do not count)")
      .array(
          "bin", [](const Histogram& x) { return vector_array(x.bin); },
          "(n,) int32 bin per vertex, -1 for those that do not count")
      .array(
          "t", [](const Histogram& x) { return vector_array(x.t); },
          "(n,) position inside the bin, in [0, 1]")
      .done(false);
  h.def("valid", &Histogram::valid, "False when there is nothing to histogram.");
}

void init_payload(py::module_& m) {
  py::class_<Key>(m, "Key",
                  "A 256-bit secret key. Functions that take key= also take a passphrase str.")
      .def_static("from_passphrase", &key_from_passphrase, py::arg("passphrase"),
                  "The key of a passphrase (Argon2id, about 0.18 s and 64 MiB), as the CLI's "
                  "--key.")
      .def_static("from_passphrase_v1", &key_from_passphrase_v1, py::arg("passphrase"),
                  "The key a passphrase gave before registry schema 4 (one BLAKE2b), as the "
                  "CLI's --legacy-passphrase: to read copies issued then.")
      .def_readonly("derivation", &Key::derivation,
                    "How the key was derived, as issued copies record it ('' for none).")
      .def_static(
          "from_file", [](py::handle path) { return key_from_file(to_path(path)); },
          py::arg("path"), "The key of a key file's bytes, as the CLI's --key-file.")
      .def_static(
          "generate", [](py::handle path) { return generate_key_file(to_path(path)); },
          py::arg("path"),
          "Makes a new key file at path (32 random bytes, mode 0600, never over an existing "
          "file), as the CLI's keygen, and returns its key.")
      .def("__eq__", [](const Key& a, const Key& b) { return a == b; })
      .def("__repr__", [](const Key&) { return std::string("Key(<secret>)"); });
  m.def(
      "payload_from_hex",
      [](const std::string& hex, int bits) {
        return vector_array(payload_from_hex(hex, bits).bits);
      },
      py::arg("hex"), py::arg("bits") = 64,
      "The bits (uint8 array, bin 1's first) of a hexadecimal payload.");
  m.def(
      "payload_to_hex",
      [](py::handle bits) { return payload_to_hex(to_payload(bits, py::none(), "bits")); },
      py::arg("bits"), "The hexadecimal form of a sequence of 0/1 bits.");
  m.def(
      "random_payload",
      [](int bits, std::uint64_t seed) { return vector_array(random_payload(bits, seed).bits); },
      py::arg("bits"), py::arg("seed"), "A uniformly random payload (SplitMix64 of seed).");
  m.def(
      "check_carrier",
      [](py::handle V, py::handle F, int bits, CenterKind center) {
        const Eigen::MatrixX3d v = to_positions(V);
        return check_carrier(v, to_faces(F, v.rows()), bits, center);
      },
      py::arg("V"), py::arg("F"), py::arg("bits") = 64, py::arg("center") = CenterKind::Discrete,
      "Whether the carrier of (V, F) can carry `bits` bits.");
}

}  // namespace

void init_types(py::module_& m) {
  init_exceptions(m);
  init_variant(m);
  init_carrier(m);
  init_payload(m);
}

}  // namespace meshmark::python

PYBIND11_MODULE(meshmark, m) {
  namespace mp = meshmark::python;
  m.doc() =
      "meshmark: blind, robust watermarking of triangle meshes (Rolland-Neviere, Doerr, Alliez, "
      "IEEE TIFS 2014). Meshes are (V, F): V an (n, 3) float64 array of positions, F an (m, 3) "
      "int array of 0-based vertex indices (returned as int32).";
  m.attr("__version__") = MESHMARK_VERSION_STRING;
  mp::init_types(m);
  mp::init_io(m);
  mp::init_embed(m);
  mp::init_decode(m);
  mp::init_attack(m);
  mp::init_metrics(m);
  mp::init_issue(m);
  mp::init_calibrate(m);
  mp::init_campaign(m);
}
