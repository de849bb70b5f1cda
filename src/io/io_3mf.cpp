// 3MF packages, through lib3mf 1.8's C interface. The reader walks the build: every build item's
// object, mesh objects directly and components objects down to their meshes, each instance's
// vertices placed in world space by the composed transforms; bit-identical positions are then
// welded (as for STL). Writing back reads the source package again with lib3mf, moves every
// mesh object's vertices by their instances' displacements taken back to object space, and lets
// lib3mf write the package; writing from scratch gives one object, one build item, millimeters.

#include <Eigen/Dense>
#include <array>
#include <cmath>
#include <limits>
#include <map>

#include <fmt/format.h>

#include <Model/COM/NMR_DLLInterfaces.h>

#include "core/component.h"
#include "io/io_formats.h"
#include "meshmark/core/error.h"

namespace meshmark::detail {

namespace {

using Affine = Eigen::Matrix<double, 3, 4>;  // world = A.leftCols<3>() * p + A.col(3)

// Owns a lib3mf handle.
struct Release {
  void operator()(NMR::PLib3MFBase* p) const {
    if (p) NMR::lib3mf_release(p);
  }
};
using Handle = std::unique_ptr<NMR::PLib3MFBase, Release>;

/// One placement of a mesh object in the build: its points are
/// points[first_point .. first_point + count) of the mesh as read.
struct Instance {
  std::uint32_t object_id = 0;
  Affine transform = Affine::Identity();
  std::size_t first_point = 0;
  std::size_t count = 0;
};

/// What a write back needs: the package as read, the instances and the vertex of every point.
struct ThreeMfImage : FormatImage {
  std::string bytes;
  std::vector<Instance> instances;
  std::vector<int> vertex_of_point;
};

/// Deepest nesting of components objects followed.
constexpr int kMaxComponentDepth = 32;

std::string last_error(NMR::PLib3MFBase* instance) {
  DWORD code = 0;
  LPCSTR message = nullptr;
  if (!instance || NMR::lib3mf_getlasterror(instance, &code, &message) != LIB3MF_OK)
    return "unknown lib3mf error";
  return fmt::format("{} (lib3mf error {:#x})", message && *message ? message : "no message",
                     static_cast<unsigned>(code));
}

// Reports a failed lib3mf call on a package being read.
void check_read(LIB3MFRESULT result, NMR::PLib3MFBase* instance, const std::string& name,
                const char* what) {
  if (result != LIB3MF_OK)
    throw InvalidInputError(name, 0, fmt::format("{}: {}", what, last_error(instance)));
}

// Reports a failed lib3mf call while writing.
void check_write(LIB3MFRESULT result, NMR::PLib3MFBase* instance, const char* what) {
  if (result != LIB3MF_OK) throw Error(fmt::format("3MF: {}: {}", what, last_error(instance)));
}

Affine affine(const NMR::MODELTRANSFORM& t) {
  Affine a;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 4; ++j) a(i, j) = t.m_fFields[i][j];
  return a;
}

Affine compose(const Affine& outer, const Affine& inner) {
  Affine a;
  a.leftCols<3>() = outer.leftCols<3>() * inner.leftCols<3>();
  a.col(3) = outer.leftCols<3>() * inner.col(3) + outer.col(3);
  return a;
}

Handle load_model(std::string& bytes, const std::string& name) {
  NMR::PLib3MFModel* model = nullptr;
  if (NMR::lib3mf_createmodel(&model) != LIB3MF_OK) throw Error("lib3mf cannot create a model");
  Handle owned(model);
  NMR::PLib3MFModelReader* reader = nullptr;
  check_read(NMR::lib3mf_model_queryreader(model, "3mf", &reader), model, name,
             "lib3mf has no 3MF reader");
  Handle owned_reader(reader);
  check_read(NMR::lib3mf_reader_readfrombuffer(reader, reinterpret_cast<BYTE*>(bytes.data()),
                                               bytes.size()),
             reader, name, "not a readable 3MF package");
  return owned;
}

// Mesh geometry of one object, as lib3mf holds it.
struct ObjectMesh {
  std::vector<NMR::MODELMESHVERTEX> vertices;
  std::vector<NMR::MODELMESHTRIANGLE> triangles;
};

Handle mesh_object(NMR::PLib3MFModel* model, std::uint32_t id, const std::string& name) {
  NMR::PLib3MFModelMeshObject* mesh = nullptr;
  check_read(NMR::lib3mf_model_getmeshobjectbyid(model, id, &mesh), model, name,
             "a mesh object cannot be found");
  return Handle(mesh);
}

ObjectMesh object_mesh(NMR::PLib3MFModelMeshObject* mesh, std::uint32_t id,
                       const std::string& name) {
  ObjectMesh out;
  DWORD nv = 0, nt = 0;
  check_read(NMR::lib3mf_meshobject_getvertexcount(mesh, &nv), mesh, name, "vertex count");
  check_read(NMR::lib3mf_meshobject_gettrianglecount(mesh, &nt), mesh, name, "triangle count");
  out.vertices.resize(nv);
  out.triangles.resize(nt);
  if (nv > 0)
    check_read(NMR::lib3mf_meshobject_getvertices(mesh, out.vertices.data(), nv, nullptr), mesh,
               name, "vertices");
  if (nt > 0)
    check_read(NMR::lib3mf_meshobject_gettriangleindices(mesh, out.triangles.data(), nt, nullptr),
               mesh, name, "triangles");
  for (DWORD t = 0; t < nt; ++t)
    for (int c = 0; c < 3; ++c)
      if (out.triangles[t].m_nIndices[c] >= nv)
        fail(name, 0,
             fmt::format("object {}, triangle {}: vertex index {} is out of range [0, {})", id, t,
                         out.triangles[t].m_nIndices[c], nv));
  return out;
}

// Walks the build, appending every mesh instance's world-space points and triangles.
class BuildWalker {
 public:
  BuildWalker(NMR::PLib3MFModel* model, const std::string& name) : model_(model), name_(name) {}

