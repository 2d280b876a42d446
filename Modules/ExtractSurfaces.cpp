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
#include "Algorithms/Surfaces/BemRepair.h"
#include "Algorithms/Surfaces/BemSurfaces.h"
#include "Algorithms/Surfaces/SurfaceSimplify.h"
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
    if (ext != ".off" && ext != ".stl" && ext != ".vtp" && ext != ".surf")
      throw InputError("filename: '" + path + "' must end in .off, .stl, .vtp or .surf");
    const std::vector<SurfaceSpec> specs = parseSurfaces(ctx.getList("surfaces"), mesh);
    const bool require = ctx.getBool("require_closed");
    Report& rep = ctx.report();

    ctx.progress().beginStage("faces");
    const std::vector<int32_t> nb = tetFaceNeighbours(mesh, ctx.progress());
    ctx.progress().endStage();
    const bool repair = ctx.getBool("repair");
    const double maxMoved = ctx.getDouble("max_volume_change");
    const int smoothing = int(ctx.getInt("smoothing_iterations"));
    const int64_t target = ctx.getInt("target_triangles");
    VertexStars stars;
    if (repair) {
      ctx.progress().beginStage("stars");
      stars = vertexStars(mesh);
      ctx.progress().endStage();
    }
    ctx.progress().beginStage(repair ? "repair" : "surfaces");
    std::vector<TriSurface> surfaces;
    std::vector<std::vector<uint8_t>> unions;
    std::vector<double> unionVolumes;
    // Listed outer to inner: a surface whose materials the previous one holds must stay inside it.
    auto inPrevious = [&](size_t i) {
      return i > 0 && std::includes(specs[i - 1].labels.begin(), specs[i - 1].labels.end(), specs[i].labels.begin(),
                                    specs[i].labels.end());
    };
    for (size_t i = 0; i < specs.size(); ++i) {
      const SurfaceSpec& spec = specs[i];
      std::vector<uint8_t> inside = materialMask(mesh, spec.labels);
      double unionVolume = 0;
      for (size_t t = 0; t < mesh.numTets(); ++t)
        if (inside[t]) unionVolume += mesh.tetVolume(t);
      const std::string k = "surface_" + spec.name + "_";
      TriSurface s;
      if (repair) {
        UnionRepair fix = repairUnion(mesh, nb, stars, inside, inPrevious(i) ? &unions[i - 1] : nullptr,
                                      inPrevious(i) ? &surfaces[i - 1] : nullptr);
        rep.set(k + "repair_rounds", ReportValue(int64_t(fix.rounds)));
        rep.set(k + "repair_pinches", ReportValue(fix.pinchesMended));
        rep.set(k + "repair_touches", ReportValue(fix.touchesMended));
        rep.set(k + "repair_tets_added", ReportValue(fix.tetsAdded));
        rep.set(k + "repair_tets_removed", ReportValue(fix.tetsRemoved));
        rep.set(k + "repair_added_mm3", ReportValue(fix.volumeAdded));
        rep.set(k + "repair_removed_mm3", ReportValue(fix.volumeRemoved));
        s = std::move(fix.surface);
        const double moved = unionVolume > 0 ? (fix.volumeAdded + fix.volumeRemoved) / unionVolume : 0.0;
        rep.set(k + "repair_moved_fraction", ReportValue(moved));
        if (moved > maxMoved) {
          std::ostringstream msg;
          msg << "max_volume_change: the repair of surface '" << spec.name << "' moved "
              << fix.volumeAdded + fix.volumeRemoved << " mm^3 (" << 100 * moved << " % of its tissues' "
              << unionVolume << " mm^3; the limit is " << 100 * maxMoved
              << " %): the mesh is coarse for its thin layers. Mesh with a smaller cell size, or raise max_volume_change";
          throw InputError(msg.str());
        }
      } else {
        s = maskBoundary(mesh, inside, nb);
      }
      surfaces.push_back(std::move(s));
      unions.push_back(std::move(inside));
      unionVolumes.push_back(unionVolume);
      ctx.progress().checkCancel();
    }
    ctx.progress().endStage();
    // Smoothing, then decimation, outer to inner, each surface against all the others as they are.
    for (const bool decimate : {false, true}) {
      if (decimate ? target <= 0 : smoothing <= 0) continue;
      ctx.progress().beginStage(decimate ? "decimate" : "smooth");
      for (size_t i = 0; i < specs.size(); ++i) {
        std::vector<const TriSurface*> others;
        for (size_t j = 0; j < surfaces.size(); ++j)
          if (j != i) others.push_back(&surfaces[j]);
        const SurfaceEditStats st = decimate ? decimateSurface(surfaces[i], others, target, ctx.progress())
                                             : smoothSurface(surfaces[i], others, smoothing, ctx.progress());
        const std::string k = "surface_" + specs[i].name + (decimate ? "_decimation_" : "_smoothing_");
        rep.set(k + (decimate ? "collapses" : "moves"), ReportValue(decimate ? st.collapses : st.moves));
        if (decimate) rep.set(k + "refused_topology", ReportValue(st.refusedTopology));
        rep.set(k + "refused_shape", ReportValue(st.refusedShape));
        rep.set(k + "refused_crossing", ReportValue(st.refusedCrossing));
      }
      ctx.progress().endStage();
    }
    ctx.progress().beginStage("check");
    std::vector<std::string> problems;
    for (size_t i = 0; i < specs.size(); ++i) {
      const SurfaceSpec& spec = specs[i];
      const TriSurface& s = surfaces[i];
      const double unionVolume = unionVolumes[i];
      const SurfaceCheck c = checkSurface(s);
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
      const int64_t self = selfIntersections(s);
      rep.set(k + "self_intersections", ReportValue(self));
      if (!c.closedManifoldOriented())
        problems.push_back("surface '" + spec.name + "': " + std::to_string(c.openEdges) + " open edge(s), " +
                           std::to_string(c.nonManifoldEdges) + " non-manifold edge(s), " +
                           std::to_string(c.nonManifoldVertices) + " non-manifold vertex(es), " +
                           std::to_string(c.misorientedEdges) + " misoriented edge(s)");
      if (self > 0)
        problems.push_back("surface '" + spec.name + "' crosses itself (" + std::to_string(self) + " triangle pairs)");
      ctx.progress().checkCancel();
    }
    // Nesting, listed outer to inner: each set holds the next, and the surfaces should neither
    // touch (share a vertex) nor cross.
    for (size_t i = 0; i + 1 < specs.size(); ++i) {
      const bool nested = inPrevious(i + 1);
      const std::string k = "surface_" + specs[i].name + "_";
      rep.set(k + "holds_next", ReportValue(nested));
      const int64_t shared = sharedVertices(surfaces[i], surfaces[i + 1]);
      rep.set(k + "shared_vertices_with_next", ReportValue(shared));
      if (nested && shared > 0)
        problems.push_back("surfaces '" + specs[i].name + "' and '" + specs[i + 1].name + "' touch at " +
                           std::to_string(shared) + " vertex(es)");
      const int64_t crossings = crossingPairs(surfaces[i], surfaces[i + 1]);
      rep.set(k + "crossings_with_next", ReportValue(crossings));
      if (nested && crossings > 0)
        problems.push_back("surfaces '" + specs[i].name + "' and '" + specs[i + 1].name + "' cross (" +
                           std::to_string(crossings) + " triangle pairs)");
    }
    ctx.progress().endStage();
    if (require && !problems.empty()) {
      std::string all;
      for (const auto& p : problems) {
        if (!all.empty()) all += "; ";
        all += p;
      }
      throw InputError("require_closed: " + all + " (nothing written; a BEM solver needs closed, manifold, oriented "
                       "surfaces that neither touch nor cross: " +
                       (repair ? std::string("the repair ran out of rounds") : std::string("set repair = true to mend them")) + ")");
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
                  "solvers (.off for OpenMEEG, .surf (FreeSurfer) for MNE, .stl, .vtp), oriented outward, checked closed, manifold and oriented, "
                  "their enclosed volumes against the materials' and their nesting reported. With repair (the default), "
                  "pinches of thin layers are mended by moving the few tets around each pinch vertex into or out of "
                  "the surface's union, so the surfaces are manifold and nested without touching. Optional smoothing and "
                  "decimation keep them closed, manifold and uncrossed; crossings are checked geometrically. One file per surface: "
                  "FILENAME_NAME.EXT.";
  m.inputs = {{"mesh", {PortType::TetMesh}, "tetrahedral mesh with material labels"}};
  ParamSpec surfaces = makeParam("surfaces", ParamType::List, std::vector<std::string>{}, "",
                                 "name: labels entries separated by ';', outer to inner (labels as numbers or "
                                 "tissue names, joined by spaces or +), e.g. scalp: 1 2 3 4; outer_skull: 2 3 4; "
                                 "inner_skull: 3 4; empty = one surface 'outer' of every material");
  ParamSpec file = makeParam("filename", ParamType::String, std::string(), "",
                             "output name and format (.off, .stl, .vtp, .surf); each surface goes to FILENAME_NAME.EXT");
  file.isOutputPath = true;
  ParamSpec require = makeParam("require_closed", ParamType::Bool, true, "",
                                "fail (and write nothing) when a surface is not closed, manifold and oriented, crosses itself, "
                                "or touches or crosses the surface before it that holds its materials");
  ParamSpec repair = makeParam("repair", ParamType::Bool, true, "",
                               "make each surface manifold and keep it off the enclosing one by moving the tets "
                               "around each pinch vertex into or out of its union (reported: tets and mm^3 moved)");
  ParamSpec maxMoved = makeParam("max_volume_change", ParamType::Double, 0.01, "",
                                 "largest volume the repair may move into and out of a surface's union, as a fraction "
                                 "of its tissues' volume; more stops the module (the mesh is too coarse for its layers)");
  maxMoved.min = 0.0;
  maxMoved.max = 1.0;
  ParamSpec smoothing = makeParam("smoothing_iterations", ParamType::Int, int64_t(0), "",
                                  "Taubin smoothing steps (lambda 0.5, mu -0.53) of the staircase; a vertex moves only "
                                  "if its surface then crosses neither itself nor the other surfaces (0 = none)");
  smoothing.min = 0.0;
  smoothing.max = 10000.0;
  ParamSpec targetTris = makeParam("target_triangles", ParamType::Int, int64_t(0), "",
                                   "decimate each surface to at most this many triangles by quadric-error edge "
                                   "collapses that keep it closed, manifold and off the other surfaces (0 = keep all; "
                                   "MNE's standard is 5120)");
  targetTris.min = 0.0;
  targetTris.max = 1e9;
  m.params = {surfaces, file, require, repair, maxMoved, smoothing, targetTris};
  m.summaryKeys = {"surfaces", "files"};
  m.factory = [] { return std::make_unique<ExtractSurfaces>(); };
  r.add(std::move(m));
}

} // namespace tetflow
