#pragma once
// Checks every writer runs before it writes a file the user named (a trajectory, a bag, a
// run directory's files), and the readers' check of an input path.

#include <string>

namespace rbpf_slam {
namespace io {

/// Throws std::runtime_error "PATH: exists and is a directory (not a regular file); not written
/// over" (a pipe, a device, a socket) when PATH exists and is not a regular file (nor a link to
/// one). A writer calls it before writing PATH: renaming a finished file onto a device replaces
/// the device (as root), and opening a pipe blocks until someone reads it.
void requireReplaceableFile(const std::string& path);

/// Makes the directories above PATH (as mkdir -p), as a writer does before writing a file the
/// user named; a failure is left to the writer's own "cannot write" when it opens PATH.
void makeParentDirectories(const std::string& path);

/// True for a character or block device, which a reader taking its whole input (/dev/zero)
/// would read until the memory is full.
bool isDevice(const std::string& path);
/// Throws std::runtime_error "PATH: is a device, not a file" when isDevice(PATH) (readers).
void requireNotADevice(const std::string& path);

}  // namespace io
}  // namespace rbpf_slam
