#include "ElectrodeIO.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <string_view>
#include <unordered_map>

#include "../Core/Errors.h"
#include "FileUtil.h"
#include "HeaderText.h"

namespace tetflow {
namespace {

constexpr int64_t kMaxFileBytes = int64_t(64) << 20;
constexpr size_t kMaxElectrodes = 1000000;

bool isBlank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }
bool isControl(char c) { return static_cast<unsigned char>(c) < 0x20 || c == 0x7f; }

std::string num(double v) {
  char b[32];
  return std::string(b, std::to_chars(b, b + sizeof b, v).ptr);
}

// A finite decimal number (an optional leading '+' allowed), stored in *out when given.
bool isNumber(std::string_view t, double* out = nullptr) {
  double v = 0;
  const bool ok = headertext::parseDouble(t, v) && std::isfinite(v);
  if (out) *out = v;
  return ok;
}

// Fields of a line split at `sep`, or at runs of blanks when sep == 0; at most maxFields + 1 are
// collected. Fields are trimmed and lose enclosing double quotes; a trailing empty one is dropped.
std::vector<std::string_view> split(std::string_view l, char sep, size_t maxFields = 8) {
  std::vector<std::string_view> f;
  for (size_t i = 0; i <= l.size() && f.size() <= maxFields;) {
    while (sep == 0 && i < l.size() && isBlank(l[i])) ++i;
    if (sep == 0 && i == l.size()) break;
    size_t j = i;
    while (j < l.size() && (sep ? l[j] != sep : !isBlank(l[j]))) ++j;
    std::string_view t = headertext::trim(l.substr(i, j - i));
    if (t.size() >= 2 && t.front() == '"' && t.back() == '"') t = t.substr(1, t.size() - 2);
    f.push_back(t);
    i = j + 1;
  }
  if (!f.empty() && f.back().empty()) f.pop_back();
  return f;
}

std::string countOf(const std::vector<std::string_view>& f) {
  return f.size() > 8 ? "more than 8 fields" : std::to_string(f.size()) + " field(s)";
}

struct Line {
  std::string_view text; // trimmed; never empty, never a comment
  int no = 0;            // 1-based
};

// Hands out the file's non-blank, non-comment lines and collects the electrodes.
class Reader {
public:
  explicit Reader(const std::string& path) : path_(path) {
    int64_t size = 0;
    data_ = readFilePrefix(path, kMaxFileBytes + 1, &size);
    if (size > kMaxFileBytes)
      fail(0, "the file is " + std::to_string(size >> 20) +
                  " MiB, far too large for an electrode position file (wrong file?)");
    rest_ = std::string_view(data_.data(), data_.size());
    if (rest_.substr(0, 3) == "\xEF\xBB\xBF") rest_.remove_prefix(3); // UTF-8 byte order mark
  }

  // The next non-blank, non-comment line; false at the end of the file.
  bool next(Line& l) {
    while (!rest_.empty()) {
      const size_t eol = std::min(rest_.find('\n'), rest_.size());
      l = {headertext::trim(rest_.substr(0, eol)), ++no_};
      rest_.remove_prefix(std::min(eol + 1, rest_.size()));
      if (!l.text.empty() && l.text.front() != '#') return true;
    }
    return false;
  }

  [[noreturn]] void fail(int line, const std::string& what) const {
    throw InputError(path_ + (line > 0 ? ", line " + std::to_string(line) : "") + ": " + what);
  }

  Vec3 coords(const std::vector<std::string_view>& f, size_t first, int line) const {
    Vec3 p{};
    for (size_t a = 0; a < 3; ++a) {
      const std::string_view t = f[first + a];
      if (!isNumber(t, &p[a]))
        fail(line, std::string("expected a finite number as the ") + "xyz"[a] +
                       " coordinate, found " + headertext::shown(t) +
                       (t.find(',') != t.npos ? " (use '.' as the decimal point)" : ""));
    }
    return p;
  }

  // nameLine: the line of the name (for .elc in the Labels section).
  void add(std::string_view name, const Vec3& p, int line, int nameLine) {
    if (name.empty()) fail(nameLine, "the electrode name is empty; give every electrode a name");
    if (std::any_of(name.begin(), name.end(), isControl))
      fail(nameLine,
           "the electrode name " + headertext::shown(name) + " contains control characters (not a text file?)");
    if (out_.size() >= kMaxElectrodes) fail(line, "too many electrodes (wrong file?)");
    const auto [it, fresh] = seen_.emplace(std::string(name), nameLine);
    if (!fresh)
      fail(nameLine, "electrode name " + headertext::shown(name) + " is used again (first on line " +
                         std::to_string(it->second) + "); names must be unique: rename one");
    out_.push_back({std::string(name), p, line});
  }
  size_t count() const { return out_.size(); }

