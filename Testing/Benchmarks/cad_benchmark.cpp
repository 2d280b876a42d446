// PSYS (MeshCADSurface's pipeline) against OpenCASCADE's own mesher BRepMesh, both followed by the
// same TetGen call and the same improvement, on the CAD test models (Testing/Fixtures/CadModels.h),
// at about equal surface vertex counts (BRepMesh's deflection is bisected to PSYS's count). Then
// one large model for the 1 M-tet timing.
//   build/Testing/cad_benchmark [RESULTS_FILE]
// Figures per mesher: surface vertices, triangles, triangle minimum angle (min, median over the
// triangles of each one's smallest angle), radius-edge ratio (max, median), the two-sided
// Hausdorff distance between the triangles and the CAD surface (sampled: triangle centroids and
// edge midpoints to their patch, and points of each patch to the nearest triangle), tets, tet
// dihedral range after TetGen (-q1.414/10) and after the improvement (surfaces kept), seconds.
#include <BRepClass_FaceClassifier.hxx>
#include <BRepMesh_IncrementalMesh.hxx>
#include <BRepTools.hxx>
#include <BRep_Tool.hxx>
#include <GeomAPI_ProjectPointOnSurf.hxx>
#include <Poly_Triangulation.hxx>
#include <TopExp.hxx>
#include <TopTools_IndexedMapOfShape.hxx>
#include <TopoDS.hxx>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>

#include "Algorithms/SurfaceMeshing/CadMesher.h"
#include "Fixtures/CadModels.h"

using namespace tetflow;

namespace {

using Tri = std::array<int32_t, 3>;

struct Surface {
  std::vector<Vec3> points;
  std::vector<Tri> tris;
  std::vector<int32_t> face; // OpenCASCADE face index - 1 (= CadModel patch)
};

double now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// BRepMesh with linear deflection `defl` (angular 0.5 rad); nodes merged by position.
Surface brepMesh(const TopoDS_Shape& shape, double defl) {
  BRepTools::Clean(shape);
  BRepMesh_IncrementalMesh mesher(shape, defl, false, 0.5, false);
  TopTools_IndexedMapOfShape faces;
  TopExp::MapShapes(shape, TopAbs_FACE, faces);
  Surface s;
  std::map<std::array<long long, 3>, int32_t> index;
  const double q = 1e9;
  for (int f = 1; f <= faces.Extent(); ++f) {
    const TopoDS_Face& face = TopoDS::Face(faces(f));
    TopLoc_Location loc;
    Handle(Poly_Triangulation) T = BRep_Tool::Triangulation(face, loc);
    if (T.IsNull()) continue;
    std::vector<int32_t> ids(size_t(T->NbNodes()) + 1);
    for (int i = 1; i <= T->NbNodes(); ++i) {
      const gp_Pnt p = T->Node(i).Transformed(loc.Transformation());
      const std::array<long long, 3> key{std::llround(p.X() * q), std::llround(p.Y() * q), std::llround(p.Z() * q)};
      auto it = index.find(key);
      if (it == index.end()) {
        it = index.emplace(key, int32_t(s.points.size())).first;
        s.points.push_back({p.X(), p.Y(), p.Z()});
      }
      ids[size_t(i)] = it->second;
    }
    const bool rev = face.Orientation() == TopAbs_REVERSED;
    for (int i = 1; i <= T->NbTriangles(); ++i) {
      int a, b, c;
      T->Triangle(i).Get(a, b, c);
      Tri t{ids[size_t(a)], ids[size_t(b)], ids[size_t(c)]};
      if (rev) std::swap(t[1], t[2]);
      if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) continue;
      s.tris.push_back(t);
      s.face.push_back(f - 1);
    }
  }
  return s;
}

double pointTriangleDistance(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  // Ericson's closest point on a triangle.
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return norm(p - a);
  const Vec3 bp = p - b;
  const double d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return norm(p - b);
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return norm(p - (a + (d1 / (d1 - d3)) * ab));
  const Vec3 cp = p - c;
  const double d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return norm(p - c);
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return norm(p - (a + (d2 / (d2 - d6)) * ac));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return norm(p - (b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b)));
  const double den = 1.0 / (va + vb + vc);
  return norm(p - (a + (vb * den) * ab + (vc * den) * ac));
}

