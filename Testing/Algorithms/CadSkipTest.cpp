// Without OpenCASCADE (-DTETFLOW_WITH_OCCT=OFF) the CAD tests are not built; this says so.
#include <gtest/gtest.h>

#ifdef TETFLOW_NO_OCCT
TEST(CadModel, SkippedWithoutOpenCascade) {
  GTEST_SKIP() << "built with -DTETFLOW_WITH_OCCT=OFF: the CAD model tests (Testing/Algorithms/CAD, "
                  "Testing/Algorithms/SurfaceMeshing/Cad*) are not built";
}
#endif
