// Writes the CAD test models of Testing/Fixtures/CadModels.h (made with OpenCASCADE's primitives,
// booleans and sweeps) as BREP and STEP files, for the nets and for trying them elsewhere:
//   build/Testing/cad_models OUTPUT_FOLDER
// Nets/electrode_in_tissue.brep and Nets/four_shell_sphere.brep were written by it.
#include <BRepTools.hxx>

#include <cstdio>
#include <filesystem>

#include "Fixtures/CadModels.h"

using namespace tetflow;

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: cad_models OUTPUT_FOLDER\n");
    return 2;
  }
  const std::filesystem::path dir = argv[1];
  std::filesystem::create_directories(dir);
  auto models = testing::testModels();
  models.push_back({"electrode_in_tissue", testing::electrodeInTissue, 6});
  models.push_back({"four_shell_sphere", testing::fourShellSphere, 8});
  for (const auto& tm : models) {
    const TopoDS_Shape shape = tm.make();
    auto model = testing::modelOf(shape, tm.name); // checks it
    const std::string brep = (dir / (tm.name + ".brep")).string();
    if (!BRepTools::Write(shape, brep.c_str())) {
      std::fprintf(stderr, "cannot write %s\n", brep.c_str());
      return 1;
    }
    model->writeStep((dir / (tm.name + ".step")).string());
    std::printf("%s: %zu solid(s), %zu patches, %zu curves, %zu corners, Euler characteristic %d\n",
                tm.name.c_str(), model->solids().size(), model->patches().size(), model->curves().size(),
                model->corners().size(), model->eulerCharacteristic());
  }
  return 0;
}
