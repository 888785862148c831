// The one config loader: every shipped config loads, partial configs take defaults, and every
// error names the file, the key, the value and the allowed range.

#include <gtest/gtest.h>

#include <dirent.h>

#include <string>

#include "rbpf_slam/io/slam_config.h"

namespace rbpf_slam {
namespace io {
namespace {

std::string errorOf(const std::string& yaml) {
  try {
    parseSlamConfig(YAML::Load(yaml), "test.yaml");
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

TEST(SlamConfig, EveryShippedConfigLoads) {
  const std::string dir = std::string(RBPF_SOURCE_DIR) + "/config";
  DIR* d = opendir(dir.c_str());
  ASSERT_NE(d, nullptr);
  int loaded = 0;
  while (dirent* entry = readdir(d)) {
    const std::string name = entry->d_name;
    if (name.size() < 5 || name.substr(name.size() - 5) != ".yaml") continue;
    SCOPED_TRACE(name);
    EXPECT_NO_THROW(loadSlamConfig(dir + "/" + name));
    ++loaded;
  }
  closedir(d);
  EXPECT_GE(loaded, 2);
}

TEST(SlamConfig, PartialConfigTakesDefaults) {
  const SlamConfig c = parseSlamConfig(YAML::Load("particles: 17\nmotion: {alpha1: 0.2}"), "t");
  EXPECT_EQ(c.filter.particles, 17);
  EXPECT_DOUBLE_EQ(c.filter.motion.alpha1, 0.2);
  EXPECT_DOUBLE_EQ(c.filter.motion.alpha3, core::MotionOptions().alpha3);
  EXPECT_EQ(c.laser.method, "incremental");
  EXPECT_NO_THROW(parseSlamConfig(YAML::Load("{}"), "t"));
}

TEST(SlamConfig, ErrorsNameTheKeyValueAndRange) {
  EXPECT_NE(errorOf("partciles: 10").find("unknown key(s) at the top level: partciles"),
            std::string::npos);
  EXPECT_NE(errorOf("motion: {alpah1: 1}").find("in motion: alpah1"), std::string::npos);
  const std::string range = errorOf("particles: 0");
  EXPECT_NE(range.find("test.yaml: particles = 0 is out of range [1, 100000]"), std::string::npos)
      << range;
  EXPECT_NE(errorOf("laser_features: {method: hough}").find("not one of: incremental"),
            std::string::npos);
  EXPECT_NE(errorOf("resample_threshold: abc").find("is not a number"), std::string::npos);
  EXPECT_NE(errorOf("motion: 3").find("must be a map"), std::string::npos);
  EXPECT_NE(errorOf("use_points: false\nuse_lines: false").find("nothing to map"),
            std::string::npos);
}

TEST(SlamConfig, OverridesApplyDottedKeys) {
  YAML::Node root = YAML::Load("particles: 5");
  applyOverride(&root, "association.gate_chi2=4.5");
  applyOverride(&root, "particles=7");
  const SlamConfig c = parseSlamConfig(root, "t");
  EXPECT_EQ(c.filter.particles, 7);
  EXPECT_DOUBLE_EQ(c.filter.association.gate_chi2, 4.5);
  EXPECT_THROW(applyOverride(&root, "novalue"), ConfigError);
}

TEST(SlamConfig, RobustConfigsLoadWithTheirSections) {
  const std::string dir = std::string(RBPF_SOURCE_DIR) + "/config/";
  const SlamConfig landmarks = loadSlamConfig(dir + "landmarks_robust.yaml");
  EXPECT_EQ(landmarks.filter.variant, "robust_fastslam2");
  EXPECT_EQ(landmarks.frontend, "features");
  EXPECT_EQ(landmarks.filter.particles, 100);
  EXPECT_EQ(landmarks.filter.robust.ancestor_sets, 5);
  EXPECT_EQ(landmarks.filter.tracker.forget_after_steps, 25);
  const SlamConfig laser = loadSlamConfig(dir + "laser_robust.yaml");
  EXPECT_EQ(laser.filter.variant, "robust_fastslam2");
  EXPECT_EQ(laser.frontend, "laser");
  EXPECT_EQ(laser.filter.particles, 50);
  EXPECT_TRUE(laser.filter.robust.intermediate_path);
  EXPECT_NE(errorOf("robust: {ancestor_set: 3}").find("in robust: ancestor_set"),
            std::string::npos);
  EXPECT_NE(errorOf("tracker: {forget_after: 3}").find("in tracker: forget_after"),
            std::string::npos);
  EXPECT_NE(errorOf("robust: {window_steps: 0}").find("robust.window_steps = 0"),
            std::string::npos);
  EXPECT_NE(errorOf("tracker: {gate_chi2: 30, new_landmark_chi2: 20}")
                .find("tracker.new_landmark_chi2"),
            std::string::npos);
}

TEST(SlamConfig, MissingFileIsNamed) {
  try {
    loadSlamConfig("/nonexistent/x.yaml");
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/x.yaml"), std::string::npos);
  }
}

}  // namespace
}  // namespace io
}  // namespace rbpf_slam
