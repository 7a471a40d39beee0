#include "colmap_irav4/eval/strecha_gt.h"

#include <fstream>

#include <gtest/gtest.h>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/util/error.h"
#include "tests/test_utils/data.h"
#include "tests/test_utils/database_test_utils.h"

namespace colmap_irav4 {
namespace {

const std::string kDataDir = DataDir();

TEST(StrechaGroundTruth, ReadsFountainCameras) {
  COLMAP_IRAV4_REQUIRE_DATA("strecha/fountain-P11/gt_cameras");
  const auto cameras =
      ReadStrechaGroundTruth(kDataDir + "/strecha/fountain-P11/gt_cameras");
  ASSERT_EQ(cameras.size(), 11u);
  ASSERT_TRUE(cameras.count("0000.jpg"));
  const StrechaCamera& camera = cameras.at("0000.jpg");
  EXPECT_NEAR(camera.K(0, 0), 2759.48, 1e-9);
  EXPECT_NEAR(camera.K(1, 2), 1006.81, 1e-9);
  EXPECT_EQ(camera.width, 3072);
  EXPECT_EQ(camera.height, 2048);
  // The file's R is camera-to-world: its first row is (0.450927 -0.0945642
  // -0.887537), i.e. the first column of cam_from_world.
  const Eigen::Matrix3d R = camera.cam_from_world.rotation.toRotationMatrix();
  EXPECT_NEAR(R(0, 0), 0.450927, 1e-5);
  EXPECT_NEAR(R(1, 0), -0.0945642, 1e-5);
  EXPECT_NEAR(R(2, 0), -0.887537, 1e-5);
  EXPECT_NEAR(R(0, 1), -0.892535, 1e-5);
  // The centre maps to the origin of the camera frame.
  EXPECT_LT((camera.cam_from_world * camera.center).norm(), 1e-9);
  EXPECT_NEAR(camera.center.x(), -7.28137, 1e-9);
  // Every camera looks at the scene: the centroid of the other centres' scene
  // (the fountain) is in front, i.e. the cameras face roughly the same point.
  Eigen::Vector3d mean_view = Eigen::Vector3d::Zero();
  for (const auto& [name, c] : cameras) {
    mean_view += c.cam_from_world.rotation.inverse() * Eigen::Vector3d::UnitZ();
  }
  mean_view.normalize();
  for (const auto& [name, c] : cameras) {
    const Eigen::Vector3d view =
        c.cam_from_world.rotation.inverse() * Eigen::Vector3d::UnitZ();
    EXPECT_GT(view.dot(mean_view), 0.5) << name;
  }
}

TEST(StrechaGroundTruth, WindowsLineEndsAndErrors) {
  test::TempDir dir;
  const std::string good = dir.File("a.jpg.camera");
  std::ofstream(good) << "100 0 50 \r\n0 100 40 \r\n0 0 1 \r\n0 0 0\r\n"
                         "0 -1 0 \r\n1 0 0 \r\n0 0 1 \r\n1 2 3 \r\n640 480\r\n";
  const StrechaCamera camera = ReadStrechaCamera(good);
  EXPECT_EQ(camera.width, 640);
  EXPECT_EQ(camera.height, 480);
  Eigen::Matrix3d world_from_cam;
  world_from_cam << 0, -1, 0, 1, 0, 0, 0, 0, 1;
  EXPECT_LT(
      AngularDistanceDeg(camera.cam_from_world.rotation.toRotationMatrix(),
                         world_from_cam.transpose()),
      1e-9);
  EXPECT_LT((camera.cam_from_world.translation +
             world_from_cam.transpose() * Eigen::Vector3d(1, 2, 3))
                .norm(),
            1e-12);
  const std::string truncated = dir.File("b.jpg.camera");
  std::ofstream(truncated) << "100 0 50\n0 100 40\n";
  EXPECT_THROW(ReadStrechaCamera(truncated), InputError);
  const std::string not_rotation = dir.File("c.jpg.camera");
  std::ofstream(not_rotation)
      << "1 0 0 0 1 0 0 0 1 0 0 0 2 0 0 0 1 0 0 0 1 0 0 0 10 10\n";
  try {
    ReadStrechaCamera(not_rotation);
    ADD_FAILURE();
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find(not_rotation), std::string::npos);
  }
  // Image sizes outside int's range (a fuzzer's find), fractional or zero.
  for (const std::string size : {"3072 2e45", "3072 20.5", "0 480", "nan 4"}) {
    const std::string bad_size = dir.File("d.jpg.camera");
    std::ofstream(bad_size)
        << "1 0 0 0 1 0 0 0 1 0 0 0 1 0 0 0 1 0 0 0 1 0 0 0 " << size << "\n";
    try {
      ReadStrechaCamera(bad_size);
      ADD_FAILURE() << size;
    } catch (const InputError& error) {
      EXPECT_NE(std::string(error.what()).find("W H"), std::string::npos)
          << size;
    }
  }
  const std::map<std::string, StrechaCamera> read = [&] {
    test::TempDir only_good;
    std::ofstream(only_good.File("x.jpg.camera"))
        << "100 0 50 0 100 40 0 0 1 0 0 0 1 0 0 0 1 0 0 0 1 0 0 0 10 10\n";
    std::ofstream(only_good.File("notes.txt")) << "ignored\n";
    return ReadStrechaGroundTruth(only_good.File(""));
  }();
  ASSERT_EQ(read.size(), 1u);
  EXPECT_TRUE(read.count("x.jpg"));
  EXPECT_THROW(ReadStrechaGroundTruth(dir.File("nope")), InputError);
}

}  // namespace
}  // namespace colmap_irav4
