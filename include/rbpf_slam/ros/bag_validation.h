#pragma once
// Checks a bag for the input problems that make SLAM fail before blaming the filter:
// backwards and duplicate stamps, gaps, zero stamps, invalid ranges, sensor frames that tf
// does not connect to the base frame, topics whose messages change frame.

#include <map>
#include <set>
#include <string>
#include <vector>

namespace rbpf_slam {
namespace rosbridge {

struct BagValidationOptions {
  std::string base_frame = "base_link";
  std::string odom_frame = "odom";
  // A step between consecutive stamps of a stream is a gap when it is longer than this and
  // than 5 times the stream's median step (the largest step left out; 3 steps or more).
  double max_gap_s = 2.0;
};

/// What one stream (a topic, or one tf parent -> child edge) looked like.
struct StreamReport {
  std::string name;  // topic, or "tf parent -> child"
  long messages = 0;
  long backwards = 0;   // stamp older than the previous one of the stream
  long duplicates = 0;  // stamp equal to the previous one
  long zero_stamps = 0;
  long far_stamps = 0;  // near 2^32 s (farStampProblem): tf2 cannot handle them
  long gaps = 0;                 // steps larger than gap_threshold_s
  double gap_threshold_s = 0.0;  // max(max_gap_s, 5 x the median step without the largest)
  double largest_gap_s = 0.0;
  double first_gap_at_s = -1.0;  // bag-relative time of the first gap
  long invalid_values = 0;       // NaN / -inf ranges, non-finite features, refused transforms
  std::string first_invalid;     // tf: why the first refused transform is (transformProblem)
  std::set<std::string> frames;  // header frames seen
};

struct BagReport {
  std::string path;
  double duration_s = 0.0;
  std::vector<StreamReport> streams;
  std::vector<std::string> problems;  // one sentence each, naming topic, frame or edge
  std::vector<std::string> notes;     // expected oddities (per-transducer sonar frames)
};

/// Reads the whole bag once. Throws std::runtime_error when it cannot be opened.
BagReport validateBag(const std::string& path, const BagValidationOptions& options);

}  // namespace rosbridge
}  // namespace rbpf_slam
