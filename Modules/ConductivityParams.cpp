// The conductivity parameters shared by AssembleFEMPoisson and ComputeLeadField
// (StandardModules.h): by label or by tissue name, completed from the mesh's label table and the
// literature (Algorithms/FEM/TissueConductivity.h).
#include <cstdio>

#include "Algorithms/FEM/TissueConductivity.h"
#include "StandardModules.h"

namespace tetflow {

std::vector<ParamSpec> conductivityParamSpecs() {
  ParamSpec cond = makeParam("conductivities", ParamType::List, std::vector<std::string>{}, "S/m",
                             "label:sigma entries separated by ';' (e.g. 1:0.33; 2:0.0042), the label "
                             "a number or the tissue's name (CSF:1.79); an anisotropic tensor as "
                             "label:xx yy zz xy yz xz");
  ParamSpec def = makeParam("default_conductivity", ParamType::Double, 1.0, "S/m",
                            "conductivity of labels not listed in conductivities and not known "
                            "otherwise (> 0)");
  ParamSpec byName = makeParam("conductivity_by_name", ParamType::Bool, true, "",
                               "labels not listed in conductivities and without a conductivity from "
                               "their label table take the literature value of their tissue name "
                               "(SimNIBS's table: white/grey matter, CSF, bone, scalp, eyes, blood, "
                               "muscle, air; docs/file-formats.md, Tissues by name)");
  return {cond, def, byName};
}

ConductivityTable conductivitiesFrom(const ExecutionContext& ctx, const TetMesh& mesh, Report& report) {
  ConductivityTable table = parseConductivities(
      conductivityItemsByLabel(ctx.getList("conductivities"), mesh.materialNames), ctx.getDouble("default_conductivity"));
  const auto sources = completeConductivities(table, mesh, ctx.getBool("conductivity_by_name"));
  for (const auto& [L, source] : sources) {
    const std::string pre = "material_" + std::to_string(L) + "_";
    if (auto n = mesh.materialNames.find(L); n != mesh.materialNames.end()) report.set(pre + "name", n->second);
    const SymTensor6 s = table.tensor(L);
    if (table.isotropic(L)) {
      report.set(pre + "conductivity", s[0]);
    } else {
      char buf[160];
      std::snprintf(buf, sizeof buf, "%g %g %g %g %g %g", s[0], s[1], s[2], s[3], s[4], s[5]);
      report.set(pre + "conductivity", std::string(buf));
    }
    report.set(pre + "conductivity_source", source);
  }
  return table;
}

} // namespace tetflow
