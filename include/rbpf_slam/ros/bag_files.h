#pragma once
// Opening bags for the tools: errors that name the file, and output bags that appear only
// when complete.

#include <ros/message_traits.h>
#include <rosbag/bag.h>

#include <boost/make_shared.hpp>
#include <memory>
#include <stdexcept>
#include <string>

namespace rbpf_slam {
namespace rosbridge {

/// Opens PATH for reading into BAG; a missing, truncated or unindexed file throws
/// std::runtime_error "PATH: cannot open bag: <rosbag's reason>" (rosbag's own message does not
/// name the file). Every message is read once first in a child process: a damaged index that
/// would crash the rosbag library (a signal, not an exception) throws, naming the message.
void openBagForReading(rosbag::Bag* bag, const std::string& path);

/// An output bag written as PATH.part and renamed to PATH by commit(), so that a run that fails
/// while writing (disk full, a file size limit, an error half-way) ends with its error message
/// and leaves neither a truncated PATH nor the .part file behind. An existing PATH is replaced
/// only by the commit. (A process killed by a signal can still leave PATH.part, never PATH.)
class PartialBag {
 public:
  /// Throws std::runtime_error naming PATH when PATH.part cannot be created, or when PATH or
  /// PATH.part exists and is not a regular file (io::requireReplaceableFile).
  explicit PartialBag(const std::string& path);
  /// Without commit(): closes and removes PATH.part.
  ~PartialBag();
  PartialBag(const PartialBag&) = delete;
  PartialBag& operator=(const PartialBag&) = delete;

  /// rosbag::Bag::write, with a write error (disk full, ...) rethrown as std::runtime_error
  /// naming PATH (rosbag's own message does not).
  /// CONNECTION_HEADER as in rosbag::Bag::write (e.g. to mark /tf_static latched).
  template <typename Message>
  void write(const std::string& topic, const ros::Time& stamp, const Message& message,
             const boost::shared_ptr<ros::M_string>& connection_header = nullptr) {
    try {
      bag_->write(topic, stamp, message, connection_header);
    } catch (const rosbag::BagException& e) {
      throw std::runtime_error(path_ + ": " + e.what());
    }
  }
  const std::string& path() const { return path_; }
  /// Closes the bag and renames PATH.part to PATH; throws std::runtime_error naming PATH when
  /// either fails (the .part file is then removed).
  void commit();

 private:
  std::string path_, partial_;
  // On the heap so that a bag whose close() failed can be abandoned: rosbag::Bag's destructor
  // would close again, throw, and end the process (std::terminate).
  std::unique_ptr<rosbag::Bag> bag_;
  bool committed_ = false;
};

/// A connection header for Message on a latched topic, from `callerid`: `rosbag play` then
/// latches it, as a static broadcaster does, so that a node started after the bag began still
/// gets it (/tf_static). A custom header replaces rosbag's, so it carries the type fields too.
template <typename Message>
boost::shared_ptr<ros::M_string> latchedConnectionHeader(const std::string& callerid) {
  auto header = boost::make_shared<ros::M_string>();
  (*header)["type"] = ros::message_traits::datatype<Message>();
  (*header)["md5sum"] = ros::message_traits::md5sum<Message>();
  (*header)["message_definition"] = ros::message_traits::definition<Message>();
  (*header)["callerid"] = callerid;
  (*header)["latching"] = "1";
  return header;
}

}  // namespace rosbridge
}  // namespace rbpf_slam
