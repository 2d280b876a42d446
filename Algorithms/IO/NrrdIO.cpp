// NRRD reader and writer (format: http://teem.sourceforge.net/nrrd/format.html), written from the
// format description.
//
// Reading happens in three steps, each failing with an InputError that names the file (and, for
// header problems, the header line):
//   1. the header is read line by line up to the first blank line (attached data follow it) or
//      the end of the file (a detached header); fields are collected with their line numbers;
//   2. fields are interpreted: type, shape (which axes are the three spatial ones), geometry,
//      encoding, endian, where the data live; everything is checked before any voxel memory is
//      allocated (the announced size is compared with the file size, or for gzip with the most
//      that the compressed bytes can inflate to);
//   3. the data are read straight into the RawVolume buffer (raw), inflated (gzip) or parsed
//      (ascii), then brought into host byte order.
//
// Coordinates: TetFlow's physical frame is LPS (as in ITK, DICOM, MetaImage; see VtkVolumeIO.h).
// A header in "left-posterior-superior" (or scanner-xyz, 3D-right-handed, or no space at all) is
// taken as given; "right-anterior-superior" negates x and y, "left-anterior-superior" negates y,
// so that one segmentation saved as NRRD in RAS and as NIfTI reads with the same geometry.
// The writer always writes "space: left-posterior-superior".
#include "NrrdIO.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <optional>
#include <sstream>
#include <string_view>
#include <system_error>
#include <vector>

#include "../Core/Errors.h"
#include "FileUtil.h"
#include "HeaderText.h"

namespace fs = std::filesystem;

namespace tetflow {
namespace {

using namespace headertext;

// ------------------------------------------------------------------------------------------------
// Text helpers

std::vector<std::string_view> splitWords(std::string_view s) {
  std::vector<std::string_view> words;
  size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && isSpace(s[i])) ++i;
    size_t j = i;
    while (j < s.size() && !isSpace(s[j])) ++j;
    if (j > i) words.push_back(s.substr(i, j - i));
    i = j;
  }
  return words;
}

// Quote a piece of header text for a message: printable characters only, at most 60 of them.
// Accepts decimal / scientific notation and nan / inf spellings.
// ------------------------------------------------------------------------------------------------
// Header

struct Field {
  std::string value;
  int line = 0;
};

// Canonical names of the fields we interpret; other fields are accepted and ignored.
const std::map<std::string, std::string>& fieldAliases() {
  static const std::map<std::string, std::string> m = {
      {"type", "type"},
      {"dimension", "dimension"},
      {"sizes", "sizes"},
      {"encoding", "encoding"},
      {"endian", "endian"},
      {"spacings", "spacings"},
      {"space directions", "space directions"},
      {"space origin", "space origin"},
      {"space", "space"},
      {"space dimension", "space dimension"},
      {"axis mins", "axis mins"},
      {"axismins", "axis mins"},
      {"kinds", "kinds"},
      {"centers", "centers"},
      {"centerings", "centers"},
      {"data file", "data file"},
      {"datafile", "data file"},
      {"line skip", "line skip"},
      {"lineskip", "line skip"},
      {"byte skip", "byte skip"},
      {"byteskip", "byte skip"},
  };
  return m;
}

struct Header {
  std::string path;
  std::map<std::string, Field> fields;
  std::map<std::string, std::string> keyValues; // "key:=value" lines (e.g. 3D Slicer's segments)
  // Offset of the first byte after the blank line ending the header; -1 when the header ran to
  // the end of the file (a detached header).
  int64_t dataOffset = -1;
  int lines = 0;

  const Field* find(const std::string& name) const {
    auto it = fields.find(name);
    return it == fields.end() ? nullptr : &it->second;
  }
  [[noreturn]] void fail(const std::string& msg) const { throw InputError(path + ": " + msg); }
  [[noreturn]] void fail(const Field& f, const std::string& msg) const {
    throw InputError(path + ":" + std::to_string(f.line) + ": " + msg);
  }
  [[noreturn]] void failLine(int line, const std::string& msg) const {
    throw InputError(path + ":" + std::to_string(line) + ": " + msg);
  }
  const Field& require(const std::string& name, const std::string& why = "") const {
    const Field* f = find(name);
    if (!f) fail("missing required field '" + name + "'" + (why.empty() ? "" : " (" + why + ")"));
    return *f;
  }
};

void openOrFail(std::ifstream& in, const std::string& path, const std::string& what) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw InputError(what + ": file not found");
  if (fs::is_directory(path, ec)) throw InputError(what + ": is a folder, not a file");
  in.open(path, std::ios::binary);
  if (!in) throw InputError(what + ": cannot open for reading (" + std::strerror(errno) + ")");
}

int64_t fileSizeOrFail(const std::string& path, const std::string& what) {
  std::error_code ec;
  const auto size = fs::file_size(path, ec);
  if (ec) throw InputError(what + ": cannot determine the file size (" + ec.message() + ")");
  return static_cast<int64_t>(size);
}

void readAt(std::ifstream& in, int64_t offset, char* dst, int64_t n, const std::string& what) {
  in.clear();
  in.seekg(offset, std::ios::beg);
  if (n > 0 && !in.read(dst, n))
    throw InputError(what + ": read error (the file changed while reading or an I/O error)");
}

