// CadModel: the cell complex and parameterisations of B-rep models built with OpenCASCADE's
// primitives, STEP written and read back, and the errors for bad files and open models.
#include <BRepBuilderAPI_MakePolygon.hxx>
#include <BRepBuilderAPI_MakeSolid.hxx>
#include <BRep_Builder.hxx>
#include <IGESControl_Controller.hxx>
#include <IGESControl_Writer.hxx>
#include <TopExp_Explorer.hxx>
#include <TopoDS.hxx>
#include <TopoDS_Compound.hxx>
#include <TopoDS_Shell.hxx>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "Algorithms/Core/Errors.h"
#include "Fixtures/CadModels.h"

using namespace tetflow;
using namespace tetflow::testing;

namespace {

std::string tempPath(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("tetflow-cad-" + name)).string();
}

template <class F> std::string errorOf(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

double dist2(const Point2& a, const Point2& b) { return std::hypot(a.x - b.x, a.y - b.y); }

} // namespace

TEST(CadModel, TestModelsHaveTheirEulerCharacteristicAndConsistentParameterisations) {
  for (const auto& tm : testModels()) {
    SCOPED_TRACE(tm.name);
    auto m = modelOf(tm.make(), tm.name);
    ASSERT_EQ(m->solids().size(), 1u);
    EXPECT_EQ(m->eulerCharacteristic(), tm.euler);
    EXPECT_GT(m->solids()[0].volume, 0);
    for (size_t c = 0; c < m->curves().size(); ++c) {
      const CadCurve& cv = m->curves()[c];
      // Curve ends are its corners.
      EXPECT_LT(norm(m->curvePoint(int(c), cv.t0) - m->corners()[cv.corner0]), 1e-6);
      EXPECT_LT(norm(m->curvePoint(int(c), cv.t1) - m->corners()[cv.corner1]), 1e-6);
      EXPECT_GT(cv.length, 0);
      EXPECT_FALSE(cv.patches.empty());
    }
    for (size_t p = 0; p < m->patches().size(); ++p) {
      const CadPatch& patch = m->patches()[p];
      EXPECT_GT(patch.area, 0);
      for (const auto& loop : patch.loops) {
        ASSERT_FALSE(loop.empty());
        for (size_t i = 0; i < loop.size(); ++i) {
          const CadCurveUse& a = loop[i];
          const CadCurveUse& b = loop[(i + 1) % loop.size()];
          // Each use ends in parameter space where the next begins: the loop is closed.
          const Point2 end = m->useOnPatch(int(p), a, a.reversed ? a.t0 : a.t1);
          const Point2 start = m->useOnPatch(int(p), b, b.reversed ? b.t1 : b.t0);
          EXPECT_LT(dist2(end, start), 1e-6) << "patch " << p << " use " << i;
          // The pcurve lies on the curve: S(pcurve(t)) = C(t).
          if (a.curve >= 0)
            for (double s : {0.0, 0.3, 0.7, 1.0}) {
              const double t = a.t0 + s * (a.t1 - a.t0);
              const Point2 uv = m->useOnPatch(int(p), a, t);
              EXPECT_LT(norm(m->patchPoint(int(p), uv.x, uv.y).p - m->curvePoint(a.curve, t)), 1e-5);
            }
          else
            EXPECT_GE(a.corner, 0);
        }
      }
    }
  }
}

TEST(CadModel, VolumesAndCurvaturesOfKnownShapes) {
  auto box = modelOf(boxWithHole(), "box");
  EXPECT_NEAR(box->solids()[0].volume, 20 * 20 * 10 - M_PI * 16 * 10, 1e-6 * 4000);
  auto tor = modelOf(torus(), "torus");
  EXPECT_NEAR(tor->solids()[0].volume, 2 * M_PI * M_PI * 10 * 9, 1e-6 * 2000);
  ASSERT_EQ(tor->patches().size(), 1u);
  const CadPatch& tp = tor->patches()[0];
  // Largest principal curvature of a torus is 1 / minor radius everywhere.
  EXPECT_NEAR(tor->patchMaxCurvature(0, 0.5 * (tp.u0 + tp.u1), 0.3), 1.0 / 3.0, 1e-9);
  auto cap = modelOf(cylinderWithCap(), "cap");
  EXPECT_NEAR(cap->solids()[0].volume, M_PI * 25 * 10 + 2.0 / 3.0 * M_PI * 125, 1e-6 * 1000);
  // A point at the cap's top is on the sphere patch, and inside/outside classification works.
  EXPECT_TRUE(cap->insideSolid(0, {0, 0, 5}));
  EXPECT_FALSE(cap->insideSolid(0, {0, 0, 15.5}));
  double best = 1e9;
  for (size_t p = 0; p < cap->patches().size(); ++p) best = std::min(best, cap->distanceToPatch(int(p), {0, 0, 15}));
  EXPECT_LT(best, 1e-7);
}

TEST(CadModel, StepWrittenAndReadBackIsTheSameModel) {
  auto m = modelOf(boxWithHole(), "box");
  const std::string path = tempPath("box.step");
  m->writeStep(path);
  auto r = CadModel::read(path);
  EXPECT_EQ(r->corners().size(), m->corners().size());
  EXPECT_EQ(r->curves().size(), m->curves().size());
  EXPECT_EQ(r->patches().size(), m->patches().size());
  EXPECT_EQ(r->eulerCharacteristic(), m->eulerCharacteristic());
  EXPECT_NEAR(r->solids()[0].volume, m->solids()[0].volume, 1e-6 * m->solids()[0].volume);
  // No temporary file is left beside it.
  int files = 0;
  for (const auto& e : std::filesystem::directory_iterator(std::filesystem::path(path).parent_path()))
    if (e.path().filename().string().rfind("tetflow-cad-box.step", 0) == 0) ++files;
  EXPECT_EQ(files, 1);
  std::filesystem::remove(path);
}

