// Gmsh MSH meshes: MSH 4.1 ASCII and MSH 2.2 ASCII / binary written, MSH 2.x and 4.1 (ASCII or
// binary) read. See GmshIO.h for what is written and read, and MeshIO.h for the contracts.
//
// The layouts, as Gmsh's reference manual ("MSH file format") gives them:
//   2.2  $Nodes: n, then n x "tag x y z" (binary: int tag, 3 doubles).
//        $Elements: n, then n x "tag type ntags tag.. node.." (binary: blocks of a header
//        int[3] {type, count, ntags} followed by count x int[1 + ntags + nodes]).
//   4.1  $Entities: counts of points, curves, surfaces, volumes, then each entity with its
//        physical tags (and, but for points, its bounding box and bounding entities).
//        $Nodes: blocks "dim entity parametric count", the block's node tags, then coordinates.
//        $Elements: blocks "dim entity type count", then count x "tag node..".
//        Binary: counts and tags of nodes and elements are size_t (the data size, 8), entity
//        dims, tags and types int, coordinates double.
// A binary file states its byte order by the int 1 after "$MeshFormat"'s line.
#include "GmshIO.h"

#include <algorithm>
#include <array>
#include <cstring>
#include <limits>
#include <map>
#include <numeric>
#include <sstream>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "../Core/Errors.h"
#include "../Core/Progress.h"
#include "FileUtil.h"
#include "MeshFileText.h"

