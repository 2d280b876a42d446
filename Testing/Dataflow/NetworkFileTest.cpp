#include <gtest/gtest.h>

#include <filesystem>

#include "Algorithms/IO/FileUtil.h"
#include "Dataflow/NetworkFile.h"
#include "TestModules.h"
#include "TestUtil.h"

using namespace tetflow;

namespace {
struct SrnFixture : ::testing::Test {
  ModuleRegistry reg;
  SrnFixture() { test::registerTestModules(reg); }

  std::vector<LoadProblem> problemsOf(const std::string& xml) {
    try {
      loadNetworkFromString(xml, "t.srn", ".", reg);
    } catch (const NetworkLoadError& e) {
      return e.problems();
    }
    ADD_FAILURE() << "expected a NetworkLoadError";
    return {};
  }

  static std::string wrap(const std::string& modules, const std::string& conns = "") {
    return "<?xml version=\"1.0\"?>\n<network version=\"tetflow-1\">\n<modules>\n" + modules +
           "</modules>\n<connections>\n" + conns + "</connections>\n</network>\n";
  }
};
} // namespace

TEST_F(SrnFixture, SaveLoadSaveGivesTheSameBytes) {
  Network net(reg);
  net.setNetworkNote("head model\nwith \"quotes\" & <brackets>");
  const auto p = net.addModule("CreatePhantom", "", 12.5, -3);
  const auto w = net.addModule("WriteVolume", "", 200, 40.25);
  net.setParameterText(p, "voxel_size", "0.1");
  net.setParameterText(p, "kind", "shell");
  net.setParameterText(w, "filename", "out dir/head & co.nrrd");
  net.setNote(w, "writes {the} result");
  net.connect(p, 0, w, 0);
  const auto n = net.addModule("Number", "m9");
  net.setParameterText(n, "value", "0.30000000000000004");
  const std::string first = saveNetworkToString(net);
  const Network back = loadNetworkFromString(first, "t.srn", ".", reg);
  const std::string second = saveNetworkToString(back);
  EXPECT_EQ(first, second);
  EXPECT_EQ(back.note(), net.note());
  EXPECT_EQ(back.requireModule("m2").note, "writes {the} result");
  EXPECT_EQ(std::get<double>(back.requireModule("m9").params.at("value")), 0.30000000000000004);
  EXPECT_EQ(back.requireModule("m1").x, 12.5);
  EXPECT_EQ(back.connections(), net.connections());
}

TEST_F(SrnFixture, SaveToFileIsAtomicAndReloads) {
  test::TempDir tmp;
  Network net(reg);
  net.addModule("CreatePhantom");
  saveNetwork(tmp.file("a.srn"), net);
  const Network back = loadNetwork(tmp.file("a.srn"), reg);
  EXPECT_EQ(back.baseDir(), tmp.path().string());
  EXPECT_THROW_MSG(saveNetwork(tmp.file("missing/a.srn"), net), InputError, "does not exist");
}

TEST_F(SrnFixture, PortsByNameAndBracesAreAccepted) {
  const Network net = loadNetworkFromString(
      wrap("<module id=\"a\" name=\"CreatePhantom\"><var name=\"voxel_size\" val=\"{3}\"/></module>\n"
           "<module id=\"b\" name=\"WriteVolume\"><var name=\"filename\" val=\"x.nrrd\"/></module>\n",
           "<connection id=\"c1\" from=\"a\" fromport=\"volume\" to=\"b\" toport=\"volume\"/>\n"),
      "t.srn", ".", reg);
  EXPECT_EQ(std::get<double>(net.requireModule("a").params.at("voxel_size")), 3.0);
  EXPECT_EQ(std::get<std::string>(net.requireModule("b").params.at("filename")), "x.nrrd");
  ASSERT_EQ(net.connections().size(), 1u);
  EXPECT_EQ(net.connections()[0].toPort, 0);
}

