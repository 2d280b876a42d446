// MeshCADSurface: PSYS (seed chapter 3) on a CAD model: particles on its corners, curves and
// patches with an inferred sizing field, their parameter-space triangulation stitched into a
// closed surface, then TetGen inside it (Algorithms/SurfaceMeshing/CadMesher.h).
// The headers are OpenCASCADE-free; without OpenCASCADE only the code behind them is left out.
#include "Algorithms/Core/Errors.h"
#include "Algorithms/SurfaceMeshing/CadMesher.h"
#include "StandardModules.h"

namespace tetflow {

namespace {

class MeshCADSurface : public Module {
public:
  void execute(ExecutionContext& ctx) override {
#ifdef TETFLOW_HAVE_OCCT
    const auto& model = ctx.inputAs<CadModelData>(0).value;
    CadMeshParams p;
    p.particles.sKappa = ctx.getDouble("s_kappa");
    p.particles.sTau = ctx.getDouble("s_tau");
    p.particles.lipschitz = ctx.getDouble("lipschitz");
    p.particles.minSize = ctx.getDouble("min_size");
    p.particles.maxSize = ctx.getDouble("max_size");
    p.particles.maxIterations = int(ctx.getInt("particle_iterations"));
    p.particles.seed = unsigned(ctx.getInt("seed"));
    p.tetgenQuality = ctx.getString("tetgen_quality");
    p.maxTetVolume = ctx.getDouble("max_tet_volume");
    p.improve = ctx.getBool("improve");
    p.improveParams = improveParamsFrom(ctx, "improve_");
    p.improveParams.fixSurfaces = true;
    if (!p.tetgenQuality.empty() && p.tetgenQuality.find_first_not_of("0123456789./") != std::string::npos)
      throw InputError("tetgen_quality '" + p.tetgenQuality +
                       "': use TetGen's -q value RATIO/ANGLE, e.g. 1.414/10, or leave it empty for none");
    CadMeshResult res = meshCadModel(*model, p);
    Report& r = ctx.report();
    int64_t counts[3] = {0, 0, 0};
    r.set("min_size_mm", res.particles.minSize);
    r.set("max_size_mm", res.particles.maxSize);
    for (size_t i = 0; i < res.particles.phases.size(); ++i) {
      const PsysPhaseStats& ph = res.particles.phases[i];
      const std::string k = "phase" + std::to_string(i + 1) + "_";
      r.set(k + "name", ph.name);
      r.set(k + "iterations", ph.iterations);
      r.set(k + "converged", ph.converged);
      r.set(k + "energy_first", ph.firstEnergy);
      r.set(k + "energy_last", ph.lastEnergy);
      r.set(k + "splits", ph.splits);
      r.set(k + "deletes", ph.deletes);
      r.set(k + "seconds", ph.seconds);
    }
    counts[0] = int64_t(model->corners().size());
    counts[1] = res.particles.phases.size() > 1 ? res.particles.phases[1].particles : 0;
    counts[2] = res.particles.phases.size() > 2 ? res.particles.phases[2].particles : 0;
    r.set("corner_particles", counts[0]);
    r.set("curve_particles", counts[1]);
    r.set("patch_particles", counts[2]);
    r.set("sigma_min_mm", res.particles.sigmaMin);
    r.set("sigma_max_mm", res.particles.sigmaMax);
    r.set("curve_splits", res.triangulation.curveSplits);
    r.set("encroaching_removed", res.triangulation.encroachingRemoved);
    r.set("surface_flips", res.triangulation.flips);
    r.set("pole_folds_cancelled", res.triangulation.foldsCancelled);
    r.set("surface_smoothing_moves", res.smoothed);
    const SurfaceFigures& f = res.figures;
    r.set("surface_vertices", f.vertices);
    r.set("surface_triangles", f.triangles);
    r.set("surface_euler", f.euler);
    r.set("model_euler", res.modelEuler);
    r.set("triangle_min_angle_deg", f.minAngle);
    r.set("triangle_median_min_angle_deg", f.medianMinAngle);
    r.set("triangle_max_radius_edge", f.maxRadiusEdge);
    r.set("triangle_median_radius_edge", f.medianRadiusEdge);
    r.set("tets", res.mesh.numTets());
    r.set("vertices", res.mesh.numPoints());
    r.set("tetgen_steiner_points", res.tetgen.addedPoints);
    r.set("min_dihedral_deg", res.minDihedral);
    r.set("max_dihedral_deg", res.maxDihedral);
    if (p.improve) {
      writeImproveReport(res.improve, p.improveParams, r);
      logUnfixed(ctx, res.improve, p.improveParams);
    }
    r.set("seconds_particles", res.seconds[0]);
    r.set("seconds_triangulate", res.seconds[1]);
    r.set("seconds_tetgen", res.seconds[2]);
    r.set("seconds_improve", res.seconds[3]);
    ctx.setOutput(0, makeData<TetMeshData>(std::move(res.mesh)));
#else
    (void)ctx;
    throwBuiltWithoutOpenCascade("MeshCADSurface");
#endif
  }
};

} // namespace

void registerMeshCADSurface(ModuleRegistry& r) {
  ModuleInfo m;
  m.name = "MeshCADSurface";
  m.category = "Meshing";
  m.description =
      "PSYS (seed chapter 3): particles on the model's corners, then curves, then surface patches, "
      "spaced by a sizing field they infer from curvature (s_kappa), gap size (s_tau) and a Lipschitz "
      "bound; moved in each patch's parameters by an energy computed in 3-D, with splits and "
      "deletes. Each patch is triangulated in its affinely scaled parameter space, the patches are "
      "stitched along their curves into a closed surface (checked: manifold, the model's Euler "
      "characteristic), and TetGen fills each solid (material = solid index + 1) keeping every "
      "surface triangle.";
  m.inputs = {{"model", {PortType::CADModel}, "the CAD model (ReadCADModel)"}};
  m.outputs = {{"mesh", {PortType::TetMesh}, "the tetrahedral mesh, one material per solid"}};
  const PsysParams d;
  ParamSpec iters = makeParam("particle_iterations", ParamType::Int, int64_t(d.maxIterations), "",
                              "iteration limit of each of the three particle phases");
  iters.min = 1.0;
  iters.max = 100000.0;
  ParamSpec seed = makeParam("seed", ParamType::Int, int64_t(d.seed), "", "random seed of the splits and seeding");
  seed.min = 0.0;
  seed.max = 4294967295.0;
  m.params = {
      doubleParam("s_kappa", d.sKappa, 1e-3, 1e3, "", "curvature scaling: sigma <= 1/(s_kappa * curvature)"),
      doubleParam("s_tau", d.sTau, 1e-3, 1.0, "", "gap scaling: sigma <= s_tau * distance to a non-adjacent cell"),
      doubleParam("lipschitz", d.lipschitz, 0.0, 0.95, "", "Lipschitz bound of the sizing field"),
      doubleParam("min_size", 0.0, 0.0, std::nullopt, "mm",
                  "smallest sigma (0: 1/1000 of the bounding box diagonal); edges come out at about 0.58 sigma"),
      doubleParam("max_size", 0.0, 0.0, std::nullopt, "mm", "largest sigma (0: 1/10 of the bounding box diagonal)"),
      iters,
      seed,
      makeParam("tetgen_quality", ParamType::String, std::string("1.414/10"), "",
                "TetGen's -q value inside the solids: radius-edge ratio / minimum dihedral angle (empty: none)"),
      doubleParam("max_tet_volume", 0.0, 0.0, std::nullopt, "mm^3", "TetGen's -a volume bound (0: none)"),
      makeParam("improve", ParamType::Bool, true, "",
                "improve TetGen's tets toward [improve_min_angle, improve_max_angle] keeping every surface "
                "triangle where it is")};
  for (auto& s : improveParamSpecs("improve_")) m.params.push_back(s);
  m.summaryKeys = {"surface_triangles", "triangle_min_angle_deg", "tets", "min_dihedral_deg", "max_dihedral_deg"};
  m.factory = [] { return std::make_unique<MeshCADSurface>(); };
  r.add(std::move(m));
}

} // namespace tetflow