namespace tetflow {

using namespace mesh_io;

namespace {

constexpr int kTet4 = 4; // Gmsh's 4-node tetrahedron

// Gmsh element types: nodes per element and dimension (Gmsh's reference manual, "MSH file
// format"); 0 nodes for a type not listed.
struct ElementType {
  int nodes = 0, dim = 0;
  const char* name = "";
};
ElementType elementType(int64_t type) {
  switch (type) {
  case 1: return {2, 1, "2-node line"};
  case 2: return {3, 2, "3-node triangle"};
  case 3: return {4, 2, "4-node quadrangle"};
  case 4: return {4, 3, "4-node tetrahedron"};
  case 5: return {8, 3, "8-node hexahedron"};
  case 6: return {6, 3, "6-node prism"};
  case 7: return {5, 3, "5-node pyramid"};
  case 8: return {3, 1, "3-node line"};
  case 9: return {6, 2, "6-node triangle"};
  case 10: return {9, 2, "9-node quadrangle"};
  case 11: return {10, 3, "10-node (second-order) tetrahedron"};
  case 12: return {27, 3, "27-node hexahedron"};
  case 13: return {18, 3, "18-node prism"};
  case 14: return {14, 3, "14-node pyramid"};
  case 15: return {1, 0, "1-node point"};
  case 16: return {8, 2, "8-node quadrangle"};
  case 17: return {20, 3, "20-node hexahedron"};
  case 18: return {15, 3, "15-node prism"};
  case 19: return {13, 3, "13-node pyramid"};
  case 20: return {9, 2, "9-node triangle"};
  case 21: return {10, 2, "10-node triangle"};
  case 22: return {12, 2, "12-node triangle"};
  case 23: return {15, 2, "15-node triangle"};
  case 24: return {15, 2, "15-node triangle"};
  case 25: return {21, 2, "21-node triangle"};
  case 26: return {4, 1, "4-node line"};
  case 27: return {5, 1, "5-node line"};
  case 28: return {6, 1, "6-node line"};
  case 29: return {20, 3, "20-node tetrahedron"};
  case 30: return {35, 3, "35-node tetrahedron"};
  case 31: return {56, 3, "56-node tetrahedron"};
  case 92: return {64, 3, "64-node hexahedron"};
  case 93: return {125, 3, "125-node hexahedron"};
  default: return {};
  }
}

// ------------------------------------------------------------------------------------------------
// Writing
// ------------------------------------------------------------------------------------------------

std::string defaultMaterialName(int64_t label) { return "material_" + std::to_string(label); }

// A name as it goes between Gmsh's double quotes: no quote, no line break.
std::string storableName(std::string n) {
  for (char& c : n) {
    if (c == '"') c = '\'';
    if (c == '\n' || c == '\r') c = ' ';
  }
  return n;
}

struct Group {
  int32_t label = 0;
  int64_t physTag = 0;
  int entityTag = 0;
  std::string name;
  std::vector<size_t> tets; // 4.1 only
  Vec3 lo{}, hi{};          // 4.1 only
};

// One physical volume group per material, in ascending label order.
std::vector<Group> physicalGroups(const std::string& path, const TetMesh& m, bool collectTets) {
  std::map<int32_t, std::vector<size_t>> byLabel;
  if (collectTets) {
    for (size_t t = 0; t < m.numTets(); ++t) byLabel[m.materials[t]].push_back(t);
  } else {
    for (int32_t L : presentMaterials(m)) byLabel[L];
  }
  int64_t maxLabel = 0;
  for (const auto& [label, tets] : byLabel) maxLabel = std::max<int64_t>(maxLabel, label);
  int64_t nextTag = maxLabel + 1;
  std::vector<Group> groups;
  for (auto& [label, tets] : byLabel) {
    Group g;
    g.label = label;
    g.physTag = label >= 1 ? label : nextTag++;
    if (g.physTag > std::numeric_limits<int32_t>::max())
      throw InputError(path + ": cannot assign a Gmsh physical tag to material " + std::to_string(label) +
                       " (labels too large)");
    g.entityTag = static_cast<int>(groups.size()) + 1;
    const auto named = m.materialNames.find(label);
    g.name = storableName(named != m.materialNames.end() && !named->second.empty() ? named->second
                                                                                  : defaultMaterialName(label));
    g.tets = std::move(tets);
    if (collectTets) {
      g.lo = {std::numeric_limits<double>::max(), std::numeric_limits<double>::max(),
              std::numeric_limits<double>::max()};
      g.hi = {std::numeric_limits<double>::lowest(), std::numeric_limits<double>::lowest(),
              std::numeric_limits<double>::lowest()};
      for (size_t t : g.tets)
        for (int32_t v : m.tets[t])
          for (int a = 0; a < 3; ++a) {
            g.lo[a] = std::min(g.lo[a], m.points[static_cast<size_t>(v)][a]);
            g.hi[a] = std::max(g.hi[a], m.points[static_cast<size_t>(v)][a]);
          }
    }
    groups.push_back(std::move(g));
  }
  return groups;
}

void writePhysicalNames(TextSink& s, const std::vector<Group>& groups) {
  // Like Gmsh itself, a section that would be empty is left out.
  if (groups.empty()) return;
  s << "$PhysicalNames\n";
  s.num(static_cast<int64_t>(groups.size())) << '\n';
  for (const Group& g : groups) {
    s << "3 ";
    s.num(g.physTag) << " \"" << g.name << "\"\n";
  }
  s << "$EndPhysicalNames\n";
}

void writeGmsh41(const std::string& path, const TetMesh& m) {
  const std::vector<Group> groups = physicalGroups(path, m, true);
  const int64_t np = static_cast<int64_t>(m.numPoints());
  const int64_t nt = static_cast<int64_t>(m.numTets());
  // Nodes must sit on an entity: with points but no tets, add one volume without physical group.
  const bool extraEntity = groups.empty() && np > 0;

  AtomicOutputFile out(path);
  {
    TextSink s(out.stream());
    s << "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n";
    writePhysicalNames(s, groups);

    s << "$Entities\n0 0 0 ";
    s.num(static_cast<int64_t>(groups.size() + (extraEntity ? 1 : 0))) << '\n';
    auto box = [&](const Vec3& lo, const Vec3& hi) {
      for (double v : lo) s.real(v) << ' ';
      for (double v : hi) s.real(v) << ' ';
    };
    for (const Group& g : groups) {
      s.num(g.entityTag) << ' ';
      box(g.lo, g.hi);
      s << "1 ";
      s.num(g.physTag) << " 0\n"; // one physical tag, no bounding surfaces
    }
    if (extraEntity) {
      Vec3 lo = m.points[0], hi = m.points[0];
      for (const Vec3& p : m.points)
        for (int a = 0; a < 3; ++a) {
          lo[a] = std::min(lo[a], p[a]);
          hi[a] = std::max(hi[a], p[a]);
        }
      s << "1 ";
      box(lo, hi);
      s << "0 0\n";
    }
    s << "$EndEntities\n";

    // All nodes in one block on the first volume entity; node tag = index + 1. Without points
    // there are no $Nodes and $Elements (as Gmsh writes it).
    if (np > 0) {
      s << "$Nodes\n1 ";
      s.num(np) << " 1 ";
      s.num(np) << "\n3 1 0 ";
      s.num(np) << '\n';
      for (int64_t i = 1; i <= np; ++i) s.num(i) << '\n';
      for (const Vec3& p : m.points) {
        s.real(p[0]) << ' ';
        s.real(p[1]) << ' ';
        s.real(p[2]) << '\n';
      }
      s << "$EndNodes\n";

      // One block per material entity, element type 4, tags 1..nt in block order.
      s << "$Elements\n";
      s.num(static_cast<int64_t>(groups.size())) << ' ';
      s.num(nt) << ' ';
      s.num(nt > 0 ? 1 : 0) << ' ';
      s.num(nt) << '\n';
      int64_t tag = 1;
      for (const Group& g : groups) {
        s << "3 ";
        s.num(g.entityTag) << " 4 ";
        s.num(static_cast<int64_t>(g.tets.size())) << '\n';
        for (size_t t : g.tets) {
          s.num(tag++);
          for (int32_t v : m.tets[t]) {
            s << ' ';
            s.num(static_cast<int64_t>(v) + 1);
          }
          s << '\n';
        }
      }
      s << "$EndElements\n";
    }
  }
  out.commit();
}

void writeGmsh22(const std::string& path, const TetMesh& m, bool binary) {
  const std::vector<Group> groups = physicalGroups(path, m, false);
  const int64_t np = static_cast<int64_t>(m.numPoints());
  const int64_t nt = static_cast<int64_t>(m.numTets());
  if (np >= std::numeric_limits<int32_t>::max() || nt >= std::numeric_limits<int32_t>::max())
    throw InputError(path + ": too many nodes or elements for MSH 2.2's 32-bit tags; write MSH 4.1");
  // Per tet: physical tag and elementary (entity) tag of its material.
  std::map<int32_t, std::pair<int32_t, int32_t>> tagsOf;
  for (const Group& g : groups) tagsOf[g.label] = {static_cast<int32_t>(g.physTag), g.entityTag};
  int32_t lastLabel = 0;
  std::pair<int32_t, int32_t> lastTags{0, 0};
  auto tags = [&](size_t t) {
    if (t == 0 || m.materials[t] != lastLabel) lastTags = tagsOf.at(lastLabel = m.materials[t]);
    return lastTags;
  };

  AtomicOutputFile out(path);
  {
    TextSink s(out.stream());
    s << (binary ? "$MeshFormat\n2.2 1 8\n" : "$MeshFormat\n2.2 0 8\n");
    if (binary) {
      const int32_t one = 1; // the byte order mark
      s.bytes(&one, 4) << '\n';
    }
    s << "$EndMeshFormat\n";
    writePhysicalNames(s, groups);

    s << "$Nodes\n";
    s.num(np) << '\n';
    if (binary) {
      char rec[4 + 3 * 8];
      for (int64_t i = 0; i < np; ++i) {
        const int32_t tag = static_cast<int32_t>(i + 1);
        std::memcpy(rec, &tag, 4);
        std::memcpy(rec + 4, m.points[static_cast<size_t>(i)].data(), 3 * 8);
        s.bytes(rec, sizeof rec);
      }
      s << '\n';
    } else {
      for (int64_t i = 0; i < np; ++i) {
        const Vec3& p = m.points[static_cast<size_t>(i)];
        s.num(i + 1) << ' ';
        s.real(p[0]) << ' ';
        s.real(p[1]) << ' ';
        s.real(p[2]) << '\n';
      }
    }
    s << "$EndNodes\n$Elements\n";
    s.num(nt) << '\n';
    if (binary) {
      if (nt > 0) {
        const int32_t header[3] = {kTet4, static_cast<int32_t>(nt), 2}; // one block, two tags each
        s.bytes(header, sizeof header);
      }
      int32_t rec[7];
      for (int64_t t = 0; t < nt; ++t) {
        const auto [phys, entity] = tags(static_cast<size_t>(t));
        rec[0] = static_cast<int32_t>(t + 1);
        rec[1] = phys;
        rec[2] = entity;
        for (int k = 0; k < 4; ++k) rec[3 + k] = m.tets[static_cast<size_t>(t)][static_cast<size_t>(k)] + 1;
        s.bytes(rec, sizeof rec);
      }
      s << '\n';
    } else {
      for (int64_t t = 0; t < nt; ++t) {
        const auto [phys, entity] = tags(static_cast<size_t>(t));
        s.num(t + 1) << " 4 2 ";
        s.num(phys) << ' ';
        s.num(entity);
        for (int32_t v : m.tets[static_cast<size_t>(t)]) {
          s << ' ';
          s.num(static_cast<int64_t>(v) + 1);
        }
        s << '\n';
      }
    }
    s << "$EndElements\n";
  }
  out.commit();
}

// ------------------------------------------------------------------------------------------------
// Reading
// ------------------------------------------------------------------------------------------------

class MshReader {
public:
  explicit MshReader(const std::string& path) : path_(path), data_(readFileBytes(path)) {}

