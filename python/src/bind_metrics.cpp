// Distortion metrics: compare (the CLI's compare), vertex_rms_percent, surface_distance, msdm,
// msdm2.

#include "bindings.h"
#include "meshmark/core/error.h"
#include "meshmark/metrics/metrics.h"

namespace meshmark::python {

namespace {

void bind_types(py::module_& m) {
  py::class_<SurfaceDistance> d(m, "SurfaceDistance",
                                "MRMS and Hausdorff between two surfaces (model units).");
  Fields<SurfaceDistance>(d)
      .ro("rms_ab", &SurfaceDistance::rms_ab, "one-sided RMS, A's samples to B")
      .ro("rms_ba", &SurfaceDistance::rms_ba, "one-sided RMS, B's samples to A")
      .ro("max_ab", &SurfaceDistance::max_ab, "one-sided maximum")
      .ro("max_ba", &SurfaceDistance::max_ba, "one-sided maximum")
      .ro("mrms", &SurfaceDistance::mrms, "max(rms_ab, rms_ba)")
      .ro("hausdorff", &SurfaceDistance::hausdorff, "max(max_ab, max_ba)")
      .ro("diagonal", &SurfaceDistance::diagonal, "A's bounding-box diagonal")
      .done(false);
  d.def("mrms_percent", &SurfaceDistance::mrms_percent, "MRMS, % of the diagonal");
  d.def("hausdorff_percent", &SurfaceDistance::hausdorff_percent, "Hausdorff, % of the diagonal");
  py::class_<MsdmOptions> o(m, "MsdmOptions", "MSDM's radii, fractions of the longest side.");
  Fields<MsdmOptions>(o)
      .rw("curvature_radius", &MsdmOptions::curvature_radius, "normal-cycle ball")
      .rw("window_radius", &MsdmOptions::window_radius, "local window")
      .rw("window_sigma", &MsdmOptions::window_sigma, "its Gaussian")
      .done(true);
  py::class_<PerceptualDistance> p(m, "PerceptualDistance", "A global score and local ones.");
  Fields<PerceptualDistance>(p)
      .ro("global_", &PerceptualDistance::global, "in [0, 1), 0 for identical meshes")
      .array(
          "local", [](const PerceptualDistance& x) { return vector_array(x.local); },
          "(n,) float64 per vertex of the first mesh")
      .done(false);
}

// Surface distances sample each surface: a mesh without triangles has none (the library
// assumes samples: refused here with a clear message).
void require_triangles(const Eigen::MatrixX3i& F, const char* name) {
  if (F.rows() == 0)
    throw InvalidInputError(name, 0, "no triangles: a surface distance needs a surface");
}

// The CLI's compare of two meshes, with its JSON report's keys.
py::dict compare(const Mesh& A, const Mesh& B, const SurfaceDistanceOptions& sampling,
                 py::handle progress) {
  require_triangles(A.F, "a");
  require_triangles(B.F, "b");
  const MeshComparison c = with_progress(progress, [&](const ProgressCallback& report) {
    CompareOptions options;
    options.sampling = sampling;
    options.progress = report;
    return compare_meshes(A, B, options);
  });
  const SurfaceDistance& d = c.surface;
  py::dict out;
  out["same_connectivity"] = c.same_connectivity;
  if (c.same_connectivity) out["rms_percent"] = c.rms_percent, out["msdm"] = c.msdm;
  out["mrms_percent"] = d.mrms_percent();
  out["hausdorff_percent"] = d.hausdorff_percent();
  out["rms_ab"] = d.rms_ab;
  out["rms_ba"] = d.rms_ba;
  out["hausdorff"] = d.hausdorff;
  out["msdm2"] = c.msdm2.global;
  return out;
}

// (V, F) of two same-connectivity position sets: A, B (n, 3) and F checked against n.
struct SharedConnectivity {
  Eigen::MatrixX3d A, B;
  Eigen::MatrixX3i F;
};
SharedConnectivity shared(py::handle A, py::handle B, py::handle F) {
  SharedConnectivity s{to_positions(A, "A"), to_positions(B, "B"), {}};
  s.F = to_faces(F, std::min(s.A.rows(), s.B.rows()));
  return s;
}

}  // namespace

void init_metrics(py::module_& m) {
  bind_types(m);
  m.def(
      "compare",
      [](py::handle a, py::handle b, int samples, std::uint64_t seed, py::handle progress) {
        SurfaceDistanceOptions o;
        o.samples = samples;
        o.seed = seed;
        return compare(to_mesh(a, "a"), to_mesh(b, "b"), o, progress);
      },
      py::arg("a"), py::arg("b"), py::kw_only(), py::arg("samples") = 0, py::arg("seed") = 1,
      py::arg("progress") = py::none(),
      "The CLI's compare of two Meshes (or (V, F) pairs), as a dict with its JSON keys: "
      "same_connectivity, rms_percent and msdm (same connectivity only), mrms_percent, "
      "hausdorff_percent, rms_ab, rms_ba, hausdorff (model units), msdm2. progress(phase, done, "
      "total, what) is called as MSDM and MSDM2 walk their windows (minutes on a million "
      "vertices); an exception it raises (or Ctrl-C) stops the comparison and is raised here.");
  m.def(
      "vertex_rms_percent",
      [](py::handle A, py::handle B, py::handle F) {
        const SharedConnectivity s = shared(A, B, F);
        return vertex_rms_percent(s.A, s.B, s.F);
      },
      py::arg("A"), py::arg("B"), py::arg("F"),
      "Vertex RMS of B - A over the referenced vertices, % of A's bounding-box diagonal.");
  m.def(
      "surface_distance",
      [](py::handle VA, py::handle FA, py::handle VB, py::handle FB, int samples,
         std::uint64_t seed) {
        const Eigen::MatrixX3d va = to_positions(VA, "VA"), vb = to_positions(VB, "VB");
        const Eigen::MatrixX3i fa = to_faces(FA, va.rows(), "FA"),
                               fb = to_faces(FB, vb.rows(), "FB");
        require_triangles(fa, "FA");
        require_triangles(fb, "FB");
        SurfaceDistanceOptions o;
        o.samples = samples;
        o.seed = seed;
        py::gil_scoped_release unlocked;
        return surface_distance(va, fa, vb, fb, o);
      },
      py::arg("VA"), py::arg("FA"), py::arg("VB"), py::arg("FB"), py::kw_only(),
      py::arg("samples") = 0, py::arg("seed") = 1,
      "MRMS and Hausdorff between two meshes of any connectivity (samples: area samples per "
      "surface besides the vertices, 0 for 2 per vertex and at least 50,000).");
  m.def(
      "msdm",
      [](py::handle A, py::handle B, py::handle F, const MsdmOptions& options,
         py::handle progress) {
        const SharedConnectivity s = shared(A, B, F);
        return with_progress(progress, [&](const ProgressCallback& report) {
          return msdm(s.A, s.B, s.F, options, report);
        });
      },
      py::arg("A"), py::arg("B"), py::arg("F"), py::arg("options") = MsdmOptions{}, py::kw_only(),
      py::arg("progress") = py::none(),
      "MSDM (Lavoue et al. 2006) between positions A and B of one connectivity F. progress: as "
      "compare's.");
  m.def(
      "msdm2",
      [](py::handle VA, py::handle FA, py::handle VB, py::handle FB) {
        const Eigen::MatrixX3d va = to_positions(VA, "VA"), vb = to_positions(VB, "VB");
        const Eigen::MatrixX3i fa = to_faces(FA, va.rows(), "FA"),
                               fb = to_faces(FB, vb.rows(), "FB");
        require_triangles(fa, "FA");
        require_triangles(fb, "FB");
        py::gil_scoped_release unlocked;
        return msdm2(va, fa, vb, fb);
      },
      py::arg("VA"), py::arg("FA"), py::arg("VB"), py::arg("FB"),
      "MSDM2 (Lavoue 2011) between meshes of any connectivity, symmetric.");
}

}  // namespace meshmark::python
