// Layered head generator (Testing/Fixtures/LayeredHead.h): writes the label volume built from
// mricron-data's HarvardOxford and JHU atlases (0 air, 1 scalp, 2 skull, 3 CSF, 4 grey, 5 white).
//
//   layered_head OUT.nii.gz [--voxel 1|2|4] [--variant 0|1|2] [--parcels] [--stats]
//
// The atlases are read from $TETFLOW_MRICRON_DIR or /usr/share/mricron/templates (Debian package
// mricron-data, installed by scripts/setup.sh). --stats prints voxel counts, 26-connected
// components, box faces, contacts, enclosed air and the thickness of the CSF, skull and scalp.
// --parcels (1 mm) keeps the brain alone (0 around it) and splits its grey matter into
// HarvardOxford's 48 cortical labels per hemisphere (labels 6-101): a 99-label brain atlas for the
// pipeline benchmarks.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <set>
#include <string>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/Core/Progress.h"
#include "Algorithms/IO/VolumeIO.h"
#include "Algorithms/Quality/LabelTopology.h"
#include "Fixtures/LayeredHead.h"

using namespace tetflow;

namespace {

const char* kNames[6] = {"air", "scalp", "skull", "CSF", "grey", "white"};

void printStats(const LabelVolume& v, const LayeredHeadInfo& info, int voxel) {
  const auto& d = v.grid.dims;
  const int64_t nx = d[0], ny = d[1], nz = d[2], n = v.grid.voxelCount();
  std::printf("dims %lld x %lld x %lld, %g mm\n", (long long)nx, (long long)ny, (long long)nz, v.grid.spacing[0]);
  for (const auto& [l, c] : labelCounts(v)) std::printf("  label %d %-6s %9lld voxels\n", l, kNames[l], (long long)c);
  NullProgress np;
  const LabelImageTopology t = analyzeLabelImage(v, np);
  std::vector<uint8_t> onBox(t.comps.size(), 0); // components with a voxel on the box
  for (int64_t k = 0; k < nz; ++k)
    for (int64_t j = 0; j < ny; ++j)
      for (int64_t i = 0; i < nx; ++i)
        if (!i || !j || !k || i == nx - 1 || j == ny - 1 || k == nz - 1)
          onBox[size_t(t.comp[size_t(v.index(i, j, k))])] = 1;
  auto touches = [&](const ImageComponent* c) { return onBox[size_t(c - t.comps.data())] != 0; };
  std::map<int32_t, std::vector<const ImageComponent*>> byLabel;
  for (const auto& c : t.comps) byLabel[c.label].push_back(&c);
  std::printf("26-connected components per label (size@voxel-index centroid of all but the largest; * = on the box):\n");
  for (const auto& [l, cs] : byLabel) {
    std::printf("  %-6s %zu:", kNames[l], cs.size());
    int64_t largest = 0;
    for (const auto* c : cs) largest = std::max(largest, c->voxels);
    bool skipped = false;
    for (const auto* c : cs) {
      if (c->voxels == largest && !skipped) { skipped = true; continue; }
      const Vec3 at = c->where.place().centroid; // mm; the grid's axes are the identity
      std::printf(" %lld%s@(%.0f,%.0f,%.0f)", (long long)c->voxels, touches(c) ? "*" : "",
                  (at[0] - v.grid.origin[0]) / v.grid.spacing[0], (at[1] - v.grid.origin[1]) / v.grid.spacing[1],
                  (at[2] - v.grid.origin[2]) / v.grid.spacing[2]);
    }
    std::printf("  (largest %lld)\n", (long long)largest);
  }
  // Box faces each label reaches.
  std::printf("labels on the box faces (-x +x -y +y -z +z):");
  for (int f = 0; f < 6; ++f) {
    std::set<int32_t> on;
    const int a = f / 2;
    const int64_t at = f % 2 ? d[a] - 1 : 0;
    for (int64_t k = 0; k < nz; ++k)
      for (int64_t j = 0; j < ny; ++j)
        for (int64_t i = 0; i < nx; ++i)
          if ((a == 0 ? i : a == 1 ? j : k) == at) on.insert(v.at(i, j, k));
    std::printf(" {");
    for (int32_t l : on) std::printf("%d", l);
    std::printf("}");
  }
  std::printf("\ncontacts (face-adjacent label pairs, mm^2):");
  for (const auto& [key, c] : t.contacts) {
    const auto [a, b] = labelPairOf(key);
    std::printf(" %d-%d:%.0f", a, b, c.first);
  }
  // Air: the exterior (touching the box) and the enclosed cavities; the ear canals' outer ends.
  std::printf("\nair components: ");
  for (const auto* c : byLabel[kHeadAir])
    std::printf("%lld%s ", (long long)c->voxels, touches(c) ? "(exterior)" : "(enclosed)");
  for (int s = 0; s < 2; ++s) {
    const auto& e = info.earCanal[size_t(s)];
    // Walk in from the box face along the canal axis to the last air voxel: it must be exterior.
    int64_t last = -1;
    for (int64_t step = 0; step < nx; ++step) {
      const int64_t i = s == 0 ? step : nx - 1 - step;
      if (v.at(i, e[1] / voxel, e[2] / voxel) != kHeadAir) break;
      last = i;
    }
    int64_t deep = last;
    for (int64_t step = 0; step < nx; ++step) { // furthest air voxel on the axis before the brain
      const int64_t i = s == 0 ? step : nx - 1 - step;
      const int32_t l = v.at(i, e[1] / voxel, e[2] / voxel);
      if (l == kHeadCsf || l == kHeadGrey || l == kHeadWhite) break;
      if (l == kHeadAir) deep = i;
    }
    const ImageComponent* c = &t.comps[size_t(t.comp[size_t(v.index(deep, e[1] / voxel, e[2] / voxel))])];
    std::printf("\near canal %d: deepest air on axis at i=%lld, in the %s air component", s, (long long)deep,
                touches(c) ? "exterior" : "ENCLOSED");
  }
  // Thickness of each shell: at its voxels that touch the next layer out (6-neighbour), the
  // distance to the nearest voxel of the layer in (voxels; 1 = a one-voxel layer).
  struct Layer { int32_t label; std::set<int32_t> in, out; };
  const Layer layers[3] = {{kHeadCsf, {kHeadGrey, kHeadWhite}, {kHeadSkull}},
                           {kHeadSkull, {kHeadCsf}, {kHeadScalp}},
                           {kHeadScalp, {kHeadSkull}, {kHeadAir}}};
  std::printf("\nshell thickness at the outer face (mm, distance to the layer inside):\n");
  for (const auto& layer : layers) {
    std::vector<uint8_t> inner(static_cast<size_t>(n));
    for (int64_t x = 0; x < n; ++x) inner[size_t(x)] = layer.in.count(v.data[size_t(x)]) > 0;
    const std::vector<float> dist = distanceToMask(d, inner);
    std::map<int, int64_t> hist;
    int64_t faces = 0, thin = 0, all = 0;
    for (int64_t k = 1; k < nz - 1; ++k)
      for (int64_t j = 1; j < ny - 1; ++j)
        for (int64_t i = 1; i < nx - 1; ++i) {
          const int64_t x = v.index(i, j, k);
          if (v.data[size_t(x)] != layer.label) continue;
          ++all;
          const int64_t st[3] = {1, nx, nx * ny};
          bool face = false, one = false;
          for (int a = 0; a < 3; ++a) {
            const int32_t lo = v.data[size_t(x - st[a])], hi = v.data[size_t(x + st[a])];
            face = face || layer.out.count(lo) || layer.out.count(hi);
            one = one || (layer.in.count(lo) && layer.out.count(hi)) || (layer.out.count(lo) && layer.in.count(hi));
          }
          thin += one;
          if (!face) continue;
          ++faces;
          ++hist[std::min(9, int(std::ceil(dist[size_t(x)] * v.grid.spacing[0] - 1e-6)))];
        }
    std::printf("  %-6s voxels one voxel thick along an axis: %.1f%%; outer-face voxels %lld by thickness:",
                kNames[layer.label], 100.0 * double(thin) / double(std::max<int64_t>(all, 1)), (long long)faces);
    for (const auto& [b, c] : hist)
      std::printf(" %s%d:%.1f%%", b == 9 ? ">" : "<=", b == 9 ? 8 : b, 100.0 * double(c) / double(faces));
    std::printf("\n");
  }
  std::printf("sulcal voxels %lld, ventricle voxels %lld (1 mm), specks:", (long long)info.sulcusVoxels,
              (long long)info.ventricleVoxels);
  for (const auto& s : info.specks) std::printf(" %s@(%d,%d,%d)", kNames[s[3]], s[0], s[1], s[2]);
  std::printf("\n");
}

} // namespace