void processLine(Header& h, std::string_view line, int lineNo) {
  if (lineNo == 1) {
    const std::string_view magic = trim(line);
    if (magic.size() != 8 || magic.substr(0, 4) != "NRRD")
      h.fail("not a NRRD file: the first line must be a magic 'NRRD0001' ... 'NRRD0005'");
    if (magic.substr(4, 3) != "000" || magic[7] < '1' || magic[7] > '5')
      h.failLine(1,
                 "unsupported NRRD version " + shown(magic) + " (NRRD0001 ... NRRD0005 are read)");
    return;
  }
  if (!line.empty() && line.front() == '#') return; // comment
  const size_t colon = line.find(':');
  if (colon == std::string_view::npos)
    h.failLine(lineNo, "expected 'field: value', got " + shown(line));
  if (colon + 1 < line.size() && line[colon + 1] == '=') { // key:=value pair
    h.keyValues[std::string(line.substr(0, colon))] = std::string(trim(line.substr(colon + 2)));
    return;
  }
  const std::string name = canonical(line.substr(0, colon));
  const auto& aliases = fieldAliases();
  auto it = aliases.find(name);
  if (it == aliases.end()) return; // a field we do not need (content, units, labels, ...)
  if (it->second == "data file") {
    // "data file: LIST" is followed by file names instead of fields: stop here.
    const auto words = splitWords(line.substr(colon + 1));
    if (!words.empty() && words.size() <= 2 && words[0] == "LIST")
      h.failLine(lineNo, "'data file: LIST' (data split over a list of files) is not supported; "
                         "combine the data into one file");
  }
  auto [pos, inserted] =
      h.fields.emplace(it->second, Field{std::string(trim(line.substr(colon + 1))), lineNo});
  if (!inserted)
    h.failLine(lineNo, "field '" + it->second + "' appears twice (also on line " +
                           std::to_string(pos->second.line) + ")");
}

// Reads header lines until a blank line (attached data follow) or the end of the file.
Header readHeader(const std::string& path) {
  Header h;
  h.path = path;
  std::ifstream in;
  openOrFail(in, path, path);
  std::string buf;
  size_t lineStart = 0; // start of the current (incomplete) line in buf
  int64_t bufBase = 0;  // file offset of buf[0]
  int lineNo = 0;
  std::vector<char> chunk(1 << 16);
  bool eof = false;
  while (true) {
    const size_t nl = buf.find('\n', lineStart);
    if (nl == std::string::npos) {
      if (eof) {
        if (lineStart < buf.size()) {
          std::string_view line(buf.data() + lineStart, buf.size() - lineStart);
          if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
          ++lineNo;
          processLine(h, line, lineNo);
        } else if (lineNo == 0) {
          h.fail("not a NRRD file: the file is empty");
        }
        break;
      }
      // Keep only the incomplete line, then read more.
      buf.erase(0, lineStart);
      bufBase += static_cast<int64_t>(lineStart);
      lineStart = 0;
      in.read(chunk.data(), static_cast<std::streamsize>(chunk.size()));
      const std::streamsize got = in.gcount();
      if (got <= 0)
        eof = true;
      else
        buf.append(chunk.data(), static_cast<size_t>(got));
      if (lineNo == 0 && buf.size() >= 4 && buf.compare(0, 4, "NRRD") != 0)
        h.fail("not a NRRD file: the first line must be a magic 'NRRD0001' ... 'NRRD0005'");
      continue;
    }
    std::string_view line(buf.data() + lineStart, nl - lineStart);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    ++lineNo;
    lineStart = nl + 1;
    if (lineNo > 1 && trim(line).empty()) {
      h.dataOffset = bufBase + static_cast<int64_t>(lineStart);
      break;
    }
    processLine(h, line, lineNo);
  }
  h.lines = lineNo;
  return h;
}

// ------------------------------------------------------------------------------------------------
// Field interpretation

std::optional<VoxelType> typeFromName(const std::string& n) {
  static const std::map<std::string, VoxelType> m = {
      {"signed char", VoxelType::Int8},
      {"int8", VoxelType::Int8},
      {"int8_t", VoxelType::Int8},
      {"uchar", VoxelType::UInt8},
      {"unsigned char", VoxelType::UInt8},
      {"uint8", VoxelType::UInt8},
      {"uint8_t", VoxelType::UInt8},
      {"short", VoxelType::Int16},
      {"short int", VoxelType::Int16},
      {"signed short", VoxelType::Int16},
      {"signed short int", VoxelType::Int16},
      {"int16", VoxelType::Int16},
      {"int16_t", VoxelType::Int16},
      {"ushort", VoxelType::UInt16},
      {"unsigned short", VoxelType::UInt16},
      {"unsigned short int", VoxelType::UInt16},
      {"uint16", VoxelType::UInt16},
      {"uint16_t", VoxelType::UInt16},
      {"int", VoxelType::Int32},
      {"signed int", VoxelType::Int32},
      {"int32", VoxelType::Int32},
      {"int32_t", VoxelType::Int32},
      {"uint", VoxelType::UInt32},
      {"unsigned int", VoxelType::UInt32},
      {"uint32", VoxelType::UInt32},
      {"uint32_t", VoxelType::UInt32},
      {"longlong", VoxelType::Int64},
      {"long long", VoxelType::Int64},
      {"long long int", VoxelType::Int64},
      {"signed long long", VoxelType::Int64},
      {"signed long long int", VoxelType::Int64},
      {"int64", VoxelType::Int64},
      {"int64_t", VoxelType::Int64},
      {"ulonglong", VoxelType::UInt64},
      {"unsigned long long", VoxelType::UInt64},
      {"unsigned long long int", VoxelType::UInt64},
      {"uint64", VoxelType::UInt64},
      {"uint64_t", VoxelType::UInt64},
      {"float", VoxelType::Float32},
      {"double", VoxelType::Float64},
  };
  auto it = m.find(n);
  if (it == m.end()) return std::nullopt;
  return it->second;
}

