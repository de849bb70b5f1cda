// Meshes and their files: meshmark.Mesh, read_mesh, write_mesh.

#include <fmt/format.h>

#include "bindings.h"
#include "meshmark/core/error.h"
#include "meshmark/io/io.h"

namespace meshmark::python {

namespace {

// The WriteOptions of write_mesh's keywords (format and encoding by the CLI's names).
WriteOptions write_options(const std::optional<std::string>& format,
                           const std::optional<std::string>& encoding, bool single_precision,
                           bool keep_source, bool float_positions) {
  WriteOptions o;
  if (format) o.format = parse_enum<FileFormat>(*format);
  if (encoding) o.encoding = parse_enum<Encoding>(*encoding);
  o.single_precision = single_precision;
  o.keep_source = keep_source;
  o.float_positions = float_positions;
  return o;
}

void bind_mesh(py::module_& m) {
  py::enum_<FileFormat>(m, "FileFormat", "Mesh file formats.")
      .value("Off", FileFormat::Off)
      .value("Obj", FileFormat::Obj)
      .value("Ply", FileFormat::Ply)
      .value("Stl", FileFormat::Stl)
      .value("Gltf", FileFormat::Gltf)
      .value("Glb", FileFormat::Glb)
      .value("Draco", FileFormat::Draco)
      .value("ThreeMf", FileFormat::ThreeMf);
  py::enum_<Encoding>(m, "Encoding", "How a file stores its numbers.")
      .value("Ascii", Encoding::Ascii)
      .value("BinaryLittleEndian", Encoding::BinaryLittleEndian)
      .value("BinaryBigEndian", Encoding::BinaryBigEndian);
  py::class_<Mesh>(m, "Mesh",
                   "A triangle mesh: positions V (n, 3) and triangles F (m, 3), plus, when read "
                   "from a file, an image of that file so that write_mesh in the same format "
                   "changes the positions and nothing else. Unpacks as V, F = mesh.")
      .def(py::init([](py::handle V, py::handle F) {
             Eigen::MatrixX3d v = to_positions(V);
             Eigen::MatrixX3i f = to_faces(F, v.rows());
             return make_mesh(std::move(v), std::move(f));
           }),
           py::arg("V"), py::arg("F"), "A mesh of V and F alone (no file image).")
      .def_property(
          "V", [](const Mesh& x) { return positions_array(x.V); },
          [](Mesh& x, py::handle V) {
            Eigen::MatrixX3d v = to_positions(V);
            if (v.rows() != x.V.rows())
              throw InvalidInputError("V", 0,
                                      fmt::format("{} rows given for a mesh of {} vertices: set "
                                                  "new connectivity with Mesh(V, F)",
                                                  v.rows(), x.V.rows()));
            x.V = std::move(v);
          },
          "(n, 3) float64 positions (a new array on each access; assign a same-shaped array to "
          "move the vertices, the file image is kept)")
      .def_property_readonly(
          "F", [](const Mesh& x) { return faces_array(x.F); },
          "(m, 3) int32 triangles, 0-based (polygons fan-triangulated)")
      .def_readonly("format", &Mesh::format, "FileFormat of the source file")
      .def_readonly("encoding", &Mesh::encoding, "Encoding of the source file")
      .def_readonly("source_path", &Mesh::source_path, "the path it was read from, if any")
      .def_readonly("notes", &Mesh::notes, "what the reader noticed, one sentence each")
      .def_property_readonly(
          "has_image", [](const Mesh& x) { return x.image != nullptr; },
          "whether the file image is kept (faithful writing)")
      .def("__iter__",
           [](const Mesh& x) {
             return py::iter(py::make_tuple(positions_array(x.V), faces_array(x.F)));
           })
      .def("__repr__", [](const Mesh& x) {
        return fmt::format("Mesh({} vertices, {} triangles{})", x.V.rows(), x.F.rows(),
                           x.source_path.empty() ? "" : ", from '" + x.source_path + "'");
      });
}

}  // namespace

void init_io(py::module_& m) {
  bind_mesh(m);
  m.def(
      "read_mesh",
      [](py::handle path, double weld_tolerance) {
        ReadOptions o;
        o.weld_tolerance = weld_tolerance;
        const std::string p = to_path(path);
        py::gil_scoped_release unlocked;
        return read_mesh(p, o);
      },
      py::arg("path"), py::arg("weld_tolerance") = 0.0,
      "Reads a mesh (.off .obj .ply .stl .gltf .glb .drc .3mf, from the extension). "
      "weld_tolerance: positions closer than this (model units) are welded, as the CLI's "
      "--weld-tolerance. Raises IOError when the file cannot be read, InvalidInputError (naming "
      "file, line or element) when it is malformed.");
  m.def(
      "write_mesh",
      [](py::handle path, py::handle mesh, std::optional<std::string> format,
         std::optional<std::string> encoding, bool single_precision, bool keep_source,
         bool float_positions) {
        const Mesh x = to_mesh(mesh);
        const WriteOptions o =
            write_options(format, encoding, single_precision, keep_source, float_positions);
        const std::string p = to_path(path);
        py::gil_scoped_release unlocked;
        write_mesh(p, x, o);
      },
      py::arg("path"), py::arg("mesh"), py::kw_only(), py::arg("format") = py::none(),
      py::arg("encoding") = py::none(), py::arg("single_precision") = false,
      py::arg("keep_source") = true, py::arg("float_positions") = false,
      "Writes a Mesh (or a (V, F) pair) atomically. format: off obj ply stl gltf glb drc 3mf "
      "(default: from the extension); encoding: ascii, binary_little_endian or "
      "binary_big_endian (PLY, STL); single_precision: float32 coordinates (PLY written from "
      "scratch); keep_source: use the file image when it applies; float_positions: glTF "
      "quantized positions stored as float32. The options of the CLI's --format, --encoding, "
      "--float32, --float-positions.");
}

}  // namespace meshmark::python
