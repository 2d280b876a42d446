#include "Xml.h"

#include <algorithm>
#include <cctype>
#include <cstring>

#include <pugixml.hpp>

namespace tetflow {

const XmlAttribute* XmlElement::attribute(const std::string& n) const {
  for (const auto& a : attributes)
    if (a.name == n) return &a;
  return nullptr;
}

std::vector<const XmlElement*> XmlElement::childrenNamed(const std::string& n) const {
  std::vector<const XmlElement*> v;
  for (const auto& c : children)
    if (c->name == n) v.push_back(c.get());
  return v;
}

namespace {

constexpr int kMaxDepth = 256;

XmlError tooDeep(int line) {
  return XmlError(line, "elements nested more than " + std::to_string(kMaxDepth) +
                            " deep; a .srn network has 4 levels (network, modules, module, var), so this is "
                            "not a network file");
}

bool nameChar(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.' || c == ':' ||
         static_cast<unsigned char>(c) >= 0x80;
}

// Line numbers and the few checks pugixml leaves to its caller, on the source text.
class Source {
public:
  explicit Source(const std::string& s) : s_(s) {
    for (size_t i = 0; i < s.size(); ++i)
      if (s[i] == '\n') newlines_.push_back(i);
  }

  int lineAt(size_t offset) const {
    return 1 + int(std::lower_bound(newlines_.begin(), newlines_.end(), std::min(offset, s_.size())) -
                   newlines_.begin());
  }

  // pugixml keeps an unknown entity or a bare '&' as text; DTD entities are never expanded. Refuse
  // both, so a billion-laughs file or a typo is an error naming its line, not silently literal text.
  void checkEntities() const {
    size_t i = 0;
    while ((i = s_.find_first_of("&<", i)) != std::string::npos) {
      if (s_[i] == '<') {
        // Comments, CDATA, PIs and DOCTYPE are skipped whole; in tags, attribute values are checked.
        const bool tag = s_.compare(i, 2, "<!") != 0 && s_.compare(i, 2, "<?") != 0;
        i = tag ? i + 1 : skipMarkup(i);
        continue;
      }
      const size_t semi = s_.find(';', i);
      if (semi == std::string::npos || semi - i > 12)
        throw XmlError(lineAt(i), "a bare '&' must be written as &amp;");
      const std::string ent = s_.substr(i + 1, semi - i - 1);
      const bool named = ent == "lt" || ent == "gt" || ent == "amp" || ent == "quot" || ent == "apos";
      bool numeric = ent.size() > 1 && ent[0] == '#';
      if (numeric) {
        const bool hex = ent[1] == 'x' || ent[1] == 'X';
        const std::string digits = ent.substr(hex ? 2 : 1);
        numeric = !digits.empty() && std::all_of(digits.begin(), digits.end(), [&](char c) {
          return hex ? std::isxdigit(static_cast<unsigned char>(c)) : std::isdigit(static_cast<unsigned char>(c));
        });
        unsigned long cp = 0;
        if (numeric) cp = digits.size() > 8 ? 0 : std::stoul(digits, nullptr, hex ? 16 : 10);
        if (!numeric || cp == 0 || cp > 0x10FFFF) throw XmlError(lineAt(i), "bad character reference &" + ent + ";");
      }
      if (!named && !numeric) {
        bool isName = !ent.empty() && std::all_of(ent.begin(), ent.end(), nameChar);
        throw XmlError(lineAt(i), isName ? "unknown entity &" + ent + "; (only &lt; &gt; &amp; &quot; &apos; "
                                            "and character references; DTD entities are not expanded)"
                                          : std::string("a bare '&' must be written as &amp;"));
      }
      i = semi + 1;
    }
  }

  // The tag name at offset `at` (just after '<' or '</').
  std::string nameAt(size_t at) const {
    size_t e = at;
    while (e < s_.size() && nameChar(s_[e])) ++e;
    return s_.substr(at, e - at);
  }