// Space names of the spec and their dimension (time-carrying spaces have 4).
std::optional<int> spaceDimensionOf(const std::string& n) {
  static const std::map<std::string, int> m = {
      {"right-anterior-superior", 3},
      {"ras", 3},
      {"left-anterior-superior", 3},
      {"las", 3},
      {"left-posterior-superior", 3},
      {"lps", 3},
      {"scanner-xyz", 3},
      {"3d-right-handed", 3},
      {"3d-left-handed", 3},
      {"right-anterior-superior-time", 4},
      {"rast", 4},
      {"left-anterior-superior-time", 4},
      {"last", 4},
      {"left-posterior-superior-time", 4},
      {"lpst", 4},
      {"scanner-xyz-time", 4},
      {"3d-right-handed-time", 4},
      {"3d-left-handed-time", 4},
  };
  auto it = m.find(n);
  if (it == m.end()) return std::nullopt;
  return it->second;
}

// Kinds that describe positions in space or time (anything else is a vector / list / colour...).
bool isDomainKind(const std::string& k) {
  return k == "domain" || k == "space" || k == "time" || k == "???" || k == "none";
}

// "(a,b,c) none (d,e,f)" -> vectors, nullopt for "none".
std::vector<std::optional<std::vector<double>>> parseVectors(const Header& h, const Field& f,
                                                             const std::string& name) {
  std::vector<std::optional<std::vector<double>>> out;
  const std::string_view s = f.value;
  size_t i = 0;
  while (true) {
    while (i < s.size() && isSpace(s[i])) ++i;
    if (i >= s.size()) break;
    if (s[i] == '(') {
      const size_t close = s.find(')', i);
      if (close == std::string_view::npos)
        h.fail(f, name + ": missing ')' in " + shown(s.substr(i)));
      std::vector<double> v;
      std::string_view inner = s.substr(i + 1, close - i - 1);
      size_t a = 0;
      while (true) {
        const size_t comma = inner.find(',', a);
        const std::string_view part =
            inner.substr(a, comma == std::string_view::npos ? std::string_view::npos : comma - a);
        double x = 0;
        if (!parseDouble(part, x)) h.fail(f, name + ": " + shown(trim(part)) + " is not a number");
        v.push_back(x);
        if (comma == std::string_view::npos) break;
        a = comma + 1;
      }
      out.emplace_back(std::move(v));
      i = close + 1;
    } else {
      size_t j = i;
      while (j < s.size() && !isSpace(s[j])) ++j;
      const std::string word = canonical(s.substr(i, j - i));
      if (word != "none")
        h.fail(f, name + ": expected a vector like '(1,0,0)' or 'none', got " +
                      shown(s.substr(i, j - i)));
      out.emplace_back(std::nullopt);
      i = j;
    }
  }
  return out;
}

// Per-axis list of doubles (spacings, axis mins): "nan" allowed; exactly `dim` values.
std::vector<double> parseAxisNumbers(const Header& h, const Field& f, const std::string& name,
                                     int dim) {
  const auto words = splitWords(f.value);
  if (static_cast<int>(words.size()) != dim)
    h.fail(f, name + " has " + std::to_string(words.size()) + " values but dimension is " +
                  std::to_string(dim));
  std::vector<double> out;
  for (auto w : words) {
    double x = 0;
    if (!parseDouble(w, x)) h.fail(f, name + ": " + shown(w) + " is not a number");
    out.push_back(x);
  }
  return out;
}

std::vector<std::string> parseAxisWords(const Header& h, const Field& f, const std::string& name,
                                        int dim) {
  const auto words = splitWords(f.value);
  if (static_cast<int>(words.size()) != dim)
    h.fail(f, name + " has " + std::to_string(words.size()) + " entries but dimension is " +
                  std::to_string(dim));
  std::vector<std::string> out;
  for (auto w : words) out.push_back(canonical(w));
  return out;
}

// Everything the header says about the data, checked.
struct Layout {
  VoxelType type = VoxelType::UInt8;
  GridGeometry grid;
  int64_t count = 0;     // voxel values
  int64_t byteCount = 0; // count * type size
  NrrdEncoding encoding = NrrdEncoding::Raw;
  bool bigEndian = false;
  std::string dataPath;  // file holding the data
  std::string what;      // names the data in messages (header, plus the data file if detached)
  int64_t dataStart = 0; // where the data file's data begin (before line/byte skip)
  int64_t lineSkip = 0;
  int64_t byteSkip = 0;
};

