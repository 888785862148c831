#include "rbpf_slam/ros/bag_files.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <stdexcept>

#include <rosbag/view.h>

#include "rbpf_slam/io/output_file.h"

namespace rbpf_slam {
namespace rosbridge {

void openBagForReading(rosbag::Bag* bag, const std::string& path) {
  try {
    bag->open(path, rosbag::bagmode::Read);
  } catch (const rosbag::BagException& e) {
    throw std::runtime_error(path + ": cannot open bag: " + e.what());
  }
  // rosbag::View of an empty bag begins at TIME_MAX and ends at TIME_MIN: its duration throws
  // "Duration is out of dual 32-bit range", naming nothing.
  if (rosbag::View(*bag).size() == 0) throw std::runtime_error(path + ": the bag holds no messages");
}

PartialBag::PartialBag(const std::string& path)
    : path_(path), partial_(path + ".part"), bag_(std::make_unique<rosbag::Bag>()) {
  io::requireReplaceableFile(path_);  // the commit's rename would replace a device or directory
  io::requireReplaceableFile(partial_);
  try {
    bag_->open(partial_, rosbag::bagmode::Write);
  } catch (const rosbag::BagException& e) {
    throw std::runtime_error(path_ + ": cannot write the bag (" + partial_ + "): " + e.what());
  }
}

PartialBag::~PartialBag() {
  if (committed_) return;
  try {
    bag_->close();
  } catch (...) {
    // The run already failed (typically the same write error again). rosbag::Bag's destructor
    // would retry the close and throw from a destructor, so the handle is abandoned instead.
    static_cast<void>(bag_.release());
  }
  std::remove(partial_.c_str());
}

void PartialBag::commit() {
  try {
    bag_->close();
  } catch (const rosbag::BagException& e) {
    static_cast<void>(bag_.release());  // as in the destructor: no second close
    std::remove(partial_.c_str());
    committed_ = true;  // nothing left for the destructor
    throw std::runtime_error(path_ + ": cannot finish the bag: " + e.what());
  }
  if (std::rename(partial_.c_str(), path_.c_str()) != 0) {
    const std::string reason = std::strerror(errno);
    std::remove(partial_.c_str());
    committed_ = true;
    throw std::runtime_error(path_ + ": cannot rename " + partial_ + " to it: " + reason);
  }
  committed_ = true;
}

}  // namespace rosbridge
}  // namespace rbpf_slam
