// ImproveMesh: label-preserving mesh improvement (Algorithms/MeshImprovement/MeshImprovement.h)
// of a mesh from any source, e.g. read from a file. CleaveMesh runs the same stage itself
// (parameters improve_*); this module is for meshes that were not cleaved here.
#include "Algorithms/MeshImprovement/MeshImprovement.h"
#include "StandardModules.h"

namespace tetflow {

namespace {

class ImproveMesh : public Module {
public:
  void execute(ExecutionContext& ctx) override {
    TetMesh mesh = ctx.inputAs<TetMeshData>(0).value;
    ImproveParams p = improveParamsFrom(ctx, "");
    p.smooth = ctx.getBool("smooth");
    p.flip = ctx.getBool("flip");
    p.collapse = ctx.getBool("collapse");
    p.insert = ctx.getBool("insert");
    p.goal_margin = ctx.getDouble("goal_margin");
    const ImproveStats s = improveMesh(mesh, p, ctx.progress());
    writeImproveReport(s, p, ctx.report());
    logUnfixed(ctx, s, p);
    ctx.setOutput(0, makeData<TetMeshData>(std::move(mesh)));
  }
};

} // namespace

std::vector<ParamSpec> improveParamSpecs(const std::string& prefix) {
  const ImproveParams d;
  ParamSpec passes = makeParam(prefix + "passes", ParamType::Int, int64_t(d.passes), "",
                               "passes over the tets still below the target (0 = measure only)");
  passes.min = 0.0;
  passes.max = 100.0;
  return {doubleParam(prefix + "min_angle", d.min_angle, 1.0, 59.0, "deg",
                      "target: every dihedral angle at least this"),
          doubleParam(prefix + "max_angle", d.max_angle, 91.0, 179.0, "deg",
                      "target: every dihedral angle at most this"),
          doubleParam(prefix + "max_volume_change", d.max_volume_change, 0.0, 0.1, "%",
                      "largest net volume change of any material (interface vertices slide in the "
                      "interface's tangent plane; flips, collapses and splits change no volume)"),
          passes};
}

ImproveParams improveParamsFrom(const ExecutionContext& ctx, const std::string& prefix) {
  ImproveParams p;
  p.min_angle = ctx.getDouble(prefix + "min_angle");
  p.max_angle = ctx.getDouble(prefix + "max_angle");
  p.max_volume_change = ctx.getDouble(prefix + "max_volume_change");
  p.passes = static_cast<int>(ctx.getInt(prefix + "passes"));
  return p;
}

void logUnfixed(ExecutionContext& ctx, const ImproveStats& s, const ImproveParams& p) {
  if (s.unfixedCount == 0) return;
  std::string msg = std::to_string(s.unfixedCount) + " tet(s) still outside [" + formatDouble(p.min_angle) + ", " +
                    formatDouble(p.max_angle) + "] deg after improvement (improve_unfixed_where in the report lists the worst)";
  ctx.log(msg);
}

void registerImproveMesh(ModuleRegistry& r) {
  ModuleInfo m;
  m.name = "ImproveMesh";
  m.category = "Meshing";
  m.description =
      "Label-preserving mesh improvement: raises the smallest and lowers the largest dihedral angles "
      "toward [min_angle, max_angle], worst tets first, by vertex smoothing (vertices inside one "
      "material move freely, vertices on an interface slide in its tangent plane, on a triple curve "
      "along it), edge removal and 2-3 flips inside one material, collapse of vertices inside one "
      "material, and edge splits. No tet is inverted; no material's region changes except by the "
      "tangent slides (net volume change per material at most max_volume_change %); the label "
      "topology and the box are kept. Deterministic for any number of threads.";
  m.inputs = {{"mesh", {PortType::TetMesh}, "a valid multimaterial tet mesh"}};
  m.outputs = {{"mesh", {PortType::TetMesh}, "the improved mesh (point fields kept, cell fields carried)"}};
  m.params = improveParamSpecs("");
  m.params.push_back(doubleParam("goal_margin", ImproveParams{}.goal_margin, 0.0, 20.0, "deg",
                                 "tets are worked on up to min_angle + goal_margin"));
  for (const char* op : {"smooth", "flip", "collapse", "insert"})
    m.params.push_back(makeParam(op, ParamType::Bool, true, "", std::string("use the operation '") + op + "'"));
  m.summaryKeys = {"improve_min_dihedral_after", "improve_max_dihedral_after", "improve_unfixed_tets"};
  m.factory = [] { return std::make_unique<ImproveMesh>(); };
  r.add(std::move(m));
}

} // namespace tetflow
