// docs/modules.md is generated from the registry (issue 51 item 3): the committed page must be
// exactly what the code generates, list every module, port, parameter and enum value, and its
// links must land on its headings.
#include <gtest/gtest.h>

#include <set>
#include <sstream>

#include "Dataflow/ModuleReference.h"
#include "Modules/StandardModules.h"
#include "TestUtil.h"

using namespace tetflow;

namespace {

std::string generatedReference() {
  ModuleRegistry reg;
  registerStandardModules(reg);
  return moduleReferenceMarkdown(reg);
}

std::vector<std::string> referenceLines(const std::string& s) {
  std::vector<std::string> v;
  std::istringstream in(s);
  for (std::string l; std::getline(in, l);) v.push_back(l);
  return v;
}

} // namespace

TEST(ModuleReference, CommittedPageMatchesTheCode) {
#ifdef TETFLOW_NO_OCCT
  GTEST_SKIP() << "built without OpenCASCADE: the CAD modules are not registered";
#endif
  const std::string path = std::string(TETFLOW_SOURCE_DIR) + "/docs/modules.md";
  const std::string committed = test::readText(path);
  const std::string generated = generatedReference();
  if (committed == generated) return;
  const auto a = referenceLines(committed), b = referenceLines(generated);
  size_t i = 0;
  while (i < a.size() && i < b.size() && a[i] == b[i]) ++i;
  ADD_FAILURE() << path << " differs from the code at line " << i + 1 << ":\n  committed: "
                << (i < a.size() ? a[i] : "(end)") << "\n  generated: " << (i < b.size() ? b[i] : "(end)")
                << "\nregenerate it with: build/Interface/tetflow describe --markdown docs/modules.md";
}

TEST(ModuleReference, ListsEveryModulePortParameterAndChoice) {
  ModuleRegistry reg;
  registerStandardModules(reg);
  const std::string page = moduleReferenceMarkdown(reg);
  ASSERT_GE(reg.all().size(), 15u);
  for (const ModuleInfo* m : reg.all()) {
    const size_t at = page.find(std::string("\n### ").append(m->name).append("\n"));
    ASSERT_NE(at, std::string::npos) << m->name;
    const size_t end = page.find("\n### ", at + 1);
    const std::string section = page.substr(at, end == std::string::npos ? std::string::npos : end - at);
    auto quoted = [](const std::string& x) { return std::string("`").append(x).append("`"); };
    for (const auto& p : m->inputs) EXPECT_NE(section.find(quoted(p.name)), std::string::npos) << m->name << " input " << p.name;
    for (const auto& p : m->outputs) EXPECT_NE(section.find(quoted(p.name)), std::string::npos) << m->name << " output " << p.name;
    for (const auto& p : m->params) {
      EXPECT_NE(section.find(std::string("| ").append(quoted(p.name)).append(" |")), std::string::npos) << m->name << "." << p.name;
      for (const auto& c : p.choices) EXPECT_NE(section.find(quoted(c)), std::string::npos) << m->name << "." << p.name << " = " << c;
    }
  }
}

TEST(ModuleReference, EveryLinkLandsOnAHeading) {
  const std::string page = generatedReference();
  std::set<std::string> anchors;
  for (const auto& l : referenceLines(page))
    if (l.rfind("#", 0) == 0) anchors.insert(markdownAnchor(l.substr(l.find(' ') + 1)));
  size_t links = 0;
  for (size_t at = page.find("](#"); at != std::string::npos; at = page.find("](#", at + 1)) {
    const size_t close = page.find(')', at);
    const std::string anchor = page.substr(at + 3, close - at - 3);
    EXPECT_TRUE(anchors.count(anchor)) << "#" << anchor;
    ++links;
  }
  EXPECT_GE(links, 15u);
  EXPECT_EQ(markdownAnchor("AssembleFEMPoisson"), "assemblefempoisson");
  EXPECT_EQ(markdownAnchor("FEM and solvers: which one"), "fem-and-solvers-which-one");
}

TEST(ModuleReference, TheCommandWritesThePageOrNamesTheFileItCannotWrite) {
  test::TempDir dir;
  const std::string out = dir.file("modules.md");
  auto r = test::runShell(std::string(TETFLOW_CLI) + " describe --markdown " + out + " 2>&1");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(test::readText(out), generatedReference());
  r = test::runShell(std::string(TETFLOW_CLI) + " describe --markdown " + dir.file("no/such/dir/m.md") + " 2>&1");
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.out.find("no/such/dir/m.md"), std::string::npos) << r.out;
  r = test::runShell(std::string(TETFLOW_CLI) + " describe --markdown a.md b.md 2>&1");
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.out.find("at most one output file"), std::string::npos) << r.out;
}
