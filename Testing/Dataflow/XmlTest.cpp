// Tests for Dataflow/Xml (pugixml underneath): lines of elements and attributes, entities and
// their refusals (billion laughs, external entities, typos), structure errors naming tags and
// lines, nesting bound, and escape/parse round trips on random strings.
#include "Dataflow/Xml.h"

#include <gtest/gtest.h>

#include <chrono>
#include <random>
#include <string>
#include <vector>

namespace tetflow {
namespace {

// The XmlError of parsing `text` (fails the test if it parses).
XmlError errorOf(const std::string& text) {
  try {
    parseXml(text);
  } catch (const XmlError& e) {
    return e;
  }
  ADD_FAILURE() << "parsed: " << text.substr(0, 200);
  return XmlError(0, "");
}

bool says(const XmlError& e, const std::string& frag) { return std::string(e.what()).find(frag) != std::string::npos; }

TEST(Xml, ElementsAndAttributesKeepTheirLines) {
  const auto root = parseXml("<?xml version=\"1.0\"?>\n<!DOCTYPE network PUBLIC \"-//SCIRun/Network DTD\" \"network.dtd\">\n"
                             "<network version=\"1\"\n   name=\"{Main}\">\n  <!-- a comment <b> -->\n"
                             "  <modules>\n    <module id=\"m1\"\n            name=\"X\"/>\n  </modules>\n</network>\n");
  EXPECT_EQ(root->name, "network");
  EXPECT_EQ(root->line, 3);
  ASSERT_NE(root->attribute("name"), nullptr);
  EXPECT_EQ(root->attribute("version")->line, 3);
  EXPECT_EQ(root->attribute("name")->line, 4);
  EXPECT_EQ(root->attribute("name")->value, "{Main}");
  const auto mods = root->childrenNamed("modules");
  ASSERT_EQ(mods.size(), 1u);
  EXPECT_EQ(mods[0]->line, 6);
  const auto m = mods[0]->childrenNamed("module");
  ASSERT_EQ(m.size(), 1u);
  EXPECT_EQ(m[0]->line, 7);
  EXPECT_EQ(m[0]->attribute("id")->line, 7);
  EXPECT_EQ(m[0]->attribute("name")->line, 8);
}

TEST(Xml, EntitiesCdataAndWhitespace) {
  const auto r = parseXml("<n a=\"x &lt; &amp; &gt; &quot; &apos; &#65;&#x42;&#xe9;\" b='line1\nline2'>"
                          "t &amp; u<![CDATA[ a & b < c ]]><!-- &nonsense; --></n>");
  EXPECT_EQ(r->attribute("a")->value, "x < & > \" ' AB\xC3\xA9");
  EXPECT_EQ(r->attribute("b")->value, "line1\nline2"); // no attribute whitespace normalisation
  EXPECT_EQ(r->text, "t & u a & b < c ");
}

TEST(Xml, UnknownEntitiesBareAmpersandsAndDtdEntitiesAreRefused) {
  EXPECT_TRUE(says(errorOf("<n>\n&foo;</n>"), "unknown entity &foo;"));
  EXPECT_EQ(errorOf("<n>\n&foo;</n>").line, 2);
  EXPECT_TRUE(says(errorOf("<n a=\"x & y\"/>"), "&amp;"));
  EXPECT_TRUE(says(errorOf("<n>fish & chips</n>"), "&amp;"));
  EXPECT_TRUE(says(errorOf("<n>&#0;</n>"), "bad character reference"));
  EXPECT_TRUE(says(errorOf("<n>&#x110000;</n>"), "bad character reference"));
  EXPECT_TRUE(says(errorOf("<n>&#12a;</n>"), "bad character reference"));
  // Billion laughs: refused at the first reference, at once.
  std::string lol = "<?xml version=\"1.0\"?>\n<!DOCTYPE lolz [\n <!ENTITY lol \"lol\">\n";
  for (int i = 1; i < 10; ++i) {
    lol += " <!ENTITY lol" + std::to_string(i) + " \"";
    for (int k = 0; k < 10; ++k) lol += "&lol" + (i == 1 ? std::string() : std::to_string(i - 1)) + ";";
    lol += "\">\n";
  }
  lol += "]>\n<network>&lol9;</network>\n";
  const auto t0 = std::chrono::steady_clock::now();
  const XmlError e = errorOf(lol);
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 1.0);
  EXPECT_TRUE(says(e, "unknown entity &lol9;")) << e.what();
  EXPECT_EQ(e.line, 14);
  // An external entity is never resolved.
  EXPECT_TRUE(says(errorOf("<!DOCTYPE n [<!ENTITY xxe SYSTEM \"file:///etc/passwd\">]>\n<n>&xxe;</n>"),
                   "unknown entity &xxe;"));
}

TEST(Xml, StructureErrorsNameTagsAndLines) {
  XmlError e = errorOf("<a>\n<b>\n</c>\n</a>");
  EXPECT_EQ(e.line, 3);
  EXPECT_TRUE(says(e, "end tag </c> does not match <b> opened on line 2")) << e.what();
  e = errorOf("<a>\n<b>\n</b>\n");
  EXPECT_TRUE(says(e, "element <a> (line 1) is not closed")) << e.what();
  e = errorOf("<a/>\n<b/>");
  EXPECT_EQ(e.line, 2);
  EXPECT_TRUE(says(e, "a second root element <b> after </a>")) << e.what();
  EXPECT_TRUE(says(errorOf("<a/>\nstray"), "text outside the root element"));
  EXPECT_TRUE(says(errorOf("<a x=\"1\" x=\"2\"/>"), "attribute 'x' given twice"));
  EXPECT_TRUE(says(errorOf(""), "no root element (empty or not an XML file)"));
  EXPECT_TRUE(says(errorOf("   \n  "), "no root element"));
  EXPECT_GT(errorOf("<a b=c/>").line, 0);
  EXPECT_GT(errorOf("<a><!-- unterminated </a>").line, 0);
}

TEST(Xml, NestingIsBoundedWithoutRecursion) {
  // 256 levels parse; 257 are refused at the 257th element's line, open or closed.
  std::string ok, closing;
  for (int i = 0; i < 256; ++i) {
    ok += "<e>";
    closing += "</e>";
  }
  EXPECT_NO_THROW(parseXml(ok + closing));
  const XmlError closed = errorOf("<r>\n" + ok + closing + "</r>");
  EXPECT_EQ(closed.line, 2);
  EXPECT_TRUE(says(closed, "nested more than 256 deep"));
  std::string deep = "<r>\n";
  for (int i = 0; i < 200000; ++i) deep += "<a>";
  const XmlError open = errorOf(deep);
  EXPECT_EQ(open.line, 2);
  EXPECT_TRUE(says(open, "nested more than 256 deep"));
}

TEST(Xml, EscapeThenParseGivesTheSameStringOnRandomText) {
  std::mt19937 rng(12);
  const std::vector<std::string> tokens = {"a", "Z", "0", " ", "{", "}", "<", ">", "&", "\"", "'", "\n", "\t",
                                           "\r", ";", "#", "=", "/", "!", "?", "-", "\xC3\xA9", "\xE2\x82\xAC"};
  for (int trial = 0; trial < 300; ++trial) {
    std::string v;
    for (int k = 0, n = int(rng() % 40); k < n; ++k) v += tokens[rng() % tokens.size()];
    const auto r = parseXml("<v val=\"" + xmlEscape(v) + "\">" + xmlEscape(v) + "</v>");
    EXPECT_EQ(r->attribute("val")->value, v) << trial;
    EXPECT_EQ(r->text, v) << trial;
  }
}

} // namespace
} // namespace tetflow