Layout interpret(const Header& h) {
  Layout L;

  // type
  const Field& typeF = h.require("type");
  const std::string typeName = canonical(typeF.value);
  if (typeName == "block")
    h.fail(typeF, "type 'block' (opaque blocks of bytes) is not supported; TetFlow reads "
                  "integer and floating point voxels");
  const auto type = typeFromName(typeName);
  if (!type) h.fail(typeF, "unknown type " + shown(typeF.value));
  L.type = *type;
  const int64_t typeSize = static_cast<int64_t>(voxelTypeSize(L.type));

  // dimension and sizes
  const Field& dimF = h.require("dimension");
  int64_t dim64 = 0;
  if (!parseInt64(dimF.value, dim64))
    h.fail(dimF, "dimension " + shown(dimF.value) + " is not a whole number");
  if (dim64 < 2 || dim64 > 4)
    h.fail(dimF, "dimension " + std::to_string(dim64) +
                     " is not supported; TetFlow reads 3D scalar volumes (dimension 3, or 4 with "
                     "a leading axis of size 1, or 2 for a single slice)");
  const int dim = static_cast<int>(dim64);
  const Field& sizesF = h.require("sizes");
  const auto sizeWords = splitWords(sizesF.value);
  if (static_cast<int>(sizeWords.size()) != dim)
    h.fail(sizesF, "sizes has " + std::to_string(sizeWords.size()) + " values but dimension is " +
                       std::to_string(dim));
  std::vector<int64_t> sizes;
  int64_t count = 1;
  for (int a = 0; a < dim; ++a) {
    int64_t s = 0;
    if (!parseInt64(sizeWords[static_cast<size_t>(a)], s))
      h.fail(sizesF,
             "sizes: " + shown(sizeWords[static_cast<size_t>(a)]) + " is not a whole number");
    if (s < 1)
      h.fail(sizesF, "sizes: axis " + std::to_string(a) + " has size " + std::to_string(s) +
                         "; every size must be at least 1");
    if (__builtin_mul_overflow(count, s, &count))
      h.fail(sizesF, "sizes " + shown(sizesF.value) +
                         " overflow: the volume would have more than 2^63 voxels");
    sizes.push_back(s);
  }
  int64_t byteCount = 0;
  if (__builtin_mul_overflow(count, typeSize, &byteCount))
    h.fail(sizesF, "sizes " + shown(sizesF.value) + " overflow: the data would exceed 2^63 bytes");
  L.count = count;
  L.byteCount = byteCount;

  // space / space dimension
  int spaceDim = 0;
  const Field* spaceF = h.find("space");
  const Field* spaceDimF = h.find("space dimension");
  if (spaceF) {
    const auto d = spaceDimensionOf(canonical(spaceF->value));
    if (!d) h.fail(*spaceF, "unknown space " + shown(spaceF->value));
    spaceDim = *d;
  }
  if (spaceDimF) {
    int64_t d = 0;
    if (!parseInt64(spaceDimF->value, d) || d < 1)
      h.fail(*spaceDimF,
             "space dimension " + shown(spaceDimF->value) + " is not a whole number >= 1");
    if (spaceF && d != spaceDim)
      h.fail(*spaceDimF,
             "space dimension " + std::to_string(d) + " contradicts space " + shown(spaceF->value));
    spaceDim = static_cast<int>(d);
  }
  if (spaceDim > 3)
    h.fail(spaceF ? *spaceF : *spaceDimF,
           "a " + std::to_string(spaceDim) +
               "-dimensional space (with time) is not supported; TetFlow reads 3D volumes");

  // space directions (one per axis, "none" for non-spatial axes)
  const Field* dirF = h.find("space directions");
  std::vector<std::optional<std::vector<double>>> dirs;
  if (dirF) {
    dirs = parseVectors(h, *dirF, "space directions");
    if (static_cast<int>(dirs.size()) != dim)
      h.fail(*dirF, "space directions has " + std::to_string(dirs.size()) +
                        " entries but dimension is " + std::to_string(dim));
    for (const auto& v : dirs) {
      if (!v) continue;
      if (spaceDim == 0) spaceDim = static_cast<int>(v->size());
      if (static_cast<int>(v->size()) != spaceDim)
        h.fail(*dirF, "space directions: a vector has " + std::to_string(v->size()) +
                          " components but the space dimension is " + std::to_string(spaceDim));
      if (spaceDim > 3)
        h.fail(*dirF, "space directions: " + std::to_string(spaceDim) +
                          "-component vectors are not supported (3D volumes only)");
    }
  }

  // kinds: only used to recognise a non-spatial leading axis
  std::vector<std::string> kinds;
  if (const Field* kindsF = h.find("kinds")) kinds = parseAxisWords(h, *kindsF, "kinds", dim);

  // Which axes are the spatial ones.
  auto nonSpatial = [&](int a) {
    return (!kinds.empty() && !isDomainKind(kinds[static_cast<size_t>(a)])) ||
           (dirF && !dirs[static_cast<size_t>(a)]);
  };
  auto refuseVector = [&](int a) {
    std::string m = "axis " + std::to_string(a) + " holds " +
                    std::to_string(sizes[static_cast<size_t>(a)]) + " values per voxel";
    if (!kinds.empty()) m += " (kind '" + kinds[static_cast<size_t>(a)] + "')";
    m += ": vector, list or multi-component data are not supported; TetFlow reads scalar 3D "
         "volumes (split the components into separate files)";
    h.fail(sizesF, m);
  };
  std::vector<int> keep;
  if (dim == 4) {
    if (sizes[0] != 1) {
      const bool leadingIsComponents =
          (!kinds.empty() && !isDomainKind(kinds[0])) || (dirF && !dirs[0]);
      if (leadingIsComponents || kinds.empty()) refuseVector(0);
      h.fail(sizesF, "4-dimensional data (sizes " + std::string(trim(sizesF.value)) + ", kinds " +
                         kinds[0] + " " + kinds[1] + " " + kinds[2] + " " + kinds[3] +
                         ") are not supported; TetFlow reads scalar 3D volumes and accepts 4 "
                         "dimensions only with a leading axis of size 1 (time series and "
                         "multi-component data are refused)");
    }
    keep = {1, 2, 3};
  } else if (dim == 3) {
    if (nonSpatial(0)) {
      if (sizes[0] != 1) refuseVector(0);
      keep = {1, 2};
    } else {
      keep = {0, 1, 2};
    }
  } else {
    if (nonSpatial(0) && sizes[0] != 1) refuseVector(0);
    keep = {0, 1};
  }

  // Geometry.
  GridGeometry& g = L.grid;
  std::array<Vec3, 3> cols{Vec3{1, 0, 0}, Vec3{0, 1, 0}, Vec3{0, 0, 1}};
  for (size_t k = 0; k < keep.size(); ++k) g.dims[k] = sizes[static_cast<size_t>(keep[k])];
  if (keep.size() == 2) g.dims[2] = 1;
  std::string geometryWhat = h.path;
  if (dirF) {
    geometryWhat = h.path + ":" + std::to_string(dirF->line);
    for (size_t k = 0; k < keep.size(); ++k) {
      const int a = keep[k];
      const auto& v = dirs[static_cast<size_t>(a)];
      if (!v)
        h.fail(*dirF, "space directions: axis " + std::to_string(a) +
                          " is a spatial axis of the volume but its direction is 'none'");
      Vec3 d{0, 0, 0};
      for (size_t c = 0; c < v->size(); ++c) d[c] = (*v)[c];
      const double len = norm(d);
      if (!std::isfinite(len))
        h.fail(*dirF,
               "space directions: the direction of axis " + std::to_string(a) + " is not finite");
      if (!(len > 0))
        h.fail(*dirF, "space directions: the direction of axis " + std::to_string(a) +
                          " has zero length (zero spacing)");
      g.spacing[k] = len;
      cols[k] = (1.0 / len) * d;
    }
  } else if (const Field* spF = h.find("spacings")) {
    const auto sp = parseAxisNumbers(h, *spF, "spacings", dim);
    for (size_t k = 0; k < keep.size(); ++k) {
      const int a = keep[k];
      const double s = sp[static_cast<size_t>(a)];
      if (std::isnan(s)) continue; // unknown spacing: keep 1
      if (!(s > 0) || !std::isfinite(s)) {
        std::ostringstream m;
        m << "spacings: axis " << a << " has spacing " << s
          << "; spacings must be positive numbers";
        h.fail(*spF, m.str());
      }
      g.spacing[k] = s;
    }
  }
  if (keep.size() == 2) {
    // One slice: the third axis is normal to the other two, right-handed.
    Vec3 n = cross(cols[0], cols[1]);
    const double len = norm(n);
    if (!(len > 1e-9)) {
      if (dirF) h.fail(*dirF, "space directions: the two axes of the slice are parallel");
      h.fail("the two axes of the slice are parallel");
    }
    cols[2] = (1.0 / len) * n;
  }
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      g.direction[r][c] = cols[static_cast<size_t>(c)][static_cast<size_t>(r)];

  if (const Field* orgF = h.find("space origin")) {
    const auto vs = parseVectors(h, *orgF, "space origin");
    if (vs.size() != 1 || !vs[0]) h.fail(*orgF, "space origin must be one vector like '(0,0,0)'");
    const auto& v = *vs[0];
    if (v.size() > 3 || (spaceDim != 0 && static_cast<int>(v.size()) != spaceDim))
      h.fail(*orgF, "space origin has " + std::to_string(v.size()) +
                        " components but the space dimension is " +
                        std::to_string(spaceDim ? spaceDim : 3));
    for (size_t c = 0; c < v.size(); ++c) {
      if (!std::isfinite(v[c])) h.fail(*orgF, "space origin is not finite");
      g.origin[c] = v[c];
    }
  } else if (const Field* minF = h.find("axis mins")) {
    const auto mins = parseAxisNumbers(h, *minF, "axis mins", dim);
    std::vector<std::string> centers;
    if (const Field* cF = h.find("centers")) centers = parseAxisWords(h, *cF, "centers", dim);
    for (size_t k = 0; k < keep.size(); ++k) {
      const size_t a = static_cast<size_t>(keep[k]);
      const double m = mins[a];
      if (std::isnan(m)) continue;
      if (!std::isfinite(m))
        h.fail(*minF, "axis mins: axis " + std::to_string(a) + " is not finite");
      // A cell-centred axis min is the outer edge of the first voxel; we store voxel centres.
      g.origin[k] = m + ((!centers.empty() && centers[a] == "cell") ? 0.5 * g.spacing[k] : 0.0);
    }
  }
  if (spaceF) {
    const std::string s = canonical(spaceF->value);
    const bool flipX = s == "right-anterior-superior" || s == "ras";
    const bool flipY = flipX || s == "left-anterior-superior" || s == "las";
    for (int c = 0; c < 3; ++c) {
      if (flipX) g.direction[0][c] = -g.direction[0][c];
      if (flipY) g.direction[1][c] = -g.direction[1][c];
    }
    if (flipX) g.origin[0] = -g.origin[0];
    if (flipY) g.origin[1] = -g.origin[1];
  }
  g.validate(geometryWhat);

  // encoding and endian
  const Field& encF = h.require("encoding");
  const std::string enc = canonical(encF.value);
  if (enc == "raw")
    L.encoding = NrrdEncoding::Raw;
  else if (enc == "gzip" || enc == "gz")
    L.encoding = NrrdEncoding::Gzip;
  else if (enc == "ascii" || enc == "text" || enc == "txt")
    L.encoding = NrrdEncoding::Ascii;
  else if (enc == "bzip2" || enc == "bz2" || enc == "hex" || enc == "zrl")
    h.fail(encF, "encoding '" + enc + "' is not supported (use raw, gzip or ascii)");
  else
    h.fail(encF, "unknown encoding " + shown(encF.value) + " (use raw, gzip or ascii)");

  if (const Field* endF = h.find("endian")) {
    const std::string e = canonical(endF->value);
    if (e == "big")
      L.bigEndian = true;
    else if (e != "little")
      h.fail(*endF, "unknown endian " + shown(endF->value) + " (use little or big)");
  } else if (typeSize > 1 && L.encoding != NrrdEncoding::Ascii) {
    h.fail("missing required field 'endian' (needed for " + std::string(voxelTypeName(L.type)) +
           " data in " + (L.encoding == NrrdEncoding::Raw ? "raw" : "gzip") + " encoding)");
  }

  // skips
  if (const Field* f = h.find("line skip")) {
    if (!parseInt64(f->value, L.lineSkip) || L.lineSkip < 0)
      h.fail(*f, "line skip " + shown(f->value) + " is not a whole number >= 0");
  }
  if (const Field* f = h.find("byte skip")) {
    if (!parseInt64(f->value, L.byteSkip) || L.byteSkip < -1)
      h.fail(*f, "byte skip " + shown(f->value) + " is not a whole number >= -1");
    if (L.byteSkip == -1 && L.encoding != NrrdEncoding::Raw)
      h.fail(*f, "byte skip -1 (data at the end of the file) is only allowed with raw encoding");
  }

  // where the data are
  if (const Field* f = h.find("data file")) {
    const std::string name(trim(f->value));
    const auto words = splitWords(name);
    if (words.size() >= 4 && words[0].find('%') != std::string_view::npos)
      h.fail(*f, "data split over numbered files (" + shown(name) +
                     ") is not supported; combine the data into one file");
    if (name.empty()) h.fail(*f, "data file is empty");
    fs::path p(name);
    if (p.is_relative()) p = fs::path(h.path).parent_path() / p;
    L.dataPath = p.string();
    L.what = h.path + " (data file '" + L.dataPath + "')";
    std::error_code ec;
    if (!fs::exists(L.dataPath, ec))
      h.fail(*f, "data file '" + name + "' not found (looked for '" + L.dataPath + "')");
    if (fs::is_directory(L.dataPath, ec))
      h.fail(*f, "data file '" + L.dataPath + "' is a folder, not a file");
    L.dataStart = 0;
  } else {
    if (h.dataOffset < 0)
      h.fail("no data: the header has no 'data file' field and no blank line after which "
             "attached data would follow");
    L.dataPath = h.path;
    L.what = h.path;
    L.dataStart = h.dataOffset;
  }
  return L;
}

