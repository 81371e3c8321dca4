// The monitor's latency plot from a recording: read back as XML — per topic one chart over time
// (a point per sample and stage, lost samples marked) and one box per stage, inside the axis.
#include "latency_plot.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "mini_xml.hpp"

#include "sensor_rig/common/clock.hpp"

namespace sensor_rig::rig {
namespace {

using test::xml::Element;
constexpr Nanos kT0 = 1'700'000'000'000'000'000;

// seq n of `topic`, 100 ms apart: sensor 1 ms, assemble 100 ms, process 2 ms, write 0.5 ms,
// dds 0.2 + n/100 ms; `lost` ones have no receive time.
SampleRecord sample(const std::string& topic, std::uint64_t n, bool lost = false) {
  SampleRecord r;
  r.topic = topic;
  r.seq = n;
  r.acquisition_ns = kT0 + static_cast<Nanos>(n) * 100 * kMs;
  r.first_rx_ns = r.acquisition_ns + 1 * kMs;
  r.last_rx_ns = r.first_rx_ns + 100 * kMs;
  r.publish_ns = r.last_rx_ns + 2 * kMs;
  r.written_ns = r.publish_ns + kMs / 2;
  r.ecu_status_ns = r.written_ns + 3 * kMs;
  if (!lost) r.received_ns = r.publish_ns + kMs / 5 + static_cast<Nanos>(n) * kMs / 100;
  return r;
}

std::vector<const Element*> nested_charts(const Element& doc) {
  std::vector<const Element*> out;
  for (const auto& c : doc.children)
    if (c->name == "svg") out.push_back(c.get());
  return out;
}
std::string title(const Element& chart) {
  for (const auto& c : chart.children)
    if (c->name == "text" && c->attrs.contains("font-weight")) return c->text;
  return "";
}
template <class Pred>
std::vector<const Element*> all(const Element& root, Pred pred) {
  std::vector<const Element*> out;
  root.each([&](const Element& e) {
    if (pred(e)) out.push_back(&e);
  });
  return out;
}
// The numbers on the y axis (tick labels right-aligned left of the frame).
std::vector<double> y_ticks(const Element& chart) {
  std::vector<double> v;
  for (const auto* t : all(chart, [](const Element& e) {
         return e.name == "text" && e.attrs.contains("text-anchor") && e.attrs.at("text-anchor") == "end";
       }))
    v.push_back(std::stod(t->text));
  return v;
}

TEST(LatencyPlot, PerTopicTimeChartWithLossMarksAndOneBoxPerStage) {
  std::vector<SampleRecord> rec;
  for (std::uint64_t n = 0; n < 50; ++n) {
    rec.push_back(sample("/sensors/lidar/front/points", n, n == 10 || n == 30));
    if (n < 20) rec.push_back(sample("/sensors/camera/front_narrow/image_raw", n));
  }
  const auto doc = test::xml::parse(latency_plot_svg(rec));
  const auto charts = nested_charts(*doc);
  ASSERT_EQ(charts.size(), 4u);  // per topic (in name order): over time, boxes
  EXPECT_EQ(title(*charts[0]).find("/sensors/camera/front_narrow/image_raw"), 0u);
  EXPECT_EQ(title(*charts[2]).find("/sensors/lidar/front/points"), 0u);

  // Over time: one point per sample and stage (8 stages; a lost sample has 6: no dds, no total).
  const auto points = all(*charts[2], [](const Element& e) { return e.name == "circle"; });
  EXPECT_EQ(points.size(), 48u * 8 + 2u * 6);
  const auto marks = all(*charts[2], [](const Element& e) {
    return e.name == "g" && e.attrs.contains("class") && e.attrs.at("class") == "marks";
  });
  ASSERT_EQ(marks.size(), 1u);
  EXPECT_EQ(marks[0]->children.size(), 2u);  // the two lost samples
  EXPECT_TRUE(all(*charts[0], [](const Element& e) { return e.attrs.contains("class") && e.attrs.at("class") == "marks"; })
                  .empty());
  // Loss marks in time order at 1 s and 3 s of a 4.9 s axis.
  const double m1 = marks[0]->children[0]->num("x1"), m2 = marks[0]->children[1]->num("x1");
  EXPECT_LT(m1, m2);

  // Boxes: one per topic and stage, labelled with the stage.
  for (const auto* c : {charts[1], charts[3]}) {
    const auto boxes = all(*c, [](const Element& e) {
      return e.name == "rect" && e.attrs.contains("class") && e.attrs.at("class") == "box";
    });
    EXPECT_EQ(boxes.size(), kStageCount);
    std::set<std::string> labels;
    for (const auto* t : all(*c, [](const Element& e) { return e.name == "text" && e.attrs.contains("transform"); }))
      labels.insert(t->text.substr(0, t->text.find(' ')));
    for (const char* s : kStageNames) EXPECT_TRUE(labels.contains(s)) << s;
  }

  // Every value lies within the y axis: ticks from <= 0.2 ms (dds) to >= 103 ms (total).
  const auto ticks = y_ticks(*charts[3]);
  ASSERT_FALSE(ticks.empty());
  EXPECT_LE(*std::min_element(ticks.begin(), ticks.end()), 0.2);
  EXPECT_GE(*std::max_element(ticks.begin(), ticks.end()), 103.69);
}

TEST(LatencyPlot, EmptyOrNonPositiveInputStillMakesAValidDocument) {
  EXPECT_NO_THROW(test::xml::parse(latency_plot_svg({})));
  auto r = sample("/t", 0);
  r.received_ns = r.publish_ns - 5 * kMs;  // receiver clock behind: a negative dds stage is left out
  const auto doc = test::xml::parse(latency_plot_svg({r}));
  EXPECT_EQ(nested_charts(*doc).size(), 2u);
}

}  // namespace
}  // namespace sensor_rig::rig
