#include "colmap_irav4/util/run_summary.h"

#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace colmap_irav4 {
namespace {

TEST(RunSummary, ProcessMemoryGrowsWithAnAllocationTouched) {
  const ProcessMemory before = ReadProcessMemory();
  ASSERT_GT(before.peak_mib, 0);
  EXPECT_GE(before.peak_mib, before.current_mib);
  // 64 MiB written (not only reserved) must show in the resident figures.
  std::vector<char> block(64 << 20, 1);
  const ProcessMemory after = ReadProcessMemory();
  EXPECT_GE(after.peak_mib, before.current_mib + 60);
#ifdef __linux__
  EXPECT_GE(after.current_mib, before.current_mib + 60);
#endif
  EXPECT_EQ(block[block.size() / 2], 1);
}

TEST(RunSummary, StageTimerRecordsThePeakItRaises) {
  std::vector<StageReport> stages;
  {
    StageTimer stage("allocating");
    // Larger than anything this test binary held before (at most the 64 MiB
    // of the test above): the peak rises by 190 MiB at least.
    std::vector<char> block(256 << 20, 1);
    EXPECT_EQ(block[1], 1);
    stage.Finish("", &stages);
  }
  {
    StageTimer stage("idle");
    stage.Finish("", &stages);
  }
  ASSERT_EQ(stages.size(), 2u);
  EXPECT_GE(stages[0].peak_rise_mib, 150);
  EXPECT_GE(stages[0].peak_memory_mib, 256);
  // The kernel's counters lag by a few pages: not exactly equal.
  EXPECT_LT(stages[1].peak_rise_mib, 1);
  EXPECT_NEAR(stages[1].peak_memory_mib, stages[0].peak_memory_mib, 1);
  EXPECT_NE(stages[0].LogLine().find("peak "), std::string::npos);
  EXPECT_EQ(PeakMemoryStage({&stages}), "allocating");

  std::ostringstream json;
  AppendStagesJson(stages, "", &json);
  EXPECT_NE(json.str().find("\"peak_memory_mib\": "), std::string::npos);
  EXPECT_NE(json.str().find("\"memory_mib\": "), std::string::npos);
  EXPECT_NE(json.str().find("\"peak_rise_mib\": "), std::string::npos);
}

TEST(RunSummary, PeakMemoryStageIsTheStageThatReachedTheHighestPeak) {
  StageReport database("database"), tracks("tracks"), ba("bundle adjustment");
  database.peak_memory_mib = 100;
  database.peak_rise_mib = 100;
  tracks.peak_memory_mib = 300;
  tracks.peak_rise_mib = 200;
  ba.peak_memory_mib = 300.01;  // reached before; the counters' lag
  ba.peak_rise_mib = 0.01;
  const std::vector<StageReport> top = {database};
  const std::vector<StageReport> model = {tracks, ba};
  EXPECT_EQ(PeakMemoryStage({&top, &model}), "tracks");
  EXPECT_EQ(PeakMemoryStage({&model, &top}), "tracks");
  EXPECT_EQ(PeakMemoryStage({}), "");
}

}  // namespace
}  // namespace colmap_irav4
