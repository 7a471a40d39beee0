// Unit tests of the mapper's own glue: the rotation-consistency filter, the
// components of a pair list, point colours, options and the summary.

#include <filesystem>
#include <fstream>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/pipeline/global_mapper.h"
#include "colmap_irav4/pipeline/global_pipeline.h"
#include "colmap_irav4/scene/point_colors.h"
#include "colmap_irav4/scene/reconstruction_utils.h"
#include "colmap_irav4/util/error.h"
#include "tests/test_utils/database_test_utils.h"

namespace colmap_irav4 {
namespace {

ImagePairGeometry Pair(image_t a, image_t b, const Eigen::Matrix3d& R) {
  ImagePairGeometry pair;
  pair.image_id1 = a;
  pair.image_id2 = b;
  pair.R = R;
  pair.num_inliers = 100;
  return pair;
}

TEST(RotationFilter, DropsPairsDisagreeingWithAveragedRotations) {
  std::mt19937_64 rng(7);
  std::map<image_t, Eigen::Matrix3d> rotations;
  for (image_t id = 1; id <= 4; ++id) rotations[id] = RandomRotation(&rng);
  std::vector<ImagePairGeometry> pairs;
  for (image_t a = 1; a <= 4; ++a) {
    for (image_t b = a + 1; b <= 4; ++b) {
      // R_ab = R_b R_a^T, with 1 deg of noise on every pair ...
      pairs.push_back(Pair(a, b,
                           RandomRotationWithAngle(DegToRad(1.0), &rng) *
                               rotations[b] * rotations[a].transpose()));
    }
  }
  // ... and one wrong pair (10 deg off), one pair with an image without
  // rotation.
  pairs[2].R = RandomRotationWithAngle(DegToRad(10.0), &rng) * pairs[2].R;
  pairs.push_back(Pair(4, 5, Eigen::Matrix3d::Identity()));

  const std::vector<ImagePairGeometry> kept =
      FilterPairsByRotation(pairs, rotations, 5.0);
  ASSERT_EQ(kept.size(), 5u);
  for (const ImagePairGeometry& pair : kept) {
    EXPECT_FALSE(pair.image_id1 == pairs[2].image_id1 &&
                 pair.image_id2 == pairs[2].image_id2);
    EXPECT_NE(pair.image_id2, 5u);
  }
  // A threshold below the noise drops everything; 180 deg keeps all pairs
  // whose images have rotations.
  EXPECT_TRUE(FilterPairsByRotation(pairs, rotations, 0.5).empty());
  EXPECT_EQ(FilterPairsByRotation(pairs, rotations, 180.0).size(), 6u);
}

TEST(PairComponents, LargestFirstThenSmallestImageId) {
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  const std::vector<ImagePairGeometry> pairs = {
      Pair(10, 11, I), Pair(1, 2, I), Pair(20, 21, I), Pair(21, 22, I),
      Pair(22, 20, I)};
  const std::vector<std::vector<image_t>> components = PairComponents(pairs);
  ASSERT_EQ(components.size(), 3u);
  EXPECT_EQ(components[0], (std::vector<image_t>{20, 21, 22}));
  EXPECT_EQ(components[1], (std::vector<image_t>{1, 2}));
  EXPECT_EQ(components[2], (std::vector<image_t>{10, 11}));
  EXPECT_TRUE(PairComponents({}).empty());
}

TEST(PointColors, MeanOfTheObservedPixelsGreyWithoutImage) {
  test::TempDir temp;
  // Two 8x8 images of one colour each (BGR on disk).
  cv::imwrite(temp.File("a.png"),
              cv::Mat(8, 8, CV_8UC3, cv::Scalar(0, 0, 200)));
  cv::imwrite(temp.File("b.png"),
              cv::Mat(8, 8, CV_8UC3, cv::Scalar(100, 0, 0)));
  Reconstruction model;
  model.cameras[1].camera_id = 1;
  // The images' size (another size would be another image: not used).
  model.cameras[1].width = 8;
  model.cameras[1].height = 8;
  const std::vector<std::string> names = {"a.png", "b.png", "missing.png"};
  for (image_t id = 1; id <= 3; ++id) {
    Image& image = model.images[id];
    image.image_id = id;
    image.camera_id = 1;
    image.name = names[id - 1];
    image.points2D.resize(2);
    image.points2D[0].xy = Eigen::Vector2d(3.5, 4.5);
    image.points2D[1].xy = Eigen::Vector2d(2.0, 2.0);
  }
  // Seen in a and b: mean of red 200 and blue 100.
  const point3D_t both =
      AddPoint3D(Eigen::Vector3d::Zero(), {{1, 0}, {2, 0}}, &model);
  // Seen only in a and the missing image.
  const point3D_t a_only =
      AddPoint3D(Eigen::Vector3d::Zero(), {{1, 1}, {3, 1}}, &model);
  // Seen only in the missing image (twice): grey.
  const point3D_t none = AddPoint3D(Eigen::Vector3d::Zero(), {{3, 0}}, &model);
  for (const int downscale : {1, 2}) {
    SCOPED_TRACE(downscale);
    ASSERT_EQ(ColorPointsFromImages(temp.File(""), &model, downscale), 1);
    using Rgb = Eigen::Matrix<int, 3, 1>;
    EXPECT_EQ(model.points3D.at(both).color.cast<int>(), Rgb(100, 0, 50));
    EXPECT_EQ(model.points3D.at(a_only).color.cast<int>(), Rgb(200, 0, 0));
    EXPECT_EQ(model.points3D.at(none).color.cast<int>(), Rgb(128, 128, 128));
  }
}

// Two views of the image file `name` (`width` x `height`) with keypoints at
// `xy` (no points).
Reconstruction TwoViewsOf(const std::string& name, int width, int height,
                          const std::vector<Eigen::Vector2d>& xy) {
  Reconstruction model;
  model.cameras[1].camera_id = 1;
  model.cameras[1].width = width;
  model.cameras[1].height = height;
  for (image_t id = 1; id <= 2; ++id) {
    Image& view = model.images[id];
    view.image_id = id;
    view.camera_id = 1;
    view.name = name;
    view.points2D.resize(xy.size());
    for (size_t k = 0; k < xy.size(); ++k) view.points2D[k].xy = xy[k];
  }
  return model;
}

TEST(PointColors, SampledAtTheKeypointWithPixelCentresAtHalfIntegers) {
  test::TempDir temp;
  // Red = 10 * column.
  cv::Mat image(16, 16, CV_8UC3, cv::Scalar(0, 0, 0));
  for (int col = 0; col < 16; ++col) {
    image.col(col).setTo(cv::Scalar(0, 0, 10 * col));
  }
  cv::imwrite(temp.File("g.png"), image);
  Reconstruction model =
      TwoViewsOf("g.png", 16, 16,
                 {Eigen::Vector2d(5.5, 2.5),  // centre of column 5
                  Eigen::Vector2d(5.0, 2.5),  // between 4 and 5
                  // Beyond int's range (a hostile database's keypoint):
                  // not sampled (undefined behaviour once), grey.
                  Eigen::Vector2d(3e38, 2.5)});
  const point3D_t centre =
      AddPoint3D(Eigen::Vector3d::Zero(), {{1, 0}, {2, 0}}, &model);
  const point3D_t between =
      AddPoint3D(Eigen::Vector3d::Zero(), {{1, 1}, {2, 1}}, &model);
  const point3D_t far =
      AddPoint3D(Eigen::Vector3d::Zero(), {{1, 2}, {2, 2}}, &model);
  ASSERT_EQ(ColorPointsFromImages(temp.File(""), &model, 1), 0);
  EXPECT_EQ(static_cast<int>(model.points3D.at(centre).color[0]), 50);
  EXPECT_EQ(static_cast<int>(model.points3D.at(between).color[0]), 45);
  EXPECT_EQ(static_cast<int>(model.points3D.at(far).color[0]), 128);
}

// A phone's portrait photo is stored landscape with an EXIF orientation tag
// ("Rotate 90 CW"); COLMAP's keypoints are in the stored pixels, so the
// colours must be sampled there, not in the turned image.
TEST(PointColors, SampledInTheStoredPixelsWhateverTheExifOrientation) {
  test::TempDir temp;
  // 32 x 16, left half red, right half blue (BGR).
  cv::Mat stored(16, 32, CV_8UC3, cv::Scalar(0, 0, 255));
  stored.colRange(16, 32).setTo(cv::Scalar(255, 0, 0));
  std::vector<uchar> jpeg;
  ASSERT_TRUE(
      cv::imencode(".jpg", stored, jpeg, {cv::IMWRITE_JPEG_QUALITY, 100}));
  // An APP1 Exif segment right after the SOI marker: a little-endian TIFF
  // header and one IFD entry, Orientation (0x0112, SHORT) = 6.
  const std::vector<uchar> app1 = {
      0xFF, 0xE1, 0x00, 0x22, 'E',  'x',  'i',  'f',
      0,    0,                                         // marker, length 34
      'I',  'I',  0x2A, 0x00, 0x08, 0x00, 0x00, 0x00,  // TIFF header
      0x01, 0x00,                                      // one entry
      0x12, 0x01, 0x03, 0x00, 0x01, 0x00, 0x00, 0x00,  // tag, type, count
      0x06, 0x00, 0x00, 0x00,                          // value 6
      0x00, 0x00, 0x00, 0x00};                         // no next IFD
  jpeg.insert(jpeg.begin() + 2, app1.begin(), app1.end());
  {
    std::ofstream file(temp.File("portrait.jpg"), std::ios::binary);
    file.write(reinterpret_cast<const char*>(jpeg.data()), jpeg.size());
  }
  // OpenCV turns it by default: the test image does carry the tag.
  ASSERT_EQ(cv::imread(temp.File("portrait.jpg")).cols, 16);
  Reconstruction model =
      TwoViewsOf("portrait.jpg", 32, 16,
                 {Eigen::Vector2d(28.5, 8.5),    // right half: blue
                  Eigen::Vector2d(4.5, 12.5)});  // left half: red
  const point3D_t blue =
      AddPoint3D(Eigen::Vector3d::Zero(), {{1, 0}, {2, 0}}, &model);
  const point3D_t red =
      AddPoint3D(Eigen::Vector3d::Zero(), {{1, 1}, {2, 1}}, &model);
  ASSERT_EQ(ColorPointsFromImages(temp.File(""), &model, 1), 0);
  const auto& b = model.points3D.at(blue).color;
  const auto& r = model.points3D.at(red).color;
  EXPECT_GT(b[2], 200);
  EXPECT_LT(b[0], 50);
  EXPECT_GT(r[0], 200);
  EXPECT_LT(r[2], 50);
}

TEST(GlobalMapperOptions, DefaultsAreValidAndCheckNamesTheOption) {
  GlobalMapperOptions options;
  EXPECT_NO_THROW(options.Check());
  EXPECT_EQ(options.rotation_method, DefaultRotationMethod());
  EXPECT_EQ(options.rotation_method, "irav4");
  EXPECT_TRUE(options.bundle_adjustment.refine_focal_length);
  EXPECT_FALSE(options.bundle_adjustment.refine_principal_point);
  EXPECT_TRUE(options.bundle_adjustment.refine_extra_params);
  options.min_model_size = 2;
  try {
    options.Check();
    FAIL() << "expected InputError";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("--Mapper.min_model_size"),
              std::string::npos);
  }
  options = GlobalMapperOptions();
  // An unknown method is not representable; its name is refused.
  EXPECT_FALSE(ParseEnum("magic", &options.positioning_method));
  options = GlobalMapperOptions();
  options.rotation_filter.max_rotation_error_deg = 0;
  EXPECT_THROW(options.Check(), InputError);
  options = GlobalMapperOptions();
  options.weak_part_min_shared_points = -1;
  try {
    options.Check();
    FAIL() << "expected InputError";
  } catch (const InputError& error) {
    EXPECT_NE(
        std::string(error.what()).find("--Mapper.weak_part_min_shared_points"),
        std::string::npos);
  }
  options = GlobalMapperOptions();
  options.weak_image_min_pair_triangles = -1;
  try {
    options.Check();
    FAIL() << "expected InputError";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what())
                  .find("--Mapper.weak_image_min_pair_triangles"),
              std::string::npos);
  }
}

