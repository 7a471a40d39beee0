#include "colmap_irav4/refinement/bundle_adjustment.h"

#include <algorithm>
#include <memory>
#include <set>

#include <ceres/ceres.h>
#include <glog/logging.h>

#include "colmap_irav4/refinement/filtering.h"
#include "colmap_irav4/scene/camera_models.h"
#include "colmap_irav4/scene/reconstruction_utils.h"
#include "colmap_irav4/util/ceres_solve.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/timer.h"

namespace colmap_irav4 {
namespace {

// Reprojection residual; blocks: quaternion (x, y, z, w), translation, point,
// camera params (kNumParams).
template <int kNumParams>
struct ReprojectionCost {
  ReprojectionCost(int model_id, const Eigen::Vector2d& xy)
      : model_id_(model_id), xy_(xy) {}

  template <typename T>
  bool operator()(const T* rotation, const T* translation, const T* point,
                  const T* params, T* residuals) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q(rotation);
    const Eigen::Matrix<T, 3, 1> in_cam =
        q * Eigen::Map<const Eigen::Matrix<T, 3, 1>>(point) +
        Eigen::Map<const Eigen::Matrix<T, 3, 1>>(translation);
    T x, y;
    CameraModelImgFromCam<T>(model_id_, params, in_cam[0], in_cam[1], in_cam[2],
                             &x, &y);
    residuals[0] = x - T(xy_[0]);
    residuals[1] = y - T(xy_[1]);
    return true;
  }

