// The Schur solver (BundleAdjustmentOptions::solver_backend schur) against
// the Ceres path: the same optimum on small synthetic scenes, the gauge and
// the held parameters kept, pose priors under their loss, and the losses it
// cannot hold sent to Ceres; its two factorisations of the reduced camera
// system (simplicial, supernodal) give the same solution, and so do its two
// accumulations of that system (cell tables, cell search), and so do its
// Jacobians kept or evaluated again; after a rejected
// undamped first step the radii its damping cannot change are skipped; its
// iterative solver (conjugate gradients) reaches the factorisations'
// solution, and auto chooses it above the factor's memory budget; its
// pair updates listed and prefetched or run as found give the same
// solution to the bit; its implicit product (the reduced system not formed)
// the formed system's solution; both
// backends stop a solve whose cost has stalled.

#include "colmap_irav4/refinement/schur_bundle_adjuster.h"

#include <cmath>
#include <functional>
#include <initializer_list>
#include <iterator>
#include <map>
#include <random>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "colmap_irav4/eval/synthetic_scene.h"
#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/refinement/bundle_adjustment.h"
#include "colmap_irav4/refinement/implicit_product.h"
#include "colmap_irav4/scene/camera_models.h"
#include "colmap_irav4/scene/reconstruction_utils.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/random.h"
#include "tests/test_utils/scene_test_utils.h"

