// The README and the manual in docs/ (issue 51): every relative link and image points to a file
// of the repository, every #anchor to a heading of its page (GitHub's heading ids), the index
// lists every page, and the README stays a few screens.
#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "TestUtil.h"

namespace fs = std::filesystem;

namespace {

const fs::path kDocsRoot = fs::path(TETFLOW_SOURCE_DIR);

// GitHub's heading id: lower case; letters, digits, spaces, '-' and '_' kept (the headings here
// have no non-ASCII letters: their non-ASCII characters are symbols, which GitHub drops);
// spaces become '-'; a repeated id gets -1, -2, ...
std::string headingId(const std::string& heading) {
  std::string id;
  for (unsigned char c : heading) {
    if (std::isalnum(c) && c < 128) id += char(std::tolower(c));
    else if (c == ' ') id += '-';
    else if (c == '-' || c == '_') id += char(c);
  }
  return id;
}

// Lines outside fenced code blocks.
std::vector<std::pair<int, std::string>> proseLines(const fs::path& p) {
  std::vector<std::pair<int, std::string>> out;
  bool fence = false;
  int n = 0;
  for (const auto& l : tetflow::test::readTextLines(p)) {
    ++n;
    if (l.rfind("```", 0) == 0) {
      fence = !fence;
      continue;
    }
    if (!fence) out.emplace_back(n, l);
  }
  return out;
}

std::set<std::string> headingIds(const fs::path& p) {
  std::set<std::string> ids;
  std::map<std::string, int> seen;
  static const std::regex heading(R"(^#{1,6} (.*)$)");
  for (const auto& [n, l] : proseLines(p)) {
    std::smatch m;
    if (!std::regex_match(l, m, heading)) continue;
    std::string base = headingId(m[1].str());
    const int k = seen[base]++;
    ids.insert(k == 0 ? base : base + "-" + std::to_string(k));
  }
  return ids;
}

std::string withoutCodeSpans(const std::string& l) {
  std::string out;
  bool code = false;
  for (char c : l) {
    if (c == '`') code = !code;
    else if (!code) out += c;
  }
  return out;
}

std::vector<fs::path> documentationPages() {
  std::vector<fs::path> pages{kDocsRoot / "README.md"};
  for (const auto& e : fs::directory_iterator(kDocsRoot / "docs"))
    if (e.path().extension() == ".md") pages.push_back(e.path());
  std::sort(pages.begin() + 1, pages.end());
  return pages;
}

} // namespace

TEST(Documentation, EveryRelativeLinkAndAnchorResolves) {
  static const std::regex link(R"(\]\(([^)\s]+)\))");
  int links = 0, anchors = 0;
  std::map<fs::path, std::set<std::string>> ids;
  auto idsOf = [&](const fs::path& p) -> const std::set<std::string>& {
    auto it = ids.find(p);
    if (it == ids.end()) it = ids.emplace(p, headingIds(p)).first;
    return it->second;
  };
  for (const auto& page : documentationPages()) {
    const std::string name = fs::relative(page, kDocsRoot).string();
    for (const auto& [n, line] : proseLines(page)) {
      const std::string text = withoutCodeSpans(line);
      for (std::sregex_iterator it(text.begin(), text.end(), link), end; it != end; ++it) {
        const std::string target = (*it)[1].str();
        if (target.find("://") != std::string::npos || target.rfind("mailto:", 0) == 0) continue;
        ++links;
        const auto hash = target.find('#');
        const std::string path = target.substr(0, hash);
        const fs::path file = path.empty() ? page : (page.parent_path() / path).lexically_normal();
        if (!fs::exists(file)) {
          ADD_FAILURE() << name << ":" << n << ": link to " << target << ": no file " << file.string();
          continue;
        }
        if (hash == std::string::npos) continue;
        ++anchors;
        const std::string anchor = target.substr(hash + 1);
        if (file.extension() != ".md") {
          ADD_FAILURE() << name << ":" << n << ": anchor #" << anchor << " into a file that is not Markdown";
          continue;
        }
        if (!idsOf(file).count(anchor))
          ADD_FAILURE() << name << ":" << n << ": link to " << target << ": " << file.filename().string()
                        << " has no heading with the id '" << anchor << "'";
      }
    }
  }
  EXPECT_GT(links, 30);  // the README and the index link every page
  EXPECT_GT(anchors, 10);
}