// Two-sided Hausdorff distance, sampled.
double hausdorff(const TopoDS_Shape& shape, const Surface& s) {
  TopTools_IndexedMapOfShape faces;
  TopExp::MapShapes(shape, TopAbs_FACE, faces);
  // One projector per face, initialised once (its search grid is built once, not per point).
  std::vector<GeomAPI_ProjectPointOnSurf> proj(size_t(faces.Extent()));
  std::vector<gp_Trsf> inv(size_t(faces.Extent()));
  for (int f = 1; f <= faces.Extent(); ++f) {
    TopLoc_Location loc;
    const TopoDS_Face& face = TopoDS::Face(faces(f));
    double u0, u1, v0, v1;
    BRepTools::UVBounds(face, u0, u1, v0, v1);
    proj[size_t(f - 1)].Init(BRep_Tool::Surface(face, loc), u0, u1, v0, v1);
    inv[size_t(f - 1)] = loc.Transformation().Inverted();
  }
  double h = 0;
  // Mesh -> CAD: centroids and edge midpoints to their own face's surface.
  for (size_t t = 0; t < s.tris.size(); ++t) {
    const Vec3 &a = s.points[size_t(s.tris[t][0])], &b = s.points[size_t(s.tris[t][1])], &c = s.points[size_t(s.tris[t][2])];
    for (const Vec3& p : {(1.0 / 3) * (a + b + c), 0.5 * (a + b), 0.5 * (b + c), 0.5 * (c + a)}) {
      gp_Pnt q(p[0], p[1], p[2]);
      q.Transform(inv[size_t(s.face[t])]);
      GeomAPI_ProjectPointOnSurf& pr = proj[size_t(s.face[t])];
      pr.Perform(q);
      if (pr.NbPoints() > 0) h = std::max(h, pr.LowerDistance());
    }
  }
  // CAD -> mesh: a 24 x 24 grid of each face's parameters (inside the face) to the nearest triangle.
  for (int f = 1; f <= faces.Extent(); ++f) {
    const TopoDS_Face& face = TopoDS::Face(faces(f));
    double u0, u1, v0, v1;
    BRepTools::UVBounds(face, u0, u1, v0, v1);
    for (int i = 0; i < 24; ++i)
      for (int j = 0; j < 24; ++j) {
        const gp_Pnt2d uv(u0 + (u1 - u0) * (i + 0.5) / 24, v0 + (v1 - v0) * (j + 0.5) / 24);
        BRepClass_FaceClassifier cls(face, uv, 1e-9);
        if (cls.State() != TopAbs_IN) continue;
        TopLoc_Location loc;
        gp_Pnt p = BRep_Tool::Surface(face, loc)->Value(uv.X(), uv.Y()).Transformed(loc.Transformation());
        const Vec3 x{p.X(), p.Y(), p.Z()};
        double best = INFINITY;
        for (const auto& t : s.tris)
          best = std::min(best, pointTriangleDistance(x, s.points[size_t(t[0])], s.points[size_t(t[1])], s.points[size_t(t[2])]));
        h = std::max(h, best);
      }
  }
  return h;
}

struct Row {
  std::string model, mesher;
  SurfaceFigures fig;
  double hausdorff = 0, surfaceSeconds = 0, tetSeconds = 0;
  size_t tets = 0;
  double dminTetgen = 0, dmaxTetgen = 0, dmin = 0, dmax = 0;
  std::string note;
};

// TetGen (same call as MeshCADSurface) + improvement with the surfaces kept.
void volume(const CadModel& model, const Surface& s, Row& row) {
  const double t0 = now();
  std::vector<TetgenRegion> regions;
  try {
    TetMesh m = tetgenFromSurface(s.points, s.tris, regions, "1.414/10");
    ImproveParams ip;
    ip.fixSurfaces = true;
    NullProgress np;
    const ImproveStats st = improveMesh(m, ip, np); // measures the whole mesh before and after
    row.dminTetgen = st.minBefore;
    row.dmaxTetgen = st.maxBefore;
    row.dmin = st.minAfter;
    row.dmax = st.maxAfter;
    row.tets = m.numTets();
  } catch (const std::exception& e) {
    row.note = std::string("TetGen: ") + e.what();
  }
  row.tetSeconds = now() - t0;
  (void)model;
}

std::string fmt(double v, int prec = 2) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", prec, v);
  return buf;
}

} // namespace

