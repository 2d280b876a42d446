// GenerateBackgroundMesh: the background tet mesh that cleaving deforms (seed §4.4).
#include <algorithm>
#include <optional>
#include <sstream>

#include "Algorithms/BackgroundMesh/BccLattice.h"
#include "Algorithms/BackgroundMesh/OctreeBcc.h"
#include "Algorithms/BackgroundMesh/Particles.h"
#include "Algorithms/BackgroundMesh/TetBudget.h"
#include "Algorithms/BackgroundMesh/ThinLayers.h"
#include "StandardModules.h"

namespace tetflow {

namespace {
// The lattice kind travels with the mesh as a point field so CleaveMesh can apply
// alpha_short / alpha_long per edge.
void attachLatticeKind(BackgroundMesh& bg) {
  Field kind;
  kind.values.reserve(bg.kind.size());
  for (auto k : bg.kind) kind.values.push_back(double(static_cast<int>(k)));
  bg.mesh.pointFields["lattice_kind"] = std::move(kind);
}

// Axis-aligned physical bounds of a grid's voxel cells.
void physicalBounds(const GridGeometry& g, Vec3& lo, Vec3& hi) {
  lo = {1e300, 1e300, 1e300};
  hi = {-1e300, -1e300, -1e300};
  for (int c = 0; c < 8; ++c) {
    const Vec3 p = g.indexToPhysical((c & 1) ? double(g.dims[0]) - 0.5 : -0.5, (c & 2) ? double(g.dims[1]) - 0.5 : -0.5,
                                     (c & 4) ? double(g.dims[2]) - 0.5 : -0.5);
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], p[a]);
      hi[a] = std::max(hi[a], p[a]);
    }
  }
}

void warnIfApart(ExecutionContext& ctx, const GridGeometry& grid, const ScalarVolume& sizing) {
  Vec3 vlo, vhi, slo, shi;
  physicalBounds(grid, vlo, vhi);
  physicalBounds(sizing.grid, slo, shi);
  bool overlap = true;
  for (int a = 0; a < 3; ++a) overlap = overlap && slo[a] < vhi[a] && vlo[a] < shi[a];
  if (!overlap)
    ctx.log("the sizing field's grid does not overlap the volume: every point takes the field's "
            "nearest edge value; compute the field from the same volume (ComputeSizingField)");
}

std::string triple(double a, double b, double c) {
  std::ostringstream s;
  s << a << " x " << b << " x " << c;
  return s.str();
}

