#pragma once

#include <cstdint>
#include <limits>
#include <utility>

namespace colmap_irav4 {

// Identifier types, as in COLMAP.
typedef uint32_t camera_t;
typedef uint32_t image_t;
typedef uint64_t image_pair_t;
typedef uint32_t point2D_t;
typedef uint64_t point3D_t;

constexpr camera_t kInvalidCameraId = std::numeric_limits<camera_t>::max();
constexpr image_t kInvalidImageId = std::numeric_limits<image_t>::max();
constexpr point2D_t kInvalidPoint2DIdx = std::numeric_limits<point2D_t>::max();
constexpr point3D_t kInvalidPoint3DId = std::numeric_limits<point3D_t>::max();

// COLMAP's database pair id: 2147483647 * min(id1, id2) + max(id1, id2).
constexpr uint64_t kMaxNumImages = 2147483647;
inline image_pair_t ImagePairToPairId(image_t image_id1, image_t image_id2) {
  if (image_id1 > image_id2) std::swap(image_id1, image_id2);
  return kMaxNumImages * image_id1 + image_id2;
}
inline std::pair<image_t, image_t> PairIdToImagePair(image_pair_t pair_id) {
  const image_t image_id2 = static_cast<image_t>(pair_id % kMaxNumImages);
  const image_t image_id1 =
      static_cast<image_t>((pair_id - image_id2) / kMaxNumImages);
  return {image_id1, image_id2};
}
// Whether the database stores the pair with its images swapped relative to
// (image_id1, image_id2), i.e. its geometry must be inverted.
inline bool SwapImagePair(image_t image_id1, image_t image_id2) {
  return image_id1 > image_id2;
}

}  // namespace colmap_irav4