  TetMesh run() {
    if (token() != "$MeshFormat")
      fail("not a Gmsh MSH file: it does not start with $MeshFormat (MSH 1 files, which start "
           "with $NOD, are not read)");
    readFormat();
    bool sawNodes = false, sawElements = false;
    for (std::string_view t = nextToken(); !t.empty(); t = nextToken()) {
      if (t[0] != '$') fail("expected a section such as $Nodes, found '" + std::string(t) + "'");
      const std::string name(t.substr(1));
      section_ = name;
      if (name == "PhysicalNames") {
        readPhysicalNames();
      } else if (name == "Entities") {
        readEntities();
      } else if (name == "PartitionedEntities") {
        fail("partitioned MSH files are not read; save the mesh unpartitioned in Gmsh");
      } else if (name == "Nodes") {
        if (sawNodes) fail("a second $Nodes section");
        sawNodes = true;
        major_ == 4 ? readNodes4() : readNodes2();
        mapNodeTags();
      } else if (name == "Elements") {
        if (sawElements) fail("a second $Elements section");
        if (!sawNodes) fail("$Elements comes before $Nodes");
        sawElements = true;
        major_ == 4 ? readElements4() : readElements2();
      } else {
        skipSection(name);
        continue;
      }
      expect("$End" + name);
    }
    return finish();
  }

private:
  // ---- cursor ----
  [[noreturn]] void fail(const std::string& problem) const { failAt(pos_, problem); }
  [[noreturn]] void failAt(size_t at, const std::string& problem) const {
    std::ostringstream m;
    if (binary_ && inBinaryData_) {
      m << path_ << ", byte " << at;
    } else {
      const size_t line = 1 + static_cast<size_t>(std::count(data_.begin(),
                                                             data_.begin() + static_cast<std::ptrdiff_t>(std::min(at, data_.size())), '\n'));
      m << path_ << ", line " << line;
    }
    if (!section_.empty()) m << " ($" << section_ << ")";
    m << ": " << problem;
    throw InputError(m.str());
  }
  static bool space(char c) { return c == ' ' || c == '\n' || c == '\r' || c == '\t' || c == '\v' || c == '\f'; }
  // The next whitespace-separated token; empty at the end of the file.
  std::string_view nextToken() {
    while (pos_ < data_.size() && space(data_[pos_])) ++pos_;
    const size_t start = pos_;
    while (pos_ < data_.size() && !space(data_[pos_])) ++pos_;
    return {data_.data() + start, pos_ - start};
  }
  std::string_view token() {
    const std::string_view t = nextToken();
    if (t.empty()) fail("the file ends inside the section (truncated file?)");
    return t;
  }
  void expect(const std::string& want) {
    const size_t at = pos_;
    const std::string_view t = nextToken();
    if (t != want)
      failAt(at, "expected " + want + (t.empty() ? std::string(", but the file ends (truncated file?)")
                                                 : ", found '" + std::string(t.substr(0, 40)) + "'"));
  }
  int64_t integer(const char* what) {
    std::string_view t = token();
    int64_t v = 0;
    auto r = std::from_chars(t.data(), t.data() + t.size(), v);
    if (r.ec != std::errc() || r.ptr != t.data() + t.size())
      fail(std::string("expected an integer ") + what + ", found '" + std::string(t.substr(0, 40)) + "'");
    return v;
  }
  double real(const char* what) {
    std::string_view t = token();
    double v = 0;
    auto r = std::from_chars(t.data(), t.data() + t.size(), v);
    if (r.ec != std::errc() || r.ptr != t.data() + t.size())
      fail(std::string("expected a number ") + what + ", found '" + std::string(t.substr(0, 40)) + "'");
    return v;
  }
  // A count of items of at least `minBytes` each, refused when the rest of the file cannot hold it.
  int64_t count(int64_t v, size_t minBytes, const char* what) {
    if (v < 0) fail(std::string("negative ") + what);
    if (static_cast<uint64_t>(v) > (data_.size() - std::min(pos_, data_.size())) / minBytes)
      fail(std::string("announces ") + std::to_string(v) + " " + what +
           ", more than the rest of the file can hold (damaged or truncated file?)");
    return v;
  }
  template <class T> T bin() {
    if (data_.size() - std::min(pos_, data_.size()) < sizeof(T))
      fail("the file ends inside the section's binary data (truncated file?)");
    char b[sizeof(T)];
    std::memcpy(b, data_.data() + pos_, sizeof(T));
    if (swap_) std::reverse(b, b + sizeof(T));
    pos_ += sizeof(T);
    T v;
    std::memcpy(&v, b, sizeof(T));
    return v;
  }
  // 4.1: a size_t field (8 bytes) in binary, a token in ASCII.
  int64_t size4(const char* what) {
    if (!binary_) return integer(what);
    const uint64_t v = bin<uint64_t>();
    if (v > uint64_t(std::numeric_limits<int64_t>::max())) fail(std::string("invalid ") + what);
    return static_cast<int64_t>(v);
  }
  // 4.1: an int field in binary, a token in ASCII.
  int64_t int4(const char* what) { return binary_ ? bin<int32_t>() : integer(what); }
  double real4(const char* what) { return binary_ ? bin<double>() : real(what); }
  // Skips the rest of the current line (binary data start after the line that announces them).
  void endOfLine() {
    while (pos_ < data_.size() && data_[pos_] != '\n') ++pos_;
    if (pos_ < data_.size()) ++pos_;
  }
  void pollCancel(int64_t i) {
    if ((i & ((1 << 20) - 1)) == 0)
      if (const Progress* p = currentProgress()) p->checkCancel();
  }

