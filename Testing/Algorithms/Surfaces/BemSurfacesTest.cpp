// Tests for Algorithms/Surfaces/BemSurfaces and the surface writers (Algorithms/IO/SurfaceIO):
// nested boxes and random blobs give closed, manifold, outward surfaces enclosing exactly their
// materials' volume; a pinch is found; meshio (Debian's python3-meshio) reads what is written.
#include "Algorithms/Surfaces/BemSurfaces.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <random>
#include <sstream>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/IO/SurfaceIO.h"
#include "Algorithms/Quality/LabelTopology.h"
#include "Fixtures/VoxelMesh.h"
#include "TestUtil.h"

namespace tetflow {
namespace {

LabelVolume boxes(int n) {
  LabelVolume v;
  GridGeometry g;
  g.dims = {n, n, n};
  g.spacing = {1.5, 1.0, 2.0};
  g.origin = {-3, 7, 0.5};
  v.allocate(g, 0);
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const int d = std::min({i, j, k, n - 1 - i, n - 1 - j, n - 1 - k}); // depth from the box's face
        v.at(i, j, k) = std::min(d, 3);                                       // 0 outside .. 3 innermost
      }
  return v;
}

double unionVolume(const TetMesh& m, const std::vector<int32_t>& labels) {
  double s = 0;
  for (size_t t = 0; t < m.numTets(); ++t)
    if (std::find(labels.begin(), labels.end(), m.materials[t]) != labels.end()) s += m.tetVolume(t);
  return s;
}

TEST(BemSurfaces, NestedLayersGiveClosedOutwardSurfacesEnclosingTheirMaterials) {
  const LabelVolume v = boxes(10);
  const TetMesh m = test::voxelMesh(v);
  Progress progress;
  const auto nb = tetFaceNeighbours(m, progress);
  std::vector<TriSurface> s;
  for (const std::vector<int32_t>& set : {std::vector<int32_t>{1, 2, 3}, {2, 3}, {3}}) {
    s.push_back(unionBoundary(m, set, nb));
    const SurfaceCheck c = checkSurface(s.back());
    EXPECT_TRUE(c.closedManifoldOriented()) << c.openEdges << " " << c.nonManifoldEdges << " " << c.misorientedEdges;
    EXPECT_EQ(c.components, 1);
    const double want = unionVolume(m, set);
    EXPECT_NEAR(c.enclosedVolume, want, 1e-9 * want); // positive: the normals point out
  }
  // Box faces of 10, 8 and 6 voxels: areas known exactly.
  EXPECT_NEAR(checkSurface(s[0]).area, 2 * (8 * 1.5 * 8 * 1.0 + 8 * 1.0 * 8 * 2.0 + 8 * 1.5 * 8 * 2.0), 1e-9);
  EXPECT_EQ(sharedVertices(s[0], s[1]), 0);
  EXPECT_EQ(sharedVertices(s[1], s[2]), 0);
}

TEST(BemSurfaces, RandomBlobsEncloseTheirVolumeAndPinchesAreFound) {
  std::mt19937 rng(5);
  int pinched = 0;
  for (int trial = 0; trial < 12; ++trial) {
    LabelVolume v = boxes(8);
    std::fill(v.data.begin(), v.data.end(), 0);
    for (int k = 1; k < 7; ++k)
      for (int j = 1; j < 7; ++j)
        for (int i = 1; i < 7; ++i) v.at(i, j, k) = rng() % 3 == 0 ? 0 : 1;
    const TetMesh m = test::voxelMesh(v);
    Progress progress;
    const auto nb = tetFaceNeighbours(m, progress);
    const TriSurface s = unionBoundary(m, {1}, nb);
    const SurfaceCheck c = checkSurface(s);
    EXPECT_EQ(c.openEdges, 0);
    EXPECT_EQ(c.misorientedEdges, 0);
    EXPECT_NEAR(c.enclosedVolume, unionVolume(m, {1}), 1e-9 * unionVolume(m, {1}));
    // Two voxels of a blob meeting at an edge or a corner make a non-manifold surface there.
    if (c.nonManifoldEdges > 0 || c.nonManifoldVertices > 0) ++pinched;
  }
  EXPECT_GT(pinched, 0);
  // Two cubes touching at a corner: one non-manifold vertex, no bad edge.
  LabelVolume v = boxes(4);
  std::fill(v.data.begin(), v.data.end(), 0);
  v.at(1, 1, 1) = v.at(2, 2, 2) = 1;
  const TetMesh m = test::voxelMesh(v);
  Progress progress;
  const SurfaceCheck c = checkSurface(unionBoundary(m, {1}, tetFaceNeighbours(m, progress)));
  EXPECT_EQ(c.nonManifoldVertices, 1);
  EXPECT_EQ(c.nonManifoldEdges + c.openEdges + c.misorientedEdges, 0);
  EXPECT_EQ(c.components, 2);
}

TEST(BemSurfaces, WrittenFilesAreReadByMeshioAndNibabel) {
  ASSERT_EQ(std::system("/usr/bin/python3 -c 'import meshio' > /dev/null 2>&1"), 0)
      << "meshio is missing: scripts/setup.sh installs it (Debian package python3-meshio)";
  const TetMesh m = test::voxelMesh(boxes(6));
  Progress progress;
  const TriSurface s = unionBoundary(m, {1, 2, 3}, tetFaceNeighbours(m, progress));
  test::TempDir dir;
  for (const char* name : {"s.off", "s.stl"}) {
    writeTriangleSurface(dir.file(name), s.points, s.triangles);
    const std::string out = dir.file("out.txt");
    const std::string cmd = "/usr/bin/python3 -c \"import meshio; m = meshio.read('" + dir.file(name) +
                            "'); print(sum(len(c.data) for c in m.cells if c.type == 'triangle'))\" > '" + out + "' 2>&1";
    ASSERT_EQ(std::system(cmd.c_str()), 0) << name;
    std::ifstream in(out);
    std::stringstream text;
    text << in.rdbuf();
    EXPECT_EQ(text.str(), std::to_string(s.triangles.size()) + "\n") << name;
  }
  // FreeSurfer's format (MNE's BEM surfaces), read back by nibabel: same points (float) and triangles.
  ASSERT_EQ(std::system("/usr/bin/python3 -c 'import nibabel' > /dev/null 2>&1"), 0)
      << "nibabel is missing: scripts/setup.sh installs it (Debian package python3-nibabel)";
  writeTriangleSurface(dir.file("s.surf"), s.points, s.triangles);
  {
    const std::string out = dir.file("surf.txt");
    const std::string cmd = "/usr/bin/python3 -c \"import nibabel.freesurfer as fs; v, f = fs.read_geometry('" +
                            dir.file("s.surf") +
                            "'); print(len(v), len(f)); print(' '.join('%.9g' % x for x in v[1])); print(*f[-1])\" > '" +
                            out + "' 2>&1";
    ASSERT_EQ(std::system(cmd.c_str()), 0);
    std::ifstream in(out);
    size_t nv = 0, nf = 0;
    double x = 0, y = 0, z = 0;
    int a = -1, b = -1, c = -1;
    in >> nv >> nf >> x >> y >> z >> a >> b >> c;
    EXPECT_EQ(nv, s.points.size());
    EXPECT_EQ(nf, s.triangles.size());
    EXPECT_EQ(x, double(float(s.points[1][0])));
    EXPECT_EQ(y, double(float(s.points[1][1])));
    EXPECT_EQ(z, double(float(s.points[1][2])));
    EXPECT_EQ((std::array<int32_t, 3>{a, b, c}), s.triangles.back());
  }
  writeTriangleSurface(dir.file("s.vtp"), s.points, s.triangles);
  std::ifstream vtp(dir.file("s.vtp"));
  std::stringstream text;
  text << vtp.rdbuf();
  EXPECT_NE(text.str().find("NumberOfPolys=\"" + std::to_string(s.triangles.size()) + "\""), std::string::npos);
  EXPECT_THROW_MSG(writeTriangleSurface(dir.file("s.ply"), s.points, s.triangles), InputError, "s.ply", ".off, .stl, .vtp, .surf");
}

} // namespace
} // namespace tetflow
