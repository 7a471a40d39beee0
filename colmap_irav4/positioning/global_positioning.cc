#include "colmap_irav4/positioning/global_positioning.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <iomanip>
#include <memory>
#include <random>
#include <set>
#include <sstream>
#include <unordered_map>

#include <ceres/ceres.h>
#include <glog/logging.h>

#include "colmap_irav4/geometry/pose_prior_cost.h"
#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/positioning/direction_cost.h"
#include "colmap_irav4/scene/camera_models.h"
#include "colmap_irav4/scene/reconstruction_utils.h"
#include "colmap_irav4/util/ceres_solve.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/random.h"
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
  if (iterative_schur_min_num_images < 0) {
    throw OptionError(&iterative_schur_min_num_images,
                      "GlobalPositioning.iterative_schur_min_num_images",
                      "must be >= 0");
  }
  if (iterative_schur_dense_min_num_images < 0) {
    throw OptionError(&iterative_schur_dense_min_num_images,
                      "GlobalPositioning.iterative_schur_dense_min_num_images",
                      "must be >= 0");
  }
  if (!(iterative_schur_min_density >= 0)) {
    throw OptionError(&iterative_schur_min_density,
                      "GlobalPositioning.iterative_schur_min_density",
                      "must be >= 0");
  }
  if (!(iterative_schur_min_products_per_observation >= 0)) {
    throw OptionError(
        &iterative_schur_min_products_per_observation,
        "GlobalPositioning.iterative_schur_min_products_per_observation",
        "must be >= 0");
  }
  if (!(iterative_schur_min_pairs_per_image >= 0)) {
    throw OptionError(&iterative_schur_min_pairs_per_image,
                      "GlobalPositioning.iterative_schur_min_pairs_per_image",
                      "must be >= 0");
  }
  solver.Check("GlobalPositioning.");
  pose_priors.Check();
}

template <>
const EnumNames<PositioningLinearSolver>& NamesOf<PositioningLinearSolver>() {
  static const EnumNames<PositioningLinearSolver> names = {
      {PositioningLinearSolver::kAuto, "auto"},
      {PositioningLinearSolver::kSparseSchur, "sparse_schur"},
      {PositioningLinearSolver::kDenseSchur, "dense_schur"},
      {PositioningLinearSolver::kIterativeSchur, "iterative_schur"}};
  return names;
}

double SchurProductsPerObservation(const Reconstruction& reconstruction) {
  double products = 0;
  double observations = 0;
  for (const auto& [point3D_id, point] : reconstruction.points3D) {
    double m = 0;
    for (const TrackElement& element : point.track) {
      m += reconstruction.images.count(element.image_id);
    }
    products += m * (m + 1) / 2;
    observations += m;
  }
  return observations > 0 ? products / observations : 0;
}

std::string ChoosePositioningLinearSolver(
    const GlobalPositionerOptions& options, int num_images,
    double schur_density, ceres::Solver::Options* ceres_options,
    double products_per_observation) {
  using Solver = PositioningLinearSolver;
  const Solver solver = options.linear_solver;
  const bool automatic = solver == Solver::kAuto;
  // schur_density of the n (n - 1) / 2 pairs: this many an image.
  const double pairs_per_image = schur_density * (num_images - 1);
  std::ostringstream size;
  size << num_images << " images";
  if (schur_density >= 0) {
    size << ", " << std::fixed << std::setprecision(1) << 100 * schur_density
         << "% of pairs share a point, " << std::setprecision(0)
         << pairs_per_image << " an image";
  }
  if (products_per_observation >= 0) {
    size << ", " << std::fixed << std::setprecision(1)
         << products_per_observation << " block products an observation";
  }
  const bool large = num_images >= options.iterative_schur_min_num_images;
  const bool dense =
      num_images >= options.iterative_schur_dense_min_num_images &&
      schur_density >= 0 &&
      (schur_density >= options.iterative_schur_min_density ||
       pairs_per_image >= options.iterative_schur_min_pairs_per_image);
  const bool long_tracks =
      options.iterative_schur_min_products_per_observation > 0 &&
      products_per_observation >=
          options.iterative_schur_min_products_per_observation;
  std::string reason;
  if (solver == Solver::kDenseSchur || (automatic && num_images < 50)) {
    ceres_options->linear_solver_type = ceres::DENSE_SCHUR;
    reason = automatic ? "fewer than 50 images" : "asked";
  } else if (solver == Solver::kIterativeSchur ||
             (automatic && (large || dense || long_tracks))) {
    ceres_options->linear_solver_type = ceres::ITERATIVE_SCHUR;
    ceres_options->preconditioner_type = ceres::SCHUR_JACOBI;
    ceres_options->use_explicit_schur_complement = false;
    reason = !automatic ? "asked"
             : large
                 ? "at least " +
                       std::to_string(options.iterative_schur_min_num_images) +
                       " images"
             : dense ? "dense reduced camera system"
                     : "long tracks (forming the reduced system costs more "
                       "than conjugate gradients)";
  } else {
    ceres_options->linear_solver_type = ceres::SPARSE_SCHUR;
    reason = automatic ? "sparse or small reduced camera system" : "asked";
  }
  return std::string(ceres::LinearSolverTypeToString(
             ceres_options->linear_solver_type)) +
         ": " + reason + " (" + size.str() + ")";
}

