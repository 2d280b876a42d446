#pragma once
// Test models made with OpenCASCADE's own primitives, booleans and sweeps (no downloaded files),
// with what each one's boundary must be: its Euler characteristic 2·shells − 2·genus.
// Sizes in mm.
#include <BRepAlgoAPI_BuilderAlgo.hxx>
#include <BRepAlgoAPI_Cut.hxx>
#include <BRepAlgoAPI_Fuse.hxx>
#include <BRepBuilderAPI_MakeEdge.hxx>
#include <BRepBuilderAPI_MakeFace.hxx>
#include <BRepBuilderAPI_MakeWire.hxx>
#include <BRepLib.hxx>
#include <BRepOffsetAPI_MakePipeShell.hxx>
#include <BRepPrimAPI_MakeBox.hxx>
#include <BRepPrimAPI_MakeCylinder.hxx>
#include <BRepPrimAPI_MakeSphere.hxx>
#include <BRepPrimAPI_MakeTorus.hxx>
#include <GCE2d_MakeSegment.hxx>
#include <Geom2d_Line.hxx>
#include <Geom_CylindricalSurface.hxx>
#include <ShapeUpgrade_UnifySameDomain.hxx>
#include <TopoDS_Shape.hxx>
#include <gp_Ax2.hxx>
#include <gp_Ax3.hxx>
#include <gp_Circ.hxx>
#include <gp_Lin2d.hxx>

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "Algorithms/CAD/CadModel.h"