  std::vector<Electrode> finish(double scale, const char* skipped) {
    if (out_.empty())
      fail(0,
           std::string("no electrodes found: the file is empty or holds only comments") + skipped);
    for (Electrode& e : out_) {
      e.position = scale * e.position;
      for (double v : e.position)
        if (!std::isfinite(v))
          fail(e.line, "a coordinate is out of range after scaling to mm by " + num(scale));
    }
    return std::move(out_);
  }

private:
  std::string path_;
  std::vector<char> data_;
  std::string_view rest_;
  int no_ = 0;
  std::unordered_map<std::string, int> seen_;
  std::vector<Electrode> out_;
};

std::vector<Electrode> readDelimited(Reader& r, double scale) {
  const auto detect = [](std::string_view l) -> char {
    for (char c : {'\t', ';', ','})
      if (l.find(c) != l.npos) return c;
    return 0;
  };
  Line l;
  bool more = r.next(l);
  if (more) { // a first line without any number is a header
    const auto f = split(l.text, detect(l.text));
    if (std::none_of(f.begin(), f.end(), [](std::string_view t) { return isNumber(t); }))
      more = r.next(l);
  }
  const char sep = more ? detect(l.text) : 0;
  const std::string sepName = sep == '\t'  ? "tabs"
                              : sep == ';' ? "semicolons"
                              : sep == ',' ? "commas"
                                           : "blanks";
  for (; more; more = r.next(l)) {
    const auto f = split(l.text, sep);
    if ((f.size() != 3 && f.size() != 4) || (f.size() == 3 && !isNumber(f[0])))
      r.fail(l.no, "expected 'name, x, y, z' or 'x, y, z' separated by " + sepName +
                       " (as on the first data line), found " + countOf(f) +
                       (f.size() == 3 ? ", the first, " + headertext::shown(f[0]) + ", not a number" : ""));
    const Vec3 p = r.coords(f, f.size() - 3, l.no);
    std::string name = "E"; // x, y, z only (two steps: GCC 12 warns falsely on "E" + string)
    name += std::to_string(r.count() + 1);
    r.add(f.size() == 4 ? std::string(f[0]) : name, p, l.no, l.no);
  }
  return r.finish(scale, " and a header");
}

// .elc keyword (first word up to a blank or '=', lower case) and value (the rest after any '=').
std::string elcKey(std::string_view t, std::string_view* value = nullptr) {
  size_t k = 0;
  while (k < t.size() && !isBlank(t[k]) && t[k] != '=') ++k;
  std::string_view v = headertext::trim(t.substr(k));
  if (value) *value = headertext::trim(v.substr(!v.empty() && v.front() == '=' ? 1 : 0));
  return headertext::canonical(t.substr(0, k));
}

std::vector<Electrode> readElc(Reader& r, double unitScale) {
  struct Pos {
    Vec3 p;
    int line;
    std::string_view label;
  };
  std::vector<Pos> pos;
  std::vector<std::pair<std::string_view, int>> labels;
  int announced = -1, countLine = 0, unitLine = 0, posLine = 0, labLine = 0;
  double scale = 1.0;
  const auto once = [&](int& seen, const Line& l, const std::string& what) {
    if (seen)
      r.fail(l.no, what + " appears again (first on line " + std::to_string(seen) + "); keep one");
    seen = l.no;
  };
  enum { None, InPositions, InLabels } section = None;
  bool any = false;
  for (Line l; r.next(l); any = true) {
    std::string_view val;
    const std::string key = elcKey(l.text, &val);
    const bool keyword = l.text.find('=') != l.text.npos || key == "numberpositions" ||
                         key == "unitposition" || key == "positions" || key == "labels";
    if (keyword) section = None;
    if (section == InPositions) {
      const size_t colon = l.text.find(':');
      const bool labelled = colon != l.text.npos;
      auto f = split(labelled ? l.text.substr(colon + 1) : l.text, 0);
      std::string_view label = labelled ? headertext::trim(l.text.substr(0, colon)) : std::string_view();
      if (!labelled && f.size() == 4) {
        label = f[0];
        f.erase(f.begin());
      }
      if (f.size() != 3)
        r.fail(l.no, "expected a position 'x y z' or 'Label: x y z', found " + countOf(f) +
                         "; the Positions section ends only at 'Labels' or another keyword");
      if (pos.size() >= kMaxElectrodes) r.fail(l.no, "too many positions (wrong file?)");
      pos.push_back({r.coords(f, 0, l.no), l.no, label});
    } else if (section == InLabels) {
      for (std::string_view t : split(l.text, 0, kMaxElectrodes)) labels.push_back({t, l.no});
      if (labels.size() > kMaxElectrodes) r.fail(l.no, "too many labels (wrong file?)");
    } else if (key == "numberpositions") {
      once(countLine, l, "NumberPositions");
      const auto res = std::from_chars(val.data(), val.data() + val.size(), announced);
      if (res.ec != std::errc() || res.ptr != val.data() + val.size() || announced < 0)
        r.fail(l.no, "expected 'NumberPositions= N' with a whole number N, found " + headertext::shown(val));
    } else if (key == "unitposition") {
      once(unitLine, l, "UnitPosition");
      const std::string u = headertext::canonical(val);
      scale = u == "mm" ? 1.0 : u == "cm" ? 10.0 : u == "m" ? 1000.0 : 0.0;
      if (scale == 0.0 && unitScale == 0.0)
        r.fail(l.no, "unknown UnitPosition " + headertext::shown(val) +
                         "; use mm, cm or m (or give the scale to mm explicitly)");
    } else if (key == "positions" && val.empty()) {
      once(posLine, l, "the Positions section");
      section = InPositions;
    } else if (key == "labels" && val.empty()) {
      once(labLine, l, "the Labels section");
      section = InLabels;
    } // other lines (ReferenceLabel, NumberPolygons=, Polygons, ...) are not needed
  }
  if (any && !posLine)
    r.fail(0,
           "no 'Positions' line; expected 'NumberPositions= N', 'Positions' and N lines "
           "'x y z', then 'Labels' and the N labels");
  if (countLine && pos.size() != size_t(announced))
    r.fail(countLine, "NumberPositions= " + std::to_string(announced) +
                          " but the Positions section (line " + std::to_string(posLine) +
                          ") holds " + std::to_string(pos.size()) +
                          " position(s); make the number agree with the list");
  if (labLine && labels.size() != pos.size())
    r.fail(labLine, "the Labels section holds " + std::to_string(labels.size()) +
                        " label(s) but there are " + std::to_string(pos.size()) +
                        " positions; give exactly one label per position");
  for (size_t k = 0; k < pos.size(); ++k) {
    if (!labLine && pos[k].label.empty())
      r.fail(pos[k].line, "no label for this position; add a Labels section or write 'L: x y z'");
    r.add(labLine ? labels[k].first : pos[k].label, pos[k].p, pos[k].line,
          labLine ? labels[k].second : pos[k].line);
  }
  return r.finish(unitScale > 0 ? unitScale : scale, "");
}

std::vector<Electrode> readSfp(Reader& r, double scale) {
  for (Line l; r.next(l);) {
    const auto f = split(l.text, 0);
    if (f.size() != 4)
      r.fail(l.no, "expected 'name x y z' separated by blanks, found " + countOf(f));
    const Vec3 p = r.coords(f, 1, l.no);
    if (headertext::canonical(f[0].substr(0, 3)) != "fid") r.add(f[0], p, l.no, l.no); // fiducials are skipped
  }
  return r.finish(scale, " and fiducials");
}

} // namespace

std::vector<Electrode> readElectrodes(const std::string& path, double unitScale) {
  if (!std::isfinite(unitScale) || unitScale < 0)
    throw InputError(path + ": invalid unit scale " + num(unitScale) +
                     "; give the factor to mm (e.g. 10 for a file in cm), or 0 for the file unit");
  const std::string ext = fileExtension(path);
  if (ext != ".csv" && ext != ".tsv" && ext != ".txt" && ext != ".elc" && ext != ".sfp")
    throw InputError(path + ": unknown electrode file extension '" + ext +
                     "'; supported: .csv, .tsv, .txt (name,x,y,z text), .elc (ASA/FieldTrip), "
                     ".sfp (BESA/EEGLAB)");
  Reader r(path);
  if (ext == ".elc") return readElc(r, unitScale);
  const double scale = unitScale > 0 ? unitScale : 1.0;
  return ext == ".sfp" ? readSfp(r, scale) : readDelimited(r, scale);
}

} // namespace tetflow
