#include "Parameter.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <sstream>

namespace tetflow {

namespace {
std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return "";
  const auto e = s.find_last_not_of(" \t\r\n");
  return s.substr(b, e - b + 1);
}
std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}
std::string joinChoices(const std::vector<std::string>& c) {
  std::string s;
  for (const auto& x : c) s += (s.empty() ? "" : ", ") + x;
  return s;
}
} // namespace

const char* paramTypeName(ParamType t) {
  switch (t) {
    case ParamType::Bool: return "bool";
    case ParamType::Int: return "int";
    case ParamType::Double: return "double";
    case ParamType::String: return "string";
    case ParamType::Enum: return "enum";
    case ParamType::List: return "list";
  }
  return "?";
}

ParamSpec makeParam(std::string name, ParamType type, ParamValue def, std::string unit,
                    std::string description) {
  ParamSpec s;
  s.name = std::move(name);
  s.type = type;
  s.defaultValue = std::move(def);
  s.unit = std::move(unit);
  s.description = std::move(description);
  return s;
}

ParamSpec doubleParam(std::string name, double def, std::optional<double> min,
                      std::optional<double> max, std::string unit, std::string description) {
  ParamSpec s = makeParam(std::move(name), ParamType::Double, def, std::move(unit), std::move(description));
  s.min = min;
  s.max = max;
  return s;
}

std::string formatDouble(double v) {
  char buf[64];
  auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

std::vector<std::string> splitList(const std::string& text) {
  std::vector<std::string> items;
  std::string cur;
  std::istringstream in(text);
  while (std::getline(in, cur, ';')) {
    cur = trim(cur);
    if (!cur.empty()) items.push_back(cur);
  }
  return items;
}

std::string describeAllowed(const ParamSpec& s) {
  std::ostringstream m;
  m << paramTypeName(s.type);
  if (s.type == ParamType::Enum) m << ": one of " << joinChoices(s.choices);
  if (s.min && s.max) m << " in [" << formatDouble(*s.min) << ", " << formatDouble(*s.max) << "]";
  else if (s.min) m << " >= " << formatDouble(*s.min);
  else if (s.max) m << " <= " << formatDouble(*s.max);
  if (!s.unit.empty()) m << " (" << s.unit << ")";
  return m.str();
}

bool checkParam(const ParamSpec& s, const ParamValue& v, std::string& error) {
  auto range = [&](double x) {
    if (!std::isfinite(x)) {
      error = "is not a finite number";
      return false;
    }
    if ((s.min && x < *s.min) || (s.max && x > *s.max)) {
      error = formatDouble(x) + " is out of range; allowed: " + describeAllowed(s);
      return false;
    }
    return true;
  };
  switch (s.type) {
    case ParamType::Bool:
      if (!std::holds_alternative<bool>(v)) { error = "expected true or false"; return false; }
      return true;
    case ParamType::Int:
      if (!std::holds_alternative<int64_t>(v)) { error = "expected a whole number"; return false; }
      return range(static_cast<double>(std::get<int64_t>(v)));
    case ParamType::Double:
      if (!std::holds_alternative<double>(v)) { error = "expected a number"; return false; }
      return range(std::get<double>(v));
    case ParamType::String:
      if (!std::holds_alternative<std::string>(v)) { error = "expected text"; return false; }
      return true;
    case ParamType::Enum: {
      if (!std::holds_alternative<std::string>(v)) { error = "expected a name"; return false; }
      const auto& x = std::get<std::string>(v);
      if (std::find(s.choices.begin(), s.choices.end(), x) == s.choices.end()) {
        error = "'" + x + "' is not a valid choice; use one of " + joinChoices(s.choices);
        return false;
      }
      return true;
    }
    case ParamType::List:
      if (!std::holds_alternative<std::vector<std::string>>(v)) { error = "expected a list"; return false; }
      for (const auto& item : std::get<std::vector<std::string>>(v))
        if (item.find(';') != std::string::npos) { error = "list items cannot contain ';'"; return false; }
      return true;
  }
  return false;
}

std::optional<ParamValue> parseParam(const ParamSpec& s, const std::string& raw, std::string& error) {
  const std::string text = trim(raw);
  ParamValue v;
  switch (s.type) {
    case ParamType::Bool: {
      const std::string t = lower(text);
      if (t == "true" || t == "1" || t == "yes" || t == "on") v = true;
      else if (t == "false" || t == "0" || t == "no" || t == "off") v = false;
      else { error = "'" + text + "' is not a bool; use true or false"; return std::nullopt; }
      break;
    }
    case ParamType::Int: {
      int64_t x = 0;
      auto r = std::from_chars(text.data(), text.data() + text.size(), x);
      if (text.empty() || r.ec != std::errc() || r.ptr != text.data() + text.size()) {
        error = "'" + text + "' is not a whole number; allowed: " + describeAllowed(s);
        return std::nullopt;
      }
      v = x;
      break;
    }
    case ParamType::Double: {
      double x = 0;
      auto r = std::from_chars(text.data(), text.data() + text.size(), x);
      if (text.empty() || r.ec != std::errc() || r.ptr != text.data() + text.size()) {
        error = "'" + text + "' is not a number; allowed: " + describeAllowed(s);
        return std::nullopt;
      }
      v = x;
      break;
    }
    case ParamType::String: v = raw; break; // keep spaces in names as written
    case ParamType::Enum: v = text; break;
    case ParamType::List: v = splitList(raw); break;
  }
  if (!checkParam(s, v, error)) return std::nullopt;
  return v;
}

std::string formatParam(const ParamSpec& s, const ParamValue& v) {
  (void)s;
  struct Visitor {
    std::string operator()(bool b) const { return b ? "true" : "false"; }
    std::string operator()(int64_t i) const { return std::to_string(i); }
    std::string operator()(double d) const { return formatDouble(d); }
    std::string operator()(const std::string& x) const { return x; }
    std::string operator()(const std::vector<std::string>& l) const {
      std::string out;
      for (const auto& x : l) out += (out.empty() ? "" : "; ") + x;
      return out;
    }
  };
  return std::visit(Visitor{}, v);
}

} // namespace tetflow
