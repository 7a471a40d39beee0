#pragma once

// Helpers shared by the model I/O tests.

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "colmap_irav4/scene/camera_models.h"
#include "colmap_irav4/scene/reconstruction.h"
#include "colmap_irav4/util/random.h"
#include "tests/test_utils/temp_dir.h"

namespace colmap_irav4 {
namespace test {

namespace fs = std::filesystem;

inline std::string ReadBytes(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  std::ostringstream bytes;
  bytes << file.rdbuf();
  return bytes.str();
}

inline void WriteBytes(const std::string& path, const std::string& bytes) {
  std::ofstream file(path, std::ios::binary | std::ios::trunc);
  file.write(bytes.data(), bytes.size());
}

// Every field, exactly (doubles included: both formats must be lossless).
inline void ExpectIdentical(const Reconstruction& a, const Reconstruction& b) {
  ASSERT_EQ(a.cameras.size(), b.cameras.size());
  ASSERT_EQ(a.images.size(), b.images.size());
  ASSERT_EQ(a.points3D.size(), b.points3D.size());
  for (const auto& [camera_id, camera] : a.cameras) {
    ASSERT_TRUE(b.cameras.count(camera_id));
    const Camera& other = b.cameras.at(camera_id);
    EXPECT_EQ(camera.camera_id, other.camera_id);
    EXPECT_EQ(camera.model_id, other.model_id);
    EXPECT_EQ(camera.width, other.width);
    EXPECT_EQ(camera.height, other.height);
    EXPECT_EQ(camera.params, other.params);
  }
  for (const auto& [image_id, image] : a.images) {
    ASSERT_TRUE(b.images.count(image_id));
    const Image& other = b.images.at(image_id);
    EXPECT_EQ(image.image_id, other.image_id);
    EXPECT_EQ(image.name, other.name);
    EXPECT_EQ(image.camera_id, other.camera_id);
    EXPECT_EQ(image.cam_from_world.rotation.coeffs(),
              other.cam_from_world.rotation.coeffs());
    EXPECT_EQ(image.cam_from_world.translation,
              other.cam_from_world.translation);
    ASSERT_EQ(image.points2D.size(), other.points2D.size());
    for (size_t i = 0; i < image.points2D.size(); ++i) {
      ASSERT_EQ(image.points2D[i].xy, other.points2D[i].xy);
      ASSERT_EQ(image.points2D[i].point3D_id, other.points2D[i].point3D_id);
    }
  }
  for (const auto& [point3D_id, point] : a.points3D) {
    ASSERT_TRUE(b.points3D.count(point3D_id));
    const Point3D& other = b.points3D.at(point3D_id);
    ASSERT_EQ(point.xyz, other.xyz);
    ASSERT_EQ(point.color, other.color);
    ASSERT_EQ(point.error, other.error);
    ASSERT_EQ(point.track.size(), other.track.size());
    for (size_t i = 0; i < point.track.size(); ++i) {
      ASSERT_EQ(point.track[i].image_id, other.track[i].image_id);
      ASSERT_EQ(point.track[i].point2D_idx, other.track[i].point2D_idx);
    }
  }
}

// A small model with every camera model, images without points2D, points
// with long tracks and a name with a space.
inline Reconstruction SyntheticModel(bool name_with_space = true) {
  Reconstruction model;
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  for (int model_id = 0; model_id < kNumCameraModels; ++model_id) {
    Camera camera;
    camera.camera_id = 10 + model_id;
    camera.model_id = model_id;
    camera.width = 640 + model_id;
    camera.height = 480;
    for (int i = 0; i < CameraModelNumParams(model_id); ++i) {
      camera.params.push_back(uniform(rng) * 1e3 / (i + 1));
    }
    model.cameras[camera.camera_id] = camera;
  }
  for (image_t image_id = 1; image_id <= 12; ++image_id) {
    Image image;
    image.image_id = image_id * 3;
    image.camera_id = 10 + image_id % kNumCameraModels;
    image.name = std::string(name_with_space ? "dir/image " : "dir/image_") +
                 std::to_string(image_id) + ".jpg";
    // Writers divide quaternions by their norm (as COLMAP does): use one
    // that the division leaves unchanged, so that round trips are exact.
    Eigen::Vector4d qvec = RandomVector<4>(uniform, rng);
    for (int k = 0; k < 10; ++k) qvec /= qvec.norm();
    EXPECT_EQ(qvec / qvec.norm(), qvec);
    image.cam_from_world.rotation =
        Eigen::Quaterniond(qvec(0), qvec(1), qvec(2), qvec(3));
    image.cam_from_world.translation = RandomVector<3>(uniform, rng) * 10.0;
    image.points2D.resize(image_id == 5 ? 0 : 40);
    for (Point2D& point2D : image.points2D) {
      point2D.xy = RandomVector<2>(uniform, rng) * 300.0;
    }
    model.images[image.image_id] = image;
  }
  point3D_t next_id = 1000000000000ull;
  std::bernoulli_distribution also_observed(0.3);
  for (auto& [image_id, image] : model.images) {
    for (size_t idx = 0; idx < image.points2D.size(); ++idx) {
      // A quarter of the points2D stay without a point.
      if (image.points2D[idx].point3D_id != kInvalidPoint3DId || idx % 4 == 3) {
        continue;
      }
      Point3D point;
      point.xyz = RandomVector<3>(uniform, rng);
      point.color << 0, 128, 255;
      point.error = std::abs(uniform(rng));
      // Observed at this index in this image and some others.
      for (auto& [other_id, other] : model.images) {
        if (other.points2D.size() > idx &&
            other.points2D[idx].point3D_id == kInvalidPoint3DId &&
            (other_id == image_id || also_observed(rng))) {
          other.points2D[idx].point3D_id = next_id;
          point.track.push_back({other_id, static_cast<point2D_t>(idx)});
        }
      }
      model.points3D[next_id++] = point;
    }
  }
  return model;
}

}  // namespace test
}  // namespace colmap_irav4
