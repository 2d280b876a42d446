#include "Xml.h"

#include <cstring>

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

class Parser {
public:
  explicit Parser(const std::string& t) : s_(t) {}

  std::unique_ptr<XmlElement> document() {
    skipBom();
    std::unique_ptr<XmlElement> root;
    while (true) {
      skipSpace();
      if (pos_ >= s_.size()) break;
      if (starts("<?")) { processingInstruction(); continue; }
      if (starts("<!--")) { comment(); continue; }
      if (starts("<!DOCTYPE")) { doctype(); continue; }
      if (starts("<")) {
        if (root) fail("a second root element <" + peekName() + "> after </" + root->name + ">");
        root = element();
        continue;
      }
      fail("text outside the root element");
    }
    if (!root) fail("no root element (empty or not an XML file)");
    return root;
  }

private:
  static constexpr int kMaxDepth = 256;
  int depth_ = 0;
  [[noreturn]] void fail(const std::string& msg) { throw XmlError(line_, msg); }
  bool starts(const char* p) const { return s_.compare(pos_, std::strlen(p), p) == 0; }
  void advance(size_t n) {
    for (size_t i = 0; i < n && pos_ < s_.size(); ++i)
      if (s_[pos_++] == '\n') ++line_;
  }
  void skipBom() {
    if (starts("\xEF\xBB\xBF")) pos_ += 3;
  }
  void skipSpace() {
    while (pos_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[pos_]))) advance(1);
  }
  void skipPast(const char* end, const char* what) {
    const size_t e = s_.find(end, pos_);
    if (e == std::string::npos) fail(std::string("unterminated ") + what);
    advance(e + std::strlen(end) - pos_);
  }
  void processingInstruction() {
    if (!starts("<?xml")) fail("processing instructions are not supported");
    skipPast("?>", "XML declaration");
  }
  void comment() { skipPast("-->", "comment"); }
  void doctype() {
    // Skip, honouring an internal subset in [ ].
    int depth = 0;
    while (pos_ < s_.size()) {
      const char c = s_[pos_];
      if (c == '[') ++depth;
      else if (c == ']') --depth;
      else if (c == '>' && depth <= 0) {
        advance(1);
        return;
      }
      advance(1);
    }
    fail("unterminated DOCTYPE");
  }
  static bool nameChar(char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.' ||
           c == ':' || static_cast<unsigned char>(c) >= 0x80;
  }
  std::string peekName() const {
    size_t p = pos_ + 1;
    while (p < s_.size() && nameChar(s_[p])) ++p;
    return s_.substr(pos_ + 1, p - pos_ - 1);
  }
  std::string name() {
    const size_t b = pos_;
    while (pos_ < s_.size() && nameChar(s_[pos_])) ++pos_;
    if (pos_ == b) fail("expected a name");
    return s_.substr(b, pos_ - b);
  }
  std::string decode(const std::string& raw, int line) {
    std::string out;
    out.reserve(raw.size());
    for (size_t i = 0; i < raw.size(); ++i) {
      if (raw[i] != '&') {
        out += raw[i];
        continue;
      }
      const size_t semi = raw.find(';', i);
      if (semi == std::string::npos || semi - i > 12)
        throw XmlError(line, "a bare '&' must be written as &amp;");
      const std::string ent = raw.substr(i + 1, semi - i - 1);
      if (ent == "lt") out += '<';
      else if (ent == "gt") out += '>';
      else if (ent == "amp") out += '&';
      else if (ent == "quot") out += '"';
      else if (ent == "apos") out += '\'';
      else if (!ent.empty() && ent[0] == '#') {
        unsigned long cp = 0;
        try {
          cp = ent.size() > 1 && (ent[1] == 'x' || ent[1] == 'X') ? std::stoul(ent.substr(2), nullptr, 16)
                                                                   : std::stoul(ent.substr(1));
        } catch (...) {
          throw XmlError(line, "bad character reference &" + ent + ";");
        }
        if (cp == 0 || cp > 0x10FFFF) throw XmlError(line, "bad character reference &" + ent + ";");
        // UTF-8 encode.
        if (cp < 0x80) out += static_cast<char>(cp);
        else if (cp < 0x800) {
          out += static_cast<char>(0xC0 | (cp >> 6));
          out += static_cast<char>(0x80 | (cp & 0x3F));
        } else if (cp < 0x10000) {
          out += static_cast<char>(0xE0 | (cp >> 12));
          out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
          out += static_cast<char>(0x80 | (cp & 0x3F));
        } else {
          out += static_cast<char>(0xF0 | (cp >> 18));
          out += static_cast<char>(0x80 | ((cp >> 12) & 0x3F));
          out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
          out += static_cast<char>(0x80 | (cp & 0x3F));
        }
      } else {
        throw XmlError(line, "unknown entity &" + ent + ";");
      }
      i = semi;
    }
    return out;
  }
  std::unique_ptr<XmlElement> element() {
    // Elements nest by recursion here (and in ~XmlElement): bound the depth so that a file of
    // 200 000 nested elements is an error, not a stack overflow. A network needs 4 levels.
    if (depth_ >= kMaxDepth)
      fail("elements nested more than " + std::to_string(kMaxDepth) + " deep; a .srn network has 4 levels "
           "(network, modules, module, var), so this is not a network file");
    struct Level {
      int& d;
      explicit Level(int& x) : d(++x) {}
      ~Level() { --d; }
    } level(depth_);
    auto el = std::make_unique<XmlElement>();
    el->line = line_;
    advance(1); // '<'
    el->name = name();
    while (true) {
      skipSpace();
      if (pos_ >= s_.size()) fail("unterminated start tag <" + el->name + ">");
      if (starts("/>")) {
        advance(2);
        return el;
      }
      if (s_[pos_] == '>') {
        advance(1);
        break;
      }
      XmlAttribute a;
      a.line = line_;
      a.name = name();
      skipSpace();
      if (pos_ >= s_.size() || s_[pos_] != '=')
        fail("attribute '" + a.name + "' of <" + el->name + "> has no value");
      advance(1);
      skipSpace();
      if (pos_ >= s_.size() || (s_[pos_] != '"' && s_[pos_] != '\''))
        fail("attribute '" + a.name + "' value must be quoted");
      const char q = s_[pos_];
      advance(1);
      const size_t e = s_.find(q, pos_);
      if (e == std::string::npos) fail("unterminated value of attribute '" + a.name + "'");
      const std::string raw = s_.substr(pos_, e - pos_);
      if (raw.find('<') != std::string::npos) fail("'<' inside attribute '" + a.name + "'");
      a.value = decode(raw, a.line);
      advance(e + 1 - pos_);
      if (el->attribute(a.name)) fail("attribute '" + a.name + "' given twice");
      el->attributes.push_back(std::move(a));
    }
    // Content.
    while (true) {
      if (pos_ >= s_.size()) fail("element <" + el->name + "> (line " + std::to_string(el->line) + ") is not closed");
      if (starts("</")) {
        advance(2);
        const int l = line_;
        const std::string n = name();
        skipSpace();
        if (pos_ >= s_.size() || s_[pos_] != '>') fail("malformed end tag </" + n);
        advance(1);
        if (n != el->name)
          throw XmlError(l, "end tag </" + n + "> does not match <" + el->name + "> opened on line " +
                                std::to_string(el->line));
        return el;
      }
      if (starts("<!--")) { comment(); continue; }
      if (starts("<![CDATA[")) {
        advance(9);
        const size_t e = s_.find("]]>", pos_);
        if (e == std::string::npos) fail("unterminated CDATA section");
        el->text += s_.substr(pos_, e - pos_);
        advance(e + 3 - pos_);
        continue;
      }
      if (starts("<?")) { fail("processing instructions are not supported"); }
      if (s_[pos_] == '<') {
        el->children.push_back(element());
        continue;
      }
      const int l = line_;
      const size_t e = s_.find('<', pos_);
      const size_t end = e == std::string::npos ? s_.size() : e;
      el->text += decode(s_.substr(pos_, end - pos_), l);
      advance(end - pos_);
    }
  }

  const std::string& s_;
  size_t pos_ = 0;
  int line_ = 1;
};

} // namespace

std::unique_ptr<XmlElement> parseXml(const std::string& text) { return Parser(text).document(); }

std::string xmlEscape(const std::string& s) {
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