TEST_F(SrnFixture, EveryProblemIsListedWithLineAndModule) {
  const std::string xml = wrap(
      "<module id=\"m1\" name=\"CreatePhantom\">\n"                         // line 4
      "  <var name=\"voxel_size\" val=\"{-2}\"/>\n"                          // 5 bad value
      "  <var name=\"colour\" val=\"{red}\"/>\n"                             // 6 unknown param
      "</module>\n"
      "<module id=\"m2\" name=\"FrobnicateMesh\" package=\"SCIRun\"/>\n"    // 8 unknown module
      "<module id=\"m1\" name=\"Number\"/>\n"                                // 9 duplicate id
      "<module id=\"m3\" name=\"NeedsVolume\"/>\n"                           // 10
      "<module id=\"m4\" name=\"Number\"/>\n"                                // 11
      "<module id=\"m5\" name=\"Number\"/>\n"                                // 12
      "<module id=\"m6\" name=\"Number\"/>\n",                               // 13
      "<connection id=\"c1\" from=\"m4\" fromport=\"0\" to=\"m3\" toport=\"0\"/>\n"  // 16 type
      "<connection id=\"c2\" from=\"m4\" fromport=\"0\" to=\"m5\" toport=\"0\"/>\n"  // 17 ok
      "<connection id=\"c3\" from=\"m5\" fromport=\"0\" to=\"m4\" toport=\"0\"/>\n"  // 18 cycle
      "<connection id=\"c4\" from=\"m6\" fromport=\"0\" to=\"m5\" toport=\"0\"/>\n"  // 19 2nd wire
      "<connection id=\"c5\" from=\"m6\" fromport=\"9\" to=\"m5\" toport=\"1\"/>\n"  // 20 bad port
      "<connection id=\"c6\" from=\"m2\" fromport=\"0\" to=\"m5\" toport=\"1\"/>\n"  // 21 unknown mod
      "<connection id=\"c7\" from=\"m9\" fromport=\"0\" to=\"m5\" toport=\"1\"/>\n"  // 22 no module
  );
  const auto ps = problemsOf(xml);
  auto has = [&](int line, const std::string& id, const std::string& frag) {
    for (const auto& p : ps)
      if (p.line == line && p.moduleId == id && p.message.find(frag) != std::string::npos) return true;
    return false;
  };
  EXPECT_TRUE(has(5, "m1", "out of range")) << ps.size();
  EXPECT_TRUE(has(6, "m1", "no parameter 'colour'"));
  EXPECT_TRUE(has(8, "m2", "unknown module 'FrobnicateMesh' (package SCIRun)"));
  EXPECT_TRUE(has(9, "m1", "used twice"));
  EXPECT_TRUE(has(16, "", "type mismatch"));
  EXPECT_TRUE(has(18, "", "cycle"));
  EXPECT_TRUE(has(19, "", "already has a wire"));
  EXPECT_TRUE(has(20, "m6", "no output port '9'"));
  EXPECT_TRUE(has(22, "", "no module with id 'm9'"));
  // c6 refers to the unknown module m2, which is already reported: no extra problem for it.
  EXPECT_FALSE(has(21, "", "m2"));
  EXPECT_EQ(ps.size(), 9u);
}

TEST_F(SrnFixture, MalformedXmlNamesTheLine) {
  const auto ps = problemsOf("<?xml version=\"1.0\"?>\n<network>\n<modules>\n<module id=\"m1\" name=\"Number\">\n</modules>\n</network>\n");
  ASSERT_EQ(ps.size(), 1u);
  EXPECT_EQ(ps[0].line, 5);
  EXPECT_NE(ps[0].message.find("does not match <module>"), std::string::npos);
  EXPECT_EQ(problemsOf("").at(0).message, "malformed XML: no root element (empty or not an XML file)");
  EXPECT_NE(problemsOf("<html></html>").at(0).message.find("expected <network>"), std::string::npos);
  EXPECT_NE(problemsOf("<network a=\"x & y\"/>").at(0).message.find("&amp;"), std::string::npos);
  // 200 000 nested elements crashed the parser (stack overflow); now an error at the 257th level.
  std::string deep = "<network>\n";
  for (int i = 0; i < 200000; ++i) deep += "<a>";
  const auto d = problemsOf(deep);
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0].line, 2);
  EXPECT_NE(d[0].message.find("nested more than 256 deep"), std::string::npos) << d[0].message;
}

TEST_F(SrnFixture, TheRealSCIRunExampleListsAllItsUnknownModules) {
  const std::string path = std::string(TETFLOW_TEST_DATA) + "/scirun4-example.srn";
  try {
    loadNetwork(path, reg);
    FAIL() << "SCIRun's modules are not TetFlow's";
  } catch (const NetworkLoadError& e) {
    std::set<std::string> ids;
    for (const auto& p : e.problems())
      if (p.message.find("unknown module") != std::string::npos) {
        ids.insert(p.moduleId);
        EXPECT_GT(p.line, 0);
      }
    EXPECT_EQ(ids.size(), 20u); // m1 .. m20
    EXPECT_TRUE(ids.count("m1") && ids.count("m20"));
    EXPECT_NE(std::string(e.what()).find("scirun4-example.srn:6: module m1: unknown module 'ViewScene'"),
              std::string::npos)
        << e.what();
  }
}
