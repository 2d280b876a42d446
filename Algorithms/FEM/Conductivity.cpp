#include "Conductivity.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <sstream>

#include "Algorithms/Core/Errors.h"

namespace tetflow {

namespace {

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return {};
  const auto e = s.find_last_not_of(" \t\r\n");
  return s.substr(b, e - b + 1);
}

// Whole-string number parse; false when anything is left over or the value is not finite.
bool parseNumber(const std::string& text, double& out) {
  const std::string t = trim(text);
  if (t.empty()) return false;
  char* end = nullptr;
  errno = 0;
  out = std::strtod(t.c_str(), &end);
  return end == t.c_str() + t.size() && errno != ERANGE && std::isfinite(out);
}

bool parseLabel(const std::string& text, int32_t& out) {
  const std::string t = trim(text);
  if (t.empty()) return false;
  char* end = nullptr;
  errno = 0;
  const long long v = std::strtoll(t.c_str(), &end, 10);
  if (end != t.c_str() + t.size() || errno == ERANGE) return false;
  if (v < INT32_MIN || v > INT32_MAX) return false;
  out = static_cast<int32_t>(v);
  return true;
}

std::vector<std::string> splitNumbers(const std::string& text) {
  std::string s = text;
  for (char& c : s)
    if (c == ',') c = ' ';
  std::istringstream in(s);
  std::vector<std::string> out;
  std::string tok;
  while (in >> tok) out.push_back(tok);
  return out;
}

// Splits "label:rest"; throws naming `what` and the entry.
void splitEntry(const std::string& item, const std::string& what, int32_t& label, std::string& rest) {
  const auto colon = item.find(':');
  std::string msg = what;
  msg += ": entry '";
  msg += item;
  msg += "'";
  if (colon == std::string::npos) {
    msg += " has no ':'; write label:value, e.g. 1:0.33";
    throw InputError(msg);
  }
  const std::string lab = trim(item.substr(0, colon));
  if (!parseLabel(lab, label)) {
    msg += ": label '";
    msg += lab;
    msg += "' is not an integer material label";
    throw InputError(msg);
  }
  rest = item.substr(colon + 1);
}

std::string entryPrefix(const std::string& what, const std::string& item) {
  std::string msg = what;
  msg += ": entry '";
  msg += item;
  msg += "'";
  return msg;
}

} // namespace

bool isPositiveDefinite(const SymTensor6& s) {
  for (double v : s)
    if (!std::isfinite(v)) return false;
  const Mat3 m = tensorMatrix(s);
  const double m1 = m[0][0];
  const double m2 = m[0][0] * m[1][1] - m[0][1] * m[1][0];
  return m1 > 0 && m2 > 0 && det(m) > 0;
}

SymTensor6 ConductivityTable::tensor(int32_t label) const {
  auto it = byLabel.find(label);
  return it == byLabel.end() ? isotropicTensor(defaultSigma) : it->second;
}

bool ConductivityTable::isotropic(int32_t label) const {
  const SymTensor6 s = tensor(label);
  return s[3] == 0 && s[4] == 0 && s[5] == 0 && s[0] == s[1] && s[1] == s[2];
}

void ConductivityTable::validate() const {
  if (!std::isfinite(defaultSigma) || defaultSigma <= 0) {
    std::ostringstream m;
    m << "default_conductivity = " << defaultSigma << " S/m: must be a finite number > 0";
    throw InputError(m.str());
  }
  for (const auto& [label, s] : byLabel)
    if (!isPositiveDefinite(s)) {
      std::ostringstream m;
      m << "conductivities: the conductivity of label " << label
        << " is not positive definite (xx yy zz xy yz xz = " << s[0] << " " << s[1] << " " << s[2]
        << " " << s[3] << " " << s[4] << " " << s[5] << " S/m)";
      throw InputError(m.str());
    }
}