  // ---- sections ----
  void readFormat() {
    section_ = "MeshFormat";
    const std::string_view v = token();
    int minor = -1;
    major_ = -1;
    if (!v.empty() && v[0] >= '0' && v[0] <= '9') {
      major_ = v[0] - '0';
      minor = v.size() >= 3 && v[1] == '.' && v[2] >= '0' && v[2] <= '9' ? v[2] - '0' : 0;
    }
    const bool ok = (major_ == 2 && minor >= 0 && minor <= 2) || (major_ == 4 && minor == 1);
    if (!ok)
      fail("MSH version " + std::string(v.substr(0, 20)) +
           " is not read; TetFlow reads MSH 2.2 and 4.1 (in Gmsh: File > Export as MSH 2 or MSH 4.1, "
           "or gmsh -format msh22 / msh41)");
    const int64_t type = integer("file type");
    const int64_t dataSize = integer("data size");
    if (type != 0 && type != 1) fail("file type " + std::to_string(type) + "; expected 0 (ASCII) or 1 (binary)");
    binary_ = type == 1;
    if (binary_) {
      if (dataSize != 8) fail("data size " + std::to_string(dataSize) + "; only 8 is read");
      endOfLine();
      inBinaryData_ = true;
      const size_t at = pos_;
      const int32_t one = bin<int32_t>();
      if (one != 1) {
        swap_ = true;
        pos_ = at;
        if (bin<int32_t>() != 1) failAt(at, "the byte order mark (the int 1) is missing or damaged");
      }
      inBinaryData_ = false;
    }
    expect("$EndMeshFormat");
  }