namespace tetflow::testing {

inline TopoDS_Shape unify(const TopoDS_Shape& s) {
  ShapeUpgrade_UnifySameDomain u(s, true, true, true);
  u.Build();
  return u.Shape();
}

// 20 x 20 x 10 box with a radius-4 cylindrical hole through it: genus 1.
inline TopoDS_Shape boxWithHole() {
  TopoDS_Shape box = BRepPrimAPI_MakeBox(20, 20, 10).Shape();
  TopoDS_Shape hole = BRepPrimAPI_MakeCylinder(gp_Ax2(gp_Pnt(10, 10, -1), gp_Dir(0, 0, 1)), 4, 12).Shape();
  return unify(BRepAlgoAPI_Cut(box, hole).Shape());
}

// Torus, major radius 10, minor 3: genus 1.
inline TopoDS_Shape torus() { return BRepPrimAPI_MakeTorus(10, 3).Shape(); }

// Cylinder (radius 5, height 10) with a hemispherical cap on top: genus 0.
inline TopoDS_Shape cylinderWithCap() {
  TopoDS_Shape cyl = BRepPrimAPI_MakeCylinder(5, 10).Shape();
  TopoDS_Shape ball = BRepPrimAPI_MakeSphere(gp_Pnt(0, 0, 10), 5).Shape();
  return unify(BRepAlgoAPI_Fuse(cyl, ball).Shape());
}

// 30 x 20 x 1.5 plate with four radius-1.5 holes: genus 4.
inline TopoDS_Shape thinPlateWithHoles() {
  TopoDS_Shape plate = BRepPrimAPI_MakeBox(30, 20, 1.5).Shape();
  for (const auto& [x, y] : std::vector<std::pair<double, double>>{{6, 6}, {24, 6}, {6, 14}, {24, 14}}) {
    TopoDS_Shape h = BRepPrimAPI_MakeCylinder(gp_Ax2(gp_Pnt(x, y, -1), gp_Dir(0, 0, 1)), 1.5, 3.5).Shape();
    plate = BRepAlgoAPI_Cut(plate, h).Shape();
  }
  return unify(plate);
}

// A coil: a radius-1 circle swept along two turns of a helix (radius 6, pitch 4): genus 0.
inline TopoDS_Shape helicalSweep() {
  const double radius = 6, pitch = 4, turns = 2;
  Handle(Geom_CylindricalSurface) cyl = new Geom_CylindricalSurface(gp_Ax3(gp::XOY()), radius);
  const gp_Lin2d line(gp_Pnt2d(0, 0), gp_Dir2d(2 * M_PI, pitch));
  Handle(Geom2d_Line) l2 = new Geom2d_Line(line);
  const double len = turns * std::sqrt(4 * M_PI * M_PI + pitch * pitch);
  TopoDS_Edge helixEdge = BRepBuilderAPI_MakeEdge(l2, cyl, 0, len).Edge();
  BRepLib::BuildCurves3d(helixEdge);
  TopoDS_Wire spine = BRepBuilderAPI_MakeWire(helixEdge).Wire();
  // Profile: a circle at the helix start, in the plane normal to the helix tangent.
  const gp_Pnt start(radius, 0, 0);
  const gp_Dir tangent(0, 2 * M_PI * radius, pitch);
  TopoDS_Edge circle = BRepBuilderAPI_MakeEdge(gp_Circ(gp_Ax2(start, tangent), 1.0)).Edge();
  TopoDS_Wire profile = BRepBuilderAPI_MakeWire(circle).Wire();
  BRepOffsetAPI_MakePipeShell pipe(spine);
  pipe.SetMode(gp_Dir(0, 0, 1)); // binormal mode: the profile keeps its orientation to the axis
  pipe.Add(profile);
  pipe.Build();
  pipe.MakeSolid();
  return pipe.Shape();
}

// A bipolar stimulation electrode in tissue: two cylindrical contacts (radius 0.75, height 1.5,
// 1.5 apart on the z axis) inside a tissue cylinder (radius 8, height 16), glued by OpenCASCADE's
// general fuse so that each contact shares its faces with the tissue: three solids.
inline TopoDS_Shape electrodeInTissue() {
  TopTools_ListOfShape args;
  args.Append(BRepPrimAPI_MakeCylinder(gp_Ax2(gp_Pnt(0, 0, -8), gp_Dir(0, 0, 1)), 8, 16).Shape());
  args.Append(BRepPrimAPI_MakeCylinder(gp_Ax2(gp_Pnt(0, 0, 0.75), gp_Dir(0, 0, 1)), 0.75, 1.5).Shape());
  args.Append(BRepPrimAPI_MakeCylinder(gp_Ax2(gp_Pnt(0, 0, -2.25), gp_Dir(0, 0, 1)), 0.75, 1.5).Shape());
  BRepAlgoAPI_BuilderAlgo gf;
  gf.SetArguments(args);
  gf.Build();
  return gf.Shape();
}

// The four-shell sphere of the EEG validation (radii 78 / 80 / 86 / 92 mm: brain, CSF, skull,
// scalp; the radii of the phantom head and of AnalyticSphereEEG's defaults), four concentric
// spheres glued by the general fuse: a ball and three shells, each pair sharing its sphere.
inline TopoDS_Shape fourShellSphere() {
  TopTools_ListOfShape args;
  for (double r : {92.0, 86.0, 80.0, 78.0}) args.Append(BRepPrimAPI_MakeSphere(r).Shape());
  BRepAlgoAPI_BuilderAlgo gf;
  gf.SetArguments(args);
  gf.Build();
  return gf.Shape();
}

struct TestModel {
  std::string name;
  std::function<TopoDS_Shape()> make;
  int euler; // 2·shells − 2·genus of the boundary
};

inline std::vector<TestModel> testModels() {
  return {{"box_with_hole", boxWithHole, 0},
          {"torus", torus, 0},
          {"cylinder_with_cap", cylinderWithCap, 2},
          {"thin_plate_with_holes", thinPlateWithHoles, 2 - 2 * 4},
          {"helical_sweep", helicalSweep, 2}};
}

inline std::shared_ptr<const CadModel> modelOf(const TopoDS_Shape& s, const std::string& name) {
  return CadModel::fromShape(&s, name);
}

} // namespace tetflow::testing
