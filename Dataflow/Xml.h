#pragma once
// The XML reader for .srn networks: pugixml (Debian's libpugixml-dev) parses, and this file adds
// what a network load error needs and pugixml leaves out: the line of every element and attribute,
// messages that name the tags involved, a refusal of unknown entities and bare '&' (pugixml keeps
// them as literal text; it never expands DTD entities, so a billion-laughs file is refused at its
// first entity reference), one root element, and a bound of 256 nesting levels (the tree below is
// built without recursion, but XmlElement's destructor recurses). DOCTYPE, comments and processing
// instructions are skipped; CDATA is text; attribute values keep their whitespace.
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "Algorithms/IO/XmlText.h" // xmlEscape

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

} // namespace tetflow
