#pragma once
// Validity of a mesh as the cleaving and mesh-improvement tests require it: no inverted, flat or
// duplicate tets, no face in more than two tets, a closed boundary, every vertex used.
#include <gtest/gtest.h>

#include "Algorithms/Quality/MeshQuality.h"

namespace tetflow::test {

inline void expectValidClosedMesh(const QualityResult& q) {
  EXPECT_TRUE(q.valid);
  EXPECT_EQ(q.inverted, 0);
  EXPECT_EQ(q.zeroVolume, 0);
  EXPECT_EQ(q.duplicateTets, 0);
  EXPECT_EQ(q.nonmanifoldFaces, 0);
  EXPECT_TRUE(q.boundaryClosed);
  EXPECT_EQ(q.unreferencedVertices, 0);
}

} // namespace tetflow::test
