// 3MF: packages made in the test with lib3mf's own writer from real meshes (objects, a
// components object, build transforms, metadata, base materials, colors, an attachment) and
// hand-made zips for the malformed cases. World positions are checked against the transforms
// applied here; a watermarked copy against the source package, part by part.

#include <gtest/gtest.h>

#include <zip.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <regex>

#include <Model/COM/NMR_DLLInterfaces.h>

#include "meshmark/core/error.h"
#include "meshmark/io/io.h"
#include "test_data.h"

using namespace meshmark;
using namespace meshmark::test;

namespace {

constexpr const char* kPayload = "0123456789abcdef";

struct Release {
  void operator()(NMR::PLib3MFBase* p) const {
    if (p) NMR::lib3mf_release(p);
  }
};
using Handle = std::unique_ptr<NMR::PLib3MFBase, Release>;

void ok(LIB3MFRESULT r, const char* what) {
  if (r != LIB3MF_OK) throw std::runtime_error(std::string("lib3mf: ") + what);
}

void ok(LIB3MFRESULT r, const char* what, NMR::PLib3MFBase* instance) {
  DWORD code = 0;
  LPCSTR message = nullptr;
  if (r != LIB3MF_OK && NMR::lib3mf_getlasterror(instance, &code, &message) == LIB3MF_OK)
    throw std::runtime_error(std::string("lib3mf: ") + what + ": " + (message ? message : ""));
  ok(r, what);
}

// A 3x4 affine transform as lib3mf stores it: world_i = sum_j m[i][j] p_j + m[i][3].
NMR::MODELTRANSFORM transform(double angle_z, double scale, double tx, double ty, double tz) {
  NMR::MODELTRANSFORM t{};
  const double c = std::cos(angle_z), s = std::sin(angle_z);
  const double m[3][4] = {
      {scale * c, -scale * s, 0, tx}, {scale * s, scale * c, 0, ty}, {0, 0, scale, tz}};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 4; ++j) t.m_fFields[i][j] = static_cast<float>(m[i][j]);
  return t;
}

Eigen::Vector3d apply(const NMR::MODELTRANSFORM& t, const Eigen::Vector3d& p) {
  Eigen::Vector3d w;
  for (int i = 0; i < 3; ++i)
    w(i) = double(t.m_fFields[i][0]) * p(0) + double(t.m_fFields[i][1]) * p(1) +
           double(t.m_fFields[i][2]) * p(2) + double(t.m_fFields[i][3]);
  return w;
}

Handle add_mesh(NMR::PLib3MFModel* model, const Mesh& m) {
  std::vector<NMR::MODELMESHVERTEX> v(m.V.rows());
  for (Eigen::Index i = 0; i < m.V.rows(); ++i)
    for (int a = 0; a < 3; ++a) v[i].m_fPosition[a] = static_cast<float>(m.V(i, a));
  std::vector<NMR::MODELMESHTRIANGLE> t(m.F.rows());
  for (Eigen::Index f = 0; f < m.F.rows(); ++f)
    for (int c = 0; c < 3; ++c) t[f].m_nIndices[c] = static_cast<DWORD>(m.F(f, c));
  NMR::PLib3MFModelMeshObject* object = nullptr;
  ok(NMR::lib3mf_model_addmeshobject(model, &object), "add mesh");
  Handle owned(object);
  ok(NMR::lib3mf_meshobject_setgeometry(object, v.data(), v.size(), t.data(), t.size()),
     "geometry");
  return owned;
}

std::string write_model(NMR::PLib3MFModel* model) {
  NMR::PLib3MFModelWriter* writer = nullptr;
  ok(NMR::lib3mf_model_querywriter(model, "3mf", &writer), "writer");
  Handle owned(writer);
  ULONG64 size = 0;
  ok(NMR::lib3mf_writer_getstreamsize(writer, &size), "size", writer);
  std::string bytes(size, '\0');
  ok(NMR::lib3mf_writer_writetobuffer(writer, reinterpret_cast<BYTE*>(bytes.data()), size),
     "write");
  return bytes;
}