  void walk(Parsed& parsed, std::vector<Instance>& instances) {
    NMR::PLib3MFModelBuildItemIterator* items = nullptr;
    check_read(NMR::lib3mf_model_getbuilditems(model_, &items), model_, name_, "build items");
    Handle owned(items);
    BOOL more = false;
    while (NMR::lib3mf_builditemiterator_movenext(items, &more) == LIB3MF_OK && more) {
      NMR::PLib3MFModelBuildItem* item = nullptr;
      check_read(NMR::lib3mf_builditemiterator_getcurrent(items, &item), items, name_,
                 "build item");
      Handle owned_item(item);
      visit_placed(item, NMR::lib3mf_builditem_getobjectresource,
                   NMR::lib3mf_builditem_getobjecttransform, Affine::Identity(), 0, parsed,
                   instances);
    }
  }

 private:
  using GetObject = LIB3MFRESULT (*)(NMR::PLib3MFBase*, NMR::PLib3MFModelObjectResource**);
  using GetTransform = LIB3MFRESULT (*)(NMR::PLib3MFBase*, NMR::MODELTRANSFORM*);

  // Visits the object a build item or a component places, under its transform.
  void visit_placed(NMR::PLib3MFBase* part, GetObject get_object, GetTransform get_transform,
                    const Affine& outer, int depth, Parsed& parsed,
                    std::vector<Instance>& instances) {
    NMR::PLib3MFModelObjectResource* object = nullptr;
    check_read(get_object(part, &object), part, name_,
               "the object a build item or component places");
    Handle owned(object);
    NMR::MODELTRANSFORM t;
    check_read(get_transform(part, &t), part, name_, "the transform of a build item or component");
    visit(object, compose(outer, affine(t)), depth, parsed, instances);
  }

  void visit(NMR::PLib3MFModelObjectResource* object, const Affine& placement, int depth,
             Parsed& parsed, std::vector<Instance>& instances) {
    DWORD id = 0;
    check_read(NMR::lib3mf_resource_getresourceid(object, &id), object, name_, "object id");
    if (depth > kMaxComponentDepth)
      fail(name_, 0,
           fmt::format("object {}: components nested deeper than {}", id, kMaxComponentDepth));
    BOOL is_mesh = false, is_components = false;
    check_read(NMR::lib3mf_object_ismeshobject(object, &is_mesh), object, name_, "object type");
    check_read(NMR::lib3mf_object_iscomponentsobject(object, &is_components), object, name_,
               "object type");
    if (is_mesh) add_instance(id, placement, parsed, instances);
    if (!is_components) return;
    NMR::PLib3MFModelComponentsObject* group = nullptr;
    check_read(NMR::lib3mf_model_getcomponentsobjectbyid(model_, id, &group), model_, name_,
               "components object");
    Handle owned(group);
    DWORD count = 0;
    check_read(NMR::lib3mf_componentsobject_getcomponentcount(group, &count), group, name_,
               "component count");
    for (DWORD k = 0; k < count; ++k) {
      NMR::PLib3MFModelComponent* component = nullptr;
      check_read(NMR::lib3mf_componentsobject_getcomponent(group, k, &component), group, name_,
                 "component");
      Handle owned_component(component);
      visit_placed(component, NMR::lib3mf_component_getobjectresource,
                   NMR::lib3mf_component_gettransform, placement, depth + 1, parsed, instances);
    }
  }

