// common/svg: every chart kind is well-formed XML (read back with a strict parser), draws what it
// was given inside its frame, and document() stacks charts into one standalone file.
#include "sensor_rig/common/svg.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "mini_xml.hpp"

namespace sensor_rig::svg {
namespace {

using test::xml::Element;

std::vector<const Element*> find_all(const Element& root, const std::string& name, const std::string& cls = "") {
  std::vector<const Element*> out;
  root.each([&](const Element& e) {
    if (e.name == name && (cls.empty() || (e.attrs.contains("class") && e.attrs.at("class") == cls))) out.push_back(&e);
  });
  return out;
}

// The plot frame: the first <rect> with a stroke and no fill (drawn by every axis chart).
const Element& frame_rect(const Element& svg) {
  for (const auto* r : find_all(svg, "rect"))
    if (r->attrs.contains("stroke") && r->attrs.contains("fill") && r->attrs.at("fill") == "none") return *r;
  throw std::runtime_error("no frame");
}

TEST(Svg, ScatterIsXmlWithEveryPointInsideTheFrameAndTheMarks) {
  Series a{"a <&> \"b\"", "#123456", {0, 1, 2, 3}, {0.01, 0.1, 10, 1000}};
  const auto doc = test::xml::parse(scatter("t & title", {0, 3, false, "s"}, {0.01, 1000, true, "ms"}, {a}, {1.5, 2.5}, "lost"));
  EXPECT_EQ(doc->name, "svg");
  const auto& f = frame_rect(*doc);
  const double x0 = f.num("x"), y0 = f.num("y"), x1 = x0 + f.num("width"), y1 = y0 + f.num("height");
  const auto circles = find_all(*doc, "circle");
  ASSERT_EQ(circles.size(), 4u);
  for (const auto* c : circles) {
    EXPECT_GE(c->num("cx"), x0);
    EXPECT_LE(c->num("cx"), x1);
    EXPECT_GE(c->num("cy"), y0);
    EXPECT_LE(c->num("cy"), y1);
  }
  // Log axis: 0.01 at the bottom, 1000 at the top, 0.1 two decades of five above the bottom.
  EXPECT_NEAR(circles[0]->num("cy"), y1, 0.1);
  EXPECT_NEAR(circles[3]->num("cy"), y0, 0.1);
  EXPECT_NEAR(circles[1]->num("cy"), y1 - (y1 - y0) / 5, 0.2);
  const auto marks = find_all(*doc, "g", "marks");
  ASSERT_EQ(marks.size(), 1u);
  EXPECT_EQ(marks[0]->children.size(), 2u);
  EXPECT_NE(doc->all_text().find("a <&> \"b\""), std::string::npos);  // escaped, decoded back
  EXPECT_NE(doc->all_text().find("t & title"), std::string::npos);
  EXPECT_NE(doc->all_text().find("lost (2)"), std::string::npos);
}

TEST(Svg, BoxesOnePerInputOrderedQuartilesInsideTheAxis) {
  std::vector<Box> in = {{"x", 1, 2, 3, 4, 5, 6, 3}, {"y", 10, 20, 30, 40, 50, 60, 30}};
  const auto doc = test::xml::parse(boxes("b", {0, 100, false, "ms"}, in));
  const auto rects = find_all(*doc, "rect", "box");
  ASSERT_EQ(rects.size(), 2u);
  const auto& f = frame_rect(*doc);
  const double top = f.num("y"), bottom = top + f.num("height");
  for (std::size_t i = 0; i < 2; ++i) {
    const double y75 = rects[i]->num("y"), y25 = y75 + rects[i]->num("height");
    EXPECT_NEAR(y75, bottom - (bottom - top) * in[i].p75 / 100, 0.1);
    EXPECT_NEAR(y25, bottom - (bottom - top) * in[i].p25 / 100, 0.1);
  }
  EXPECT_LT(rects[0]->num("x"), rects[1]->num("x"));
}

TEST(Svg, DocumentStacksChartsWithoutOverlap) {
  const std::string c1 = bars("one", {0, 10, false, "n"}, {"a", "b"}, {1, 2}, "#000");
  const std::string c2 = stacks("two", {"p", "q"}, {"#111", "#222"}, {{"r", {0.5, 0.5}}});
  const std::string text = document({c1, c2});
  ASSERT_EQ(text.rfind("<?xml", 0), 0u);
  const auto doc = test::xml::parse(text);
  ASSERT_EQ(doc->name, "svg");
  EXPECT_EQ(doc->attrs.at("xmlns"), "http://www.w3.org/2000/svg");
  std::vector<const Element*> nested;
  for (const auto& c : doc->children)
    if (c->name == "svg") nested.push_back(c.get());
  ASSERT_EQ(nested.size(), 2u);
  EXPECT_EQ(nested[0]->num("y"), 0);
  EXPECT_GE(nested[1]->num("y"), nested[0]->num("height"));
  EXPECT_GE(doc->num("height"), nested[1]->num("y") + nested[1]->num("height"));
}

TEST(MiniXml, RefusesMalformedInput) {
  for (const char* bad : {"<a>", "<a></b>", "<a x=1/>", "<a x='1' x='2'/>", "<a>&nope;</a>", "<a/><b/>", "<a>1 < 2</a>"})
    EXPECT_THROW(test::xml::parse(bad), std::runtime_error) << bad;
  EXPECT_NO_THROW(test::xml::parse("<?xml version='1.0'?>\n<a x=\"1\"><b/>t&amp;t</a>\n"));
}

}  // namespace
}  // namespace sensor_rig::svg