// The scene: spot (object 1, base materials alternating per triangle) at the origin; the
// bunny (object 2, a color per triangle) inside a components object (3) scaled by 10, the
// build item rotating it by 90 degrees about z and moving it. Metadata and an attachment.
struct Scene {
  Mesh spot, bunny;
  NMR::MODELTRANSFORM component = transform(0, 10, 0.5, 0, 0);
  NMR::MODELTRANSFORM item = transform(M_PI / 2, 1, 3, -1, 0.25);
  DWORD spot_id = 0, bunny_id = 0;  // their resource ids
  std::string package;
};

Scene make_scene(const std::string& spot_path, const std::string& bunny_path) {
  Scene s;
  s.spot = read_mesh(spot_path);
  s.bunny = read_mesh(bunny_path);
  NMR::PLib3MFModel* model = nullptr;
  ok(NMR::lib3mf_createmodel(&model), "model");
  Handle owned(model);
  ok(NMR::lib3mf_model_addmetadatautf8(model, "Title", "meshmark 3MF test"), "metadata");
  ok(NMR::lib3mf_model_addmetadatautf8(model, "Designer", "lib3mf"), "metadata");
  NMR::PLib3MFModelBaseMaterial* group = nullptr;
  ok(NMR::lib3mf_model_addbasematerialgroup(model, &group), "materials");
  Handle owned_group(group);
  DWORD red = 0, blue = 0, group_id = 0;
  ok(NMR::lib3mf_basematerial_addmaterialutf8(group, "red", 255, 0, 0, &red), "material");
  ok(NMR::lib3mf_basematerial_addmaterialutf8(group, "blue", 0, 0, 255, &blue), "material");
  ok(NMR::lib3mf_resource_getresourceid(group, &group_id), "id");
  const Handle spot = add_mesh(model, s.spot), bunny = add_mesh(model, s.bunny);
  ok(NMR::lib3mf_resource_getresourceid(spot.get(), &s.spot_id), "id");
  ok(NMR::lib3mf_resource_getresourceid(bunny.get(), &s.bunny_id), "id");
  NMR::PLib3MFPropertyHandler* props = nullptr;
  ok(NMR::lib3mf_meshobject_createpropertyhandler(spot.get(), &props), "properties");
  Handle owned_props(props);
  for (Eigen::Index t = 0; t < s.spot.F.rows(); ++t)
    ok(NMR::lib3mf_propertyhandler_setbasematerial(props, t, group_id, t % 2 ? red : blue), "bm");
  NMR::PLib3MFPropertyHandler* colors = nullptr;
  ok(NMR::lib3mf_meshobject_createpropertyhandler(bunny.get(), &colors), "properties");
  Handle owned_colors(colors);
  for (Eigen::Index t = 0; t < s.bunny.F.rows(); ++t)
    ok(NMR::lib3mf_propertyhandler_setsinglecolorrgb(colors, t, t % 256, 128, 7), "color");
  // lib3mf writes triangle properties only beside an object-level default.
  NMR::PLib3MFDefaultPropertyHandler *spot_default = nullptr, *bunny_default = nullptr;
  ok(NMR::lib3mf_object_createdefaultpropertyhandler(spot.get(), &spot_default), "default");
  ok(NMR::lib3mf_object_createdefaultpropertyhandler(bunny.get(), &bunny_default), "default");
  Handle owned_spot_default(spot_default), owned_bunny_default(bunny_default);
  ok(NMR::lib3mf_defaultpropertyhandler_setbasematerial(spot_default, group_id, red), "default");
  ok(NMR::lib3mf_defaultpropertyhandler_setcolorrgb(bunny_default, 1, 2, 3), "default");
  NMR::PLib3MFModelComponentsObject* assembly = nullptr;
  ok(NMR::lib3mf_model_addcomponentsobject(model, &assembly), "components");
  Handle owned_assembly(assembly);
  NMR::PLib3MFModelComponent* component = nullptr;
  ok(NMR::lib3mf_componentsobject_addcomponent(assembly, bunny.get(), &s.component, &component),
     "component");
  Handle owned_component(component);
  NMR::PLib3MFModelBuildItem *item1 = nullptr, *item2 = nullptr;
  ok(NMR::lib3mf_model_addbuilditem(model, spot.get(), nullptr, &item1), "item");
  ok(NMR::lib3mf_model_addbuilditem(model, assembly, &s.item, &item2), "item");
  Handle owned1(item1), owned2(item2);
  NMR::PLib3MFModelAttachment* attachment = nullptr;
  char path[] = "/Metadata/notes.txt", rel[] = "http://example.com/meshmark/notes";
  ok(NMR::lib3mf_model_addattachmentutf8(model, path, rel, &attachment), "attachment");
  Handle owned_attachment(attachment);
  std::string notes = "sold to buyer 42";
  ok(NMR::lib3mf_attachment_readfrombuffer(attachment, reinterpret_cast<BYTE*>(notes.data()),
                                           notes.size()),
     "attachment data");
  s.package = write_model(model);
  return s;
}

