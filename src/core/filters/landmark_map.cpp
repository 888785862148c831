#include "rbpf_slam/core/filters/landmark_map.h"

#include <algorithm>
#include <cstdint>

namespace rbpf_slam {
namespace core {
namespace {

// Grid of the spatial index. Points: square cells of the map frame. Lines: the normal
// angle folded into [0, pi) (rho then signed) in kLineAngleBins bins; within a bin, cells
// of the frame rotated to the bin's lines: rho across the line, position along it.
// Sizes chosen on the Intel log (lines ~100 m from the origin, where a bin's angular width
// spreads the along-line range of a query most): a line query looks up ~9 cells and gets
// ~12 candidates, a point query ~6 cells and ~12 candidates, of ~900 landmarks.
constexpr double kPointCellM = 3.0;
constexpr int kLineAngleBins = 4;
constexpr double kLineAngleBinRad = M_PI / kLineAngleBins;
constexpr double kLineRhoCellM = 3.0;
constexpr double kLineAlongCellM = 32.0;
// Queries are widened by these so that rounding never drops a landmark on a cell border.
constexpr double kSlackM = 1e-3;
constexpr double kSlackRad = 1e-4;

constexpr int kPointTag = 1, kLineTag = 2;

int cellOf(double v, double size, int limit) {
  const double c = std::floor(v / size);
  if (!(c > -limit)) return std::isnan(c) ? 0 : -limit;
  return c < limit - 1 ? static_cast<int>(c) : limit - 1;
}
constexpr int kPointLimit = 1 << 30;  // cells per axis: 31 bits each in the key
constexpr int kLineLimit = 1 << 28;   // 29 bits each

uint64_t pointKey(int x, int y) {
  return (uint64_t{kPointTag} << 62) | (static_cast<uint64_t>(x + kPointLimit) << 31) |
         static_cast<uint64_t>(y + kPointLimit);
}

uint64_t lineKey(int bin, int rho, int along) {
  return (uint64_t{kLineTag} << 62) | (static_cast<uint64_t>(bin) << 58) |
         (static_cast<uint64_t>(rho + kLineLimit) << 29) |
         static_cast<uint64_t>(along + kLineLimit);
}

/// A line in the folded form: normal angle in [0, pi), rho signed, extent along the folded
/// direction.
struct FoldedLine {
  double rho, angle, extent_min, extent_max;
};

FoldedLine fold(const Eigen::Vector2d& line, double extent_min, double extent_max) {
  FoldedLine f{line.x(), wrapAngle(line.y()), std::min(extent_min, extent_max),
               std::max(extent_min, extent_max)};
  if (f.angle < 0.0) {
    f = {-f.rho, f.angle + M_PI, -f.extent_max, -f.extent_min};
  }
  return f;
}

int angleBinOf(double folded_angle) {
  return std::clamp(static_cast<int>(std::floor(folded_angle / kLineAngleBinRad)), 0,
                    kLineAngleBins - 1);
}

/// Widens [lo, hi] to the range of p . (-sin a, cos a), p's position along a line of normal
/// angle a, over a in [a0, a1] (a1 - a0 < pi), given (cos, sin) of a0 and a1. Inside the
/// interval the position has an extreme (+-|p|) only where p . (cos a, sin a), its negated
/// derivative, changes sign: from + to - a minimum, from - to + a maximum.
void widenAlongRange(const Eigen::Vector2d& p, const Eigen::Vector2d& cs0,
                     const Eigen::Vector2d& cs1, double* lo, double* hi) {
  const double f0 = -cs0.y() * p.x() + cs0.x() * p.y(), f1 = -cs1.y() * p.x() + cs1.x() * p.y();
  const double g0 = cs0.x() * p.x() + cs0.y() * p.y(), g1 = cs1.x() * p.x() + cs1.y() * p.y();
  *lo = std::min({*lo, f0, f1});
  *hi = std::max({*hi, f0, f1});
  if (g0 > 0.0 && g1 <= 0.0) *lo = std::min(*lo, -p.norm());
  if (g0 < 0.0 && g1 >= 0.0) *hi = std::max(*hi, p.norm());
}

Eigen::Vector2d cosSin(double a) { return Eigen::Vector2d(std::cos(a), std::sin(a)); }

}  // namespace

LandmarkMap::CellBox LandmarkMap::cellsOf(const Landmark& landmark) {
  CellBox box;
  if (landmark.type == LandmarkType::kPoint) {
    box.tag = kPointTag;
    box.first_a = box.last_a = cellOf(landmark.mean.x(), kPointCellM, kPointLimit);
    box.first_b = box.last_b = cellOf(landmark.mean.y(), kPointCellM, kPointLimit);
    return box;
  }
  const FoldedLine f = fold(landmark.mean, landmark.extent_min, landmark.extent_max);
  box.tag = kLineTag;
  box.bin = angleBinOf(f.angle);
  box.first_a = box.last_a = cellOf(f.rho, kLineRhoCellM, kLineLimit);
  // A line is filed in every cell along its extent: a corrupt extent (1e300 m) would be 2^29
  // cells. Beyond a thousand kilometres nothing is filed (nor looked up in practice).
  constexpr double kMaxAlongM = 1e6;
  box.first_b =
      cellOf(std::clamp(f.extent_min, -kMaxAlongM, kMaxAlongM), kLineAlongCellM, kLineLimit);
  box.last_b =
      cellOf(std::clamp(f.extent_max, -kMaxAlongM, kMaxAlongM), kLineAlongCellM, kLineLimit);
  return box;
}

void LandmarkMap::file(const CellBox& box, int index, bool insert) {
  for (int a = box.first_a; a <= box.last_a; ++a) {
    for (int b = box.first_b; b <= box.last_b; ++b) {
      const uint64_t key = box.tag == kPointTag ? pointKey(a, b) : lineKey(box.bin, a, b);
      if (insert) {
        cells_.insert(key, index);
      } else {
        cells_.erase(key, index);
      }
    }
  }
}

void LandmarkMap::add(const Landmark& landmark) {
  const int index = landmarks_.size();
  landmarks_.push_back(landmark);
  file(cellsOf(landmark), index, true);
  ids_.insert(static_cast<uint32_t>(landmark.id), index);
}

void LandmarkMap::set(int i, const Landmark& landmark) {
  const Landmark& old = landmarks_[i];
  const CellBox before = cellsOf(old), after = cellsOf(landmark);
  if (!(before == after)) {
    file(before, i, false);
    file(after, i, true);
  }
  if (old.id != landmark.id) {
    ids_.erase(static_cast<uint32_t>(old.id), i);
    ids_.insert(static_cast<uint32_t>(landmark.id), i);
  }
  landmarks_.set(i, landmark);
}

void LandmarkMap::remove(int i) {
  if (i < 0 || i >= size()) return;
  const int last = size() - 1;
  for (int j = i; j <= last; ++j) {  // unfile every landmark whose index changes
    file(cellsOf(landmarks_[j]), j, false);
    ids_.erase(static_cast<uint32_t>(landmarks_[j].id), j);
  }
  for (int j = i; j < last; ++j) {
    const Landmark moved = landmarks_[j + 1];
    landmarks_.set(j, moved);
    file(cellsOf(moved), j, true);
    ids_.insert(static_cast<uint32_t>(moved.id), j);
  }
  landmarks_.pop_back();
}

bool LandmarkMap::collect(const CellBox& box, std::vector<int>* out) const {
  for (int a = box.first_a; a <= box.last_a; ++a) {
    for (int b = box.first_b; b <= box.last_b; ++b) {
      const uint64_t key = box.tag == kPointTag ? pointKey(a, b) : lineKey(box.bin, a, b);
      cells_.forEach(key, [out](int index) { out->push_back(index); });
    }
  }
  return true;
}

void LandmarkMap::allIndices(std::vector<int>* out) const {
  out->resize(size());
  for (int i = 0; i < size(); ++i) (*out)[i] = i;
}

namespace {

double cellCount(int first_a, int last_a, int first_b, int last_b) {
  return (static_cast<double>(last_a) - first_a + 1.0) *
         (static_cast<double>(last_b) - first_b + 1.0);
}

void sortUnique(std::vector<int>* v) {
  std::sort(v->begin(), v->end());
  v->erase(std::unique(v->begin(), v->end()), v->end());
}

}  // namespace

void LandmarkMap::pointCandidates(const Eigen::Vector2d& center, double radius_m,
                                  std::vector<int>* out) const {
  out->clear();
  const double r = radius_m + kSlackM;
  CellBox box;
  box.tag = kPointTag;
  box.first_a = cellOf(center.x() - r, kPointCellM, kPointLimit);
  box.last_a = cellOf(center.x() + r, kPointCellM, kPointLimit);
  box.first_b = cellOf(center.y() - r, kPointCellM, kPointLimit);
  box.last_b = cellOf(center.y() + r, kPointCellM, kPointLimit);
  if (!(r >= 0.0) || !center.allFinite() ||
      cellCount(box.first_a, box.last_a, box.first_b, box.last_b) > size()) {
    allIndices(out);  // a scan is cheaper (or the query is not a disc)
    return;
  }
  for (int a = box.first_a; a <= box.last_a; ++a) {
    for (int b = box.first_b; b <= box.last_b; ++b) {
      // Skip cells of the box that the disc does not reach.
      const double dx =
          std::max({a * kPointCellM - center.x(), center.x() - (a + 1) * kPointCellM, 0.0});
      const double dy =
          std::max({b * kPointCellM - center.y(), center.y() - (b + 1) * kPointCellM, 0.0});
      if (dx * dx + dy * dy > r * r) continue;
      cells_.forEach(pointKey(a, b), [out](int index) { out->push_back(index); });
    }
  }
  sortUnique(out);
}

void LandmarkMap::lineCandidates(const LineQuery& query, std::vector<int>* out) const {
  out->clear();
  const double reach = query.max_rho_m + kSlackM;
  // Otherwise (not a line, or a pre-gate too wide for the bins): a scan.
  const bool finite = query.line.allFinite() && query.start.allFinite() && query.end.allFinite() &&
                      std::isfinite(reach) && std::isfinite(query.overlap_margin_m) &&
                      query.max_angle_rad >= 0.0 && query.max_angle_rad < M_PI / 4.0;
  const FoldedLine f = fold(finite ? query.line : Eigen::Vector2d::Zero(), 0.0, 0.0);
  const double lo_angle = f.angle - (finite ? query.max_angle_rad : 0.0) - kSlackRad;
  const double hi_angle = f.angle + (finite ? query.max_angle_rad : 0.0) + kSlackRad;
  const int first_bin = static_cast<int>(std::floor(lo_angle / kLineAngleBinRad));
  const int last_bin = static_cast<int>(std::floor(hi_angle / kLineAngleBinRad));
  std::vector<CellBox> boxes;
  double cells = 0.0;
  Eigen::Vector2d cs1_previous = Eigen::Vector2d::Zero();
  for (int bin = first_bin; finite && bin <= last_bin; ++bin) {
    // This virtual bin's angles, and how the landmarks there are filed: a bin beyond
    // [0, pi) holds lines folded with the opposite normal (rho and extent negated).
    const double a0 = std::max(bin * kLineAngleBinRad, lo_angle);
    const double a1 = std::min((bin + 1) * kLineAngleBinRad, hi_angle);
    const int folded_bin = ((bin % kLineAngleBins) + kLineAngleBins) % kLineAngleBins;
    const bool flipped = ((bin - folded_bin) / kLineAngleBins) % 2 != 0;
    // Bins share their borders: (cos, sin) of each border computed once.
    const Eigen::Vector2d cs0 = bin == first_bin ? cosSin(a0) : cs1_previous;
    const Eigen::Vector2d cs1 = cosSin(a1);
    cs1_previous = cs1;
    double along_lo = INFINITY, along_hi = -INFINITY;
    widenAlongRange(query.start, cs0, cs1, &along_lo, &along_hi);
    widenAlongRange(query.end, cs0, cs1, &along_lo, &along_hi);
    along_lo -= query.overlap_margin_m + kSlackM;
    along_hi += query.overlap_margin_m + kSlackM;
    double rho_lo = f.rho - reach, rho_hi = f.rho + reach;
    if (flipped) {
      std::swap(along_lo, along_hi);
      along_lo = -along_lo;
      along_hi = -along_hi;
      std::swap(rho_lo, rho_hi);
      rho_lo = -rho_lo;
      rho_hi = -rho_hi;
    }
    CellBox box;
    box.tag = kLineTag;
    box.bin = folded_bin;
    box.first_a = cellOf(rho_lo, kLineRhoCellM, kLineLimit);
    box.last_a = cellOf(rho_hi, kLineRhoCellM, kLineLimit);
    box.first_b = cellOf(along_lo, kLineAlongCellM, kLineLimit);
    box.last_b = cellOf(along_hi, kLineAlongCellM, kLineLimit);
    cells += cellCount(box.first_a, box.last_a, box.first_b, box.last_b);
    boxes.push_back(box);
  }
  if (!finite || cells > size()) {
    allIndices(out);
    return;
  }
  for (const CellBox& box : boxes) collect(box, out);
  sortUnique(out);
}

void LandmarkMap::idCandidates(int id, std::vector<int>* out) const {
  out->clear();
  ids_.forEach(static_cast<uint32_t>(id), [out](int index) { out->push_back(index); });
  std::sort(out->begin(), out->end());
}

}  // namespace core
}  // namespace rbpf_slam
