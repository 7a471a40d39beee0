#include "colmap_irav4/scene/point_colors.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include <glog/logging.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "colmap_irav4/util/threading.h"

namespace colmap_irav4 {

namespace fs = std::filesystem;

int ColorPointsFromImages(const std::string& image_path,
                          Reconstruction* reconstruction, int downscale,
                          int num_threads) {
  CHECK(downscale == 1 || downscale == 2 || downscale == 4 || downscale == 8)
      << downscale;
  // JPEG decoders scale by 2, 4 or 8 inside the DCT: much faster, and the
  // colour of a point (a mean over its track) barely changes. The pixels as
  // stored, as COLMAP's feature extractor reads them: OpenCV would turn a
  // photo by its EXIF orientation tag (phones store portrait shots turned),
  // and the keypoints would then sample the wrong pixels.
  const int flags = (downscale == 1   ? cv::IMREAD_COLOR
                     : downscale == 2 ? cv::IMREAD_REDUCED_COLOR_2
                     : downscale == 4 ? cv::IMREAD_REDUCED_COLOR_4
                                      : cv::IMREAD_REDUCED_COLOR_8) |
                    cv::IMREAD_IGNORE_ORIENTATION;
  // Per image, the colour at each observation (read in parallel, summed
  // serially so that the result does not depend on the thread count).
  std::vector<const Image*> images;
  for (const auto& [image_id, image] : reconstruction->images) {
    images.push_back(&image);
  }
  std::vector<std::vector<std::pair<point3D_t, Eigen::Vector3d>>> colors(
      images.size());
  // Why an image was not used ("" if it was).
  std::vector<std::string> missing(images.size());
  ParallelFor(num_threads, images.size(), [&](size_t i) {
    const Image& image = *images[i];
    const std::string file = (fs::path(image_path) / image.name).string();
    // Only regular files: opening a named pipe would block the run.
    std::error_code error;
    const fs::file_status status = fs::status(file, error);
    if (!fs::is_regular_file(status)) {
      missing[i] = fs::exists(status)
                       ? "not a regular file (a pipe or device?), not read"
                       : "cannot read the image";
      return;
    }
    const cv::Mat bgr = cv::imread(file, flags);
    if (bgr.empty()) {
      missing[i] = "cannot read the image";
      return;
    }
    // Another image than the one the keypoints were found in (another
    // size, or rotated): its colours would be wrong.
    const Camera& camera = reconstruction->cameras.at(image.camera_id);
    const auto scaled = [&](uint64_t size) {
      return static_cast<int>((size + downscale - 1) / downscale);
    };
    if (std::abs(bgr.cols - scaled(camera.width)) > 1 ||
        std::abs(bgr.rows - scaled(camera.height)) > 1) {
      missing[i] = "the image is " + std::to_string(bgr.cols * downscale) +
                   " x " + std::to_string(bgr.rows * downscale) +
                   " px, its camera " + std::to_string(camera.width) + " x " +
                   std::to_string(camera.height) + " px: not this image's file";
      return;
    }
    for (const Point2D& point2D : image.points2D) {
      if (point2D.point3D_id == kInvalidPoint3DId) continue;
      // Keypoints put the centre of the top-left pixel at (0.5, 0.5):
      // bilinear interpolation between the four nearest pixel centres.
      const double x = point2D.xy.x() / downscale - 0.5;
      const double y = point2D.xy.y() / downscale - 0.5;
      // (Checked before the casts: a keypoint far outside, or not finite,
      // is beyond int's range.)
      if (!(x >= 0 && y >= 0 && x < bgr.cols - 1 && y < bgr.rows - 1)) {
        continue;
      }
      const int x0 = static_cast<int>(std::floor(x));
      const int y0 = static_cast<int>(std::floor(y));
      const double dx = x - x0;
      const double dy = y - y0;
      Eigen::Vector3d rgb = Eigen::Vector3d::Zero();
      const double w[4] = {(1 - dx) * (1 - dy), dx * (1 - dy), (1 - dx) * dy,
                           dx * dy};
      const cv::Vec3b* pixels[4] = {
          &bgr.at<cv::Vec3b>(y0, x0), &bgr.at<cv::Vec3b>(y0, x0 + 1),
          &bgr.at<cv::Vec3b>(y0 + 1, x0), &bgr.at<cv::Vec3b>(y0 + 1, x0 + 1)};
      for (int k = 0; k < 4; ++k) {
        rgb += w[k] * Eigen::Vector3d((*pixels[k])[2], (*pixels[k])[1],
                                      (*pixels[k])[0]);
      }
      colors[i].emplace_back(point2D.point3D_id, rgb);
    }
  });

  std::map<point3D_t, std::pair<Eigen::Vector3d, int>> sums;
  int num_missing = 0;
  for (size_t i = 0; i < images.size(); ++i) {
    if (!missing[i].empty()) {
      ++num_missing;
      LOG(WARNING) << (fs::path(image_path) / images[i]->name).string() << ": "
                   << missing[i] << "; its points stay grey";
    }
    for (const auto& [point3D_id, rgb] : colors[i]) {
      auto& sum = sums[point3D_id];
      if (sum.second == 0) sum.first.setZero();
      sum.first += rgb;
      ++sum.second;
    }
  }
  for (auto& [point3D_id, point] : reconstruction->points3D) {
    const auto it = sums.find(point3D_id);
    if (it == sums.end()) {
      point.color.setConstant(128);
      continue;
    }
    const Eigen::Vector3d mean = it->second.first / it->second.second;
    for (int c = 0; c < 3; ++c) {
      point.color[c] =
          static_cast<uint8_t>(std::clamp(std::round(mean[c]), 0.0, 255.0));
    }
  }
  return num_missing;
}

}  // namespace colmap_irav4
