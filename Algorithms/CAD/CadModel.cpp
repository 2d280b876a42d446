// CadModel through OpenCASCADE: reading, the cell complex, and geometry queries (CadModel.h).
#include "CadModel.h"

#include <BRepAdaptor_Surface.hxx>
#include <BRepAlgoAPI_BuilderAlgo.hxx>
#include <BRepBndLib.hxx>
#include <BRepCheck_Analyzer.hxx>
#include <BRepClass3d_SolidClassifier.hxx>
#include <BRepExtrema_DistShapeShape.hxx>
#include <BRepBuilderAPI_MakeVertex.hxx>
#include <BRepGProp.hxx>
#include <BRepLib.hxx>
#include <BRepTools.hxx>
#include <BRepTools_WireExplorer.hxx>
#include <BRep_Builder.hxx>
#include <BRep_Tool.hxx>
#include <Bnd_Box.hxx>
#include <GCPnts_AbscissaPoint.hxx>
#include <BRepAdaptor_Curve.hxx>
#include <GProp_GProps.hxx>
#include <GeomLProp_CLProps.hxx>
#include <GeomLProp_SLProps.hxx>
#include <Geom2d_Curve.hxx>
#include <Geom_Curve.hxx>
#include <Geom_Surface.hxx>
#include <IFSelect_ReturnStatus.hxx>
#include <IGESControl_Reader.hxx>
#include <Interface_Static.hxx>
#include <Message.hxx>
#include <Message_Messenger.hxx>
#include <STEPControl_Reader.hxx>
#include <STEPControl_Writer.hxx>
#include <Standard_Failure.hxx>
#include <TopExp.hxx>
#include <TopExp_Explorer.hxx>
#include <TopTools_IndexedMapOfShape.hxx>
#include <TopTools_ListOfShape.hxx>
#include <TopoDS.hxx>
#include <TopoDS_Edge.hxx>
#include <TopoDS_Face.hxx>
#include <TopoDS_Shape.hxx>
#include <TopoDS_Vertex.hxx>
#include <TopoDS_Wire.hxx>
#include <gp_Pnt.hxx>
#include <gp_Pnt2d.hxx>
#include <gp_Trsf.hxx>
#include <gp_Vec.hxx>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <map>
#include <mutex>
#include <sstream>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/IO/FileUtil.h"

