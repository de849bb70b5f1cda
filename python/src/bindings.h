#pragma once
// The meshmark Python module: what its binding files share. Arrays come in as numpy arrays (or
// anything numpy.asarray takes), are checked here (shapes, dtypes, finite values, index
// ranges) before the library sees them, and go out as new C-contiguous numpy arrays.

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <Eigen/Core>
#include <cstdint>
#include <exception>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "meshmark/carrier/variant.h"
#include "meshmark/core/enum_names.h"
#include "meshmark/core/mesh.h"
#include "meshmark/core/progress.h"
#include "meshmark/mark/payload.h"
#include "meshmark/protocol/key.h"

namespace meshmark::python {

namespace py = pybind11;

/// Positions from a (n, 3) array of real numbers (any float or integer dtype, converted to
/// float64), every coordinate finite. `name` names the argument in messages.
/// \throw TypeError for a non-numeric dtype; InvalidInputError for a wrong shape or a
///        non-finite coordinate (naming the row).
Eigen::MatrixX3d to_positions(py::handle array, const char* name = "V");

/// Triangles from a (m, 3) array of integers (any signed or unsigned dtype), every index in
/// [0, vertices). \throw TypeError for a non-integer dtype; InvalidInputError for a wrong
/// shape or an index out of range (naming the face, the corner and the value).
Eigen::MatrixX3i to_faces(py::handle array, Eigen::Index vertices, const char* name = "F");

/// A new (n, 3) float64 array (C order) holding V.
py::array_t<double> positions_array(const Eigen::MatrixX3d& V);

/// A new (m, 3) int32 array (C order) holding F.
py::array_t<std::int32_t> faces_array(const Eigen::MatrixX3i& F);

/// A new 1-D array holding values.
template <class T>
py::array_t<T> vector_array(const std::vector<T>& values) {
  py::array_t<T> out(static_cast<py::ssize_t>(values.size()));
  std::copy(values.begin(), values.end(), out.mutable_data());
  return out;
}

/// A new 1-D float64 array holding an Eigen vector.
py::array_t<double> vector_array(const Eigen::VectorXd& values);

/// A Mesh object of the module, or a (V, F) pair (then a mesh without a file image).
Mesh to_mesh(py::handle mesh, const char* name = "mesh");

/// A path: str, bytes or os.PathLike.
std::string to_path(py::handle path);

/// The key of `key` (a Key, or a passphrase str) or of `key_file` (a path), or none when both
/// are None. \throw InvalidArgumentError when both are given.
std::optional<Key> resolve_key(py::handle key, py::handle key_file);

/// A payload from a hexadecimal str (nbits bits; 64 when nbits is None) or a sequence of 0/1
/// values (its length, which nbits must then equal when given). \throw InvalidArgumentError
/// naming the bad value.
Payload to_payload(py::handle payload, py::handle nbits, const char* name = "payload");

/// A Variant, or one from its three letters. \throw InvalidArgumentError naming a bad letter.
Variant to_variant(py::handle variant);

/// A value of the bound enum E, or its name (the library's table, enum_names.h; any case).
/// \throw TypeError for another type (naming `what`); InvalidArgumentError for an unknown
///        name (listing the names).
template <class E>
E to_enum(py::handle value, const char* what) {
  if (py::isinstance<py::str>(value)) return parse_enum<E>(value.cast<std::string>());
  if (!py::isinstance<E>(value))
    throw py::type_error(std::string(what) + ": expected a " +
                         py::str(py::type::of<E>().attr("__name__")).cast<std::string>() +
                         " or its name (" + EnumTable<E>::what + ")");
  return value.cast<E>();
}

/// Thrown through the library when a Python callback raised: the work stops, and the Python
/// exception is raised again once the GIL is held (CallbackGate::rethrow).
struct CallbackRaised : std::exception {
  const char* what() const noexcept override { return "a Python callback raised"; }
};

/// Python callables called back from the library's worker threads, under the GIL. A callable
/// that raises, or a Ctrl-C seen while one runs, stops the work: CallbackRaised goes through
/// the library, later calls throw it at once, and rethrow() raises the Python exception. A
/// gate that does not stop the work (work that must not end halfway) calls no callable after
/// one raised, and rethrow() raises it once the work is done.
class CallbackGate {
 public:
  /// progress: progress(phase, done, total, what), or None. \throw TypeError when it is
  /// neither (before any work).
  explicit CallbackGate(py::handle progress = py::none(), bool stops = true)
      : progress_(py::reinterpret_borrow<py::object>(progress)), stops_(stops) {
    if (!progress_.is_none() && PyCallable_Check(progress_.ptr()) == 0)
      throw py::type_error(
          "progress must be a callable progress(phase, done, total, what) or None");
  }
  CallbackGate(const CallbackGate&) = delete;  // the callbacks it hands out hold its address
  CallbackGate& operator=(const CallbackGate&) = delete;

  /// The progress callable as the library's ProgressCallback (empty for None). The gate must
  /// outlive the work it is given to.
  ProgressCallback progress() {
    if (progress_.is_none()) return {};
    return [this](const std::string& phase, long done, long total, const std::string& what) {
      call([&] { progress_(phase, done, total, what); });
    };
  }

