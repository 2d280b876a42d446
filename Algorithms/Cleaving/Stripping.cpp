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
// The 26-connected components of one label's voxels, from its runs along x (LabelRuns.h): the
// runs, the component of each, and each component's voxels and whether it touches the box.
struct LabelRunComponents {
  LabelRows rows;
  std::vector<int32_t> compOfRun;
  std::vector<ImageComponent> comps;
};

LabelRunComponents runComponentsOf(const LabelVolume& labels, int32_t L, Progress& progress) {
  LabelRunComponents out;
  out.rows = labelRows(labels, L);
  const LabelRows& rows = out.rows;
  const int64_t nx = rows.nx, ny = rows.ny, nz = rows.nz;
  DisjointSets sets(rows.runs.size());
  joinRuns(rows, sets, progress);
  int32_t count = 0;
  out.compOfRun = runComponents(rows, sets, count);
  out.comps.resize(size_t(count));
  for (int64_t r = 0; r < rows.rows(); ++r) {
    const int64_t j = r % ny, k = r / ny;
    const bool rowOnBox = j == 0 || j == ny - 1 || k == 0 || k == nz - 1;
    for (int64_t q = rows.start[size_t(r)]; q < rows.start[size_t(r) + 1]; ++q) {
      ImageComponent& c = out.comps[size_t(out.compOfRun[size_t(q)])];
      const LabelRun& x = rows.runs[size_t(q)];
      c.label = L;
      c.voxels += x.i1 - x.i0 + 1;
      c.touchesBox = c.touchesBox || rowOnBox || x.i0 == 0 || x.i1 == nx - 1;
    }
  }
  return out;
}

// What stripping needs of analyzeLabelImage, for one label (no cores, no contacts): comp (per
// voxel, -1 elsewhere) only when `perVoxel` and some component is a cavity (does not touch the
// box): without one, every tet of the label goes and no tet needs a vote.
LabelImageTopology labelComponents(const LabelVolume& labels, int32_t L, bool perVoxel, Progress& progress) {
  LabelRunComponents rc = runComponentsOf(labels, L, progress);
  LabelImageTopology out;
  out.comps = std::move(rc.comps);
  const bool cavity = std::any_of(out.comps.begin(), out.comps.end(), [](const ImageComponent& c) { return !c.touchesBox; });
  if (perVoxel && cavity) {
    out.comp.assign(labels.data.size(), -1);
    paintRuns(rc.rows, rc.compOfRun, out.comp);
  }
  return out;
}
} // namespace

ExteriorTest::ExteriorTest(const LabelVolume& labels, const StripParams& p, Progress& progress) : labels_(labels) {
  LabelRunComponents rc = runComponentsOf(labels, p.label, progress);
  const auto& runs = rc.rows.runs;
  start_ = std::move(rc.rows.start);
  i0_.resize(runs.size());
  i1_.resize(runs.size());
  exterior_.resize(runs.size());
  for (size_t q = 0; q < runs.size(); ++q) {
    i0_[q] = runs[q].i0;
    i1_[q] = runs[q].i1;
    exterior_[q] = p.cavities || rc.comps[size_t(rc.compOfRun[q])].touchesBox;
  }
}

bool ExteriorTest::operator()(const Vec3& p) const {
  const Vec3 c = IndexFrame{labels_.grid}.toIndex(p);
  const auto& d = labels_.grid.dims;
  int64_t x[3];
  for (int a = 0; a < 3; ++a) {
    const double r = std::round(c[a]);
    if (!(r >= 0.0 && r <= double(d[a] - 1))) return false; // outside the volume (or not a number)
    x[a] = int64_t(r);
  }
  const int64_t r = x[1] + d[1] * x[2];
  const auto first = i1_.begin() + start_[size_t(r)], last = i1_.begin() + start_[size_t(r) + 1];
  const auto it = std::lower_bound(first, last, int32_t(x[0])); // the first run ending at or after x
  if (it == last) return false;
  const size_t q = size_t(it - i1_.begin());
  return i0_[q] <= x[0] && exterior_[q];
}

StripStats stripExterior(TetMesh& mesh, const LabelVolume& labels, const LabelImageTopology* image,
                         const StripParams& p, const DomainBox& box, Progress& progress,
                         const std::vector<std::pair<int32_t, int32_t>>* joins,
                         std::vector<int32_t>* faceNeighbours) {
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
    std::vector<int32_t> own;
    std::vector<int32_t>& nbr = faceNeighbours ? *faceNeighbours : own; // renumbered below
    if (nbr.empty()) nbr = tetFaceNeighbours(mesh, progress);
    DisjointSets pieces = sameLabelPieces(mesh, nbr, joins);
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
        if (nbr[4 * size_t(t) + size_t(f)] != kNoNeighbour) continue;
        const auto& q = mesh.tets[size_t(t)];
        const uint8_t common = box.fixedAxes(mesh.points[size_t(q[kTetFaceVertices[f][0]])]) &
                               box.fixedAxes(mesh.points[size_t(q[kTetFaceVertices[f][1]])]) &
                               box.fixedAxes(mesh.points[size_t(q[kTetFaceVertices[f][2]])]);
        if (common) onBox[size_t(root)] = 1;
      }
    }
    if (joins) // joined through the exterior that was never meshed: as good as on the box
      for (const auto& [a, b] : *joins)
        for (const int32_t t : {a, b})
          if (mesh.materials[size_t(t)] == p.label) onBox[size_t(pieces.find(t))] = 1;
    for (int64_t t = 0; t < nt; ++t) {
      if (mesh.materials[size_t(t)] != p.label) continue;
      const size_t root = size_t(pieces.find(int32_t(t)));
      drop[size_t(t)] = onBox[root] || outside[root] >= inside[root];
    }
  }
  // The new number of every kept tet (-1: removed), for the face neighbours.
  std::vector<int32_t> renumber;
  const bool keepNeighbours = faceNeighbours && !faceNeighbours->empty();
  if (keepNeighbours) renumber.assign(size_t(nt), -1);
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
    if (keepNeighbours) renumber[size_t(t)] = int32_t(w);
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
  if (keepNeighbours) {
    std::vector<int32_t>& nb = *faceNeighbours;
    for (int64_t t = 0; t < nt; ++t) {
      const int32_t to = renumber[size_t(t)];
      if (to < 0) continue;
      for (int f = 0; f < 4; ++f) {
        const int32_t o = nb[4 * size_t(t) + size_t(f)];
        nb[4 * size_t(to) + size_t(f)] = o >= 0 ? (renumber[size_t(o)] >= 0 ? renumber[size_t(o)] : kNoNeighbour) : o;
      }
    }
    nb.resize(4 * w);
  } else if (faceNeighbours) {
    faceNeighbours->clear();
  }
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
