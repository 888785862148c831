#include "rbpf_slam/ros/bag_files.h"

#include <fcntl.h>
#include <rosbag/view.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <topic_tools/shape_shifter.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <new>
#include <stdexcept>

#include "rbpf_slam/io/output_file.h"

namespace rbpf_slam {
namespace rosbridge {
namespace {

/// Where the reading child process was: shared with the parent.
struct ReadProgress {
  long index = -1;
  double time = 0.0;
  char topic[256] = {0};
};

/// Little-endian unsigned integer of n bytes.
uint64_t littleEndian(const std::string& bytes, size_t at, size_t n) {
  uint64_t value = 0;
  for (size_t k = 0; k < n; ++k) {
    value |= static_cast<uint64_t>(static_cast<unsigned char>(bytes[at + k])) << (8 * k);
  }
  return value;
}

/// A bag file read record by record (format 2.0: header length, header fields "name=value",
/// data length, data).
class BagRecords {
 public:
  explicit BagRecords(const std::string& path) : in_(path, std::ios::binary) {
    in_.seekg(0, std::ios::end);
    size_ = static_cast<uint64_t>(std::max<std::streamoff>(in_.tellg(), 0));
  }
  uint64_t size() const { return size_; }
  bool read(uint64_t at, uint64_t n, std::string* out) {
    if (at > size_ || n > size_ - at) return false;
    out->resize(n);
    in_.seekg(static_cast<std::streamoff>(at));
    return n == 0 || static_cast<bool>(in_.read(&(*out)[0], static_cast<std::streamsize>(n)));
  }
  /// The record at `at`: its fields, where its data starts and how long it is. False with
  /// *problem when it does not fit in the file or its header does not parse.
  bool record(uint64_t at, std::map<std::string, std::string>* fields, uint64_t* data_at,
              uint64_t* data_size, std::string* problem) {
    std::string bytes;
    if (!read(at, 4, &bytes)) return fail(problem, "a record header length past the end", at);
    const uint64_t header_size = littleEndian(bytes, 0, 4);
    std::string header;
    if (!read(at + 4, header_size, &header) || !read(at + 4 + header_size, 4, &bytes)) {
      return fail(problem, "a record header longer than the file", at);
    }
    *data_size = littleEndian(bytes, 0, 4);
    *data_at = at + 8 + header_size;
    if (*data_at > size_ || *data_size > size_ - *data_at) {
      return fail(problem, "a record longer than the file", at);
    }
    fields->clear();
    for (size_t p = 0; p < header.size();) {
      if (header.size() - p < 4) return fail(problem, "a broken record header", at);
      const uint64_t n = littleEndian(header, p, 4);
      if (n > header.size() - p - 4) return fail(problem, "a broken record header", at);
      const std::string field = header.substr(p + 4, n);
      const size_t eq = field.find('=');
      if (eq == std::string::npos) return fail(problem, "a broken record header", at);
      (*fields)[field.substr(0, eq)] = field.substr(eq + 1);
      p += 4 + n;
    }
    return true;
  }

