#include "Report.h"

#include <cstdio>
#include <stdexcept>

namespace tetflow {

void Report::set(const std::string& key, ReportValue value) {
  for (auto& e : entries_)
    if (e.first == key) {
      e.second = std::move(value);
      return;
    }
  entries_.emplace_back(key, std::move(value));
}

const ReportValue* Report::find(const std::string& key) const {
  for (const auto& e : entries_)
    if (e.first == key) return &e.second;
  return nullptr;
}

double Report::number(const std::string& key) const {
  const ReportValue* v = find(key);
  if (!v) throw std::out_of_range("report has no entry '" + key + "'");
  if (const auto* i = std::get_if<int64_t>(v)) return static_cast<double>(*i);
  if (const auto* d = std::get_if<double>(v)) return *d;
  throw std::invalid_argument("report entry '" + key + "' is not a number");
}

std::string formatReportValue(const ReportValue& v) {
  struct Visitor {
    std::string operator()(bool b) const { return b ? "yes" : "no"; }
    std::string operator()(int64_t i) const { return std::to_string(i); }
    std::string operator()(double d) const {
      char buf[64];
      std::snprintf(buf, sizeof buf, "%.6g", d);
      return buf;
    }
    std::string operator()(const std::string& s) const { return s; }
  };
  return std::visit(Visitor{}, v);
}

} // namespace tetflow