  // For pugixml's start-end mismatch (which also covers elements left open at the end): replays
  // the tags to name the first end tag that does not close the open element, or the element left
  // open, or the level where nesting passes kMaxDepth, with the line.
  XmlError structureError(size_t offset) const {
    struct Open {
      std::string name;
      size_t at;
    };
    std::vector<Open> stack;
    size_t i = 0;
    while ((i = s_.find('<', i)) != std::string::npos) {
      if (s_.compare(i, 2, "</") == 0) {
        const std::string n = nameAt(i + 2);
        if (stack.empty() || stack.back().name != n) {
          if (stack.empty()) return XmlError(lineAt(i), "end tag </" + n + "> with no element open");
          return XmlError(lineAt(i), "end tag </" + n + "> does not match <" + stack.back().name +
                                         "> opened on line " + std::to_string(lineAt(stack.back().at)));
        }
        stack.pop_back();
        i += 2;
        continue;
      }
      const size_t next = skipMarkup(i);
      if (i + 1 < s_.size() && (std::isalpha(static_cast<unsigned char>(s_[i + 1])) || s_[i + 1] == '_' || s_[i + 1] == ':')) {
        const bool selfClosing = next >= 2 && s_[next - 2] == '/';
        if (!selfClosing) {
          stack.push_back({nameAt(i + 1), i});
          if (stack.size() > size_t(kMaxDepth)) return tooDeep(lineAt(i));
        }
      }
      i = next;
    }
    if (!stack.empty())
      return XmlError(lineAt(s_.size()), "element <" + stack.back().name + "> (line " +
                                             std::to_string(lineAt(stack.back().at)) + ") is not closed");
    return XmlError(lineAt(offset), "start and end tags do not match");
  }

  // Lines of the attributes of the start tag at `tag` ('<'), in order.
  std::vector<int> attributeLines(size_t tag) const {
    std::vector<int> lines;
    size_t i = tag + 1;
    while (i < s_.size() && nameChar(s_[i])) ++i;
    while (i < s_.size() && s_[i] != '>' && s_[i] != '/') {
      if (std::isspace(static_cast<unsigned char>(s_[i]))) {
        ++i;
        continue;
      }
      lines.push_back(lineAt(i));
      while (i < s_.size() && s_[i] != '=') ++i;
      while (i < s_.size() && s_[i] != '"' && s_[i] != '\'') ++i;
      if (i >= s_.size()) break;
      const size_t close = s_.find(s_[i], i + 1);
      if (close == std::string::npos) break;
      i = close + 1;
    }
    return lines;
  }

  // Offset of the '<' that starts the element whose name pugixml reports at `nameOffset`.
  size_t tagStart(size_t nameOffset) const {
    const size_t lt = s_.rfind('<', std::min(nameOffset, s_.size() - 1));
    return lt == std::string::npos ? 0 : lt;
  }

private:
  // Past the markup starting at `i` ('<'): comments, CDATA, PIs and DOCTYPE (with its internal
  // subset) are skipped whole; for tags, past the '>' (quotes honoured).
  size_t skipMarkup(size_t i) const {
    auto past = [&](const char* end) {
      const size_t e = s_.find(end, i);
      return e == std::string::npos ? s_.size() : e + std::strlen(end);
    };
    if (s_.compare(i, 4, "<!--") == 0) return past("-->");
    if (s_.compare(i, 9, "<![CDATA[") == 0) return past("]]>");
    if (s_.compare(i, 2, "<?") == 0) return past("?>");
    if (s_.compare(i, 2, "<!") == 0) {
      int depth = 0;
      for (size_t k = i; k < s_.size(); ++k) {
        if (s_[k] == '[') ++depth;
        else if (s_[k] == ']') --depth;
        else if (s_[k] == '>' && depth <= 0) return k + 1;
      }
      return s_.size();
    }
    char quote = 0;
    for (size_t k = i + 1; k < s_.size(); ++k) {
      if (quote) {
        if (s_[k] == quote) quote = 0;
      } else if (s_[k] == '"' || s_[k] == '\'') {
        quote = s_[k];
      } else if (s_[k] == '>') {
        return k + 1;
      }
    }
    return s_.size();
  }