// The entries of a zip archive: name -> bytes.
std::map<std::string, std::string> zip_entries(const std::string& path) {
  int err = 0;
  zip_t* z = zip_open(path.c_str(), ZIP_RDONLY, &err);
  if (!z) throw std::runtime_error("cannot open zip " + path);
  std::map<std::string, std::string> out;
  for (zip_int64_t i = 0; i < zip_get_num_entries(z, 0); ++i) {
    zip_stat_t st;
    zip_stat_index(z, i, 0, &st);
    std::string data(st.size, '\0');
    zip_file_t* f = zip_fopen_index(z, i, 0);
    if (st.size > 0) zip_fread(f, data.data(), st.size);
    zip_fclose(f);
    out[st.name] = std::move(data);
  }
  zip_close(z);
  return out;
}

void write_zip(const std::string& path, const std::map<std::string, std::string>& entries) {
  int err = 0;
  zip_t* z = zip_open(path.c_str(), ZIP_CREATE | ZIP_TRUNCATE, &err);
  ASSERT_NE(z, nullptr);
  for (const auto& [name, data] : entries)
    zip_file_add(z, name.c_str(), zip_source_buffer(z, data.data(), data.size(), 0),
                 ZIP_FL_OVERWRITE);
  ASSERT_EQ(zip_close(z), 0);
}

// The coordinates of object `id`'s vertices as the model XML's text gives them, as float32.
std::vector<std::array<float, 3>> vertex_text(const std::string& xml, DWORD id) {
  std::vector<std::array<float, 3>> out;
  std::size_t p = xml.find("<object id=\"" + std::to_string(id) + "\"");
  const std::size_t end = xml.find("</vertices>", p);
  while ((p = xml.find("<vertex ", p)) < end) {
    std::array<float, 3> v{};
    for (int a = 0; a < 3; ++a) {
      p = xml.find(std::string(1, "xyz"[a]) + "=\"", p) + 3;
      v[a] = std::strtof(xml.c_str() + p, nullptr);
    }
    out.push_back(v);
  }
  return out;
}

// The model XML without its vertex coordinates.
std::string without_vertices(const std::string& xml) {
  static const std::regex vertex("<vertex [^>]*/>");
  return std::regex_replace(xml, vertex, "<vertex/>");
}

const char* kContentTypes =
    R"(<?xml version="1.0" encoding="UTF-8"?>
<Types xmlns="http://schemas.openxmlformats.org/package/2006/content-types"><Default Extension="rels" ContentType="application/vnd.openxmlformats-package.relationships+xml"/><Default Extension="model" ContentType="application/vnd.ms-package.3dmanufacturing-3dmodel+xml"/></Types>)";
const char* kRels =
    R"(<?xml version="1.0" encoding="UTF-8"?>
<Relationships xmlns="http://schemas.openxmlformats.org/package/2006/relationships"><Relationship Target="/3D/3dmodel.model" Id="rel0" Type="http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"/></Relationships>)";

// A tetrahedron model; vertex 3's x and the last triangle's v3 as given.
std::string tetrahedron(const std::string& x3, const std::string& v3) {
  return R"(<?xml version="1.0" encoding="UTF-8"?>
<model unit="millimeter" xmlns="http://schemas.microsoft.com/3dmanufacturing/core/2015/02">
<resources><object id="1" type="model"><mesh><vertices>
<vertex x="0" y="0" z="0"/><vertex x="10" y="0" z="0"/><vertex x="0" y="10" z="0"/>
<vertex x=")" +
         x3 +
         R"(" y="0" z="10"/></vertices><triangles>
<triangle v1="0" v2="2" v3="1"/><triangle v1="0" v2="1" v3="3"/><triangle v1="0" v2="3" v3="2"/>
<triangle v1="1" v2="2" v3=")" +
         v3 + R"("/></triangles></mesh></object></resources>
<build><item objectid="1"/></build></model>)";
}

}  // namespace

