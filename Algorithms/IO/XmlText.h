#pragma once
// Escaping text for XML attribute values and character data, shared by the .vtu writer and the
// network files (Dataflow/Xml.h).
#include <string>

namespace tetflow {

// & < > " become entities, and newline, carriage return and tab character references (so that
// an attribute value keeps them).
inline std::string xmlEscape(const std::string& s) {
  std::string out;
  out.reserve(s.size());
  for (char c : s) {
    switch (c) {
    case '&': out += "&amp;"; break;
    case '<': out += "&lt;"; break;
    case '>': out += "&gt;"; break;
    case '"': out += "&quot;"; break;
    case '\n': out += "&#10;"; break;
    case '\r': out += "&#13;"; break;
    case '\t': out += "&#9;"; break;
    default: out += c;
    }
  }
  return out;
}

} // namespace tetflow