TEST(GlobalMapperSummary, JsonHasTheFiguresAndEscapesStrings) {
  GlobalMapperSummary summary;
  summary.database_path = "a \"quoted\" path";
  summary.rotation_method = "irav4";
  StageReport stage("view graph");
  stage.seconds = 1.5;
  stage.figures = {{"pairs kept", 55}};
  summary.stages.push_back(stage);
  ComponentReport component;
  component.num_registered_images = 11;
  component.mean_reprojection_error_per_observation = 0.4;
  component.mean_reprojection_error_per_point = 0.35;
  summary.components.push_back(component);
  const std::string json = summary.ToJson();
  EXPECT_NE(json.find("\"a \\\"quoted\\\" path\""), std::string::npos) << json;
  EXPECT_NE(json.find("\"pairs kept\": 55"), std::string::npos) << json;
  EXPECT_NE(json.find("\"num_registered_images\": 11"), std::string::npos);
  // One set of keys: no unqualified mean_reprojection_error beside them.
  EXPECT_EQ(json.find("\"mean_reprojection_error\""), std::string::npos);
  EXPECT_NE(json.find("\"mean_reprojection_error_per_observation\": 0.4"),
            std::string::npos);
  EXPECT_NE(json.find("\"mean_reprojection_error_per_point\": 0.35"),
            std::string::npos);
}

TEST(ReprojectionError, PerPointIsTheMeanOfTheTrackMeans) {
  Reconstruction model;
  model.cameras[1].camera_id = 1;
  for (image_t id = 1; id <= 3; ++id) {
    model.images[id].image_id = id;
    model.images[id].camera_id = 1;
    model.images[id].points2D.resize(2);
  }
  const point3D_t a =
      AddPoint3D(Eigen::Vector3d::Zero(), {{1, 0}, {2, 0}}, &model);
  const point3D_t b =
      AddPoint3D(Eigen::Vector3d::Zero(), {{1, 1}, {2, 1}, {3, 1}}, &model);
  model.points3D.at(a).error = 1.0;
  model.points3D.at(b).error = 0.5;
  // Per point: (1 + 0.5) / 2; per observation it would be (2 + 1.5) / 5.
  EXPECT_DOUBLE_EQ(MeanPointReprojectionError(model), 0.75);
  EXPECT_DOUBLE_EQ(MeanPointReprojectionError(Reconstruction()), 0.0);
}

}  // namespace
}  // namespace colmap_irav4