// ------------------------------------------------------------------------------------------------
// Data

// Offset just past `lines` newlines counted from `start`.
int64_t skipLines(std::ifstream& in, int64_t start, int64_t lines, const std::string& what) {
  if (lines == 0) return start;
  in.clear();
  in.seekg(start, std::ios::beg);
  std::vector<char> chunk(1 << 16);
  int64_t pos = start;
  int64_t found = 0;
  while (true) {
    in.read(chunk.data(), static_cast<std::streamsize>(chunk.size()));
    const std::streamsize got = in.gcount();
    if (got <= 0) break;
    for (std::streamsize i = 0; i < got; ++i) {
      if (chunk[static_cast<size_t>(i)] == '\n' && ++found == lines) return pos + i + 1;
    }
    pos += got;
  }
  throw InputError(what + ": line skip " + std::to_string(lines) +
                   " goes past the end of the data (found only " + std::to_string(found) +
                   " lines)");
}

bool isAsciiSeparator(char c) { return isSpace(c) || c == ','; }

template <class T>
bool parseAsciiValue(const char* b, const char* e, T& out) {
  if (b < e && *b == '+') ++b;
  if (b == e) return false;
  if constexpr (std::is_floating_point_v<T>) {
    const auto r = std::from_chars(b, e, out);
    return r.ec == std::errc() && r.ptr == e;
  } else {
    const auto r = std::from_chars(b, e, out);
    if (r.ec == std::errc() && r.ptr == e) return true;
    // Integers written as "3.0" or "1e3": accept when whole and in range.
    double d = 0;
    const auto rd = std::from_chars(b, e, d);
    if (rd.ec != std::errc() || rd.ptr != e || !std::isfinite(d) || d != std::floor(d))
      return false;
    if (d < static_cast<double>(std::numeric_limits<T>::min()) ||
        d >= static_cast<double>(std::numeric_limits<T>::max()) + 1.0)
      return false;
    out = static_cast<T>(d);
    return true;
  }
}