  const int model_id_;
  const Eigen::Vector2d xy_;
};

template <int kNumParams>
ceres::CostFunction* MakeCost(int model_id, const Eigen::Vector2d& xy) {
  return new ceres::AutoDiffCostFunction<ReprojectionCost<kNumParams>, 2, 4, 3,
                                         3, kNumParams>(
      new ReprojectionCost<kNumParams>(model_id, xy));
}

ceres::CostFunction* CreateReprojectionCost(int model_id,
                                            const Eigen::Vector2d& xy) {
  switch (CameraModelNumParams(model_id)) {
    case 3:
      return MakeCost<3>(model_id, xy);
    case 4:
      return MakeCost<4>(model_id, xy);
    case 5:
      return MakeCost<5>(model_id, xy);
    case 8:
      return MakeCost<8>(model_id, xy);
    case 12:
      return MakeCost<12>(model_id, xy);
  }
  LOG(FATAL) << "unsupported camera model " << model_id;
  return nullptr;
}

// "huber" is iteratively reweighted: each solve weighs an observation by
// Huber's weight min(1, scale / error) at its error when the solve starts
// (the rounds update the weights). Ceres' HuberLoss ("huber_ceres") makes
// Levenberg-Marquardt crawl whenever many residuals sit in the linear region
// (its corrector drops their curvature): 59 iterations instead of 12 on
// fountain-P11 for the same result. The others: CreateLossFunction.
ceres::LossFunction* MakeLoss(const std::string& name, double scale,
                              double error) {
  if (name == "huber") {
    return error > scale ? new ceres::ScaledLoss(nullptr, scale / error,
                                                 ceres::TAKE_OWNERSHIP)
                         : nullptr;
  }
  return CreateLossFunction(name == "huber_ceres" ? "huber" : name, scale);
}

// One solve. Returns the Ceres summary; adds the time spent building the
// problem to *problem_seconds.
ceres::Solver::Summary Solve(const BundleAdjustmentOptions& options,
                             Reconstruction* reconstruction,
                             double* problem_seconds) {
  Timer timer;
  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();

  for (auto& [image_id, image] : reconstruction->images) {
    image.cam_from_world.rotation.normalize();
  }
  std::set<image_t> used_images;
  std::set<camera_t> used_cameras;
  for (auto& [point3D_id, point] : reconstruction->points3D) {
    for (const TrackElement& element : point.track) {
      Image& image = reconstruction->images.at(element.image_id);
      Camera& camera = reconstruction->cameras.at(image.camera_id);
      // Points behind the camera would give meaningless residuals; the
      // filtering between rounds removes them.
      if ((image.cam_from_world * point.xyz).z() <= 0) continue;
      const double error =
          options.loss_function == "huber"
              ? ReprojectionError(camera, image, point.xyz,
                                  image.points2D[element.point2D_idx].xy)
              : 0.0;
      problem.AddResidualBlock(
          CreateReprojectionCost(camera.model_id,
                                 image.points2D[element.point2D_idx].xy),
          MakeLoss(options.loss_function, options.loss_scale, error),
          image.cam_from_world.rotation.coeffs().data(),
          image.cam_from_world.translation.data(), point.xyz.data(),
          camera.params.data());
      used_images.insert(element.image_id);
      used_cameras.insert(image.camera_id);
    }
    if (problem.HasParameterBlock(point.xyz.data())) {
      ordering->AddElementToGroup(point.xyz.data(), 0);
      if (!options.refine_points)
        problem.SetParameterBlockConstant(point.xyz.data());
    }
  }
  if (problem.NumResidualBlocks() == 0) return ceres::Solver::Summary();

  // Poses and gauge.
  std::vector<image_t> images(used_images.begin(), used_images.end());
  for (size_t k = 0; k < images.size(); ++k) {
    Image& image = reconstruction->images.at(images[k]);
    double* rotation = image.cam_from_world.rotation.coeffs().data();
    double* translation = image.cam_from_world.translation.data();
    ordering->AddElementToGroup(rotation, 1);
    ordering->AddElementToGroup(translation, 1);
    problem.SetManifold(rotation, new ceres::EigenQuaternionManifold());
    if (!options.refine_poses || (options.fix_gauge && k == 0)) {
      problem.SetParameterBlockConstant(rotation);
      problem.SetParameterBlockConstant(translation);
    } else if (options.fix_gauge && k == 1) {
      const Image& first = reconstruction->images.at(images[0]);
      const Eigen::Vector3d baseline =
          image.cam_from_world.rotation *
          (image.ProjectionCenter() - first.ProjectionCenter());
      int fixed_coordinate = 0;
      baseline.cwiseAbs().maxCoeff(&fixed_coordinate);
      problem.SetManifold(translation,
                          new ceres::SubsetManifold(3, {fixed_coordinate}));
    }
  }

  // Intrinsics.
  for (camera_t camera_id : used_cameras) {
    Camera& camera = reconstruction->cameras.at(camera_id);
    ordering->AddElementToGroup(camera.params.data(), 1);
    std::vector<int> constant;
    auto add = [&constant](const std::vector<int>& idxs) {
      constant.insert(constant.end(), idxs.begin(), idxs.end());
    };
    if (!options.refine_focal_length)
      add(CameraModelFocalLengthIdxs(camera.model_id));
    if (!options.refine_principal_point)
      add(CameraModelPrincipalPointIdxs(camera.model_id));
    if (!options.refine_extra_params)
      add(CameraModelExtraParamsIdxs(camera.model_id));
    const int num_params = camera.params.size();
    if (static_cast<int>(constant.size()) >= num_params) {
      problem.SetParameterBlockConstant(camera.params.data());
    } else if (!constant.empty()) {
      problem.SetManifold(camera.params.data(),
                          new ceres::SubsetManifold(num_params, constant));
    }
  }

  SolverOptions solver = options.solver;
  ChooseLinearSolver(options, static_cast<int>(used_images.size()),
                     &solver.ceres);
  if (options.refine_points) solver.ceres.linear_solver_ordering = ordering;
  *problem_seconds += timer.ElapsedSeconds();
  return SolveProblem("bundle adjustment", solver, &problem);
}

}  // namespace

void ChooseLinearSolver(const BundleAdjustmentOptions& options, int num_images,
                        ceres::Solver::Options* ceres_options) {
  const std::string& name = options.linear_solver;
  if (name == "dense_schur" || (name == "auto" && num_images < 50)) {
    ceres_options->linear_solver_type = ceres::DENSE_SCHUR;
  } else if (name == "iterative_schur" ||
             (name == "auto" &&
              num_images >= options.iterative_schur_min_num_images)) {
    ceres_options->linear_solver_type = ceres::ITERATIVE_SCHUR;
    ceres_options->preconditioner_type = ceres::SCHUR_JACOBI;
  } else {
    ceres_options->linear_solver_type = ceres::SPARSE_SCHUR;
  }
}

BundleAdjustmentOptions::BundleAdjustmentOptions() {
  solver.ceres.max_num_iterations = 100;
  solver.ceres.function_tolerance = 1e-5;
  solver.ceres.gradient_tolerance = 1e-10;
  solver.ceres.parameter_tolerance = 1e-8;
  solver.ceres.initial_trust_region_radius = 1e8;
}