  void readPhysicalNames() {
    const int64_t n = count(integer("number of names"), 6, "physical names");
    for (int64_t i = 0; i < n; ++i) {
      const int64_t dim = integer("dimension");
      const int64_t tag = integer("physical tag");
      while (pos_ < data_.size() && space(data_[pos_])) ++pos_;
      if (pos_ >= data_.size() || data_[pos_] != '"') fail("expected a quoted physical name");
      const size_t start = ++pos_;
      while (pos_ < data_.size() && data_[pos_] != '"' && data_[pos_] != '\n') ++pos_;
      if (pos_ >= data_.size() || data_[pos_] != '"') fail("a physical name without its closing quote");
      if (dim == 3) volumeNames_[tag] = std::string(data_.data() + start, pos_ - start);
      ++pos_;
    }
  }

  void readEntities() {
    if (major_ != 4) fail("an $Entities section in an MSH 2 file");
    inBinaryData_ = binary_;
    if (binary_) endOfLine();
    int64_t n[4];
    for (int d = 0; d < 4; ++d) n[d] = size4("number of entities");
    for (int d = 0; d < 4; ++d) {
      count(n[d], binary_ ? 4 + 3 * 8 + 8 : 8, "entities");
      for (int64_t i = 0; i < n[d]; ++i) {
        const int64_t tag = int4("entity tag");
        for (int k = 0; k < (d == 0 ? 3 : 6); ++k) real4("coordinate");
        const int64_t np = count(size4("number of physical tags"), binary_ ? 4 : 2, "physical tags");
        for (int64_t k = 0; k < np; ++k) {
          const int64_t phys = int4("physical tag");
          if (d == 3 && k == 0) volumePhysical_[tag] = phys;
        }
        if (d > 0) {
          const int64_t nb = count(size4("number of bounding entities"), binary_ ? 4 : 2, "bounding entities");
          for (int64_t k = 0; k < nb; ++k) int4("bounding entity tag");
        }
      }
    }
    inBinaryData_ = false;
  }

  void addNode(int64_t tag, const Vec3& p) {
    nodeTags_.push_back(tag);
    points_.push_back(p);
  }

  void readNodes2() {
    const int64_t n = count(integer("number of nodes"), binary_ ? 28 : 8, "nodes");
    points_.reserve(static_cast<size_t>(n));
    nodeTags_.reserve(static_cast<size_t>(n));
    if (binary_) {
      endOfLine();
      inBinaryData_ = true;
      for (int64_t i = 0; i < n; ++i) {
        pollCancel(i);
        const int64_t tag = bin<int32_t>();
        const double x = bin<double>(), y = bin<double>(), z = bin<double>();
        addNode(tag, {x, y, z});
      }
      inBinaryData_ = false;
    } else {
      for (int64_t i = 0; i < n; ++i) {
        pollCancel(i);
        const int64_t tag = integer("node tag");
        const double x = real("x coordinate"), y = real("y coordinate"), z = real("z coordinate");
        addNode(tag, {x, y, z});
      }
    }
  }

