#pragma once
// Turns fuzzer bytes into typed values: a cursor that hands out numbers (including NaN and
// inf, which a float read from raw bytes can be) until the input runs out.

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>

namespace rbpf_slam {
namespace fuzz {

class ByteReader {
 public:
  ByteReader(const uint8_t* data, size_t size) : data_(data), size_(size) {}
  bool empty() const { return offset_ >= size_; }
  template <typename T>
  T take() {
    T value{};
    if (offset_ + sizeof(T) <= size_) std::memcpy(&value, data_ + offset_, sizeof(T));
    offset_ += sizeof(T);
    return value;
  }
  std::string rest() const {
    return offset_ < size_ ? std::string(reinterpret_cast<const char*>(data_ + offset_), size_ - offset_)
                           : std::string();
  }

 private:
  const uint8_t* data_;
  size_t size_;
  size_t offset_ = 0;
};

/// Aborts (a finding for the fuzzer) when the condition does not hold.
inline void require(bool condition) {
  if (!condition) __builtin_trap();
}

}  // namespace fuzz
}  // namespace rbpf_slam
