#pragma once
// A boundary-representation (B-rep) CAD model read through OpenCASCADE (Debian libocct-*-dev 7.6),
// seen as the piecewise-smooth complex of the seed's chapter 3: corners (0-cells), curves
// (1-cells) and patches (2-cells), each with its parameterisation, and the solids they bound.
//
// OpenCASCADE stays behind this header (a private implementation): callers get plain numbers.
//
// Indexing (0-based, stable for one model):
//   corners  : the model's vertices;
//   curves   : its edges that are not degenerate (a degenerate edge is a pole of a sphere or
//              the apex of a cone: one point in space, a segment in its patch's parameters);
//   patches  : its faces, each once even when two solids share it;
//   solids   : its solids (one material each, label = index + 1).
// Each patch's boundary is a list of loops (OpenCASCADE's wires), each an ordered list of uses
// of curves in the patch's parameter space. A seam (the curve where a periodic surface closes,
// e.g. a cylinder's) is used twice by its patch, once on each side (`side` 0 and 1).
#include <array>
#include <memory>
#include <string>
#include <vector>

#include "Algorithms/Core/Geometry.h"

namespace tetflow {

struct CadCurve {
  int corner0 = -1, corner1 = -1; // the corners at t0 and t1 (equal for a closed curve)
  double t0 = 0, t1 = 0;          // parameter range
  double length = 0;              // arc length in mm
  std::vector<int> patches;       // patches that use it (a seam's patch once)
};

// One use of a curve (or of a degenerate edge) in a patch's loop, in loop order.
struct CadCurveUse {
  int curve = -1;        // -1 for a degenerate edge
  int corner = -1;       // for a degenerate edge: the corner it collapses to
  bool reversed = false; // traversed from t1 to t0
  int side = 0;          // which of a seam's two parameter-space copies (0 otherwise)
  double t0 = 0, t1 = 0; // the edge's parameter range (a degenerate edge's own)
  int edge = -1;         // OpenCASCADE's index of the edge (for a degenerate edge's pcurve)
};

struct CadPatch {
  double u0 = 0, u1 = 0, v0 = 0, v1 = 0; // parameter bounds of the trimmed patch
  double area = 0;                       // mm²
  std::vector<std::vector<CadCurveUse>> loops;
  std::vector<int> solids;               // solids it bounds (1, or 2 for a shared face)
  bool reversed = false;                 // the face's normal points opposite to the surface's
};

struct CadSolid {
  std::vector<int> patches;
  double volume = 0; // mm³
};

// Derivatives of a patch at (u, v).
struct PatchPoint {
  Vec3 p{}, du{}, dv{};
};

class CadModel {
public:
  // Reads .step/.stp, .iges/.igs or .brep (OpenCASCADE's own format), by extension. Throws
  // InputError naming the file for a missing or unreadable file, an unknown extension, a model
  // without solids, one that is not closed (a curve used by one patch), not manifold (a curve
  // used by three or more patch sides of one solid) or not valid for OpenCASCADE's checker.
  static std::shared_ptr<const CadModel> read(const std::string& path);
  // Writes the model as STEP (AP214), atomically (temp file + rename).
  void writeStep(const std::string& path) const;

  ~CadModel();
  CadModel(const CadModel&) = delete;
  CadModel& operator=(const CadModel&) = delete;

  const std::string& source() const { return source_; }
  // Solids in the file. With more than one, the model is their general fuse (OpenCASCADE's
  // BRepAlgoAPI_BuilderAlgo): solids that touch share the faces where they touch (as a STEP
  // assembly does not), and an overlap of two solids becomes a solid of its own, so solids()
  // can hold more than the file.
  int solidsInFile() const { return solidsInFile_; }
  const std::vector<Vec3>& corners() const { return corners_; }
  const std::vector<CadCurve>& curves() const { return curves_; }
  const std::vector<CadPatch>& patches() const { return patches_; }
  const std::vector<CadSolid>& solids() const { return solids_; }
  // Bounding box (min, max) of the model, mm.
  std::array<Vec3, 2> bounds() const { return bounds_; }

  // Euler characteristic of the model's boundary: V − E + Σ_patches (2 − loops), counting
  // corners, curves (not degenerate edges) and each patch as a disk with loops − 1 holes. For a
  // closed surface it is 2·(components) − 2·(genus); a mesh of it must have the same.
  int eulerCharacteristic() const;

  // Geometry queries. Thread-safe (every call builds its own OpenCASCADE adaptor).
  Vec3 curvePoint(int curve, double t) const;
  Vec3 curveDerivative(int curve, double t) const;
  double curveCurvature(int curve, double t) const;
  // The curve's position in a patch's parameters (its pcurve); `side` selects a seam's copy.
  Point2 curveOnPatch(int curve, int patch, int side, double t) const;
  // The same for any use of a patch's loop, degenerate edges included.
  Point2 useOnPatch(int patch, const CadCurveUse& use, double t) const;
  PatchPoint patchPoint(int patch, double u, double v) const;
  // Largest absolute principal curvature (1/mm); 0 where it is not defined (e.g. a pole).
  double patchMaxCurvature(int patch, double u, double v) const;
  // Outward unit normal of the solid `solid` at (u, v) (the patch's normal, flipped as needed).
  Vec3 patchNormal(int patch, double u, double v) const;
  // Distance from p to the trimmed patch (mm) and the parameters of the nearest point.
  double distanceToPatch(int patch, const Vec3& p, Point2* uv = nullptr) const;
  // Is p strictly inside solid s (OpenCASCADE's classifier, tolerance tol mm)?
  bool insideSolid(int solid, const Vec3& p, double tol = 1e-7) const;

  // For tests and programs that build models with OpenCASCADE: the model of a TopoDS_Shape
  // passed as `const void*` (a `const TopoDS_Shape*`), so that this header needs no OpenCASCADE.
  // Same checks and errors as read(); `name` stands for the file in messages.
  static std::shared_ptr<const CadModel> fromShape(const void* topoDsShape, const std::string& name);
  // The OpenCASCADE shape (a `const TopoDS_Shape*`), for programs that use OpenCASCADE too.
  const void* shape() const;

  struct Impl;

private:
  CadModel();
  std::unique_ptr<Impl> impl_;
  std::string source_;
  int solidsInFile_ = 0;
  std::vector<Vec3> corners_;
  std::vector<CadCurve> curves_;
  std::vector<CadPatch> patches_;
  std::vector<CadSolid> solids_;
  std::array<Vec3, 2> bounds_{};
};

} // namespace tetflow