ConductivityTable parseConductivities(const std::vector<std::string>& items, double defaultSigma) {
  ConductivityTable table;
  table.defaultSigma = defaultSigma;
  const std::string what = "conductivities";
  for (const std::string& raw : items) {
    const std::string item = trim(raw);
    if (item.empty()) continue;
    int32_t label = 0;
    std::string rest;
    splitEntry(item, what, label, rest);
    if (table.byLabel.count(label)) {
      std::string msg = entryPrefix(what, item);
      msg += ": label ";
      msg += std::to_string(label);
      msg += " is listed twice";
      throw InputError(msg);
    }
    const auto toks = splitNumbers(rest);
    std::vector<double> v;
    for (const auto& t : toks) {
      double d = 0;
      if (!parseNumber(t, d)) {
        std::string msg = entryPrefix(what, item);
        msg += ": '";
        msg += t;
        msg += "' is not a finite number";
        throw InputError(msg);
      }
      v.push_back(d);
    }
    if (v.size() == 1) {
      if (v[0] <= 0) {
        std::string msg = entryPrefix(what, item);
        msg += ": sigma must be > 0 S/m";
        throw InputError(msg);
      }
      table.set(label, v[0]);
    } else if (v.size() == 6) {
      const SymTensor6 s{v[0], v[1], v[2], v[3], v[4], v[5]};
      if (!isPositiveDefinite(s)) {
        std::string msg = entryPrefix(what, item);
        msg += ": the tensor (xx yy zz xy yz xz) is not positive definite";
        throw InputError(msg);
      }
      table.set(label, s);
    } else {
      std::string msg = entryPrefix(what, item);
      msg += ": give 1 value (isotropic sigma, S/m) or 6 (tensor xx yy zz xy yz xz), not ";
      msg += std::to_string(v.size());
      throw InputError(msg);
    }
  }
  table.validate();
  return table;
}

std::map<int32_t, double> parseLabelValues(const std::vector<std::string>& items, const std::string& what) {
  std::map<int32_t, double> out;
  for (const std::string& raw : items) {
    const std::string item = trim(raw);
    if (item.empty()) continue;
    int32_t label = 0;
    std::string rest;
    splitEntry(item, what, label, rest);
    double v = 0;
    if (!parseNumber(rest, v)) {
      std::string msg = entryPrefix(what, item);
      msg += ": '";
      msg += trim(rest);
      msg += "' is not a finite number";
      throw InputError(msg);
    }
    if (!out.emplace(label, v).second) {
      std::string msg = entryPrefix(what, item);
      msg += ": label ";
      msg += std::to_string(label);
      msg += " is listed twice";
      throw InputError(msg);
    }
  }
  return out;
}

std::vector<double> parseNumbers(const std::string& text, const std::string& what) {
  std::vector<double> v;
  for (const std::string& tok : splitNumbers(text)) {
    double x = 0;
    if (!parseNumber(tok, x))
      throw InputError(what + ": '" + tok + "' is not a finite number (give numbers separated by spaces)");
    v.push_back(x);
  }
  return v;
}

std::vector<int32_t> parseLabels(const std::vector<std::string>& items, const std::string& what) {
  std::vector<int32_t> out;
  for (const std::string& item : items) {
    int32_t l = 0;
    if (!parseLabel(item, l)) throw InputError(what + ": '" + item + "' is not an integer label");
    out.push_back(l);
  }
  return out;
}

Vec3 parseVec3(const std::string& text, const std::string& what) {
  const auto toks = splitNumbers(text);
  Vec3 v{0, 0, 0};
  bool ok = toks.size() == 3;
  for (size_t i = 0; ok && i < 3; ++i) ok = parseNumber(toks[i], v[i]);
  if (!ok) {
    std::string msg = what;
    msg += " = '";
    msg += text;
    msg += "': give three finite numbers \"x y z\"";
    throw InputError(msg);
  }
  return v;
}

} // namespace tetflow
