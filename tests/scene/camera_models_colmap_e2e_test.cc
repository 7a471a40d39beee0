// End-to-end check of the projection formulas against COLMAP 3.8 itself:
// COLMAP's image_undistorter resamples an image of the distorted camera into
// a pinhole camera, sampling the source at COLMAP's own projection of each
// target ray. We draw blobs where OUR projection puts known rays; the blobs
// must come out where the pinhole camera puts those rays. A formula that
// differs from COLMAP's (a sign, a term, a parameter order) moves them by
// pixels; the distortion parameters are chosen so that every term matters.

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "colmap_irav4/io/model_io.h"
#include "colmap_irav4/scene/camera_models.h"
#include "tests/test_utils/record.h"

namespace colmap_irav4 {
namespace {

namespace fs = std::filesystem;

const char kColmap[] = "/usr/bin/colmap";

int RunShell(const std::string& command, std::string* output) {
  FILE* pipe = popen((command + " 2>&1").c_str(), "r");
  if (pipe == nullptr) return -1;
  char buffer[4096];
  size_t n;
  while ((n = fread(buffer, 1, sizeof(buffer), pipe)) > 0) {
    output->append(buffer, n);
  }
  const int status = pclose(pipe);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// Strong distortion for every model (640 x 480, f ~ 400) that stays
// invertible over the whole image (else COLMAP shrinks the output).
std::vector<Camera> TestCameras() {
  const std::vector<std::vector<double>> params = {
      {400, 320, 240},
      {400, 410, 322, 238},
      {400, 320, 240, -0.08},
      {400, 320, 240, -0.08, 0.01},
      {400, 410, 320, 240, -0.08, 0.01, 0.01, -0.012},
      {400, 410, 320, 240, 0.1, -0.05, 0.03, -0.01},
      {400, 410, 320, 240, -0.08, 0.01, 0.01, -0.012, 0.005, 0.05, -0.02, 0.01},
      {400, 410, 320, 240, 0.7},
      {400, 320, 240, 0.1},
      {400, 320, 240, 0.1, -0.05},
      {400, 410, 320, 240, 0.1, -0.05, 0.01, -0.012, 0.03, -0.01, 0.02, -0.015},
  };
  std::vector<Camera> cameras;
  for (int model_id = 0; model_id < kNumCameraModels; ++model_id) {
    Camera camera;
    camera.camera_id = 1;
    camera.model_id = model_id;
    camera.width = 640;
    camera.height = 480;
    camera.params = params[model_id];
    cameras.push_back(camera);
  }
  return cameras;
}

TEST(CameraModelsColmap, ImageUndistorterAgreesWithOurProjection) {
  if (!fs::exists(kColmap)) GTEST_SKIP() << kColmap << " is not installed";
  const double kSigma = 1.5;  // blob radius in pixels
  // Rays on a grid, away from the borders.
  std::vector<Eigen::Vector2d> rays;
  for (double x = -0.5; x <= 0.51; x += 0.25) {
    for (double y = -0.375; y <= 0.38; y += 0.25) rays.emplace_back(x, y);
  }
  const fs::path root =
      fs::temp_directory_path() /
      ("colmap_irav4_undistorter_" + std::to_string(::getpid()));
  for (const Camera& camera : TestCameras()) {
    SCOPED_TRACE(CameraModelIdToName(camera.model_id));
    fs::remove_all(root);
    fs::create_directories(root / "images");
    fs::create_directories(root / "out");

    // The source image: Gaussian blobs at our projections of the rays.
    cv::Mat image(camera.height, camera.width, CV_8UC1, cv::Scalar(0));
    std::vector<Eigen::Vector2d> projections;
    for (const Eigen::Vector2d& ray : rays) {
      projections.push_back(CameraCameraToImage(camera, ray));
    }
    for (int row = 0; row < image.rows; ++row) {
      for (int col = 0; col < image.cols; ++col) {
        // COLMAP's pixel (col, row) has its centre at (col + 0.5, row + 0.5).
        const Eigen::Vector2d centre(col + 0.5, row + 0.5);
        double value = 0.0;
        for (const Eigen::Vector2d& p : projections) {
          value +=
              std::exp(-(centre - p).squaredNorm() / (2 * kSigma * kSigma));
        }
        image.at<uint8_t>(row, col) =
            static_cast<uint8_t>(std::min(255.0, std::round(250.0 * value)));
      }
    }
    ASSERT_TRUE(cv::imwrite((root / "images" / "blobs.png").string(), image));

    Reconstruction model;
    model.cameras[1] = camera;
    Image model_image;
    model_image.image_id = 1;
    model_image.camera_id = 1;
    model_image.name = "blobs.png";
    model.images[1] = model_image;
    WriteReconstruction(model, (root / "sparse").string(), "BIN");

    std::string output;
    ASSERT_EQ(RunShell(std::string(kColmap) + " image_undistorter" +
                           " --image_path " + (root / "images").string() +
                           " --input_path " + (root / "sparse").string() +
                           " --output_path " + (root / "out").string(),
                       &output),
              0)
        << output;
    const Reconstruction undistorted =
        ReadReconstruction((root / "out" / "sparse").string());
    ASSERT_EQ(undistorted.cameras.size(), 1u);
    const Camera& pinhole = undistorted.cameras.begin()->second;
    ASSERT_TRUE(pinhole.model_id == kPinhole ||
                pinhole.model_id == kSimplePinhole);
    const cv::Mat result = cv::imread(
        (root / "out" / "images" / "blobs.png").string(), cv::IMREAD_GRAYSCALE);
    ASSERT_FALSE(result.empty());
    ASSERT_EQ(static_cast<uint64_t>(result.cols), pinhole.width);

    // Each blob's centroid is where the pinhole camera sees its ray.
    double max_error = 0.0;
    for (const Eigen::Vector2d& ray : rays) {
      const Eigen::Vector2d expected = CameraCameraToImage(pinhole, ray);
      const int radius = 6;
      double sum = 0.0;
      Eigen::Vector2d weighted = Eigen::Vector2d::Zero();
      for (int row = int(expected.y()) - radius;
           row <= int(expected.y()) + radius; ++row) {
        for (int col = int(expected.x()) - radius;
             col <= int(expected.x()) + radius; ++col) {
          if (row < 0 || col < 0 || row >= result.rows || col >= result.cols) {
            continue;
          }
          const double value = result.at<uint8_t>(row, col);
          sum += value;
          weighted += value * Eigen::Vector2d(col + 0.5, row + 0.5);
        }
      }
      if (sum < 500.0) {  // the blob is not there at all
        max_error = std::numeric_limits<double>::infinity();
        continue;
      }
      max_error = std::max(max_error, (weighted / sum - expected).norm());
    }
    EXPECT_LT(max_error, 0.15);
    ::colmap_irav4::test::RecordFiguresF(
        "%-22s max blob offset %.3f px\n",
        CameraModelIdToName(camera.model_id).c_str(), max_error);
  }
  fs::remove_all(root);
}

}  // namespace
}  // namespace colmap_irav4
