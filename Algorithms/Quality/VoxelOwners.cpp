#include "VoxelOwners.h"

#include "LabelTopology.h"

namespace tetflow {

VoxelOwners::VoxelOwners(const TetMesh& mesh, const GridGeometry& g, Progress& progress)
    : mesh_(mesh), g_(g), progress_(progress) {
  const IndexFrame frame{g};
  ip_.resize(mesh.numPoints());
#pragma omp parallel for schedule(static)
  for (int64_t p = 0; p < static_cast<int64_t>(mesh.numPoints()); ++p)
    ip_[static_cast<size_t>(p)] = frame.toIndex(mesh.points[static_cast<size_t>(p)]);
  words_.assign(static_cast<size_t>((g.voxelCount() + 15) / 16), 0u);
}

} // namespace tetflow