TEST(CadModel, BadFilesNameTheFileAndTheFix) {
  EXPECT_NE(errorOf([] { CadModel::read("/nonexistent/part.step"); }).find("'/nonexistent/part.step' does not exist"),
            std::string::npos);
  const std::string stl = tempPath("part.stl");
  std::ofstream(stl) << "solid x\nendsolid x\n";
  const std::string e1 = errorOf([&] { CadModel::read(stl); });
  EXPECT_NE(e1.find("extension '.stl'"), std::string::npos) << e1;
  EXPECT_NE(e1.find("STEP (.step, .stp), IGES (.iges, .igs) or BREP"), std::string::npos) << e1;
  const std::string junk = tempPath("junk.step");
  std::ofstream(junk) << "this is not ISO-10303-21\n";
  const std::string e2 = errorOf([&] { CadModel::read(junk); });
  EXPECT_NE(e2.find(junk), std::string::npos) << e2;
  const std::string junkBrep = tempPath("junk.brep");
  std::ofstream(junkBrep) << "nothing\n";
  EXPECT_NE(errorOf([&] { CadModel::read(junkBrep); }).find("not a readable BREP file"), std::string::npos);
  for (const auto& f : {stl, junk, junkBrep}) std::filesystem::remove(f);
}

TEST(CadModel, ModelsWithoutAClosedSolidAreRefused) {
  // One face: no solid.
  TopoDS_Shape box = BRepPrimAPI_MakeBox(1, 2, 3).Shape();
  TopExp_Explorer fx(box, TopAbs_FACE);
  TopoDS_Shape face = fx.Current();
  const std::string e1 = errorOf([&] { modelOf(face, "face.step"); });
  EXPECT_NE(e1.find("has no solid (1 faces)"), std::string::npos) << e1;
  // A solid from a shell that lacks one of the box's faces: not closed.
  BRep_Builder b;
  TopoDS_Shell shell;
  b.MakeShell(shell);
  int n = 0;
  for (TopExp_Explorer x(box, TopAbs_FACE); x.More(); x.Next())
    if (n++ < 5) b.Add(shell, x.Current());
  TopoDS_Solid solid;
  b.MakeSolid(solid);
  b.Add(solid, shell);
  const std::string e2 = errorOf([&] { modelOf(solid, "open.step"); });
  EXPECT_TRUE(e2.find("not closed") != std::string::npos || e2.find("not a valid B-rep") != std::string::npos) << e2;
  EXPECT_NE(e2.find("open.step"), std::string::npos) << e2;
}

TEST(CadModel, SolidsAreGluedSoThatTouchingSolidsShareTheirFaces) {
  // The electrode model shares faces; STEP repeats a shared face in each solid, and reading it
  // back glues them again: the same patches, not two copies.
  auto m = modelOf(electrodeInTissue(), "electrode");
  EXPECT_EQ(m->solids().size(), 3u);
  EXPECT_EQ(m->patches().size(), 9u);
  EXPECT_EQ(m->eulerCharacteristic(), 6);
  int shared = 0;
  for (const auto& p : m->patches()) shared += p.solids.size() == 2;
  EXPECT_EQ(shared, 6); // each contact's three faces
  const std::string path = tempPath("electrode.step");
  m->writeStep(path);
  auto r = CadModel::read(path);
  EXPECT_EQ(r->solidsInFile(), 3);
  EXPECT_EQ(r->solids().size(), 3u);
  EXPECT_EQ(r->patches().size(), 9u);
  EXPECT_EQ(r->eulerCharacteristic(), 6);
  std::filesystem::remove(path);
  // Two overlapping boxes: three solids (each box less the other, and their overlap).
  TopoDS_Compound both;
  BRep_Builder b;
  b.MakeCompound(both);
  b.Add(both, BRepPrimAPI_MakeBox(gp_Pnt(0, 0, 0), 2, 2, 2).Shape());
  b.Add(both, BRepPrimAPI_MakeBox(gp_Pnt(1, 1, 1), 2, 2, 2).Shape());
  auto o = modelOf(both, "overlap");
  EXPECT_EQ(o->solidsInFile(), 2);
  ASSERT_EQ(o->solids().size(), 3u);
  double total = 0;
  for (const auto& s : o->solids()) total += s.volume;
  EXPECT_NEAR(total, 8 + 8 - 1, 1e-9);
}

TEST(CadModel, IgesWrittenAndReadBackIsTheSameModel) {
  IGESControl_Controller::Init();
  for (const auto& tm : testModels()) {
    SCOPED_TRACE(tm.name);
    const TopoDS_Shape shape = tm.make();
    auto m = modelOf(shape, tm.name);
    IGESControl_Writer w("MM", 1); // B-rep mode (MSBO solids)
    w.AddShape(shape);
    w.ComputeModel();
    const std::string path = tempPath(tm.name + ".igs");
    ASSERT_TRUE(w.Write(path.c_str()));
    auto r = CadModel::read(path);
    EXPECT_EQ(r->solids().size(), 1u);
    EXPECT_EQ(r->patches().size(), m->patches().size());
    EXPECT_EQ(r->eulerCharacteristic(), tm.euler);
    EXPECT_NEAR(r->solids()[0].volume, m->solids()[0].volume, 1e-5 * m->solids()[0].volume);
    std::filesystem::remove(path);
  }
}
