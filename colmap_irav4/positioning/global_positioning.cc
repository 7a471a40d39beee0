#include "colmap_irav4/positioning/global_positioning.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <random>
#include <unordered_map>

#include <ceres/ceres.h>
#include <glog/logging.h>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/positioning/direction_cost.h"
#include "colmap_irav4/scene/camera_models.h"
#include "colmap_irav4/scene/reconstruction_utils.h"
#include "colmap_irav4/util/ceres_solve.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/timer.h"

namespace colmap_irav4 {

GlobalPositionerOptions::GlobalPositionerOptions() {
  solver.ceres.max_num_iterations = 200;
  solver.ceres.function_tolerance = 1e-3;
  solver.ceres.gradient_tolerance = 1e-10;
  solver.ceres.parameter_tolerance = 1e-4;
}

void GlobalPositionerOptions::Check() const {
  if (min_track_length < 2) {
    throw OptionError(&min_track_length, "GlobalPositioning.min_track_length",
                      "must be at least 2");
  }
  if (!(loss_scale > 0)) {
    throw OptionError(&loss_scale, "GlobalPositioning.loss_scale",
                      "must be positive");
  }
  if (!(initialization_box > 0)) {
    throw OptionError(&initialization_box,
                      "GlobalPositionerOptions::initialization_box",
                      "must be positive");
  }
  if (!(max_angular_error_deg >= 0 && max_angular_error_deg < 180)) {
    throw OptionError(&max_angular_error_deg,
                      "GlobalPositioning.max_angular_error_deg",
                      "must be in [0, 180)");
  }
  solver.Check("GlobalPositioning.");
}

bool RunGlobalPositioning(const GlobalPositionerOptions& options,
                          Reconstruction* reconstruction,
                          GlobalPositionerSummary* summary) {
  options.Check();
  Timer timer;
  GlobalPositionerSummary local_summary;

  // Tracks long enough, and the images they see.
  std::vector<point3D_t> dropped_points;
  std::unordered_map<image_t, int> num_image_observations;
  for (const auto& [point3D_id, point] : reconstruction->points3D) {
    int num_valid = 0;
    for (const TrackElement& element : point.track) {
      num_valid += reconstruction->images.count(element.image_id);
    }
    if (num_valid < options.min_track_length) {
      dropped_points.push_back(point3D_id);
      continue;
    }
    for (const TrackElement& element : point.track) {
      ++num_image_observations[element.image_id];
    }
  }
  for (point3D_t point3D_id : dropped_points)
    DeletePoint3D(point3D_id, reconstruction);
  local_summary.num_points_dropped = dropped_points.size();
  std::vector<image_t> dropped_images;
  for (const auto& [image_id, image] : reconstruction->images) {
    if (!num_image_observations.count(image_id))
      dropped_images.push_back(image_id);
  }
  for (image_t image_id : dropped_images) DeleteImage(image_id, reconstruction);
  local_summary.num_images_dropped = dropped_images.size();
  if (reconstruction->images.size() < 2) {
    LOG(WARNING) << "Global positioning: fewer than two images are observed by "
                    "tracks of "
                 << options.min_track_length << " or more images";
    if (summary != nullptr) *summary = local_summary;
    return false;
  }

  // Parameters: centres (own storage), points (in place), one scale per
  // observation.
  std::mt19937_64 rng(options.random_seed);
  std::uniform_real_distribution<double> uniform(-options.initialization_box,
                                                 options.initialization_box);
  std::map<image_t, Eigen::Vector3d> centers;
  std::map<image_t, Eigen::Matrix3d> world_from_cam;
  for (const auto& [image_id, image] : reconstruction->images) {
    world_from_cam[image_id] =
        image.cam_from_world.rotation.toRotationMatrix().transpose();
    centers[image_id] =
        options.random_initialization
            ? Eigen::Vector3d(uniform(rng), uniform(rng), uniform(rng))
            : image.ProjectionCenter();
  }
  const image_t gauge_image_id = centers.begin()->first;
  if (options.random_initialization) {
    centers[gauge_image_id].setZero();
    for (auto& [point3D_id, point] : reconstruction->points3D) {
      point.xyz = Eigen::Vector3d(uniform(rng), uniform(rng), uniform(rng));
    }
  }
  // The gauge image's centre is at the origin in the result.
  const Eigen::Vector3d gauge_offset = centers[gauge_image_id];
  for (auto& [image_id, center] : centers) center -= gauge_offset;
  if (!options.random_initialization) {
    for (auto& [point3D_id, point] : reconstruction->points3D)
      point.xyz -= gauge_offset;
  }

  struct Observation {
    point3D_t point3D_id;
    image_t image_id;
    point2D_t point2D_idx;
    Eigen::Vector3d direction;
  };
  std::vector<Observation> observations;
  for (const auto& [point3D_id, point] : reconstruction->points3D) {
    for (const TrackElement& element : point.track) {
      const Image& image = reconstruction->images.at(element.image_id);
      const Camera& camera = reconstruction->cameras.at(image.camera_id);
      const Eigen::Vector2d normalized =
          CameraImageToCamera(camera, image.points2D[element.point2D_idx].xy);
      if (!normalized.allFinite()) continue;
      observations.push_back({point3D_id, element.image_id, element.point2D_idx,
                              world_from_cam.at(element.image_id) *
                                  normalized.homogeneous().normalized()});
    }
  }
  // One loss for all residuals (Ceres evaluates it per residual): not one
  // allocation per observation. Declared first: it outlives the problem.
  const std::unique_ptr<ceres::LossFunction> loss(
      CreateLossFunction(options.loss_function, options.loss_scale));
  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
  for (size_t k = 0; k < observations.size(); ++k) {
    const Observation& observation = observations[k];
    double* center = centers.at(observation.image_id).data();
    double* point =
        reconstruction->points3D.at(observation.point3D_id).xyz.data();
    problem.AddResidualBlock(
        ProjectedDirectionCost::Create(observation.direction), loss.get(),
        center, point);
    ordering->AddElementToGroup(point, 0);
    ordering->AddElementToGroup(center, 1);
  }
  problem.SetParameterBlockConstant(centers.at(gauge_image_id).data());

  SolverOptions solver = options.solver;
  // The scales are eliminated in the cost (ProjectedDirectionCost), so Schur
  // elimination of the points leaves a camera-sized system: on a synthetic
  // 100-image scene (200k observations) 13 s with explicit scales and a sparse
  // Cholesky, DENSE_SCHUR/SPARSE_SCHUR here.
  solver.ceres.linear_solver_type =
      centers.size() < 50 ? ceres::DENSE_SCHUR : ceres::SPARSE_SCHUR;
  solver.ceres.linear_solver_ordering = ordering;
  const ceres::Solver::Summary solver_summary =
      SolveProblem("global positioning", solver, &problem);

  local_summary.num_observations = observations.size();
  local_summary.num_iterations = solver_summary.iterations.size();
  local_summary.initial_cost = solver_summary.initial_cost;
  local_summary.final_cost = solver_summary.final_cost;
  local_summary.converged =
      solver_summary.termination_type == ceres::CONVERGENCE;
  if (!solver_summary.IsSolutionUsable()) {
    LOG(WARNING) << "Global positioning: " << solver_summary.message;
    if (summary != nullptr) *summary = local_summary;
    return false;
  }

  for (auto& [image_id, image] : reconstruction->images) {
    image.cam_from_world.translation =
        -(image.cam_from_world.rotation * centers.at(image_id));
  }
  if (options.max_angular_error_deg > 0) {
    const double min_cos = std::cos(DegToRad(options.max_angular_error_deg));
    for (const Observation& observation : observations) {
      auto point_it = reconstruction->points3D.find(observation.point3D_id);
      if (point_it == reconstruction->points3D.end()) continue;
      const Eigen::Vector3d ray =
          point_it->second.xyz - centers.at(observation.image_id);
      if (ray.dot(observation.direction) < min_cos * ray.norm()) {
        DeleteObservation(observation.image_id, observation.point2D_idx,
                          reconstruction);
        ++local_summary.num_observations_filtered;
      }
    }
  }
  local_summary.num_images = reconstruction->images.size();
  local_summary.num_points = reconstruction->points3D.size();
  local_summary.seconds = timer.ElapsedSeconds();
  VLOG(1) << "Global positioning: " << local_summary.num_images << " images, "
          << local_summary.num_points << " points, "
          << local_summary.num_observations << " observations, "
          << local_summary.num_iterations << " iterations, "
          << local_summary.seconds << " s";
  if (summary != nullptr) *summary = local_summary;
  return true;
}

}  // namespace colmap_irav4