  /// Runs f under the GIL, as every callback of the gate runs.
  template <class F>
  void call(F f) {
    py::gil_scoped_acquire gil;
    if (raised_ || other_) {  // another worker's callback raised: stop too, or call no more
      if (stops_) throw CallbackRaised();
      return;
    }
    try {
      f();
      if (PyErr_CheckSignals() != 0) throw py::error_already_set();  // Ctrl-C on the main thread
    } catch (py::error_already_set& e) {
      raised_ = std::move(e);
      if (stops_) throw CallbackRaised();
    } catch (...) {  // a C++ error in the call itself (a failed conversion, no memory)
      if (stops_) throw;
      other_ = std::current_exception();
    }
  }

  /// Raises what a callback raised, if one did (with the GIL held), even when the library
  /// caught CallbackRaised and went on (a copy recorded as failed).
  void rethrow() {
    if (raised_) throw *raised_;
    if (other_) std::rethrow_exception(other_);
  }

 private:
  py::object progress_;
  bool stops_ = true;
  std::optional<py::error_already_set> raised_;
  std::exception_ptr other_;
};

/// Runs work(ProgressCallback) without the GIL, progress (a callable or None) called back under
/// it; raises what progress raised (the work stopped there, or with stops false once it is
/// done), else returns what work returned.
template <class Work>
auto with_progress(py::handle progress, Work work, bool stops = true) {
  CallbackGate gate(progress, stops);
  const ProgressCallback callback = gate.progress();
  try {
    auto result = [&] {
      py::gil_scoped_release unlocked;
      return work(callback);
    }();
    gate.rethrow();
    return result;
  } catch (const CallbackRaised&) {
    gate.rethrow();
    throw;
  }
}

/// An ID: a non-negative Python int below 2^64. \throw InvalidArgumentError otherwise.
std::uint64_t to_id(py::handle id, const char* name = "id");

/// A Python object (dict, list, ...) from one JSON text (the library's *_to_json), so that
/// Python sees the same names and values as the files and the CLI's --json.
py::object json_object(const std::string& text);

/// Sets the attributes of an options object from keyword arguments, refusing names that are
/// not among the `fields` of its class (TypeError, listing the fields).
void apply_keywords(py::handle target, const py::kwargs& kwargs);

/// "Name(field=repr, ...)" over the `fields` of self's class.
std::string repr_of_fields(py::handle self);

/// Declares the fields of a bound struct: read-write fields become keyword arguments of its
/// constructor, every field listed in `fields` (a class attribute) and in its repr.
template <class T>
class Fields {
 public:
  explicit Fields(py::class_<T>& cls) : cls_(cls) {}

  /// A read-write field (an option).
  template <class M>
  Fields& rw(const char* name, M T::*member, const char* doc) {
    cls_.def_readwrite(name, member, doc);
    names_.emplace_back(name);
    return *this;
  }
  /// A read-write property with its own getter and setter (an option that converts).
  template <class Getter, class Setter>
  Fields& rw_property(const char* name, Getter getter, Setter setter, const char* doc) {
    cls_.def_property(name, getter, setter, doc);
    names_.emplace_back(name);
    return *this;
  }
  /// A read-only field (a result), shown in the repr.
  template <class M>
  Fields& ro(const char* name, M T::*member, const char* doc) {
    cls_.def_readonly(name, member, doc);
    names_.emplace_back(name);
    return *this;
  }
  /// A read-only computed property shown in the repr (a name from the library's *_name).
  template <class Getter>
  Fields& ro_property(const char* name, Getter getter, const char* doc) {
    cls_.def_property_readonly(name, getter, doc);
    names_.emplace_back(name);
    return *this;
  }
  /// A read-only computed property (arrays: a new copy on each access), not in the repr.
  template <class Getter>
  Fields& array(const char* name, Getter getter, const char* doc) {
    cls_.def_property_readonly(name, getter, doc);
    return *this;
  }
  /// Ends the declaration: `fields`, the repr, and for options a keyword constructor.
  void done(bool keyword_constructor) {
    py::tuple names(names_.size());
    for (std::size_t k = 0; k < names_.size(); ++k) names[k] = py::str(names_[k]);
    cls_.attr("fields") = names;
    if (keyword_constructor) {
      cls_.def(py::init([](const py::kwargs& kwargs) {
                 T value{};
                 apply_keywords(py::cast(&value, py::return_value_policy::reference), kwargs);
                 return value;
               }),
               "Keyword construction: every field (see `fields`) may be given; the others keep "
               "the C++ defaults.");
    }
    cls_.def("__repr__", &repr_of_fields);
  }

 private:
  py::class_<T>& cls_;
  std::vector<std::string> names_;
};

/// The binding files' parts of the module.
void init_types(py::module_& m);
void init_io(py::module_& m);
void init_embed(py::module_& m);
void init_decode(py::module_& m);
void init_attack(py::module_& m);
void init_metrics(py::module_& m);
void init_issue(py::module_& m);
void init_calibrate(py::module_& m);
void init_campaign(py::module_& m);

}  // namespace meshmark::python
