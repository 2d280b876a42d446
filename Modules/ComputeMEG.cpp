// ComputeMEG: the magnetic flux density at MEG sensors of one solved dipole potential
// (Algorithms/FEM/Meg.h): the primary field of the dipole plus Biot-Savart over the tets of the
// FEM current sigma grad u, and optionally the Sarvas closed form for a spherically symmetric
// conductor with RDM and MAG against it.
// Inputs: 0 mesh carrying AssembleFEMPoisson's point field "potential". Outputs: 0 field
// (DenseMatrix, sensors x 3: total, primary, volume-current part, fT), 1 report.
#include <cmath>
#include <iomanip>
#include <sstream>

#include "Algorithms/FEM/Meg.h"
#include "Algorithms/IO/FileUtil.h"
#include "StandardModules.h"

namespace tetflow {

namespace {
class ComputeMEG : public Module {
public:
  void execute(ExecutionContext& ctx) override {
    const TetMesh& mesh = ctx.inputAs<TetMeshData>(0).value;
    if (mesh.pointFields.count("singular_potential"))
      throw InputError("mesh: its potential comes from source_model subtraction (point field singular_potential); "
                       "ComputeMEG's volume currents need partial_integration or venant in AssembleFEMPoisson");
    auto it = mesh.pointFields.find("potential");
    if (it == mesh.pointFields.end() || it->second.components != 1)
      throw InputError("mesh: no point field 'potential'; connect AssembleFEMPoisson's mesh output "
                       "(boundary_condition dipole, the same dipole as here)");
    MegParams p;
    p.conductivities = conductivitiesFrom(ctx, mesh, ctx.report());
    p.sensors = megSensorsFrom(ctx);
    p.dipolePosition = parseVec3(ctx.getString("dipole_position"), "dipole_position");
    p.dipoleMoment = parseVec3(ctx.getString("dipole_moment"), "dipole_moment");
    const MegResult r = computeMeg(mesh, it->second.values, p, ctx.progress());
    const size_t ns = p.sensors.size();

    Report& rep = ctx.report();
    int64_t coils = 0;
    for (const MegSensor& s : p.sensors) coils += int64_t(s.coils.size());
    rep.set("sensors", ReportValue(int64_t(ns)));
    rep.set("coils", ReportValue(coils));
    double bmax = 0, pnorm = 0, vnorm = 0;
    for (size_t i = 0; i < ns; ++i) {
      bmax = std::max(bmax, std::abs(r.total[i]));
      pnorm += r.primary[i] * r.primary[i], vnorm += r.volume[i] * r.volume[i];
    }
    rep.set("b_max_ft", ReportValue(bmax));
    rep.set("volume_to_primary", ReportValue(pnorm > 0 ? std::sqrt(vnorm / pnorm) : 0.0));
    rep.set("coils_inside_mesh", ReportValue(r.coilsInsideMesh));
    std::vector<double> sarvas;
    if (ctx.getBool("compare_sarvas")) {
      const Vec3 center = parseVec3(ctx.getString("sphere_center"), "sphere_center");
      for (const MegSensor& s : p.sensors)
        sarvas.push_back(sensorSignal(s, [&](const Vec3& x) { return sarvasField(x, p.dipolePosition, p.dipoleMoment, center); }));
      double snorm = 0;
      for (double v : sarvas) snorm += v * v;
      if (snorm > 0) {
        const MegErrors e = compareMeg(r.total, sarvas);
        rep.set("rdm", ReportValue(e.rdm));
        rep.set("mag", ReportValue(e.mag));
        rep.set("ln_mag", ReportValue(e.lnMag));
        std::ostringstream m;
        m << "FEM vs Sarvas at " << ns << " sensors: RDM " << e.rdm << ", MAG " << e.mag;
        ctx.log(m.str());
      } else {
        ctx.log("the Sarvas field is zero at every sensor (a radial dipole, or one at the centre): no RDM/MAG");
      }
    }
    rep.set("seconds", ReportValue(r.seconds));
    for (const auto& n : r.notes) ctx.log(n);
    if (!ctx.getString("filename").empty()) {
      const std::string path = ctx.getPath("filename");
      if (fileExtension(path) != ".csv")
        throw InputError("filename " + path + ": the MEG signals are written as .csv");
      AtomicOutputFile out(path, false);
      auto& s = out.stream();
      s << "sensor,total_fT,primary_fT,volume_fT" << (sarvas.empty() ? "" : ",sarvas_fT") << "\n" << std::setprecision(17);
      for (size_t i = 0; i < ns; ++i) {
        s << p.sensors[i].name << ',' << r.total[i] << ',' << r.primary[i] << ',' << r.volume[i];
        if (!sarvas.empty()) s << ',' << sarvas[i];
        s << "\n";
      }
      out.commit();
      rep.set("file", path);
    }
    auto mat = std::make_shared<Eigen::MatrixXd>(Eigen::Index(ns), 3);
    for (size_t i = 0; i < ns; ++i) {
      (*mat)(Eigen::Index(i), 0) = r.total[i];
      (*mat)(Eigen::Index(i), 1) = r.primary[i];
      (*mat)(Eigen::Index(i), 2) = r.volume[i];
    }
    ctx.setOutput(0, makeData<DenseMatrixData>(std::shared_ptr<const Eigen::MatrixXd>(std::move(mat))));
    ctx.setOutput(1, makeData<ReportData>(Report(rep)));
  }
};
} // namespace

void registerComputeMEG(ModuleRegistry& r) {
  ModuleInfo m;
  m.name = "ComputeMEG";
  m.category = "FEM";
  m.description =
      "MEG of one FEM dipole solution: the magnetic flux density (fT) at sensors read from a file "
      "(magnetometers, or gradiometers as several coils with weights), the dipole's primary field "
      "plus the field of the volume currents sigma grad u by Biot-Savart over the tets, integrated "
      "exactly on each tet. Connect AssembleFEMPoisson's mesh (boundary_condition dipole) and give "
      "the same dipole and conductivities. Optionally compares with the Sarvas formula of a "
      "spherically symmetric conductor (RDM, MAG).";
  m.inputs = {{"mesh", {PortType::TetMesh}, "the mesh with point field potential (V) of a dipole solve"}};
  m.outputs = {{"field", {PortType::DenseMatrix}, "sensors x 3: total, primary and volume-current signal (fT)"},
               {"report", {PortType::Report}, "MEG figures (same as the module report)"}};
  const std::vector<ParamSpec> cp = conductivityParamSpecs();
  const std::vector<ParamSpec> ms = megSensorParamSpecs(); // sensors_file, sensor_unit_scale
  ParamSpec dpos = makeParam("dipole_position", ParamType::String, std::string("0 0 40"), "mm",
                             "the dipole of the FEM solve: position \"x y z\"");
  ParamSpec dmom = makeParam("dipole_moment", ParamType::String, std::string("0.01 0 0"), "mA mm",
                             "the dipole of the FEM solve: moment \"x y z\" (0.01 mA mm = 10 nA m)");
  ParamSpec cmp = makeParam("compare_sarvas", ParamType::Bool, true, "",
                            "also compute the Sarvas field of a spherically symmetric conductor and "
                            "report RDM and MAG of the FEM field against it");
  ParamSpec ctr = makeParam("sphere_center", ParamType::String, std::string("0 0 0"), "mm",
                            "compare_sarvas: centre of the spheres");
  ParamSpec out = makeParam("filename", ParamType::String, std::string(), "",
                            "optional .csv: sensor, total, primary, volume (and sarvas) in fT");
  out.isOutputPath = true;
  m.params = {cp[0], cp[1], ms[0], ms[1], dpos, dmom, cmp, ctr, out, cp[2]};
  m.summaryKeys = {"sensors", "b_max_ft", "rdm", "mag"};
  m.factory = [] { return std::make_unique<ComputeMEG>(); };
  r.add(std::move(m));
}

} // namespace tetflow