namespace colmap_irav4 {
namespace {

using test::PerturbModel;

SyntheticScene Scene(int camera_model_id = 1, bool shared_camera = true) {
  SyntheticSceneOptions options;
  options.num_images = 12;
  options.num_points = 600;
  options.visibility = 0.7;
  options.noise_px = 1.0;
  options.camera_model_id = camera_model_id;
  if (camera_model_id != 1) options.extra_param = -0.05;
  options.shared_camera = shared_camera;
  return GenerateSyntheticScene(options);
}

// Converged tightly: the optimum, whatever the path.
BundleAdjustmentOptions TightOptions() {
  BundleAdjustmentOptions options;
  options.solver.ceres.function_tolerance = 1e-14;
  options.solver.ceres.gradient_tolerance = 1e-14;
  options.solver.ceres.parameter_tolerance = 1e-14;
  options.solver.ceres.num_threads = 1;
  return options;
}

struct Difference {
  double center = 0;        // largest, no alignment (same gauge)
  double rotation_deg = 0;  // largest
  double point = 0;         // largest
  double param = 0;         // largest relative camera parameter difference
};

Difference Compare(const Reconstruction& a, const Reconstruction& b) {
  Difference d;
  for (const auto& [image_id, image] : a.images) {
    const Image& other = b.images.at(image_id);
    d.center = std::max(
        d.center, (image.ProjectionCenter() - other.ProjectionCenter()).norm());
    d.rotation_deg = std::max(
        d.rotation_deg, RadToDeg(image.cam_from_world.rotation.angularDistance(
                            other.cam_from_world.rotation)));
  }
  EXPECT_EQ(a.points3D.size(), b.points3D.size());
  for (const auto& [point3D_id, point] : a.points3D) {
    const auto it = b.points3D.find(point3D_id);
    if (it == b.points3D.end()) continue;
    d.point = std::max(d.point, (point.xyz - it->second.xyz).norm());
  }
  for (const auto& [camera_id, camera] : a.cameras) {
    const Camera& other = b.cameras.at(camera_id);
    for (size_t i = 0; i < camera.params.size(); ++i) {
      d.param =
          std::max(d.param, std::abs(camera.params[i] - other.params[i]) /
                                std::max(1.0, std::abs(camera.params[i])));
    }
  }
  return d;
}

// The same model to the bit.
void ExpectSameBits(const Reconstruction& a, const Reconstruction& b) {
  const Difference d = Compare(a, b);
  EXPECT_EQ(d.center, 0.0);
  EXPECT_EQ(d.rotation_deg, 0.0);
  EXPECT_EQ(d.point, 0.0);
  EXPECT_EQ(d.param, 0.0);
}

// Both backends from the same start; returns their summaries.
std::pair<BundleAdjustmentSummary, BundleAdjustmentSummary> RunBoth(
    BundleAdjustmentOptions options, Reconstruction* ceres_model,
    Reconstruction* schur_model, const PosePriors* priors = nullptr) {
  BundleAdjustmentSummary ceres_summary, schur_summary;
  options.solver_backend = BundleAdjustmentSolverBackend::kCeres;
  EXPECT_TRUE(
      RunBundleAdjustment(options, ceres_model, &ceres_summary, priors));
  options.solver_backend = BundleAdjustmentSolverBackend::kSchur;
  EXPECT_TRUE(
      RunBundleAdjustment(options, schur_model, &schur_summary, priors));
  EXPECT_EQ(ceres_summary.backend, "ceres");
  EXPECT_EQ(schur_summary.backend, "schur");
  return {ceres_summary, schur_summary};
}

// The same mean reprojection error and model, to the solves' tolerance.
void ExpectSameOptimum(const BundleAdjustmentSummary& ceres_summary,
                       const BundleAdjustmentSummary& schur_summary,
                       const Reconstruction& ceres_model,
                       const Reconstruction& schur_model) {
  EXPECT_NEAR(schur_summary.final_mean_reproj_error,
              ceres_summary.final_mean_reproj_error, 1e-9);
  const Difference d = Compare(ceres_model, schur_model);
  EXPECT_LT(d.center, 1e-7);  // scene radius 10
  EXPECT_LT(d.rotation_deg, 1e-7);
  EXPECT_LT(d.point, 1e-6);
  EXPECT_LT(d.param, 1e-9);
}

// Default options (IRLS Huber, three rounds of filtering, keypoint scale
// weighting off: the scene has no scales) on a perturbed model with wrong
// observations: the same observations filtered and the same optimum.
TEST(SchurBundleAdjuster, SameOptimumAsCeresWithTheDefaultLoss) {
  const SyntheticScene scene = Scene();
  Reconstruction start = scene.truth;
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  for (auto& [image_id, image] : start.images) {
    for (Point2D& point2D : image.points2D) {
      if (uniform(rng) < 0.05) point2D.xy += Eigen::Vector2d(40, -30);
    }
  }
  PerturbModel(1.0, 0.1, 0.05, 1.03, 5, &start);
  Reconstruction ceres_model = start, schur_model = start;
  const auto [ceres_summary, schur_summary] =
      RunBoth(TightOptions(), &ceres_model, &schur_model);
  EXPECT_GT(ceres_summary.num_observations_filtered, 100);
  EXPECT_EQ(schur_summary.num_observations_filtered,
            ceres_summary.num_observations_filtered);
  EXPECT_EQ(schur_summary.num_rounds, ceres_summary.num_rounds);
  ExpectSameOptimum(ceres_summary, schur_summary, ceres_model, schur_model);
  // The focal length moved back from 3% off.
  EXPECT_NEAR(CameraMeanFocalLength(schur_model.cameras.at(1)), 1200.0, 3.0);
}

// A camera model with distortion, one camera per image, principal points
// refined too, poses as rotation and translation; least squares.
TEST(SchurBundleAdjuster, SameOptimumWithDistortionAndTranslations) {
  const SyntheticScene scene =
      Scene(CameraModelNameToId("SIMPLE_RADIAL"), /*shared_camera=*/false);
  Reconstruction start = scene.truth;
  PerturbModel(0.3, 0.05, 0.02, 1.02, 6, &start);
  for (auto& [camera_id, camera] : start.cameras) camera.params[3] = 0.0;
  BundleAdjustmentOptions options = TightOptions();
  options.loss_function = BundleAdjustmentLoss::kTrivial;
  options.max_reproj_error = 0;
  options.refine_principal_point = true;
  options.parameterize_centers = false;
  Reconstruction ceres_model = start, schur_model = start;
  RunBoth(options, &ceres_model, &schur_model);
  const Difference d = Compare(ceres_model, schur_model);
  EXPECT_LT(d.center, 1e-7);
  EXPECT_LT(d.rotation_deg, 1e-7);
  EXPECT_LT(d.point, 1e-6);
  EXPECT_LT(d.param, 1e-8);
  for (const auto& [camera_id, camera] : schur_model.cameras) {
    EXPECT_NEAR(camera.params[3], -0.05, 0.02);
  }
}

// The gauge: the first image's pose bit for bit, and one coordinate of the
// centre of the image farthest from it (the scale on the longest baseline);
// with held intrinsics and poses only the points move.
TEST(SchurBundleAdjuster, HoldsTheGaugeAndTheHeldParameters) {
  const SyntheticScene scene = Scene(CameraModelNameToId("SIMPLE_RADIAL"));
  Reconstruction start = scene.truth;
  PerturbModel(0.5, 0.05, 0.02, 1.0, 7, &start);
  BundleAdjustmentOptions options = TightOptions();
  options.refine_focal_length = false;
  options.solver_backend = BundleAdjustmentSolverBackend::kSchur;
  Reconstruction model = start;
  ASSERT_TRUE(RunBundleAdjustment(options, &model));
  const Image& first = model.images.begin()->second;
  const Image& first_start = start.images.begin()->second;
  EXPECT_EQ(first.cam_from_world.rotation.coeffs(),
            first_start.cam_from_world.rotation.coeffs());
  EXPECT_EQ(first.cam_from_world.translation,
            first_start.cam_from_world.translation);
  image_t farthest = kInvalidImageId;
  double max_distance = 0;
  for (const auto& [image_id, image] : start.images) {
    const double distance =
        (image.ProjectionCenter() - first_start.ProjectionCenter()).norm();
    if (distance > max_distance) {
      max_distance = distance;
      farthest = image_id;
    }
  }
  ASSERT_NE(farthest, std::next(start.images.begin())->first);
  for (const auto& [image_id, image] : model.images) {
    if (image_id == first_start.image_id) continue;
    const Eigen::Vector3d moved = (image.ProjectionCenter() -
                                   start.images.at(image_id).ProjectionCenter())
                                      .cwiseAbs();
    if (image_id == farthest) {
      EXPECT_LT(moved.minCoeff(), 1e-12);  // the held coordinate
    } else {
      EXPECT_GT(moved.minCoeff(), 1e-9) << image_id;
    }
    EXPECT_GT(moved.maxCoeff(), 1e-4);
  }
  EXPECT_EQ(model.cameras.at(1).params[0], start.cameras.at(1).params[0]);
  EXPECT_NE(model.cameras.at(1).params[3], start.cameras.at(1).params[3]);

  options.refine_poses = false;
  options.refine_extra_params = false;
  Reconstruction points_start = scene.truth;
  PerturbModel(0.0, 0.0, 0.1, 1.0, 8, &points_start);
  Reconstruction points_only = points_start;
  ASSERT_TRUE(RunBundleAdjustment(options, &points_only));
  for (const auto& [image_id, image] : points_only.images) {
    EXPECT_EQ(image.cam_from_world.translation,
              points_start.images.at(image_id).cam_from_world.translation);
  }
  EXPECT_EQ(points_only.cameras.at(1).params,
            points_start.cameras.at(1).params);
  double max_point_error = 0;
  for (const auto& [point3D_id, point] : points_only.points3D) {
    max_point_error =
        std::max(max_point_error,
                 (point.xyz - scene.truth.points3D.at(point3D_id).xyz).norm());
  }
  EXPECT_LT(max_point_error, 0.05);
  EXPECT_GT(max_point_error, 0.0);
}

// Pose priors (positions with and without covariance, two of them outliers
// in the Cauchy tail, gravity) on a perturbed model: the same optimum as
// Ceres', poses as centres and as translations, with a shared camera and
// with a camera per image (each joined to its pose's block, which the
// priors' residuals fill in part). The priors hold the gauge: every pose
// moves.
TEST(SchurBundleAdjuster, SameOptimumAsCeresWithPosePriors) {
  for (const bool shared_camera : {true, false}) {
    SCOPED_TRACE(shared_camera ? "shared camera" : "camera per image");
    const SyntheticScene scene = Scene(1, shared_camera);
    const Eigen::Vector3d kOutlierOffset(0, 6, -4);
    PosePriors priors;
    std::mt19937_64 rng(4);
    std::normal_distribution<double> normal(0.0, 1.0);
    auto noise = [&](double std) {
      return Eigen::Vector3d(std * normal(rng), std * normal(rng),
                             std * normal(rng));
    };
    int k = 0;
    for (const auto& [image_id, image] : scene.truth.images) {
      PosePrior& prior = priors[image_id];
      prior.position = image.ProjectionCenter() + noise(0.3);
      if (k % 2 == 0) {
        prior.position_covariance =
            Eigen::Vector3d(0.09, 0.04, 0.25).asDiagonal();
      }
      if (k == 3 || k == 8) prior.position += kOutlierOffset;
      prior.gravity =
          (image.cam_from_world.rotation * Eigen::Vector3d(0, 0, -1) +
           noise(0.01))
              .normalized();
      ++k;
    }
    BundleAdjustmentOptions options = TightOptions();
    options.pose_priors.position_std = 0.3;
    options.pose_priors.gravity_std_deg = 0.5;
    // The outliers stay in the problem, in the loss's Cauchy tail (what the
    // Schur solver's loss correction must match); the gate would leave them
    // out (bundle_adjustment_priors_test.cc).
    options.pose_priors.gate_std = 0;
    for (const bool centers : {true, false}) {
      SCOPED_TRACE(centers ? "centres" : "translations");
      options.parameterize_centers = centers;
      Reconstruction start = scene.truth;
      PerturbModel(0.5, 0.05, 0.02, 1.0, 7, &start);
      Reconstruction ceres_model = start, schur_model = start;
      const auto [ceres_summary, schur_summary] =
          RunBoth(options, &ceres_model, &schur_model, &priors);
      EXPECT_EQ(schur_summary.num_position_priors, 12);
      EXPECT_EQ(schur_summary.num_gravity_priors, 12);
      EXPECT_EQ(schur_summary.num_position_priors,
                ceres_summary.num_position_priors);
      ExpectSameOptimum(ceres_summary, schur_summary, ceres_model, schur_model);
      // The outliers (7.2 m off) do not drag their images: each within a
      // tenth of that of the truth.
      for (const int outlier : {3, 8}) {
        const image_t image_id =
            std::next(scene.truth.images.begin(), outlier)->first;
        EXPECT_LT((schur_model.images.at(image_id).ProjectionCenter() -
                   scene.truth.images.at(image_id).ProjectionCenter())
                      .norm(),
                  0.1 * kOutlierOffset.norm());
      }
    }
  }
}

// The supernodal factorisation (CHOLMOD) against the simplicial one (Eigen)
// on the same problem: one camera per image with distortion (the photo
// collections' case), outliers, the default IRLS Huber loss and filter
// rounds. The same solves (iterations, filtered observations) and the same
// solution to the last digits the tight tolerances leave.
TEST(SchurBundleAdjuster, SupernodalSameSolutionAsSimplicial) {
  const SyntheticScene scene =
      Scene(CameraModelNameToId("SIMPLE_RADIAL"), /*shared_camera=*/false);
  Reconstruction start = scene.truth;
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  for (auto& [image_id, image] : start.images) {
    for (Point2D& point2D : image.points2D) {
      if (uniform(rng) < 0.05) point2D.xy += Eigen::Vector2d(-35, 25);
    }
  }
  PerturbModel(0.5, 0.05, 0.02, 1.02, 12, &start);
  BundleAdjustmentOptions options = TightOptions();
  // The two factorisations round differently (CHOLMOD's supernodes go
  // through BLAS, whose kernels depend on the buffers' alignment): a stop at
  // a cost change of 1e-14, the cost's own rounding, then falls one
  // iteration apart (30 vs 31 seen). 1e-10 stops both at the same iteration
  // while the change is still above rounding, where "the same solution" can
  // be asserted to 1e-9.
  options.solver.ceres.function_tolerance = 1e-10;
  options.solver_backend = BundleAdjustmentSolverBackend::kSchur;
  Reconstruction simplicial_model = start, supernodal_model = start;
  BundleAdjustmentSummary simplicial, supernodal;
  options.schur_linear_solver = SchurLinearSolver::kSimplicial;
  ASSERT_TRUE(RunBundleAdjustment(options, &simplicial_model, &simplicial));
  options.schur_linear_solver = SchurLinearSolver::kSupernodal;
  ASSERT_TRUE(RunBundleAdjustment(options, &supernodal_model, &supernodal));
  EXPECT_EQ(simplicial.linear_solver, "SCHUR_SIMPLICIAL_LLT");
  EXPECT_EQ(supernodal.linear_solver, "SCHUR_SUPERNODAL_LLT");
  EXPECT_NE(supernodal.linear_solver_reason.find("supernodal (CHOLMOD)"),
            std::string::npos);
  EXPECT_GT(simplicial.num_observations_filtered, 100);
  EXPECT_EQ(supernodal.num_observations_filtered,
            simplicial.num_observations_filtered);
  EXPECT_EQ(supernodal.num_rounds, simplicial.num_rounds);
  EXPECT_EQ(supernodal.num_iterations, simplicial.num_iterations);
  EXPECT_NEAR(supernodal.final_mean_reproj_error,
              simplicial.final_mean_reproj_error, 1e-12);
  const Difference d = Compare(simplicial_model, supernodal_model);
  EXPECT_LT(d.center, 1e-9);  // scene radius 10
  EXPECT_LT(d.rotation_deg, 1e-9);
  EXPECT_LT(d.point, 1e-8);
  EXPECT_LT(d.param, 1e-11);
  // And the solves moved the model: the start was off.
  double moved = 0;
  for (const auto& [image_id, image] : supernodal_model.images) {
    moved = std::max(moved, (image.ProjectionCenter() -
                             start.images.at(image_id).ProjectionCenter())
                                .norm());
  }
  EXPECT_GT(moved, 1e-3);

  // auto: this reduced system is dense (every pose and camera coupled
  // through shared points; about 90 parameters: 60 flops per factor entry),
  // so supernodal.
  options.schur_linear_solver = SchurLinearSolver::kAuto;
  Reconstruction auto_model = start;
  BundleAdjustmentSummary automatic;
  ASSERT_TRUE(RunBundleAdjustment(options, &auto_model, &automatic));
  EXPECT_EQ(automatic.linear_solver, "SCHUR_SUPERNODAL_LLT");
  EXPECT_NE(automatic.linear_solver_reason.find("auto: supernodal from 40"),
            std::string::npos);
}

// Least squares on one camera per image (SIMPLE_RADIAL), no filtering, by
// the Schur solver from the undamped start (1e16); a step is accepted when
// its cost decrease is at least `min_relative_decrease` of its model's.
BundleAdjustmentSummary AdjustWithRejectedStartRadius(
    double rejected_start_radius, double min_relative_decrease,
    Reconstruction* model) {
  BundleAdjustmentOptions options;
  options.solver.ceres.num_threads = 1;
  options.solver.ceres.min_relative_decrease = min_relative_decrease;
  options.solver_backend = BundleAdjustmentSolverBackend::kSchur;
  options.loss_function = BundleAdjustmentLoss::kTrivial;
  options.max_reproj_error = 0;
  options.rejected_start_trust_region_radius = rejected_start_radius;
  // The scale held on the second image: this start's Gauss-Newton step then
  // realises less than 99.9% of its model's decrease (held on the farthest
  // image, the default, 99.97%: accepted, nothing to skip).
  options.gauge_scale_farthest = false;
  BundleAdjustmentSummary summary;
  EXPECT_TRUE(RunBundleAdjustment(options, model, &summary));
  EXPECT_EQ(summary.backend, "schur");
  EXPECT_EQ(summary.num_solves, 1);
  return summary;
}

// After a rejected first step the cuts of the radius down to
// rejected_start_radius are made without trying their steps. A start whose
// Gauss-Newton step is rejected (every step must realise 99.9% of its
// model's decrease: the steps from radius 1e16 down to 3e11 are the same
// step, rejected each time, and so is 4.8e9's): the same radii are tried
// from 4.8e9 (or 3.7e7) on, so the same model, bit for bit, in exactly 5
// (6) iterations fewer (5e15, 1.25e15, 1.6e14, 9.8e12, 3.1e11, and 4.8e9,
// not tried). A start whose first step is accepted
// (Ceres' own threshold): nothing changes.
TEST(SchurBundleAdjuster, RejectedStartSkipsTheUndampedRadii) {
  const SyntheticScene scene =
      Scene(CameraModelNameToId("SIMPLE_RADIAL"), /*shared_camera=*/false);
  Reconstruction start = scene.truth;
  PerturbModel(0.5, 0.05, 0.02, 1.02, 6, &start);
  for (const double min_relative_decrease : {0.999, 1e-3}) {
    SCOPED_TRACE(min_relative_decrease);
    Reconstruction tried = start;
    const BundleAdjustmentSummary every_cut =
        AdjustWithRejectedStartRadius(0, min_relative_decrease, &tried);
    EXPECT_LT(every_cut.final_mean_reproj_error, 1.5);  // noise 1 px
    // Down to 1e10: 5 tries fewer; to 1e9 (the default) also 4.8e9's.
    for (const auto& [radius, num_skipped] :
         std::vector<std::pair<double, int>>{{1e10, 5}, {1e9, 6}}) {
      SCOPED_TRACE(radius);
      Reconstruction skipped = start;
      const BundleAdjustmentSummary skipping = AdjustWithRejectedStartRadius(
          radius, min_relative_decrease, &skipped);
      EXPECT_EQ(skipping.final_mean_reproj_error,
                every_cut.final_mean_reproj_error);
      ExpectSameBits(tried, skipped);
      EXPECT_EQ(skipping.num_iterations,
                every_cut.num_iterations -
                    (min_relative_decrease > 0.5 ? num_skipped : 0));
    }
  }

  BundleAdjustmentOptions options;
  options.rejected_start_trust_region_radius = -1;
  EXPECT_THROW(options.Check(), OptionError);
}

// Leaves image `image_id` `num_points` observations, each of a point seen by
// one other image only (every other observation of those points and the
// image's other observations dropped): each such point is one epipolar
// constraint on the image's pose, too few to determine it without damping.
void LeaveFewTwoViewPoints(image_t image_id, size_t num_points,
                           Reconstruction* model) {
  auto unlink = [&](const TrackElement& element) {
    model->images.at(element.image_id)
        .points2D[element.point2D_idx]
        .point3D_id = kInvalidPoint3DId;
  };
  size_t kept = 0;
  for (const Point2D& point2D : model->images.at(image_id).points2D) {
    if (point2D.point3D_id == kInvalidPoint3DId) continue;
    Point3D& point = model->points3D.at(point2D.point3D_id);
    std::vector<TrackElement> track;
    bool has_other = false;
    for (const TrackElement& element : point.track) {
      const bool own = element.image_id == image_id;
      if (kept < num_points && (own || !has_other)) {
        has_other = has_other || !own;
        track.push_back(element);
      } else if (!own) {
        track.push_back(element);
      }
    }
    if (kept < num_points) {
      for (const TrackElement& element : point.track) {
        if (std::find_if(track.begin(), track.end(), [&](const auto& e) {
              return e.image_id == element.image_id;
            }) == track.end()) {
          unlink(element);
        }
      }
      ++kept;
    } else {
      for (const TrackElement& element : point.track) {
        if (element.image_id == image_id) unlink(element);
      }
    }
    point.track = track;
  }
  // Points left with one observation go.
  for (auto it = model->points3D.begin(); it != model->points3D.end();) {
    if (it->second.track.size() >= 2) {
      ++it;
      continue;
    }
    for (const TrackElement& element : it->second.track) unlink(element);
    it = model->points3D.erase(it);
  }
}

// A factorisation that fails before any step is accepted is cut as a
// rejected step is: down to rejected_start_radius without trying the radii
// above it. An image left with one two-view point: its pose block of the
// reduced system is singular without damping, and the factorisation fails
// at 1e16 (with every cut tried, the next radius's tiny damping lets it
// through, and the radius returns to 1e16 after each accepted step, to fail
// again). Skipping: fewer iterations, the same optimum for every other
// image (the singular image's pose is not determined by its point).
TEST(SchurBundleAdjuster, FailedFactorisationSkipsTheUndampedRadii) {
  const SyntheticScene scene =
      Scene(CameraModelNameToId("SIMPLE_RADIAL"), /*shared_camera=*/true);
  const image_t singular = 5;
  Reconstruction start = scene.truth;
  LeaveFewTwoViewPoints(singular, 1, &start);
  PerturbModel(0.5, 0.05, 0.02, 1.02, 6, &start);
  Reconstruction tried = start, skipped = start;
  const BundleAdjustmentSummary every_cut =
      AdjustWithRejectedStartRadius(0, 1e-3, &tried);
  const BundleAdjustmentSummary skipping =
      AdjustWithRejectedStartRadius(1e10, 1e-3, &skipped);
  EXPECT_LT(skipping.num_iterations, every_cut.num_iterations);
  tried.images.erase(singular);
  skipped.images.erase(singular);
  const Difference d = Compare(tried, skipped);
  EXPECT_LT(d.center, 1e-6);  // scene radius 10
  EXPECT_LT(d.rotation_deg, 1e-6);
  EXPECT_LT(d.param, 1e-8);
}

// Ceres' losses are the Ceres path's, whatever is asked; auto takes the
// Schur solver from the size on, pose priors or not.
// A model's parameters in a SchurBundleAdjuster (centres false: poses as
// rotation and translation): one camera block per camera, the first pose
// held (and with `gauge` one coordinate of the second), the principal
// points held, every seventh observation unweighted and every fiftieth
// point held (every `hold_every`-th).
void AddModel(bool gauge, Reconstruction* model,
              std::map<image_t, std::vector<double>>* weights,
              SchurBundleAdjuster* adjuster, size_t hold_every = 50) {
  std::map<camera_t, int> cameras;
  for (auto& [camera_id, camera] : model->cameras) {
    cameras[camera_id] =
        adjuster->AddCamera(camera.params.data(), camera.model_id);
    adjuster->SetCameraConstant(cameras[camera_id],
                                CameraModelPrincipalPointIdxs(camera.model_id));
  }
  std::map<image_t, int> poses;
  for (auto& [image_id, image] : model->images) {
    std::vector<double>& image_weights = (*weights)[image_id];
    image_weights.assign(image.points2D.size(), 1.0);
    for (size_t i = 0; i < image_weights.size(); i += 7) image_weights[i] = 0;
    poses[image_id] = adjuster->AddPose(
        image.cam_from_world.rotation.coeffs().data(),
        image.cam_from_world.translation.data(), cameras.at(image.camera_id),
        &image.points2D, &image_weights);
    adjuster->SetPoseConstant(poses[image_id], poses.size() == 1,
                              gauge && poses.size() == 2 ? 0 : -1);
  }
  size_t index = 0;
  for (auto& [point3D_id, point] : model->points3D) {
    std::vector<std::pair<int, point2D_t>> observations;
    for (const TrackElement& element : point.track) {
      observations.emplace_back(poses.at(element.image_id),
                                element.point2D_idx);
    }
    adjuster->AddPoint(point.xyz.data(), index++ % hold_every == 0,
                       observations);
  }
}

// Two solves of the same path: the same iterations and costs to the bit.
void ExpectSameSolve(const SchurBundleAdjuster::Summary& a,
                     const SchurBundleAdjuster::Summary& b) {
  EXPECT_EQ(a.num_iterations, b.num_iterations);
  EXPECT_EQ(a.initial_cost, b.initial_cost);
  EXPECT_EQ(a.final_cost, b.final_cost);
}

// Two solves of one problem by two paths that differ in rounding (and in
// conjugate gradients stopped at a relative residual of 1e-10): from the
// same start to the same optimum, `relative_cost` apart in cost.
void ExpectSameSolution(const SchurBundleAdjuster::Summary& a,
                        const SchurBundleAdjuster::Summary& b,
                        const Reconstruction& model_a,
                        const Reconstruction& model_b, double relative_cost) {
  EXPECT_NE(a.termination, ceres::FAILURE);
  EXPECT_NE(b.termination, ceres::FAILURE);
  EXPECT_EQ(a.initial_cost, b.initial_cost);
  EXPECT_LT(a.final_cost, 0.5 * a.initial_cost);
  EXPECT_NEAR(b.final_cost, a.final_cost, relative_cost * a.final_cost);
  const Difference d = Compare(model_a, model_b);
  EXPECT_LT(d.center, 1e-6);  // scene radius 10
  EXPECT_LT(d.rotation_deg, 1e-6);
  EXPECT_LT(d.point, 1e-5);
  EXPECT_LT(d.param, 1e-8);
}

// The scene's true model (SIMPLE_RADIAL; a shared camera or one per
// image) perturbed: the start of the Schur paths' comparisons.
Reconstruction PerturbedStart(bool shared_camera) {
  Reconstruction start = Scene(2, shared_camera).truth;
  PerturbModel(0.5, 0.05, 0.05, 1.02, 8, &start);
  return start;
}

// `start` adjusted by one adjuster with each of `a` and `b` (AddModel with
// the gauge; `options`): the summaries and the adjusted models.
struct TwoSolves {
  SchurBundleAdjuster::Summary a, b;
  Reconstruction model_a, model_b;
};
TwoSolves SolveWithEach(const Reconstruction& start,
                        const SchurSolverOptions& a,
                        const SchurSolverOptions& b,
                        const ceres::Solver::Options& options) {
  TwoSolves result{{}, {}, start, start};
  std::map<image_t, std::vector<double>> weights_a, weights_b;
  SchurBundleAdjuster adjuster_a(/*center=*/false, a),
      adjuster_b(/*center=*/false, b);
  AddModel(/*gauge=*/true, &result.model_a, &weights_a, &adjuster_a);
  AddModel(/*gauge=*/true, &result.model_b, &weights_b, &adjuster_b);
  result.a = adjuster_a.Solve(options);
  result.b = adjuster_b.Solve(options);
  return result;
}

// Every fifth observation of each image (from keypoint 3) unweighted in
// each of `weights` (AddModel's): a second solve with fewer weighed
// observations than the first.
void UnweighEveryFifth(
    std::initializer_list<std::map<image_t, std::vector<double>>*> weights) {
  for (auto* adjuster_weights : weights) {
    for (auto& [image_id, image_weights] : *adjuster_weights) {
      for (size_t i = 3; i < image_weights.size(); i += 5) {
        image_weights[i] = 0;
      }
    }
  }
}

// The cell tables add the same products in the same order as the search of
// every block pair's cell: the same iterations and the same solution to the
// bit, with one camera per image (the photo collections' pattern: all four
// kinds of cells) and with a shared camera (pairs of observations on one
// camera block), with and without a gauge coordinate (a pose block of 5),
// over two solves (the second with fewer observations); and with tables for
// only the points within a smaller max_cell_table_mib (the others search).
TEST(SchurBundleAdjuster, CellTablesSameSolutionAsTheCellSearch) {
  for (const bool shared_camera : {false, true}) {
    for (const bool gauge : {false, true}) {
      SCOPED_TRACE(
          std::string(shared_camera ? "shared camera" : "camera per image") +
          (gauge ? ", gauge" : ""));
      const Reconstruction start = PerturbedStart(shared_camera);
      Reconstruction tables_model = start, search_model = start,
                     partial_model = start;
      std::map<image_t, std::vector<double>> tables_weights, search_weights,
          partial_weights;
      SchurBundleAdjuster tables(/*center=*/false), search(/*center=*/false);
      search.SetUseCellTables(false);
      AddModel(gauge, &tables_model, &tables_weights, &tables);
      AddModel(gauge, &search_model, &search_weights, &search);
      // The partial budget: half of what the tables take with every point.
      std::unique_ptr<SchurBundleAdjuster> partial;
      ceres::Solver::Options options;
      options.max_num_iterations = 30;
      for (int solve = 0; solve < 2; ++solve) {
        if (solve == 1) {
          UnweighEveryFifth(
              {&tables_weights, &search_weights, &partial_weights});
        }
        const SchurBundleAdjuster::Summary a = tables.Solve(options);
        const SchurBundleAdjuster::Summary b = search.Solve(options);
        if (solve == 0) {
          SchurSolverOptions half;
          half.max_cell_table_mib = tables.CellTableBytes() / 2 / 1048576.0;
          partial = std::make_unique<SchurBundleAdjuster>(false, half);
          AddModel(gauge, &partial_model, &partial_weights, partial.get());
        }
        const SchurBundleAdjuster::Summary c = partial->Solve(options);
        EXPECT_NE(a.termination, ceres::FAILURE);
        EXPECT_GT(a.num_iterations, 2);
        EXPECT_LT(a.final_cost, a.initial_cost);
        ExpectSameSolve(a, b);
        EXPECT_EQ(c.final_cost, b.final_cost);
      }
      EXPECT_GT(tables.CellTableBytes(), 0u);
      // Some points tabled, not all.
      EXPECT_LT(partial->CellTableBytes(), tables.CellTableBytes());
      EXPECT_GT(partial->CellTableBytes(), search.CellTableBytes());
      ExpectSameBits(tables_model, search_model);
      ExpectSameBits(partial_model, search_model);
      // The solves moved the model (the comparison is not of two starts).
      EXPECT_GT(Compare(start, tables_model).point, 1e-3);
    }
  }
}

// The Jacobians kept from an elimination (for its back-substitution and
// the tries after a rejected step) give the solution of evaluating them
// again to the bit, whether every point's are kept, some or none; over two
// solves (the second with fewer weighed observations), shared and per-image
// cameras, with and without a gauge coordinate. 90% of the model decrease
// is required so that steps are rejected and the kept Jacobians are read
// by the next elimination (a kept Jacobian not dropped after an accepted
// step, or restored out of place, changes the path).
TEST(SchurBundleAdjuster, KeptJacobiansSameSolutionToTheBit) {
  for (const bool shared_camera : {false, true}) {
    for (const bool gauge : {false, true}) {
      SCOPED_TRACE(
          std::string(shared_camera ? "shared camera" : "camera per image") +
          (gauge ? ", gauge" : ""));
      const Reconstruction start = PerturbedStart(shared_camera);
      Reconstruction kept_model = start, evaluated_model = start,
                     partial_model = start;
      std::map<image_t, std::vector<double>> kept_weights, evaluated_weights,
          partial_weights;
      SchurSolverOptions none_options;
      none_options.max_jacobian_store_mib = 0;
      SchurBundleAdjuster kept(/*center=*/false),
          evaluated(/*center=*/false, none_options);
      AddModel(gauge, &kept_model, &kept_weights, &kept);
      AddModel(gauge, &evaluated_model, &evaluated_weights, &evaluated);
      std::unique_ptr<SchurBundleAdjuster> partial;
      ceres::Solver::Options options;
      options.max_num_iterations = 60;
      options.min_relative_decrease = 0.9;
      options.function_tolerance = 1e-15;
      options.gradient_tolerance = 1e-12;
      options.parameter_tolerance = 1e-15;
      int num_from_kept = 0;
      for (int solve = 0; solve < 2; ++solve) {
        if (solve == 1) {
          UnweighEveryFifth(
              {&kept_weights, &evaluated_weights, &partial_weights});
        }
        const SchurBundleAdjuster::Summary a = kept.Solve(options);
        const SchurBundleAdjuster::Summary b = evaluated.Solve(options);
        if (solve == 0) {
          // Half of what every point's Jacobians take.
          SchurSolverOptions half;
          half.max_jacobian_store_mib = a.jacobian_store_bytes / 2 / 1048576.0;
          partial = std::make_unique<SchurBundleAdjuster>(false, half);
          AddModel(gauge, &partial_model, &partial_weights, partial.get());
        }
        const SchurBundleAdjuster::Summary c = partial->Solve(options);
        EXPECT_NE(a.termination, ceres::FAILURE);
        EXPECT_GT(a.num_iterations, 2);
        EXPECT_LT(a.final_cost, a.initial_cost);
        EXPECT_EQ(b.jacobian_store_bytes, 0u);
        EXPECT_EQ(b.num_eliminations_from_kept_jacobians, 0);
        EXPECT_GT(c.jacobian_store_bytes, 0u);
        EXPECT_LT(c.jacobian_store_bytes, a.jacobian_store_bytes);
        EXPECT_EQ(a.num_eliminations_from_kept_jacobians,
                  c.num_eliminations_from_kept_jacobians);
        num_from_kept += a.num_eliminations_from_kept_jacobians;
        ExpectSameSolve(a, b);
        ExpectSameSolve(a, c);
      }
      EXPECT_GT(num_from_kept, 0);
      ExpectSameBits(kept_model, evaluated_model);
      ExpectSameBits(partial_model, evaluated_model);
      EXPECT_GT(Compare(start, kept_model).point, 1e-3);
    }
  }
  BundleAdjustmentOptions options;
  options.schur_max_jacobian_store_mib = -1;
  EXPECT_THROW(options.Check(), OptionError);
}

// The pair updates listed and run with their cells prefetched (forced on
// this small system: prefetch_updates_min_mib 0) give the solution of
// running each as it is found (the default below 16 MiB) to the bit: the
// same updates in the same order; with cell tables and with the cell
// search, shared and per-image cameras, over two solves (the second with
// fewer weighed observations).
TEST(SchurBundleAdjuster, PrefetchedUpdatesSameSolutionToTheBit) {
  for (const bool shared_camera : {false, true}) {
    for (const bool tables : {false, true}) {
      SCOPED_TRACE(
          std::string(shared_camera ? "shared camera" : "camera per image") +
          (tables ? ", cell tables" : ", cell search"));
      const Reconstruction start = PerturbedStart(shared_camera);
      Reconstruction direct_model = start, prefetched_model = start;
      std::map<image_t, std::vector<double>> direct_weights, prefetched_weights;
      SchurSolverOptions prefetch_options;
      prefetch_options.prefetch_updates_min_mib = 0;
      SchurBundleAdjuster direct(/*center=*/false),
          prefetched(/*center=*/false, prefetch_options);
      direct.SetUseCellTables(tables);
      prefetched.SetUseCellTables(tables);
      AddModel(/*gauge=*/true, &direct_model, &direct_weights, &direct);
      AddModel(/*gauge=*/true, &prefetched_model, &prefetched_weights,
               &prefetched);
      ceres::Solver::Options options;
      options.max_num_iterations = 30;
      for (int solve = 0; solve < 2; ++solve) {
        if (solve == 1)
          UnweighEveryFifth({&direct_weights, &prefetched_weights});
        const SchurBundleAdjuster::Summary a = direct.Solve(options);
        const SchurBundleAdjuster::Summary b = prefetched.Solve(options);
        EXPECT_NE(a.termination, ceres::FAILURE);
        EXPECT_GT(a.num_iterations, 2);
        EXPECT_LT(a.final_cost, a.initial_cost);
        ExpectSameSolve(a, b);
      }
      EXPECT_FALSE(direct.PrefetchesUpdates());
      EXPECT_TRUE(prefetched.PrefetchesUpdates());
      ExpectSameBits(prefetched_model, direct_model);
      EXPECT_GT(Compare(start, direct_model).point, 1e-3);
    }
  }
  BundleAdjustmentOptions options;
  options.schur_prefetch_updates_min_mib = -1;
  EXPECT_THROW(options.Check(), OptionError);
}

// The points eliminated in the locality order (by their largest blocks,
// forced on a small system) give the solution of the points' own order up
// to rounding: the same updates, summed in another order.
TEST(SchurBundleAdjuster, LocalityOrderSameSolutionUpToRounding) {
  for (const bool shared_camera : {false, true}) {
    SCOPED_TRACE(shared_camera ? "shared camera" : "camera per image");
    const Reconstruction start = PerturbedStart(shared_camera);
    Reconstruction own_model = start, ordered_model = start;
    std::map<image_t, std::vector<double>> own_weights, ordered_weights;
    SchurSolverOptions ordered_options;
    ordered_options.locality_order_min_mib = 0;
    SchurBundleAdjuster own(/*center=*/false),
        ordered(/*center=*/false, ordered_options);
    AddModel(/*gauge=*/true, &own_model, &own_weights, &own);
    AddModel(/*gauge=*/true, &ordered_model, &ordered_weights, &ordered);
    ceres::Solver::Options options;
    options.max_num_iterations = 30;
    const SchurBundleAdjuster::Summary a = own.Solve(options);
    const SchurBundleAdjuster::Summary b = ordered.Solve(options);
    // The default threshold (16 MiB) is far above this system.
    EXPECT_FALSE(own.OrdersPointsForLocality());
    EXPECT_TRUE(ordered.OrdersPointsForLocality());
    EXPECT_NE(a.termination, ceres::FAILURE);
    EXPECT_NE(b.termination, ceres::FAILURE);
    EXPECT_LT(a.final_cost, 0.5 * a.initial_cost);
    EXPECT_EQ(a.initial_cost, b.initial_cost);
    EXPECT_NEAR(b.final_cost, a.final_cost, 1e-9 * a.final_cost);
    const Difference d = Compare(ordered_model, own_model);
    EXPECT_LT(d.center, 1e-7);
    EXPECT_LT(d.rotation_deg, 1e-7);
    EXPECT_LT(d.point, 1e-7);
    EXPECT_LT(d.param, 1e-6);
    EXPECT_GT(Compare(start, own_model).point, 1e-3);
  }
}

// A camera of one pose joined to the pose's block (a camera per image)
// gives the solution of separate blocks up to rounding; a shared camera is
// not joined (the same bits). With the iterative solver too (the joined
// block is its own preconditioner group).
TEST(SchurBundleAdjuster, OwnCameraJoinedToItsPoseSameSolution) {
  for (const bool shared_camera : {false, true}) {
    for (const bool iterative : {false, true}) {
      SCOPED_TRACE(
          std::string(shared_camera ? "shared camera" : "camera per image") +
          (iterative ? ", iterative" : ""));
      const Reconstruction start = PerturbedStart(shared_camera);
      Reconstruction joined_model = start, separate_model = start;
      std::map<image_t, std::vector<double>> joined_weights, separate_weights;
      SchurSolverOptions joined_options, separate_options;
      separate_options.join_own_camera_blocks = false;
      if (iterative) {
        joined_options.linear_solver = SchurLinearSolver::kIterative;
        separate_options.linear_solver = SchurLinearSolver::kIterative;
        joined_options.eta = separate_options.eta = 1e-10;
      }
      SchurBundleAdjuster joined(/*center=*/false, joined_options),
          separate(/*center=*/false, separate_options);
      AddModel(/*gauge=*/true, &joined_model, &joined_weights, &joined);
      AddModel(/*gauge=*/true, &separate_model, &separate_weights, &separate);
      ceres::Solver::Options options;
      options.max_num_iterations = 30;
      const SchurBundleAdjuster::Summary a = separate.Solve(options);
      const SchurBundleAdjuster::Summary b = joined.Solve(options);
      EXPECT_NE(a.termination, ceres::FAILURE);
      EXPECT_NE(b.termination, ceres::FAILURE);
      EXPECT_LT(a.final_cost, 0.5 * a.initial_cost);
      EXPECT_EQ(a.initial_cost, b.initial_cost);
      EXPECT_EQ(a.num_reduced_parameters, b.num_reduced_parameters);
      EXPECT_NEAR(b.final_cost, a.final_cost, 1e-8 * a.final_cost);
      const Difference d = Compare(joined_model, separate_model);
      if (shared_camera && !iterative) {
        EXPECT_EQ(d.center, 0.0);
        EXPECT_EQ(d.point, 0.0);
        EXPECT_EQ(d.param, 0.0);
      }
      EXPECT_LT(d.center, 1e-6);
      EXPECT_LT(d.rotation_deg, 1e-6);
      EXPECT_LT(d.point, 1e-6);
      EXPECT_LT(d.param, 1e-5);
      EXPECT_GT(Compare(start, separate_model).point, 1e-3);
    }
  }
}

// The iterative solver (conjugate gradients on the reduced camera system,
// Schur-Jacobi preconditioner) against the supernodal factorisation. One
// Levenberg-Marquardt step solved to a relative residual of 1e-10: the same
// step (the error of a CG solution is at most the condition number of the
// preconditioned system, here below 1e4, times its relative residual:
// 1e-6 of the step, and the step moves the model by about its perturbation,
// 0.05-0.5; the bounds are a few times that). Then whole bundle
// adjustments converged tightly, with nearly exact steps (the direct
// solves' optimum to the Ceres comparison's bounds) and with a loose
// forcing term (0.1, Ceres' eta, shrinking with the right-hand side:
// inexact steps).
TEST(SchurBundleAdjuster, IterativeSameSolutionAsDirect) {
  Reconstruction start = Scene(2, /*shared_camera=*/false).truth;
  PerturbModel(0.5, 0.05, 0.05, 1.02, 8, &start);
  Reconstruction direct_model = start, iterative_model = start;
  std::map<image_t, std::vector<double>> direct_weights, iterative_weights;
  SchurSolverOptions iterative_options;
  iterative_options.linear_solver = SchurLinearSolver::kIterative;
  iterative_options.eta = 1e-10;
  SchurBundleAdjuster direct(/*center=*/false, SchurLinearSolver::kSupernodal),
      iterative(/*center=*/false, iterative_options);
  AddModel(/*gauge=*/true, &direct_model, &direct_weights, &direct);
  AddModel(/*gauge=*/true, &iterative_model, &iterative_weights, &iterative);
  ceres::Solver::Options options;
  options.max_num_iterations = 1;  // one step
  const SchurBundleAdjuster::Summary a = direct.Solve(options);
  const SchurBundleAdjuster::Summary b = iterative.Solve(options);
  EXPECT_TRUE(a.supernodal);
  EXPECT_FALSE(a.iterative);
  EXPECT_EQ(a.num_linear_iterations, 0);
  EXPECT_TRUE(b.iterative);
  EXPECT_FALSE(b.supernodal);
  EXPECT_NE(b.linear_solver_reason.find("iterative (conjugate gradients"),
            std::string::npos);
  EXPECT_GT(b.num_linear_iterations, 1);
  EXPECT_LE(b.num_linear_iterations, 500);
  EXPECT_EQ(a.num_iterations, 2);
  EXPECT_EQ(b.num_iterations, 2);
  EXPECT_LT(a.final_cost, a.initial_cost);
  EXPECT_EQ(a.initial_cost, b.initial_cost);
  EXPECT_NEAR(b.final_cost, a.final_cost, 1e-9 * a.final_cost);
  const Difference step = Compare(start, direct_model);
  EXPECT_GT(step.point, 1e-2);  // the step moved the model
  const Difference d = Compare(direct_model, iterative_model);
  EXPECT_LT(d.center, 1e-6);  // scene radius 10
  EXPECT_LT(d.rotation_deg, 1e-6);
  EXPECT_LT(d.point, 1e-5);
  EXPECT_LT(d.param, 1e-8);

  // Whole bundle adjustments (outliers, filtering, Huber reweighting).
  BundleAdjustmentOptions ba = TightOptions();
  ba.solver_backend = BundleAdjustmentSolverBackend::kSchur;
  Reconstruction with_outliers = start;
  std::mt19937_64 rng(13);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  for (auto& [image_id, image] : with_outliers.images) {
    for (Point2D& point2D : image.points2D) {
      if (uniform(rng) < 0.05) point2D.xy += Eigen::Vector2d(30, 35);
    }
  }
  Reconstruction direct_ba = with_outliers;
  BundleAdjustmentSummary direct_summary;
  ba.schur_linear_solver = SchurLinearSolver::kSupernodal;
  ASSERT_TRUE(RunBundleAdjustment(ba, &direct_ba, &direct_summary));
  EXPECT_EQ(direct_summary.linear_solver, "SCHUR_SUPERNODAL_LLT");
  EXPECT_EQ(direct_summary.num_linear_iterations, 0);
  EXPECT_GT(direct_summary.num_observations_filtered, 100);
  ba.schur_linear_solver = SchurLinearSolver::kIterative;
  // Forcing terms 1e-8 and 0.1 on the residual; 1e-8 with the quadratic
  // model's rule (model tolerance 1e-3), which then stops them.
  const std::vector<std::pair<double, double>> rules = {
      {1e-8, 0.0}, {0.1, 0.0}, {1e-8, 1e-3}};
  std::map<std::pair<double, double>, BundleAdjustmentSummary> summaries;
  for (const auto& [eta, model_tolerance] : rules) {
    SCOPED_TRACE("eta " + std::to_string(eta) + ", model tolerance " +
                 std::to_string(model_tolerance));
    ba.schur_iterative_eta = eta;
    ba.schur_iterative_model_tolerance = model_tolerance;
    ba.schur_iterative_model_min_num_images = 0;
    Reconstruction iterative_ba = with_outliers;
    BundleAdjustmentSummary& summary = summaries[{eta, model_tolerance}];
    ASSERT_TRUE(RunBundleAdjustment(ba, &iterative_ba, &summary));
    EXPECT_EQ(summary.linear_solver, "SCHUR_ITERATIVE_PCG");
    EXPECT_GT(summary.num_linear_iterations, summary.num_iterations);
    EXPECT_EQ(summary.num_observations_filtered,
              direct_summary.num_observations_filtered);
    // Nearly exact steps: checked below, at tolerances above rounding.
    if (eta < 1e-6 && model_tolerance == 0) continue;
    // Inexact steps (forcing term 0.1) take another path (50
    // iterations instead of 30) to the same optimum and stop where the
    // tolerances stop them, a little off the direct solves' stopping point:
    // measured 7e-8 (centres, points; scene radius 10), 4e-8 deg, 1e-8 of
    // the focal length, 2e-10 px; the bounds are 10x that. (With eta 1e-2 the
    // same; with 1e-4 3e-9: the difference is where inexact steps stop.)
    EXPECT_NEAR(summary.final_mean_reproj_error,
                direct_summary.final_mean_reproj_error, 2e-9);
    const Difference d = Compare(direct_ba, iterative_ba);
    EXPECT_LT(d.center, 1e-6);
    EXPECT_LT(d.rotation_deg, 1e-6);
    EXPECT_LT(d.point, 1e-6);
    EXPECT_LT(d.param, 1e-7);
    EXPECT_GT(Compare(with_outliers, iterative_ba).point, 1e-2);
  }
  // The model rule's inexact steps cost fewer conjugate gradient iterations
  // in all (549 against 700). The forcing term 0.1 alone did too until the
  // gauge's scale moved to the farthest image (session 43): now its 20 more
  // iterations cost more (765) than its cheaper steps save.
  const auto cg = [&](double eta, double model_tolerance) {
    return summaries.at({eta, model_tolerance}).num_linear_iterations;
  };
  EXPECT_LT(cg(1e-8, 1e-3), cg(1e-8, 0.0));
  // The model rule acts in models of schur_iterative_model_min_num_images
  // images or more only: one more than this model's, and it does not.
  ba.schur_iterative_model_tolerance = 1e-3;
  ba.schur_iterative_model_min_num_images =
      static_cast<int>(with_outliers.images.size()) + 1;
  {
    Reconstruction small = with_outliers;
    BundleAdjustmentSummary summary;
    ASSERT_TRUE(RunBundleAdjustment(ba, &small, &summary));
    EXPECT_EQ(summary.num_linear_iterations, cg(1e-8, 0.0));
  }
  ba.schur_iterative_model_tolerance = 0;

  // Nearly exact steps (eta 1e-8) take the direct solves' path to their
  // optimum (the Ceres comparison's bounds; measured 1e-13). Compared where
  // both stop at tolerances of 1e-10: at 1e-14, the cost's own rounding,
  // the iteration they stop at depends on the last bits of the two solves
  // (31 vs 33 iterations on one CPU, and then 1e-8 apart in the focal
  // length along the flat valley of focal and distortion).
  ba.solver.ceres.function_tolerance = 1e-10;
  ba.solver.ceres.gradient_tolerance = 1e-10;
  ba.solver.ceres.parameter_tolerance = 1e-10;
  ba.schur_iterative_eta = 1e-8;
  Reconstruction exact_iterative_ba = with_outliers;
  BundleAdjustmentSummary exact_iterative_summary;
  ASSERT_TRUE(
      RunBundleAdjustment(ba, &exact_iterative_ba, &exact_iterative_summary));
  ba.schur_linear_solver = SchurLinearSolver::kSupernodal;
  Reconstruction loose_direct_ba = with_outliers;
  BundleAdjustmentSummary loose_direct_summary;
  ASSERT_TRUE(RunBundleAdjustment(ba, &loose_direct_ba, &loose_direct_summary));
  EXPECT_EQ(exact_iterative_summary.num_iterations,
            loose_direct_summary.num_iterations);
  ExpectSameOptimum(loose_direct_summary, exact_iterative_summary,
                    loose_direct_ba, exact_iterative_ba);
}

// The implicit product (SchurSolverOptions::implicit_min_mib 0: the reduced
// system not formed, S x from the kept Jacobians) against the formed system,
// both conjugate gradients to a relative residual of 1e-10: one step the same
// (the bounds of IterativeSameSolutionAsDirect), then whole solves to the
// same cost, with a shared camera (its diagonal block summed over many
// observations of a point), a camera per image joined to its pose and not
// joined (the pose and camera blocks a preconditioner group: their coupling
// cell formed), and a focal length prior (the product's diagonal term).
// The implicit solver keeps every observation's Jacobians whatever the
// store's budget (here 0) and forms only the local cells.
TEST(SchurBundleAdjuster, ImplicitSameSolutionAsFormedSystem) {
  for (const bool shared_camera : {true, false}) {
    for (const bool join : {true, false}) {
      if (shared_camera && !join) continue;  // (nothing to join)
      SCOPED_TRACE(
          std::string(shared_camera ? "shared camera" : "camera per image") +
          (join ? "" : ", not joined"));
      for (const int num_iterations : {1, 30}) {
        SCOPED_TRACE(std::to_string(num_iterations) + " iterations");
        const Reconstruction start = PerturbedStart(shared_camera);
        Reconstruction formed_model = start, implicit_model = start;
        std::map<image_t, std::vector<double>> formed_weights, implicit_weights;
        SchurSolverOptions formed_options;
        formed_options.linear_solver = SchurLinearSolver::kIterative;
        formed_options.eta = 1e-10;
        formed_options.join_own_camera_blocks = join;
        formed_options.max_jacobian_store_mib = 0;
        SchurSolverOptions implicit_options = formed_options;
        implicit_options.implicit_min_mib = 0;
        // (The double product: ImplicitSinglePrecisionSameOptimum for the
        // single-precision one.)
        implicit_options.implicit_single_precision = false;
        SchurBundleAdjuster formed(/*center=*/false, formed_options),
            implicit(/*center=*/false, implicit_options);
        AddModel(/*gauge=*/true, &formed_model, &formed_weights, &formed);
        AddModel(/*gauge=*/true, &implicit_model, &implicit_weights, &implicit);
        // A focal length prior 2% off the start's value on the first camera.
        const double focal = start.cameras.begin()->second.params[0];
        formed.SetCameraPrior(0, 0, 1.02 * focal, 0.01 * focal);
        implicit.SetCameraPrior(0, 0, 1.02 * focal, 0.01 * focal);
        ceres::Solver::Options options;
        options.max_num_iterations = num_iterations;
        const SchurBundleAdjuster::Summary a = formed.Solve(options);
        const SchurBundleAdjuster::Summary b = implicit.Solve(options);
        EXPECT_TRUE(a.iterative);
        EXPECT_FALSE(a.implicit);
        EXPECT_TRUE(b.iterative);
        EXPECT_TRUE(b.implicit);
        EXPECT_NE(b.linear_solver_reason.find("implicit"), std::string::npos);
        EXPECT_EQ(a.jacobian_store_bytes, 0u);
        // r, B and A (6 pose, 2 camera columns) of every weighed observation.
        EXPECT_GE(b.jacobian_store_bytes, 24 * sizeof(double) * 1000);
        // Only the diagonal blocks and the pose-camera cells formed.
        EXPECT_LT(b.num_reduced_nonzeros, a.num_reduced_nonzeros / 2);
        EXPECT_EQ(a.num_reduced_parameters, b.num_reduced_parameters);
        EXPECT_GT(b.num_linear_iterations, 1);
        ExpectSameSolution(a, b, formed_model, implicit_model, 1e-8);
        EXPECT_GT(Compare(start, implicit_model).point, 1e-2);
        EXPECT_FALSE(b.jacobian_store_single);
      }
    }
  }
}

// The preconditioner's coarse level (SchurSolverOptions::coarse_cluster_size:
// the images' clusters moving as rigid bodies with a scale) changes the
// conjugate gradients' path, not where they lead: the same optimum as
// Schur-Jacobi alone, with the reduced system formed and implicit (poses as
// rotation and translation here, their motions SimilarityMotion's), in
// fewer conjugate gradient iterations.
TEST(SchurBundleAdjuster, CoarseLevelSameOptimumInFewerIterations) {
  const Reconstruction start = PerturbedStart(/*shared_camera=*/false);
  ceres::Solver::Options options;
  options.max_num_iterations = 30;
  for (const bool implicit : {false, true}) {
    SCOPED_TRACE(implicit ? "implicit" : "formed");
    SchurSolverOptions jacobi;
    jacobi.linear_solver = SchurLinearSolver::kIterative;
    jacobi.eta = 1e-10;
    jacobi.implicit_min_mib = implicit ? 0 : 1e9;
    jacobi.implicit_single_precision = false;
    jacobi.coarse_cluster_size = 0;
    SchurSolverOptions coarse = jacobi;
    coarse.coarse_cluster_size = 3;
    const TwoSolves solves = SolveWithEach(start, jacobi, coarse, options);
    EXPECT_EQ(solves.a.num_coarse_clusters, 0);
    // 11 refined poses (the first held) in clusters of 3.
    EXPECT_GE(solves.b.num_coarse_clusters, 3);
    EXPECT_EQ(solves.b.implicit, implicit);
    ExpectSameSolution(solves.a, solves.b, solves.model_a, solves.model_b,
                       1e-8);
    EXPECT_LT(solves.b.num_linear_iterations, solves.a.num_linear_iterations);
  }
}

// The implicit solver's Jacobians kept in single precision (the default):
// each step's system and back-substitution off by float rounding, the costs
// in double, so the same optimum as the formed system's, with a shared
// camera and with one per image (joined and not); with the AVX2 kernel
// (where the processor has it) and the portable code.
TEST(SchurBundleAdjuster, ImplicitSinglePrecisionSameOptimum) {
  for (const bool shared_camera : {true, false}) {
    for (const bool join : {true, false}) {
      for (const bool avx2 : {true, false}) {
        if (shared_camera && !join) continue;  // (nothing to join)
        SCOPED_TRACE(
            std::string(shared_camera ? "shared camera" : "camera per image") +
            (join ? "" : ", not joined") + (avx2 ? ", AVX2" : ", portable"));
        SchurSolverOptions formed_options;
        formed_options.linear_solver = SchurLinearSolver::kIterative;
        formed_options.join_own_camera_blocks = join;
        SchurSolverOptions single_options = formed_options;
        single_options.implicit_min_mib = 0;
        single_options.implicit_avx2 = avx2;
        ASSERT_TRUE(single_options.implicit_single_precision);
        ceres::Solver::Options options;
        options.max_num_iterations = 200;
        options.function_tolerance = 1e-12;
        options.gradient_tolerance = 1e-14;
        options.parameter_tolerance = 1e-12;
        const Reconstruction start = PerturbedStart(shared_camera);
        const TwoSolves solves =
            SolveWithEach(start, formed_options, single_options, options);
        const SchurBundleAdjuster::Summary& a = solves.a;
        const SchurBundleAdjuster::Summary& b = solves.b;
        EXPECT_TRUE(b.implicit);
        EXPECT_NE(a.termination, ceres::FAILURE);
        EXPECT_NE(b.termination, ceres::FAILURE);
        EXPECT_EQ(a.initial_cost, b.initial_cost);
        EXPECT_LT(a.final_cost, 0.5 * a.initial_cost);
        EXPECT_NEAR(b.final_cost, a.final_cost, 1e-9 * a.final_cost);
        const Difference d = Compare(solves.model_a, solves.model_b);
        LOG(INFO) << "single precision against formed: centre " << d.center
                  << ", rotation " << d.rotation_deg << " deg, point "
                  << d.point << ", parameters " << d.param << "; iterations "
                  << a.num_iterations << ", " << b.num_iterations;
        EXPECT_LT(d.center, 1e-6);  // scene radius 10
        EXPECT_LT(d.rotation_deg, 1e-6);
        EXPECT_LT(d.point, 1e-5);
        EXPECT_LT(d.param, 1e-8);
        // Half the double store's bytes.
        EXPECT_TRUE(b.jacobian_store_single);
        SchurSolverOptions double_options = single_options;
        double_options.implicit_single_precision = false;
        options.max_num_iterations = 1;
        const TwoSolves one_iteration =
            SolveWithEach(start, single_options, double_options, options);
        EXPECT_TRUE(one_iteration.a.jacobian_store_single);
        EXPECT_FALSE(one_iteration.b.jacobian_store_single);
        EXPECT_EQ(one_iteration.a.jacobian_store_bytes, b.jacobian_store_bytes);
        EXPECT_GT(b.jacobian_store_bytes, 0u);
        EXPECT_EQ(2 * b.jacobian_store_bytes,
                  one_iteration.b.jacobian_store_bytes);
        EXPECT_EQ(b.implicit_avx2, avx2 && Avx2ProductAvailable());
        EXPECT_FALSE(one_iteration.b.implicit_avx2);  // (doubles)
      }
    }
  }
}

// The implicit product's pose residual term: pose priors (position and
// gravity, Cauchy loss with outliers) through the bundle adjustment, the
// implicit iterative solver against the supernodal factorisation: the same
// optimum.
TEST(SchurBundleAdjuster, ImplicitSameOptimumWithPosePriors) {
  const SyntheticScene scene = Scene(1, /*shared_camera=*/false);
  PosePriors priors;
  std::mt19937_64 rng(4);
  std::normal_distribution<double> normal(0.0, 1.0);
  int k = 0;
  for (const auto& [image_id, image] : scene.truth.images) {
    PosePrior& prior = priors[image_id];
    prior.position =
        image.ProjectionCenter() +
        0.3 * Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
    if (k++ == 3) prior.position += Eigen::Vector3d(0, 6, -4);
    prior.gravity = image.cam_from_world.rotation * Eigen::Vector3d(0, 0, -1);
  }
  BundleAdjustmentOptions options = TightOptions();
  options.solver_backend = BundleAdjustmentSolverBackend::kSchur;
  options.pose_priors.position_std = 0.3;
  options.pose_priors.gravity_std_deg = 0.5;
  options.pose_priors.gate_std = 0;
  Reconstruction start = scene.truth;
  PerturbModel(0.5, 0.05, 0.02, 1.0, 7, &start);
  Reconstruction direct_model = start, implicit_model = start;
  BundleAdjustmentSummary direct_summary, implicit_summary;
  options.schur_linear_solver = SchurLinearSolver::kSupernodal;
  ASSERT_TRUE(
      RunBundleAdjustment(options, &direct_model, &direct_summary, &priors));
  options.schur_linear_solver = SchurLinearSolver::kIterative;
  options.schur_implicit_min_mib = 0;
  options.schur_iterative_eta = 1e-10;
  // The double product: the same optimum to the solves' tolerance.
  options.schur_implicit_single_precision = false;
  ASSERT_TRUE(RunBundleAdjustment(options, &implicit_model, &implicit_summary,
                                  &priors));
  EXPECT_EQ(implicit_summary.linear_solver, "SCHUR_IMPLICIT_PCG");
  EXPECT_EQ(implicit_summary.num_position_priors, 12);
  EXPECT_EQ(implicit_summary.num_gravity_priors, 12);
  ExpectSameOptimum(direct_summary, implicit_summary, direct_model,
                    implicit_model);
  // Single precision (the default): each step exact to float rounding only
  // (the conjugate gradients cannot reach eta 1e-10), so within 100x those
  // tolerances: still 1e-5 deg and 1e-5 of the scene's radius.
  options.schur_implicit_single_precision = true;
  Reconstruction single_model = start;
  BundleAdjustmentSummary single_summary;
  ASSERT_TRUE(
      RunBundleAdjustment(options, &single_model, &single_summary, &priors));
  EXPECT_EQ(single_summary.linear_solver, "SCHUR_IMPLICIT_PCG");
  EXPECT_NEAR(single_summary.final_mean_reproj_error,
              direct_summary.final_mean_reproj_error, 1e-7);
  const Difference d = Compare(direct_model, single_model);
  EXPECT_LT(d.center, 1e-5);
  EXPECT_LT(d.rotation_deg, 1e-5);
  EXPECT_LT(d.point, 1e-4);
  EXPECT_LT(d.param, 1e-7);
}

// After a rejected step the next try re-damps the cameras of the reduced
// system it has (reuse_min_radius) instead of eliminating the points again:
// another damping of the same Gauss-Newton model, so the solves reach the
// same optimum as Ceres' tries (a new elimination each), with a camera per
// image and a shared camera, through both factorisations and the iterative
// solver (eta 1e-10: as exact). Many tries are rejected: each step must
// realise 90% of its model's decrease. Off (0): nothing reused.
TEST(SchurBundleAdjuster, ReusedEliminationAfterRejectionSameOptimum) {
  for (const bool shared_camera : {false, true}) {
    for (const SchurLinearSolver solver :
         {SchurLinearSolver::kSimplicial, SchurLinearSolver::kSupernodal,
          SchurLinearSolver::kIterative}) {
      SCOPED_TRACE(
          std::string(shared_camera ? "shared camera" : "camera per image") +
          ", solver " + std::to_string(static_cast<int>(solver)));
      // Whether a try is rejected depends on the path, which rounding
      // (the CPU's libm and BLAS kernels) can change: three starts, each
      // checked, at least one of which must reuse.
      int num_reused = 0;
      for (const int seed : {8, 9, 10}) {
        SCOPED_TRACE("seed " + std::to_string(seed));
        Reconstruction start = Scene(2, shared_camera).truth;
        PerturbModel(0.5, 0.05, 0.05, 1.02, seed, &start);
        SchurSolverOptions fresh_options;
        fresh_options.linear_solver = solver;
        fresh_options.eta = 1e-10;
        SchurSolverOptions reuse_options = fresh_options;
        reuse_options.reuse_min_radius = 1e-3;
        ceres::Solver::Options options;
        options.max_num_iterations = 200;
        options.min_relative_decrease = 0.9;
        options.function_tolerance = 1e-15;
        options.gradient_tolerance = 1e-12;
        options.parameter_tolerance = 1e-15;
        const TwoSolves solves =
            SolveWithEach(start, fresh_options, reuse_options, options);
        EXPECT_EQ(solves.a.num_reused_eliminations, 0);
        num_reused += solves.b.num_reused_eliminations;
        ExpectSameSolution(solves.a, solves.b, solves.model_a, solves.model_b,
                           1e-9);
      }
      EXPECT_GT(num_reused, 0);
    }
  }
  BundleAdjustmentOptions options;
  options.schur_reuse_min_radius = -1;
  EXPECT_THROW(options.Check(), OptionError);
}

// With every point held nothing is eliminated: a reused system re-damped is
// the system a new linearisation would give, so the tries are Ceres' own,
// the same radii and iterations and the same model up to the rounding of
// the damping taken off and put on (cameras and poses only).
TEST(SchurBundleAdjuster, ReusedEliminationWithoutPointsIsCeresTry) {
  for (const SchurLinearSolver solver :
       {SchurLinearSolver::kSimplicial, SchurLinearSolver::kSupernodal}) {
    SCOPED_TRACE(static_cast<int>(solver));
    Reconstruction start = Scene(2, /*shared_camera=*/false).truth;
    PerturbModel(5, 0.5, 0.05, 1.1, 8, &start);
    Reconstruction fresh_model = start, reused_model = start;
    std::map<image_t, std::vector<double>> fresh_weights, reused_weights;
    SchurSolverOptions fresh_options;
    fresh_options.linear_solver = solver;
    SchurSolverOptions reuse_options = fresh_options;
    reuse_options.reuse_min_radius = 1e-9;
    SchurBundleAdjuster fresh(/*center=*/false, fresh_options),
        reused(/*center=*/false, reuse_options);
    AddModel(/*gauge=*/true, &fresh_model, &fresh_weights, &fresh,
             /*hold_every=*/1);
    AddModel(/*gauge=*/true, &reused_model, &reused_weights, &reused,
             /*hold_every=*/1);
    ceres::Solver::Options options;
    options.max_num_iterations = 40;
    options.min_relative_decrease = 0.999;
    const SchurBundleAdjuster::Summary a = fresh.Solve(options);
    const SchurBundleAdjuster::Summary b = reused.Solve(options);
    EXPECT_GT(b.num_reused_eliminations, 2);
    EXPECT_EQ(a.num_iterations, b.num_iterations);
    EXPECT_LT(a.final_cost, a.initial_cost);
    EXPECT_NEAR(b.final_cost, a.final_cost, 1e-12 * a.final_cost);
    const Difference d = Compare(fresh_model, reused_model);
    EXPECT_LT(d.center, 1e-9);
    EXPECT_LT(d.rotation_deg, 1e-9);
    EXPECT_LT(d.param, 1e-11);
  }
}

// auto: iterative when the factor's estimated size is above
// max_factor_mib or its factorisation's flops above max_factor_gflops, the
// factorisation below; the estimate (block pattern) of this system, dense
// (every pose and camera coupled), is within 10% of the dense triangle
// n (n + 1) / 2 and of a dense factorisation's n (n + 1) (2n + 1) / 6
// flops, and not above them.
TEST(SchurBundleAdjuster, AutoChoosesIterativeAboveTheFactorBudget) {
  const Reconstruction start = Scene(2, /*shared_camera=*/false).truth;
  auto solve = [&](double max_factor_mib, double max_factor_gflops = 50) {
    Reconstruction model = start;
    std::map<image_t, std::vector<double>> weights;
    SchurSolverOptions solver_options;
    solver_options.max_factor_mib = max_factor_mib;
    solver_options.max_factor_gflops = max_factor_gflops;
    SchurBundleAdjuster adjuster(/*center=*/false, solver_options);
    AddModel(/*gauge=*/true, &model, &weights, &adjuster);
    ceres::Solver::Options options;
    options.max_num_iterations = 3;
    const SchurBundleAdjuster::Summary summary = adjuster.Solve(options);
    EXPECT_NE(summary.termination, ceres::FAILURE);
    return summary;
  };
  const SchurBundleAdjuster::Summary probe = solve(1024);
  const double n = probe.num_reduced_parameters;
  const double dense_bytes = sizeof(double) * n * (n + 1) / 2;
  EXPECT_GT(n, 50);
  EXPECT_GT(probe.factor_bytes_estimate, 0.9 * dense_bytes);
  EXPECT_LE(probe.factor_bytes_estimate, dense_bytes);
  EXPECT_FALSE(probe.iterative);
  EXPECT_TRUE(probe.supernodal);
  const double mib = probe.factor_bytes_estimate / 1048576.0;
  const SchurBundleAdjuster::Summary above = solve(0.99 * mib);
  EXPECT_TRUE(above.iterative);
  EXPECT_GT(above.num_linear_iterations, 0);
  EXPECT_NE(above.linear_solver_reason.find("auto: iterative above"),
            std::string::npos);
  const SchurBundleAdjuster::Summary below = solve(1.01 * mib);
  EXPECT_FALSE(below.iterative);
  EXPECT_EQ(below.num_linear_iterations, 0);
  EXPECT_NE(below.linear_solver_reason.find("supernodal (CHOLMOD)"),
            std::string::npos);
  EXPECT_EQ(below.final_cost, probe.final_cost);

  const double dense_flops = n * (n + 1) * (2 * n + 1) / 6;
  EXPECT_GT(probe.factor_flops_estimate, 0.9 * dense_flops);
  EXPECT_LE(probe.factor_flops_estimate, dense_flops);
  const double gflops = probe.factor_flops_estimate * 1e-9;
  const SchurBundleAdjuster::Summary costly = solve(1024, 0.99 * gflops);
  EXPECT_TRUE(costly.iterative);
  EXPECT_GT(costly.num_linear_iterations, 0);
  EXPECT_NE(costly.linear_solver_reason.find("GFlop)"), std::string::npos);
  const SchurBundleAdjuster::Summary cheap = solve(1024, 1.01 * gflops);
  EXPECT_FALSE(cheap.iterative);
  EXPECT_EQ(cheap.final_cost, probe.final_cost);
}

// Check() rejects the iterative solver's bad settings, naming the flag.
TEST(SchurBundleAdjuster, CheckRejectsBadIterativeSettings) {
  const auto error =
      [](const std::function<void(BundleAdjustmentOptions*)>& change)
      -> std::string {
    BundleAdjustmentOptions options;
    change(&options);
    try {
      options.Check();
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_EQ(error([](BundleAdjustmentOptions*) {}), "");
  EXPECT_NE(error([](BundleAdjustmentOptions* o) {
              o->schur_max_factor_mib = 0;
            }).find("--BundleAdjustment.schur_max_factor_mib"),
            std::string::npos);
  EXPECT_NE(error([](BundleAdjustmentOptions* o) {
              o->schur_max_factor_gflops = 0;
            }).find("--BundleAdjustment.schur_max_factor_gflops"),
            std::string::npos);
  for (const double eta : {0.0, 1.0, -0.5, std::nan("")}) {
    EXPECT_NE(error([eta](BundleAdjustmentOptions* o) {
                o->schur_iterative_eta = eta;
              }).find("--BundleAdjustment.schur_iterative_eta"),
              std::string::npos);
  }
  EXPECT_NE(error([](BundleAdjustmentOptions* o) {
              o->schur_max_cg_iterations = 0;
            }).find("--BundleAdjustment.schur_max_cg_iterations"),
            std::string::npos);
  for (const double tolerance : {1.0, -0.1, std::nan("")}) {
    EXPECT_NE(error([tolerance](BundleAdjustmentOptions* o) {
                o->schur_iterative_model_tolerance = tolerance;
              }).find("--BundleAdjustment.schur_iterative_model_tolerance"),
              std::string::npos);
  }
  EXPECT_NE(error([](BundleAdjustmentOptions* o) {
              o->schur_iterative_model_min_num_images = -1;
            }).find("--BundleAdjustment.schur_iterative_model_min_num_images"),
            std::string::npos);
  for (const double mib : {-1.0, std::nan("")}) {
    EXPECT_NE(error([mib](BundleAdjustmentOptions* o) {
                o->schur_implicit_min_mib = mib;
              }).find("--BundleAdjustment.schur_implicit_min_mib"),
              std::string::npos);
  }
  EXPECT_EQ(error([](BundleAdjustmentOptions* o) {
              o->schur_linear_solver = SchurLinearSolver::kIterative;
              o->schur_iterative_eta = 0.5;
              o->schur_max_cg_iterations = 1;
              o->schur_max_factor_mib = 0.001;
            }),
            "");
}

TEST(CostStall, StallsOnceTheWindowDecreasesLessThanTheThreshold) {
  CostStall stall(3, 0.01);
  EXPECT_FALSE(stall.Add(100));
  EXPECT_FALSE(stall.Add(90));
  EXPECT_FALSE(stall.Add(89.9));
  // 100 -> 89.8 over the last 3 steps: 11% of 89.8.
  EXPECT_FALSE(stall.Add(89.8));
  // 90 -> 89.7: 0.33% < 1%.
  EXPECT_TRUE(stall.Add(89.7));
  // Off: never, however flat.
  CostStall off(0, 0.01);
  for (int i = 0; i < 10; ++i) EXPECT_FALSE(off.Add(1.0));
}

// A perturbed model with distortion, one camera per image, least squares,
// the trust region held small (a crawl: each step a damped gradient step,
// the cost falling by a little each time): with the stall rule both
// backends stop long before the tight tolerances would (the solve counted
// as converged and as stalled), near the optimum they reach without it.
// The rule acts only on adjustments of stall_min_num_images images or more.
TEST(SchurBundleAdjuster, BothBackendsStopWhenTheCostStalls) {
  Reconstruction start = Scene(2, /*shared_camera=*/false).truth;
  PerturbModel(0.5, 0.05, 0.05, 1.02, 8, &start);
  BundleAdjustmentOptions options = TightOptions();
  options.loss_function = BundleAdjustmentLoss::kTrivial;
  options.num_rounds = 1;
  options.weight_by_keypoint_scale = false;
  options.solver.ceres.initial_trust_region_radius = 100;
  options.solver.ceres.max_trust_region_radius = 100;
  options.solver.ceres.max_num_iterations = 200;
  options.stall_num_iterations = 3;
  options.stall_relative_decrease = 0.005;
  const int num_images = static_cast<int>(start.images.size());
  options.stall_min_num_images = num_images + 1;
  Reconstruction ceres_tight = start, schur_tight = start;
  const auto [ceres_full, schur_full] =
      RunBoth(options, &ceres_tight, &schur_tight);
  EXPECT_EQ(ceres_full.num_stalled_solves, 0);
  EXPECT_EQ(schur_full.num_stalled_solves, 0);
  options.stall_min_num_images = num_images;
  Reconstruction ceres_model = start, schur_model = start;
  const auto [ceres_stalled, schur_stalled] =
      RunBoth(options, &ceres_model, &schur_model);
  for (const auto& [stalled, full] :
       {std::make_pair(ceres_stalled, ceres_full),
        std::make_pair(schur_stalled, schur_full)}) {
    SCOPED_TRACE(stalled.backend);
    EXPECT_EQ(stalled.num_stalled_solves, 1);
    EXPECT_TRUE(stalled.converged);
    EXPECT_LT(stalled.num_iterations, full.num_iterations);
    EXPECT_GE(stalled.final_mean_reproj_error, full.final_mean_reproj_error);
    EXPECT_LT(stalled.final_mean_reproj_error,
              1.01 * full.final_mean_reproj_error);
  }
  // The same rule on the same steps.
  EXPECT_EQ(schur_stalled.num_iterations, ceres_stalled.num_iterations);
  options.stall_num_iterations = -1;
  EXPECT_THROW(options.Check(), OptionError);
  options.stall_num_iterations = 5;
  options.stall_relative_decrease = -0.1;
  EXPECT_THROW(options.Check(), OptionError);
  options.stall_relative_decrease = 0.005;
  options.stall_min_num_images = -1;
  EXPECT_THROW(options.Check(), OptionError);
}

// Embedded point iterations: the same optimum as Ceres' (tight
// tolerances), in no more iterations; on a start whose points are far off
// (1 unit in a scene of radius 10, cameras near), in fewer.
TEST(SchurBundleAdjuster, PointIterationsSameOptimumFewerIterations) {
  Reconstruction start = Scene(2, /*shared_camera=*/false).truth;
  PerturbModel(0.5, 0.05, 1.0, 1.02, 8, &start);
  BundleAdjustmentOptions options = TightOptions();
  options.loss_function = BundleAdjustmentLoss::kTrivial;
  options.num_rounds = 1;
  options.weight_by_keypoint_scale = false;
  options.solver.ceres.max_num_iterations = 200;
  Reconstruction ceres_model = start, schur_model = start;
  const auto [ceres_summary, schur_summary] =
      RunBoth(options, &ceres_model, &schur_model);
  options.schur_point_iterations = 2;
  Reconstruction ceres_again = start, embedded_model = start;
  const auto [unused, embedded_summary] =
      RunBoth(options, &ceres_again, &embedded_model);
  EXPECT_TRUE(embedded_summary.converged);
  // (ExpectSameOptimum's bounds but 1e-8 on the camera parameters: the
  // camera parameters of a Schur solve came out 1.9e-9 from Ceres' here.)
  EXPECT_NEAR(embedded_summary.final_mean_reproj_error,
              ceres_summary.final_mean_reproj_error, 1e-9);
  const Difference d = Compare(ceres_model, embedded_model);
  EXPECT_LT(d.center, 1e-7);
  EXPECT_LT(d.rotation_deg, 1e-7);
  EXPECT_LT(d.point, 1e-6);
  EXPECT_LT(d.param, 1e-8);
  EXPECT_LT(embedded_summary.num_iterations, schur_summary.num_iterations);
}

TEST(SchurBundleAdjuster, FallsBackToCeresForLosses) {
  const SyntheticScene scene = Scene();
  BundleAdjustmentOptions options = TightOptions();
  options.solver_backend = BundleAdjustmentSolverBackend::kSchur;
  options.loss_function = BundleAdjustmentLoss::kCauchy;
  Reconstruction model = scene.truth;
  BundleAdjustmentSummary summary;
  ASSERT_TRUE(RunBundleAdjustment(options, &model, &summary));
  EXPECT_EQ(summary.backend, "ceres");
  EXPECT_NE(summary.backend_reason.find("cauchy"), std::string::npos);

  std::string reason;
  options.loss_function = BundleAdjustmentLoss::kHuber;
  options.solver_backend = BundleAdjustmentSolverBackend::kAuto;
  options.schur_min_num_observations = 1000;
  EXPECT_FALSE(ChooseSchurBackend(options, 999, &reason));
  EXPECT_TRUE(ChooseSchurBackend(options, 1000, &reason));
  options.solver_backend = BundleAdjustmentSolverBackend::kCeres;
  EXPECT_FALSE(ChooseSchurBackend(options, 1000000, &reason));
  options.schur_min_num_observations = -1;
  EXPECT_THROW(options.Check(), InputError);
}

}  // namespace
}  // namespace colmap_irav4
