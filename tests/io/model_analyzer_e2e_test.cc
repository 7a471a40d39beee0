// End-to-end: COLMAP 3.8 (Debian's /usr/bin/colmap) reads the models we
// write, and we read the models it writes.

#include <cstdio>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "colmap_irav4/io/model_io.h"
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

const char kColmap[] = "/usr/bin/colmap";

struct CommandResult {
  int exit_code = -1;
  std::string output;  // stdout and stderr
};

CommandResult RunShell(const std::string& command) {
  CommandResult result;
  FILE* pipe = popen((command + " 2>&1").c_str(), "r");
  if (pipe == nullptr) return result;
  char buffer[4096];
  size_t n;
  while ((n = fread(buffer, 1, sizeof(buffer), pipe)) > 0) {
    result.output.append(buffer, n);
  }
  const int status = pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

// "Name: value" lines of model_analyzer's output.
std::map<std::string, double> ParseAnalyzerOutput(const std::string& output) {
  std::map<std::string, double> values;
  std::istringstream stream(output);
  std::string line;
  while (std::getline(stream, line)) {
    const size_t colon = line.find(": ");
    if (colon == std::string::npos || line.find(']') != std::string::npos) {
      continue;  // not a "Name: value" line (e.g. a glog line)
    }
    try {
      values[line.substr(0, colon)] = std::stod(line.substr(colon + 2));
    } catch (const std::exception&) {
    }
  }
  return values;
}

double MeanReprojectionError(const Reconstruction& model) {
  double sum = 0.0;
  int count = 0;
  for (const auto& [point3D_id, point] : model.points3D) {
    if (point.error >= 0.0) {
      sum += point.error;
      ++count;
    }
  }
  return count > 0 ? sum / count : 0.0;
}

// Writes `model` with our writer and checks what COLMAP's model_analyzer
// says about it.
void ExpectAnalyzerAgrees(const Reconstruction& model,
                          const std::string& type) {
  TempDir temp;
  WriteReconstruction(model, temp.path(), type);
  const CommandResult result =
      RunShell(std::string(kColmap) + " model_analyzer --path " + temp.path());
  ASSERT_EQ(result.exit_code, 0) << result.output;
  const std::map<std::string, double> values =
      ParseAnalyzerOutput(result.output);
  for (const std::string key :
       {"Cameras", "Images", "Registered images", "Points", "Observations",
        "Mean track length", "Mean observations per image",
        "Mean reprojection error"}) {
    ASSERT_TRUE(values.count(key)) << key << " missing in:\n" << result.output;
  }
  EXPECT_EQ(values.at("Cameras"), model.cameras.size());
  EXPECT_EQ(values.at("Images"), model.images.size());
  EXPECT_EQ(values.at("Registered images"), model.images.size());
  EXPECT_EQ(values.at("Points"), model.points3D.size());
  EXPECT_EQ(values.at("Observations"), NumObservations(model));
  // model_analyzer prints six decimals.
  EXPECT_NEAR(values.at("Mean track length"), MeanTrackLength(model), 1e-6);
  EXPECT_NEAR(values.at("Mean observations per image"),
              MeanObservationsPerImage(model), 1e-6);
  EXPECT_NEAR(values.at("Mean reprojection error"),
              MeanReprojectionError(model), 1e-6);
}

// The lines of a COLMAP text file: the header comments in order, and the
// data records (images take two lines) as a set, since COLMAP writes them in
// its hash-map order.
struct TextRecords {
  std::vector<std::string> header;
  std::multiset<std::string> records;
};

TextRecords SplitText(const std::string& bytes, int lines_per_record) {
  TextRecords result;
  std::istringstream stream(bytes);
  std::string line;
  while (std::getline(stream, line)) {
    if (!line.empty() && line[0] == '#') {
      result.header.push_back(line);
      continue;
    }
    std::string record = line;
    for (int k = 1; k < lines_per_record; ++k) {
      std::getline(stream, line);
      record += "\n" + line;
    }
    result.records.insert(record);
  }
  return result;
}

class ColmapEndToEnd : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!fs::exists(kColmap)) GTEST_SKIP() << kColmap << " is not installed";
    COLMAP_IRAV4_REQUIRE_DATA("strecha/fountain-P11");
  }
};

TEST_F(ColmapEndToEnd, ModelAnalyzerReadsOurBinaryAndTextModels) {
  const Reconstruction strecha = ReadReconstruction(
      DataDir() + "/strecha/fountain-P11/colmap38_incremental");
  ExpectAnalyzerAgrees(strecha, "BIN");
  ExpectAnalyzerAgrees(strecha, "TXT");
  // Every camera model; COLMAP's text reader splits names at spaces.
  ExpectAnalyzerAgrees(SyntheticModel(/*name_with_space=*/false), "BIN");
  ExpectAnalyzerAgrees(SyntheticModel(/*name_with_space=*/false), "TXT");
}