template <class T>
void parseAscii(const char* p, const char* e, int64_t n, unsigned char* dst, VoxelType type,
                const std::string& what) {
  for (int64_t i = 0; i < n; ++i) {
    while (p < e && isAsciiSeparator(*p)) ++p;
    if (p == e) {
      throw InputError(what + ": ascii data are truncated: they hold " + std::to_string(i) +
                       " values, expected " + std::to_string(n) + " values");
    }
    const char* q = p;
    while (q < e && !isAsciiSeparator(*q)) ++q;
    T v{};
    if (!parseAsciiValue<T>(p, q, v)) {
      throw InputError(what + ": ascii value " + std::to_string(i + 1) + " " +
                       shown(std::string_view(p, static_cast<size_t>(q - p))) + " is not a valid " +
                       voxelTypeName(type) + " number");
    }
    std::memcpy(dst + static_cast<size_t>(i) * sizeof(T), &v, sizeof(T));
    p = q;
  }
}

void parseAsciiData(const char* p, const char* e, RawVolume& raw, int64_t n,
                    const std::string& what) {
  unsigned char* dst = raw.bytes.data();
  switch (raw.type) {
    case VoxelType::Int8: parseAscii<int8_t>(p, e, n, dst, raw.type, what); break;
    case VoxelType::UInt8: parseAscii<uint8_t>(p, e, n, dst, raw.type, what); break;
    case VoxelType::Int16: parseAscii<int16_t>(p, e, n, dst, raw.type, what); break;
    case VoxelType::UInt16: parseAscii<uint16_t>(p, e, n, dst, raw.type, what); break;
    case VoxelType::Int32: parseAscii<int32_t>(p, e, n, dst, raw.type, what); break;
    case VoxelType::UInt32: parseAscii<uint32_t>(p, e, n, dst, raw.type, what); break;
    case VoxelType::Int64: parseAscii<int64_t>(p, e, n, dst, raw.type, what); break;
    case VoxelType::UInt64: parseAscii<uint64_t>(p, e, n, dst, raw.type, what); break;
    case VoxelType::Float32: parseAscii<float>(p, e, n, dst, raw.type, what); break;
    case VoxelType::Float64: parseAscii<double>(p, e, n, dst, raw.type, what); break;
  }
}

