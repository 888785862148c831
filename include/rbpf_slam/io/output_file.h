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

/// Throws std::runtime_error "PATH: is a device, not a file" for a character or block device:
/// a reader that takes the whole input (/dev/zero) would fill the memory before it failed.
void requireNotADevice(const std::string& path);

}  // namespace io
}  // namespace rbpf_slam