class GenerateBackgroundMesh : public Module {
public:
  void execute(ExecutionContext& ctx) override {
    const DataPtr& in = ctx.input(0);
    const GridGeometry grid = in->type() == PortType::LabelVolume
                                  ? ctx.inputAs<LabelVolumeData>(0).value.grid
                                  : ctx.inputAs<MaterialsData>(0).value->grid();
    const std::string kind = ctx.getString("kind");
    const bool haveSizing = ctx.hasInput(1);
    Report& r = ctx.report();
    r.set("kind", kind);
    // Thin layers: the labels the edges are checked against (the argmax of indicator functions).
    const std::string thinMode = ctx.getString("refine_thin_layers");
    const bool thinOn = thinMode != "none" && kind != "particles";
    const EdgeTopology::Mode mode = thinMode == "all" ? EdgeTopology::Mode::All : EdgeTopology::Mode::Separating;
    std::optional<LabelVolume> argmax;
    std::optional<EdgeTopology> thin;
    if (thinOn) {
      if (in->type() == PortType::LabelVolume) {
        thin.emplace(ctx.inputAs<LabelVolumeData>(0).value, mode);
      } else {
        argmax.emplace(ctx.inputAs<MaterialsData>(0).value->dominantLabels());
        thin.emplace(*argmax, mode);
      }
    }
    // The label volume the tets are predicted against (and the budget fitted to).
    // Indicator functions give their argmax, when the thin layers made it already or a budget needs it.
    const int64_t maxTets = ctx.getInt("max_tets");
    const LabelVolume* labels = nullptr;
    if (in->type() == PortType::LabelVolume) {
      labels = &ctx.inputAs<LabelVolumeData>(0).value;
    } else {
      if (!argmax && maxTets > 0) argmax.emplace(ctx.inputAs<MaterialsData>(0).value->dominantLabels());
      if (argmax) labels = &*argmax;
    }
    const std::optional<int32_t> exterior =
        labelOrNoneParam(ctx, "max_tets_exterior", "the label CleaveMesh's strip_exterior removes");
    // Every size times `scale` (1 = as the parameters ask); the last build's report wins.
    std::optional<ScalarVolume> scaledSizing;
    const double thinRatio = ctx.getDouble("thin_layer_ratio");
    auto build = [&](double scale) -> BackgroundMesh {
      // A budget relaxes the thin-layer refinement by the same factor (the layers' tets are most
      // of a head's, and the lattice's cells move in steps of two).
      if (thin) thin->setSplitRatio(std::min(8.0, thinRatio * scale));
      BackgroundMesh bg;
      if (kind == "particles") {
        if (!haveSizing)
          throw InputError("kind particles needs a sizing field on input port 1 'sizing': connect "
                           "ComputeSizingField's output, or use kind regular_bcc");
        warnIfApart(ctx, grid, ctx.inputAs<ScalarVolumeData>(1).value);
        ParticleParams p;
        p.padding = ctx.getDouble("padding");
        p.min_size = ctx.getDouble("min_cell_size") * scale;
        p.max_size = ctx.getDouble("max_cell_size") * scale;
        p.size_scale = ctx.getDouble("particle_size_scale") * scale;
        p.max_iterations = int(ctx.getInt("particle_iterations"));
        p.theta = ctx.getDouble("particle_theta");
        p.move_tolerance = ctx.getDouble("particle_tolerance");
        p.min_angle = ctx.getDouble("particle_min_angle");
        p.max_angle = ctx.getDouble("particle_max_angle");
        p.seed = uint32_t(ctx.getInt("particle_seed"));
        ParticleMeshResult pm = generateParticleMesh(grid, ctx.inputAs<ScalarVolumeData>(1).value, p, ctx.progress());
        bg = std::move(pm.background);
        reportParticleMesh(pm.stats, r);
        ctx.log("particles: " + std::to_string(pm.stats.iterations) + " iterations (" +
                formatReportValue(ReportValue(pm.stats.secondsPerIteration)) + " s each, stopped by " +
                pm.stats.stopReason + "); Delaunay dihedral angles [" +
                formatReportValue(ReportValue(pm.stats.improve.minBefore)) + ", " +
                formatReportValue(ReportValue(pm.stats.improve.maxBefore)) + "] -> [" +
                formatReportValue(ReportValue(pm.stats.improve.minAfter)) + ", " +
                formatReportValue(ReportValue(pm.stats.improve.maxAfter)) + "] after sliver removal");
      } else if (kind == "octree_bcc") {
        if (!haveSizing)
          throw InputError("kind octree_bcc needs a sizing field on input port 1 'sizing': connect "
                           "ComputeSizingField's output, or use kind regular_bcc");
        OctreeBccParams p;
        p.min_cell_size = ctx.getDouble("min_cell_size") * scale;
        p.max_cell_size = ctx.getDouble("max_cell_size") * scale;
        p.padding = ctx.getDouble("padding");
        p.thin_layer_cell_size = ctx.getDouble("thin_layer_cell_size");
        std::shared_ptr<const MaterialSet> mats;
        if (ctx.getBool("uniform_interfaces")) mats = materialsFromInput(in, ctx.getDouble("blend_sigma"));
        const ScalarVolume* field = &ctx.inputAs<ScalarVolumeData>(1).value;
        if (scale != 1.0) {
          scaledSizing = *field;
          for (float& v : scaledSizing->data) v = float(double(v) * scale);
          field = &*scaledSizing;
        }
        const ScalarVolume& sizing = *field;
        if (scale == 1.0) warnIfApart(ctx, grid, sizing);
        OctreeBccResult o = generateOctreeBcc(grid, sizing, p, ctx.progress(), mats.get(), thin ? &*thin : nullptr);
        bg = std::move(o.background);
        r.set("root_cells", std::to_string(bg.cells[0]) + " x " + std::to_string(bg.cells[1]) + " x " +
                                std::to_string(bg.cells[2]));
        reportOctreeBcc(o.stats, r);
      } else {
        if (haveSizing)
          ctx.log("kind regular_bcc ignores the sizing field on port 1 (uniform cell_size); use kind "
                  "octree_bcc to grade the lattice by it");
        BccParams p;
        p.cell_size = ctx.getDouble("cell_size") * scale;
        p.padding = ctx.getDouble("padding");
        if (thin) {
          OctreeBccParams op;
          op.thin_layer_cell_size = ctx.getDouble("thin_layer_cell_size");
          std::shared_ptr<const MaterialSet> mats;
          if (ctx.getBool("uniform_interfaces")) mats = materialsFromInput(in, ctx.getDouble("blend_sigma"));
          OctreeBccResult o = generateThinLayerBcc(grid, p, op, *thin, ctx.progress(), mats.get());
          bg = std::move(o.background);
          reportThinLayers(o.stats, r);
          if (o.stats.thinLayerSplits > 0) r.set("levels", ReportValue(int64_t(o.stats.levels)));
        } else {
          bg = generateRegularBcc(grid, p, ctx.progress());
        }
        r.set("cells", std::to_string(bg.cells[0]) + " x " + std::to_string(bg.cells[1]) + " x " +
                           std::to_string(bg.cells[2]));
        r.set("cell_size_mm", triple(bg.cellSize[0], bg.cellSize[1], bg.cellSize[2]));
      }
      return bg;
    };
    BackgroundMesh bg;
    if (maxTets > 0) {
      TetBudgetParams bp;
      bp.maxTets = maxTets;
      bp.strippedLabel = exterior;
      double longest = 0.0;
      for (int a = 0; a < 3; ++a) longest = std::max(longest, double(grid.dims[size_t(a)]) * grid.spacing[a]);
      double smallest = 0.0;
      if (kind == "regular_bcc") {
        smallest = ctx.getDouble("cell_size");
        bp.scaledWhat = "cell_size " + formatReportValue(ReportValue(smallest)) + " mm";
      } else if (haveSizing) {
        const SizeRange range = checkSizingField(ctx.inputAs<ScalarVolumeData>(1).value);
        smallest = std::max(double(range.min), ctx.getDouble("min_cell_size"));
        bp.scaledWhat = "the sizing field";
      }
      bp.maxScale = std::max(1.0, longest / std::max(smallest, 1e-9));
      if (thinOn)
        bp.refinementAdvice = "raise thin_layer_ratio or thin_layer_cell_size (the layer is then kept where it is "
                              "thicker than the cells and closed by the label repair elsewhere), or set "
                              "refine_thin_layers none";
      ctx.progress().beginStage("tet budget");
      TetBudgetResult fit = fitTetBudget(build, *labels, bp, ctx.progress());
      ctx.progress().endStage();
      bg = std::move(fit.background);
      reportTetPrediction(fit.prediction, r);
      r.set("max_tets", ReportValue(maxTets));
      r.set("budget_scale", ReportValue(fit.scale));
      r.set("budget_tries", ReportValue(int64_t(fit.tries.size())));
      std::string trace;
      for (const auto& t : fit.tries)
        trace += (trace.empty() ? "" : ", ") + formatReportValue(ReportValue(t.scale)) + " -> " +
                 std::to_string(int64_t(std::llround(t.predicted)));
      ctx.log("max_tets " + std::to_string(maxTets) + ": sizes x " + formatReportValue(ReportValue(fit.scale)) +
              " (tries: scale -> predicted tets: " + trace + ")");
    } else {
      bg = build(1.0);
      if (labels) reportTetPrediction(predictCleavedTets(bg.tets(), *labels, exterior, ctx.progress()), r);
    }
    if (kind == "regular_bcc" && thin) {
      const double asked = ctx.getDouble("cell_size") * (r.has("budget_scale") ? r.number("budget_scale") : 1.0);
      const double got = std::max({bg.cellSize[0], bg.cellSize[1], bg.cellSize[2]});
      if (std::abs(got / asked - 1.0) > 0.1)
        ctx.log("cells of " + formatReportValue(ReportValue(got)) + " mm for cell_size " + formatReportValue(ReportValue(asked)) +
                " mm: with refine_thin_layers the cells are the power of two times the voxel nearest to it, so that "
                "the refinement's levels fall on the same sizes and a coarser cell never gives more tets "
                "(refine_thin_layers none keeps cell_size as it is)");
    }
    if (!bg.kind.empty()) attachLatticeKind(bg); // none for particles: CleaveMesh then uses per-vertex alphas
    r.set("vertices", ReportValue(int64_t(bg.mesh.numPoints())));
    r.set("tets", ReportValue(int64_t(bg.mesh.numTets())));
    r.set("box_volume_mm3", ReportValue(bg.boxVolume));
    ctx.setOutput(0, makeData<TetMeshData>(std::move(bg.mesh)));
  }
};
} // namespace

