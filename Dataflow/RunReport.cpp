#include "RunReport.h"

#include <cmath>
#include <cstdio>
#include <sstream>

namespace tetflow {

std::string jsonEscape(const std::string& s) {
  std::string o = "\"";
  for (unsigned char c : s) {
    switch (c) {
      case '"': o += "\\\""; break;
      case '\\': o += "\\\\"; break;
      case '\n': o += "\\n"; break;
      case '\r': o += "\\r"; break;
      case '\t': o += "\\t"; break;
      default:
        if (c < 0x20) {
          char b[8];
          std::snprintf(b, sizeof b, "\\u%04x", c);
          o += b;
        } else {
          o += static_cast<char>(c);
        }
    }
  }
  return o + "\"";
}

namespace {
std::string jsonNumber(double d) {
  if (!std::isfinite(d)) return "null";
  return formatDouble(d);
}
std::string jsonValue(const ReportValue& v) {
  struct V {
    std::string operator()(bool b) const { return b ? "true" : "false"; }
    std::string operator()(int64_t i) const { return std::to_string(i); }
    std::string operator()(double d) const { return jsonNumber(d); }
    std::string operator()(const std::string& s) const { return jsonEscape(s); }
  };
  return std::visit(V{}, v);
}
} // namespace

std::string executionReportJson(const std::string& networkFile, const Network& net,
                                const Executor& exec, const Executor::Summary& sum) {
  std::ostringstream o;
  o << "{\n  \"network\": " << jsonEscape(networkFile) << ",\n";
  o << "  \"success\": " << (sum.success ? "true" : "false") << ",\n";
  o << "  \"seconds\": " << jsonNumber(sum.seconds) << ",\n";
  o << "  \"counts\": {\"ran\": " << sum.ran << ", \"reused\": " << sum.reused
    << ", \"failed\": " << sum.failed << ", \"skipped\": " << sum.skipped
    << ", \"cancelled\": " << sum.cancelled << "},\n";
  o << "  \"modules\": [";
  bool firstM = true;
  for (const auto& id : net.topologicalOrder()) {
    const ModuleNode& m = net.requireModule(id);
    const ModuleState* s = exec.state(id);
    o << (firstM ? "\n" : ",\n") << "    {\"id\": " << jsonEscape(id)
      << ", \"module\": " << jsonEscape(m.info->name) << ", \"status\": "
      << jsonEscape(moduleStatusName(s ? s->status : ModuleStatus::Idle));
    firstM = false;
    if (s) {
      o << ", \"seconds\": " << jsonNumber(s->seconds) << ", \"reused\": " << (s->reused ? "true" : "false");
      if (!s->error.empty())
        o << ", \"error\": " << jsonEscape(s->error) << ", \"error_kind\": " << jsonEscape(s->errorKind);
      if (!s->skippedBecause.empty()) o << ", \"skipped_because\": " << jsonEscape(s->skippedBecause);
      o << ",\n     \"stages\": [";
      for (size_t i = 0; i < s->stages.size(); ++i)
        o << (i ? ", " : "") << "{\"name\": " << jsonEscape(s->stages[i].name)
          << ", \"seconds\": " << jsonNumber(s->stages[i].seconds) << "}";
      o << "],\n     \"messages\": [";
      for (size_t i = 0; i < s->messages.size(); ++i) o << (i ? ", " : "") << jsonEscape(s->messages[i]);
      o << "],\n     \"report\": {";
      bool firstR = true;
      for (const auto& [k, v] : s->report.entries()) {
        o << (firstR ? "" : ", ") << jsonEscape(k) << ": " << jsonValue(v);
        firstR = false;
      }
      o << "}";
    }
    o << "}";
  }
  o << "\n  ]\n}\n";
  return o.str();
}

} // namespace tetflow
