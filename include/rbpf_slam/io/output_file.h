#pragma once
// Checks every writer runs before it writes a file the user named (a trajectory, a bag, a
// run directory's files).

#include <string>

namespace rbpf_slam {
namespace io {

/// Throws std::runtime_error "PATH: exists and is a directory (not a regular file); not written
/// over" (a pipe, a device, a socket) when PATH exists and is not a regular file (nor a link to
/// one). A writer calls it before writing PATH: renaming a finished file onto a device replaces
/// the device (as root), and opening a pipe blocks until someone reads it.
void requireReplaceableFile(const std::string& path);

}  // namespace io
}  // namespace rbpf_slam