 private:
  static bool fail(std::string* problem, const std::string& what, uint64_t at) {
    *problem = what + " at byte " + std::to_string(at);
    return false;
  }
  std::ifstream in_;
  uint64_t size_ = 0;
};

/// What is wrong with a format 2.0 bag's chunk indexes ("" when nothing is), checked before
/// rosbag trusts them: every index entry must point into its chunk, and in an uncompressed
/// chunk at a record that fits in it. rosbag reads outside its buffer otherwise and the process
/// dies by a signal. *unchecked: a chunk is compressed, so its records could not be checked.
std::string chunkIndexProblem(const std::string& path, bool* unchecked) {
  BagRecords bag(path);
  std::string bytes;
  *unchecked = true;
  if (!bag.read(0, 13, &bytes) || bytes != "#ROSBAG V2.0\n") return "";  // rosbag's to judge
  *unchecked = false;
  uint64_t at = 13, index_at = bag.size();
  bool in_chunk = false;
  uint64_t chunk_at = 0, chunk_data_at = 0, chunk_size = 0;
  bool uncompressed = false;
  std::map<std::string, std::string> fields;
  std::string problem;
  while (at < index_at && at < bag.size()) {
    uint64_t data_at = 0, data_size = 0;
    if (!bag.record(at, &fields, &data_at, &data_size, &problem)) return problem;
    const std::string op = fields.count("op") ? fields["op"] : "";
    if (op == std::string(1, '\x03') && fields["index_pos"].size() == 8) {
      const uint64_t pos = littleEndian(fields["index_pos"], 0, 8);
      if (pos > 0) index_at = pos;
    } else if (op == std::string(1, '\x05')) {
      if (fields["size"].size() != 4)
        return "a chunk without its size at byte " + std::to_string(at);
      in_chunk = true;
      chunk_at = at;
      chunk_data_at = data_at;
      chunk_size = littleEndian(fields["size"], 0, 4);
      uncompressed = fields["compression"] == "none";
      if (!uncompressed) *unchecked = true;
      if (uncompressed && chunk_size != data_size) {
        return "an uncompressed chunk of " + std::to_string(data_size) + " bytes that says " +
               std::to_string(chunk_size) + " at byte " + std::to_string(at);
      }
    } else if (op == std::string(1, '\x04')) {
      const uint64_t count = fields["count"].size() == 4 ? littleEndian(fields["count"], 0, 4) : 0;
      if (!in_chunk || fields["ver"].size() != 4 || littleEndian(fields["ver"], 0, 4) != 1 ||
          count * 12 != data_size || !bag.read(data_at, data_size, &bytes)) {
        return "a broken index record at byte " + std::to_string(at);
      }
      for (uint64_t k = 0; k < count; ++k) {
        const uint64_t offset = littleEndian(bytes, 12 * k + 8, 4);
        const auto where = [&] {  // built only for the message
          return "index entry " + std::to_string(k + 1) + " of the record at byte " +
                 std::to_string(at) + " points at offset " + std::to_string(offset) +
                 " of the chunk at byte " + std::to_string(chunk_at) + " (" +
                 std::to_string(chunk_size) + " bytes)";
        };
        if (offset >= chunk_size) return where() + ", past its end";
        if (!uncompressed) continue;
        uint64_t message_data_at = 0, message_size = 0;
        std::map<std::string, std::string> message;
        std::string why;
        if (!bag.record(chunk_data_at + offset, &message, &message_data_at, &message_size, &why) ||
            message_data_at + message_size > chunk_data_at + chunk_size) {
          return where() + ", at a record that does not fit in the chunk";
        }
      }
    }
    at = data_at + data_size;
  }
  return "";
}

/// rosbag trusts a bag's index: a damaged index entry (an offset past its chunk, a wrong size)
/// makes it read outside its buffer and the process dies by a signal, which no exception
/// handler can catch (a fuzzed bag: 17 of 2700 one-field mutations). So every message is read
/// once in a child process first; when that child dies, the bag is refused with where it died.
void requireReadableMessages(const std::string& path) {
  void* shared = mmap(nullptr, sizeof(ReadProgress), PROT_READ | PROT_WRITE,
                      MAP_SHARED | MAP_ANONYMOUS, -1, 0);
  if (shared == MAP_FAILED) return;  // no check possible: read as before
  ReadProgress* progress = new (shared) ReadProgress();
  const pid_t pid = fork();
  if (pid < 0) {
    munmap(shared, sizeof(ReadProgress));
    return;
  }
  if (pid == 0) {
    // The child: its own file handle (not the parent's offsets), no destructors, no output,
    // no core file.
    const struct rlimit no_core = {0, 0};
    setrlimit(RLIMIT_CORE, &no_core);
    const int null = open("/dev/null", O_WRONLY);
    if (null >= 0) {
      dup2(null, STDOUT_FILENO);
      dup2(null, STDERR_FILENO);
    }
    try {
      rosbag::Bag bag;
      bag.open(path, rosbag::bagmode::Read);
      long index = 0;
      for (const rosbag::MessageInstance& m : rosbag::View(bag)) {
        progress->index = index++;
        progress->time = m.getTime().toSec();
        std::strncpy(progress->topic, m.getTopic().c_str(), sizeof(progress->topic) - 1);
        m.instantiate<topic_tools::ShapeShifter>();
      }
    } catch (...) {
      // Exceptions are the reader's to report, message by message.
    }
    _exit(0);
  }
  // Waits while the child makes progress: one stuck on a message for a minute is stopped (a
  // damaged bag can make rosbag loop) and the bag refused.
  int status = 0;
  long last_index = -2;
  auto last_progress = std::chrono::steady_clock::now();
  bool stuck = false;
  for (;;) {
    const pid_t done = waitpid(pid, &status, WNOHANG);
    if (done == pid || (done < 0 && errno != EINTR)) break;
    if (progress->index != last_index) {
      last_index = progress->index;
      last_progress = std::chrono::steady_clock::now();
    } else if (std::chrono::steady_clock::now() - last_progress > std::chrono::seconds(60)) {
      kill(pid, SIGKILL);
      waitpid(pid, &status, 0);
      stuck = true;
      break;
    }
    usleep(2000);
  }
  const ReadProgress where = *progress;
  munmap(shared, sizeof(ReadProgress));
  // Only a crash of the reading says the bag is damaged (not a kill from outside, e.g. the
  // out-of-memory killer).
  const int signal = WIFSIGNALED(status) ? WTERMSIG(status) : 0;
  const bool crashed = signal == SIGSEGV || signal == SIGBUS || signal == SIGABRT ||
                       signal == SIGFPE || signal == SIGILL;
  if (!crashed && !stuck) return;
  char at[64];
  std::snprintf(at, sizeof(at), "%.3f", where.time);
  throw std::runtime_error(
      path + ": the bag is damaged: reading message " + std::to_string(where.index + 1) +
      " (topic " + where.topic + ", bag time " + at + ") made the rosbag library " +
      (stuck ? std::string("hang for a minute")
             : "crash (" + std::string(strsignal(signal)) + ")") +
      "; its index is probably broken: try `rosbag reindex` on a copy, or `rosbag filter` "
      "to leave that part out");
}

}  // namespace

void openBagForReading(rosbag::Bag* bag, const std::string& path) {
  try {
    bag->open(path, rosbag::bagmode::Read);
  } catch (const rosbag::BagException& e) {
    throw std::runtime_error(path + ": cannot open bag: " + e.what());
  }
  // rosbag::View of an empty bag begins at TIME_MAX and ends at TIME_MIN: its duration throws
  // "Duration is out of dual 32-bit range", naming nothing.
  if (rosbag::View(*bag).size() == 0) throw std::runtime_error(path + ": the bag holds no messages");
  bool unchecked = true;
  const std::string problem = chunkIndexProblem(path, &unchecked);
  if (!problem.empty()) {
    throw std::runtime_error(path + ": the bag is damaged (" + problem +
                             "); try `rosbag reindex` on a copy, or `rosbag filter` to leave "
                             "that part out");
  }
  // Compressed chunks (or a format the parser does not read) are read once in a child first.
  if (unchecked) requireReadableMessages(path);
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