int main(int argc, char** argv) {
  std::string outPath;
  LayeredHeadParams p;
  bool stats = false;
  for (int a = 1; a < argc; ++a) {
    const std::string s = argv[a];
    if (s == "--voxel" && a + 1 < argc) p.voxel = std::atoi(argv[++a]);
    else if (s == "--variant" && a + 1 < argc) p.variant = std::atoi(argv[++a]);
    else if (s == "--stats") stats = true;
    else if (s == "--parcels") p.parcels = true;
    else if (!s.empty() && s[0] != '-' && outPath.empty()) outPath = s;
    else {
      std::fprintf(stderr, "usage: layered_head OUT.nii.gz [--voxel 1|2|4] [--variant 0|1|2] [--parcels] [--stats]\n");
      return 2;
    }
  }
  if (outPath.empty()) {
    std::fprintf(stderr, "usage: layered_head OUT.nii.gz [--voxel 1|2|4] [--variant 0|1|2] [--parcels] [--stats]\n");
    return 2;
  }
  try {
    const auto t0 = std::chrono::steady_clock::now();
    LayeredHeadInfo info;
    const LabelVolume v = makeLayeredHead(mricronTemplatesDir(), p, &info);
    const auto t1 = std::chrono::steady_clock::now();
    writeVolume(outPath, fromLabelVolume(v));
    const auto t2 = std::chrono::steady_clock::now();
    std::printf("layered head variant %d, %d mm: generated in %.2f s, written in %.2f s -> %s\n", p.variant, p.voxel,
                std::chrono::duration<double>(t1 - t0).count(), std::chrono::duration<double>(t2 - t1).count(),
                outPath.c_str());
    if (p.parcels) {
      std::set<int32_t> labels(v.data.begin(), v.data.end());
      std::printf("%zu labels (grey matter in %zu cortical parcels)\n", labels.size(),
                  size_t(std::count_if(labels.begin(), labels.end(), [](int32_t l) { return l > kHeadWhite; })));
    } else if (stats) {
      printStats(v, info, p.voxel);
    }
  } catch (const Error& e) {
    std::fprintf(stderr, "layered_head: %s\n", e.what());
    return 1;
  }
  return 0;
}
