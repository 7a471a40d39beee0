// `colmap_irav4 model_viewer`: the picture of COLMAP 3.8's fountain-P11 model
// exists, has the asked size, shows points and red frusta in both panels;
// bad input is a clear error with no file written.

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "colmap_irav4/eval/model_render.h"
#include "colmap_irav4/eval/scene_generator.h"
#include "tests/test_utils/data.h"
#include "tests/test_utils/database_test_utils.h"

namespace colmap_irav4 {
namespace {

int RunViewer(const std::string& arguments, const test::TempDir& temp,
              std::string* output) {
  const std::string log = temp.File("run.log");
  const int status =
      std::system((std::string(COLMAP_IRAV4_BINARY) + " model_viewer " +
                   arguments + " > " + log + " 2>&1")
                      .c_str());
  std::ifstream file(log);
  output->assign(std::istreambuf_iterator<char>(file),
                 std::istreambuf_iterator<char>());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// Pixels that are not white, and red frustum pixels, in a panel.
void CountPixels(const cv::Mat& image, const cv::Rect& area, int* non_white,
                 int* red) {
  *non_white = 0;
  *red = 0;
  for (int y = area.y; y < area.y + area.height; ++y) {
    for (int x = area.x; x < area.x + area.width; ++x) {
      const cv::Vec3b c = image.at<cv::Vec3b>(y, x);  // BGR
      if (c[0] < 235 || c[1] < 235 || c[2] < 235) ++*non_white;
      if (c[2] > 150 && c[1] < 120 && c[0] < 120) ++*red;
    }
  }
}

TEST(ModelViewerCommand, RendersFountainTopAndSideViews) {
  COLMAP_IRAV4_REQUIRE_DATA("strecha/fountain-P11/colmap38_incremental");
  test::TempDir temp;
  const std::string model =
      DataDir() + "/strecha/fountain-P11/colmap38_incremental";
  const std::string png = temp.File("view.png");
  std::string output;
  ASSERT_EQ(RunViewer("--input_path " + model + " --output_path " + png +
                          " --width 1000 --height 500",
                      temp, &output),
            0)
      << output;
  const cv::Mat image = cv::imread(png, cv::IMREAD_COLOR);
  ASSERT_FALSE(image.empty());
  EXPECT_EQ(image.cols, 1000);
  EXPECT_EQ(image.rows, 500);
  for (const cv::Rect& half :
       {cv::Rect(0, 0, 500, 500), cv::Rect(500, 0, 500, 500)}) {
    int non_white = 0, red = 0;
    CountPixels(image, half, &non_white, &red);
    // Thousands of points and 11 frusta in each view; far from blank.
    EXPECT_GT(non_white, 3000);
    EXPECT_LT(non_white, 0.9 * half.area());
    EXPECT_GT(red, 50);
  }
  EXPECT_FALSE(std::filesystem::exists(temp.File(".tmp_view.png")));
}

TEST(ModelViewerCommand, BadInputIsAClearErrorAndWritesNothing) {
  test::TempDir temp;
  std::string output;
  EXPECT_EQ(RunViewer("--input_path " + temp.File("missing") +
                          " --output_path " + temp.File("v.png"),
                      temp, &output),
            1);
  EXPECT_NE(output.find("missing"), std::string::npos) << output;
  EXPECT_FALSE(std::filesystem::exists(temp.File("v.png")));
  // A wrong output extension on a real model (skipped without the data).
  if (!HaveData("strecha/fountain-P11/colmap38_incremental")) return;
  const std::string model =
      DataDir() + "/strecha/fountain-P11/colmap38_incremental";
  EXPECT_EQ(RunViewer("--input_path " + model + " --output_path " +
                          temp.File("v.txt"),
                      temp, &output),
            1);
  EXPECT_NE(output.find(".png"), std::string::npos) << output;
}

TEST(ModelRender, CamerasOfASyntheticCourtyardAreDrawnWhereTheyAre) {
  // Top view of a courtyard: the cameras walk a loop inside the walls, so the
  // centre of the top panel is empty and its border region is not.
  SceneGeneratorOptions options;
  options.num_images = 80;
  options.point_density = 10;
  const GeneratedScene scene = GenerateScene(options);
  ModelRenderOptions render;
  render.width = 800;
  render.height = 400;
  const cv::Mat image = RenderModel(scene.truth, render);
  ASSERT_EQ(image.cols, 800);
  ASSERT_EQ(image.rows, 400);
  int centre_non_white = 0, centre_red = 0;
  CountPixels(image, cv::Rect(170, 170, 60, 60), &centre_non_white,
              &centre_red);
  int all_non_white = 0, all_red = 0;
  CountPixels(image, cv::Rect(0, 0, 400, 400), &all_non_white, &all_red);
  EXPECT_EQ(centre_non_white, 0);
  EXPECT_GT(all_red, 500);
  EXPECT_GT(all_non_white, 5000);
}

}  // namespace
}  // namespace colmap_irav4