  // 4.1 $Nodes / $Elements: "blocks count smallest-tag largest-tag" (size_t each in binary, whose
  // data start on the next line); returns (blocks, count), both checked against the file.
  std::pair<int64_t, int64_t> blocks4(const std::string& items, size_t minBytesPerItem) {
    inBinaryData_ = binary_;
    if (binary_) endOfLine();
    const int64_t blocks = size4(("number of " + items.substr(0, items.size() - 1) + " blocks").c_str());
    const int64_t n = count(size4(("number of " + items).c_str()), minBytesPerItem, items.c_str());
    size4("smallest tag");
    size4("largest tag");
    count(blocks, binary_ ? 20 : 8, (items.substr(0, items.size() - 1) + " blocks").c_str());
    return {blocks, n};
  }

  void readNodes4() {
    const auto [blocks, n] = blocks4("nodes", binary_ ? 32 : 8);
    points_.reserve(static_cast<size_t>(n));
    nodeTags_.reserve(static_cast<size_t>(n));
    int64_t read = 0;
    std::vector<int64_t> tags;
    for (int64_t b = 0; b < blocks; ++b) {
      const int64_t dim = int4("entity dimension");
      int4("entity tag");
      const int64_t parametric = int4("parametric flag");
      const int64_t k = count(size4("number of nodes in the block"), binary_ ? 32 : 8, "nodes");
      if (dim < 0 || dim > 3) fail("entity dimension " + std::to_string(dim));
      if (read + k > n) fail("the node blocks hold more nodes than the section announces");
      tags.resize(static_cast<size_t>(k));
      for (int64_t i = 0; i < k; ++i) tags[static_cast<size_t>(i)] = size4("node tag");
      const int extra = parametric ? static_cast<int>(dim) : 0;
      for (int64_t i = 0; i < k; ++i) {
        pollCancel(read + i);
        const double x = real4("x coordinate"), y = real4("y coordinate"), z = real4("z coordinate");
        for (int e = 0; e < extra; ++e) real4("parametric coordinate");
        addNode(tags[static_cast<size_t>(i)], {x, y, z});
      }
      read += k;
    }
    if (read != n) fail("the node blocks hold " + std::to_string(read) + " nodes; the section announces " + std::to_string(n));
    inBinaryData_ = false;
  }

  // Node tag -> index: an array when the tags are dense enough, else a hash map.
  void mapNodeTags() {
    if (points_.size() >= size_t(std::numeric_limits<int32_t>::max())) fail("too many nodes for 32-bit indices");
    int64_t maxTag = 0;
    for (int64_t t : nodeTags_) {
      if (t < 1) fail("node tag " + std::to_string(t) + "; node tags start at 1");
      maxTag = std::max(maxTag, t);
    }
    const bool dense = maxTag <= 2 * static_cast<int64_t>(nodeTags_.size()) + 1024;
    auto duplicate = [&](int64_t t) { fail("node tag " + std::to_string(t) + " appears twice"); };
    if (dense) {
      denseIndex_.assign(static_cast<size_t>(maxTag) + 1, -1);
      for (size_t i = 0; i < nodeTags_.size(); ++i) {
        int32_t& slot = denseIndex_[static_cast<size_t>(nodeTags_[i])];
        if (slot >= 0) duplicate(nodeTags_[i]);
        slot = static_cast<int32_t>(i);
      }
    } else {
      sparseIndex_.reserve(nodeTags_.size());
      for (size_t i = 0; i < nodeTags_.size(); ++i)
        if (!sparseIndex_.emplace(nodeTags_[i], static_cast<int32_t>(i)).second) duplicate(nodeTags_[i]);
    }
    std::vector<int64_t>().swap(nodeTags_);
  }
  int32_t nodeIndex(int64_t tag, int64_t element) const {
    if (!denseIndex_.empty()) {
      if (tag >= 0 && static_cast<size_t>(tag) < denseIndex_.size() && denseIndex_[static_cast<size_t>(tag)] >= 0)
        return denseIndex_[static_cast<size_t>(tag)];
    } else if (auto it = sparseIndex_.find(tag); it != sparseIndex_.end()) {
      return it->second;
    }
    fail("element " + std::to_string(element) + " refers to node " + std::to_string(tag) +
         ", which the $Nodes section does not hold");
  }

