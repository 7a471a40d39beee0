#include "colmap_irav4/positioning/global_positioning.h"

#include <random>

#include <gtest/gtest.h>

#include "colmap_irav4/eval/model_alignment.h"
#include "colmap_irav4/eval/synthetic_scene.h"
#include "colmap_irav4/positioning/track_builder.h"
#include "colmap_irav4/scene/reconstruction_utils.h"
#include "colmap_irav4/util/error.h"
#include "tests/test_utils/scene_test_utils.h"

namespace colmap_irav4 {
namespace {

using test::MaxRelativeCenterError;

Reconstruction PrepareFromTracks(const SyntheticScene& scene) {
  Reconstruction reconstruction = StripPoints(scene.truth);
  for (auto& [image_id, image] : reconstruction.images) {
    image.cam_from_world.translation.setZero();  // unknown
  }
  AddTracksToReconstruction(
      BuildTracks(TrackBuilderOptions(), scene.matches, reconstruction.images),
      &reconstruction);
  return reconstruction;
}

// 15 images, 500 points each seen by ~60% of them.
SyntheticSceneOptions SceneOptions() {
  SyntheticSceneOptions options;
  options.num_images = 15;
  options.num_points = 500;
  options.visibility = 0.6;
  return options;
}

TEST(GlobalPositioning, RecoversCentersOfExactScene) {
  const SyntheticSceneOptions scene_options = SceneOptions();
  const SyntheticScene scene = GenerateSyntheticScene(scene_options);
  Reconstruction reconstruction = PrepareFromTracks(scene);
  GlobalPositionerOptions options;
  // Exact data: solved to tight tolerances the cost's minimum is the truth.
  options.solver.ceres.function_tolerance = 1e-10;
  options.solver.ceres.parameter_tolerance = 1e-10;
  GlobalPositionerSummary summary;
  ASSERT_TRUE(RunGlobalPositioning(options, &reconstruction, &summary));
  EXPECT_EQ(summary.num_images, 15);
  EXPECT_EQ(reconstruction.images.size(), 15u);
  EXPECT_LT(MaxRelativeCenterError(reconstruction, scene.truth,
                                   scene_options.arc_radius),
            1e-4);
  // Rotations are untouched.
  for (const auto& [image_id, image] : reconstruction.images) {
    EXPECT_LT(image.cam_from_world.rotation.angularDistance(
                  scene.truth.images.at(image_id).cam_from_world.rotation),
              1e-12);
  }
}

TEST(GlobalPositioning, RobustToNoiseAndWrongMatches) {
  SyntheticSceneOptions scene_options = SceneOptions();
  scene_options.num_points = 800;
  scene_options.noise_px = 1.0;
  scene_options.outlier_match_ratio = 0.002;
  const SyntheticScene scene = GenerateSyntheticScene(scene_options);
  Reconstruction reconstruction = PrepareFromTracks(scene);
  // Add 10% wrong observations to the kept tracks: a random keypoint of
  // another image that is not yet in the track.
  std::mt19937_64 rng(3);
  int num_added = 0;
  const size_t num_points = reconstruction.points3D.size();
  for (auto& [point3D_id, point] : reconstruction.points3D) {
    if (num_added >= static_cast<int>(0.1 * NumObservations(reconstruction)))
      break;
    std::uniform_int_distribution<image_t> image_dist(1, 15);
    const image_t image_id = image_dist(rng);
    bool present = false;
    for (const auto& element : point.track)
      present |= element.image_id == image_id;
    if (present) continue;
    Image& image = reconstruction.images.at(image_id);
    std::uniform_int_distribution<point2D_t> idx_dist(
        0, image.points2D.size() - 1);
    const point2D_t idx = idx_dist(rng);
    if (image.points2D[idx].point3D_id != kInvalidPoint3DId) continue;
    image.points2D[idx].point3D_id = point3D_id;
    point.track.push_back({image_id, idx});
    ++num_added;
  }
  ASSERT_GT(num_added, static_cast<int>(0.05 * num_points));
  ASSERT_GT(num_points, 300u);
  GlobalPositionerOptions options;
  GlobalPositionerSummary summary;
  ASSERT_TRUE(RunGlobalPositioning(options, &reconstruction, &summary));
  EXPECT_EQ(reconstruction.images.size(), 15u);
  EXPECT_LT(MaxRelativeCenterError(reconstruction, scene.truth,
                                   scene_options.arc_radius),
            0.005);
  EXPECT_GT(summary.num_observations_filtered, num_added / 2);
}

TEST(GlobalPositioning, DropsShortTracksAndUnobservedImages) {
  SyntheticSceneOptions scene_options;
  scene_options.num_images = 5;
  scene_options.num_points = 200;
  const SyntheticScene scene = GenerateSyntheticScene(scene_options);
  Reconstruction reconstruction = PrepareFromTracks(scene);
  // Image 5 keeps only 2-view observations: unlink all others.
  for (point2D_t idx = 0; idx < reconstruction.images.at(5).points2D.size();
       ++idx) {
    DeleteObservation(5, idx, &reconstruction);
  }
  Image extra;
  extra.image_id = 6;
  extra.camera_id = 1;
  reconstruction.images[6] = extra;
  GlobalPositionerSummary summary;
  ASSERT_TRUE(RunGlobalPositioning(GlobalPositionerOptions(), &reconstruction,
                                   &summary));
  EXPECT_EQ(summary.num_images_dropped, 2);
  EXPECT_EQ(reconstruction.images.size(), 4u);
}

TEST(GlobalPositioning, SameBitsWhereverTheModelIsOnTheHeap) {
  // Ceres orders the blocks of an elimination group by address: solved in
  // place, a copy laid out otherwise would differ in the last bits.
  SyntheticSceneOptions scene_options = SceneOptions();
  scene_options.noise_px = 1.0;
  Reconstruction a = PrepareFromTracks(GenerateSyntheticScene(scene_options));
  Reconstruction b = test::CopyInReverseOrder(a);
  GlobalPositionerOptions options;
  options.solver.ceres.num_threads = 1;
  ASSERT_TRUE(RunGlobalPositioning(options, &a));
  ASSERT_TRUE(RunGlobalPositioning(options, &b));
  test::ExpectSameBits(a, b);
}

TEST(GlobalPositioning, OptionsCheck) {
  GlobalPositionerOptions options;
  EXPECT_NO_THROW(options.Check());
  EXPECT_FALSE(ParseEnum("l7", &options.loss_function));
  options = GlobalPositionerOptions();
  options.min_track_length = 1;
  EXPECT_THROW(options.Check(), InputError);
  options = GlobalPositionerOptions();
  options.iterative_schur_min_density = -0.1;
  EXPECT_THROW(options.Check(), OptionError);
  options = GlobalPositionerOptions();
  options.iterative_schur_dense_min_num_images = -1;
  EXPECT_THROW(options.Check(), OptionError);
  options = GlobalPositionerOptions();
  options.iterative_schur_min_pairs_per_image = -1;
  EXPECT_THROW(options.Check(), OptionError);
  options = GlobalPositionerOptions();
  options.iterative_schur_min_products_per_observation = -1;
  EXPECT_THROW(options.Check(), OptionError);
  EXPECT_TRUE(ParseEnum("iterative_schur", &options.linear_solver));
  EXPECT_EQ(options.linear_solver, PositioningLinearSolver::kIterativeSchur);
}

TEST(GlobalPositioning, ChoosesTheLinearSolverBySizeAndDensity) {
  GlobalPositionerOptions options;
  options.iterative_schur_min_num_images = 5000;
  options.iterative_schur_dense_min_num_images = 2000;
  options.iterative_schur_min_density = 0.2;
  options.iterative_schur_min_pairs_per_image = 500;
  // The defaults: the 5,000-image photo scene (4,953 images, 8.8% of the
  // pairs) iterative, the 1,000-image one (990, 16.3%) sparse.
  ceres::Solver::Options defaults;
  ChoosePositioningLinearSolver(GlobalPositionerOptions(), 4953, 0.088,
                                &defaults);
  EXPECT_EQ(defaults.linear_solver_type, ceres::ITERATIVE_SCHUR);
  ChoosePositioningLinearSolver(GlobalPositionerOptions(), 990, 0.163,
                                &defaults);
  EXPECT_EQ(defaults.linear_solver_type, ceres::SPARSE_SCHUR);
  // Its re-mapping after the fold cut (4,935 images, 4.97%) iterative, the
  // 3,000-image courtyard (1.4%) sparse.
  ChoosePositioningLinearSolver(GlobalPositionerOptions(), 4935, 0.0497,
                                &defaults);
  EXPECT_EQ(defaults.linear_solver_type, ceres::ITERATIVE_SCHUR);
  ChoosePositioningLinearSolver(GlobalPositionerOptions(), 3000, 0.014,
                                &defaults);
  EXPECT_EQ(defaults.linear_solver_type, ceres::SPARSE_SCHUR);
  // The 10,000-image photo scene re-mapped after its fold cut (9,904
  // images, 3.7%: 366 pairs an image) iterative by its pairs per image; a
  // 10,000-image courtyard (0.4%, 40 an image) sparse.
  ChoosePositioningLinearSolver(GlobalPositionerOptions(), 9904, 0.037,
                                &defaults);
  EXPECT_EQ(defaults.linear_solver_type, ceres::ITERATIVE_SCHUR);
  ChoosePositioningLinearSolver(GlobalPositionerOptions(), 10000, 0.004,
                                &defaults);
  EXPECT_EQ(defaults.linear_solver_type, ceres::SPARSE_SCHUR);
  // Photo 1,000 (993 images, 12.2%, 12.7 block products an observation)
  // sparse; one 2,000-image landmark (1,992, 27.7%, 45.9) iterative by its
  // long tracks, under the density rule's 2,000 images.
  ChoosePositioningLinearSolver(GlobalPositionerOptions(), 993, 0.122,
                                &defaults, 12.7);
  EXPECT_EQ(defaults.linear_solver_type, ceres::SPARSE_SCHUR);
  ChoosePositioningLinearSolver(GlobalPositionerOptions(), 1992, 0.277,
                                &defaults, 45.9);
  EXPECT_EQ(defaults.linear_solver_type, ceres::ITERATIVE_SCHUR);
  auto choose = [&](int num_images, double density,
                    ceres::Solver::Options* ceres_options) {
    return ChoosePositioningLinearSolver(options, num_images, density,
                                         ceres_options);
  };
  ceres::Solver::Options ceres_options;
  choose(30, 1.0, &ceres_options);
  EXPECT_EQ(ceres_options.linear_solver_type, ceres::DENSE_SCHUR);
  // The 1,000-image courtyard or photo scene: sparse Cholesky is cheap.
  choose(1000, 0.6, &ceres_options);
  EXPECT_EQ(ceres_options.linear_solver_type, ceres::SPARSE_SCHUR);
  choose(3000, 0.05, &ceres_options);
  EXPECT_EQ(ceres_options.linear_solver_type, ceres::SPARSE_SCHUR);
  // Under the density's 0.2 but 0.15 x 3,999 = 600 pairs an image: iterative
  // by the pairs per image.
  ceres_options = ceres::Solver::Options();
  const std::string by_pairs = choose(4000, 0.15, &ceres_options);
  EXPECT_EQ(ceres_options.linear_solver_type, ceres::ITERATIVE_SCHUR);
  EXPECT_NE(by_pairs.find("15.0% of pairs share a point, 600 an image"),
            std::string::npos)
      << by_pairs;
  // Dense and large: neither the reduced system nor its factor is stored.
  ceres_options = ceres::Solver::Options();
  const std::string dense = choose(3000, 0.4, &ceres_options);
  EXPECT_EQ(ceres_options.linear_solver_type, ceres::ITERATIVE_SCHUR);
  EXPECT_EQ(ceres_options.preconditioner_type, ceres::SCHUR_JACOBI);
  EXPECT_FALSE(ceres_options.use_explicit_schur_complement);
  EXPECT_NE(dense.find("dense reduced camera system"), std::string::npos)
      << dense;
  EXPECT_NE(dense.find("3000 images, 40.0% of pairs"), std::string::npos)
      << dense;
  // Large whatever the density (or unknown).
  const std::string large = choose(6000, -1, &ceres_options);
  EXPECT_EQ(ceres_options.linear_solver_type, ceres::ITERATIVE_SCHUR);
  EXPECT_NE(large.find("at least 5000 images"), std::string::npos) << large;
  // Long tracks at any size (from 50 images) once the rule is on.
  ceres_options = ceres::Solver::Options();
  choose(1000, 0.05, &ceres_options);
  EXPECT_EQ(ceres_options.linear_solver_type, ceres::SPARSE_SCHUR);
  options.iterative_schur_min_products_per_observation = 20;
  const auto by_products = [&](double products) {
    ceres::Solver::Options choice;
    const std::string reason =
        ChoosePositioningLinearSolver(options, 1000, 0.05, &choice, products);
    return std::make_pair(choice.linear_solver_type, reason);
  };
  EXPECT_EQ(by_products(19.9).first, ceres::SPARSE_SCHUR);
  const auto [long_tracks, long_reason] = by_products(20);
  EXPECT_EQ(long_tracks, ceres::ITERATIVE_SCHUR);
  EXPECT_NE(long_reason.find("long tracks"), std::string::npos) << long_reason;
  EXPECT_NE(long_reason.find("20.0 block products an observation"),
            std::string::npos)
      << long_reason;
  EXPECT_EQ(by_products(-1).first, ceres::SPARSE_SCHUR);  // not counted
  ceres::Solver::Options few;
  ChoosePositioningLinearSolver(options, 40, 0.9, &few, 100);
  EXPECT_EQ(few.linear_solver_type, ceres::DENSE_SCHUR);
  options.iterative_schur_min_products_per_observation = 0;  // off
  EXPECT_EQ(by_products(1000).first, ceres::SPARSE_SCHUR);
  // Asked: whatever the size.
  options.linear_solver = PositioningLinearSolver::kSparseSchur;
  choose(6000, 0.9, &ceres_options);
  EXPECT_EQ(ceres_options.linear_solver_type, ceres::SPARSE_SCHUR);
  options.linear_solver = PositioningLinearSolver::kIterativeSchur;
  choose(60, 0.01, &ceres_options);
  EXPECT_EQ(ceres_options.linear_solver_type, ceres::ITERATIVE_SCHUR);
}

TEST(GlobalPositioning, SchurDensityCountsThePairsSharingAPoint) {
  Reconstruction reconstruction;
  Camera camera;
  camera.camera_id = 1;
  reconstruction.cameras[1] = camera;
  for (image_t image_id = 1; image_id <= 4; ++image_id) {
    Image image;
    image.image_id = image_id;
    image.camera_id = 1;
    image.points2D.resize(2);
    reconstruction.images[image_id] = image;
  }
  EXPECT_EQ(PositioningSchurDensity(reconstruction), 0.0);
  // Tracks (1, 2, 3) and (3, 4): pairs 12, 13, 23, 34 of 6.
  AddTracksToReconstruction({{{1, 0}, {2, 0}, {3, 0}}, {{3, 1}, {4, 0}}},
                            &reconstruction);
  EXPECT_DOUBLE_EQ(PositioningSchurDensity(reconstruction), 4.0 / 6.0);
  EXPECT_EQ(PositioningSchurDensity(reconstruction, 3), -1.0);
  // Block products 3 * 4 / 2 + 2 * 3 / 2 = 9 over 5 observations; without
  // image 4, 6 + 1 over 4.
  EXPECT_DOUBLE_EQ(SchurProductsPerObservation(reconstruction), 9.0 / 5.0);
  reconstruction.images.erase(4);
  EXPECT_DOUBLE_EQ(SchurProductsPerObservation(reconstruction), 7.0 / 4.0);
}

TEST(GlobalPositioning, ChoosesTheSolverByTheDensityGivenInsteadOfCounted) {
  // The mapper gives the density of the tracks before the per-image cap
  // thins them; the choice must follow it, not the thinned points'.
  SyntheticSceneOptions scene_options = SceneOptions();
  scene_options.num_images = 50;
  scene_options.num_points = 300;
  const SyntheticScene scene = GenerateSyntheticScene(scene_options);
  GlobalPositionerOptions options;
  options.iterative_schur_dense_min_num_images = 50;
  options.iterative_schur_min_density = 0.5;
  options.solver.ceres.max_num_iterations = 2;  // only the choice matters
  Reconstruction counted = PrepareFromTracks(scene);
  const double density = PositioningSchurDensity(counted);
  ASSERT_GE(density, 0.5);
  GlobalPositionerSummary summary;
  ASSERT_TRUE(RunGlobalPositioning(options, &counted, &summary));
  EXPECT_DOUBLE_EQ(summary.schur_density, density);
  EXPECT_EQ(summary.linear_solver, "ITERATIVE_SCHUR");
  Reconstruction given = PrepareFromTracks(scene);
  ASSERT_TRUE(RunGlobalPositioning(options, &given, &summary, nullptr, 0.1));
  EXPECT_DOUBLE_EQ(summary.schur_density, 0.1);
  EXPECT_EQ(summary.linear_solver, "SPARSE_SCHUR");
}

TEST(GlobalPositioning, IterativeSchurRecoversTheSameCenters) {
  const SyntheticSceneOptions scene_options = SceneOptions();
  const SyntheticScene scene = GenerateSyntheticScene(scene_options);
  Reconstruction reconstruction = PrepareFromTracks(scene);
  GlobalPositionerOptions options;
  options.linear_solver = PositioningLinearSolver::kIterativeSchur;
  options.solver.ceres.function_tolerance = 1e-10;
  options.solver.ceres.parameter_tolerance = 1e-10;
  GlobalPositionerSummary summary;
  ASSERT_TRUE(RunGlobalPositioning(options, &reconstruction, &summary));
  EXPECT_EQ(summary.linear_solver, "ITERATIVE_SCHUR");
  EXPECT_NE(summary.linear_solver_reason.find("asked"), std::string::npos);
  EXPECT_EQ(reconstruction.images.size(), 15u);
  EXPECT_LT(MaxRelativeCenterError(reconstruction, scene.truth,
                                   scene_options.arc_radius),
            1e-4);
}

}  // namespace
}  // namespace colmap_irav4
