// ExtractSurfaces: the closed surfaces of unions of materials (scalp, outer skull, inner skull,
// ...) for BEM solvers, checked and written as .off, .stl or .vtp (Algorithms/Surfaces).
#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <sstream>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/IO/FileUtil.h"
#include "Algorithms/IO/HeaderText.h"
#include "Algorithms/IO/SurfaceIO.h"
#include "Algorithms/Quality/LabelTopology.h"
#include "Algorithms/Surfaces/BemSurfaces.h"
#include "StandardModules.h"

namespace tetflow {

namespace {

std::string trimmed(const std::string& s) { return std::string(headertext::trim(s)); }

struct SurfaceSpec {
  std::string name;
  std::vector<int32_t> labels;
};

// "name: 1 2 3" or "name: scalp+skull" entries; empty: one surface "outer" of every material.
std::vector<SurfaceSpec> parseSurfaces(const std::vector<std::string>& items, const TetMesh& mesh) {
  const std::vector<int32_t> present = presentMaterials(mesh);
  auto occurs = [&](int32_t L) { return std::binary_search(present.begin(), present.end(), L); };
  std::vector<SurfaceSpec> out;
  for (const std::string& raw : items) {
    const std::string item = trimmed(raw);
    if (item.empty()) continue;
    const size_t colon = item.find(':');
    if (colon == std::string::npos || trimmed(item.substr(0, colon)).empty())
      throw InputError("surfaces: entry '" + item + "': expected 'name: labels' (e.g. inner_skull: 3 4, or brain: CSF+brain)");
    SurfaceSpec s;
    s.name = trimmed(item.substr(0, colon));
    for (char& c : s.name)
      if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_') c = '_';
    std::string rest = item.substr(colon + 1);
    for (char& c : rest)
      if (c == '+' || c == ',') c = ' ';
    std::istringstream in(rest);
    for (std::string tok; in >> tok;) {
      int64_t v = 0;
      auto r = std::from_chars(tok.data(), tok.data() + tok.size(), v);
      if (r.ec == std::errc() && r.ptr == tok.data() + tok.size()) {
        if (!occurs(int32_t(v)))
          throw InputError("surfaces: entry '" + item + "': label " + tok + " does not occur in the mesh");
        s.labels.push_back(int32_t(v));
        continue;
      }
      bool found = false;
      for (int32_t L : labelsNamed(mesh.materialNames, tok))
        if (occurs(L)) {
          s.labels.push_back(L);
          found = true;
        }
      if (!found)
        throw InputError("surfaces: entry '" + item + "': '" + tok + "' is neither a label of the mesh nor one of its tissue names");
    }
    if (s.labels.empty()) throw InputError("surfaces: entry '" + item + "' names no material");
    std::sort(s.labels.begin(), s.labels.end());
    s.labels.erase(std::unique(s.labels.begin(), s.labels.end()), s.labels.end());
    for (const SurfaceSpec& o : out)
      if (o.name == s.name) throw InputError("surfaces: the name '" + s.name + "' is given twice");
    out.push_back(std::move(s));
  }
  if (out.empty()) out.push_back({"outer", present});
  return out;
}

class ExtractSurfaces : public Module {
public:
  void execute(ExecutionContext& ctx) override {
    const TetMesh& mesh = ctx.inputAs<TetMeshData>(0).value;
    const std::string path = ctx.getPath("filename");
    const std::string ext = fileExtension(path);
    if (ext != ".off" && ext != ".stl" && ext != ".vtp")
      throw InputError("filename: '" + path + "' must end in .off, .stl or .vtp");
    const std::vector<SurfaceSpec> specs = parseSurfaces(ctx.getList("surfaces"), mesh);
    const bool require = ctx.getBool("require_closed");
    Report& rep = ctx.report();

    ctx.progress().beginStage("faces");
    const std::vector<int32_t> nb = tetFaceNeighbours(mesh, ctx.progress());
    ctx.progress().endStage();
    ctx.progress().beginStage("surfaces");
    std::vector<TriSurface> surfaces;
    std::vector<std::string> problems;
    for (const SurfaceSpec& spec : specs) {
      TriSurface s = unionBoundary(mesh, spec.labels, nb);
      const SurfaceCheck c = checkSurface(s);
      double unionVolume = 0;
      for (size_t t = 0; t < mesh.numTets(); ++t)
        if (std::binary_search(spec.labels.begin(), spec.labels.end(), mesh.materials[t])) unionVolume += mesh.tetVolume(t);
      const std::string k = "surface_" + spec.name + "_";
      std::string labels;
      for (int32_t L : spec.labels) {
        if (!labels.empty()) labels += ' ';
        labels += std::to_string(L);
      }
      rep.set(k + "labels", labels);
      rep.set(k + "triangles", ReportValue(c.triangles));
      rep.set(k + "vertices", ReportValue(c.vertices));
      rep.set(k + "closed_manifold_oriented", ReportValue(c.closedManifoldOriented()));
      rep.set(k + "open_edges", ReportValue(c.openEdges));
      rep.set(k + "nonmanifold_edges", ReportValue(c.nonManifoldEdges));
      rep.set(k + "nonmanifold_vertices", ReportValue(c.nonManifoldVertices));
      rep.set(k + "misoriented_edges", ReportValue(c.misorientedEdges));
      rep.set(k + "components", ReportValue(int64_t(c.components)));
      rep.set(k + "area_mm2", ReportValue(c.area));
      rep.set(k + "enclosed_mm3", ReportValue(c.enclosedVolume));
      rep.set(k + "materials_mm3", ReportValue(unionVolume));
      rep.set(k + "volume_rel_difference",
              ReportValue(unionVolume > 0 ? (c.enclosedVolume - unionVolume) / unionVolume : 0.0));
      if (!c.closedManifoldOriented())
        problems.push_back("surface '" + spec.name + "': " + std::to_string(c.openEdges) + " open edge(s), " +
                           std::to_string(c.nonManifoldEdges) + " non-manifold edge(s), " +
                           std::to_string(c.nonManifoldVertices) + " non-manifold vertex(es), " +
                           std::to_string(c.misorientedEdges) + " misoriented edge(s)");
      surfaces.push_back(std::move(s));
      ctx.progress().checkCancel();
    }
    // Nesting, listed outer to inner: each set holds the next, and the surfaces should not touch.
    for (size_t i = 0; i + 1 < specs.size(); ++i) {
      const bool nested = std::includes(specs[i].labels.begin(), specs[i].labels.end(), specs[i + 1].labels.begin(),
                                        specs[i + 1].labels.end());
      const std::string k = "surface_" + specs[i].name + "_";
      rep.set(k + "holds_next", ReportValue(nested));
      rep.set(k + "shared_vertices_with_next", ReportValue(sharedVertices(surfaces[i], surfaces[i + 1])));
    }
    ctx.progress().endStage();
    if (require && !problems.empty()) {
      std::string all;
      for (const auto& p : problems) {
        if (!all.empty()) all += "; ";
        all += p;
      }
      throw InputError("require_closed: " + all + " (nothing written; a BEM solver needs closed, manifold, oriented "
                       "surfaces: a thin layer pinched in the segmentation makes them touch themselves)");
    }
    ctx.progress().beginStage("write");
    const std::string stem = path.substr(0, path.size() - ext.size());
    std::string files;
    for (size_t i = 0; i < specs.size(); ++i) {
      const std::string file = stem + "_" + specs[i].name + ext;
      writeTriangleSurface(file, surfaces[i].points, surfaces[i].triangles);
      rep.set("surface_" + specs[i].name + "_file", file);
      if (!files.empty()) files += ' ';
      files += file;
    }
    ctx.progress().endStage();
    rep.set("surfaces", ReportValue(int64_t(specs.size())));
    rep.set("files", files);
  }
};

} // namespace

void registerExtractSurfaces(ModuleRegistry& r) {
  ModuleInfo m;
  m.name = "ExtractSurfaces";
  m.category = "DataIO";
  m.description = "Writes the closed surface of each union of materials (e.g. scalp: every tissue; outer_skull: the "
                  "skull and what is inside; inner_skull: what is inside the skull) as triangle meshes for BEM "
                  "solvers (.off for OpenMEEG, .stl, .vtp), oriented outward, checked closed, manifold and oriented, "
                  "their enclosed volumes against the materials' and their nesting reported. One file per surface: "
                  "FILENAME_NAME.EXT.";
  m.inputs = {{"mesh", {PortType::TetMesh}, "tetrahedral mesh with material labels"}};
  ParamSpec surfaces = makeParam("surfaces", ParamType::List, std::vector<std::string>{}, "",
                                 "name: labels entries separated by ';', outer to inner (labels as numbers or "
                                 "tissue names, joined by spaces or +), e.g. scalp: 1 2 3 4; outer_skull: 2 3 4; "
                                 "inner_skull: 3 4; empty = one surface 'outer' of every material");
  ParamSpec file = makeParam("filename", ParamType::String, std::string(), "",
                             "output name and format (.off, .stl, .vtp); each surface goes to FILENAME_NAME.EXT");
  file.isOutputPath = true;
  ParamSpec require = makeParam("require_closed", ParamType::Bool, true, "",
                                "fail (and write nothing) when a surface is not closed, manifold and oriented");
  m.params = {surfaces, file, require};
  m.summaryKeys = {"surfaces", "files"};
  m.factory = [] { return std::make_unique<ExtractSurfaces>(); };
  r.add(std::move(m));
}

} // namespace tetflow
