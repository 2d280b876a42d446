// AnalyticSphereEEG: the analytic potential of a current dipole in concentric spheres
// (Algorithms/FEM/AnalyticSphere.h) at the surface vertices of a mesh, and, when the mesh carries
// AssembleFEMPoisson's point field "potential", the standard errors of that FEM solution against
// it (RDM, MAG, lnMAG; both average-referenced over the electrodes).
// Inputs: 0 mesh. Outputs: 0 the mesh with point field "analytic_potential" (V; 0 away from the
// electrodes), 1 report.
#include <cmath>
#include <sstream>

#include "Algorithms/FEM/AnalyticSphere.h"
#include "Algorithms/FEM/Assembly.h"
#include "Algorithms/FEM/Conductivity.h"
#include "Algorithms/IO/ElectrodeIO.h"
#include "StandardModules.h"

namespace tetflow {

namespace {
class AnalyticSphereEEG : public Module {
public:
  void execute(ExecutionContext& ctx) override {
    const TetMesh& in = ctx.inputAs<TetMeshData>(0).value;
    in.validateStructure("mesh");
    SphereShells shells;
    shells.radii = parseNumbers(ctx.getString("radii"), "radii");
    shells.conductivities = parseNumbers(ctx.getString("sphere_conductivities"), "sphere_conductivities");
    const Vec3 center = parseVec3(ctx.getString("center"), "center");
    const Vec3 pos = parseVec3(ctx.getString("dipole_position"), "dipole_position") - center;
    const Vec3 mom = parseVec3(ctx.getString("dipole_moment"), "dipole_moment");

    // Electrodes: every boundary vertex, or the file's positions snapped to the nearest one.
    std::vector<int32_t> electrodes;
    if (ctx.getString("electrodes_file").empty()) {
      const std::vector<uint8_t> onBoundary = boundaryVertexFlags(in);
      for (size_t v = 0; v < onBoundary.size(); ++v)
        if (onBoundary[v]) electrodes.push_back(int32_t(v));
      if (electrodes.empty()) throw InputError("mesh: no boundary vertices (no tets?)");
    } else {
      std::vector<Vec3> given;
      for (const Electrode& e : readElectrodes(ctx.getPath("electrodes_file"), 0.0)) given.push_back(e.position);
      for (const SurfaceSnap& s : snapToBoundary(in, given)) electrodes.push_back(s.vertex);
    }
    std::vector<Vec3> where;
    for (int32_t v : electrodes) where.push_back(in.points[size_t(v)] - center);
    int terms = 0;
    const std::vector<double> analytic = sphereDipolePotentials(shells, pos, mom, where, 10000, 1e-12, &terms);
    TetMesh out = in;
    std::vector<double> field(in.numPoints(), 0.0);
    for (size_t i = 0; i < electrodes.size(); ++i) field[size_t(electrodes[i])] = analytic[i];
    out.pointFields["analytic_potential"] = Field{1, field};

    Report& rep = ctx.report();
    rep.set("electrodes", ReportValue(int64_t(electrodes.size())));
    rep.set("series_terms", ReportValue(int64_t(terms)));
    double rmin = INFINITY, rmax = 0;
    for (const Vec3& p : where) rmin = std::min(rmin, norm(p)), rmax = std::max(rmax, norm(p));
    rep.set("electrode_radius_min", ReportValue(rmin));
    rep.set("electrode_radius_max", ReportValue(rmax));
    auto it = in.pointFields.find("potential");
    if (it != in.pointFields.end() && it->second.components == 1) {
      std::vector<double> fem;
      for (int32_t v : electrodes) fem.push_back(it->second.values[size_t(v)]);
      const ForwardErrors e = compareToAnalytic(fem, analytic);
      rep.set("rdm", ReportValue(e.rdm));
      rep.set("mag", ReportValue(e.mag));
      rep.set("ln_mag", ReportValue(e.lnMag));
      std::ostringstream m;
      m << "FEM vs analytic at " << electrodes.size() << " electrodes: RDM " << e.rdm << ", MAG " << e.mag;
      ctx.log(m.str());
    } else {
      ctx.log("the mesh has no point field 'potential' (connect AssembleFEMPoisson with a dipole): "
              "analytic potentials only, no RDM/MAG");
    }
    ctx.setOutput(0, makeData<TetMeshData>(std::move(out)));
    ctx.setOutput(1, makeData<ReportData>(Report(rep)));
  }
};
} // namespace

void registerAnalyticSphereEEG(ModuleRegistry& r) {
  ModuleInfo m;
  m.name = "AnalyticSphereEEG";
  m.category = "FEM";
  m.description =
      "Analytic EEG potential of a current dipole in concentric spheres (Legendre series, de Munck "
      "& Peters 1993) at the surface vertices of a mesh (or at the electrodes of a file, snapped "
      "to them); with the point field potential of AssembleFEMPoisson (boundary_condition dipole, "
      "same dipole) it reports RDM, MAG and lnMAG of the FEM solution, both average-referenced.";
  m.inputs = {{"mesh", {PortType::TetMesh}, "mesh of the spheres, optionally with point field potential"}};
  m.outputs = {{"mesh", {PortType::TetMesh}, "the mesh with point field analytic_potential (V)"},
               {"report", {PortType::Report}, "rdm, mag, ln_mag, electrodes"}};
  ParamSpec radii = makeParam("radii", ParamType::String, std::string("78 80 86 92"), "mm",
                              "sphere radii, innermost first (head phantom: brain, CSF, skull, scalp)");
  ParamSpec sig = makeParam("sphere_conductivities", ParamType::String, std::string("0.33 1.79 0.0042 0.33"), "S/m",
                            "one conductivity per shell, innermost first");
  ParamSpec center = makeParam("center", ParamType::String, std::string("0 0 0"), "mm", "centre of the spheres");
  ParamSpec dpos = makeParam("dipole_position", ParamType::String, std::string("0 0 40"), "mm",
                             "dipole position \"x y z\" (inside the innermost sphere)");
  ParamSpec dmom = makeParam("dipole_moment", ParamType::String, std::string("0 0 0.01"), "mA mm",
                             "dipole moment \"x y z\"");
  ParamSpec ef = makeParam("electrodes_file", ParamType::String, std::string(), "",
                           "electrodes (.csv/.tsv/.txt, .elc, .sfp) snapped to the nearest surface "
                           "vertex; empty = every surface vertex");
  ef.isInputPath = true;
  m.params = {radii, sig, center, dpos, dmom, ef};
  m.summaryKeys = {"electrodes", "rdm", "mag"};
  m.factory = [] { return std::make_unique<AnalyticSphereEEG>(); };
  r.add(std::move(m));
}

} // namespace tetflow