double PositioningSchurDensity(const Reconstruction& reconstruction,
                               int max_num_images) {
  std::vector<const Track*> tracks;
  tracks.reserve(reconstruction.points3D.size());
  for (const auto& [point3D_id, point] : reconstruction.points3D) {
    tracks.push_back(&point.track);
  }
  return SchurDensity(tracks, max_num_images);
}

namespace {

// The mean of unit vectors, after dropping those more than 10 deg from the
// first mean (gravity outliers).
Eigen::Vector3d RobustMeanDirection(const std::vector<Eigen::Vector3d>& dirs) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& d : dirs) mean += d;
  mean.normalize();
  for (int iteration = 0; iteration < 2; ++iteration) {
    Eigen::Vector3d kept = Eigen::Vector3d::Zero();
    for (const Eigen::Vector3d& d : dirs) {
      if (d.dot(mean) > std::cos(DegToRad(10.0))) kept += d;
    }
    if (kept.norm() > 0) mean = kept.normalized();
  }
  return mean;
}

// Heading (rotation about z), scale and offset mapping R_tilt src onto dst
// in least squares, the tilt R_tilt given.
Sim3d FitWithFixedTilt(const Eigen::Matrix3d& tilt,
                       const std::vector<Eigen::Vector3d>& src,
                       const std::vector<Eigen::Vector3d>& dst) {
  Eigen::Vector3d mean_a = Eigen::Vector3d::Zero(), mean_b = mean_a;
  for (size_t k = 0; k < src.size(); ++k) {
    mean_a += tilt * src[k];
    mean_b += dst[k];
  }
  mean_a /= src.size();
  mean_b /= src.size();
  double sin_sum = 0, cos_sum = 0;
  for (size_t k = 0; k < src.size(); ++k) {
    const Eigen::Vector3d a = tilt * src[k] - mean_a, b = dst[k] - mean_b;
    cos_sum += a.x() * b.x() + a.y() * b.y();
    sin_sum += a.x() * b.y() - a.y() * b.x();
  }
  const double heading = std::atan2(sin_sum, cos_sum);
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(heading, Eigen::Vector3d::UnitZ()).toRotationMatrix() *
      tilt;
  double num = 0, den = 0;
  for (size_t k = 0; k < src.size(); ++k) {
    const Eigen::Vector3d a = R * src[k] - R * (tilt.transpose() * mean_a);
    num += a.dot(dst[k] - mean_b);
    den += a.squaredNorm();
  }
  Sim3d sim;
  sim.R = R;
  sim.scale = den > 0 ? num / den : 1.0;
  sim.t = mean_b - sim.scale * (R * (tilt.transpose() * mean_a));
  return sim;
}

}  // namespace

