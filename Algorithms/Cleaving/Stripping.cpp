#include "Stripping.h"

#include <algorithm>
#include <cmath>

#include "Algorithms/Quality/LabelRuns.h"
#include "Algorithms/Quality/LabelTopology.h"

namespace tetflow {

void removeUnusedVertices(TetMesh& mesh) {
  std::vector<int32_t> remap(mesh.points.size(), -1);
  for (const auto& q : mesh.tets)
    for (int32_t v : q) remap[size_t(v)] = 0;
  int32_t used = 0;
  for (auto& r : remap)
    if (r == 0) r = used++;
  if (size_t(used) == mesh.points.size()) return;
  std::vector<Vec3> pts(static_cast<size_t>(used));
  for (size_t v = 0; v < remap.size(); ++v)
    if (remap[v] >= 0) pts[size_t(remap[v])] = mesh.points[v];
  for (auto& [name, f] : mesh.pointFields) {
    std::vector<double> vals(size_t(used) * size_t(f.components));
    for (size_t v = 0; v < remap.size(); ++v)
      if (remap[v] >= 0)
        for (int c = 0; c < f.components; ++c)
          vals[size_t(remap[v]) * size_t(f.components) + size_t(c)] = f.values[v * size_t(f.components) + size_t(c)];
    f.values.swap(vals);
  }
  mesh.points.swap(pts);
  for (auto& q : mesh.tets)
    for (auto& v : q) v = remap[size_t(v)];
}

namespace {
// The 26-connected components of one label's voxels, from its runs along x (LabelRuns.h). comp
// (per voxel, -1 elsewhere) only when `perVoxel` and some component is a cavity (does not touch
// the box): without one, every tet of the label goes and no tet needs a vote. No cores, no
// contacts: what stripping needs of analyzeLabelImage, for one label.
LabelImageTopology labelComponents(const LabelVolume& labels, int32_t L, bool perVoxel, Progress& progress) {
  const LabelRows rows = labelRows(labels, L);
  const int64_t nx = rows.nx, ny = rows.ny, nz = rows.nz;
  const auto& start = rows.start;
  const auto& runs = rows.runs;
  DisjointSets sets(runs.size());
  joinRuns(rows, sets, progress);
  LabelImageTopology out;
  int32_t count = 0;
  const std::vector<int32_t> compOfRun = runComponents(rows, sets, count);
  out.comps.resize(size_t(count));
  for (int64_t r = 0; r < rows.rows(); ++r) {
    const int64_t j = r % ny, k = r / ny;
    const bool rowOnBox = j == 0 || j == ny - 1 || k == 0 || k == nz - 1;
    for (int64_t q = start[size_t(r)]; q < start[size_t(r) + 1]; ++q) {
      ImageComponent& c = out.comps[size_t(compOfRun[size_t(q)])];
      const LabelRun& x = runs[size_t(q)];
      c.label = L;
      c.voxels += x.i1 - x.i0 + 1;
      c.touchesBox = c.touchesBox || rowOnBox || x.i0 == 0 || x.i1 == nx - 1;
    }
  }
  const bool cavity = std::any_of(out.comps.begin(), out.comps.end(), [](const ImageComponent& c) { return !c.touchesBox; });
  if (perVoxel && cavity) {
    out.comp.assign(labels.data.size(), -1);
    paintRuns(rows, compOfRun, out.comp);
  }
  return out;
}
} // namespace

StripStats stripExterior(TetMesh& mesh, const LabelVolume& labels, const LabelImageTopology* image,
                         const StripParams& p, const DomainBox& box, Progress& progress) {
  progress.beginStage("strip exterior");
  mesh.validateStructure("strip exterior");
  StripStats st;
  st.label = p.label;
  // Without the repair's analysis of the whole image, the label's own components: from its runs,
  // per voxel only when it has cavities (without, every tet of the label goes).
  LabelImageTopology own;
  if (!image) {
    own = labelComponents(labels, p.label, !p.cavities, progress);
    image = &own;
  }
  const double voxel = labels.grid.voxelVolume();
  for (const auto& c : image->comps) {
    if (c.label != p.label) continue;
    if (c.touchesBox || p.cavities) {
      st.exteriorVoxels += c.voxels;
    } else {
      st.cavityVoxels += c.voxels;
      ++st.cavityComponents;
    }
  }
  st.exteriorVolume = double(st.exteriorVoxels) * voxel;
  st.cavityVolume = double(st.cavityVoxels) * voxel;
  const int64_t nt = int64_t(mesh.numTets());
  std::vector<uint8_t> drop(size_t(nt), 0);
  bool any = false;
  for (int64_t t = 0; t < nt && !any; ++t) any = mesh.materials[size_t(t)] == p.label;
  if (any && (p.cavities || st.cavityVoxels == 0)) { // everything of the label is exterior
    for (int64_t t = 0; t < nt; ++t) drop[size_t(t)] = mesh.materials[size_t(t)] == p.label;
  } else if (any) {
    const std::vector<int32_t> nb = tetFaceNeighbours(mesh, progress);
    DisjointSets pieces = sameLabelPieces(mesh, nb);
    progress.checkCancel();
    const IndexFrame frame{labels.grid};
    // Per piece (root): exterior and cavity votes, and whether it has a face on the box.
    std::vector<double> outside(size_t(nt), 0.0), inside(size_t(nt), 0.0);
    std::vector<uint8_t> onBox(size_t(nt), 0);
    for (int64_t t = 0; t < nt; ++t) {
      if (mesh.materials[size_t(t)] != p.label) continue;
      const int32_t root = pieces.find(int32_t(t));
      const int32_t c = voteImageComponent(labels, image->comp, frame.toIndex(tetCentroid(mesh, size_t(t))), p.label);
      const double v = std::abs(mesh.tetVolume(size_t(t)));
      if (c >= 0 && !image->comps[size_t(c)].touchesBox) inside[size_t(root)] += v;
      else if (c >= 0) outside[size_t(root)] += v;
      for (int f = 0; f < 4 && !onBox[size_t(root)]; ++f) {
        if (nb[4 * size_t(t) + size_t(f)] != kNoNeighbour) continue;
        const auto& q = mesh.tets[size_t(t)];
        const uint8_t common = box.fixedAxes(mesh.points[size_t(q[kTetFaceVertices[f][0]])]) &
                               box.fixedAxes(mesh.points[size_t(q[kTetFaceVertices[f][1]])]) &
                               box.fixedAxes(mesh.points[size_t(q[kTetFaceVertices[f][2]])]);
        if (common) onBox[size_t(root)] = 1;
      }
    }
    for (int64_t t = 0; t < nt; ++t) {
      if (mesh.materials[size_t(t)] != p.label) continue;
      const size_t root = size_t(pieces.find(int32_t(t)));
      drop[size_t(t)] = onBox[root] || outside[root] >= inside[root];
    }
  }
  size_t w = 0;
  for (int64_t t = 0; t < nt; ++t) {
    const double v = std::abs(mesh.tetVolume(size_t(t)));
    if (mesh.materials[size_t(t)] == p.label) {
      if (drop[size_t(t)]) {
        ++st.strippedTets;
        st.strippedVolume += v;
      } else {
        ++st.keptTets;
        st.keptVolume += v;
      }
    }
    if (drop[size_t(t)]) continue;
    mesh.tets[w] = mesh.tets[size_t(t)];
    mesh.materials[w] = mesh.materials[size_t(t)];
    for (auto& [name, f] : mesh.cellFields)
      for (int c = 0; c < f.components; ++c)
        f.values[w * size_t(f.components) + size_t(c)] = f.values[size_t(t) * size_t(f.components) + size_t(c)];
    ++w;
  }
  mesh.tets.resize(w);
  mesh.materials.resize(w);
  for (auto& [name, f] : mesh.cellFields) f.values.resize(w * size_t(f.components));
  removeUnusedVertices(mesh);
  progress.endStage();
  return st;
}

void writeStripReport(const StripStats& s, bool cavities, Report& r) {
  r.set("strip_label", ReportValue(int64_t(s.label)));
  r.set("strip_cavities", ReportValue(cavities));
  r.set("strip_exterior_voxels", ReportValue(s.exteriorVoxels));
  r.set("strip_exterior_mm3", ReportValue(s.exteriorVolume));
  r.set("strip_cavity_voxels", ReportValue(s.cavityVoxels));
  r.set("strip_cavity_mm3", ReportValue(s.cavityVolume));
  r.set("strip_cavity_components", ReportValue(int64_t(s.cavityComponents)));
  r.set("stripped_tets", ReportValue(s.strippedTets));
  r.set("stripped_mm3", ReportValue(s.strippedVolume));
  r.set("strip_kept_tets", ReportValue(s.keptTets));
  r.set("strip_kept_mm3", ReportValue(s.keptVolume));
}

} // namespace tetflow