void registerGenerateBackgroundMesh(ModuleRegistry& r) {
  ModuleInfo m;
  m.name = "GenerateBackgroundMesh";
  m.category = "Meshing";
  m.description = "Builds the background mesh for cleaving, covering exactly the volume's box (plus "
                  "padding): a regular body-centred cubic lattice (regular_bcc) or a BCC lattice graded "
                  "on a balanced octree by a sizing field (octree_bcc), both with tets bisected at the "
                  "box faces so the mesh ends on the box; or an unstructured mesh of electrostatic "
                  "particles spaced by the sizing field, box corners, edges and faces first, "
                  "tetrahedralized by TetGen and freed of slivers (particles, seed §5.4).";
  m.inputs = {{"volume", {PortType::LabelVolume, PortType::Materials}, "gives the box to cover"},
              {"sizing", {PortType::ScalarVolume}, "element size field in mm (ComputeSizingField); needed by octree_bcc and particles", true}};
  m.outputs = {{"mesh", {PortType::TetMesh}, "background tet mesh"}};
  ParamSpec kind = makeParam("kind", ParamType::Enum, std::string("regular_bcc"), "", "lattice type");
  kind.choices = {"regular_bcc", "octree_bcc", "particles"};
  ParamSpec cs = doubleParam("cell_size", 4.0, 1e-6, std::nullopt, "mm",
                             "regular_bcc: edge of a lattice cell (rounded per axis so cells tile the box exactly)");
  ParamSpec pad = doubleParam("padding", 0.0, 0.0, std::nullopt, "mm",
                              "margin added around the volume's box on every side");
  ParamSpec minc = doubleParam("min_cell_size", 0.0, 0.0, std::nullopt, "mm",
                               "octree_bcc: leaves stop splitting at this edge (the finest lie between half of it and it); particles: lower clamp of the spacing; 0 = the sizing field's minimum");
  ParamSpec maxc = doubleParam("max_cell_size", 0.0, 0.0, std::nullopt, "mm",
                               "octree_bcc: root cell edge; particles: upper clamp of the spacing; 0 = the sizing field's maximum");
  ParamSpec uni = makeParam("uniform_interfaces", ParamType::Bool, false, "",
                            "octree_bcc: refine until no graded (transition or bisected) tet is cut by a "
                            "material interface (seed §4.8.1); better angles after cleaving, more tets");
  ParamSpec sigma = doubleParam("blend_sigma", kDefaultBlendSigma, 0.05, 10.0, "voxels",
                                "uniform_interfaces with a label volume: smoothing into indicator "
                                "functions (use CleaveMesh's value)");
  const ParticleParams pd;
  ParamSpec pscale = doubleParam("particle_size_scale", pd.size_scale, 0.05, 20.0, "",
                                 "particles: spacing = this x the sizing field");
  ParamSpec pit = makeParam("particle_iterations", ParamType::Int, int64_t(pd.max_iterations), "",
                            "particles: relaxation iterations at most (it stops earlier when the energy or the largest move stops falling)");
  pit.min = 0.0;
  pit.max = 100000.0;
  ParamSpec ptheta = doubleParam("particle_theta", pd.theta, 0.0, 1.5, "",
                                 "particles: Barnes-Hut opening ratio (cell edge / distance; 0 = exact sums)");
  ParamSpec ptol = doubleParam("particle_tolerance", pd.move_tolerance, 0.001, 0.5, "",
                               "particles: the relaxation stops when no particle moves more than this x its spacing");
  ParamSpec pmin = doubleParam("particle_min_angle", pd.min_angle, 1.0, 35.0, "deg",
                               "particles: sliver removal target for the smallest dihedral angle of the background");
  ParamSpec pmax = doubleParam("particle_max_angle", pd.max_angle, 120.0, 179.0, "deg",
                               "particles: sliver removal target for the largest dihedral angle of the background");
  ParamSpec pseed = makeParam("particle_seed", ParamType::Int, int64_t(pd.seed), "",
                              "particles: seed of the initial placement (the result is the same for any thread count)");
  pseed.min = 0.0;
  pseed.max = 2147483647.0;
  ParamSpec thinOn = makeParam("refine_thin_layers", ParamType::Enum, std::string("separating"), "",
                               "regular_bcc and octree_bcc: split the cells whose edges miss a layer of the "
                               "voxels (seed §6.2) down to thin_layer_cell_size: separating = only where the "
                               "missed layer keeps apart two labels that do not touch near the edge (the CSF "
                               "between skull and brain) or belongs to a component without a core voxel (a "
                               "one-voxel sheet, lost whole); all = every layer and sheet thinner than the cells (many more "
                               "tets on a real head); none = the lattice as it is");
  thinOn.choices = {"separating", "all", "none"};
  ParamSpec thinCell = doubleParam("thin_layer_cell_size", 0.0, 0.0, std::nullopt, "mm",
                                   "refine_thin_layers: splitting stops at cells no longer than this (0 = sqrt 2 x the voxel size: cells within a factor sqrt 2 of the voxels)");
  ParamSpec thinRatio = doubleParam("thin_layer_ratio", 2.0, 1.0, 8.0, "",
                                    "refine_thin_layers: a cell whose edge misses a layer is split only while the edge "
                                    "is longer than this x the layer's extent along it (1 = until no edge misses it or "
                                    "thin_layer_cell_size is reached; larger = as fine as the layer is thin, fewer "
                                    "tets, the label repair closes what is left)");
  ParamSpec maxTets = makeParam("max_tets", ParamType::Int, int64_t(0), "",
                                "a budget for the mesh cleaving makes (predicted from the background: a tet of one label "
                                "stays one tet, a tet cut by an interface becomes about 2): every size (cell_size, the "
                                "sizing field, the particles' spacing) and thin_layer_ratio (up to 8) are scaled up by "
                                "one factor until the prediction fits, or the module fails naming the layer that cannot "
                                "be kept within it; 0 = no budget");
  maxTets.min = 0.0;
  maxTets.max = 2147483647.0;
  ParamSpec maxTetsExt = makeParam("max_tets_exterior", ParamType::String, std::string("none"), "",
                                   "max_tets: the label CleaveMesh's strip_exterior removes (its tets do not count), or none");
  m.params = {kind, cs, pad, minc, maxc, uni, sigma, pscale, pit, ptheta, ptol, pmin, pmax, pseed, thinOn, thinCell, thinRatio,
              maxTets, maxTetsExt};
  m.summaryKeys = {"cells", "levels", "tets"};
  m.factory = [] { return std::make_unique<GenerateBackgroundMesh>(); };
  r.add(std::move(m));
}

} // namespace tetflow