TEST(ThreeMfRead, BuildInWorldSpaceWithComponents) {
  const std::string spot = data_mesh("spot.obj"), bunny = data_mesh("bunny.ply");
  MESHMARK_REQUIRE(spot, "spot.obj");
  MESHMARK_REQUIRE(bunny, "bunny.ply");
  const Scene s = make_scene(spot, bunny);
  const std::string path = scratch_dir() + "/scene.3mf";
  std::ofstream(path, std::ios::binary) << s.package;
  const Mesh m = read_mesh(path);
  // Expected: the coordinates as the model part's text gives them (lib3mf writes 6 decimals),
  // spot's as they are, the bunny's through component then item; each object's bit-identical
  // positions once, in order of first appearance.
  const std::string xml = zip_entries(path).at("3D/3dmodel.model");
  std::vector<Eigen::Vector3d> expected;
  for (const DWORD object : {s.spot_id, s.bunny_id}) {
    std::map<std::array<float, 3>, int> seen;
    for (const std::array<float, 3>& f : vertex_text(xml, object))
      if (seen.emplace(f, 0).second) {
        const Eigen::Vector3d p(f[0], f[1], f[2]);
        expected.push_back(object == s.spot_id ? p : apply(s.item, apply(s.component, p)));
      }
  }
  ASSERT_EQ(static_cast<std::size_t>(m.V.rows()), expected.size());
  EXPECT_EQ(m.F.rows(), s.spot.F.rows() + s.bunny.F.rows());
  // The reader composes the two float32 transforms before applying them: a few ulps apart.
  const double tolerance = 1e-12 * bounding_box_diagonal(m.V);
  double worst = 0;
  for (std::size_t i = 0; i < expected.size(); ++i)
    worst = std::max(worst, (m.V.row(i).transpose() - expected[i]).cwiseAbs().maxCoeff());
  EXPECT_LE(worst, tolerance);
}

// Embeds with the command line; the copy carries the mark, and every part of the package
// lib3mf wrote is unchanged but the vertex coordinates of the model part.
TEST(ThreeMfWriteBack, MarkSurvivesAndOnlyVerticesChange) {
  const std::string spot = data_mesh("spot.obj"), bunny = data_mesh("bunny.ply");
  MESHMARK_REQUIRE(spot, "spot.obj");
  MESHMARK_REQUIRE(bunny, "bunny.ply");
  const std::string dir = scratch_dir();
  const Scene s = make_scene(spot, bunny);
  const std::string a = dir + "/scene.3mf", b = dir + "/marked.3mf";
  std::ofstream(a, std::ios::binary) << s.package;
  const CliRun e = run_cli("embed " + a + " " + b + " --payload " + kPayload);
  ASSERT_EQ(e.code, 0) << e.out;
  const CliRun x = run_cli("extract " + b + " --expect " + kPayload);
  EXPECT_EQ(x.code, 0) << x.out;
  const auto pa = zip_entries(a), pb = zip_entries(b);
  std::vector<std::string> na, nb;
  for (const auto& [n, d] : pa) na.push_back(n);
  for (const auto& [n, d] : pb) nb.push_back(n);
  // lib3mf 1.8 drops attachments whose relationship type the reader was not told about, and
  // the model's relationships part that named it.
  std::erase(na, "Metadata/notes.txt");
  std::erase(na, "3D/_rels/3dmodel.model.rels");
  EXPECT_EQ(na, nb);
  for (const auto& [n, d] : pb) {
    SCOPED_TRACE(n);
    if (n == "3D/3dmodel.model") {
      EXPECT_EQ(without_vertices(d), without_vertices(pa.at(n)));
      EXPECT_NE(d, pa.at(n));
    } else {
      EXPECT_EQ(d, pa.at(n));
    }
  }
  const Mesh ma = read_mesh(a), mb = read_mesh(b);
  ASSERT_EQ(ma.V.rows(), mb.V.rows());
  EXPECT_EQ(ma.F, mb.F);
  // The mark moves vertices by a small fraction of the size; lib3mf writes 6 decimals.
  const double diag = bounding_box_diagonal(ma.V);
  EXPECT_LE((ma.V - mb.V).cwiseAbs().maxCoeff(), 0.01 * diag);
  EXPECT_GT((ma.V - mb.V).cwiseAbs().maxCoeff(), 0);
}

