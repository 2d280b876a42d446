// Label tables (see LabelTable.h).
#include "LabelTable.h"

#include <charconv>
#include <cmath>
#include <filesystem>
#include <limits>
#include <string_view>
#include <vector>

#include "../Core/Errors.h"
#include "FileUtil.h"
#include "HeaderText.h"

namespace tetflow {

namespace {


std::vector<std::string_view> whitespaceTokens(std::string_view l) {
  std::vector<std::string_view> t;
  size_t i = 0;
  while (i < l.size()) {
    while (i < l.size() && (l[i] == ' ' || l[i] == '\t' || l[i] == '\r')) ++i;
    size_t j = i;
    while (j < l.size() && l[j] != ' ' && l[j] != '\t' && l[j] != '\r') ++j;
    if (j > i) t.push_back(l.substr(i, j - i));
    i = j;
  }
  return t;
}

bool isInteger(std::string_view t, int64_t* out = nullptr) {
  if (!t.empty() && t[0] == '+') t.remove_prefix(1);
  int64_t v = 0;
  auto r = std::from_chars(t.data(), t.data() + t.size(), v);
  if (r.ec != std::errc() || r.ptr != t.data() + t.size()) return false;
  if (out) *out = v;
  return true;
}

bool isNumber(std::string_view t, double* out = nullptr) {
  if (!t.empty() && t[0] == '+') t.remove_prefix(1);
  double v = 0;
  auto r = std::from_chars(t.data(), t.data() + t.size(), v);
  if (r.ec != std::errc() || r.ptr != t.data() + t.size()) return false;
  if (out) *out = v;
  return true;
}

// ITK-SNAP: IDX R G B A VIS MSH "name".
bool itkSnapLine(std::string_view l) {
  const size_t q = l.find('"');
  if (q == std::string_view::npos || l.rfind('"') == q) return false;
  const auto t = whitespaceTokens(l.substr(0, q));
  if (t.size() != 7 || !isInteger(t[0])) return false;
  for (size_t k = 1; k < 7; ++k)
    if (!isNumber(t[k])) return false;
  return true;
}

// FreeSurfer: label name R G B A.
bool freeSurferLine(std::string_view l) {
  const auto t = whitespaceTokens(l);
  if (t.size() != 6 || !isInteger(t[0]) || isNumber(t[1])) return false;
  for (size_t k = 2; k < 6; ++k)
    if (!isInteger(t[k])) return false;
  return true;
}

// Splits a CSV/TSV row at `sep`; double quotes protect separators ("" is a quote).
std::vector<std::string> fields(std::string_view l, char sep) {
  std::vector<std::string> out(1);
  bool quoted = false;
  for (size_t i = 0; i < l.size(); ++i) {
    const char c = l[i];
    if (c == '"') {
      if (quoted && i + 1 < l.size() && l[i + 1] == '"') {
        out.back() += '"';
        ++i;
      } else {
        quoted = !quoted;
      }
    } else if (c == sep && !quoted) {
      out.emplace_back();
    } else {
      out.back() += c;
    }
  }
  for (auto& f : out) f = std::string(headertext::trim(f));
  return out;
}

} // namespace

LabelTable readLabelTable(const std::string& path) {
  const std::vector<char> bytes = readFileBytes(path);
  const std::string_view text(bytes.data(), bytes.size());
  LabelTable table;
  enum class Kind { Unknown, ItkSnap, FreeSurfer, Delimited } kind = Kind::Unknown;
  char sep = ',';
  size_t line = 0, pos = 0;
  auto fail = [&](const std::string& problem) {
    throw InputError(path + ", line " + std::to_string(line) + ": " + problem);
  };
  auto add = [&](std::string_view labelText, std::string name) {
    int64_t label = 0;
    if (!isInteger(labelText, &label) || label < std::numeric_limits<int32_t>::min() ||
        label > std::numeric_limits<int32_t>::max())
      fail("label '" + std::string(labelText) + "' is not a 32-bit integer");
    if (name.empty()) fail("label " + std::to_string(label) + " has an empty name");
    if (!table.names.emplace(int32_t(label), std::move(name)).second)
      fail("label " + std::to_string(label) + " is listed twice");
    return int32_t(label);
  };
  while (pos < text.size()) {
    size_t end = text.find('\n', pos);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view l = headertext::trim(text.substr(pos, end - pos));
    pos = end + 1;
    ++line;
    if (l.empty() || l[0] == '#') continue;
    if (kind == Kind::Unknown) {
      if (itkSnapLine(l)) {
        kind = Kind::ItkSnap;
        table.format = "ITK-SNAP";
      } else if (freeSurferLine(l)) {
        kind = Kind::FreeSurfer;
        table.format = "FreeSurfer";
      } else {
        kind = Kind::Delimited;
        sep = l.find(',') != std::string_view::npos    ? ','
              : l.find('\t') != std::string_view::npos ? '\t'
              : l.find(';') != std::string_view::npos  ? ';'
                                                       : '\0';
        if (sep == '\0')
          fail("not a label table line: '" + std::string(l.substr(0, 80)) +
               "' (expected an ITK-SNAP label description, a FreeSurfer colour table, or CSV/TSV rows "
               "'label, name[, conductivity]')");
        table.format = sep == '\t' ? "TSV" : "CSV";
        const auto f = fields(l, sep);
        if (!isInteger(f[0])) continue; // a header row
      }
    }
    switch (kind) {
    case Kind::ItkSnap: {
      if (!itkSnapLine(l)) fail("not an ITK-SNAP label line (IDX R G B A VIS MSH \"name\"): '" + std::string(l.substr(0, 80)) + "'");
      const size_t q = l.find('"'), r = l.rfind('"');
      add(whitespaceTokens(l)[0], std::string(l.substr(q + 1, r - q - 1)));
      break;
    }
    case Kind::FreeSurfer: {
      if (!freeSurferLine(l)) fail("not a FreeSurfer colour table line (label name R G B A): '" + std::string(l.substr(0, 80)) + "'");
      const auto t = whitespaceTokens(l);
      add(t[0], std::string(t[1]));
      break;
    }
    case Kind::Delimited: {
      const auto f = fields(l, sep);
      if (f.size() < 2 || f.size() > 3)
        fail("expected 'label" + std::string(1, sep) + " name[" + std::string(1, sep) + " conductivity]', found " +
             std::to_string(f.size()) + " fields");
      const int32_t label = add(f[0], f[1]);
      if (f.size() == 3 && !f[2].empty()) {
        double c = 0;
        if (!isNumber(f[2], &c) || !std::isfinite(c) || c <= 0)
          fail("the conductivity of label " + std::to_string(label) + " ('" + f[2] + "') is not a positive number (S/m)");
        table.conductivities[label] = c;
      }
      break;
    }
    case Kind::Unknown: break;
    }
  }
  if (table.names.empty()) throw InputError(path + ": the label table has no entry");
  return table;
}

std::string labelTableBeside(const std::string& volumePath) {
  namespace fs = std::filesystem;
  std::string stem = volumePath.substr(0, volumePath.size() - fileExtension(volumePath).size());
  if (stem.size() > 4 && stem.compare(stem.size() - 4, 4, ".seg") == 0) stem.resize(stem.size() - 4);
  for (const char* suffix : {"_LUT.txt", ".lut", ".ctbl", ".label", ".txt", ".csv", ".tsv"}) {
    const std::string candidate = stem + suffix;
    std::error_code ec;
    if (fs::is_regular_file(candidate, ec)) return candidate;
  }
  return {};
}

} // namespace tetflow