// COLMAP converts our binary model to text: we read its text back
// identically, and its text files hold exactly our text writer's lines.
TEST_F(ColmapEndToEnd, ModelConverterOutputMatchesOurReaderAndWriter) {
  COLMAP_IRAV4_REQUIRE_DATA("strecha/Herz-Jesus-P8/colmap38_incremental");
  const std::vector<Reconstruction> models = {
      ReadReconstruction(DataDir() +
                         "/strecha/Herz-Jesus-P8/colmap38_incremental"),
      SyntheticModel(/*name_with_space=*/false)};
  for (const Reconstruction& model : models) {
    TempDir temp;
    const std::string ours = temp.File("ours");
    const std::string theirs_txt = temp.File("theirs_txt");
    const std::string theirs_bin = temp.File("theirs_bin");
    WriteReconstruction(model, ours, "BIN");
    // COLMAP 3.8 does not create its output directories.
    fs::create_directories(theirs_txt);
    fs::create_directories(theirs_bin);
    CommandResult result =
        RunShell(std::string(kColmap) + " model_converter --input_path " +
                 ours + " --output_path " + theirs_txt + " --output_type TXT");
    ASSERT_EQ(result.exit_code, 0) << result.output;
    ExpectIdentical(model, ReadReconstruction(theirs_txt));

    const std::vector<std::pair<std::string, std::string>> files = {
        {"cameras.txt", CamerasTextBytes(model)},
        {"images.txt", ImagesTextBytes(model)},
        {"points3D.txt", Points3DTextBytes(model)}};
    for (const auto& [name, our_bytes] : files) {
      SCOPED_TRACE(name);
      const int lines_per_record = name == "images.txt" ? 2 : 1;
      const TextRecords our_text = SplitText(our_bytes, lines_per_record);
      const TextRecords their_text =
          SplitText(ReadBytes(theirs_txt + "/" + name), lines_per_record);
      EXPECT_EQ(our_text.header, their_text.header);
      EXPECT_EQ(our_text.records.size(), their_text.records.size());
      EXPECT_TRUE(our_text.records == their_text.records);
    }

    // And back to binary with COLMAP from our text: the same records.
    fs::create_directories(temp.File("ours_txt"));
    WriteReconstruction(model, temp.File("ours_txt"), "TXT");
    result = RunShell(std::string(kColmap) + " model_converter --input_path " +
                      temp.File("ours_txt") + " --output_path " + theirs_bin +
                      " --output_type BIN");
    ASSERT_EQ(result.exit_code, 0) << result.output;
    ExpectIdentical(model, ReadReconstruction(theirs_bin));
  }
}

// Our model_converter command: BIN -> TXT -> BIN gives COLMAP's cameras and
// images files byte for byte; bad input fails with one line naming the file.
TEST(ModelConverterCommand, ConvertsAndReportsBadInput) {
  COLMAP_IRAV4_REQUIRE_DATA("strecha/Herz-Jesus-P8/colmap38_incremental");
  const std::string source =
      DataDir() + "/strecha/Herz-Jesus-P8/colmap38_incremental";
  const std::string binary = COLMAP_IRAV4_BINARY;
  TempDir temp;
  CommandResult result =
      RunShell(binary + " model_converter --input_path " + source +
               " --output_path " + temp.File("txt") + " --output_type TXT");
  ASSERT_EQ(result.exit_code, 0) << result.output;
  EXPECT_TRUE(ExistsTextModel(temp.File("txt")));
  result = RunShell(binary + " model_converter --input_path " +
                    temp.File("txt") + " --output_path " + temp.File("bin"));
  ASSERT_EQ(result.exit_code, 0) << result.output;
  for (const std::string name : {"cameras.bin", "images.bin"}) {
    EXPECT_TRUE(ReadBytes(source + "/" + name) ==
                ReadBytes(temp.File("bin") + "/" + name))
        << name;
  }
  ExpectIdentical(ReadReconstruction(source),
                  ReadReconstruction(temp.File("bin")));

  result = RunShell(binary + " model_converter --input_path " +
                    temp.File("none") + " --output_path " + temp.File("out"));
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_NE(result.output.find("ERROR: " + temp.File("none")),
            std::string::npos)
      << result.output;
  EXPECT_FALSE(fs::exists(temp.File("out")));
  result =
      RunShell(binary + " model_converter --input_path " + source +
               " --output_path " + temp.File("out") + " --output_type PLY");
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_NE(result.output.find("--output_type"), std::string::npos)
      << result.output;
}

}  // namespace
}  // namespace colmap_irav4
