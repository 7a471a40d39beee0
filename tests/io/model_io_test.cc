#include "colmap_irav4/io/model_io.h"
#include "colmap_irav4/util/atomic_output.h"

#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <sstream>

#include <gtest/gtest.h>

#include "colmap_irav4/scene/camera_models.h"
#include "colmap_irav4/util/error.h"
#include "tests/io/model_test_utils.h"
#include "tests/test_utils/data.h"

namespace colmap_irav4 {
namespace {

namespace fs = std::filesystem;
using test::ExpectIdentical;
using test::ReadBytes;
using test::SyntheticModel;
using test::TempDir;
using test::WriteBytes;

const std::string kDataDir = DataDir();

std::vector<std::string> StrechaModelDirs() {
  return {kDataDir + "/strecha/fountain-P11/colmap38_incremental",
          kDataDir + "/strecha/Herz-Jesus-P8/colmap38_incremental"};
}

// Splits a COLMAP binary file into its count and its records (id -> bytes),
// with a parser of its own, independent of the library's reader.
struct BinaryRecords {
  uint64_t count = 0;
  std::vector<uint64_t> ids;  // in file order
  std::map<uint64_t, std::string> records;
};

template <typename T>
T Get(const std::string& bytes, size_t offset) {
  T value;
  std::memcpy(&value, bytes.data() + offset, sizeof(T));
  return value;
}

BinaryRecords SplitBinary(const std::string& bytes, const std::string& kind) {
  BinaryRecords result;
  result.count = Get<uint64_t>(bytes, 0);
  size_t offset = 8;
  for (uint64_t i = 0; i < result.count; ++i) {
    const size_t begin = offset;
    uint64_t id = 0;
    if (kind == "cameras") {
      id = Get<uint32_t>(bytes, offset);
      const int model_id = Get<int32_t>(bytes, offset + 4);
      offset += 24 + 8 * CameraModelNumParams(model_id);
    } else if (kind == "images") {
      id = Get<uint32_t>(bytes, offset);
      offset += 4 + 56 + 4;
      offset = bytes.find('\0', offset) + 1;
      offset += 8 + 24 * Get<uint64_t>(bytes, offset);
    } else {
      id = Get<uint64_t>(bytes, offset);
      offset += 8 + 24 + 3 + 8;
      offset += 8 + 8 * Get<uint64_t>(bytes, offset);
    }
    EXPECT_LE(offset, bytes.size());
    result.ids.push_back(id);
    result.records[id] = bytes.substr(begin, offset - begin);
  }
  EXPECT_EQ(offset, bytes.size());
  return result;
}

TEST(ModelIO, ReadsCOLMAP38ModelsAndRoundTripsBinaryAndText) {
  COLMAP_IRAV4_REQUIRE_DATA("strecha/Herz-Jesus-P8/colmap38_incremental");
  for (const std::string& dir : StrechaModelDirs()) {
    SCOPED_TRACE(dir);
    const Reconstruction model = ReadReconstruction(dir);
    ASSERT_TRUE(ExistsBinaryModel(dir));
    // The dataset's README: one PINHOLE camera, every image registered.
    ASSERT_EQ(model.cameras.size(), 1u);
    EXPECT_EQ(model.cameras.begin()->second.model_id, kPinhole);
    EXPECT_EQ(model.cameras.begin()->second.width, 3072u);
    EXPECT_GE(model.images.size(), 8u);
    EXPECT_GT(model.points3D.size(), 5000u);
    for (const auto& [image_id, image] : model.images) {
      EXPECT_NEAR(image.cam_from_world.rotation.norm(), 1.0, 1e-12);
    }

    TempDir temp;
    const std::string bin_dir = temp.File("bin");
    const std::string txt_dir = temp.File("txt");
    WriteReconstruction(model, bin_dir, "BIN");
    WriteReconstruction(model, txt_dir, "TXT");
    EXPECT_TRUE(ExistsBinaryModel(bin_dir));
    EXPECT_FALSE(ExistsTextModel(bin_dir));
    EXPECT_TRUE(ExistsTextModel(txt_dir));
    EXPECT_FALSE(ExistsBinaryModel(txt_dir));
    // No temporary files are left behind.
    EXPECT_EQ(std::distance(fs::directory_iterator(bin_dir),
                            fs::directory_iterator()),
              3);
    ExpectIdentical(model, ReadReconstruction(bin_dir));
    ExpectIdentical(model, ReadReconstruction(txt_dir));
    // Text -> binary gives the same bytes again.
    const std::string bin2_dir = temp.File("bin2");
    WriteReconstruction(ReadReconstructionText(txt_dir), bin2_dir, "bin");
    for (const std::string name :
         {"cameras.bin", "images.bin", "points3D.bin"}) {
      EXPECT_EQ(ReadBytes(bin_dir + "/" + name),
                ReadBytes(bin2_dir + "/" + name))
          << name;
    }
  }
}

// COLMAP writes its records in the iteration order of its hash maps
// (unordered_map), which is not defined; we write increasing ids. So: the
// counts are equal, every record is byte-identical, and where COLMAP's file
// happens to be in increasing id order (cameras and images here) the whole
// files are byte-identical.
TEST(ModelIO, BinaryWriteIsByteIdenticalToCOLMAP) {
  COLMAP_IRAV4_REQUIRE_DATA("strecha/Herz-Jesus-P8/colmap38_incremental");
  for (const std::string& dir : StrechaModelDirs()) {
    SCOPED_TRACE(dir);
    const Reconstruction model = ReadReconstruction(dir);
    const std::vector<std::pair<std::string, std::string>> files = {
        {"cameras", CamerasBinaryBytes(model)},
        {"images", ImagesBinaryBytes(model)},
        {"points3D", Points3DBinaryBytes(model)}};
    for (const auto& [kind, ours] : files) {
      SCOPED_TRACE(kind);
      const std::string theirs = ReadBytes(dir + "/" + kind + ".bin");
      ASSERT_EQ(ours.size(), theirs.size());
      const BinaryRecords our_records = SplitBinary(ours, kind);
      const BinaryRecords their_records = SplitBinary(theirs, kind);
      EXPECT_EQ(our_records.count, their_records.count);
      EXPECT_EQ(our_records.records.size(), our_records.count);
      EXPECT_TRUE(our_records.records == their_records.records);
      EXPECT_TRUE(
          std::is_sorted(our_records.ids.begin(), our_records.ids.end()));
      if (std::is_sorted(their_records.ids.begin(), their_records.ids.end())) {
        EXPECT_TRUE(ours == theirs);
      }
    }
    // The cameras and images files of these models are in id order.
    EXPECT_TRUE(CamerasBinaryBytes(model) == ReadBytes(dir + "/cameras.bin"));
    EXPECT_TRUE(ImagesBinaryBytes(model) == ReadBytes(dir + "/images.bin"));
  }
}

// The number after "prefix" in the first line containing it.
double HeaderNumber(const std::string& path, const std::string& prefix) {
  std::ifstream file(path);
  std::string line;
  while (std::getline(file, line)) {
    const size_t pos = line.find(prefix);
    if (pos != std::string::npos) {
      return std::stod(line.substr(pos + prefix.size()));
    }
  }
  ADD_FAILURE() << prefix << " not in " << path;
  return -1;
}

TEST(ModelIO, ReadsCOLMAP37TextModel) {
  COLMAP_IRAV4_REQUIRE_DATA(
      "colmap_samples/maupertuis_colmap37/reference_model");
  const std::string dir =
      kDataDir + "/colmap_samples/maupertuis_colmap37/reference_model";
  ASSERT_FALSE(ExistsBinaryModel(dir));
  const Reconstruction model = ReadReconstruction(dir);
  EXPECT_EQ(model.cameras.size(),
            HeaderNumber(dir + "/cameras.txt", "Number of cameras: "));
  EXPECT_EQ(model.images.size(),
            HeaderNumber(dir + "/images.txt", "Number of images: "));
  EXPECT_EQ(model.points3D.size(),
            HeaderNumber(dir + "/points3D.txt", "Number of points: "));
  EXPECT_NEAR(
      MeanObservationsPerImage(model),
      HeaderNumber(dir + "/images.txt", "mean observations per image: "), 1e-4);
  EXPECT_NEAR(MeanTrackLength(model),
              HeaderNumber(dir + "/points3D.txt", "mean track length: "), 1e-4);
  // The README: one SIMPLE_PINHOLE camera, four images.
  ASSERT_EQ(model.cameras.size(), 1u);
  EXPECT_EQ(model.cameras.begin()->second.model_id, kSimplePinhole);
  EXPECT_EQ(model.images.size(), 4u);
  for (const auto& [image_id, image] : model.images) {
    EXPECT_FALSE(image.name.empty());
    EXPECT_FALSE(image.points2D.empty());
  }
}

TEST(ModelIO, SyntheticModelWithEveryCameraModelRoundTrips) {
  const Reconstruction model = SyntheticModel();
  ASSERT_GT(model.points3D.size(), 50u);
  TempDir temp;
  for (const std::string type : {"BIN", "TXT"}) {
    const std::string dir = temp.File(type);
    WriteReconstruction(model, dir, type);
    ExpectIdentical(model, ReadReconstruction(dir));
  }
  // The image without points2D has an empty POINTS2D line.
  const std::string images_txt = ReadBytes(temp.File("TXT/images.txt"));
  EXPECT_NE(images_txt.find("dir/image 5.jpg\n\n"), std::string::npos);
  EXPECT_NE(images_txt.find("# Number of images: 12, mean observations"),
            std::string::npos);
  EXPECT_THROW(WriteReconstruction(model, temp.File("x"), "PLY"), InputError);
}

// Expects `function` to throw InputError whose message names `path` and
// contains `problem`.
template <typename Function>
void ExpectInputError(Function function, const std::string& path,
                      const std::string& problem) {
  try {
    function();
    ADD_FAILURE() << "no InputError for " << path << " (" << problem << ")";
  } catch (const InputError& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find(path), std::string::npos) << message;
    EXPECT_NE(message.find(problem), std::string::npos) << message;
  }
}

// COLMAP 4.x models add rigs and frames files beside the three files, whose
// layout is unchanged: those are ignored. Text files with Windows line ends
// read the same.
TEST(ModelIO, ReadsCOLMAP4xLayoutAndWindowsLineEnds) {
  const Reconstruction model = SyntheticModel();
  TempDir temp;
  for (const std::string type : {"BIN", "TXT"}) {
    const std::string dir = temp.File(type);
    WriteReconstruction(model, dir, type);
    const std::string ext = type == "BIN" ? ".bin" : ".txt";
    WriteBytes(dir + "/rigs" + ext, "rigs of COLMAP 4");
    WriteBytes(dir + "/frames" + ext, "frames of COLMAP 4");
    ExpectIdentical(model, ReadReconstruction(dir));
  }
  const std::string dir = temp.File("TXT");
  for (const std::string name : {"cameras.txt", "images.txt", "points3D.txt"}) {
    std::string crlf;
    for (const char c : ReadBytes(dir + "/" + name)) {
      if (c == '\n') crlf += '\r';
      crlf += c;
    }
    WriteBytes(dir + "/" + name, crlf);
  }
  ExpectIdentical(model, ReadReconstruction(dir));
  // Camera models added after COLMAP 3.8 are reported as such.
  WriteBytes(dir + "/cameras.txt",
             "1 SIMPLE_DIVISION 640 480 500 320 240 0.1\n");
  ExpectInputError([&] { ReadReconstruction(dir); }, dir + "/cameras.txt",
                   "line 1: unknown camera model 'SIMPLE_DIVISION'");
}

// Quaternions are written divided by their norm, as COLMAP 3.8 writes them.
TEST(ModelIO, WritesNormalizedQuaternions) {
  Reconstruction model = SyntheticModel();
  Image& image = model.images.begin()->second;
  image.cam_from_world.rotation = Eigen::Quaterniond(2.0, 0.0, -2.0, 0.0);
  Image& zero = std::next(model.images.begin())->second;
  zero.cam_from_world.rotation.coeffs().setZero();
  TempDir temp;
  for (const std::string type : {"BIN", "TXT"}) {
    WriteReconstruction(model, temp.File(type), type);
    const Reconstruction read = ReadReconstruction(temp.File(type));
    const Eigen::Quaterniond& q =
        read.images.at(image.image_id).cam_from_world.rotation;
    EXPECT_NEAR(q.w(), std::sqrt(0.5), 1e-15);
    EXPECT_NEAR(q.y(), -std::sqrt(0.5), 1e-15);
    EXPECT_EQ(q.x(), 0.0);
    EXPECT_EQ(q.z(), 0.0);
    // COLMAP writes a zero quaternion as (1, 0, 0, 0).
    EXPECT_EQ(read.images.at(zero.image_id).cam_from_world.rotation.coeffs(),
              Eigen::Quaterniond::Identity().coeffs());
  }
}

TEST(ModelIO, MissingFilesAndDirectories) {
  TempDir temp;
  ExpectInputError([&] { ReadReconstruction(temp.File("none")); },
                   temp.File("none"), "does not exist");
  ExpectInputError([&] { ReadReconstruction(temp.path()); }, temp.path(),
                   "no COLMAP model");
  // Only some files of a model.
  WriteReconstruction(SyntheticModel(), temp.path(), "BIN");
  fs::remove(temp.File("points3D.bin"));
  ExpectInputError([&] { ReadReconstruction(temp.path()); }, temp.path(),
                   "no COLMAP model");
  ExpectInputError([&] { ReadReconstructionBinary(temp.path()); },
                   temp.File("points3D.bin"), "does not exist");
}

TEST(ModelIO, TruncatedAndGarbageBinaryFiles) {
  COLMAP_IRAV4_REQUIRE_DATA("strecha/Herz-Jesus-P8/colmap38_incremental");
  const std::string source = StrechaModelDirs()[1];
  for (const std::string name : {"cameras.bin", "images.bin", "points3D.bin"}) {
    const std::string original = ReadBytes(source + "/" + name);
    std::vector<size_t> cuts = {
        0, 3, 8, 12, 40, original.size() / 2, original.size() - 1};
    for (const size_t cut : cuts) {
      if (cut >= original.size()) continue;
      SCOPED_TRACE(name + " cut at " + std::to_string(cut));
      TempDir temp;
      for (const std::string file :
           {"cameras.bin", "images.bin", "points3D.bin"}) {
        fs::copy_file(source + "/" + file, temp.File(file));
      }
      WriteBytes(temp.File(name), original.substr(0, cut));
      ExpectInputError([&] { ReadReconstruction(temp.path()); },
                       temp.File(name), "");
    }
    // Trailing garbage, and random bytes.
    TempDir temp;
    for (const std::string file :
         {"cameras.bin", "images.bin", "points3D.bin"}) {
      fs::copy_file(source + "/" + file, temp.File(file));
    }
    WriteBytes(temp.File(name), original + "xyz");
    ExpectInputError([&] { ReadReconstruction(temp.path()); }, temp.File(name),
                     "unexpected bytes");
    std::mt19937_64 rng(1);
    std::string garbage(4096, '\0');
    for (char& c : garbage) c = static_cast<char>(rng());
    WriteBytes(temp.File(name), garbage);
    ExpectInputError([&] { ReadReconstruction(temp.path()); }, temp.File(name),
                     "");
  }
}

TEST(ModelIO, BadBinaryContents) {
  const Reconstruction model = SyntheticModel();
  TempDir temp;
  WriteReconstruction(model, temp.path(), "BIN");
  const std::string cameras = ReadBytes(temp.File("cameras.bin"));
  // Unknown camera model id in the first record.
  std::string bad = cameras;
  const int32_t unknown_model = 42;
  std::memcpy(&bad[8 + 4], &unknown_model, 4);
  WriteBytes(temp.File("cameras.bin"), bad);
  ExpectInputError([&] { ReadReconstruction(temp.path()); },
                   temp.File("cameras.bin"), "unknown camera model id 42");
  // An image referencing a camera that is not there: drop camera 10.
  Reconstruction missing_camera = model;
  missing_camera.cameras.erase(10);
  WriteBytes(temp.File("cameras.bin"), CamerasBinaryBytes(missing_camera));
  ExpectInputError([&] { ReadReconstruction(temp.path()); },
                   temp.File("images.bin"), "references camera 10");
  WriteBytes(temp.File("cameras.bin"), cameras);
  // A track element that the images do not have.
  Reconstruction bad_track = model;
  bad_track.points3D.begin()->second.track[0].point2D_idx = 7;
  WriteBytes(temp.File("points3D.bin"), Points3DBinaryBytes(bad_track));
  ExpectInputError([&] { ReadReconstruction(temp.path()); },
                   temp.File("points3D.bin"), "disagrees");
  // An observation whose point is missing.
  Reconstruction missing_point = model;
  missing_point.points3D.erase(missing_point.points3D.begin());
  WriteBytes(temp.File("points3D.bin"), Points3DBinaryBytes(missing_point));
  ExpectInputError([&] { ReadReconstruction(temp.path()); },
                   temp.File("points3D.bin"), "not in the points3D file");
  WriteBytes(temp.File("points3D.bin"), Points3DBinaryBytes(model));
  ExpectIdentical(model, ReadReconstruction(temp.path()));
}

TEST(ModelIO, BadTextContents) {
  const Reconstruction model = SyntheticModel();
  TempDir temp;
  WriteReconstruction(model, temp.path(), "TXT");
  const std::string cameras = CamerasTextBytes(model);
  const std::string images = ImagesTextBytes(model);
  const std::string points = Points3DTextBytes(model);
  struct Case {
    std::string file, contents, problem;
  };
  const std::vector<Case> cases = {
      {"cameras.txt", cameras + "99 PINHOLE 640 480 1 2 3\n",
       "has 4 parameters"},
      {"cameras.txt", cameras + "99 FISHEYE_X 640 480 1 2 3\n",
       "unknown camera model 'FISHEYE_X'"},
      {"cameras.txt", cameras + "99 PINHOLE 640 480 1 2 3 abc\n",
       "invalid parameter 'abc'"},
      {"cameras.txt", cameras + "99 PINHOLE\n", "line 15"},
      {"cameras.txt", cameras + "10 PINHOLE 640 480 1 2 3 4\n",
       "duplicate camera id 10"},
      {"images.txt", images + "999 1 0 0 0 0 0 0 77 x.jpg\n\n",
       "references camera 77"},
      {"images.txt", images + "999 1 0 0 0 0 0 0 10 x.jpg\n",
       "missing POINTS2D line"},
      {"images.txt", images + "999 1 0 0 0 0 0 0 10 x.jpg\n1 2\n",
       "(X, Y, POINT3D_ID) triples"},
      {"images.txt", images + "999 1 0 0 0 0 0 0\n\n", "expected IMAGE_ID"},
      {"images.txt", images + "-5 1 0 0 0 0 0 0 10 x.jpg\n\n",
       "invalid image id '-5'"},
      {"points3D.txt", points + "5 1 2 3 0 0 0 0.5 3 0 7\n", "expected"},
      {"points3D.txt", points + "5 1 2 3 0 0 300 0.5\n", "invalid color"},
      {"points3D.txt", points + "5 1 2 3 0 0 0 0.5 3 1000\n",
       "track references point2D 1000"},
      {"points3D.txt", points + "5 1 2 3 0 0 0 0.5 4 0\n",
       "track references image 4"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.problem);
    WriteReconstruction(model, temp.path(), "TXT");
    WriteBytes(temp.File(c.file), c.contents);
    ExpectInputError([&] { ReadReconstruction(temp.path()); },
                     temp.File(c.file), c.problem);
  }
  // Every line number is right: a bad camera line after the header and
  // the 11 cameras is line 15.
  WriteBytes(temp.File("cameras.txt"), cameras + "99 PINHOLE\n");
  ExpectInputError([&] { ReadReconstruction(temp.path()); },
                   temp.File("cameras.txt"), "line 15:");
}

// Found by text_readers_fuzzer: an image line whose fields are separated by
// a vertical tab split into ten tokens, but the name search knew only spaces
// and tabs and threw std::out_of_range. Any isspace separator now works.
TEST(ModelIO, ImageLineWithOtherWhitespaceSeparators) {
  const Reconstruction model = SyntheticModel();
  TempDir temp;
  WriteReconstruction(model, temp.path(), "TXT");
  WriteBytes(temp.File("images.txt"),
             ImagesTextBytes(model) + "999\v1 0 0 0\f0 0 0 10\vx.jpg\n\n");
  const Reconstruction read = ReadReconstruction(temp.path());
  ASSERT_EQ(read.images.count(999), 1u);
  EXPECT_EQ(read.images.at(999).name, "x.jpg");
  EXPECT_EQ(read.images.at(999).camera_id, 10u);
}

TEST(ModelIO, FailedWriteLeavesNoPartialModel) {
  const Reconstruction model = SyntheticModel();
  TempDir temp;
  // The output path is a file.
  WriteBytes(temp.File("file"), "x");
  EXPECT_THROW(WriteReconstruction(model, temp.File("file"), "BIN"),
               InputError);
  // The last temporary file cannot be created: nothing is written and the
  // previous model stays intact.
  const std::string dir = temp.File("model");
  Reconstruction old_model = model;
  for (auto& [image_id, image] : old_model.images) {
    for (Point2D& point2D : image.points2D)
      point2D.point3D_id = kInvalidPoint3DId;
  }
  old_model.points3D.clear();
  WriteReconstruction(old_model, dir, "BIN");
  const std::string blocker =
      dir + "/points3D.bin" + kTemporaryMarker + std::to_string(::getpid());
  fs::create_directories(blocker + "/inside");
  ExpectInputError([&] { WriteReconstruction(model, dir, "BIN"); },
                   dir + "/points3D.bin", "cannot write");
  EXPECT_TRUE(fs::exists(blocker + "/inside"));
  ExpectIdentical(old_model, ReadReconstruction(dir));
  EXPECT_EQ(
      std::distance(fs::directory_iterator(dir), fs::directory_iterator()),
      4);  // the three files and the blocker
  // A directory where a file must go.
  fs::remove_all(blocker);
  fs::remove(dir + "/images.bin");
  fs::create_directories(dir + "/images.bin");
  ExpectInputError([&] { WriteReconstruction(model, dir, "BIN"); },
                   dir + "/images.bin", "is a directory");
  EXPECT_EQ(ReadBytes(dir + "/cameras.bin"), CamerasBinaryBytes(old_model));
  EXPECT_EQ(
      std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 3);
}

// Issue 28, items 7-9: no model with a NaN or inf is written or read; the
// non-finite 2D points are removed with the tracks renumbered.
TEST(ModelIO, NonFiniteValuesAreNeitherWrittenNorRead) {
  TempDir temp;
  const Reconstruction good = SyntheticModel(false);
  ASSERT_EQ(NonFiniteValueProblem(good), "");
  const image_t image_id = good.images.begin()->first;
  const camera_t camera_id = good.cameras.begin()->first;
  const point3D_t point3D_id = good.points3D.begin()->first;
  std::vector<std::pair<std::string, Reconstruction>> bad;
  bad.emplace_back("camera", good);
  bad.back().second.cameras.at(camera_id).params[0] = NAN;
  bad.emplace_back("translation", good);
  bad.back().second.images.at(image_id).cam_from_world.translation.x() =
      INFINITY;
  bad.emplace_back("point2D", good);
  bad.back().second.images.at(image_id).points2D[3].xy.y() = NAN;
  bad.emplace_back("point3D", good);
  bad.back().second.points3D.at(point3D_id).xyz.z() = -INFINITY;
  for (const auto& [what, model] : bad) {
    EXPECT_NE(NonFiniteValueProblem(model).find("not finite"),
              std::string::npos)
        << what;
    for (const char* type : {"BIN", "TXT"}) {
      const std::string path = temp.File(what + type);
      EXPECT_THROW(WriteReconstruction(model, path, type), InputError)
          << what << type;
      EXPECT_FALSE(fs::exists(path + "/cameras.bin")) << what;
      EXPECT_FALSE(fs::exists(path + "/cameras.txt")) << what;
    }
    // Written byte by byte as another program would: refused on reading.
    const std::string path = temp.File(what + "_raw");
    fs::create_directories(path);
    WriteBytes(path + "/cameras.bin", CamerasBinaryBytes(model));
    WriteBytes(path + "/images.bin", ImagesBinaryBytes(model));
    WriteBytes(path + "/points3D.bin", Points3DBinaryBytes(model));
    EXPECT_THROW(ReadReconstruction(path), InputError) << what;
  }
}

TEST(ModelIO, RemoveNonFinitePoints2DRenumbersTracks) {
  Reconstruction model = SyntheticModel(false);
  // An image with observations: NaN at a free 2D point before an observed
  // one, whose track must follow it down by one.
  image_t image_id = 0;
  point2D_t observed = 0;
  for (const auto& [id, image] : model.images) {
    for (point2D_t k = 1; k < image.points2D.size(); ++k) {
      if (image.points2D[k].point3D_id != kInvalidPoint3DId &&
          image.points2D[k - 1].point3D_id == kInvalidPoint3DId) {
        image_id = id;
        observed = k;
        break;
      }
    }
    if (image_id != 0) break;
  }
  ASSERT_NE(image_id, 0u);
  Image& image = model.images.at(image_id);
  const size_t size = image.points2D.size();
  const point3D_t point3D_id = image.points2D[observed].point3D_id;
  image.points2D[observed - 1].xy.x() = NAN;
  const std::map<image_t, int> removed = RemoveNonFinitePoints2D(&model);
  ASSERT_EQ(removed.size(), 1u);
  EXPECT_EQ(removed.at(image_id), 1);
  EXPECT_EQ(model.images.at(image_id).points2D.size(), size - 1);
  EXPECT_EQ(model.images.at(image_id).points2D[observed - 1].point3D_id,
            point3D_id);
  bool found = false;
  for (const TrackElement& element : model.points3D.at(point3D_id).track) {
    if (element.image_id == image_id) {
      EXPECT_EQ(element.point2D_idx, observed - 1);
      found = true;
    }
  }
  EXPECT_TRUE(found);
  EXPECT_EQ(NonFiniteValueProblem(model), "");
  // The model is consistent: it writes and reads back.
  TempDir temp;
  WriteReconstruction(model, temp.File("m"), "BIN");
  ExpectIdentical(ReadReconstruction(temp.File("m")), model);
}

}  // namespace
}  // namespace colmap_irav4