bool EstimatePriorFrameFromModel(
    const std::map<image_t, Eigen::Vector3d>& centers,
    const std::map<image_t, Eigen::Matrix3d>& cam_from_world_rotations,
    const PosePriors& priors, const PosePriorOptions& options, uint64_t seed,
    Sim3d* prior_from_model, std::set<image_t>* inliers, std::string* problem) {
  std::vector<image_t> ids;
  std::vector<Eigen::Vector3d> src, dst, downs;
  std::vector<double> stds;
  for (const auto& [image_id, center] : centers) {
    const auto it = priors.find(image_id);
    if (it == priors.end()) continue;
    if (it->second.HasGravity() && cam_from_world_rotations.count(image_id)) {
      downs.push_back(cam_from_world_rotations.at(image_id).transpose() *
                      it->second.gravity);
    }
    if (!it->second.HasPosition()) continue;
    ids.push_back(image_id);
    src.push_back(center);
    dst.push_back(it->second.position);
    stds.push_back(PositionPriorStd(it->second, options));
  }
  if (static_cast<int>(ids.size()) < options.min_num_positions) {
    *problem = std::to_string(ids.size()) + " images with a position prior (" +
               std::to_string(options.min_num_positions) + " needed)";
    return false;
  }
  // RANSAC's threshold is relative to the priors' spread about their
  // centroid: 3 standard deviations (the median one).
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : dst) centroid += p;
  centroid /= dst.size();
  std::vector<double> spreads;
  for (const Eigen::Vector3d& p : dst) spreads.push_back((p - centroid).norm());
  std::vector<double> sorted_stds = stds;
  std::nth_element(spreads.begin(), spreads.begin() + spreads.size() / 2,
                   spreads.end());
  std::nth_element(sorted_stds.begin(),
                   sorted_stds.begin() + sorted_stds.size() / 2,
                   sorted_stds.end());
  const double spread = spreads[spreads.size() / 2];
  const double threshold = 3.0 * sorted_stds[sorted_stds.size() / 2];
  SimilarityRansacOptions ransac;
  ransac.seed = seed;
  ransac.max_relative_error =
      spread > 0 ? std::clamp(threshold / spread, 1e-3, 0.99) : 0.99;
  Sim3d sim;
  std::vector<bool> is_inlier;
  if (!EstimateSimilarityRansac(src, dst, ransac, &sim, &is_inlier)) {
    *problem =
        "no similarity maps the centres onto the priors (are the "
        "cameras on a line?)";
    return false;
  }
  // RANSAC's threshold, one distance for all and at most the spread, is
  // only a start: the inliers are then the priors within 4 of their own
  // standard deviations (chi-square, 3 degrees of freedom: 99.9%), and the
  // similarity is fitted to them again, until they no longer change.
  std::vector<Eigen::Vector3d> inlier_src, inlier_dst;
  for (int iteration = 0; iteration < 5; ++iteration) {
    std::vector<bool> whitened_inlier(ids.size());
    for (size_t k = 0; k < ids.size(); ++k) {
      whitened_inlier[k] =
          (PositionPriorSqrtInformation(priors.at(ids[k]), options) *
           (sim * src[k] - dst[k]))
              .norm() < 4.0;
    }
    if (whitened_inlier == is_inlier) break;
    inlier_src.clear();
    inlier_dst.clear();
    for (size_t k = 0; k < ids.size(); ++k) {
      if (!whitened_inlier[k]) continue;
      inlier_src.push_back(src[k]);
      inlier_dst.push_back(dst[k]);
    }
    Sim3d refit;
    if (inlier_src.size() < 3 ||
        !EstimateSimilarity(inlier_src, inlier_dst, &refit)) {
      break;
    }
    sim = refit;
    is_inlier = whitened_inlier;
  }
  inlier_src.clear();
  inlier_dst.clear();
  inliers->clear();
  for (size_t k = 0; k < ids.size(); ++k) {
    if (!is_inlier[k]) continue;
    inliers->insert(ids[k]);
    inlier_src.push_back(src[k]);
    inlier_dst.push_back(dst[k]);
  }
  if (downs.size() >= 3 && inlier_src.size() >= 2) {
    // The tilt from gravity: the model's down onto -z (the minimal
    // rotation), then heading, scale and offset from the positions.
    const Eigen::Vector3d down = RobustMeanDirection(downs);
    const Eigen::Matrix3d tilt =
        Eigen::Quaterniond::FromTwoVectors(down, -Eigen::Vector3d::UnitZ())
            .toRotationMatrix();
    sim = FitWithFixedTilt(tilt, inlier_src, inlier_dst);
  }
  if (!(sim.scale > 0) || !sim.R.allFinite() || !sim.t.allFinite()) {
    *problem = "degenerate similarity to the priors";
    return false;
  }
  *prior_from_model = sim;
  return true;
}

