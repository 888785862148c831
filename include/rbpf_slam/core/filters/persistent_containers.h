#pragma once
// Persistent (path-copying) containers shared between particles: copying one is O(1) (a root
// pointer), reading is O(log N), and a write copies only the O(log N) nodes on its path, so
// that the copies made by resampling share every landmark none of them has changed
// (the O(M log N) landmark tree of FastSLAM, Montemerlo et al. 2002, as a fixed-fanout trie).

#include <array>
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

namespace rbpf_slam {
namespace core {

/// An array of T indexed 0..size-1 with value semantics: a copy shares every node, a write
/// copies the nodes on its path unless this array already owns them alone.
template <typename T>
class PersistentArray {
 public:
  int size() const { return size_; }

  const T& operator[](int i) const {
    const Node* node = root_.get();
    for (int shift = shift_; shift > 0; shift -= kBranchBits) {
      node = static_cast<const Branch*>(node)->child[(i >> shift) & kBranchMask].get();
    }
    return static_cast<const Leaf*>(node)->item[i & kLeafMask];
  }

  /// Replaces element i (0 <= i < size); copies its path when it is shared.
  void set(int i, const T& value) { *mutableSlot(i) = value; }

  /// Drops the last element (its slot is reused by the next push_back).
  void pop_back() {
    if (size_ > 0) --size_;
  }

  void push_back(const T& value) {
    if (!root_) {
      root_ = std::make_shared<Leaf>();
      shift_ = 0;
    } else if (size_ >= capacity()) {  // full: a new root above the old one
      auto branch = std::make_shared<Branch>();
      branch->child[0] = std::move(root_);
      root_ = std::move(branch);
      shift_ = shift_ == 0 ? kLeafBits : shift_ + kBranchBits;
    }
    ++size_;
    *mutableSlot(size_ - 1) = value;
  }

 private:
  static constexpr int kLeafBits = 3;    // 8 elements per leaf, copied whole on a write
  static constexpr int kBranchBits = 4;  // 16 children per branch
  static constexpr int kLeafMask = (1 << kLeafBits) - 1;
  static constexpr int kBranchMask = (1 << kBranchBits) - 1;

  struct Node {
    virtual ~Node() = default;
  };
  struct Branch : Node {
    std::array<std::shared_ptr<Node>, 1 << kBranchBits> child;
  };
  struct Leaf : Node {
    std::array<T, 1 << kLeafBits> item{};
  };

  long capacity() const {
    return root_ ? 1L << (shift_ == 0 ? kLeafBits : shift_ + kBranchBits) : 0;
  }

  /// The node `slot` points to, made exclusively ours (copied when shared, created if absent).
  template <typename N>
  static N* own(std::shared_ptr<Node>* slot) {
    if (!*slot) {
      *slot = std::make_shared<N>();
    } else if (slot->use_count() > 1) {
      *slot = std::make_shared<N>(*static_cast<const N*>(slot->get()));
    }
    return static_cast<N*>(slot->get());
  }

  T* mutableSlot(int i) {
    std::shared_ptr<Node>* slot = &root_;
    for (int shift = shift_; shift > 0; shift -= kBranchBits) {
      slot = &own<Branch>(slot)->child[(i >> shift) & kBranchMask];
    }
    return &own<Leaf>(slot)->item[i & kLeafMask];
  }

  std::shared_ptr<Node> root_;
  int size_ = 0;
  int shift_ = 0;  // bits of the index consumed below the root: 0 when the root is a leaf
};

/// A multimap from 64-bit keys to int values (a cell -> the landmarks in it) with the same
/// sharing: a hash trie of 16-way branches over leaves of a few (key, value) pairs.
class PersistentMultimap {
 public:
  /// Calls f(value) for every value stored under key.
  template <typename F>
  void forEach(uint64_t key, F&& f) const {
    const uint64_t h = hash(key);
    const Node* node = root_.get();
    for (int depth = 0; node && !node->leaf; ++depth) {
      node = static_cast<const Branch*>(node)->child[childOf(h, depth)].get();
    }
    if (!node) return;
    for (const auto& [k, v] : static_cast<const Leaf*>(node)->entries) {
      if (k == key) f(v);
    }
  }

