#include "colmap_irav4/util/progress_bar.h"

#include <sstream>

#include <gtest/gtest.h>

namespace colmap_irav4 {
namespace {

int CountLines(const std::string& text) {
  return static_cast<int>(std::count(text.begin(), text.end(), '\n'));
}

TEST(ProgressBar, LogModePrintsOneLinePerTenPercent) {
  std::ostringstream out;
  ProgressBar bar("positioning", 1000, true, &out, /*interactive=*/0);
  for (int done = 0; done <= 1000; ++done) bar.Update(done);
  bar.Finish();
  // 0%, 10%, ..., 100%: eleven lines, however many updates.
  EXPECT_EQ(CountLines(out.str()), 11);
  EXPECT_NE(out.str().find("positioning: 50% (500/1000)"), std::string::npos);
  EXPECT_NE(out.str().find("positioning: 100% (1000/1000)"), std::string::npos);
}

TEST(ProgressBar, InteractiveModeRedrawsOneLine) {
  std::ostringstream out;
  ProgressBar bar("bundle adjustment", 4, true, &out, /*interactive=*/1);
  for (int done = 1; done <= 4; ++done) bar.Update(done);
  bar.Finish();
  const std::string text = out.str();
  EXPECT_EQ(CountLines(text), 1);  // only the final newline
  EXPECT_NE(text.find("\rbundle adjustment ["), std::string::npos);
  EXPECT_NE(text.find("100% (4/4)"), std::string::npos);
}

TEST(ProgressBar, DisabledPrintsNothingAndClamps) {
  std::ostringstream out;
  {
    ProgressBar bar("x", 10, false, &out, 0);
    bar.Update(50);
    bar.Finish();
  }
  EXPECT_TRUE(out.str().empty());
}

}  // namespace
}  // namespace colmap_irav4