void readData(const Layout& L, RawVolume& raw) {
  std::ifstream in;
  openOrFail(in, L.dataPath, L.what);
  const int64_t fileSize = fileSizeOrFail(L.dataPath, L.what);
  const int64_t start = skipLines(in, L.dataStart, L.lineSkip, L.what);
  const int64_t M = L.byteCount;

  switch (L.encoding) {
    case NrrdEncoding::Raw: {
      int64_t offset = 0;
      int64_t available = 0;
      if (L.byteSkip == -1) {
        available = fileSize - start;
        offset = fileSize - M;
      } else {
        offset = start + L.byteSkip;
        available = std::max<int64_t>(0, fileSize - offset);
      }
      if (available < M)
        throw InputError(L.what + ": data are truncated: the file holds " +
                         std::to_string(available) + " bytes, expected " + std::to_string(M) +
                         " (" + std::to_string(L.count) + " " + voxelTypeName(L.type) + " values)");
      if (L.byteSkip != -1 && available > M)
        throw InputError(L.what + ": the file holds " + std::to_string(available) + " bytes of data but the header's " +
                         "sizes and type announce " + std::to_string(M) + " (" + std::to_string(L.count) + " " +
                         voxelTypeName(L.type) + " values); the sizes or the type are wrong (use 'byte skip: -1' " +
                         "for data at the end of a longer file)");
      raw.bytes.resize(static_cast<size_t>(M));
      readAt(in, offset, reinterpret_cast<char*>(raw.bytes.data()), M, L.what);
      break;
    }
    case NrrdEncoding::Gzip: {
      const int64_t compressed = std::max<int64_t>(0, fileSize - start);
      const int64_t need = L.byteSkip + M;
      if (need > maxInflatedSize(compressed))
        throw InputError(L.what + ": the header announces " + std::to_string(M) +
                         " bytes of data but the file's " + std::to_string(compressed) +
                         " compressed bytes cannot hold that much; the sizes or the type are "
                         "wrong, or the file is truncated");
      std::vector<char> packed(static_cast<size_t>(compressed));
      readAt(in, start, packed.data(), compressed, L.what);
      std::vector<char> plain = gunzip(packed.data(), packed.size(), need, L.what, true);
      std::vector<char>().swap(packed);
      raw.bytes.resize(static_cast<size_t>(M));
      if (M > 0) std::memcpy(raw.bytes.data(), plain.data() + L.byteSkip, static_cast<size_t>(M));
      break;
    }
    case NrrdEncoding::Ascii: {
      const int64_t offset = start + L.byteSkip;
      const int64_t textBytes = std::max<int64_t>(0, fileSize - offset);
      // Every value but the last needs a separator: n values need at least 2n-1 characters.
      if (L.count > (textBytes + 1) / 2)
        throw InputError(L.what + ": ascii data are truncated: " + std::to_string(textBytes) +
                         " bytes of text hold fewer than the expected " + std::to_string(L.count) +
                         " values");
      std::vector<char> text(static_cast<size_t>(textBytes));
      readAt(in, offset, text.data(), textBytes, L.what);
      raw.bytes.resize(static_cast<size_t>(M));
      parseAsciiData(text.data(), text.data() + text.size(), raw, L.count, L.what);
      return; // values are already in host order
    }
  }
  const size_t size = voxelTypeSize(raw.type);
  if (size > 1 && L.bigEndian == hostIsLittleEndian())
    byteSwapInPlace(raw.bytes.data(), static_cast<size_t>(L.count), size);
}

// ------------------------------------------------------------------------------------------------
// Writer helpers

const char* nrrdTypeName(VoxelType t) {
  switch (t) {
    case VoxelType::Int8: return "signed char";
    case VoxelType::UInt8: return "unsigned char";
    case VoxelType::Int16: return "short";
    case VoxelType::UInt16: return "unsigned short";
    case VoxelType::Int32: return "int";
    case VoxelType::UInt32: return "unsigned int";
    case VoxelType::Int64: return "long long int";
    case VoxelType::UInt64: return "unsigned long long int";
    case VoxelType::Float32: return "float";
    case VoxelType::Float64: return "double";
  }
  return "?";
}

std::string fmt(double x) {
  char b[40];
  std::snprintf(b, sizeof b, "%.17g", x);
  return b;
}

template <class T>
void appendAscii(std::string& out, const unsigned char* src, int64_t n, int64_t perLine) {
  char b[64];
  for (int64_t i = 0; i < n; ++i) {
    T v;
    std::memcpy(&v, src + static_cast<size_t>(i) * sizeof(T), sizeof(T));
    const auto r = std::to_chars(b, b + sizeof b, v); // shortest exact form for floats
    out.append(b, r.ptr);
    out += ((i + 1) % perLine == 0 || i + 1 == n) ? '\n' : ' ';
  }
}

std::string asciiText(const RawVolume& v) {
  const int64_t n = v.grid.voxelCount();
  const int64_t perLine = std::max<int64_t>(1, v.grid.dims[0]);
  std::string out;
  out.reserve(static_cast<size_t>(n) * 4);
  const unsigned char* s = v.bytes.data();
  switch (v.type) {
    case VoxelType::Int8: appendAscii<int8_t>(out, s, n, perLine); break;
    case VoxelType::UInt8: appendAscii<uint8_t>(out, s, n, perLine); break;
    case VoxelType::Int16: appendAscii<int16_t>(out, s, n, perLine); break;
    case VoxelType::UInt16: appendAscii<uint16_t>(out, s, n, perLine); break;
    case VoxelType::Int32: appendAscii<int32_t>(out, s, n, perLine); break;
    case VoxelType::UInt32: appendAscii<uint32_t>(out, s, n, perLine); break;
    case VoxelType::Int64: appendAscii<int64_t>(out, s, n, perLine); break;
    case VoxelType::UInt64: appendAscii<uint64_t>(out, s, n, perLine); break;
    case VoxelType::Float32: appendAscii<float>(out, s, n, perLine); break;
    case VoxelType::Float64: appendAscii<double>(out, s, n, perLine); break;
  }
  return out;
}