namespace tetflow {

namespace {

Vec3 toVec(const gp_Pnt& p) { return {p.X(), p.Y(), p.Z()}; }
Vec3 toVec(const gp_Vec& v) { return {v.X(), v.Y(), v.Z()}; }

// OpenCASCADE prints its translators' messages to stdout by default; a library stays quiet.
void silenceOpenCascade() {
  static std::once_flag once;
  std::call_once(once, [] {
    const Handle(Message_Messenger)& m = Message::DefaultMessenger();
    Message_SequenceOfPrinters& printers = m->ChangePrinters();
    printers.Clear();
  });
}

} // namespace

struct CadModel::Impl {
  TopoDS_Shape shape;
  TopTools_IndexedMapOfShape vertexMap, edgeMap, faceMap, solidMap;
  std::vector<int> edgeToCurve; // edgeMap index - 1 -> curve id (-1 degenerate)
  // Per curve: its 3D geometry (location applied at evaluation).
  struct CurveGeom {
    Handle(Geom_Curve) curve;
    gp_Trsf trsf;
    bool identity = true;
  };
  std::vector<CurveGeom> curveGeom;
  struct SurfaceGeom {
    Handle(Geom_Surface) surface;
    gp_Trsf trsf;
    bool identity = true;
    TopoDS_Face face; // forward
  };
  std::vector<SurfaceGeom> surfaceGeom;
  // (curve, patch, side) -> pcurve
  std::map<std::array<int, 3>, Handle(Geom2d_Curve)> pcurves;
  // For each solid: its shape, for the classifier.
  std::vector<TopoDS_Shape> solidShapes;
};

CadModel::CadModel() : impl_(std::make_unique<Impl>()) {}
CadModel::~CadModel() = default;

const void* CadModel::shape() const { return &impl_->shape; }

std::shared_ptr<const CadModel> CadModel::read(const std::string& path) {
  silenceOpenCascade();
  std::error_code ec;
  if (!std::filesystem::exists(path, ec))
    throw InputError("ReadCADModel: file '" + path + "' does not exist");
  if (std::filesystem::is_directory(path, ec))
    throw InputError("ReadCADModel: '" + path + "' is a folder, not a CAD file");
  const std::string ext = fileExtension(path);
  TopoDS_Shape shape;
  try {
    if (ext == ".step" || ext == ".stp") {
      STEPControl_Reader reader;
      if (reader.ReadFile(path.c_str()) != IFSelect_RetDone)
        throw InputError("ReadCADModel: '" + path + "' is not a readable STEP file (OpenCASCADE's "
                         "STEP reader rejected it)");
      if (reader.TransferRoots() == 0)
        throw InputError("ReadCADModel: '" + path + "' holds no shape OpenCASCADE can translate");
      shape = reader.OneShape();
    } else if (ext == ".iges" || ext == ".igs") {
      IGESControl_Reader reader;
      if (reader.ReadFile(path.c_str()) != IFSelect_RetDone)
        throw InputError("ReadCADModel: '" + path + "' is not a readable IGES file (OpenCASCADE's "
                         "IGES reader rejected it)");
      if (reader.TransferRoots() == 0)
        throw InputError("ReadCADModel: '" + path + "' holds no shape OpenCASCADE can translate");
      shape = reader.OneShape();
    } else if (ext == ".brep" || ext == ".brp") {
      BRep_Builder builder;
      if (!BRepTools::Read(shape, path.c_str(), builder))
        throw InputError("ReadCADModel: '" + path + "' is not a readable BREP file");
    } else {
      throw InputError("ReadCADModel: '" + path + "' has extension '" + ext +
                       "'; use a STEP (.step, .stp), IGES (.iges, .igs) or BREP (.brep) file");
    }
  } catch (const Standard_Failure& f) {
    throw InputError("ReadCADModel: OpenCASCADE failed to read '" + path +
                     "': " + std::string(f.GetMessageString()));
  }
  auto m = fromShape(&shape, path);
  return m;
}

std::shared_ptr<const CadModel> CadModel::fromShape(const void* topoDsShape, const std::string& name) {
  silenceOpenCascade();
  const TopoDS_Shape& input = *static_cast<const TopoDS_Shape*>(topoDsShape);
  const std::string where = "CAD model '" + name + "'";
  if (input.IsNull()) throw InputError(where + " is empty");
  std::shared_ptr<CadModel> model(new CadModel());
  Impl& I = *model->impl_;
  model->source_ = name;
  try {
    I.shape = input;
    BRepLib::BuildCurves3d(I.shape); // edges known only by their pcurves get a 3-D curve
    TopExp::MapShapes(I.shape, TopAbs_SOLID, I.solidMap);
    model->solidsInFile_ = I.solidMap.Extent();
    if (I.solidMap.Extent() > 1) {
      // Glue the solids (OpenCASCADE's general fuse): where they touch they then share faces,
      // which one conforming mesh needs (a STEP assembly repeats a shared face in each solid);
      // where they overlap, the overlap becomes a solid of its own.
      TopTools_ListOfShape args;
      for (int s = 1; s <= I.solidMap.Extent(); ++s) args.Append(I.solidMap(s));
      BRepAlgoAPI_BuilderAlgo gf;
      gf.SetArguments(args);
      gf.SetFuzzyValue(1e-7 * std::max(1.0, [&] {
        Bnd_Box b;
        BRepBndLib::Add(I.shape, b);
        return std::sqrt(b.SquareExtent());
      }()));
      gf.SetRunParallel(false);
      gf.Build();
      if (gf.HasErrors() || gf.Shape().IsNull())
        throw InputError(where + " has " + std::to_string(I.solidMap.Extent()) +
                         " solids that OpenCASCADE's general fuse could not glue into one conforming "
                         "model; fuse or separate them in the CAD program");
      I.shape = gf.Shape();
      I.solidMap.Clear();
      TopExp::MapShapes(I.shape, TopAbs_SOLID, I.solidMap);
    }
    if (I.solidMap.Extent() == 0) {
      TopTools_IndexedMapOfShape faces;
      TopExp::MapShapes(I.shape, TopAbs_FACE, faces);
      throw InputError(where + " has no solid (" + std::to_string(faces.Extent()) +
                       " faces): TetFlow meshes closed solids; sew the surfaces and make a solid "
                       "in the CAD program (or OpenCASCADE's BRepBuilderAPI_Sewing + MakeSolid)");
    }
    {
      BRepCheck_Analyzer check(I.shape);
      if (!check.IsValid())
        throw InputError(where + " is not a valid B-rep (OpenCASCADE's BRepCheck_Analyzer found "
                         "faults); repair it in the CAD program (e.g. ShapeFix) and export again");
    }
    // Only the solids' faces count: free faces or edges outside any solid are an error.
    TopTools_IndexedMapOfShape solidFaces;
    for (int s = 1; s <= I.solidMap.Extent(); ++s) TopExp::MapShapes(I.solidMap(s), TopAbs_FACE, solidFaces);
    TopExp::MapShapes(I.shape, TopAbs_FACE, I.faceMap);
    if (I.faceMap.Extent() != solidFaces.Extent())
      throw InputError(where + " has " + std::to_string(I.faceMap.Extent() - solidFaces.Extent()) +
                       " faces that bound no solid; remove them or make them part of a solid");
    TopExp::MapShapes(I.shape, TopAbs_VERTEX, I.vertexMap);
    TopExp::MapShapes(I.shape, TopAbs_EDGE, I.edgeMap);

    for (int v = 1; v <= I.vertexMap.Extent(); ++v)
      model->corners_.push_back(toVec(BRep_Tool::Pnt(TopoDS::Vertex(I.vertexMap(v)))));

    I.edgeToCurve.assign(I.edgeMap.Extent(), -1);
    for (int e = 1; e <= I.edgeMap.Extent(); ++e) {
      TopoDS_Edge edge = TopoDS::Edge(I.edgeMap(e));
      if (BRep_Tool::Degenerated(edge)) continue;
      CadCurve c;
      TopoDS_Vertex a, b;
      TopExp::Vertices(edge, a, b, /*CumOri=*/false);
      if (a.IsNull() || b.IsNull())
        throw InputError(where + ": edge " + std::to_string(e) + " has no end vertex");
      c.corner0 = I.vertexMap.FindIndex(a) - 1;
      c.corner1 = I.vertexMap.FindIndex(b) - 1;
      Impl::CurveGeom g;
      TopLoc_Location loc;
      double f = 0, l = 0;
      g.curve = BRep_Tool::Curve(edge, loc, f, l);
      if (g.curve.IsNull())
        throw InputError(where + ": edge " + std::to_string(e) + " has no 3-D curve");
      g.trsf = loc.Transformation();
      g.identity = loc.IsIdentity();
      c.t0 = f;
      c.t1 = l;
      BRepAdaptor_Curve ac(edge);
      c.length = GCPnts_AbscissaPoint::Length(ac);
      I.edgeToCurve[e - 1] = int(model->curves_.size());
      model->curves_.push_back(c);
      I.curveGeom.push_back(g);
    }

    // Patches, their loops and pcurves.
    for (int fi = 1; fi <= I.faceMap.Extent(); ++fi) {
      TopoDS_Face face = TopoDS::Face(I.faceMap(fi));
      CadPatch p;
      p.reversed = face.Orientation() == TopAbs_REVERSED;
      TopoDS_Face fwd = TopoDS::Face(face.Oriented(TopAbs_FORWARD));
      BRepTools::UVBounds(fwd, p.u0, p.u1, p.v0, p.v1);
      GProp_GProps props;
      BRepGProp::SurfaceProperties(fwd, props);
      p.area = props.Mass();
      Impl::SurfaceGeom sg;
      TopLoc_Location loc;
      sg.surface = BRep_Tool::Surface(fwd, loc);
      if (sg.surface.IsNull()) throw InputError(where + ": face " + std::to_string(fi) + " has no surface");
      sg.trsf = loc.Transformation();
      sg.identity = loc.IsIdentity();
      sg.face = fwd;
      const int pid = fi - 1;
      for (TopExp_Explorer wx(fwd, TopAbs_WIRE); wx.More(); wx.Next()) {
        std::vector<CadCurveUse> loop;
        for (BRepTools_WireExplorer ex(TopoDS::Wire(wx.Current()), fwd); ex.More(); ex.Next()) {
          const TopoDS_Edge& edge = ex.Current();
          CadCurveUse use;
          const int e = I.edgeMap.FindIndex(edge);
          use.curve = I.edgeToCurve[e - 1];
          use.reversed = edge.Orientation() == TopAbs_REVERSED;
          double f = 0, l = 0;
          Handle(Geom2d_Curve) pc = BRep_Tool::CurveOnSurface(edge, fwd, f, l);
          if (pc.IsNull())
            throw InputError(where + ": edge " + std::to_string(e) + " has no curve in the parameters of face " +
                             std::to_string(fi));
          use.t0 = f;
          use.t1 = l;
          use.edge = e;
          if (use.curve < 0) {
            TopoDS_Vertex a, b;
            TopExp::Vertices(edge, a, b);
            use.corner = I.vertexMap.FindIndex(a) - 1;
          }
          // A seam's two uses: side 0 for the first met, 1 for the second.
          if (use.curve >= 0) {
            auto seen = [&](const std::vector<CadCurveUse>& l) {
              return std::any_of(l.begin(), l.end(), [&](const CadCurveUse& o) { return o.curve == use.curve; });
            };
            use.side = seen(loop) || std::any_of(p.loops.begin(), p.loops.end(), seen) ? 1 : 0;
            I.pcurves[{use.curve, pid, use.side}] = pc;
          } else {
            I.pcurves[{-e, pid, 0}] = pc; // a degenerate edge: keyed by -(edge index)
          }
          loop.push_back(use);
        }
        if (loop.empty()) continue;
        p.loops.push_back(std::move(loop));
      }
      if (p.loops.empty()) throw InputError(where + ": face " + std::to_string(fi) + " has no boundary");
      model->patches_.push_back(std::move(p));
      I.surfaceGeom.push_back(sg);
    }

    // Solids, and closedness/manifoldness per solid: every curve is used exactly twice by the
    // solid's patch sides (a seam's two sides count as two).
    for (int s = 1; s <= I.solidMap.Extent(); ++s) {
      CadSolid solid;
      const TopoDS_Shape& sh = I.solidMap(s);
      I.solidShapes.push_back(sh);
      std::map<int, int> uses;
      for (TopExp_Explorer fx(sh, TopAbs_FACE); fx.More(); fx.Next()) {
        const int pid = I.faceMap.FindIndex(fx.Current()) - 1;
        solid.patches.push_back(pid);
        model->patches_[pid].solids.push_back(s - 1);
        for (const auto& loop : model->patches_[pid].loops)
          for (const auto& u : loop)
            if (u.curve >= 0) ++uses[u.curve];
      }
      for (const auto& [c, n] : uses) {
        if (n == 2) continue;
        const Vec3 mid = model->curvePoint(c, 0.5 * (model->curves_[c].t0 + model->curves_[c].t1));
        std::ostringstream os;
        os << where << ": solid " << s << " is " << (n < 2 ? "not closed" : "not manifold") << ": curve " << c
           << " (near " << mid[0] << ", " << mid[1] << ", " << mid[2] << " mm) bounds " << n
           << (n == 1 ? " patch side" : " patch sides") << " instead of 2"
           << (n < 2 ? "; close the gap (sew the faces) in the CAD program"
                     : "; split the model into solids that meet along whole faces");
        throw InputError(os.str());
      }
      GProp_GProps props;
      BRepGProp::VolumeProperties(sh, props);
      solid.volume = std::abs(props.Mass());
      model->solids_.push_back(std::move(solid));
    }
    for (size_t p = 0; p < model->patches_.size(); ++p)
      for (const auto& loop : model->patches_[p].loops)
        for (const auto& u : loop)
          if (u.curve >= 0) {
            auto& list = model->curves_[u.curve].patches;
            if (std::find(list.begin(), list.end(), int(p)) == list.end()) list.push_back(int(p));
          }
    Bnd_Box box;
    BRepBndLib::AddOptimal(I.shape, box, false, false);
    double x0, y0, z0, x1, y1, z1;
    box.Get(x0, y0, z0, x1, y1, z1);
    model->bounds_ = {Vec3{x0, y0, z0}, Vec3{x1, y1, z1}};
  } catch (const Standard_Failure& f) {
    throw InputError(where + ": OpenCASCADE failed while reading its topology: " +
                     std::string(f.GetMessageString()));
  }
  return model;
}

void CadModel::writeStep(const std::string& path) const {
  silenceOpenCascade();
  AtomicOutputFile out(path);
  out.closeStream();
  STEPControl_Writer writer;
  if (writer.Transfer(impl_->shape, STEPControl_AsIs) != IFSelect_RetDone)
    throw ProcessingError("writing '" + path + "': OpenCASCADE could not translate the model to STEP");
  if (writer.Write(out.tempPath().c_str()) != IFSelect_RetDone)
    throw InputError("writing '" + path + "': OpenCASCADE could not write the STEP file");
  out.commit();
}

int CadModel::eulerCharacteristic() const {
  int chi = int(corners_.size()) - int(curves_.size());
  for (const auto& p : patches_) chi += 2 - int(p.loops.size());
  return chi;
}

Vec3 CadModel::curvePoint(int curve, double t) const {
  const auto& g = impl_->curveGeom[curve];
  gp_Pnt p = g.curve->Value(t);
  if (!g.identity) p.Transform(g.trsf);
  return toVec(p);
}

Vec3 CadModel::curveDerivative(int curve, double t) const {
  const auto& g = impl_->curveGeom[curve];
  gp_Pnt p;
  gp_Vec d;
  g.curve->D1(t, p, d);
  if (!g.identity) d.Transform(g.trsf);
  return toVec(d);
}

double CadModel::curveCurvature(int curve, double t) const {
  const auto& g = impl_->curveGeom[curve];
  GeomLProp_CLProps props(g.curve, t, 2, 1e-9);
  if (!props.IsTangentDefined()) return 0.0;
  return std::abs(props.Curvature());
}

Point2 CadModel::curveOnPatch(int curve, int patch, int side, double t) const {
  auto it = impl_->pcurves.find({curve, patch, side});
  if (it == impl_->pcurves.end()) it = impl_->pcurves.find({curve, patch, 0});
  if (it == impl_->pcurves.end())
    throw ProcessingError("CadModel: curve " + std::to_string(curve) + " is not on patch " + std::to_string(patch));
  const gp_Pnt2d q = it->second->Value(t);
  return {q.X(), q.Y()};
}

Point2 CadModel::useOnPatch(int patch, const CadCurveUse& use, double t) const {
  if (use.curve >= 0) return curveOnPatch(use.curve, patch, use.side, t);
  auto it = impl_->pcurves.find({-use.edge, patch, 0});
  if (it == impl_->pcurves.end())
    throw ProcessingError("CadModel: degenerate edge " + std::to_string(use.edge) + " is not on patch " +
                          std::to_string(patch));
  const gp_Pnt2d q = it->second->Value(t);
  return {q.X(), q.Y()};
}

PatchPoint CadModel::patchPoint(int patch, double u, double v) const {
  const auto& g = impl_->surfaceGeom[patch];
  gp_Pnt p;
  gp_Vec du, dv;
  g.surface->D1(u, v, p, du, dv);
  if (!g.identity) {
    p.Transform(g.trsf);
    du.Transform(g.trsf);
    dv.Transform(g.trsf);
  }
  return {toVec(p), toVec(du), toVec(dv)};
}

double CadModel::patchMaxCurvature(int patch, double u, double v) const {
  const auto& g = impl_->surfaceGeom[patch];
  GeomLProp_SLProps props(g.surface, u, v, 2, 1e-9);
  if (!props.IsCurvatureDefined()) return 0.0;
  return std::max(std::abs(props.MaxCurvature()), std::abs(props.MinCurvature()));
}

Vec3 CadModel::patchNormal(int patch, double u, double v) const {
  const PatchPoint pp = patchPoint(patch, u, v);
  Vec3 n = cross(pp.du, pp.dv);
  const double len = norm(n);
  if (len == 0) return {0, 0, 0};
  n = (1.0 / len) * n;
  return patches_[patch].reversed ? -1.0 * n : n;
}

double CadModel::distanceToPatch(int patch, const Vec3& p, Point2* uv) const {
  const TopoDS_Vertex v = BRepBuilderAPI_MakeVertex(gp_Pnt(p[0], p[1], p[2]));
  BRepExtrema_DistShapeShape dist(v, impl_->surfaceGeom[patch].face);
  if (!dist.IsDone() || dist.NbSolution() == 0)
    throw ProcessingError("CadModel: no distance from a point to patch " + std::to_string(patch));
  if (uv) {
    double u = 0, w = 0;
    if (dist.SupportTypeShape2(1) == BRepExtrema_IsInFace) {
      dist.ParOnFaceS2(1, u, w);
    }
    *uv = {u, w};
  }
  return dist.Value();
}

bool CadModel::insideSolid(int solid, const Vec3& p, double tol) const {
  BRepClass3d_SolidClassifier cls(impl_->solidShapes[solid], gp_Pnt(p[0], p[1], p[2]), tol);
  return cls.State() == TopAbs_IN;
}

} // namespace tetflow
