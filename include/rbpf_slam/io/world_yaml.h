#pragma once
// Reads simulation worlds from YAML (format: docs/worlds.md). Unknown keys are errors, and
// every error names the file and the key path, e.g.
// "worlds/x.yaml: sensors.laser.range_noise_m = -1 is out of range [0, inf)".

#include <stdexcept>
#include <string>

#include "rbpf_slam/core/sim/world.h"

namespace rbpf_slam {
namespace io {

/// A world file that cannot be read, parsed or validated; what() names file and field.
class WorldFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Loads and validates the world in the YAML file at path; throws WorldFileError.
core::sim::World loadWorld(const std::string& path);

/// Parses and validates a world from YAML text; source names it in error messages.
core::sim::World parseWorld(const std::string& yaml_text, const std::string& source);

}  // namespace io
}  // namespace rbpf_slam
