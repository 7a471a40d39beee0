#include "colmap_irav4/io/database.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/io/database_writer.h"
#include "colmap_irav4/io/pose_priors.h"
#include "colmap_irav4/scene/camera_models.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/view_graph/view_graph_builder.h"
#include "tests/test_utils/data.h"
#include "tests/test_utils/database_test_utils.h"
#include "tests/test_utils/record.h"
#include "tests/test_utils/synthetic_two_view.h"

namespace colmap_irav4 {
namespace {

using test::HashFile;
using test::SqliteWriter;
using test::TempDir;
using test::ToBlob;
using Value = SqliteWriter::Value;

const std::string kDataDir = DataDir();
const std::string kFountain = kDataDir + "/strecha/fountain-P11/database.db";
const std::string kHerzJesus = kDataDir + "/strecha/Herz-Jesus-P8/database.db";
const std::string kMaupertuis =
    kDataDir + "/colmap_samples/maupertuis_colmap37/database.db";
const std::string kT265 = kDataDir + "/colmap_samples/t265_fisheye/database.db";

// Median Sampson error in pixels of x2^T F x1 = 0 over a pair's inliers, with
// the keypoints taken in the given order.
double MedianFundamentalErrorPx(const TwoViewGeometry& geometry,
                                const FeatureKeypoints& keypoints1,
                                const FeatureKeypoints& keypoints2) {
  std::vector<double> errors;
  for (const FeatureMatch& match : geometry.inlier_matches) {
    const Eigen::Vector2d x1 = keypoints1[match.point2D_idx1].cast<double>();
    const Eigen::Vector2d x2 = keypoints2[match.point2D_idx2].cast<double>();
    errors.push_back(std::sqrt(SampsonErrorSquared(geometry.F, x1, x2)));
  }
  std::nth_element(errors.begin(), errors.begin() + errors.size() / 2,
                   errors.end());
  return errors[errors.size() / 2];
}

TEST(Database, ReadsColmap38StrechaDatabase) {
  COLMAP_IRAV4_REQUIRE_DATA("strecha/fountain-P11/database.db");
  const uint64_t hash = HashFile(kFountain);
  {
    Database database(kFountain);
    EXPECT_TRUE(database.Schema().has_two_view_pose);
    EXPECT_TRUE(database.Schema().has_image_prior_columns);
    EXPECT_FALSE(database.Schema().has_pose_priors_table);
    EXPECT_EQ(database.Schema().Description(), "COLMAP 3.8/3.9");
    const std::vector<Camera> cameras = database.ReadAllCameras();
    ASSERT_EQ(cameras.size(), 1u);
    EXPECT_EQ(CameraModelIdToName(cameras[0].model_id), "PINHOLE");
    EXPECT_EQ(cameras[0].width, 3072u);
    EXPECT_EQ(cameras[0].height, 2048u);
    EXPECT_NEAR(cameras[0].params[0], 2759.48, 1e-6);  // K.txt's fx
    EXPECT_NEAR(cameras[0].params[3], 1006.81, 1e-6);  // cy
    EXPECT_TRUE(cameras[0].has_prior_focal_length);
    const std::vector<DatabaseImage> images = database.ReadAllImages();
    ASSERT_EQ(images.size(), 11u);
    // Ids are not in name order in this database (7 is 0007, 8 is 0006).
    EXPECT_EQ(images[6].image_id, 7u);
    EXPECT_EQ(images[6].name, "0007.jpg");
    EXPECT_EQ(images[7].name, "0006.jpg");
    EXPECT_FALSE(images[0].has_prior_rotation);
    const FeatureKeypoints keypoints = database.ReadKeypoints(1);
    EXPECT_EQ(keypoints.size(), 10496u);  // 6 columns in the blob; x, y kept
    for (const Eigen::Vector2f& xy : keypoints) {
      ASSERT_TRUE(xy.x() >= 0 && xy.x() <= 3072 && xy.y() >= 0 &&
                  xy.y() <= 2048);
    }
    // Scales from the affine shapes: SIFT's, from about 1.8 px upwards.
    std::vector<float> scales;
    EXPECT_EQ(database.ReadKeypoints(1, &scales), keypoints);
    ASSERT_EQ(scales.size(), keypoints.size());
    EXPECT_GT(*std::min_element(scales.begin(), scales.end()), 1.5f);
    EXPECT_LT(*std::min_element(scales.begin(), scales.end()), 2.5f);
    EXPECT_GT(*std::max_element(scales.begin(), scales.end()), 8.0f);
    const std::vector<TwoViewGeometry> geometries =
        database.ReadAllTwoViewGeometries();
    ASSERT_EQ(geometries.size(), 55u);
    std::map<int, int> configs;
    for (const TwoViewGeometry& geometry : geometries) {
      ++configs[geometry.config];
      EXPECT_LT(geometry.image_id1, geometry.image_id2);
      // COLMAP 3.8 leaves qvec/tvec zero: no stored pose.
      EXPECT_FALSE(geometry.has_pose);
    }
    EXPECT_EQ(configs[TwoViewGeometry::CALIBRATED], 41);
    EXPECT_EQ(configs[TwoViewGeometry::UNCALIBRATED], 1);
    EXPECT_EQ(configs[TwoViewGeometry::PLANAR_OR_PANORAMIC], 13);
    EXPECT_EQ(geometries[0].inlier_matches.size(), 5131u);

    // F's convention: x2^T F x1 = 0 with x1 in the smaller id's image; the
    // other order does not fit, which tells the orientation apart.
    const TwoViewGeometry& g = geometries[0];
    const FeatureKeypoints k1 = database.ReadKeypoints(g.image_id1);
    const FeatureKeypoints k2 = database.ReadKeypoints(g.image_id2);
    EXPECT_LT(MedianFundamentalErrorPx(g, k1, k2), 1.0);
    TwoViewGeometry transposed = g;
    transposed.F.transposeInPlace();
    EXPECT_GT(MedianFundamentalErrorPx(transposed, k1, k2), 10.0);

    // Requesting the pair the other way round inverts the geometry.
    TwoViewGeometry forward, backward;
    ASSERT_TRUE(
        database.ReadTwoViewGeometry(g.image_id1, g.image_id2, &forward));
    ASSERT_TRUE(
        database.ReadTwoViewGeometry(g.image_id2, g.image_id1, &backward));
    EXPECT_EQ(backward.image_id1, g.image_id2);
    EXPECT_EQ(backward.inlier_matches[10].point2D_idx1,
              forward.inlier_matches[10].point2D_idx2);
    EXPECT_LT((backward.F - forward.F.transpose()).norm(), 1e-12);
    EXPECT_LT(MedianFundamentalErrorPx(backward, k2, k1), 1.0);
    TwoViewGeometry absent;
    EXPECT_FALSE(database.ReadTwoViewGeometry(1, 1000, &absent));
    // Raw matches are oriented the same way.
    const FeatureMatches raw12 = database.ReadMatches(1, 2);
    const FeatureMatches raw21 = database.ReadMatches(2, 1);
    ASSERT_FALSE(raw12.empty());
    ASSERT_EQ(raw12.size(), raw21.size());
    EXPECT_EQ(raw12[5].point2D_idx1, raw21[5].point2D_idx2);
    EXPECT_EQ(database.ReadNumMatches().at(ImagePairToPairId(1, 2)),
              static_cast<int>(raw12.size()));
  }
  // Read-only: the file is unchanged.
  EXPECT_EQ(HashFile(kFountain), hash);
}

TEST(Database, KeypointScaleFromEachLayout) {
  const float two[] = {10, 20};
  EXPECT_EQ(KeypointScale(two, 2), 0.0f);
  const float four[] = {10, 20, 3.5f, 0.7f};  // x, y, scale, orientation
  EXPECT_EQ(KeypointScale(four, 4), 3.5f);
  // x, y, then a 2x2 shape: a rotation by 30 deg scaled by 2 in x and 4 in y
  // has columns of length 2 and 4.
  const float c = std::cos(0.5236f), s = std::sin(0.5236f);
  const float six[] = {10, 20, 2 * c, -4 * s, 2 * s, 4 * c};
  EXPECT_NEAR(KeypointScale(six, 6), 3.0f, 1e-5f);
}

TEST(Database, ReadsOlderSchemaWithoutPoseColumns) {
  COLMAP_IRAV4_REQUIRE_DATA("colmap_samples/maupertuis_colmap37");
  const uint64_t hash = HashFile(kMaupertuis);
  const DatabaseContents contents = ReadDatabase(kMaupertuis);
  EXPECT_FALSE(contents.schema.has_two_view_pose);
  EXPECT_EQ(contents.schema.Description(), "COLMAP <= 3.7");
  ASSERT_EQ(contents.cameras.size(), 1u);
  EXPECT_EQ(CameraModelIdToName(contents.cameras.at(1).model_id),
            "SIMPLE_PINHOLE");
  EXPECT_EQ(contents.images.size(), 4u);
  EXPECT_EQ(contents.images.at(1).name, "00.jpg");
  EXPECT_EQ(contents.keypoints.at(1).size(), 6424u);
  ASSERT_EQ(contents.two_view_geometries.size(), 6u);
  for (const TwoViewGeometry& geometry : contents.two_view_geometries) {
    EXPECT_EQ(geometry.config, TwoViewGeometry::UNCALIBRATED);
    EXPECT_FALSE(geometry.has_pose);
  }
  EXPECT_EQ(HashFile(kMaupertuis), hash);
}

// Relative rotations of the older-schema database against its reference model
// (reference_model, COLMAP's text format).
TEST(Database, OlderSchemaRelativePosesMatchReferenceModel) {
  COLMAP_IRAV4_REQUIRE_DATA("colmap_samples/maupertuis_colmap37");
  const std::map<std::string, Eigen::Matrix3d> reference =
      test::ModelRotationsByName(
          kDataDir + "/colmap_samples/maupertuis_colmap37/reference_model");
  ASSERT_EQ(reference.size(), 4u);
  DatabaseContents contents = ReadDatabase(kMaupertuis);
  // The database holds COLMAP's initial focal guess (1.2 x 1919 px); F -> E
  // needs the true intrinsics: take the reference model's refined camera.
  EXPECT_NEAR(contents.cameras.at(1).params[0], 1.2 * 1919, 1e-9);
  const Camera reference_camera =
      ReadReconstruction(kDataDir +
                         "/colmap_samples/maupertuis_colmap37/reference_model")
          .cameras.at(1);
  ASSERT_EQ(CameraModelIdToName(reference_camera.model_id), "SIMPLE_PINHOLE");
  contents.cameras.at(1).params = reference_camera.params;
  ViewGraphSummary summary;
  const ViewGraph view_graph =
      BuildViewGraph(contents, ViewGraphBuilderOptions(), &summary);
  ASSERT_EQ(view_graph.pairs.size(), 6u);
  for (const ImagePairGeometry& pair : view_graph.pairs) {
    const Eigen::Matrix3d R1 =
        reference.at(view_graph.image_names.at(pair.image_id1));
    const Eigen::Matrix3d R2 =
        reference.at(view_graph.image_names.at(pair.image_id2));
    const double error = AngularDistanceDeg(pair.R, R2 * R1.transpose());
    ::colmap_irav4::test::RecordFiguresF(
        "maupertuis %s-%s: relative rotation error %.3f deg (%d inliers)\n",
        view_graph.image_names.at(pair.image_id1).c_str(),
        view_graph.image_names.at(pair.image_id2).c_str(), error,
        pair.num_inliers);
    EXPECT_LT(error, 1.0);
  }
}

TEST(Database, FisheyeCamerasWithoutMatchesGiveEmptyGraph) {
  COLMAP_IRAV4_REQUIRE_DATA("colmap_samples/t265_fisheye/database.db");
  const uint64_t hash = HashFile(kT265);
  const DatabaseContents contents = ReadDatabase(kT265);
  ASSERT_EQ(contents.cameras.size(), 2u);
  for (const auto& [camera_id, camera] : contents.cameras) {
    EXPECT_EQ(CameraModelIdToName(camera.model_id), "OPENCV_FISHEYE");
    EXPECT_EQ(camera.params.size(), 8u);
  }
  EXPECT_NEAR(contents.cameras.at(1).params[0], 284.468, 1e-3);  // cameras.txt
  EXPECT_NEAR(contents.cameras.at(2).params[2], 417.246, 1e-3);
  EXPECT_EQ(contents.images.size(), 6u);
  EXPECT_TRUE(contents.images.at(1).has_prior_rotation);
  EXPECT_TRUE(contents.images.at(1).has_prior_position);
  EXPECT_NEAR(contents.images.at(1).prior_tvec.x(), 2.71094022818609, 1e-12);
  EXPECT_TRUE(contents.two_view_geometries.empty());
  EXPECT_TRUE(contents.keypoints.at(1).empty());
  ViewGraphSummary summary;
  const ViewGraph view_graph =
      BuildViewGraph(contents, ViewGraphBuilderOptions(), &summary);
  EXPECT_TRUE(view_graph.pairs.empty());
  EXPECT_TRUE(view_graph.image_names.empty());
  EXPECT_EQ(summary.num_images, 6);
  EXPECT_EQ(summary.num_components, 0);
  EXPECT_EQ(summary.num_images_in_component, 0);
  EXPECT_EQ(HashFile(kT265), hash);
}

TEST(Database, ImmutableOpenLeavesWalDatabaseAndDirectoryUntouched) {
  COLMAP_IRAV4_REQUIRE_DATA("strecha/Herz-Jesus-P8/database.db");
  // Herz-Jesus is in WAL mode without a -shm file, in a read-only directory:
  // only an immutable open can read it.
  const DatabaseContents contents = ReadDatabase(kHerzJesus);
  EXPECT_EQ(contents.two_view_geometries.size(), 28u);
  // A WAL-mode database of our own: reading creates no -wal / -shm file.
  TempDir dir;
  const std::string path = dir.File("wal.db");
  {
    SqliteWriter writer(path);
    writer.Exec(Colmap38Schema());
    writer.Exec("PRAGMA journal_mode=WAL;");
  }
  ASSERT_FALSE(std::filesystem::exists(path + "-wal"));
  const uint64_t hash = HashFile(path);
  const auto mtime = std::filesystem::last_write_time(path);
  const DatabaseContents empty = ReadDatabase(path);
  EXPECT_TRUE(empty.images.empty());
  EXPECT_FALSE(std::filesystem::exists(path + "-wal"));
  EXPECT_FALSE(std::filesystem::exists(path + "-shm"));
  EXPECT_EQ(HashFile(path), hash);
  EXPECT_EQ(std::filesystem::last_write_time(path), mtime);
}

// Writes a synthetic pair (image ids 1, 2, camera 1 PINHOLE) into an open
// database of either schema; returns the pair.
test::SyntheticPair WriteSyntheticPair(SqliteWriter* writer, bool colmap4,
                                       bool swap_names) {
  std::mt19937_64 rng(7);
  const Camera camera = test::MakeCamera(CameraModelNameToId("PINHOLE"));
  const Eigen::Matrix3d R = RandomRotationWithAngle(DegToRad(12), &rng);
  test::SyntheticPair pair = test::MakeSyntheticPair(
      camera, camera, R, Eigen::Vector3d(0.9, -0.2, 0.3), 120, 0.2, false,
      &rng);
  writer->Run("INSERT INTO cameras VALUES (1, 1, 1600, 1200, ?, 1)",
              {ToBlob(camera.params)});
  if (colmap4) {
    writer->Exec("INSERT INTO rigs VALUES (1, 1, 0);");
    writer->Exec("INSERT INTO frames VALUES (1, 1), (2, 1);");
    writer->Exec("INSERT INTO frame_data VALUES (1, 1, 1, 0), (2, 2, 1, 0);");
    writer->Exec(std::string("INSERT INTO images VALUES (1, '") +
                 (swap_names ? "b.jpg" : "a.jpg") + "', 1), (2, '" +
                 (swap_names ? "a.jpg" : "b.jpg") + "', 1);");
    writer->Run("INSERT INTO pose_priors VALUES (1, 2, 1, 0, ?, NULL, NULL, 1)",
                {ToBlob(std::vector<double>{4.0, 5.0, 6.0})});
  } else {
    writer->Exec(
        "INSERT INTO images VALUES (1, 'a.jpg', 1, NULL, NULL, NULL, NULL, "
        "NULL, NULL, NULL),"
        " (2, 'b.jpg', 1, 1, 0, 0, 0, 1, 2, 3);");
  }
  for (int image_id = 1; image_id <= 2; ++image_id) {
    const FeatureKeypoints& keypoints =
        image_id == 1 ? pair.keypoints1 : pair.keypoints2;
    // 4 columns (x, y, scale, orientation) as COLMAP < 3.0 wrote them.
    std::vector<float> data;
    for (const Eigen::Vector2f& xy : keypoints) {
      data.insert(data.end(), {xy.x(), xy.y(), 2.0f, 0.5f});
    }
    writer->Run(
        "INSERT INTO keypoints VALUES (?, ?, 4, ?)",
        {image_id, static_cast<int64_t>(keypoints.size()), ToBlob(data)});
  }
  std::vector<uint32_t> matches;
  for (const FeatureMatch& m : pair.geometry.inlier_matches) {
    matches.push_back(m.point2D_idx1);
    matches.push_back(m.point2D_idx2);
  }
  auto row_major = [](const Eigen::Matrix3d& M) {
    std::vector<double> values;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) values.push_back(M(r, c));
    return ToBlob(values);
  };
  writer->Run(
      "INSERT INTO two_view_geometries VALUES (?, ?, 2, ?, 2, ?, ?, ?, ?, ?)",
      {static_cast<int64_t>(ImagePairToPairId(1, 2)),
       static_cast<int64_t>(pair.geometry.inlier_matches.size()),
       ToBlob(matches), row_major(pair.geometry.F), row_major(pair.geometry.E),
       row_major(pair.geometry.H), ToBlob(std::vector<double>{0, 0, 0, 0}),
       ToBlob(std::vector<double>{0, 0, 0})});
  writer->Run("INSERT INTO matches VALUES (?, ?, 2, ?)",
              {static_cast<int64_t>(ImagePairToPairId(1, 2)),
               static_cast<int64_t>(pair.geometry.inlier_matches.size()),
               ToBlob(matches)});
  return pair;
}

TEST(Database, ReadsSyntheticColmap38Database) {
  TempDir dir;
  const std::string path = dir.File("colmap38.db");
  test::SyntheticPair pair;
  {
    SqliteWriter writer(path);
    writer.Exec(Colmap38Schema());
    pair = WriteSyntheticPair(&writer, false, false);
  }
  const DatabaseContents contents = ReadDatabase(path);
  EXPECT_FALSE(contents.images.at(1).has_prior_rotation);
  EXPECT_TRUE(contents.images.at(2).has_prior_rotation);
  EXPECT_TRUE(contents.images.at(2).has_prior_position);
  EXPECT_EQ(contents.images.at(2).prior_tvec, Eigen::Vector3d(1, 2, 3));
  ASSERT_EQ(contents.keypoints.at(2).size(), pair.keypoints2.size());
  EXPECT_EQ(contents.keypoints.at(2)[17], pair.keypoints2[17]);
  ASSERT_EQ(contents.two_view_geometries.size(), 1u);
  const TwoViewGeometry& geometry = contents.two_view_geometries[0];
  EXPECT_LT((geometry.E - pair.geometry.E).norm(), 1e-15);
  EXPECT_LT((geometry.H - pair.geometry.H).norm(), 1e-12);
  EXPECT_FALSE(geometry.has_pose);
  ViewGraphSummary summary;
  const ViewGraph view_graph =
      BuildViewGraph(contents, ViewGraphBuilderOptions(), &summary);
  ASSERT_EQ(view_graph.pairs.size(), 1u);
  EXPECT_LT(AngularDistanceDeg(view_graph.pairs[0].R, pair.R), 0.1);
}

TEST(Database, ReadsSyntheticColmap4Database) {
  for (const bool swap_names : {false, true}) {
    TempDir dir;
    const std::string path = dir.File("colmap4.db");
    test::SyntheticPair pair;
    {
      SqliteWriter writer(path);
      writer.Exec(test::Colmap4Schema());
      pair = WriteSyntheticPair(&writer, true, swap_names);
    }
    const uint64_t hash = HashFile(path);
    const DatabaseContents contents = ReadDatabase(path);
    EXPECT_EQ(HashFile(path), hash);
    EXPECT_FALSE(contents.schema.has_image_prior_columns);
    EXPECT_TRUE(contents.schema.has_pose_priors_table);
    EXPECT_TRUE(contents.schema.has_rigs_table);
    EXPECT_TRUE(contents.schema.has_frames_table);
    EXPECT_TRUE(contents.schema.has_frame_data_table);
    EXPECT_EQ(contents.schema.Description(), "COLMAP 4.x");
    // The pose_priors table is read by io/pose_priors.h.
    const StoredPosePriors priors = ReadDatabasePosePriors(Database(path));
    ASSERT_EQ(priors.priors.size(), 1u);
    EXPECT_EQ(priors.priors[0].image_name, swap_names ? "a.jpg" : "b.jpg");
    EXPECT_EQ(priors.priors[0].position, Eigen::Vector3d(4, 5, 6));
    ViewGraphSummary summary;
    const ViewGraph view_graph =
        BuildViewGraph(contents, ViewGraphBuilderOptions(), &summary);
    ASSERT_EQ(view_graph.pairs.size(), 1u);
    // The pair stays in id order (1 -> 2) whatever the names: R =
    // cam2_from_cam1.
    EXPECT_EQ(view_graph.pairs[0].image_id1, 1u);
    EXPECT_EQ(view_graph.image_names.at(1), swap_names ? "b.jpg" : "a.jpg");
    EXPECT_LT(AngularDistanceDeg(view_graph.pairs[0].R, pair.R), 0.1);
    EXPECT_GT(AngularDistanceDeg(view_graph.pairs[0].R, pair.R.transpose()),
              10);
  }
}

TEST(Database, StoredPoseIsReadAndInvertedForSwappedRequests) {
  TempDir dir;
  const std::string path = dir.File("pose.db");
  test::SyntheticPair pair;
  {
    SqliteWriter writer(path);
    writer.Exec(Colmap38Schema());
    pair = WriteSyntheticPair(&writer, false, false);
    const Eigen::Vector4d q = RotationToQuaternion(pair.R);
    writer.Run("UPDATE two_view_geometries SET qvec = ?, tvec = ?",
               {ToBlob(std::vector<double>{q(0), q(1), q(2), q(3)}),
                ToBlob(std::vector<double>{pair.t(0), pair.t(1), pair.t(2)})});
  }
  Database database(path);
  TwoViewGeometry forward, backward;
  ASSERT_TRUE(database.ReadTwoViewGeometry(1, 2, &forward));
  ASSERT_TRUE(database.ReadTwoViewGeometry(2, 1, &backward));
  ASSERT_TRUE(forward.has_pose && backward.has_pose);
  EXPECT_LT(AngularDistanceDeg(QuaternionToRotation(forward.qvec), pair.R),
            1e-9);
  EXPECT_LT(AngularDistanceDeg(QuaternionToRotation(backward.qvec),
                               pair.R.transpose()),
            1e-9);
  EXPECT_LT((backward.tvec + pair.R.transpose() * pair.t).norm(), 1e-12);
  const RelativePose pose =
      EstimateRelativePose(forward, pair.camera1, pair.camera2, pair.keypoints1,
                           pair.keypoints2, RelativePoseOptions());
  EXPECT_EQ(pose.source, RelativePoseSource::kStored);
}

// Each bad database: InputError naming the file and the problem, file
// unchanged.
void ExpectBadDatabase(const std::string& path, const std::string& problem) {
  SCOPED_TRACE(problem);
  const bool existed = std::filesystem::exists(path);
  const uint64_t hash = HashFile(path);
  try {
    ReadDatabase(path);
    ADD_FAILURE() << "no error for " << path;
  } catch (const InputError& error) {
    const std::string message = error.what();
    ::colmap_irav4::test::RecordFiguresF("  %s\n", message.c_str());
    EXPECT_EQ(message.rfind(path + ": ", 0), 0u) << message;
    EXPECT_NE(message.find(problem), std::string::npos) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  }
  EXPECT_EQ(std::filesystem::exists(path), existed);
  if (existed) {
    EXPECT_EQ(HashFile(path), hash);
  }
  EXPECT_FALSE(std::filesystem::exists(path + "-journal"));
  EXPECT_FALSE(std::filesystem::exists(path + "-wal"));
}

TEST(Database, BadInputGivesOneClearError) {
  TempDir dir;
  ExpectBadDatabase(dir.File("missing.db"), "No such file");
  {
    std::ofstream(dir.File("text.db"))
        << "this is not a database, just some text\n";
    ExpectBadDatabase(dir.File("text.db"), "not an SQLite database");
  }
  auto make = [&](const std::string& name, const std::string& sql) {
    const std::string path = dir.File(name);
    SqliteWriter writer(path);
    writer.Exec(Colmap38Schema());
    WriteSyntheticPair(&writer, false, false);
    if (!sql.empty()) writer.Exec(sql);
    return path;
  };
  ExpectBadDatabase(make("no_table.db", "DROP TABLE two_view_geometries;"),
                    "table 'two_view_geometries' is missing");
  ExpectBadDatabase(
      make("bad_keypoints.db",
           "UPDATE keypoints SET rows = rows + 1 WHERE image_id = 2;"),
      "keypoints of image 2: data blob has");
  ExpectBadDatabase(
      make("bad_matches.db",
           "UPDATE two_view_geometries SET data = substr(data, 1, 40);"),
      "two_view_geometries of pair (1, 2): data blob has");
  ExpectBadDatabase(
      make("bad_F.db", "UPDATE two_view_geometries SET F = zeroblob(64);"),
      "F blob has 64 bytes");
  ExpectBadDatabase(
      make("bad_params.db", "UPDATE cameras SET params = zeroblob(24);"),
      "camera 1: params blob has 24 bytes, PINHOLE expects 4 doubles");
  ExpectBadDatabase(make("bad_model.db", "UPDATE cameras SET model = 42;"),
                    "camera 1: unknown camera model id 42");
  ExpectBadDatabase(
      make("bad_column.db",
           "ALTER TABLE images RENAME COLUMN camera_id TO cam_id;"),
      "table 'images' has no column 'camera_id'");
  ExpectBadDatabase(make("bad_index.db",
                         "UPDATE keypoints SET rows = 3, data = substr(data, "
                         "1, 48) WHERE image_id = 1;"),
                    "out of range");
  ExpectBadDatabase(make("bad_camera_ref.db",
                         "UPDATE images SET camera_id = 9 WHERE image_id = 2;"),
                    "refers to camera 9");
  // Row counts whose byte count overflows 64 bits (found by the fuzzer: UB
  // before the size check).
  ExpectBadDatabase(
      make("huge_keypoint_rows.db",
           "UPDATE keypoints SET rows = 4755801206503243780 WHERE image_id = "
           "2;"),
      "keypoints of image 2: row count 4755801206503243780 is larger than a "
      "blob can hold");
  ExpectBadDatabase(
      make("huge_match_rows.db",
           "UPDATE two_view_geometries SET rows = 4755801206503243780;"),
      "row count 4755801206503243780 is larger than a blob can hold");
  // A directory is not a database either.
  ExpectBadDatabase(dir.File(""), "not a regular file");
}

}  // namespace
}  // namespace colmap_irav4
