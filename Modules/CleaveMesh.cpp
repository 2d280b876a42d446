// CleaveMesh: lattice cleaving (Algorithms/Cleaving/Cleaver.h) of a background mesh into a
// conforming multimaterial mesh.
#include <cmath>
#include <optional>
#include <sstream>

#include "Algorithms/Cleaving/CleavePipeline.h"
#include "Algorithms/Core/MemoryBudget.h"
#include "StandardModules.h"

namespace tetflow {

namespace {

// Peak memory above the inputs: 129-148 bytes per background tet measured (head phantom, regular
// lattice of 1.4-5.8 M tets, label repair on); 160 assumed, plus 60 for the best trial that volume
// calibration keeps. Refused before anything is copied, with the background size that fits and
// the cell_size giving it (a regular BCC lattice has 12 tets per cell).
void requireCleaveMemory(const TetMesh& bg, bool calibration) {
  const double perTet = 160.0 + (calibration ? 60.0 : 0.0);
  const double tets = double(bg.numTets());
  std::ostringstream what;
  what << "CleaveMesh on a background mesh of " << bg.numTets() << " tets";
  requireMemory(perTet * tets, what.str(), [&](double avail) {
    const double fits = std::floor(avail / perTet);
    double volume = 0.0;
    for (size_t t = 0; t < bg.numTets(); ++t) volume += std::abs(bg.tetVolume(t));
    const double cell = std::cbrt(12.0 * volume / std::max(tets, 1.0));
    std::ostringstream f;
    f << "use a background mesh of at most " << fits << " tets (GenerateBackgroundMesh regular_bcc: cell_size >= "
      << roundUpForAdvice(cell * std::cbrt(tets / std::max(fits, 1.0)) * 1.02) << " mm)";
    return f.str();
  });
}

class CleaveMesh : public Module {
public:
  void execute(ExecutionContext& ctx) override {
    // Indicator functions and the working copy of the background: a stage of its own, so that
    // its time is reported and a cancellation between its steps is seen.
    ctx.progress().beginStage("prepare");
    const auto mats = materialsFromInput(ctx.input(0), ctx.getDouble("blend_sigma"));
    ctx.progress().checkCancel();
    const TetMesh& bgMesh = ctx.inputAs<TetMeshData>(1).value;
    requireCleaveMemory(bgMesh, ctx.getInt("volume_calibration") > 0);
    BackgroundMesh bg;
    bg.view = &bgMesh; // read in place: the cleaver copies only the vertex positions it warps
    auto it = bgMesh.pointFields.find("lattice_kind");
    if (it != bgMesh.pointFields.end() && it->second.components == 1) {
      bg.kind.reserve(bgMesh.numPoints());
      for (double k : it->second.values) bg.kind.push_back(static_cast<LatticeVertexKind>(int(k)));
    }
    ctx.progress().checkCancel();
    CleaveParams p;
    p.alpha_short = ctx.getDouble("alpha_short");
    p.alpha_long = ctx.getDouble("alpha_long");
    p.xi = ctx.getDouble("xi");
    const std::string ip0 = ctx.getString("interface_points");
    p.interface_points = ip0 == "exact"    ? CleaveParams::InterfacePoints::Exact
                         : ip0 == "linear" ? CleaveParams::InterfacePoints::Linear
                                           : CleaveParams::InterfacePoints::Auto;
    p.strip_exterior = labelOrNoneParam(ctx, "strip_exterior", "a material label value");
    const bool repairOn = ctx.getBool("repair_labels");
    CleavePipelineParams pp;
    pp.cleave = p;
    pp.calibration_rounds = static_cast<int>(ctx.getInt("volume_calibration"));
    pp.repair = repairOn;
    pp.repairParams.fragment_voxels = ctx.getDouble("fragment_voxels");
    pp.repairParams.points = ctx.getBool("repair_point_contacts");
    pp.strip = p.strip_exterior;
    pp.stripCavities = ctx.getBool("strip_cavities");
    pp.correct = ctx.getBool("correct_volumes");
    const bool improveOn = ctx.getBool("improve");
    const ImproveParams ip = improveParamsFrom(ctx, "improve_");
    pp.correction.min_angle = ip.min_angle; // the improvement's bounds, whether it runs or not
    pp.correction.max_angle = ip.max_angle;
    CleavePipelineResult res = cleavePipeline(bg, *mats, pp, ctx.progress());
    CleaveResult& r = res.cleaved;
    // Label-preserving improvement of the final labels: the worst tets up to the angle targets.
    ImproveStats improved;
    int64_t finished = 0;
    if (improveOn) {
      // The face neighbours the pipeline left follow the improvement to the label finish.
      improved = improveMesh(r.mesh, ip, ctx.progress(), repairOn ? &res.faceNeighbours : nullptr);
      if (repairOn) finished = finishLabels(r.mesh, *mats, res, ctx.progress());
      const std::vector<MaterialTally> now = tallyMaterials(r.mesh, mats->labels());
      for (size_t i = 0; i < r.materials.size(); ++i) {
        r.materials[i].tets = now[i].tets;
        r.materials[i].meshVolume = now[i].volume;
      }
    }
    writeCleavePipelineReport(res, pp, mats->labels(), ctx.report());
    if (improveOn && repairOn) ctx.report().set("repair_fragments_after_improvement", ReportValue(finished));
    if (improveOn) {
      writeImproveReport(improved, ip, ctx.report());
      logUnfixed(ctx, improved, ip);
    }
    ctx.report().set("background", bg.kind.empty() ? "unstructured" : "bcc_lattice");
    for (const auto& m : r.materials)
      if (m.lost()) {
        std::ostringstream msg;
        msg << "material " << m.label << " (" << m.inputVolume
            << " mm^3 in the input) is too small for this lattice and was lost; use a smaller "
               "cell_size to keep it";
        ctx.log(msg.str());
      }
    carryLabelNames(ctx.input(0), r.mesh);
    ctx.setOutput(0, makeData<TetMeshData>(std::move(r.mesh)));
  }
};
} // namespace

void registerCleaveMesh(ModuleRegistry& r) {
  const CleaveParams d;
  ModuleInfo m;
  m.name = "CleaveMesh";
  m.category = "Meshing";
  m.description = "Lattice cleaving: cuts the background mesh along the material interfaces "
                  "(snapping and warping to keep dihedral angles bounded) and outputs a "
                  "conforming multimaterial tet mesh with the material label per tet.";
  m.inputs = {{"volume", {PortType::LabelVolume, PortType::Materials}, "labels or indicator functions"},
              {"background", {PortType::TetMesh}, "background mesh (GenerateBackgroundMesh)"}};
  m.outputs = {{"mesh", {PortType::TetMesh}, "the cleaved mesh"}};
  const auto dbl = doubleParam;

  ParamSpec strip;
  strip.name = "strip_exterior";
  strip.type = ParamType::String;
  strip.defaultValue = std::string("none");
  strip.description = "material label whose exterior is removed after meshing (its voxels connected to the box: "
                      "e.g. 0 for the air around a head; its cavities stay unless strip_cavities), or none";
  ParamSpec interfacePoints = makeParam("interface_points", ParamType::Enum, std::string("auto"), "",
                                        "where interface points go on an edge: exact = where the materials' "
                                        "functions cross (a one-voxel layer keeps its thickness), linear = where "
                                        "the linear interpolation of the end samples crosses (the seed, Cleaver), "
                                        "auto = exact on BCC lattices, linear on unstructured backgrounds");
  interfacePoints.choices = {"auto", "exact", "linear"};
  ParamSpec volumeCalibration = makeParam(
      "volume_calibration", ParamType::Int, int64_t(0), "rounds",
      "per-material offsets on the indicator functions so that each material's volume matches its "
      "voxels (0 = off; each round costs one more cleave and repair)");
  volumeCalibration.min = 0.0;
  volumeCalibration.max = 10.0;
  m.params = {dbl("alpha_short", d.alpha_short, 0.0, 0.49, "", "violation threshold on short BCC edges, fraction of edge length (0 = no warping)"),
              dbl("alpha_long", d.alpha_long, 0.0, 0.49, "", "violation threshold on long BCC edges, fraction of edge length"),
              dbl("xi", d.xi, 1e-6, 0.5, "", "unstructured backgrounds: alpha = (1/2 - xi) x shortest altitude (seed §5.5.2)"),
              dbl("blend_sigma", kDefaultBlendSigma, 0.05, 10.0, "voxels", "smoothing of label volumes into indicator functions (0.3 keeps one-voxel layers one voxel thick; larger values smooth more and thin them)"),
              strip,
              makeParam("strip_cavities", ParamType::Bool, false, "",
                        "strip_exterior removes the label's cavities too (air in sinuses, enclosed "
                        "background): everything of the label"),
              interfacePoints,
              makeParam("repair_labels", ParamType::Bool, true, "",
                        "after cleaving, relabel tets (geometry unchanged) so that labels that never touch "
                        "in the input do not share faces, and drop fragments: pieces smaller than "
                        "fragment_voxels that are not the main piece of an image component"),
              dbl("fragment_voxels", 1.0, 0.0, 1e6, "voxel volumes",
                  "largest fragment the label repair may relabel"),
              makeParam("repair_point_contacts", ParamType::Bool, true, "",
                        "label repair also where labels that never touch meet at a vertex or edge "
                        "(thin layers pinched to nothing): no such contact left; the layer becomes a "
                        "whole tet thick there, which the volume correction gives back"),
              volumeCalibration,
              makeParam("correct_volumes", ParamType::Bool, true, "",
                        "after the label repair, move the vertices on material interfaces along the "
                        "interfaces' normals (a fraction of a millimetre, no dihedral angle taken outside "
                        "the improvement's bounds) so that every material's volume equals its voxels'"),
              makeParam("improve", ParamType::Bool, true, "",
                        "after cleaving (and the label repair), label-preserving mesh improvement "
                        "toward every dihedral angle in [improve_min_angle, improve_max_angle] "
                        "(the ImproveMesh module's operations)")};
  for (ParamSpec& s : improveParamSpecs("improve_")) m.params.push_back(std::move(s));
  m.summaryKeys = {"tets", "materials_lost"};
  m.factory = [] { return std::make_unique<CleaveMesh>(); };
  r.add(std::move(m));
}

} // namespace tetflow
