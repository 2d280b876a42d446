// ExtractSurfaces as a module: the head phantom's BEM surfaces (scalp, outer skull, inner skull)
// from the cleaved mesh, named by tissue, checked and written; bad parameters named.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "Dataflow/Executor.h"
#include "Dataflow/NetworkFile.h"
#include "Modules/StandardModules.h"
#include "TestModules.h"
#include "TestUtil.h"

using namespace tetflow;

namespace {

struct HeadSurfaces {
  ModuleRegistry reg;
  Network net{reg};
  Executor exec;
  test::TempDir dir;
  HeadSurfaces() {
    test::registerTestModules(reg);
    net.addModule("CreatePhantom", "p");
    net.setParameterText("p", "kind", "head");
    net.setParameterText("p", "voxel_size", "2");
    net.setParameterText("p", "radius", "30");
    net.setParameterText("p", "skull_radius", "26");
    net.setParameterText("p", "csf_radius", "21");
    net.setParameterText("p", "brain_radius", "17");
    net.addModule("GenerateBackgroundMesh", "bg");
    net.setParameterText("bg", "cell_size", "4");
    net.addModule("CleaveMesh", "cl");
    net.setParameterText("cl", "strip_exterior", "0");
    net.addModule("ExtractSurfaces", "bem");
    net.setParameterText("bem", "surfaces", "scalp: scalp skull CSF brain; outer_skull: skull+CSF+brain; inner_skull: 3 4");
    net.setParameterText("bem", "filename", dir.file("head.off"));
    net.connect("p", 0, "bg", 0);
    net.connect("p", 0, "cl", 0);
    net.connect("bg", 0, "cl", 1);
    net.connect("cl", 0, "bem", 0);
  }
  const Report& report() { return exec.state("bem")->report; }
};

// The cleaved head phantom's voxel layers pinch: without repair its surfaces touch themselves at
// a few vertices (non-manifold) and the skull's two surfaces touch, and with require_closed (the
// default) the module says so and writes nothing.
TEST(ExtractSurfacesModule, WithoutRepairThePinchedPhantomIsRefused) {
  HeadSurfaces h;
  h.net.setParameterText("bem", "repair", "false");
  EXPECT_FALSE(h.exec.execute(h.net).success);
  const std::string error = h.exec.state("bem")->error;
  EXPECT_NE(error.find("require_closed: surface 'scalp': 0 open edge(s), 0 non-manifold edge(s), "), std::string::npos)
      << error;
  EXPECT_NE(error.find("nothing written"), std::string::npos) << error;
  EXPECT_NE(error.find("set repair = true"), std::string::npos) << error;
  EXPECT_FALSE(std::filesystem::exists(h.dir.file("head_scalp.off")));
  h.net.setParameterText("bem", "require_closed", "false");
  ASSERT_TRUE(h.exec.execute(h.net).success) << h.exec.state("bem")->error;
  const Report& r = h.report();
  double defects = 0;
  for (const char* name : {"scalp", "outer_skull", "inner_skull"}) {
    const std::string k = std::string("surface_") + name + "_";
    EXPECT_LT(std::abs(r.number(k + "volume_rel_difference")), 1e-9) << name; // unrepaired: the tets exactly
    defects += r.number(k + "nonmanifold_vertices") + r.number(k + "nonmanifold_edges");
  }
  EXPECT_GT(defects, 0);
}

// With repair (the default) the surfaces are closed, manifold, outward, nested without touching
// and one piece each. This phantom is coarse (4 mm cells for a 4 mm skull and CSF in a 30 mm
// head): the repair moves 1-3 % of a surface's volume, more than max_volume_change allows by
// default, and the module says so; allowed 5 %, it goes on. (On Nets/bem_head.srn, the default
// phantom, it moves 0.01 %.)
TEST(ExtractSurfacesModule, TheHeadPhantomsBemSurfacesAreClosedManifoldNestedAndEncloseTheirTissues) {
  HeadSurfaces h;
  EXPECT_FALSE(h.exec.execute(h.net).success);
  const std::string error = h.exec.state("bem")->error;
  EXPECT_NE(error.find("max_volume_change: the repair of surface 'scalp' moved "), std::string::npos) << error;
  EXPECT_NE(error.find("Mesh with a smaller cell size"), std::string::npos) << error;
  h.net.setParameterText("bem", "max_volume_change", "0.05");
  ASSERT_TRUE(h.exec.execute(h.net).success) << h.exec.state("bem")->error << h.exec.state("cl")->error;
  const Report& r = h.report();
  for (const char* name : {"scalp", "outer_skull", "inner_skull"}) {
    SCOPED_TRACE(name);
    const std::string k = std::string("surface_") + name + "_";
    EXPECT_TRUE(std::get<bool>(*r.find(k + "closed_manifold_oriented")));
    EXPECT_EQ(r.number(k + "open_edges"), 0);
    EXPECT_EQ(r.number(k + "nonmanifold_edges"), 0);
    EXPECT_EQ(r.number(k + "nonmanifold_vertices"), 0);
    EXPECT_EQ(r.number(k + "misoriented_edges"), 0);
    EXPECT_EQ(r.number(k + "components"), 1);
    EXPECT_LE(r.number(k + "repair_moved_fraction"), 0.05);
    EXPECT_LT(std::abs(r.number(k + "volume_rel_difference")), r.number(k + "repair_moved_fraction") + 1e-12)
        << r.number(k + "repair_rounds") << " rounds, " << r.number(k + "repair_pinches") << " pinches, "
        << r.number(k + "repair_touches") << " touches, +" << r.number(k + "repair_added_mm3") << " -"
        << r.number(k + "repair_removed_mm3") << " of " << r.number(k + "materials_mm3");
    // The enclosed volume is the tissues' plus what the repair moved in, minus what it moved out.
    EXPECT_NEAR(r.number(k + "enclosed_mm3"),
                r.number(k + "materials_mm3") + r.number(k + "repair_added_mm3") - r.number(k + "repair_removed_mm3"),
                1e-9 * r.number(k + "materials_mm3"));
    EXPECT_GT(r.number(k + "enclosed_mm3"), 0.0); // outward
    EXPECT_TRUE(std::filesystem::exists(h.dir.file(std::string("head_") + name + ".off")));
  }
  EXPECT_GT(r.number("surface_scalp_repair_pinches") + r.number("surface_outer_skull_repair_pinches") +
                r.number("surface_inner_skull_repair_pinches"),
            0);
  EXPECT_EQ(std::get<std::string>(*r.find("surface_outer_skull_labels")), "2 3 4");
  EXPECT_EQ(std::get<bool>(*r.find("surface_scalp_holds_next")), true);
  EXPECT_EQ(std::get<bool>(*r.find("surface_outer_skull_holds_next")), true);
  EXPECT_EQ(r.number("surface_scalp_shared_vertices_with_next"), 0);
  EXPECT_EQ(r.number("surface_outer_skull_shared_vertices_with_next"), 0);
  EXPECT_GT(r.number("surface_scalp_enclosed_mm3"), r.number("surface_outer_skull_enclosed_mm3"));
  EXPECT_GT(r.number("surface_outer_skull_enclosed_mm3"), r.number("surface_inner_skull_enclosed_mm3"));
}

// Nets/bem_head.srn: the default head phantom's three surfaces, repaired (moving at most 0.1 % of
// a tissue's volume) and decimated to 5120 triangles, are closed, manifold, outward, nested without
// touching or crossing, and enclose their tissues' volume to 0.15 % (measured: the decimated inner
// skull -0.103 %, the others within 0.09 %, on default.srn's mesh); MNE-Python's make_bem_model
// (Debian python3-mne) takes them, and refuses them with inner and outer skull swapped.
// `radii`: the phantom's "scalp skull csf brain" radii in mm, or empty for the net's own.
namespace {
void expectBemHeadSurfacesPassTheirChecksAndMnes(const std::string& radii) {
  ASSERT_EQ(std::system("/usr/bin/python3 -c 'import mne' > /dev/null 2>&1"), 0)
      << "MNE-Python is missing: scripts/setup.sh installs it (Debian package python3-mne)";
  ModuleRegistry reg;
  registerStandardModules(reg);
  Network net = loadNetwork(std::string(TETFLOW_SOURCE_DIR) + "/Nets/bem_head.srn", reg);
  if (!radii.empty()) {
    std::istringstream in(radii);
    for (const char* name : {"radius", "skull_radius", "csf_radius", "brain_radius"}) {
      std::string r;
      in >> r;
      net.setParameterText("m1", name, r);
    }
  }
  test::TempDir dir;
  net.setParameterText("m4", "filename", dir.file("bem.surf"));
  Executor exec;
  ASSERT_TRUE(exec.execute(net).success) << exec.state("m4")->error << exec.state("m3")->error;
  const Report& r = exec.state("m4")->report;
  for (const char* name : {"outer_skin", "outer_skull", "inner_skull"}) {
    SCOPED_TRACE(name);
    const std::string k = std::string("surface_") + name + "_";
    EXPECT_TRUE(std::get<bool>(*r.find(k + "closed_manifold_oriented")));
    EXPECT_EQ(r.number(k + "components"), 1);
    EXPECT_EQ(r.number(k + "self_intersections"), 0);
    EXPECT_EQ(r.number(k + "triangles"), 5120);
    EXPECT_LE(r.number(k + "repair_moved_fraction"), 1e-3);
    EXPECT_LT(std::abs(r.number(k + "volume_rel_difference")), 1.5e-3);
    EXPECT_GT(r.number(k + "enclosed_mm3"), 0.0);
  }
  EXPECT_GT(r.number("surface_inner_skull_repair_pinches"), 0); // the one-voxel CSF does pinch
  for (const char* name : {"outer_skin", "outer_skull"}) {
    EXPECT_EQ(r.number(std::string("surface_") + name + "_shared_vertices_with_next"), 0) << name;
    EXPECT_EQ(r.number(std::string("surface_") + name + "_crossings_with_next"), 0) << name;
  }
  auto mne = [&](const std::string& inner, const std::string& outer) {
    std::filesystem::create_directories(dir.file("subjects/head/bem"));
    const auto copy = std::filesystem::copy_options::overwrite_existing;
    std::filesystem::copy_file(dir.file("bem_outer_skin.surf"), dir.file("subjects/head/bem/outer_skin.surf"), copy);
    std::filesystem::copy_file(dir.file("bem_" + outer + ".surf"), dir.file("subjects/head/bem/outer_skull.surf"), copy);
    std::filesystem::copy_file(dir.file("bem_" + inner + ".surf"), dir.file("subjects/head/bem/inner_skull.surf"), copy);
    const std::string log = dir.file("mne.txt");
    const int rc = std::system(("/usr/bin/python3 '" + std::string(TETFLOW_SOURCE_DIR) + "/Testing/Scripts/mne_bem_check.py' '" +
                                dir.file("subjects") + "' head > '" + log + "' 2>&1")
                                   .c_str());
    std::ifstream in(log);
    std::stringstream text;
    text << in.rdbuf();
    return std::pair(rc, text.str());
  };
  const auto [rc, out] = mne("inner_skull", "outer_skull");
  EXPECT_EQ(rc, 0) << out;
  EXPECT_NE(out.find("passed"), std::string::npos) << out;
  const auto [rcSwapped, outSwapped] = mne("outer_skull", "inner_skull");
  EXPECT_NE(rcSwapped, 0) << outSwapped;
  EXPECT_NE(outSwapped.find("MNE refused"), std::string::npos) << outSwapped;
}
} // namespace

// A study (Testing/Tiers.cmake): the net as shipped, on the 92 mm head phantom.
TEST(ExtractSurfacesModule, TheBemHeadNetsSurfacesPassTheirChecksAndMnes) { expectBemHeadSurfacesPassTheirChecksAndMnes(""); }

// In CI: the same net and checks on a smaller phantom with the same layers (6, 6 and 2 mm); 70 mm
// is about as small as 5120 triangles per surface keep the enclosed volumes within 0.1 % (at 64 mm
// the inner skull's is 0.11 % off).
TEST(ExtractSurfacesModule, ASmallerHeadsBemSurfacesPassTheirChecksAndMnes) {
  expectBemHeadSurfacesPassTheirChecksAndMnes("70 64 58 56");
}

TEST(ExtractSurfacesModule, BadParametersNameTheEntry) {
  HeadSurfaces h;
  h.net.setParameterText("bem", "surfaces", "inner: 3 9");
  h.exec.execute(h.net);
  EXPECT_NE(h.exec.state("bem")->error.find("label 9 does not occur in the mesh"), std::string::npos)
      << h.exec.state("bem")->error;
  h.net.setParameterText("bem", "surfaces", "inner: grey");
  h.exec.execute(h.net);
  EXPECT_NE(h.exec.state("bem")->error.find("'grey' is neither a label of the mesh nor one of its tissue names"),
            std::string::npos)
      << h.exec.state("bem")->error;
  h.net.setParameterText("bem", "surfaces", "just labels");
  h.exec.execute(h.net);
  EXPECT_NE(h.exec.state("bem")->error.find("expected 'name: labels'"), std::string::npos) << h.exec.state("bem")->error;
  h.net.setParameterText("bem", "surfaces", "");
  h.net.setParameterText("bem", "filename", h.dir.file("head.ply"));
  h.exec.execute(h.net);
  EXPECT_NE(h.exec.state("bem")->error.find("must end in .off, .stl, .vtp or .surf"), std::string::npos)
      << h.exec.state("bem")->error;
  EXPECT_FALSE(std::filesystem::exists(h.dir.file("head_outer.ply")));
}

} // namespace