TEST(ThreeMfWrite, FromScratchOneObjectMillimeters) {
  const std::string spot = data_mesh("spot.obj");
  MESHMARK_REQUIRE(spot, "spot.obj");
  const std::string dir = scratch_dir();
  const Mesh m = read_mesh(spot);
  write_mesh(dir + "/spot.3mf", m);
  const auto entries = zip_entries(dir + "/spot.3mf");
  ASSERT_TRUE(entries.count("3D/3dmodel.model"));
  const std::string& xml = entries.at("3D/3dmodel.model");
  EXPECT_NE(xml.find("unit=\"millimeter\""), std::string::npos);
  const auto count = [&](const std::string& what) {
    std::size_t n = 0;
    for (std::size_t p = xml.find(what); p != std::string::npos; p = xml.find(what, p + 1)) ++n;
    return n;
  };
  EXPECT_EQ(count("<object "), 1u);
  EXPECT_EQ(count("<item "), 1u);
  EXPECT_EQ(count("<vertex "), static_cast<std::size_t>(m.V.rows()));
  EXPECT_EQ(count("<triangle "), static_cast<std::size_t>(m.F.rows()));
  const Mesh back = read_mesh(dir + "/spot.3mf");
  EXPECT_EQ(back.F, m.F);
  // lib3mf writes 6 digits after the point, truncating: within 1e-6 plus float32 rounding.
  const double tolerance = 1e-6 + 1e-7 * m.V.cwiseAbs().maxCoeff();
  EXPECT_LE((back.V - m.V).cwiseAbs().maxCoeff(), tolerance);
  Mesh huge = m;
  huge.V(0, 0) = 1e39;
  EXPECT_THROW(write_mesh_to_bytes(huge, FileFormat::ThreeMf), InvalidArgumentError);
  EXPECT_FALSE(std::filesystem::exists(dir + "/huge.3mf"));
}

TEST(ThreeMfRead, MalformedPackagesThrowNamingTheFile) {
  const std::string dir = scratch_dir();
  write_zip(dir + "/good.3mf", {{"[Content_Types].xml", kContentTypes},
                                {"_rels/.rels", kRels},
                                {"3D/3dmodel.model", tetrahedron("0", "3")}});
  const Mesh good = read_mesh(dir + "/good.3mf");  // the hand-made package is valid
  EXPECT_EQ(good.V.rows(), 4);
  EXPECT_EQ(good.F.rows(), 4);
  write_zip(dir + "/no-model.3mf",
            {{"[Content_Types].xml", kContentTypes}, {"_rels/.rels", kRels}});
  write_zip(dir + "/index.3mf", {{"[Content_Types].xml", kContentTypes},
                                 {"_rels/.rels", kRels},
                                 {"3D/3dmodel.model", tetrahedron("0", "9")}});
  write_zip(dir + "/nan.3mf", {{"[Content_Types].xml", kContentTypes},
                               {"_rels/.rels", kRels},
                               {"3D/3dmodel.model", tetrahedron("nan", "3")}});
  write_zip(dir + "/huge.3mf", {{"[Content_Types].xml", kContentTypes},
                                {"_rels/.rels", kRels},
                                {"3D/3dmodel.model", tetrahedron("1e39", "3")}});
  const std::string bytes = read_file(dir + "/good.3mf");
  std::ofstream(dir + "/truncated.3mf", std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  std::mt19937 rng(11);
  std::string noise(4096, '\0');
  for (char& c : noise) c = static_cast<char>(rng());
  std::ofstream(dir + "/noise.3mf", std::ios::binary) << noise;
  for (const char* file :
       {"no-model.3mf", "index.3mf", "nan.3mf", "huge.3mf", "truncated.3mf", "noise.3mf"}) {
    SCOPED_TRACE(file);
    expect_invalid_input(dir + "/" + file);
  }
}