  void add_instance(std::uint32_t id, const Affine& placement, Parsed& parsed,
                    std::vector<Instance>& instances) {
    const Handle mesh = mesh_object(model_, id, name_);
    const ObjectMesh geometry = object_mesh(mesh.get(), id, name_);
    const Instance instance{id, placement, parsed.xyz.size() / 3, geometry.vertices.size()};
    for (std::size_t v = 0; v < geometry.vertices.size(); ++v) {
      const float* p = geometry.vertices[v].m_fPosition;
      const Eigen::Vector3d world =
          placement.leftCols<3>() * Eigen::Vector3d(p[0], p[1], p[2]) + placement.col(3);
      for (int a = 0; a < 3; ++a) {
        if (!std::isfinite(world(a)))
          fail(name_, 0,
               fmt::format("object {}, vertex {}: coordinate {} is not finite{}", id, v, "xyz"[a],
                           std::isfinite(p[a]) ? " once transformed" : ""));
        parsed.xyz.push_back(world(a));
      }
    }
    const bool mirrored = placement.leftCols<3>().determinant() < 0;  // keep faces outward
    for (const NMR::MODELMESHTRIANGLE& t : geometry.triangles) {
      int face[3];
      for (int c = 0; c < 3; ++c)
        face[c] = static_cast<int>(instance.first_point + t.m_nIndices[mirrored ? 2 - c : c]);
      parsed.faces.push_back(face, 3);
    }
    instances.push_back(instance);
  }

