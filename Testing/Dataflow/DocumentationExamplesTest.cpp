// The examples of the README and the manual run (issue 51 item 5). A ```sh block right after a
// line `<!-- example -->` is an example: each of its commands is run from a fresh folder, with
// `build/Interface/tetflow` the CLI of this build and `Testing/Data/`, `Nets/` the repository's
// (links in that folder), and must exit 0. When the next block is a ```text block right after `<!-- example output -->`,
// every line of it must appear in what the commands print, compared by its first words: the
// first two (a module line's id and name, or "mesh: cell"), and a module line's status too; so a
// renamed module, a changed message or a failing step shows, while times and counts may differ.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "TestUtil.h"

namespace fs = std::filesystem;

namespace {

struct DocExample {
  std::string page;
  int line = 0;
  std::vector<std::string> commands;
  std::vector<std::string> expected;
};

std::vector<DocExample> examplesOf(const fs::path& page, const std::string& name) {
  const auto lines = tetflow::test::readTextLines(page);
  std::vector<DocExample> out;
  auto block = [&](size_t& i, const std::string& fence, std::vector<std::string>& into) {
    if (i >= lines.size() || lines[i] != fence) return false;
    for (++i; i < lines.size() && lines[i].rfind("```", 0) != 0; ++i) into.push_back(lines[i]);
    ++i;
    return true;
  };
  for (size_t i = 0; i < lines.size(); ++i) {
    if (lines[i] != "<!-- example -->") continue;
    DocExample ex;
    ex.page = name;
    ex.line = int(i) + 1;
    size_t j = i + 1;
    std::vector<std::string> raw;
    if (!block(j, "```sh", raw)) {
      ADD_FAILURE() << name << ":" << ex.line << ": <!-- example --> is not followed by a ```sh block";
      continue;
    }
    for (auto l : raw) {
      if (const auto c = l.find("  #"); c != std::string::npos) l.erase(c);
      while (!l.empty() && l.back() == ' ') l.pop_back();
      if (!l.empty() && l[0] != '#') ex.commands.push_back(l);
    }
    while (j < lines.size() && lines[j].empty()) ++j;
    if (j < lines.size() && lines[j] == "<!-- example output -->") {
      ++j;
      if (!block(j, "```text", ex.expected))
        ADD_FAILURE() << name << ":" << j << ": <!-- example output --> is not followed by a ```text block";
    }
    out.push_back(ex);
    i = j - 1;
  }
  return out;
}

std::vector<std::string> exampleWords(const std::string& line) {
  std::istringstream in(line);
  std::vector<std::string> w;
  for (std::string x; in >> x;) w.push_back(x);
  return w;
}

// The words a line is recognised by: two, and a module line's status (its third word).
std::vector<std::string> exampleKey(const std::string& line) {
  auto w = exampleWords(line);
  const bool moduleLine = !w.empty() && w[0].size() > 1 && w[0][0] == 'm' &&
                          w[0].find_first_not_of("0123456789", 1) == std::string::npos;
  w.resize(std::min(w.size(), size_t(moduleLine ? 3 : 2)));
  return w;
}

} // namespace

TEST(DocumentationExamples, EveryMarkedExampleRunsAndPrintsWhatItsPageShows) {
  const fs::path root(TETFLOW_SOURCE_DIR);
  std::vector<std::pair<fs::path, std::string>> pages{{root / "README.md", "README.md"}};
  for (const auto& e : fs::directory_iterator(root / "docs"))
    if (e.path().extension() == ".md") pages.emplace_back(e.path(), "docs/" + e.path().filename().string());
  const std::string cli = TETFLOW_CLI;
  int examples = 0;
  for (const auto& [path, name] : pages) {
    for (const auto& ex : examplesOf(path, name)) {
      ++examples;
      // A folder that looks like the repository to the commands: its Testing/Data, its Nets and
      // this build's CLI as build/Interface/tetflow; what the commands write stays in it.
      tetflow::test::TempDir dir;
      fs::create_directories(dir.path() / "Testing");
      fs::create_directories(dir.path() / "build" / "Interface");
      fs::create_directory_symlink(root / "Testing" / "Data", dir.path() / "Testing" / "Data");
      fs::create_directory_symlink(root / "Nets", dir.path() / "Nets");
      fs::create_symlink(cli, dir.path() / "build" / "Interface" / "tetflow");
      std::string output;
      for (const auto& c : ex.commands) {
        const auto r = tetflow::test::runShell("cd '" + dir.path().string() + "' && " + c + " 2>&1");
        output += r.out;
        ASSERT_EQ(r.code, 0) << ex.page << ":" << ex.line << ": `" << c << "` exited " << r.code << ":\n" << r.out;
      }
      std::vector<std::vector<std::string>> printed;
      std::istringstream in(output);
      for (std::string l; std::getline(in, l);) printed.push_back(exampleWords(l));
      for (const auto& e : ex.expected) {
        const auto key = exampleKey(e);
        if (key.empty()) continue;
        bool found = false;
        for (const auto& w : printed)
          found = found || (w.size() >= key.size() && std::equal(key.begin(), key.end(), w.begin()));
        EXPECT_TRUE(found) << ex.page << ":" << ex.line << ": the page shows\n  " << e
                           << "\nbut the example printed no line starting with those words:\n" << output;
      }
    }
  }
  EXPECT_GE(examples, 4);
}