void BundleAdjustmentOptions::Check() const {
  if (!IsLossFunction(loss_function) && loss_function != "huber_ceres") {
    throw OptionError(&loss_function, "BundleAdjustment.loss_function",
                      "must be huber, huber_ceres, cauchy or trivial, not '" +
                          loss_function + "'");
  }
  if (!(loss_scale > 0))
    throw OptionError(&loss_scale, "BundleAdjustment.loss_scale",
                      "must be positive");
  if (num_rounds < 1)
    throw OptionError(&num_rounds, "BundleAdjustment.num_rounds",
                      "must be at least 1");
  if (!(min_filtered_fraction >= 0 && min_filtered_fraction < 1)) {
    throw OptionError(&min_filtered_fraction,
                      "BundleAdjustment.min_filtered_fraction",
                      "must be in [0, 1)");
  }
  if (!(max_reproj_error >= 0)) {
    throw OptionError(&max_reproj_error, "BundleAdjustment.max_reproj_error",
                      "must be >= 0");
  }
  if (linear_solver != "auto" && linear_solver != "sparse_schur" &&
      linear_solver != "dense_schur" && linear_solver != "iterative_schur") {
    throw OptionError(
        &linear_solver, "BundleAdjustment.linear_solver",
        "must be auto, sparse_schur, dense_schur or iterative_schur");
  }
  if (iterative_schur_min_num_images < 1) {
    throw OptionError(&iterative_schur_min_num_images,
                      "BundleAdjustment.iterative_schur_min_num_images",
                      "must be positive");
  }
  solver.Check("BundleAdjustment.");
}

bool RunBundleAdjustment(const BundleAdjustmentOptions& options,
                         Reconstruction* reconstruction,
                         BundleAdjustmentSummary* summary) {
  options.Check();
  Timer timer;
  BundleAdjustmentSummary local_summary;
  local_summary.initial_mean_reproj_error =
      UpdateReprojectionErrors(reconstruction);
  bool success = true;
  for (int round = 0; round < options.num_rounds; ++round) {
    // Huber by reweighting: a few solves, each from the last one's errors.
    const int num_solves = options.loss_function == "huber" ? 3 : 1;
    ceres::Solver::Summary solver_summary;
    for (int solve = 0; solve < num_solves; ++solve) {
      solver_summary =
          Solve(options, reconstruction, &local_summary.problem_seconds);
      local_summary.num_iterations += solver_summary.iterations.size();
      ++local_summary.num_solves;
      local_summary.preprocessor_seconds +=
          solver_summary.preprocessor_time_in_seconds;
      local_summary.linear_solver_seconds +=
          solver_summary.linear_solver_time_in_seconds;
      local_summary.linear_solver = ceres::LinearSolverTypeToString(
          solver_summary.linear_solver_type_used);
      if (solver_summary.termination_type == ceres::FAILURE ||
          solver_summary.iterations.size() <= 2) {
        break;
      }
    }
    ++local_summary.num_rounds;
    local_summary.converged =
        solver_summary.termination_type == ceres::CONVERGENCE;
    if (solver_summary.termination_type == ceres::FAILURE) {
      LOG(WARNING) << "Bundle adjustment: " << solver_summary.message;
      success = false;
      break;
    }
    if (options.max_reproj_error <= 0) break;
    const size_t num_filtered = FilterObservationsWithLargeReprojectionError(
        options.max_reproj_error, reconstruction);
    local_summary.num_observations_filtered += num_filtered;
    if (num_filtered == 0 ||
        num_filtered <
            options.min_filtered_fraction * NumObservations(*reconstruction)) {
      break;
    }
  }
  local_summary.final_mean_reproj_error =
      UpdateReprojectionErrors(reconstruction);
  local_summary.num_images = reconstruction->images.size();
  local_summary.num_points = reconstruction->points3D.size();
  local_summary.num_observations = NumObservations(*reconstruction);
  local_summary.seconds = timer.ElapsedSeconds();
  VLOG(1) << "Bundle adjustment: " << local_summary.num_rounds << " rounds, "
          << local_summary.num_iterations << " iterations, reprojection error "
          << local_summary.initial_mean_reproj_error << " -> "
          << local_summary.final_mean_reproj_error << " px, "
          << local_summary.num_observations_filtered
          << " observations filtered, " << local_summary.seconds << " s ("
          << local_summary.num_solves << " solves with "
          << local_summary.linear_solver << ", building the problems "
          << local_summary.problem_seconds << " s, Ceres' preprocessing "
          << local_summary.preprocessor_seconds << " s, linear solves "
          << local_summary.linear_solver_seconds << " s)";
  if (summary != nullptr) *summary = local_summary;
  return success;
}

}  // namespace colmap_irav4
