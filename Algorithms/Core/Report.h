#pragma once
// An ordered key -> value table of figures (counts, angles, condition numbers, timings).
// Keys keep their insertion order; setting an existing key replaces its value in place.
// Values are typed so reports serialise faithfully (JSON) and print with sensible precision.
#include <cstdint>
#include <string>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

namespace tetflow {

using ReportValue = std::variant<bool, int64_t, double, std::string>;

class Report {
public:
  void set(const std::string& key, ReportValue value);
  // Numbers keep their kind: integers (and bool) as such, floating point as double. (An `int`
  // overload alone would silently truncate a double argument.)
  template <class T>
    requires std::is_arithmetic_v<T>
  void set(const std::string& key, T value) {
    if constexpr (std::is_same_v<T, bool>) set(key, ReportValue(value));
    else if constexpr (std::is_integral_v<T>) set(key, ReportValue(int64_t(value)));
    else set(key, ReportValue(double(value)));
  }
  void set(const std::string& key, const char* value) { set(key, ReportValue(std::string(value))); }
  bool has(const std::string& key) const { return find(key) != nullptr; }
  const ReportValue* find(const std::string& key) const;
  double number(const std::string& key) const; // int or double value; throws if absent/not numeric
  const std::vector<std::pair<std::string, ReportValue>>& entries() const { return entries_; }
  bool empty() const { return entries_.empty(); }

private:
  std::vector<std::pair<std::string, ReportValue>> entries_;
};

// Human-readable value: integers as is, doubles with 6 significant digits, bools yes/no.
std::string formatReportValue(const ReportValue& v);

} // namespace tetflow
