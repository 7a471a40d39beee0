// The stages after rotation averaging on real data: the Strecha scenes'
// COLMAP 3.8 databases (keypoints, verified inlier matches) with the ground
// truth rotations perturbed by 0.05 deg (the accuracy class of the rotation
// averaging) -> tracks -> global positioning -> bundle adjustment ->
// retriangulation -> bundle adjustment -> filtering, compared with the LIDAR
// ground truth cameras.

#include <iostream>
#include <random>

#include <gtest/gtest.h>

#include "colmap_irav4/eval/model_alignment.h"
#include "colmap_irav4/eval/strecha_gt.h"
#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/io/database.h"
#include "colmap_irav4/io/model_io.h"
#include "colmap_irav4/positioning/global_positioning.h"
#include "colmap_irav4/positioning/track_builder.h"
#include "colmap_irav4/refinement/bundle_adjustment.h"
#include "colmap_irav4/refinement/filtering.h"
#include "colmap_irav4/refinement/triangulation.h"
#include "colmap_irav4/scene/reconstruction_utils.h"
#include "colmap_irav4/util/timer.h"
#include "tests/test_utils/data.h"
#include "tests/test_utils/record.h"

namespace colmap_irav4 {
namespace {

void RunScene(const std::string& scene) {
  const std::string dir = DataDir() + "/strecha/" + scene;
  const DatabaseContents database = ReadDatabase(dir + "/database.db");
  const std::map<std::string, StrechaCamera> gt =
      ReadStrechaGroundTruth(dir + "/gt_cameras");

  StrechaStart start = MakeStrechaStart(database, gt, dir + "/gt_cameras",
                                        /*rotation_noise_deg=*/0.05,
                                        /*seed=*/1);
  Reconstruction& reconstruction = start.reconstruction;
  const std::vector<ImagePairMatches>& pairs = start.pairs;

  Timer timer;
  const std::vector<Track> tracks =
      BuildTracks(TrackBuilderOptions(), pairs, reconstruction.images);
  AddTracksToReconstruction(tracks, &reconstruction);
  const double tracks_seconds = timer.ElapsedSeconds();
  GlobalPositionerSummary positioning;
  GlobalPositionerOptions gp_options;
  ASSERT_TRUE(RunGlobalPositioning(gp_options, &reconstruction, &positioning));
  BundleAdjustmentOptions ba_options;
  BundleAdjustmentSummary ba1, ba2;
  ASSERT_TRUE(RunBundleAdjustment(ba_options, &reconstruction, &ba1));
  Timer retriangulation_timer;
  const TriangulationSummary retriangulation =
      TriangulateTracks(TriangulationOptions(), tracks, &reconstruction);
  const double retriangulation_seconds = retriangulation_timer.ElapsedSeconds();
  ASSERT_TRUE(RunBundleAdjustment(ba_options, &reconstruction, &ba2));
  RunFiltering(FilterOptions(), &reconstruction);
  const double mean_reproj_error = UpdateReprojectionErrors(&reconstruction);
  const double seconds = timer.ElapsedSeconds();

  std::map<std::string, Rigid3d> reference;
  for (const auto& [name, camera] : gt) reference[name] = camera.cam_from_world;
  PoseComparison comparison;
  ASSERT_TRUE(ComparePoses(PosesByName(reconstruction), reference,
                           SimilarityRansacOptions(), &comparison));
  COLMAP_IRAV4_FIGURES << scene << ": " << tracks.size() << " tracks ("
                       << tracks_seconds << " s), positioning "
                       << positioning.num_points << " points "
                       << positioning.seconds << " s, BA "
                       << ba1.initial_mean_reproj_error << " -> "
                       << ba1.final_mean_reproj_error << " px " << ba1.seconds
                       << " s, retriangulation "
                       << retriangulation.num_points_added << " points "
                       << retriangulation_seconds << " s, BA " << ba2.seconds
                       << " s; " << reconstruction.images.size() << " images, "
                       << reconstruction.points3D.size()
                       << " points, mean track "
                       << MeanTrackLength(reconstruction) << ", reprojection "
                       << mean_reproj_error << " px; rotation error median/max "
                       << comparison.rotation_error_median_deg << " / "
                       << comparison.rotation_error_max_deg
                       << " deg, centre error median/max "
                       << 1000 * comparison.center_error_median << " / "
                       << 1000 * comparison.center_error_max << " mm; total "
                       << seconds << " s\n";
  // COLMAP 3.8's incremental model of the same database, measured the same way.
  PoseComparison colmap_comparison;
  ASSERT_TRUE(ComparePoses(
      PosesByName(ReadReconstruction(dir + "/colmap38_incremental")), reference,
      SimilarityRansacOptions(), &colmap_comparison));
  COLMAP_IRAV4_FIGURES << scene
                       << " COLMAP 3.8 incremental: rotation error median/max "
                       << colmap_comparison.rotation_error_median_deg << " / "
                       << colmap_comparison.rotation_error_max_deg
                       << " deg, centre error median/max "
                       << 1000 * colmap_comparison.center_error_median << " / "
                       << 1000 * colmap_comparison.center_error_max << " mm\n";
  EXPECT_EQ(reconstruction.images.size(), database.images.size());
  EXPECT_EQ(comparison.num_common, static_cast<int>(database.images.size()));
  // The bounds for the whole mapper: centres under 1 cm, reprojection
  // under 1 px. Rotations: as accurate as COLMAP's model measured the same
  // way (after the similarity alignment on centres, COLMAP's own Herz-Jesus
  // model shows 0.10 deg: the alignment, not the model, sets that figure).
  EXPECT_LT(comparison.rotation_error_median_deg,
            std::max(0.1, 1.1 * colmap_comparison.rotation_error_median_deg));
  EXPECT_LT(comparison.center_error_median, 0.01);
  EXPECT_LT(comparison.center_error_median,
            1.2 * colmap_comparison.center_error_median);
  EXPECT_LT(mean_reproj_error, 1.0);
}

TEST(StrechaPositioning, FountainP11) {
  COLMAP_IRAV4_REQUIRE_DATA("strecha/fountain-P11");
  RunScene("fountain-P11");
}
TEST(StrechaPositioning, HerzJesusP8) {
  COLMAP_IRAV4_REQUIRE_DATA("strecha/Herz-Jesus-P8");
  RunScene("Herz-Jesus-P8");
}

}  // namespace
}  // namespace colmap_irav4