int main(int argc, char** argv) {
  std::ostringstream out;
  out << "# cad_benchmark: PSYS vs BRepMesh (+ the same TetGen -pYq1.414/10 and improvement), "
         "2-core VM\n";
  out << "# model | mesher | surface vertices | triangles | tri min angle min / median | radius-edge max / median | "
         "Hausdorff mm | surface s | tets | dihedral after TetGen | after improvement | volume s\n";
  std::vector<Row> rows;
  for (const auto& tm : testing::testModels()) {
    const TopoDS_Shape shape = tm.make();
    auto model = testing::modelOf(shape, tm.name);
    CadMeshParams p;
    p.particles.maxSize = tm.name == "thin_plate_with_holes" ? 3.0 : 2.5;
    p.improve = false;
    double t0 = now();
    CadMeshResult r = meshCadModel(*model, p);
    Row a;
    a.model = tm.name;
    a.mesher = "PSYS";
    a.surfaceSeconds = r.seconds[0] + r.seconds[1];
    a.fig = r.figures;
    Surface ps{r.surface.points, r.surface.triangles, r.surface.trianglePatch};
    a.hausdorff = hausdorff(shape, ps);
    (void)t0;
    volume(*model, ps, a);
    rows.push_back(a);
    // BRepMesh at the same vertex count: bisect the deflection (log scale).
    double lo = 1e-4, hi = 5.0;
    Surface best;
    double bestDefl = hi, bestSeconds = 0;
    for (int it = 0; it < 30; ++it) {
      const double d = std::sqrt(lo * hi);
      const double s0 = now();
      Surface s = brepMesh(shape, d);
      const double sec = now() - s0;
      if (best.points.empty() ||
          std::abs(double(s.points.size()) - double(a.fig.vertices)) < std::abs(double(best.points.size()) - double(a.fig.vertices))) {
        best = s;
        bestDefl = d;
        bestSeconds = sec;
      }
      if (int64_t(s.points.size()) > a.fig.vertices) lo = d;
      else hi = d;
      if (std::abs(double(s.points.size()) - double(a.fig.vertices)) < 0.01 * double(a.fig.vertices)) break;
    }
    Row b;
    b.model = tm.name;
    b.mesher = "BRepMesh (deflection " + fmt(bestDefl, 4) + ")";
    b.fig = surfaceFigures(best.points, best.tris);
    b.hausdorff = hausdorff(shape, best);
    b.surfaceSeconds = bestSeconds;
    volume(*model, best, b);
    rows.push_back(b);
  }
  for (const Row& r : rows) {
    out << r.model << " | " << r.mesher << " | " << r.fig.vertices << " | " << r.fig.triangles << " | "
        << fmt(r.fig.minAngle) << " / " << fmt(r.fig.medianMinAngle) << " | " << fmt(r.fig.maxRadiusEdge) << " / "
        << fmt(r.fig.medianRadiusEdge) << " | " << fmt(r.hausdorff, 4) << " | " << fmt(r.surfaceSeconds) << " | "
        << r.tets << " | " << fmt(r.dminTetgen) << " / " << fmt(r.dmaxTetgen) << " | " << fmt(r.dmin) << " / "
        << fmt(r.dmax) << " | " << fmt(r.tetSeconds) << (r.note.empty() ? "" : " | " + r.note) << "\n";
  }
  // A 1 M-tet model: the box with a hole at a fine size, TetGen's volume bound set for ~1 M tets.
  {
    const TopoDS_Shape shape = testing::boxWithHole();
    auto model = testing::modelOf(shape, "box_with_hole");
    CadMeshParams p;
    p.particles.maxSize = 0.8;
    p.maxTetVolume = 0.0035;
    const double t0 = now();
    CadMeshResult r = meshCadModel(*model, p);
    const double total = now() - t0;
    const double lo = r.minDihedral, hi = r.maxDihedral;
    out << "# large: box_with_hole, max_size 0.8 mm, max_tet_volume 0.0035 mm^3: " << r.figures.vertices
        << " surface vertices, " << r.mesh.numTets() << " tets, dihedral [" << fmt(lo) << ", " << fmt(hi)
        << "], " << fmt(total) << " s (particles " << fmt(r.seconds[0]) << ", triangulation " << fmt(r.seconds[1])
        << ", TetGen " << fmt(r.seconds[2]) << ", improvement " << fmt(r.seconds[3]) << ")\n";
  }
  std::fputs(out.str().c_str(), stdout);
  if (argc > 1) {
    std::ofstream f(argv[1]);
    f << out.str();
    if (!f) {
      std::fprintf(stderr, "cannot write %s\n", argv[1]);
      return 1;
    }
  }
  return 0;
}
