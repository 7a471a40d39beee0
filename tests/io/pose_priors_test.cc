#include "colmap_irav4/io/pose_priors.h"

#include <fstream>

#include <gtest/gtest.h>

#include "colmap_irav4/io/database_writer.h"
#include "colmap_irav4/util/error.h"
#include "tests/test_utils/database_test_utils.h"

namespace colmap_irav4 {
namespace {

using test::SqliteWriter;
using test::TempDir;
using test::ToBlob;
using Value = SqliteWriter::Value;

// COLMAP 3.11/3.12's CREATE TABLE (scene/database.cc).
constexpr const char* kColmap311PosePriors =
    "CREATE TABLE IF NOT EXISTS pose_priors"
    "   (image_id                   INTEGER  PRIMARY KEY  NOT NULL,"
    "    position                   BLOB,"
    "    coordinate_system          INTEGER               NOT NULL,"
    "    position_covariance        BLOB,"
    "FOREIGN KEY(image_id) REFERENCES images(image_id) ON DELETE CASCADE);";

// Three images a.jpg, b.jpg, c.jpg (ids 1-3) of camera 1, no keypoints.
void WriteImages(SqliteWriter* writer, bool colmap4) {
  writer->Run("INSERT INTO cameras VALUES (1, 1, 1600, 1200, ?, 0)",
              {ToBlob(std::vector<double>{1200, 1200, 800, 600})});
  if (colmap4) {
    writer->Exec(
        "INSERT INTO images VALUES (1, 'a.jpg', 1), (2, 'b.jpg', 1), "
        "(3, 'c.jpg', 1);");
  } else {
    writer->Exec(
        "INSERT INTO images(image_id, name, camera_id) VALUES (1, 'a.jpg', 1), "
        "(2, 'b.jpg', 1), (3, 'c.jpg', 1);");
  }
}

std::vector<char> Doubles(std::vector<double> values) { return ToBlob(values); }

TEST(PosePriors, ReadsColmap311Table) {
  TempDir dir;
  const std::string path = dir.File("colmap311.db");
  {
    SqliteWriter writer(path);
    writer.Exec(Colmap38Schema());
    writer.Exec(kColmap311PosePriors);
    WriteImages(&writer, false);
    // WGS84 with a covariance; NULL position; a prior of no image.
    writer.Run(
        "INSERT INTO pose_priors VALUES (1, ?, 0, ?)",
        {Doubles({47.1, 8.2, 400.0}), Doubles({4, 0, 0, 0, 4, 0, 0, 0, 9})});
    writer.Run("INSERT INTO pose_priors VALUES (2, NULL, 0, NULL)", {});
    writer.Run("INSERT INTO pose_priors VALUES (9, ?, 0, NULL)",
               {Doubles({47.1, 8.2, 400.0})});
  }
  const StoredPosePriors stored = ReadDatabasePosePriors(Database(path));
  EXPECT_EQ(stored.source, "pose_priors table (COLMAP 3.11/3.12)");
  ASSERT_EQ(stored.priors.size(), 2u);
  EXPECT_EQ(stored.priors[0].image_name, "a.jpg");
  EXPECT_EQ(stored.priors[0].position, Eigen::Vector3d(47.1, 8.2, 400.0));
  EXPECT_EQ(stored.priors[0].coordinate_system, PriorCoordinateSystem::kWgs84);
  EXPECT_EQ(stored.priors[0].position_covariance(2, 2), 9.0);
  EXPECT_FALSE(stored.priors[0].gravity.allFinite());
  EXPECT_FALSE(stored.priors[1].position.allFinite());  // NULL: absent
  EXPECT_EQ(stored.num_skipped.at("prior of an image not in the database"), 1);

  const LocalPosePriors local =
      ConvertPosePriors(stored, {{"a.jpg", 1}, {"b.jpg", 2}, {"c.jpg", 3}});
  EXPECT_TRUE(local.is_enu);
  EXPECT_EQ(local.num_positions, 1);
  EXPECT_EQ(local.num_skipped.at("no position or a NaN coordinate"), 1);
  // The only prior is the origin.
  EXPECT_NEAR(local.priors.at(1).position.norm(), 0, 1e-9);
  EXPECT_EQ(local.priors.at(1).position_covariance(0, 0), 4.0);
  EXPECT_EQ(local.enu_origin.latitude, 47.1);
}

TEST(PosePriors, ReadsColmap4Table) {
  TempDir dir;
  const std::string path = dir.File("colmap4.db");
  {
    SqliteWriter writer(path);
    writer.Exec(test::Colmap4Schema());
    WriteImages(&writer, true);
    // Cartesian with gravity; an IMU's prior; a prior naming another camera.
    writer.Run("INSERT INTO pose_priors VALUES (1, 2, 1, 0, ?, NULL, ?, 1)",
               {Doubles({1.0, 2.0, 3.0}), Doubles({0.0, 2.0, 0.0})});
    writer.Run("INSERT INTO pose_priors VALUES (2, 1, 1, 1, ?, NULL, NULL, 1)",
               {Doubles({5.0, 5.0, 5.0})});
    writer.Run("INSERT INTO pose_priors VALUES (3, 3, 7, 0, ?, NULL, NULL, 1)",
               {Doubles({5.0, 5.0, 5.0})});
  }
  const StoredPosePriors stored = ReadDatabasePosePriors(Database(path));
  EXPECT_EQ(stored.source, "pose_priors table (COLMAP 4.x)");
  ASSERT_EQ(stored.priors.size(), 1u);
  EXPECT_EQ(stored.priors[0].image_name, "b.jpg");
  EXPECT_EQ(stored.num_skipped.at("prior of a non-camera sensor"), 1);
  EXPECT_EQ(stored.num_skipped.at("prior of another camera than its image's"),
            1);
  const LocalPosePriors local =
      ConvertPosePriors(stored, {{"a.jpg", 1}, {"b.jpg", 2}, {"c.jpg", 3}});
  EXPECT_FALSE(local.is_enu);
  EXPECT_EQ(local.priors.at(2).position, Eigen::Vector3d(1, 2, 3));
  // Gravity normalised.
  EXPECT_EQ(local.priors.at(2).gravity, Eigen::Vector3d(0, 1, 0));
  EXPECT_EQ(local.num_gravity, 1);
}

TEST(PosePriors, ReadsColmap38ImageColumns) {
  TempDir dir;
  const std::string path = dir.File("colmap38.db");
  {
    SqliteWriter writer(path);
    writer.Exec(Colmap38Schema());
    WriteImages(&writer, false);
    writer.Exec(
        "UPDATE images SET prior_tx = 47.0, prior_ty = 8.0, prior_tz = 500 "
        "WHERE image_id = 3;");
  }
  const StoredPosePriors stored = ReadDatabasePosePriors(Database(path));
  EXPECT_EQ(stored.source, "images.prior_tx/ty/tz (COLMAP 3.8/3.9, WGS84)");
  ASSERT_EQ(stored.priors.size(), 1u);
  EXPECT_EQ(stored.priors[0].image_name, "c.jpg");
  EXPECT_EQ(stored.priors[0].coordinate_system, PriorCoordinateSystem::kWgs84);
  EXPECT_EQ(stored.num_skipped.at("no position (NULL)"), 2);
  // Some images with a fix, some without: worth a warning.
  const LocalPosePriors local =
      ConvertPosePriors(stored, {{"a.jpg", 1}, {"b.jpg", 2}, {"c.jpg", 3}});
  EXPECT_FALSE(local.NoneStored());
  EXPECT_EQ(local.Warnings().size(), 1u);
}

TEST(PosePriors, Colmap38ColumnsWithoutAnyFixWarnNothing) {
  TempDir dir;
  const std::string path = dir.File("colmap38_no_gps.db");
  {
    SqliteWriter writer(path);
    writer.Exec(Colmap38Schema());
    WriteImages(&writer, false);
  }
  const LocalPosePriors local =
      ConvertPosePriors(ReadDatabasePosePriors(Database(path)),
                        {{"a.jpg", 1}, {"b.jpg", 2}, {"c.jpg", 3}});
  EXPECT_TRUE(local.priors.empty());
  EXPECT_EQ(local.num_skipped.at("no position (NULL)"), 3);
  EXPECT_TRUE(local.NoneStored());
  EXPECT_TRUE(local.Warnings().empty());
}

TEST(PosePriors, WrongBlobSizeNamesTheFileAndImage) {
  TempDir dir;
  const std::string path = dir.File("bad.db");
  {
    SqliteWriter writer(path);
    writer.Exec(Colmap38Schema());
    writer.Exec(kColmap311PosePriors);
    WriteImages(&writer, false);
    writer.Run("INSERT INTO pose_priors VALUES (2, ?, 0, NULL)",
               {Doubles({47.1, 8.2})});
  }
  try {
    ReadDatabasePosePriors(Database(path));
    FAIL() << "no error";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find(path), std::string::npos);
    EXPECT_NE(std::string(error.what()).find("image 2"), std::string::npos);
    EXPECT_NE(std::string(error.what()).find("16 bytes"), std::string::npos);
  }
}

TEST(PosePriors, TextFile) {
  TempDir dir;
  const std::string path = dir.File("priors.txt");
  {
    std::ofstream file(path);
    file << "# name lat lon alt\n"
         << "a.jpg 47.0 8.0 400  # comment\n"
         << "\n"
         << "b.jpg 47.001 8.0 400 0 0.5 0\n"
         << "c.jpg nan 8.0 400\n"
         << "x.jpg 47.0 8.0 400\n"
         << "d.jpg 95.0 8.0 400\n"
         << "a.jpg 0 0 0\n";
  }
  const StoredPosePriors stored = ReadPosePriorText(path, true);
  ASSERT_EQ(stored.priors.size(), 6u);
  const LocalPosePriors local = ConvertPosePriors(
      stored, {{"a.jpg", 1}, {"b.jpg", 2}, {"c.jpg", 3}, {"d.jpg", 4}});
  EXPECT_EQ(local.num_positions, 2);
  EXPECT_EQ(local.num_gravity, 1);
  EXPECT_EQ(local.num_skipped.at("image name not in the database"), 1);
  EXPECT_EQ(local.num_skipped.at("no position or a NaN coordinate"), 1);
  EXPECT_EQ(local.num_skipped.at("WGS84 position out of range"), 1);
  EXPECT_EQ(local.num_skipped.at("second prior of an image"), 1);
  // b is 0.001 deg north of a (111.2 m at 47 deg); the origin is their
  // median.
  EXPECT_NEAR((local.priors.at(2).position - local.priors.at(1).position).y(),
              111.2, 0.1);
  EXPECT_EQ(local.priors.at(2).gravity, Eigen::Vector3d(0, 1, 0));
  EXPECT_EQ(PriorFrameText(local).find("FRAME ENU") != std::string::npos, true);

  // Cartesian: used as they are.
  const LocalPosePriors cartesian = ConvertPosePriors(
      ReadPosePriorText(path, false), {{"a.jpg", 1}, {"d.jpg", 4}});
  EXPECT_FALSE(cartesian.is_enu);
  EXPECT_EQ(cartesian.priors.at(4).position, Eigen::Vector3d(95, 8, 400));
}

TEST(PosePriors, MalformedTextFileIsAnErrorNamingTheLine) {
  TempDir dir;
  const std::string path = dir.File("priors.txt");
  {
    std::ofstream file(path);
    file << "a.jpg 1 2 3\nb.jpg 1 two 3\n";
  }
  try {
    ReadPosePriorText(path, false);
    FAIL() << "no error";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find(path + ": line 2"),
              std::string::npos)
        << error.what();
  }
  {
    std::ofstream file(path);
    file << "a.jpg 1 2\n";
  }
  EXPECT_THROW(ReadPosePriorText(path, false), InputError);
  EXPECT_THROW(ReadPosePriorText(dir.File("missing.txt"), false), InputError);
}