TEST(Documentation, TheIndexListsEveryPageAndTheReadmeLinksTheIndex) {
  const std::string index = tetflow::test::readText((kDocsRoot / "docs" / "README.md").string());
  for (const auto& page : documentationPages()) {
    if (page.parent_path().filename() != "docs" || page.filename() == "README.md") continue;
    EXPECT_NE(index.find("](" + page.filename().string() + ")"), std::string::npos)
        << "docs/README.md does not link " << page.filename().string();
  }
  const std::string readme = tetflow::test::readText((kDocsRoot / "README.md").string());
  EXPECT_NE(readme.find("](docs/README.md)"), std::string::npos);
}

TEST(Documentation, ReadmeIsAFewScreens) {
  const auto lines = tetflow::test::readTextLines(kDocsRoot / "README.md").size();
  EXPECT_LE(lines, 400u) << "README.md has " << lines << " lines; the manual is docs/ (issue 51)";
  EXPECT_GT(lines, 60u);
}

TEST(Documentation, HeadingIdsFollowGitHub) {
  EXPECT_EQ(headingId("Mesh improvement: every tet in [10°, 160°]"), "mesh-improvement-every-tet-in-10-160");
  EXPECT_EQ(headingId("Quality → conditioning → iterations"), "quality--conditioning--iterations");
  EXPECT_EQ(headingId("Node editor (tetflow-gui)"), "node-editor-tetflow-gui");
  EXPECT_EQ(headingId("PETSc/MPI: solver_backend = petsc"), "petscmpi-solver_backend--petsc");
}

// Every figure the README or the manual quotes comes from a results file (issue 51 item 4): each
// results file it names exists, and each results file's first line names the benchmark script or
// program of Testing/Benchmarks/ that writes it.
TEST(Documentation, QuotedResultsFilesExistAndNameTheirCommand) {
  const fs::path bench = kDocsRoot / "Testing" / "Benchmarks";
  static const std::regex quoted(R"(results/([A-Za-z0-9_]+\.txt))");
  int quotes = 0;
  for (const auto& page : documentationPages()) {
    int n = 0;
    for (const auto& line : tetflow::test::readTextLines(page)) {
      ++n;
      for (std::sregex_iterator it(line.begin(), line.end(), quoted), end; it != end; ++it) {
        ++quotes;
        EXPECT_TRUE(fs::exists(bench / "results" / (*it)[1].str()))
            << fs::relative(page, kDocsRoot).string() << ":" << n << " quotes results/" << (*it)[1].str()
            << ", which does not exist";
      }
    }
  }
  EXPECT_GT(quotes, 10);
  int files = 0;
  for (const auto& e : fs::directory_iterator(bench / "results")) {
    if (e.path().extension() != ".txt") continue;
    ++files;
    const auto lines = tetflow::test::readTextLines(e.path());
    ASSERT_FALSE(lines.empty()) << e.path().string();
    std::string word;
    std::istringstream(lines.front().rfind("# ", 0) == 0 ? lines.front().substr(2) : std::string()) >> word;
    while (!word.empty() && (word.back() == ':' || word.back() == ',')) word.pop_back();
    const fs::path stem = fs::path(word).stem();
    const bool named = !word.empty() && (fs::exists(bench / (stem.string() + ".sh")) ||
                                         fs::exists(bench / (stem.string() + ".cpp")) ||
                                         fs::exists(bench / (stem.string() + ".py")));
    EXPECT_TRUE(named) << "results/" << e.path().filename().string()
                       << ": its first line should start with '# ' and the benchmark that writes it "
                          "(a .sh, .cpp or .py of Testing/Benchmarks/); it is: "
                       << lines.front();
  }
  EXPECT_GT(files, 10);
}