  NMR::PLib3MFModel* model_;
  const std::string& name_;
};

// The finite float32 a coordinate becomes, or an exception naming it.
float to_float32(double value, std::uint32_t object, std::size_t vertex, int axis) {
  if (!(std::abs(value) <= std::numeric_limits<float>::max()))
    throw InvalidArgumentError(
        fmt::format("3MF stores float32 coordinates: object {}, vertex {}: {} = {} does not fit",
                    object, vertex, "xyz"[axis], value));
  return static_cast<float>(value);
}

std::string write_model(NMR::PLib3MFModel* model) {
  NMR::PLib3MFModelWriter* writer = nullptr;
  check_write(NMR::lib3mf_model_querywriter(model, "3mf", &writer), model, "no 3MF writer");
  Handle owned(writer);
  ULONG64 size = 0;
  check_write(NMR::lib3mf_writer_getstreamsize(writer, &size), writer, "cannot size the package");
  std::string bytes(size, '\0');
  check_write(NMR::lib3mf_writer_writetobuffer(writer, reinterpret_cast<BYTE*>(bytes.data()), size),
              writer, "cannot write the package");
  return bytes;
}

// Object-space displacement of every vertex of every moved object: the mean, over the
// object's instances, of its points' world displacements taken back through the instance's
// linear part.
std::map<std::uint32_t, std::vector<Eigen::Vector3d>> object_displacements(
    const ThreeMfImage& image, const std::vector<double>& world) {
  std::map<std::uint32_t, std::vector<Eigen::Vector3d>> sum;
  std::map<std::uint32_t, int> instances_of;
  for (const Instance& in : image.instances) ++instances_of[in.object_id];
  for (const Instance& in : image.instances) {
    bool moved = false;
    for (std::size_t k = 3 * in.first_point; k < 3 * (in.first_point + in.count); ++k)
      moved = moved || world[k] != 0;
    if (!moved) continue;
    const Eigen::FullPivLU<Eigen::Matrix3d> lu(in.transform.leftCols<3>());
    if (!lu.isInvertible())
      throw InvalidArgumentError(fmt::format(
          "3MF object {}: its transform in the build is singular, so moved vertices cannot be "
          "taken back to the object",
          in.object_id));
    std::vector<Eigen::Vector3d>& d = sum[in.object_id];
    d.resize(in.count, Eigen::Vector3d::Zero());
    for (std::size_t v = 0; v < in.count; ++v)
      d[v] += lu.solve(Eigen::Vector3d::Map(&world[3 * (in.first_point + v)])) /
              instances_of[in.object_id];
  }
  return sum;
}

std::string write_back(const Mesh& mesh, const ThreeMfImage& image) {
  std::string source = image.bytes;
  const Handle model = load_model(source, "the source 3MF package");
  const auto moved = object_displacements(image, point_displacements(mesh, image.vertex_of_point));
  for (const auto& [id, d] : moved) {
    const Handle object = mesh_object(model.get(), id, "the source 3MF package");
    ObjectMesh geometry = object_mesh(object.get(), id, "the source 3MF package");
    for (std::size_t v = 0; v < d.size() && v < geometry.vertices.size(); ++v) {
      if (d[v].isZero(0)) continue;
      NMR::MODELMESHVERTEX& p = geometry.vertices[v];
      for (int a = 0; a < 3; ++a)
        p.m_fPosition[a] = to_float32(p.m_fPosition[a] + d[v](a), id, v, a);
      check_write(NMR::lib3mf_meshobject_setvertex(object.get(), static_cast<DWORD>(v), &p),
                  object.get(), "cannot set a vertex");
    }
  }
  return write_model(model.get());
}

std::string write_from_scratch(const Mesh& mesh) {
  std::vector<NMR::MODELMESHVERTEX> vertices(static_cast<std::size_t>(mesh.V.rows()));
  for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    for (int a = 0; a < 3; ++a)
      vertices[i].m_fPosition[a] = to_float32(mesh.V(i, a), 1, static_cast<std::size_t>(i), a);
  std::vector<NMR::MODELMESHTRIANGLE> triangles(static_cast<std::size_t>(mesh.F.rows()));
  for (Eigen::Index t = 0; t < mesh.F.rows(); ++t)
    for (int c = 0; c < 3; ++c) triangles[t].m_nIndices[c] = static_cast<DWORD>(mesh.F(t, c));
  NMR::PLib3MFModel* model = nullptr;
  if (NMR::lib3mf_createmodel(&model) != LIB3MF_OK) throw Error("lib3mf cannot create a model");
  const Handle owned(model);
  check_write(NMR::lib3mf_model_setunit(model, NMR::MODELUNIT_MILLIMETER), model, "unit");
  NMR::PLib3MFModelMeshObject* object = nullptr;
  check_write(NMR::lib3mf_model_addmeshobject(model, &object), model, "cannot add an object");
  const Handle owned_object(object);
  check_write(NMR::lib3mf_meshobject_setgeometry(
                  object, vertices.data(), static_cast<DWORD>(vertices.size()), triangles.data(),
                  static_cast<DWORD>(triangles.size())),
              object, "cannot set the geometry");
  NMR::PLib3MFModelBuildItem* item = nullptr;
  check_write(NMR::lib3mf_model_addbuilditem(model, object, nullptr, &item), model,
              "cannot add a build item");
  const Handle owned_item(item);
  return write_model(model);
}

Mesh read(std::string bytes, const std::string& name, const ReadOptions& options) {
  auto image = std::make_shared<ThreeMfImage>();
  Parsed parsed;
  {
    const Handle model = load_model(bytes, name);
    BuildWalker(model.get(), name).walk(parsed, image->instances);
  }
  if (image->instances.empty()) fail(name, 0, "the build has no mesh object");
  Mesh mesh = assemble_welded(std::move(parsed), FileFormat::ThreeMf, name, options,
                              image->vertex_of_point);
  image->bytes = std::move(bytes);
  attach_image(mesh, std::move(image), options);
  return mesh;
}

std::string write(const Mesh& mesh, const WriteOptions& options) {
  const auto* image =
      mesh.image ? dynamic_cast<const ThreeMfImage*>(mesh.image->extra.get()) : nullptr;
  if (options.keep_source && image &&
      image_applies(mesh, FileFormat::ThreeMf, Encoding::BinaryLittleEndian))
    return write_back(mesh, *image);
  return write_from_scratch(mesh);
}

}  // namespace

// The 3mf component: the core's read_mesh and write_mesh call these.
const ThreeMfCodec kThreeMfCodec{&read, &write};
MESHMARK_COMPONENT(3mf, three_mf_codec_slot(), kThreeMfCodec)

}  // namespace meshmark::detail
