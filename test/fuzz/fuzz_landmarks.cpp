// libFuzzer target: arbitrary bytes as a saved landmark map (~load_map, map_file). The reader
// must return finite landmarks with positive definite covariances or throw runtime_error.

#include <unistd.h>

#include <Eigen/Dense>

#include <cstdio>
#include <stdexcept>

#include "fuzz_common.h"
#include "rbpf_slam/io/landmark_file.h"

using namespace rbpf_slam;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string path = "/tmp/rbpf_fuzz_landmarks_" + std::to_string(getpid()) + ".yaml";
  FILE* file = std::fopen(path.c_str(), "wb");
  if (!file) return 0;
  std::fwrite(data, 1, size, file);
  std::fclose(file);
  try {
    for (const auto& l : io::loadLandmarksYaml(path)) {
      fuzz::require(l.mean.allFinite() && l.covariance.allFinite());
      fuzz::require(l.covariance(0, 0) > 0.0 && l.covariance.determinant() > 0.0);
    }
  } catch (const std::runtime_error&) {
  }
  std::remove(path.c_str());
  return 0;
}