namespace {

// The solved parameters: copies of the centres (by image id), then of the
// points (by id), so that each elimination group is in that order (see
// ParameterBlockCopies).
struct PositioningBlocks {
  PositioningBlocks(std::map<image_t, Eigen::Vector3d>* centers,
                    Reconstruction* reconstruction)
      : copies(3 * (centers->size() + reconstruction->points3D.size())) {
    for (auto& [image_id, center] : *centers) {
      this->centers[image_id] = copies.Add(center.data(), 3);
    }
    points.reserve(reconstruction->points3D.size());
    for (auto& [point3D_id, point] : reconstruction->points3D) {
      points.emplace_back(point3D_id, copies.Add(point.xyz.data(), 3));
    }
  }

  // The elimination ordering of `problem`: points, then centres.
  std::shared_ptr<ceres::ParameterBlockOrdering> Ordering(
      const ceres::Problem& problem) const {
    auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
    for (const auto& [point3D_id, point] : points) {
      if (problem.HasParameterBlock(point)) {
        ordering->AddElementToGroup(point, 0);
      }
    }
    for (const auto& [image_id, center] : centers) {
      if (problem.HasParameterBlock(center)) {
        ordering->AddElementToGroup(center, 1);
      }
    }
    return ordering;
  }

  ParameterBlockCopies copies;
  std::map<image_t, double*> centers;
  std::vector<std::pair<point3D_t, double*>> points;  // by id
};

// The position priors' cost functions and loss: the problem owns neither
// (see RunGlobalPositioning), so they live here, as long as it does.
struct PriorTerms {
  std::unique_ptr<ceres::LossFunction> loss;
  std::vector<std::unique_ptr<ceres::CostFunction>> costs;
};

// The second solve of RunGlobalPositioning with position priors (see the
// header): places the solved model (centres, points, rotations) in the
// priors' frame, or leaves it as it is with summary->prior_problem set.
bool SolveWithPriors(
    const GlobalPositionerOptions& options, const PosePriors& priors,
    const std::map<image_t, Eigen::Matrix3d>& world_from_cam,
    image_t gauge_image_id, const SolverOptions& solver,
    ceres::Problem* problem, PriorTerms* prior_terms, PositioningBlocks* blocks,
    std::map<image_t, Eigen::Vector3d>* centers, Reconstruction* reconstruction,
    GlobalPositionerSummary* summary, Sim3d* prior_from_model) {
  std::map<image_t, Eigen::Matrix3d> cam_from_world;
  for (const auto& [image_id, R] : world_from_cam) {
    cam_from_world[image_id] = R.transpose();
    const auto it = priors.find(image_id);
    if (it == priors.end()) continue;
    summary->num_position_priors += it->second.HasPosition();
    summary->num_gravity_priors += it->second.HasGravity();
  }
  Sim3d sim;
  std::set<image_t> inliers;
  if (!EstimatePriorFrameFromModel(*centers, cam_from_world, priors,
                                   options.pose_priors, options.random_seed,
                                   &sim, &inliers, &summary->prior_problem)) {
    LOG(WARNING) << "Global positioning: model not placed in the priors' "
                    "frame: "
                 << summary->prior_problem;
    return false;
  }
  // Every position prior in the model's frame, x = sim^-1(p): the residual
  // W (sim(c) - p) = s W R (c - x).
  const Eigen::Matrix3d model_R_prior = sim.R.transpose();
  prior_terms->loss.reset(new QuadraticCauchyTailLoss(
      options.pose_priors.quadratic_std, options.pose_priors.loss_scale));
  for (auto& [image_id, center] : *centers) {
    const auto it = priors.find(image_id);
    if (it == priors.end() || !it->second.HasPosition()) continue;
    const Eigen::Vector3d target =
        model_R_prior * (it->second.position - sim.t) / sim.scale;
    const Eigen::Matrix3d W =
        sim.scale *
        PositionPriorSqrtInformation(it->second, options.pose_priors) * sim.R;
    prior_terms->costs.emplace_back(PositionPriorCost::Create(target, W));
    problem->AddResidualBlock(prior_terms->costs.back().get(),
                              prior_terms->loss.get(),
                              blocks->centers.at(image_id));
  }
  problem->SetParameterBlockVariable(blocks->centers.at(gauge_image_id));
  // A fresh elimination ordering: Ceres drops the constant gauge centre from
  // the first solve's.
  SolverOptions prior_solver = solver;
  prior_solver.ceres.linear_solver_ordering = blocks->Ordering(*problem);
  const ceres::Solver::Summary solver_summary =
      SolveProblem("global positioning with priors", prior_solver, problem);
  blocks->copies.CopyToModel();
  if (!solver_summary.IsSolutionUsable()) {
    summary->prior_problem =
        "the solve with priors failed: " + solver_summary.message;
    LOG(WARNING) << "Global positioning: " << summary->prior_problem;
    return false;
  }
  summary->num_iterations += solver_summary.iterations.size();
  // The inliers after the solve: within 3 standard deviations.
  summary->num_position_prior_inliers = 0;
  for (const auto& [image_id, center] : *centers) {
    const auto it = priors.find(image_id);
    if (it == priors.end() || !it->second.HasPosition()) continue;
    const Eigen::Vector3d r =
        PositionPriorSqrtInformation(it->second, options.pose_priors) *
        (sim * center - it->second.position);
    summary->num_position_prior_inliers += r.norm() < 3.0;
  }
  *prior_from_model = sim;
  summary->in_prior_frame = true;
  summary->priors_disagree =
      summary->num_position_priors >= 10 &&
      summary->num_position_prior_inliers < 0.8 * summary->num_position_priors;
  if (summary->priors_disagree) {
    LOG(WARNING) << "Global positioning: only "
                 << summary->num_position_prior_inliers << " of "
                 << summary->num_position_priors
                 << " position priors are within 3 standard deviations of "
                    "the model: the priors are poorer than their covariance "
                    "says, or part of the model is turned (a fold); compare "
                    "the model with the map";
  }
  LOG(INFO) << "Global positioning: placed in the priors' frame (scale "
            << sim.scale << ") with " << summary->num_position_priors
            << " position priors (" << inliers.size() << " RANSAC inliers, "
            << summary->num_position_prior_inliers
            << " within 3 std after the solve) and "
            << summary->num_gravity_priors << " gravity priors"
            << (summary->num_gravity_priors >= 3 ? " (they set the up axis)"
                                                 : "");
  return true;
}

// Maps the model (centres, points, rotations) by `sim`.
void TransformModel(const Sim3d& sim,
                    std::map<image_t, Eigen::Vector3d>* centers,
                    Reconstruction* reconstruction) {
  for (auto& [image_id, center] : *centers) center = sim * center;
  for (auto& [point3D_id, point] : reconstruction->points3D) {
    point.xyz = sim * point.xyz;
  }
  const Eigen::Quaterniond model_from_prior(Eigen::Matrix3d(sim.R.transpose()));
  for (auto& [image_id, image] : reconstruction->images) {
    image.cam_from_world.rotation =
        (image.cam_from_world.rotation * model_from_prior).normalized();
  }
}

// Drops the tracks seen by fewer than min_track_length images of the
// reconstruction, then the images no remaining track sees.
void DropShortTracks(int min_track_length, Reconstruction* reconstruction,
                     GlobalPositionerSummary* summary) {
  std::vector<point3D_t> dropped_points;
  std::unordered_map<image_t, int> num_image_observations;
  for (const auto& [point3D_id, point] : reconstruction->points3D) {
    int num_valid = 0;
    for (const TrackElement& element : point.track) {
      num_valid += reconstruction->images.count(element.image_id);
    }
    if (num_valid < min_track_length) {
      dropped_points.push_back(point3D_id);
      continue;
    }
    for (const TrackElement& element : point.track) {
      ++num_image_observations[element.image_id];
    }
  }
  for (point3D_t point3D_id : dropped_points)
    DeletePoint3D(point3D_id, reconstruction);
  summary->num_points_dropped = dropped_points.size();
  std::vector<image_t> dropped_images;
  for (const auto& [image_id, image] : reconstruction->images) {
    if (!num_image_observations.count(image_id))
      dropped_images.push_back(image_id);
  }
  for (image_t image_id : dropped_images) DeleteImage(image_id, reconstruction);
  summary->num_images_dropped = dropped_images.size();
}

// The starting centres (own storage) and points (in place): the model's, or
// random in the initialisation box; translated so that the gauge image (the
// first), returned, is at the origin. Also each image's world_from_cam.
image_t InitializeCenters(const GlobalPositionerOptions& options,
                          Reconstruction* reconstruction,
                          std::map<image_t, Eigen::Vector3d>* centers,
                          std::map<image_t, Eigen::Matrix3d>* world_from_cam) {
  std::mt19937_64 rng(options.random_seed);
  std::uniform_real_distribution<double> uniform(-options.initialization_box,
                                                 options.initialization_box);
  for (const auto& [image_id, image] : reconstruction->images) {
    (*world_from_cam)[image_id] =
        image.cam_from_world.rotation.toRotationMatrix().transpose();
    (*centers)[image_id] = options.random_initialization
                               ? RandomVector<3>(uniform, rng)
                               : image.ProjectionCenter();
  }
  const image_t gauge_image_id = centers->begin()->first;
  if (options.random_initialization) {
    (*centers)[gauge_image_id].setZero();
    for (auto& [point3D_id, point] : reconstruction->points3D) {
      point.xyz = RandomVector<3>(uniform, rng);
    }
  }
  const Eigen::Vector3d gauge_offset = (*centers)[gauge_image_id];
  for (auto& [image_id, center] : *centers) center -= gauge_offset;
  if (!options.random_initialization) {
    for (auto& [point3D_id, point] : reconstruction->points3D)
      point.xyz -= gauge_offset;
  }
  return gauge_image_id;
}

// One observation of a point (16 bytes); its world-frame bearing is kept
// only in its cost function, the entry of the same index in
// PositioningCosts.
struct Observation {
  point3D_t point3D_id;
  image_t image_id;
  point2D_t point2D_idx;
};

// One cost function per observation, in a store of their own (a deque: its
// elements never move, and it grows without copying): the problem does not
// own them, so that it keeps no ownership table and each is one 64-byte
// element instead of two heap objects (see ProjectedDirectionCostFunction).
using PositioningCosts = std::deque<ProjectedDirectionCostFunction>;

// The observations of the points whose normalised coordinates are finite,
// and their cost functions (bearings in the world frame).
void CollectObservations(
    const Reconstruction& reconstruction,
    const std::map<image_t, Eigen::Matrix3d>& world_from_cam,
    std::vector<Observation>* observations, PositioningCosts* costs) {
  size_t num_observations = 0;
  for (const auto& [point3D_id, point] : reconstruction.points3D) {
    num_observations += point.track.size();
  }
  observations->reserve(num_observations);
  for (const auto& [point3D_id, point] : reconstruction.points3D) {
    for (const TrackElement& element : point.track) {
      const Image& image = reconstruction.images.at(element.image_id);
      const Camera& camera = reconstruction.cameras.at(image.camera_id);
      const Eigen::Vector2d normalized =
          CameraImageToCamera(camera, image.points2D[element.point2D_idx].xy);
      if (!normalized.allFinite()) continue;
      observations->push_back(
          {point3D_id, element.image_id, element.point2D_idx});
      costs->emplace_back(world_from_cam.at(element.image_id) *
                          normalized.homogeneous().normalized());
    }
  }
}

// Adds one residual per observation on its centre's and point's copies.
void AddObservationResiduals(const std::vector<Observation>& observations,
                             PositioningCosts* costs, ceres::LossFunction* loss,
                             const PositioningBlocks& blocks,
                             ceres::Problem* problem) {
  for (size_t k = 0; k < observations.size(); ++k) {
    problem->AddResidualBlock(
        &(*costs)[k], loss, blocks.centers.at(observations[k].image_id),
        FindBlock(blocks.points, observations[k].point3D_id));
  }
}

// Deletes the observations whose bearing is more than max_angular_error_deg
// from the ray from the solved centre to the solved point.
void FilterObservationsByAngle(
    double max_angular_error_deg, const std::vector<Observation>& observations,
    const PositioningCosts& costs,
    const std::map<image_t, Eigen::Vector3d>& centers,
    Reconstruction* reconstruction, GlobalPositionerSummary* summary) {
  const double min_cos = std::cos(DegToRad(max_angular_error_deg));
  for (size_t k = 0; k < observations.size(); ++k) {
    const Observation& observation = observations[k];
    auto point_it = reconstruction->points3D.find(observation.point3D_id);
    if (point_it == reconstruction->points3D.end()) continue;
    const Eigen::Vector3d ray =
        point_it->second.xyz - centers.at(observation.image_id);
    if (ray.dot(costs[k].direction()) < min_cos * ray.norm()) {
      DeleteObservation(observation.image_id, observation.point2D_idx,
                        reconstruction);
      ++summary->num_observations_filtered;
    }
  }
}

}  // namespace