TEST(PosePriors, InvalidCovarianceFallsBackToTheDefault) {
  StoredPosePriors stored;
  StoredPosePrior prior;
  prior.image_name = "a.jpg";
  prior.position = Eigen::Vector3d(1, 2, 3);
  prior.coordinate_system = PriorCoordinateSystem::kCartesian;
  prior.position_covariance = -Eigen::Matrix3d::Identity();
  stored.priors.push_back(prior);
  const LocalPosePriors local = ConvertPosePriors(stored, {{"a.jpg", 1}});
  EXPECT_FALSE(local.priors.at(1).HasPositionCovariance());
  EXPECT_EQ(local.num_skipped.at(
                "covariance not symmetric positive definite (default used)"),
            1);
}

TEST(PosePriors, WrittenInEverySchemaReadBackTheSame) {
  std::map<image_t, StoredPosePrior> priors;
  for (image_t id = 1; id <= 3; ++id) {
    StoredPosePrior& prior = priors[id];
    prior.position =
        Eigen::Vector3d(47.0 + 1e-4 * id, 8.0 - 2e-4 * id, 400 + id);
    prior.coordinate_system = PriorCoordinateSystem::kWgs84;
    prior.position_covariance = Eigen::Vector3d(9, 9, 25).asDiagonal();
    prior.gravity = Eigen::Vector3d(0, 1, 0.01 * id).normalized();
  }
  const std::map<std::string, image_t> ids = {
      {"a.jpg", 1}, {"b.jpg", 2}, {"c.jpg", 3}};
  std::map<std::string, LocalPosePriors> read;
  for (const std::string schema : {"colmap38", "colmap311", "colmap4"}) {
    TempDir dir;
    const std::string path = dir.File(schema + ".db");
    {
      SqliteWriter writer(path);
      writer.Exec(schema == "colmap4" ? test::Colmap4Schema()
                                      : Colmap38Schema());
      WriteImages(&writer, schema == "colmap4");
    }
    WritePosePriorsToDatabase(path, PosePriorSchemaFromName(schema), priors);
    read[schema] =
        ConvertPosePriors(ReadDatabasePosePriors(Database(path)), ids);
  }
  for (const auto& [schema, local] : read) {
    ASSERT_EQ(local.num_positions, 3) << schema;
    for (image_t id = 1; id <= 3; ++id) {
      EXPECT_LT((local.priors.at(id).position -
                 read.at("colmap4").priors.at(id).position)
                    .norm(),
                1e-9)
          << schema;
    }
  }
  // What each schema holds besides positions.
  EXPECT_FALSE(read.at("colmap38").priors.at(1).HasPositionCovariance());
  EXPECT_TRUE(read.at("colmap311").priors.at(1).HasPositionCovariance());
  EXPECT_FALSE(read.at("colmap311").priors.at(1).HasGravity());
  EXPECT_TRUE(read.at("colmap4").priors.at(1).HasGravity());
}

}  // namespace
}  // namespace colmap_irav4
