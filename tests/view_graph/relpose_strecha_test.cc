// Relative rotations and translation directions of the epipolar graph of the
// Strecha databases (COLMAP 3.8, qvec/tvec zero: derived from E/F/H) against
// the LIDAR ground truth.

#include <gtest/gtest.h>

#include "colmap_irav4/eval/relative_pose_eval.h"
#include "colmap_irav4/eval/strecha_gt.h"
#include "colmap_irav4/io/database.h"
#include "colmap_irav4/view_graph/view_graph_builder.h"
#include "tests/test_utils/data.h"
#include "tests/test_utils/database_test_utils.h"
#include "tests/test_utils/record.h"

namespace colmap_irav4 {
namespace {

const std::string kStrecha = DataDir() + "/strecha/";

RelativePoseErrors Evaluate(const std::string& scene, bool refine,
                            int expected_pairs) {
  const std::string database_path = kStrecha + scene + "/database.db";
  const uint64_t hash = test::HashFile(database_path);
  const DatabaseContents database = ReadDatabase(database_path);
  std::map<std::string, Rigid3d> gt;
  for (const auto& [name, camera] :
       ReadStrechaGroundTruth(kStrecha + scene + "/gt_cameras")) {
    gt[name] = camera.cam_from_world;
  }
  ViewGraphBuilderOptions options;
  options.relative_pose.refine = refine;
  ViewGraphSummary summary;
  const ViewGraph view_graph = BuildViewGraph(database, options, &summary);
  EXPECT_EQ(test::HashFile(database_path), hash);
  EXPECT_EQ(static_cast<int>(view_graph.pairs.size()), expected_pairs);
  const RelativePoseErrors e = EvaluateRelativePoses(view_graph, gt);
  EXPECT_EQ(e.num_pairs, expected_pairs);
  ::colmap_irav4::test::RecordFiguresF(
      "%-14s refine %-3s: %d pairs, rotation error median %.4f mean %.4f max "
      "%.4f deg, "
      "%d > 5 deg; translation direction median %.4f mean %.4f max %.4f deg "
      "(%zu pairs); transposed-R median %.2f deg\n",
      scene.c_str(), refine ? "on" : "off", e.num_pairs, e.rotation_median_deg,
      e.rotation_mean_deg, e.rotation_max_deg, e.num_rotation_over_5deg,
      e.translation_median_deg, e.translation_mean_deg, e.translation_max_deg,
      e.translation_errors_deg.size(), e.rotation_median_transposed_deg);
  return e;
}

void ExpectAccurate(const RelativePoseErrors& e) {
  EXPECT_LT(e.rotation_median_deg, 0.5);
  EXPECT_EQ(e.num_rotation_over_5deg, 0);
  // Every pair has a translation (no pure rotation in these scenes).
  EXPECT_EQ(static_cast<int>(e.translation_errors_deg.size()), e.num_pairs);
  EXPECT_LT(e.translation_median_deg, 1.0);
  // Direction of R: against R_i R_j^T instead of R_j R_i^T the errors are
  // large (the views differ by tens of degrees).
  EXPECT_GT(e.rotation_median_transposed_deg, 10.0);
}

TEST(RelposeStrecha, FountainP11) {
  COLMAP_IRAV4_REQUIRE_DATA("strecha/fountain-P11");
  // Every one of the 55 verified pairs is kept (all have >= 15 inliers).
  ExpectAccurate(Evaluate("fountain-P11", true, 55));
  ExpectAccurate(Evaluate("fountain-P11", false, 55));
}

TEST(RelposeStrecha, HerzJesusP8) {
  COLMAP_IRAV4_REQUIRE_DATA("strecha/Herz-Jesus-P8");
  ExpectAccurate(Evaluate("Herz-Jesus-P8", true, 28));
  ExpectAccurate(Evaluate("Herz-Jesus-P8", false, 28));
}

}  // namespace
}  // namespace colmap_irav4