bool RunGlobalPositioning(const GlobalPositionerOptions& options,
                          Reconstruction* reconstruction,
                          GlobalPositionerSummary* summary,
                          const PosePriors* priors, double schur_density) {
  options.Check();
  Timer timer;
  GlobalPositionerSummary local_summary;

  DropShortTracks(options.min_track_length, reconstruction, &local_summary);
  if (reconstruction->images.size() < 2) {
    LOG(WARNING) << "Global positioning: fewer than two images are observed by "
                    "tracks of "
                 << options.min_track_length << " or more images";
    if (summary != nullptr) *summary = local_summary;
    return false;
  }

  // Parameters: centres (own storage), points (in place), one scale per
  // observation.
  std::map<image_t, Eigen::Vector3d> centers;
  std::map<image_t, Eigen::Matrix3d> world_from_cam;
  const image_t gauge_image_id =
      InitializeCenters(options, reconstruction, &centers, &world_from_cam);
  std::vector<Observation> observations;
  PositioningCosts costs;  // declared before the problem: outlives it
  CollectObservations(*reconstruction, world_from_cam, &observations, &costs);
  // One loss for all residuals (Ceres evaluates it per residual): not one
  // allocation per observation. Declared first: it outlives the problem.
  const std::unique_ptr<ceres::LossFunction> loss(
      CreateLossFunction(options.loss_function, options.loss_scale));
  PriorTerms prior_terms;  // set by SolveWithPriors
  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  // The cost functions live in `costs`; the position priors' (added by
  // SolveWithPriors) by `prior_terms`.
  problem_options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  PositioningBlocks blocks(&centers, reconstruction);
  AddObservationResiduals(observations, &costs, loss.get(), blocks, &problem);
  problem.SetParameterBlockConstant(blocks.centers.at(gauge_image_id));

  SolverOptions solver = options.solver;
  // The scales are eliminated in the cost (ProjectedDirectionCost), so Schur
  // elimination of the points leaves a camera-sized system: on a synthetic
  // 100-image scene (200k observations) 13 s with explicit scales and a sparse
  // Cholesky, a Schur solver here; which one by its size and density.
  const int num_images = static_cast<int>(centers.size());
  local_summary.schur_density =
      options.linear_solver != PositioningLinearSolver::kAuto || num_images < 50
          ? -1
      : schur_density >= 0 ? schur_density
                           : PositioningSchurDensity(*reconstruction);
  // Counted whatever the solver (a linear pass): the log says what forming
  // the reduced system would cost.
  local_summary.schur_products_per_observation =
      num_images < 50 ? -1 : SchurProductsPerObservation(*reconstruction);
  local_summary.linear_solver_reason = ChoosePositioningLinearSolver(
      options, num_images, local_summary.schur_density, &solver.ceres,
      local_summary.schur_products_per_observation);
  local_summary.linear_solver =
      ceres::LinearSolverTypeToString(solver.ceres.linear_solver_type);
  LOG(INFO) << "Global positioning: " << observations.size()
            << " observations, " << reconstruction->points3D.size()
            << " points; linear solver " << local_summary.linear_solver_reason;
  solver.ceres.linear_solver_ordering = blocks.Ordering(problem);
  const ceres::Solver::Summary solver_summary =
      SolveProblem("global positioning", solver, &problem);
  blocks.copies.CopyToModel();

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

  // With priors: solved again with them, placed in their frame after the
  // filter below (which compares the bearings in the model's frame).
  Sim3d prior_from_model;
  const bool place =
      priors != nullptr && !priors->empty() &&
      SolveWithPriors(options, *priors, world_from_cam, gauge_image_id, solver,
                      &problem, &prior_terms, &blocks, &centers, reconstruction,
                      &local_summary, &prior_from_model);
  if (options.max_angular_error_deg > 0) {
    FilterObservationsByAngle(options.max_angular_error_deg, observations,
                              costs, centers, reconstruction, &local_summary);
  }
  if (place) TransformModel(prior_from_model, &centers, reconstruction);
  for (auto& [image_id, image] : reconstruction->images) {
    image.cam_from_world.translation =
        -(image.cam_from_world.rotation * centers.at(image_id));
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
