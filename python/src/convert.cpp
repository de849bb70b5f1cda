// Arrays, paths, keys, payloads and IDs from Python values, each checked at entry.

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <cmath>
#include <limits>

#include "bindings.h"
#include "meshmark/core/error.h"

namespace meshmark::python {

namespace {

// numpy.asarray(value), and the one-letter kind of its dtype ('f', 'i', 'u', 'b', ...).
py::array as_array(py::handle value, char& kind) {
  py::array a = py::module_::import("numpy").attr("asarray")(value);
  kind = a.dtype().kind();
  return a;
}

// Refuses anything but an (n, 3) array, naming the argument and the shape it has.
void require_rows_of_three(const py::array& a, const char* name, const char* what) {
  if (a.ndim() == 2 && a.shape(1) == 3) return;
  std::vector<py::ssize_t> shape(a.shape(), a.shape() + a.ndim());
  throw InvalidInputError(name, 0,
                          fmt::format("expected an (n, 3) array of {}, got shape ({}{})", what,
                                      fmt::join(shape, ", "), a.ndim() == 1 ? "," : ""));
}

}  // namespace

Eigen::MatrixX3d to_positions(py::handle array, const char* name) {
  char kind = 0;
  const py::array raw = as_array(array, kind);
  if (kind != 'f' && kind != 'i' && kind != 'u')
    throw py::type_error(fmt::format("{}: positions must be real numbers, got dtype {}", name,
                                     py::str(raw.dtype()).cast<std::string>()));
  require_rows_of_three(raw, name, "positions");
  const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(raw);
  if (!a) throw py::error_already_set();
  const auto rows = a.shape(0);
  if (rows > std::numeric_limits<int>::max())
    throw InvalidInputError(name, 0,
                            fmt::format("{} vertices are more than meshmark indexes", rows));
  Eigen::MatrixX3d V(rows, 3);
  const double* data = a.data();
  for (py::ssize_t i = 0; i < rows; ++i)
    for (int c = 0; c < 3; ++c) {
      const double x = data[3 * i + c];
      if (!std::isfinite(x))
        throw InvalidInputError(name, 0, fmt::format("vertex {}: coordinate {} is {}", i, c, x));
      V(i, c) = x;
    }
  return V;
}

Eigen::MatrixX3i to_faces(py::handle array, Eigen::Index vertices, const char* name) {
  char kind = 0;
  py::array raw = as_array(array, kind);
  if (raw.size() == 0 && raw.ndim() == 1) return Eigen::MatrixX3i(0, 3);  // [] means no faces
  if (kind != 'i' && kind != 'u')
    throw py::type_error(fmt::format("{}: face indices must be integers, got dtype {}", name,
                                     py::str(raw.dtype()).cast<std::string>()));
  require_rows_of_three(raw, name, "vertex indices");
  // Unsigned indices above 2^63 would wrap as int64: they are out of range either way.
  if (kind == 'u') raw = raw.attr("clip")(0, std::numeric_limits<std::int64_t>::max());
  const auto a = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>::ensure(raw);
  if (!a) throw py::error_already_set();
  Eigen::MatrixX3i F(a.shape(0), 3);
  const std::int64_t* data = a.data();
  for (py::ssize_t f = 0; f < a.shape(0); ++f)
    for (int c = 0; c < 3; ++c) {
      const std::int64_t v = data[3 * f + c];
      if (v < 0 || v >= vertices)
        throw InvalidInputError(
            name, 0,
            fmt::format("face {}, corner {}: vertex index {} is out of range (V has {} vertices)",
                        f, c, v, vertices));
      F(f, c) = static_cast<int>(v);
    }
  return F;
}

py::array_t<double> positions_array(const Eigen::MatrixX3d& V) {
  py::array_t<double> out({static_cast<py::ssize_t>(V.rows()), py::ssize_t{3}});
  auto w = out.mutable_unchecked<2>();
  for (Eigen::Index i = 0; i < V.rows(); ++i)
    for (int c = 0; c < 3; ++c) w(i, c) = V(i, c);
  return out;
}

py::array_t<std::int32_t> faces_array(const Eigen::MatrixX3i& F) {
  py::array_t<std::int32_t> out({static_cast<py::ssize_t>(F.rows()), py::ssize_t{3}});
  auto w = out.mutable_unchecked<2>();
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) w(f, c) = F(f, c);
  return out;
}

py::array_t<double> vector_array(const Eigen::VectorXd& values) {
  py::array_t<double> out(static_cast<py::ssize_t>(values.size()));
  std::copy(values.data(), values.data() + values.size(), out.mutable_data());
  return out;
}