void writeAll(std::ofstream& out, const char* data, size_t n) {
  out.write(data, static_cast<std::streamsize>(n));
}

} // namespace

namespace {

// 3D Slicer's segmentation files (.seg.nrrd) name their segments in key:=value pairs:
// SegmentN_Name, SegmentN_LabelValue and SegmentN_Layer. Segments of layer 0 (or with no layer)
// that have both a name and a label value name that label.
std::map<int32_t, std::string> slicerSegmentNames(const Header& h) {
  std::map<int32_t, std::string> names;
  for (const auto& [key, value] : h.keyValues) {
    if (key.rfind("Segment", 0) != 0 || key.size() < 13 || key.compare(key.size() - 5, 5, "_Name") != 0) continue;
    const std::string segment = key.substr(0, key.size() - 5);
    auto label = h.keyValues.find(segment + "_LabelValue");
    auto layer = h.keyValues.find(segment + "_Layer");
    if (label == h.keyValues.end() || (layer != h.keyValues.end() && trim(layer->second) != "0")) continue;
    int32_t L = 0;
    const std::string_view text = trim(label->second);
    auto r = std::from_chars(text.data(), text.data() + text.size(), L);
    if (r.ec != std::errc() || r.ptr != text.data() + text.size() || value.empty()) continue;
    names[L] = value;
  }
  return names;
}

} // namespace

RawVolume readNrrd(const std::string& path) {
  const Header h = readHeader(path);
  const Layout L = interpret(h);
  RawVolume raw;
  raw.grid = L.grid;
  raw.type = L.type;
  readData(L, raw);
  raw.labelNames = slicerSegmentNames(h);
  return raw;
}

void writeNrrd(const std::string& path, const RawVolume& v, NrrdEncoding enc) {
  v.grid.validate(path + ": cannot write");
  const size_t size = voxelTypeSize(v.type);
  if (size == 0) throw InputError(path + ": cannot write: unknown voxel type");
  const size_t expected = static_cast<size_t>(v.grid.voxelCount()) * size;
  if (v.bytes.size() != expected)
    throw InputError(path + ": cannot write: the volume holds " + std::to_string(v.bytes.size()) +
                     " bytes of voxel data, expected " + std::to_string(expected));
  if (enc != NrrdEncoding::Raw && enc != NrrdEncoding::Gzip && enc != NrrdEncoding::Ascii)
    throw InputError(path + ": cannot write: unknown NRRD encoding");

  const bool detached = fileExtension(path) == ".nhdr";
  const fs::path target(path);
  const char* dataSuffix = enc == NrrdEncoding::Raw    ? ".raw"
                           : enc == NrrdEncoding::Gzip ? ".raw.gz"
                                                       : ".txt";
  const std::string dataName = target.stem().string() + dataSuffix;
  const std::string dataPath = (target.parent_path() / dataName).string();

  // Open every output first: a missing folder fails before anything is written.
  AtomicOutputFile headerOut(path);
  std::optional<AtomicOutputFile> dataOut;
  if (detached) dataOut.emplace(dataPath);

  std::ostringstream hdr;
  hdr << "NRRD0004\n"
      << "# Complete NRRD file format specification at:\n"
      << "# http://teem.sourceforge.net/nrrd/format.html\n"
      << "type: " << nrrdTypeName(v.type) << "\n"
      << "dimension: 3\n"
      << "space: left-posterior-superior\n"
      << "sizes: " << v.grid.dims[0] << " " << v.grid.dims[1] << " " << v.grid.dims[2] << "\n"
      << "space directions:";
  for (int c = 0; c < 3; ++c) {
    hdr << " (";
    for (int r = 0; r < 3; ++r)
      hdr << (r ? "," : "") << fmt(v.grid.direction[r][c] * v.grid.spacing[c]);
    hdr << ")";
  }
  hdr << "\nkinds: domain domain domain\n";
  if (size > 1) hdr << "endian: little\n";
  hdr << "encoding: "
      << (enc == NrrdEncoding::Raw    ? "raw"
          : enc == NrrdEncoding::Gzip ? "gzip"
                                      : "ascii")
      << "\n"
      << "space origin: (" << fmt(v.grid.origin[0]) << "," << fmt(v.grid.origin[1]) << ","
      << fmt(v.grid.origin[2]) << ")\n";
  if (detached) hdr << "data file: " << dataName << "\n";
  hdr << "\n";
  const std::string header = hdr.str();

  // Little-endian payload.
  const unsigned char* src = v.bytes.data();
  std::vector<unsigned char> swapped;
  if (size > 1 && !hostIsLittleEndian() && enc != NrrdEncoding::Ascii) {
    swapped = v.bytes;
    byteSwapInPlace(swapped.data(), static_cast<size_t>(v.grid.voxelCount()), size);
    src = swapped.data();
  }
  std::ofstream& dataStream = detached ? dataOut->stream() : headerOut.stream();
  if (detached)
    writeAll(headerOut.stream(), header.data(), header.size());
  else
    writeAll(dataStream, header.data(), header.size());
  switch (enc) {
    case NrrdEncoding::Raw:
      writeAll(dataStream, reinterpret_cast<const char*>(src), v.bytes.size());
      break;
    case NrrdEncoding::Gzip: {
      const std::string packed = gzipCompress(reinterpret_cast<const char*>(src), v.bytes.size());
      writeAll(dataStream, packed.data(), packed.size());
      break;
    }
    case NrrdEncoding::Ascii: {
      const std::string text = asciiText(v);
      writeAll(dataStream, text.data(), text.size());
      break;
    }
  }
  if (detached) dataOut->commit();
  headerOut.commit();
}

} // namespace tetflow
