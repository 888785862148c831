// libFuzzer target: arbitrary text as a SLAM config. The loader must either accept it with
// options the core validates or throw io::ConfigError; anything else is a finding.

#include <yaml-cpp/yaml.h>

#include "fuzz_common.h"
#include "rbpf_slam/core/slam/slam_pipeline.h"
#include "rbpf_slam/io/slam_config.h"

using namespace rbpf_slam;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception&) {
    return 0;  // not YAML: the file loader reports it as such
  }
  try {
    const io::SlamConfig config = io::parseSlamConfig(root, "fuzz");
    if (config.filter.particles > 2000) return 0;  // valid, only slow to construct
    core::SlamPipeline pipeline(config.pipeline());  // accepted options must construct
  } catch (const io::ConfigError&) {
  }
  return 0;
}
