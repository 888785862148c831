#include "rbpf_slam/io/output_file.h"

#include <filesystem>
#include <stdexcept>

namespace rbpf_slam {
namespace io {

void requireReplaceableFile(const std::string& path) {
  std::error_code error;
  const std::filesystem::file_status status = std::filesystem::status(path, error);
  if (!std::filesystem::exists(status) || std::filesystem::is_regular_file(status)) return;
  const char* kind = std::filesystem::is_directory(status)   ? "a directory"
                     : std::filesystem::is_fifo(status)      ? "a pipe"
                     : std::filesystem::is_character_file(status) ||
                             std::filesystem::is_block_file(status)
                         ? "a device"
                     : std::filesystem::is_socket(status) ? "a socket"
                                                          : "something else";
  throw std::runtime_error(path + ": exists and is " + kind +
                           " (not a regular file); not written over");
}

bool isDevice(const std::string& path) {
  std::error_code error;
  const std::filesystem::file_status status = std::filesystem::status(path, error);
  return std::filesystem::is_character_file(status) || std::filesystem::is_block_file(status);
}

void makeParentDirectories(const std::string& path) {
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  std::error_code ignored;  // reported when the writer opens path
  if (!parent.empty()) std::filesystem::create_directories(parent, ignored);
}

void requireNotADevice(const std::string& path) {
  if (isDevice(path)) throw std::runtime_error(path + ": is a device, not a file");
}

}  // namespace io
}  // namespace rbpf_slam