  // One element: a tet is kept, a lower-dimensional element skipped, anything else refused.
  void addElement(int64_t tag, int64_t type, const int64_t* nodes, int64_t group, bool physical) {
    if (type == kTet4) {
      TetMesh::Tet q;
      for (int k = 0; k < 4; ++k) q[static_cast<size_t>(k)] = nodeIndex(nodes[k], tag);
      if (group < std::numeric_limits<int32_t>::min() || group > std::numeric_limits<int32_t>::max())
        fail("element " + std::to_string(tag) + ": physical or entity tag " + std::to_string(group) +
             " does not fit a 32-bit material label");
      tets_.push_back(q);
      materials_.push_back(static_cast<int32_t>(group));
      if (physical) physicalUsed_ = true;
      if (major_ == 2) elementTags_.push_back(tag);
      return;
    }
    const ElementType e = elementType(type);
    if (e.nodes == 0) fail("element " + std::to_string(tag) + " has the unknown element type " + std::to_string(type));
    if (e.dim < 3) return; // a boundary element beside the volume
    fail("element " + std::to_string(tag) + " is a " + e.name + " (Gmsh type " + std::to_string(type) +
         "); only 4-node tetrahedra (type 4) are read. Mesh with tetrahedra of order 1 "
         "(Mesh.ElementOrder = 1, no recombination)");
  }

  void readElements2() {
    const int64_t n = count(integer("number of elements"), binary_ ? 12 : 8, "elements");
    tets_.reserve(static_cast<size_t>(n));
    materials_.reserve(static_cast<size_t>(n));
    std::vector<int64_t> nodes, tags;
    auto group = [&](const std::vector<int64_t>& t, bool& physical) -> int64_t {
      physical = !t.empty() && t[0] != 0;
      if (physical) return t[0];
      return t.size() >= 2 ? t[1] : 0;
    };
    if (binary_) {
      endOfLine();
      inBinaryData_ = true;
      int64_t read = 0;
      while (read < n) {
        const int64_t type = bin<int32_t>();
        const int64_t follow = count(bin<int32_t>(), 12, "elements");
        const int64_t ntags = bin<int32_t>();
        const ElementType e = elementType(type);
        if (e.nodes == 0) fail("unknown element type " + std::to_string(type));
        if (ntags < 0 || ntags > 1000) fail("invalid number of tags " + std::to_string(ntags));
        if (follow < 1 || read + follow > n) fail("an element block of " + std::to_string(follow) + " elements after " + std::to_string(read) + " of " + std::to_string(n));
        tags.resize(static_cast<size_t>(ntags));
        nodes.resize(static_cast<size_t>(e.nodes));
        for (int64_t i = 0; i < follow; ++i) {
          pollCancel(read + i);
          const int64_t tag = bin<int32_t>();
          for (auto& t : tags) t = bin<int32_t>();
          for (auto& v : nodes) v = bin<int32_t>();
          bool physical = false;
          const int64_t g = group(tags, physical);
          addElement(tag, type, nodes.data(), g, physical);
        }
        read += follow;
      }
      inBinaryData_ = false;
    } else {
      for (int64_t i = 0; i < n; ++i) {
        pollCancel(i);
        const int64_t tag = integer("element tag");
        const int64_t type = integer("element type");
        const int64_t ntags = integer("number of tags");
        if (ntags < 0 || ntags > 1000) fail("invalid number of tags " + std::to_string(ntags));
        tags.resize(static_cast<size_t>(ntags));
        for (auto& t : tags) t = integer("tag");
        const ElementType e = elementType(type);
        if (e.nodes == 0) fail("element " + std::to_string(tag) + " has the unknown element type " + std::to_string(type));
        nodes.resize(static_cast<size_t>(e.nodes));
        for (auto& v : nodes) v = integer("node tag");
        bool physical = false;
        const int64_t g = group(tags, physical);
        addElement(tag, type, nodes.data(), g, physical);
      }
    }
  }

  void readElements4() {
    const auto [blocks, n] = blocks4("elements", binary_ ? 16 : 4);
    tets_.reserve(static_cast<size_t>(n));
    materials_.reserve(static_cast<size_t>(n));
    int64_t read = 0;
    std::vector<int64_t> nodes;
    for (int64_t b = 0; b < blocks; ++b) {
      const int64_t dim = int4("entity dimension");
      const int64_t entity = int4("entity tag");
      const int64_t type = int4("element type");
      const int64_t k = count(size4("number of elements in the block"), binary_ ? 16 : 4, "elements");
      if (read + k > n) fail("the element blocks hold more elements than the section announces");
      const ElementType e = elementType(type);
      if (e.nodes == 0) fail("unknown element type " + std::to_string(type));
      if (e.dim != dim) fail("element type " + std::to_string(type) + " in a block of dimension " + std::to_string(dim));
      bool physical = false;
      int64_t g = entity;
      if (auto it = volumePhysical_.find(entity); dim == 3 && it != volumePhysical_.end()) {
        g = it->second;
        physical = true;
      }
      nodes.resize(static_cast<size_t>(e.nodes));
      for (int64_t i = 0; i < k; ++i) {
        pollCancel(read + i);
        const int64_t tag = size4("element tag");
        for (auto& v : nodes) v = size4("node tag");
        addElement(tag, type, nodes.data(), g, physical);
      }
      read += k;
    }
    if (read != n) fail("the element blocks hold " + std::to_string(read) + " elements; the section announces " + std::to_string(n));
    inBinaryData_ = false;
  }