  /// Adds (key, value); a pair already present is not added twice.
  void insert(uint64_t key, int value) {
    if (insertAt(&root_, 0, hash(key), key, value)) ++size_;
  }
  /// Removes (key, value) if present.
  void erase(uint64_t key, int value) {
    if (eraseAt(&root_, 0, hash(key), key, value)) --size_;
  }
  long size() const { return size_; }

 private:
  static constexpr int kBits = 4;
  static constexpr uint64_t kMask = (1u << kBits) - 1;
  static constexpr int kMaxDepth = 64 / kBits;
  static constexpr size_t kLeafCapacity = 8;

  struct Node {
    explicit Node(bool is_leaf) : leaf(is_leaf) {}
    virtual ~Node() = default;
    bool leaf;
  };
  struct Leaf : Node {
    Leaf() : Node(true) {}
    std::vector<std::pair<uint64_t, int>> entries;
  };
  struct Branch : Node {
    Branch() : Node(false) {}
    std::array<std::shared_ptr<Node>, 1 << kBits> child;
  };

  /// splitmix64 finaliser (a bijection): neighbouring cells land in unrelated branches.
  static uint64_t hash(uint64_t x) {
    x ^= x >> 30;
    x *= 0xbf58476d1ce4e5b9ULL;
    x ^= x >> 27;
    x *= 0x94d049bb133111ebULL;
    return x ^ (x >> 31);
  }
  static int childOf(uint64_t h, int depth) {
    return static_cast<int>((h >> (kBits * depth)) & kMask);
  }

  /// The node `slot` points to, made exclusively ours (copied when shared).
  template <typename N>
  static N* own(std::shared_ptr<Node>* slot) {
    if (!*slot) {
      *slot = std::make_shared<N>();
    } else if (slot->use_count() > 1) {
      *slot = std::make_shared<N>(*static_cast<const N*>(slot->get()));
    }
    return static_cast<N*>(slot->get());
  }

  static bool insertAt(std::shared_ptr<Node>* slot, int depth, uint64_t h, uint64_t key,
                       int value) {
    if (*slot && !(*slot)->leaf) {
      return insertAt(&own<Branch>(slot)->child[childOf(h, depth)], depth + 1, h, key, value);
    }
    if (*slot) {
      for (const auto& e : static_cast<const Leaf*>(slot->get())->entries) {
        if (e.first == key && e.second == value) return false;
      }
    }
    own<Leaf>(slot)->entries.emplace_back(key, value);
    splitIfFull(slot, depth);
    return true;
  }

  /// Replaces an overfull leaf (which this map owns) by a branch over leaves keyed by the
  /// next bits of the hash. Pairs of one key never split; they share a leaf at any depth.
  static void splitIfFull(std::shared_ptr<Node>* slot, int depth) {
    const auto* leaf = static_cast<const Leaf*>(slot->get());
    if (leaf->entries.size() <= kLeafCapacity || depth >= kMaxDepth) return;
    auto branch = std::make_shared<Branch>();
    for (const auto& e : leaf->entries) {
      own<Leaf>(&branch->child[childOf(hash(e.first), depth)])->entries.push_back(e);
    }
    for (auto& child : branch->child) {
      if (child) splitIfFull(&child, depth + 1);
    }
    *slot = std::move(branch);
  }

  static bool eraseAt(std::shared_ptr<Node>* slot, int depth, uint64_t h, uint64_t key, int value) {
    if (!contains(slot->get(), depth, h, key, value)) return false;  // copy nothing
    for (; !(*slot)->leaf; ++depth) slot = &own<Branch>(slot)->child[childOf(h, depth)];
    auto& entries = own<Leaf>(slot)->entries;
    for (size_t i = 0; i < entries.size(); ++i) {
      if (entries[i].first == key && entries[i].second == value) {
        entries.erase(entries.begin() + static_cast<long>(i));
        break;
      }
    }
    if (entries.empty()) slot->reset();
    return true;
  }

  static bool contains(const Node* node, int depth, uint64_t h, uint64_t key, int value) {
    for (; node && !node->leaf; ++depth) {
      node = static_cast<const Branch*>(node)->child[childOf(h, depth)].get();
    }
    if (!node) return false;
    for (const auto& e : static_cast<const Leaf*>(node)->entries) {
      if (e.first == key && e.second == value) return true;
    }
    return false;
  }

  std::shared_ptr<Node> root_;
  long size_ = 0;
};

}  // namespace core
}  // namespace rbpf_slam
