#include "Cleaver.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "Algorithms/Cleaving/CleaverStages.h"
#include "Algorithms/Core/Errors.h"

namespace tetflow {

namespace cleaving_detail {

CleaveResult Cleaver::run() {
  if (m_.tets.empty()) throw InputError("cleaving: the background mesh has no tets");
  for (double a : {p_.alpha_short, p_.alpha_long})
    if (!(a >= 0.0 && a < 0.5)) throw InputError("alpha_short and alpha_long must be in [0, 0.5)");
  if (!(p_.xi > 0.0 && p_.xi <= 0.5)) throw InputError("xi must be in (0, 0.5]");
  stats_.backgroundTets = static_cast<int64_t>(m_.tets.size());
  computeBoxConstraints();
  sample();
  cullExterior();
  buildInterfaces();
  buildWarpStars();
  computeVertexAlphas();
  phaseVertices();
  phaseEdges();
  phaseFaces();
  generalize();
  closure();
  CleaveResult r = stencil();
  joinAroundCulled(r);
  releaseInterfaces();
  if (p_.optimize_angles) optimizeAngles(r.mesh);
  progress_.beginStage("finish");
  TetMesh& out = r.mesh;
  // Per-material outcome, then strip_exterior, then drop unused vertices.
  const auto& labels = mats_.labels();
  r.materials.resize(labels.size());
  for (size_t i = 0; i < labels.size(); ++i) {
    r.materials[i].label = labels[i];
    r.materials[i].inputVolume = mats_.inputVolumes()[i];
  }
  const std::vector<MaterialTally> tally = tallyMaterials(out, labels);
  for (size_t i = 0; i < labels.size(); ++i) {
    r.materials[i].tets = tally[i].tets;
    r.materials[i].meshVolume = tally[i].volume;
  }
  if (p_.strip_exterior) {
    size_t w = 0;
    for (size_t t = 0; t < out.tets.size(); ++t)
      if (out.materials[t] != *p_.strip_exterior) {
        out.tets[w] = out.tets[t];
        out.materials[w] = out.materials[t];
        ++w;
      }
    stats_.strippedTets = static_cast<int64_t>(out.tets.size() - w);
    out.tets.resize(w);
    out.materials.resize(w);
    for (auto& mo : r.materials)
      if (mo.label == *p_.strip_exterior) mo.stripped = true;
  }
  std::vector<int32_t> remap(out.points.size(), -1);
  int32_t used = 0;
  for (const auto& q : out.tets)
    for (int32_t v : q)
      if (remap[v] < 0) remap[v] = 0;
  for (size_t v = 0; v < remap.size(); ++v)
    if (remap[v] == 0) remap[v] = used++;
  std::vector<Vec3> pts(static_cast<size_t>(used));
  for (size_t v = 0; v < remap.size(); ++v)
    if (remap[v] >= 0) pts[remap[v]] = out.points[v];
  out.points.swap(pts);
  for (auto& q : out.tets)
    for (auto& v : q) v = remap[v];
  progress_.endStage();
  r.stats = stats_;
  return r;
}

} // namespace cleaving_detail


std::vector<MaterialTally> tallyMaterials(const TetMesh& mesh, const std::vector<int32_t>& labels) {
  std::vector<MaterialTally> tally(labels.size());
  const bool sorted = std::is_sorted(labels.begin(), labels.end());
  for (size_t t = 0; t < mesh.numTets(); ++t) {
    const int32_t L = mesh.materials[t];
    const auto it = sorted ? std::lower_bound(labels.begin(), labels.end(), L) : std::find(labels.begin(), labels.end(), L);
    if (it == labels.end() || *it != L) continue;
    auto& e = tally[size_t(it - labels.begin())];
    ++e.tets;
    e.volume += mesh.tetVolume(t);
  }
  return tally;
}

CleaveResult cleave(const BackgroundMesh& background, const MaterialSet& materials,
                    const CleaveParams& params, Progress& progress) {
  cleaving_detail::Cleaver c(background, materials, params, progress);
  return c.run();
}

void writeCleaveReport(const CleaveResult& r, Report& rep) {
  const CleaveStats& s = r.stats;
  rep.set("tets", ReportValue(int64_t(r.mesh.numTets())));
  rep.set("vertices", ReportValue(int64_t(r.mesh.numPoints())));
  rep.set("background_tets", ReportValue(s.backgroundTets));
  rep.set("interface_tets", ReportValue(s.interfaceTets));
  rep.set("cuts", ReportValue(s.cuts));
  rep.set("triples", ReportValue(s.triples));
  rep.set("quadruples", ReportValue(s.quadruples));
  rep.set("warped_vertices", ReportValue(s.warpedVertices));
  rep.set("snaps", ReportValue(s.snaps));
  rep.set("degeneracy_snaps", ReportValue(s.degeneracySnaps));
  rep.set("steiner_points", ReportValue(s.steinerPoints));
  rep.set("limited_warps", ReportValue(s.limitedWarps));
  rep.set("optimized_vertices", ReportValue(s.optimizedVertices));
  if (s.strippedTets) rep.set("stripped_tets", ReportValue(s.strippedTets));
  if (s.culledTets) {
    rep.set("culled_tets", ReportValue(s.culledTets));
    rep.set("culled_mm3", ReportValue(s.culledVolume));
  }
  std::string present, lost;
  for (const auto& m : r.materials) {
    const std::string key = "material_" + std::to_string(m.label);
    rep.set(key + "_tets", ReportValue(m.tets));
    rep.set(key + "_volume_mm3", ReportValue(m.meshVolume));
    rep.set(key + "_input_mm3", ReportValue(m.inputVolume));
    if (m.lost()) {
      if (!lost.empty()) lost += ' ';
      lost += std::to_string(m.label);
    } else {
      if (!present.empty()) present += ' ';
      present += std::to_string(m.label);
    }
  }
  rep.set("materials_present", present);
  rep.set("materials_lost", lost.empty() ? std::string("none") : lost);
}

} // namespace tetflow