  const std::string& s_;
  std::vector<size_t> newlines_;
};

std::string pugiMessage(const pugi::xml_parse_result& r, const std::string& text) {
  switch (r.status) {
    case pugi::status_no_document_element: return "no root element (empty or not an XML file)";
    case pugi::status_unrecognized_tag:
      return "malformed markup at '" + text.substr(size_t(r.offset), 20) + "'";
    case pugi::status_bad_attribute: return "malformed attribute (values must be quoted; '<' is not allowed in them)";
    case pugi::status_bad_start_element: return "malformed start tag";
    case pugi::status_bad_end_element: return "malformed end tag";
    default: return r.description();
  }
}

// pugixml's tree -> ours, iteratively (no recursion on the input's depth).
std::unique_ptr<XmlElement> convert(pugi::xml_node root, const Source& src) {
  auto make = [&](pugi::xml_node n) {
    auto el = std::make_unique<XmlElement>();
    el->name = n.name();
    const size_t tag = src.tagStart(size_t(n.offset_debug()));
    el->line = src.lineAt(tag);
    const std::vector<int> lines = src.attributeLines(tag);
    size_t k = 0;
    for (pugi::xml_attribute a : n.attributes()) {
      if (el->attribute(a.name())) throw XmlError(el->line, std::string("attribute '") + a.name() + "' given twice");
      el->attributes.push_back({a.name(), a.value(), k < lines.size() ? lines[k] : el->line});
      ++k;
    }
    return el;
  };
  struct Frame {
    pugi::xml_node node;
    XmlElement* el;
    int depth;
  };
  std::unique_ptr<XmlElement> top = make(root);
  std::vector<Frame> stack{{root, top.get(), 1}};
  while (!stack.empty()) {
    const Frame f = stack.back();
    stack.pop_back();
    for (pugi::xml_node c : f.node.children()) {
      if (c.type() == pugi::node_pcdata || c.type() == pugi::node_cdata) {
        f.el->text += c.value();
      } else if (c.type() == pugi::node_element) {
        f.el->children.push_back(make(c));
        XmlElement* child = f.el->children.back().get();
        if (f.depth + 1 > kMaxDepth) throw tooDeep(child->line);
        stack.push_back({c, child, f.depth + 1});
      }
    }
  }
  return top;
}

} // namespace

std::unique_ptr<XmlElement> parseXml(const std::string& text) {
  const Source src(text);
  src.checkEntities();
  pugi::xml_document doc;
  // No whitespace normalisation of attribute values (a value keeps its newlines), whitespace-only
  // text kept (an element's text is all its character data), no DOCTYPE or PI nodes (skipped),
  // escapes decoded (only the five named ones and character references:
  // pugixml never expands DTD entities).
  const unsigned flags = pugi::parse_cdata | pugi::parse_escapes | pugi::parse_eol | pugi::parse_ws_pcdata |
                         pugi::parse_fragment; // fragment: keeps text outside the root, to refuse it
  const pugi::xml_parse_result r = doc.load_buffer(text.data(), text.size(), flags, pugi::encoding_utf8);
  if (r.status == pugi::status_end_element_mismatch) throw src.structureError(size_t(r.offset));
  if (!r) throw XmlError(src.lineAt(size_t(r.offset)), pugiMessage(r, text));
  pugi::xml_node root;
  for (pugi::xml_node c : doc.children()) {
    const std::string v = c.value();
    const bool blank = std::all_of(v.begin(), v.end(), [](char ch) { return std::isspace(static_cast<unsigned char>(ch)); });
    if ((c.type() == pugi::node_pcdata || c.type() == pugi::node_cdata) && !blank) {
      throw XmlError(src.lineAt(size_t(c.offset_debug())), "text outside the root element");
    }
    if (c.type() != pugi::node_element) continue;
    if (root)
      throw XmlError(src.lineAt(src.tagStart(size_t(c.offset_debug()))),
                     std::string("a second root element <") + c.name() + "> after </" + root.name() + ">");
    root = c;
  }
  if (!root) throw XmlError(1, "no root element (empty or not an XML file)");
  return convert(root, src);
}

} // namespace tetflow