Mesh to_mesh(py::handle mesh, const char* name) {
  if (py::isinstance<Mesh>(mesh)) return mesh.cast<Mesh>();
  if (py::isinstance<py::tuple>(mesh) || py::isinstance<py::list>(mesh)) {
    const py::sequence pair = py::reinterpret_borrow<py::sequence>(mesh);
    if (pair.size() == 2) {
      Eigen::MatrixX3d V = to_positions(pair[0], "V");
      Eigen::MatrixX3i F = to_faces(pair[1], V.rows(), "F");
      return make_mesh(std::move(V), std::move(F));
    }
  }
  throw py::type_error(fmt::format("{}: expected a meshmark.Mesh or a (V, F) pair, got {}", name,
                                   py::str(py::type::of(mesh)).cast<std::string>()));
}

std::string to_path(py::handle path) {
  const py::object p = py::module_::import("os").attr("fsdecode")(path);
  return p.cast<std::string>();
}

std::optional<Key> resolve_key(py::handle key, py::handle key_file) {
  if (!key.is_none() && !key_file.is_none())
    throw InvalidArgumentError("give key or key_file, not both");
  if (!key_file.is_none()) return key_from_file(to_path(key_file));
  if (key.is_none()) return std::nullopt;
  if (py::isinstance<Key>(key)) return key.cast<Key>();
  if (py::isinstance<py::str>(key)) return key_from_passphrase(key.cast<std::string>());
  throw py::type_error(fmt::format("key: expected a passphrase (str) or a meshmark.Key, got {}",
                                   py::str(py::type::of(key)).cast<std::string>()));
}

Payload to_payload(py::handle payload, py::handle nbits, const char* name) {
  if (py::isinstance<py::str>(payload))
    return payload_from_hex(payload.cast<std::string>(), nbits.is_none() ? 64 : nbits.cast<int>());
  char kind = 0;
  const py::array raw = as_array(payload, kind);
  if ((kind != 'i' && kind != 'u' && kind != 'b') || raw.ndim() != 1 || raw.size() == 0)
    throw InvalidArgumentError(
        fmt::format("{}: expected a hexadecimal str or a non-empty 1-D sequence of 0 and 1", name));
  const auto a = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>::ensure(raw);
  Payload p;
  for (py::ssize_t j = 0; j < a.size(); ++j) {
    const std::int64_t b = a.data()[j];
    if (b != 0 && b != 1)
      throw InvalidArgumentError(fmt::format("{}: bit {} is {}, not 0 or 1", name, j, b));
    p.bits.push_back(static_cast<std::uint8_t>(b));
  }
  if (!nbits.is_none() && nbits.cast<int>() != p.size())
    throw InvalidArgumentError(
        fmt::format("{}: {} bits given, but bits={}", name, p.size(), nbits.cast<int>()));
  return p;
}

Variant to_variant(py::handle variant) {
  if (py::isinstance<Variant>(variant)) return variant.cast<Variant>();
  if (py::isinstance<py::str>(variant)) return parse_variant(variant.cast<std::string>());
  throw py::type_error(fmt::format("variant: expected three letters (str) or a Variant, got {}",
                                   py::str(py::type::of(variant)).cast<std::string>()));
}

std::uint64_t to_id(py::handle id, const char* name) {
  if (!py::isinstance<py::int_>(id) || py::isinstance<py::bool_>(id))
    throw InvalidArgumentError(fmt::format("{}: expected a non-negative int", name));
  const py::int_ value = py::reinterpret_borrow<py::int_>(id);
  if (value < py::int_(0) || value >= py::int_(py::module_::import("builtins").attr("pow")(2, 64)))
    throw InvalidArgumentError(fmt::format("{} {} is not an integer in [0, 2^64)", name,
                                           py::repr(value).cast<std::string>()));
  return value.cast<std::uint64_t>();
}

py::object json_object(const std::string& text) {
  return py::module_::import("json").attr("loads")(text);
}

void apply_keywords(py::handle target, const py::kwargs& kwargs) {
  const py::tuple fields = py::type::of(target).attr("fields");
  for (const auto& [key, value] : kwargs) {
    if (!fields.contains(key)) {
      std::vector<std::string> known;
      for (const py::handle f : fields) known.push_back(f.cast<std::string>());
      throw py::type_error(fmt::format("{}: unexpected keyword '{}' (fields: {})",
                                       py::type::of(target).attr("__name__").cast<std::string>(),
                                       key.cast<std::string>(), fmt::join(known, ", ")));
    }
    py::setattr(target, key, value);
  }
}

std::string repr_of_fields(py::handle self) {
  std::string out = py::type::of(self).attr("__name__").cast<std::string>() + "(";
  const py::tuple fields = py::type::of(self).attr("fields");
  for (std::size_t k = 0; k < fields.size(); ++k) {
    const std::string name = fields[k].cast<std::string>();
    out += (k ? ", " : "") + name + "=" + py::repr(self.attr(name.c_str())).cast<std::string>();
  }
  return out + ")";
}

}  // namespace meshmark::python
