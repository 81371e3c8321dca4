// Config validation: every problem names file:line:column and the key, and all are reported at once.
#include <gtest/gtest.h>

#include "sensor_rig/common/errors.hpp"
#include "sensor_rig/common/config_node.hpp"

namespace sensor_rig::config {
namespace {

Node load(const std::string& text, std::shared_ptr<Problems>& problems) {
  problems = std::make_shared<Problems>();
  return Node::load_string(text, "rig.yaml", problems);
}

TEST(ConfigNode, ReadsValuesWithDefaults) {
  std::shared_ptr<Problems> pr;
  auto n = load("name: front\nport: 2368\nrange: 1.5\nenabled: true\n", pr);
  n.allow_keys({"name", "port", "range", "enabled"});
  EXPECT_EQ(n.get_string("name"), "front");
  EXPECT_EQ(n.get_int("port", 1, 65535), 2368);
  EXPECT_DOUBLE_EQ(n.get_double("range", 0, 10), 1.5);
  EXPECT_TRUE(n.get_bool("enabled"));
  EXPECT_EQ(n.get_int("missing", 0, 10, 7), 7);
  EXPECT_TRUE(pr->empty()) << pr->str();
}

TEST(ConfigNode, UnknownKeyNamesLineAndKey) {
  std::shared_ptr<Problems> pr;
  auto n = load("lidars:\n  - name: a\n    modle: VLP-16\n", pr);
  auto items = n.items("lidars");
  ASSERT_EQ(items.size(), 1u);
  items[0].allow_keys({"name", "model"});
  ASSERT_EQ(pr->items().size(), 1u);
  EXPECT_EQ(pr->items()[0].line, 3);
  EXPECT_EQ(pr->items()[0].key, "lidars[0].modle");
  EXPECT_NE(pr->str().find("rig.yaml:3:5: lidars[0].modle: unknown key"), std::string::npos) << pr->str();
}

TEST(ConfigNode, WrongTypesAndRangesAreAllReported) {
  std::shared_ptr<Problems> pr;
  auto n = load("port: abc\nrate: 1e9\nmode: fast\nflag: maybe\n", pr);
  n.get_int("port", 1, 65535);
  n.get_double("rate", 0, 100);
  n.get_choice("mode", {"strongest", "last", "dual"});
  n.get_bool("flag");
  n.get_string("required_key");
  ASSERT_EQ(pr->items().size(), 5u) << pr->str();
  EXPECT_EQ(pr->items()[0].line, 1);
  EXPECT_EQ(pr->items()[1].line, 2);
  EXPECT_NE(pr->items()[2].message.find("strongest, last, dual"), std::string::npos);
  EXPECT_THROW(pr->throw_if_any(), ConfigError);
}

TEST(ConfigNode, SyntaxErrorHasPosition) {
  std::shared_ptr<Problems> pr;
  load("a: [1, 2\nb: 3\n", pr);
  ASSERT_EQ(pr->items().size(), 1u);
  EXPECT_GT(pr->items()[0].line, 0);
  EXPECT_NE(pr->items()[0].message.find("YAML syntax"), std::string::npos);
}

TEST(ConfigNode, MissingFileIsAProblemNotACrash) {
  auto pr = std::make_shared<Problems>();
  auto n = Node::load_file("/nonexistent/rig.yaml", pr);
  EXPECT_FALSE(n.valid());
  ASSERT_EQ(pr->items().size(), 1u);
  EXPECT_NE(pr->str().find("cannot open"), std::string::npos);
}

TEST(ConfigNode, RelativePathsResolveAgainstTheConfigFile) {
  auto pr = std::make_shared<Problems>();
  Node n(YAML::Load("calibration: cal/vlp16.yaml\nabs: /x/y\n"), std::make_shared<const std::string>("/etc/rig/rig.yaml"), "",
         pr);
  EXPECT_EQ(n.get_path("calibration"), "/etc/rig/cal/vlp16.yaml");
  EXPECT_EQ(n.get_path("abs"), "/x/y");
}

}  // namespace
}  // namespace sensor_rig::config
