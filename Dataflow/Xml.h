#pragma once
// A small XML reader that keeps line numbers, for .srn networks. Boost.PropertyTree's XML parser
// drops line numbers, and every .srn load error must name its line. Supports the XML that
// network files use: declaration, DOCTYPE (skipped), comments, CDATA, elements, attributes in
// single or double quotes, text, the five named entities and numeric character references.
// Not supported (refused with a message): processing instructions other than the declaration,
// custom entities.
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace tetflow {

struct XmlAttribute {
  std::string name, value;
  int line = 0;
};

struct XmlElement {
  std::string name;
  int line = 0;
  std::vector<XmlAttribute> attributes;
  std::vector<std::unique_ptr<XmlElement>> children;
  std::string text; // concatenated character data directly inside this element

  const XmlAttribute* attribute(const std::string& n) const;
  std::vector<const XmlElement*> childrenNamed(const std::string& n) const;
};

class XmlError : public std::runtime_error {
public:
  XmlError(int line, const std::string& msg) : std::runtime_error(msg), line(line) {}
  int line;
};

// Parse a whole document; returns the root element. Throws XmlError with the line.
std::unique_ptr<XmlElement> parseXml(const std::string& text);

// Escape text for an attribute value or character data (& < > " and control characters).
std::string xmlEscape(const std::string& s);

} // namespace tetflow