  void skipSection(const std::string& name) {
    const std::string end = "$End" + name;
    size_t at = pos_;
    while (true) {
      at = std::string_view(data_.data(), data_.size()).find(end, at);
      if (at == std::string_view::npos)
        fail("the section $" + name + " has no " + end + " (truncated file?)");
      const size_t after = at + end.size();
      if ((at == 0 || space(data_[at - 1])) && (after == data_.size() || space(data_[after]))) {
        pos_ = after;
        section_.clear();
        return;
      }
      at = after;
    }
  }

  TetMesh finish() {
    section_.clear();
    // 2.x: an element in two physical groups is listed twice under one tag; keep the first.
    if (!elementTags_.empty() && !std::is_sorted(elementTags_.begin(), elementTags_.end(),
                                                 [](int64_t a, int64_t b) { return a <= b; })) {
      std::vector<size_t> order(elementTags_.size());
      std::iota(order.begin(), order.end(), size_t(0));
      std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return elementTags_[a] < elementTags_[b]; });
      std::vector<uint8_t> drop(order.size(), 0);
      for (size_t i = 1; i < order.size(); ++i)
        if (elementTags_[order[i]] == elementTags_[order[i - 1]]) drop[order[i]] = 1;
      size_t w = 0;
      for (size_t t = 0; t < tets_.size(); ++t)
        if (!drop[t]) {
          tets_[w] = tets_[t];
          materials_[w++] = materials_[t];
        }
      tets_.resize(w);
      materials_.resize(w);
    }
    TetMesh m;
    m.points = std::move(points_);
    m.tets = std::move(tets_);
    m.materials = std::move(materials_);
    // Physical volume names: "material_<n>" gives label n back; other names name their label.
    std::map<int32_t, int32_t> relabel;
    for (const auto& [tag, name] : volumeNames_) {
      if (tag < std::numeric_limits<int32_t>::min() || tag > std::numeric_limits<int32_t>::max()) continue;
      const std::string_view prefix = "material_";
      int64_t n = 0;
      if (name.size() > prefix.size() && name.compare(0, prefix.size(), prefix) == 0) {
        const char* b = name.data() + prefix.size();
        const char* e = name.data() + name.size();
        auto r = std::from_chars(b, e, n);
        if (r.ec == std::errc() && r.ptr == e && n >= std::numeric_limits<int32_t>::min() &&
            n <= std::numeric_limits<int32_t>::max()) {
          if (n != tag) relabel[static_cast<int32_t>(tag)] = static_cast<int32_t>(n);
          continue;
        }
      }
      m.materialNames[static_cast<int32_t>(tag)] = name;
    }
    if (!relabel.empty() && physicalUsed_)
      for (int32_t& L : m.materials)
        if (auto it = relabel.find(L); it != relabel.end()) L = it->second;
    m.validateStructure(path_);
    orientPositively(m);
    return m;
  }

  std::string path_;
  std::vector<char> data_;
  size_t pos_ = 0;
  std::string section_;
  int major_ = 0;
  bool binary_ = false, swap_ = false, inBinaryData_ = false;
  std::map<int64_t, std::string> volumeNames_;
  std::unordered_map<int64_t, int64_t> volumePhysical_;
  std::vector<Vec3> points_;
  std::vector<int64_t> nodeTags_;
  std::vector<int32_t> denseIndex_;
  std::unordered_map<int64_t, int32_t> sparseIndex_;
  std::vector<TetMesh::Tet> tets_;
  std::vector<int32_t> materials_;
  std::vector<int64_t> elementTags_; // 2.x
  bool physicalUsed_ = false;
};

} // namespace

void writeGmsh(const std::string& path, const TetMesh& m, GmshVariant variant) {
  switch (variant) {
  case GmshVariant::V41Ascii: writeGmsh41(path, m); return;
  case GmshVariant::V22Ascii: writeGmsh22(path, m, false); return;
  case GmshVariant::V22Binary: writeGmsh22(path, m, true); return;
  }
}

TetMesh readGmsh(const std::string& path) {
  requireExistingFile(path);
  return MshReader(path).run();
}

} // namespace tetflow
