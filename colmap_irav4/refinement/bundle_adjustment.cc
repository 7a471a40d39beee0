#include "colmap_irav4/refinement/bundle_adjustment.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <map>
#include <memory>
#include <numeric>
#include <set>
#include <sstream>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include <ceres/ceres.h>
#include <glog/logging.h>

#include "colmap_irav4/geometry/pose_prior_cost.h"
#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/geometry/sim3d.h"
#include "colmap_irav4/refinement/filtering.h"
#include "colmap_irav4/refinement/model_rigidity.h"
#include "colmap_irav4/refinement/reprojection_cost.h"
#include "colmap_irav4/refinement/schur_bundle_adjuster.h"
#include "colmap_irav4/scene/camera_models.h"
#include "colmap_irav4/scene/reconstruction_utils.h"
#include "colmap_irav4/util/ceres_solve.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/statistics.h"
#include "colmap_irav4/util/timer.h"

namespace colmap_irav4 {
namespace {

// The initial trust region radius of a solve started again after an
// undamped start failed (Ceres' default: Levenberg-Marquardt's damping).
constexpr double kDampedTrustRegionRadius = 1e4;

// A quadratic prior on one parameter of a camera's block of `num_params`:
// (params[index] - value) / std (SchurBundleAdjuster::SetCameraPrior's).
class CameraParamPriorCost final : public ceres::CostFunction {
 public:
  CameraParamPriorCost(int num_params, int index, double value, double std)
      : index_(index), value_(value), std_(std) {
    set_num_residuals(1);
    mutable_parameter_block_sizes()->push_back(num_params);
  }
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    residuals[0] = (parameters[0][index_] - value_) / std_;
    if (jacobians != nullptr && jacobians[0] != nullptr) {
      std::fill(jacobians[0], jacobians[0] + parameter_block_sizes()[0], 0.0);
      jacobians[0][index_] = 1 / std_;
    }
    return true;
  }

 private:
  const int index_;
  const double value_;
  const double std_;
};

// ceres::AutoDiffCostFunction with the functor held in place: one
// allocation per observation instead of two (48 bytes less each; a model's
// every observation is a residual block). Same derivatives: Ceres' own
// automatic differentiation, as AutoDiffCostFunction::Evaluate calls it.
template <int kNumParams>
class ReprojectionCostFunction final
    : public ceres::SizedCostFunction<2, 4, 3, 3, kNumParams> {
 public:
  using ParameterDims =
      typename ceres::SizedCostFunction<2, 4, 3, 3, kNumParams>::ParameterDims;

  explicit ReprojectionCostFunction(const ReprojectionCost<kNumParams>& cost)
      : cost_(cost) {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    if (jacobians == nullptr) {
      return ceres::internal::VariadicEvaluate<ParameterDims>(cost_, parameters,
                                                              residuals);
    }
    return ceres::internal::AutoDifferentiate<2, ParameterDims>(
        cost_, parameters, 2, residuals, jacobians);
  }

 private:
  const ReprojectionCost<kNumParams> cost_;
};

ceres::CostFunction* CreateReprojectionCost(int model_id,
                                            const Eigen::Vector2d& xy,
                                            const double* weight, bool center) {
  ceres::CostFunction* cost = nullptr;
  CHECK(WithNumCameraParams(
      CameraModelNumParams(model_id),
      [&](auto n) {
        cost = new ReprojectionCostFunction<decltype(n)::value>(
            ReprojectionCost<decltype(n)::value>(model_id, xy, weight, center));
      }))
      << "unsupported camera model " << model_id;
  return cost;
}

// The poses that hold the gauge of a model whose parts may share no point
// or be joined through one image only. A part that shares no point with the
// rest has a similarity of its own, one joined to it through one image a
// scale about that image's centre; each such freedom left free makes the
// reduced camera system singular. (The photo-collection scene's slow first
// adjustment is not this: parts tied by a few points are nearly, not
// exactly, free; docs/notes/2026-12-03-photo-collection-scenes.md.) Every
// connected part holds its first image and one coordinate of a second,
// and each further 2-connected block of images sharing points, reached
// through its articulation image, one coordinate of another of its images.
// The second is the image farthest from the first (from the joint;
// ScaleImage, BundleAdjustmentOptions::gauge_scale_farthest). Only images
// of `images` (those adjusted) hold the gauge: a block's first images not
// among them are passed over, and a block joined through an image not
// among them is a part of its own.
struct GaugeHolds {
  std::set<image_t> held;                  // pose constant
  std::map<image_t, image_t> scale_about;  // one coordinate held: the image
                                           // the scale turns about
  int num_pieces = 0;
  int num_joints = 0;
};

// The image of `candidates` other than `about` that holds the scale about
// it (kInvalidImageId: none): the one whose centre is farthest from
// `about`'s (the first of equals; `farthest`), or the first. Held on a short
// baseline (two neighbours of a kilometre-long street), the rest of the
// model sways about the pair, and Gauss-Newton's steps along those nearly
// free motions fail far from it.
image_t ScaleImage(const Reconstruction& reconstruction,
                   const std::vector<image_t>& candidates, image_t about,
                   bool farthest) {
  const Eigen::Vector3d center =
      reconstruction.images.at(about).ProjectionCenter();
  image_t chosen = kInvalidImageId;
  double max_distance = -1;
  for (const image_t image_id : candidates) {
    if (image_id == about) continue;
    if (!farthest) return image_id;
    const double distance =
        (reconstruction.images.at(image_id).ProjectionCenter() - center)
            .squaredNorm();
    if (distance > max_distance) {
      max_distance = distance;
      chosen = image_id;
    }
  }
  return chosen;
}

GaugeHolds FindGaugeHolds(const Reconstruction& reconstruction,
                          const std::set<image_t>& images,
                          int min_shared_points, bool scale_farthest) {
  ModelRigidityOptions options;
  options.min_shared_points = min_shared_points;
  const std::vector<std::vector<image_t>> blocks =
      AnalyzeModelRigidity(options, reconstruction, 1).joined_blocks;
  std::map<image_t, std::vector<size_t>> blocks_of;
  for (size_t b = 0; b < blocks.size(); ++b) {
    for (const image_t image_id : blocks[b]) blocks_of[image_id].push_back(b);
  }
  // Roots: the largest block first, then images in no block (they share no
  // point with any image).
  std::vector<size_t> order(blocks.size());
  for (size_t b = 0; b < order.size(); ++b) order[b] = b;
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return blocks[a].size() > blocks[b].size();
  });
  GaugeHolds holds;
  std::vector<char> reached(blocks.size(), 0);
  for (const size_t root : order) {
    if (reached[root]) continue;
    reached[root] = 1;
    std::vector<image_t> adjusted;
    for (const image_t image_id : blocks[root]) {
      if (images.count(image_id) > 0) adjusted.push_back(image_id);
    }
    if (adjusted.empty()) continue;
    ++holds.num_pieces;
    holds.held.insert(adjusted[0]);
    const image_t scale_image =
        ScaleImage(reconstruction, adjusted, adjusted[0], scale_farthest);
    if (scale_image != kInvalidImageId) {
      holds.scale_about[scale_image] = adjusted[0];
    }
    std::vector<size_t> queue = {root};
    while (!queue.empty()) {
      const size_t b = queue.back();
      queue.pop_back();
      for (const image_t joint : blocks[b]) {
        if (images.count(joint) == 0) continue;
        for (const size_t next : blocks_of[joint]) {
          if (reached[next]) continue;
          reached[next] = 1;
          ++holds.num_joints;
          // Blocks form a tree: only the joint is reached already.
          std::vector<image_t> others;
          for (const image_t other : blocks[next]) {
            if (images.count(other) > 0) others.push_back(other);
          }
          const image_t scale_image =
              ScaleImage(reconstruction, others, joint, scale_farthest);
          if (scale_image != kInvalidImageId) {
            holds.scale_about[scale_image] = joint;
          }
          queue.push_back(next);
        }
      }
    }
  }
  // An image in no block shares no point with another (with a threshold
  // over one point: fewer than it with each other image; such an image is
  // refined unless it shares no point at all).
  std::set<image_t> tied;
  if (min_shared_points > 1) {
    options.min_shared_points = 1;
    for (const std::vector<image_t>& block :
         AnalyzeModelRigidity(options, reconstruction, 1).joined_blocks) {
      tied.insert(block.begin(), block.end());
    }
  }
  for (const image_t image_id : images) {
    if (blocks_of.count(image_id) == 0 && tied.count(image_id) == 0 &&
        holds.held.insert(image_id).second) {
      ++holds.num_pieces;
    }
  }
  return holds;
}

// CostStall for Ceres' minimizer: ends the solve (USER_SUCCESS) once the
// cost of its accepted steps has stalled.
class StallCallback : public ceres::IterationCallback {
 public:
  StallCallback(int num_steps, double relative_decrease)
      : stall_(num_steps, relative_decrease) {}
  ceres::CallbackReturnType operator()(
      const ceres::IterationSummary& iteration) override {
    if ((iteration.iteration == 0 || iteration.step_is_successful) &&
        stall_.Add(iteration.cost)) {
      stalled_ = true;
      return ceres::SOLVER_TERMINATE_SUCCESSFULLY;
    }
    return ceres::SOLVER_CONTINUE;
  }
  bool stalled() const { return stalled_; }

 private:
  CostStall stall_;
  bool stalled_ = false;
};

// The Ceres problem of one bundle adjustment, built once and kept for all
// its solves. Each observation's residual is scaled by a weight its cost
// reads when evaluated: the Huber reweighting sets the weights, and the
// filter between rounds sets those of the observations it unlinks to zero
// (removing residual blocks would need Ceres' fast removal, a set of blocks
// per parameter block, which made building slower than rebuilding). Points the
// filter leaves with fewer than two observations are held constant and deleted
// when it is done (the problem points at their coordinates).
class BundleAdjustmentProblem {
 public:
  BundleAdjustmentProblem(const BundleAdjustmentOptions& options,
                          Reconstruction* reconstruction,
                          const PosePriors* priors)
      : options_(options),
        reconstruction_(reconstruction),
        priors_(priors),
        huber_(options.loss_function == BundleAdjustmentLoss::kHuber),
        schur_(ChooseSchurBackend(options, NumObservations(*reconstruction),
                                  &backend_reason_)),
        weighted_(huber_ || options.weight_by_keypoint_scale || schur_ ||
                  (options.num_rounds > 1 && options.max_reproj_error > 0)),
        ordering_(std::make_shared<ceres::ParameterBlockOrdering>()) {
    if (schur_) {
      SchurSolverOptions schur_options;
      schur_options.linear_solver = options.schur_linear_solver;
      schur_options.max_factor_mib = options.schur_max_factor_mib;
      schur_options.max_factor_gflops = options.schur_max_factor_gflops;
      schur_options.max_cell_table_mib = options.schur_max_cell_table_mib;
      schur_options.max_jacobian_store_mib =
          options.schur_max_jacobian_store_mib;
      schur_options.locality_order_min_mib =
          options.schur_locality_order_min_mib;
      schur_options.prefetch_updates_min_mib =
          options.schur_prefetch_updates_min_mib;
      schur_options.eta = options.schur_iterative_eta;
      schur_options.max_cg_iterations = options.schur_max_cg_iterations;
      schur_options.coarse_cluster_size = options.schur_coarse_cluster_size;
      schur_options.coarse_max_clusters = options.schur_coarse_max_clusters;
      schur_options.implicit_min_mib = options.schur_implicit_min_mib;
      schur_options.implicit_single_precision =
          options.schur_implicit_single_precision;
      schur_options.implicit_avx2 = options.schur_implicit_avx2;
      schur_options.reuse_min_radius = options.schur_reuse_min_radius;
      schur_options.point_iterations = options.schur_point_iterations;
      schur_adjuster_ =
          std::make_unique<SchurBundleAdjuster>(use_centers_, schur_options);
    }
    ceres::Problem::Options problem_options;
    problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    problem_ = std::make_unique<ceres::Problem>(problem_options);
    Build();
  }

  ~BundleAdjustmentProblem() {
    // The model is whole again: no point with fewer than two observations.
    problem_.reset();
    for (const point3D_t point3D_id : held_points_) {
      DeletePoint3D(point3D_id, reconstruction_);
    }
  }

  bool Empty() const {
    return schur_ ? schur_adjuster_->NumObservations() == 0
                  : problem_->NumResidualBlocks() == 0;
  }
  bool Schur() const { return schur_; }
  const std::string& BackendReason() const { return backend_reason_; }
  int NumPositionPriors() const { return num_position_priors_; }
  int NumGravityPriors() const { return num_gravity_priors_; }
  // Parts of the model that share no point, and parts joined to the rest
  // through one image only (GaugeHolds).
  int NumPieces() const { return num_pieces_; }
  int NumJoints() const { return num_joints_; }
  // Images left out for few observations (min_num_image_observations).
  int NumImagesLeftOut() const { return num_images_left_out_; }
  // Cameras with a focal length prior (focal_prior_std and
  // guessed_focal_prior_std).
  int NumFocalPriors() const { return num_focal_priors_; }
  // Cameras held for few observations (min_num_intrinsics_observations).
  int NumIntrinsicsHeld() const { return num_intrinsics_held_; }

  // The scale bins' inner edges and their noise at the last reweighting
  // (BundleAdjustmentSummary).
  std::vector<double> ScaleBinEdges() const {
    return std::vector<double>(noise_.edges.begin(), noise_.edges.end());
  }
  const std::vector<double>& ScaleBinNoise() const { return bin_noise_; }
  // The relative noise of the scale bins at the last reweighting; empty when
  // the observations are not weighed by scale.
  const KeypointScaleNoise& Noise() const { return noise_; }

  // "huber" is iteratively reweighted: each solve weighs an observation by
  // Huber's weight min(1, scale / error) at its error when the solve starts
  // (the residual by its square root). Ceres' HuberLoss ("huber_ceres")
  // makes Levenberg-Marquardt crawl whenever many residuals sit in the
  // linear region (its corrector drops their curvature): 59 iterations
  // instead of 12 on fountain-P11 for the same result.
  //
  // With scale bins, each residual is first divided by the noise of its
  // keypoint scale bin (the bin's median error), relative to the median error
  // of all: the loss scale keeps its meaning in pixels of a typical keypoint.
  void Reweight() {
    if (noise_.edges.empty()) {
      if (!huber_) return;
      ForEachLiveObservation([&](const Image& image, const Camera& camera,
                                 point2D_t idx, double* weight) {
        *weight = HuberWeight(ObservationError(image, camera, idx));
      });
      return;
    }
    // Floats: the errors of all observations are held at once.
    std::vector<float> errors;
    std::vector<std::vector<float>> bin_errors(noise_.edges.size() + 1);
    ForEachLiveObservation(
        [&](const Image& image, const Camera& camera, point2D_t idx, double*) {
          errors.push_back(
              static_cast<float>(ObservationError(image, camera, idx)));
          bin_errors[noise_.Bin(image.points2D[idx].scale)].push_back(
              errors.back());
        });
    const double all_noise = Median(errors);
    std::vector<double> bin_weights(bin_errors.size(), 1.0);
    bin_noise_.assign(bin_errors.size(), 0.0);
    noise_.factors.assign(bin_errors.size(), 1.0);
    for (size_t b = 0; b < bin_errors.size(); ++b) {
      bin_noise_[b] = Median(std::move(bin_errors[b]));
      // Bounded, so that a degenerate bin (errors all but zero) cannot take
      // the adjustment over.
      if (bin_noise_[b] > 0 && all_noise > 0) {
        bin_weights[b] = std::clamp(all_noise / bin_noise_[b], 0.25, 4.0);
        noise_.factors[b] = std::clamp(bin_noise_[b] / all_noise, 0.25, 4.0);
      }
    }
    size_t k = 0;
    ForEachLiveObservation(
        [&](const Image& image, const Camera&, point2D_t idx, double* weight) {
          const double bin_weight =
              bin_weights[noise_.Bin(image.points2D[idx].scale)];
          *weight = bin_weight * HuberWeight(bin_weight * errors[k++]);
        });
  }

  // One solve's outcome, whoever solved.
  struct SolveSummary {
    ceres::TerminationType termination = ceres::FAILURE;
    std::string message;
    int num_iterations = 0;         // Ceres' count (iteration 0 included)
    int num_linear_iterations = 0;  // the Schur solver's conjugate gradients
    bool stalled = false;           // stopped by CostStall
    double preprocessor_seconds = 0;
    double linear_solver_seconds = 0;
    std::string linear_solver;
  };

  // The stall rule's window for this adjustment (0: off).
  int StallNumIterations() const {
    return num_images_ >= options_.stall_min_num_images
               ? options_.stall_num_iterations
               : 0;
  }

  // The conjugate gradients' model rule for this adjustment (0: off),
  // gated by the images it holds as the stall rule is.
  double ModelTolerance() const {
    return num_images_ >= options_.schur_iterative_model_min_num_images
               ? options_.schur_iterative_model_tolerance
               : 0;
  }

  // `initial_trust_region_radius` (> 0) replaces the options' radius.
  SolveSummary Solve(double initial_trust_region_radius = 0) {
    SolveSummary summary;
    SolverOptions solver = options_.solver;
    if (initial_trust_region_radius > 0) {
      solver.ceres.initial_trust_region_radius = initial_trust_region_radius;
    }
    if (schur_) {
      const SchurBundleAdjuster::Summary schur = schur_adjuster_->Solve(
          solver.ceres, options_.rejected_start_trust_region_radius,
          StallNumIterations(), options_.stall_relative_decrease,
          ModelTolerance());
      summary.termination = schur.termination;
      summary.stalled = schur.stalled;
      summary.message = schur.message;
      summary.num_iterations = schur.num_iterations;
      summary.num_linear_iterations = schur.num_linear_iterations;
      summary.linear_solver_seconds = schur.linear_solver_seconds;
      summary.linear_solver = schur.implicit     ? "SCHUR_IMPLICIT_PCG"
                              : schur.iterative  ? "SCHUR_ITERATIVE_PCG"
                              : schur.supernodal ? "SCHUR_SUPERNODAL_LLT"
                                                 : "SCHUR_SIMPLICIAL_LLT";
      linear_solver_reason_ =
          "schur (ours): " + std::to_string(schur.num_reduced_parameters) +
          " reduced parameters, " + std::to_string(schur.num_reduced_nonzeros) +
          " stored entries; " + schur.linear_solver_reason;
    } else {
      linear_solver_reason_ = ChooseLinearSolver(options_, num_images_,
                                                 schur_density_, &solver.ceres);
      if (options_.refine_points) {
        solver.ceres.linear_solver_ordering = ordering_;
      }
      StallCallback stall(StallNumIterations(),
                          options_.stall_relative_decrease);
      if (StallNumIterations() > 0) {
        solver.ceres.callbacks.push_back(&stall);
      }
      const ceres::Solver::Summary ceres_summary =
          SolveProblem("bundle adjustment", solver, problem_.get());
      summary.termination = ceres_summary.termination_type;
      if (stall.stalled()) {
        summary.termination = ceres::CONVERGENCE;
        summary.stalled = true;
      }
      summary.message = ceres_summary.message;
      summary.num_iterations = ceres_summary.iterations.size();
      summary.preprocessor_seconds = ceres_summary.preprocessor_time_in_seconds;
      summary.linear_solver_seconds =
          ceres_summary.linear_solver_time_in_seconds;
      summary.linear_solver = ceres::LinearSolverTypeToString(
          ceres_summary.linear_solver_type_used);
    }
    // The model from the solved copies, its poses from the solved centres
    // (the filter and the reweighting read them).
    copies_->CopyToModel();
    for (const auto& [image_id, center] : centers_) {
      if (refined_poses_.count(image_id) == 0) {
        continue;  // held: the model's pose stays as it was, bit for bit
      }
      Rigid3d& pose = reconstruction_->images.at(image_id).cam_from_world;
      pose.translation = -(pose.rotation * center);
    }
    return summary;
  }

  // Unlinks from the model the observations whose reprojection error is
  // above max_reproj_error (FindObservationsWithLargeReprojectionError; in
  // units of the scale bins' noise with filter_by_keypoint_noise) and zeroes
  // their weights. Returns the number unlinked.
  size_t Filter(double max_reproj_error) {
    CHECK(weighted_);
    size_t num_filtered = 0;
    std::unordered_set<point3D_t> held_this_pass;
    for (const TrackElement& element :
         FindObservationsWithLargeReprojectionError(
             max_reproj_error, *reconstruction_,
             options_.filter_by_keypoint_noise ? &noise_ : nullptr)) {
      const point3D_t point3D_id = reconstruction_->images.at(element.image_id)
                                       .points2D.at(element.point2D_idx)
                                       .point3D_id;
      Point3D& point = reconstruction_->points3D.at(point3D_id);
      if (point.track.size() < 2) {
        // Held (deleted at the end). An outlier of a point held by this
        // pass counts, as it did when the point was deleted at once.
        num_filtered += held_this_pass.count(point3D_id);
        continue;
      }
      Unweigh(element);
      ++num_filtered;
      if (point.track.size() == 2) {
        // Its last observation cannot fix it: held constant, weightless.
        held_points_.push_back(point3D_id);
        held_this_pass.insert(point3D_id);
        for (const TrackElement& other : point.track) Unweigh(other);
        double* block = FindBlock(points_, point3D_id);
        if (problem_->HasParameterBlock(block)) {
          problem_->SetParameterBlockConstant(block);
        }
      }
      UnlinkObservation(element.image_id, element.point2D_idx, reconstruction_);
    }
    return num_filtered;
  }

 private:
  // Zero for an observation without a residual block (behind its camera
  // when the problem was built) too.
  void Unweigh(const TrackElement& element) {
    const auto it = weights_.find(element.image_id);
    if (it != weights_.end()) it->second[element.point2D_idx] = 0.0;
  }

  // Calls f(image, camera, point2D_idx, weight) for each observation of the
  // model with a non-zero weight.
  template <typename F>
  void ForEachLiveObservation(F&& f) {
    for (auto& [image_id, weights] : weights_) {
      const Image& image = reconstruction_->images.at(image_id);
      const Camera& camera = reconstruction_->cameras.at(image.camera_id);
      for (point2D_t idx = 0; idx < weights.size(); ++idx) {
        if (weights[idx] > 0) f(image, camera, idx, &weights[idx]);
      }
    }
  }

  double ObservationError(const Image& image, const Camera& camera,
                          point2D_t idx) const {
    const Point2D& point2D = image.points2D[idx];
    return ReprojectionError(
        camera, image, reconstruction_->points3D.at(point2D.point3D_id).xyz,
        point2D.xy);
  }

  // The residual's factor of the Huber reweighting at `error` (1 without it).
  double HuberWeight(double error) const {
    return huber_ && error > options_.loss_scale
               ? std::sqrt(options_.loss_scale / error)
               : 1.0;
  }

  // noise_.edges: the kNumKeypointScaleBins - 1 inner edges of equal-count
  // bins over the scales of the observations with a residual block; none
  // (no scale weighting) unless every one has a scale and they differ.
  void FindScaleBins() {
    if (!options_.weight_by_keypoint_scale) return;
    std::vector<float> scales;
    bool all_known = true;
    ForEachLiveObservation(
        [&](const Image& image, const Camera&, point2D_t idx, double*) {
          const float scale = image.points2D[idx].scale;
          if (!(scale > 0) || !std::isfinite(scale)) all_known = false;
          scales.push_back(scale);
        });
    if (!all_known ||
        scales.size() < kNumKeypointScaleBins * kMinObservationsPerScaleBin) {
      return;
    }
    std::sort(scales.begin(), scales.end());
    if (scales.front() == scales.back()) return;
    for (int b = 1; b < kNumKeypointScaleBins; ++b) {
      noise_.edges.push_back(scales[b * scales.size() / kNumKeypointScaleBins]);
    }
  }

  // The parameters in copies_ (see ParameterBlockCopies): the poses by image
  // id (rotation, then the centre or the translation), the cameras', then the
  // points' in id order; each elimination group is ordered so.
  void CopyParameters() {
    size_t size = 3 * reconstruction_->points3D.size() +
                  7 * reconstruction_->images.size();
    for (const auto& [camera_id, camera] : reconstruction_->cameras) {
      size += camera.params.size();
    }
    copies_ = std::make_unique<ParameterBlockCopies>(size);
    for (auto& [image_id, image] : reconstruction_->images) {
      double* rotation =
          copies_->Add(image.cam_from_world.rotation.coeffs().data(), 4);
      double* position =
          copies_->Add(use_centers_ ? centers_.at(image_id).data()
                                    : image.cam_from_world.translation.data(),
                       3);
      poses_[image_id] = {rotation, position, -1};
    }
    for (auto& [camera_id, camera] : reconstruction_->cameras) {
      cameras_[camera_id] =
          copies_->Add(camera.params.data(), camera.params.size());
    }
    points_.reserve(reconstruction_->points3D.size());
    for (auto& [point3D_id, point] : reconstruction_->points3D) {
      points_.emplace_back(point3D_id, copies_->Add(point.xyz.data(), 3));
    }
  }

  void Build() {
    if (options_.loss_function == BundleAdjustmentLoss::kHuberCeres) {
      loss_.reset(
          CreateLossFunction(LossFunctionType::kHuber, options_.loss_scale));
    } else if (options_.loss_function == BundleAdjustmentLoss::kCauchy) {
      loss_.reset(
          CreateLossFunction(LossFunctionType::kCauchy, options_.loss_scale));
    }
    for (auto& [image_id, image] : reconstruction_->images) {
      image.cam_from_world.rotation.normalize();
    }
    if (use_centers_) {
      for (auto& [image_id, image] : reconstruction_->images) {
        centers_[image_id] = image.ProjectionCenter();
      }
    }
    CopyParameters();
    if (schur_) AddSchurPosesAndCameras();
    std::vector<std::pair<int, point2D_t>> schur_observations;
    std::set<image_t> used_images;
    std::set<camera_t> used_cameras;
    // Images of fewer observations (in front of them) are left out.
    std::unordered_set<image_t> left_out;
    std::unordered_map<image_t, int> num_observations;
    if (options_.min_num_image_observations > 0 ||
        options_.min_num_intrinsics_observations > 0) {
      for (const auto& [point3D_id, point] : reconstruction_->points3D) {
        for (const TrackElement& element : point.track) {
          const Image& image = reconstruction_->images.at(element.image_id);
          if ((image.cam_from_world * point.xyz).z() > 0) {
            ++num_observations[element.image_id];
          }
        }
      }
    }
    if (options_.min_num_image_observations > 0) {
      for (const auto& [image_id, image] : reconstruction_->images) {
        const int n = num_observations[image_id];
        if (n > 0 && n < options_.min_num_image_observations) {
          VLOG(2) << "Bundle adjustment: image " << image_id << " ("
                  << image.name << ") left out: " << n << " observations";
          left_out.insert(image_id);
        }
      }
      num_images_left_out_ = static_cast<int>(left_out.size());
    }
    size_t point_index = 0;
    for (auto& [point3D_id, point] : reconstruction_->points3D) {
      double* point_block = points_[point_index++].second;
      schur_observations.clear();
      int num_adjusted = 0;
      for (const TrackElement& element : point.track) {
        Image& image = reconstruction_->images.at(element.image_id);
        Camera& camera = reconstruction_->cameras.at(image.camera_id);
        // Points behind the camera would give meaningless residuals; the
        // filtering between rounds removes them.
        if ((image.cam_from_world * point.xyz).z() <= 0) continue;
        if (left_out.count(element.image_id) > 0) continue;
        ++num_adjusted;
        const double* weight = nullptr;
        if (weighted_) {
          // Sized once per image, before any address is taken (0: no
          // residual block).
          std::vector<double>& weights = weights_[element.image_id];
          if (weights.empty()) weights.assign(image.points2D.size(), 0.0);
          weights[element.point2D_idx] = 1.0;
          weight = &weights[element.point2D_idx];
        }
        const PoseBlocks& pose = poses_.at(element.image_id);
        if (schur_) {
          schur_observations.emplace_back(pose.schur_index,
                                          element.point2D_idx);
        } else {
          problem_->AddResidualBlock(
              CreateReprojectionCost(camera.model_id,
                                     image.points2D[element.point2D_idx].xy,
                                     weight, use_centers_),
              loss_.get(), pose.rotation, pose.position, point_block,
              cameras_.at(image.camera_id));
        }
        used_images.insert(element.image_id);
        used_cameras.insert(image.camera_id);
      }
      if (schur_) {
        if (!schur_observations.empty()) {
          schur_adjuster_->AddPoint(point_block, !options_.refine_points,
                                    schur_observations);
        }
      } else if (problem_->HasParameterBlock(point_block)) {
        ordering_->AddElementToGroup(point_block, 0);
        // (The Schur solver holds a point of fewer than two weighed
        // observations itself.)
        if (!options_.refine_points || num_adjusted < 2) {
          problem_->SetParameterBlockConstant(point_block);
        }
      }
    }
    num_images_ = static_cast<int>(used_images.size());
    if (Empty()) return;
    // Only auto's choice needs it (a pass over the tracks).
    if (!schur_ &&
        options_.linear_solver == BundleAdjustmentLinearSolver::kAuto &&
        num_images_ >= 50) {
      std::vector<const Track*> tracks;
      tracks.reserve(reconstruction_->points3D.size());
      for (const auto& [point3D_id, point] : reconstruction_->points3D) {
        tracks.push_back(&point.track);
      }
      schur_density_ = colmap_irav4::SchurDensity(tracks);
    }
    FindScaleBins();

    // Poses and gauge (held by the position priors when there are enough).
    std::vector<image_t> images(used_images.begin(), used_images.end());
    const bool prior_gauge = AddPosePriors(images);
    const bool fix_gauge =
        options_.fix_gauge && !prior_gauge && options_.refine_poses;
    const GaugeHolds holds =
        fix_gauge ? FindGaugeHolds(*reconstruction_, used_images,
                                   options_.gauge_min_shared_points,
                                   options_.gauge_scale_farthest)
                  : GaugeHolds();
    num_pieces_ = holds.num_pieces;
    num_joints_ = holds.num_joints;
    for (size_t k = 0; k < images.size(); ++k) {
      const PoseBlocks& pose = poses_.at(images[k]);
      double* rotation = pose.rotation;
      double* position = pose.position;
      const bool held =
          !options_.refine_poses || holds.held.count(images[k]) > 0;
      const auto scale_hold = holds.scale_about.find(images[k]);
      const int fixed_coordinate =
          !held && scale_hold != holds.scale_about.end()
              ? GaugeCoordinate(images[k], scale_hold->second)
              : -1;
      if (!held) refined_poses_.insert(images[k]);
      if (schur_) {
        schur_adjuster_->SetPoseConstant(pose.schur_index, held,
                                         fixed_coordinate);
        continue;
      }
      ordering_->AddElementToGroup(rotation, 1);
      ordering_->AddElementToGroup(position, 1);
      problem_->SetManifold(rotation, new ceres::EigenQuaternionManifold());
      if (held) {
        problem_->SetParameterBlockConstant(rotation);
        problem_->SetParameterBlockConstant(position);
      } else if (fixed_coordinate >= 0) {
        problem_->SetManifold(position,
                              new ceres::SubsetManifold(3, {fixed_coordinate}));
      }
    }

    // Intrinsics; a camera of few observations (all its images') is held.
    std::unordered_map<camera_t, int> camera_observations;
    if (options_.min_num_intrinsics_observations > 0) {
      for (const image_t image_id : used_images) {
        camera_observations[reconstruction_->images.at(image_id).camera_id] +=
            num_observations[image_id];
      }
    }
    for (camera_t camera_id : used_cameras) {
      const Camera& camera = reconstruction_->cameras.at(camera_id);
      double* params = cameras_.at(camera_id);
      std::vector<int> constant;
      auto add = [&constant](const std::vector<int>& idxs) {
        constant.insert(constant.end(), idxs.begin(), idxs.end());
      };
      if (!options_.refine_focal_length)
        add(CameraModelFocalLengthIdxs(camera.model_id));
      if (!options_.refine_principal_point)
        add(CameraModelPrincipalPointIdxs(camera.model_id));
      if (!options_.refine_extra_params)
        add(CameraModelExtraParamsIdxs(camera.model_id));
      const bool intrinsics_held =
          options_.min_num_intrinsics_observations > 0 &&
          camera_observations[camera_id] <
              options_.min_num_intrinsics_observations;
      if (intrinsics_held) {
        constant.resize(camera.params.size());
        std::iota(constant.begin(), constant.end(), 0);
        ++num_intrinsics_held_;
        VLOG(2) << "Bundle adjustment: camera " << camera_id
                << " held: " << camera_observations[camera_id]
                << " observations";
      }
      // The focal length prior at its value now (one focal length models).
      const std::vector<int> focal =
          CameraModelFocalLengthIdxs(camera.model_id);
      const double prior_std = camera.has_prior_focal_length
                                   ? options_.focal_prior_std
                                   : options_.guessed_focal_prior_std;
      const bool focal_prior = options_.refine_focal_length &&
                               !intrinsics_held && prior_std > 0 &&
                               focal.size() == 1 && camera.params[focal[0]] > 0;
      const double focal_value = focal_prior ? camera.params[focal[0]] : 0;
      if (focal_prior) ++num_focal_priors_;
      if (schur_) {
        const int index = schur_cameras_.at(camera_id);
        schur_adjuster_->SetCameraConstant(index, constant);
        if (focal_prior) {
          schur_adjuster_->SetCameraPrior(index, focal[0], focal_value,
                                          prior_std * focal_value);
        }
        continue;
      }
      ordering_->AddElementToGroup(params, 1);
      const int num_params = camera.params.size();
      if (static_cast<int>(constant.size()) >= num_params) {
        problem_->SetParameterBlockConstant(params);
      } else if (!constant.empty()) {
        problem_->SetManifold(params,
                              new ceres::SubsetManifold(num_params, constant));
      }
      if (focal_prior) {
        problem_->AddResidualBlock(
            new CameraParamPriorCost(num_params, focal[0], focal_value,
                                     prior_std * focal_value),
            nullptr, params);
      }
    }
  }

  // A gauge's scale: the coordinate of the image's position along which a
  // scaling about the image `about` moves it most.
  int GaugeCoordinate(image_t image_id, image_t about) const {
    const Image& first = reconstruction_->images.at(about);
    const Image& image = reconstruction_->images.at(image_id);
    Eigen::Vector3d baseline =
        image.ProjectionCenter() - first.ProjectionCenter();
    if (!use_centers_) {
      baseline = image.cam_from_world.rotation * baseline;
    }
    int fixed_coordinate = 0;
    baseline.cwiseAbs().maxCoeff(&fixed_coordinate);
    return fixed_coordinate;
  }

  // The Schur solver's cameras and poses: every one of the model, held
  // until Build finds it observed (the weights of every image sized now).
  void AddSchurPosesAndCameras() {
    for (const auto& [camera_id, camera] : reconstruction_->cameras) {
      const int index =
          schur_adjuster_->AddCamera(cameras_.at(camera_id), camera.model_id);
      std::vector<int> all(camera.params.size());
      std::iota(all.begin(), all.end(), 0);
      schur_adjuster_->SetCameraConstant(index, all);
      schur_cameras_[camera_id] = index;
      VLOG(3) << "Bundle adjustment: solver camera " << index << " is camera "
              << camera_id;
    }
    for (auto& [image_id, image] : reconstruction_->images) {
      std::vector<double>& weights = weights_[image_id];
      weights.assign(image.points2D.size(), 0.0);
      PoseBlocks& pose = poses_.at(image_id);
      pose.schur_index = schur_adjuster_->AddPose(
          pose.rotation, pose.position, schur_cameras_.at(image.camera_id),
          &image.points2D, &weights);
      schur_adjuster_->SetPoseConstant(pose.schur_index, true, -1);
      VLOG(3) << "Bundle adjustment: solver pose " << pose.schur_index
              << " is image " << image_id << " (" << image.name << "), camera "
              << image.camera_id;
    }
  }

  // The prior residuals of the images in the problem (see the header);
  // true when the position priors hold the gauge.
  bool AddPosePriors(const std::vector<image_t>& images) {
    if (priors_ == nullptr || !options_.refine_poses) return false;
    const PosePriorOptions& prior_options = options_.pose_priors;
    prior_loss_.reset(new QuadraticCauchyTailLoss(prior_options.quadratic_std,
                                                  prior_options.loss_scale));
    for (const image_t image_id : images) {
      const auto it = priors_->find(image_id);
      if (it == priors_->end()) continue;
      const PosePrior& prior = it->second;
      const PoseBlocks& pose = poses_.at(image_id);
      using Arguments = SchurBundleAdjuster::PoseArguments;
      // The same cost functions and loss for either backend.
      auto add = [&](ceres::CostFunction* cost, Arguments arguments) {
        if (schur_) {
          schur_adjuster_->AddPoseResidual(
              pose.schur_index, arguments,
              std::unique_ptr<ceres::CostFunction>(cost), prior_loss_.get());
        } else if (arguments == Arguments::kRotation) {
          problem_->AddResidualBlock(cost, prior_loss_.get(), pose.rotation);
        } else if (arguments == Arguments::kPosition) {
          problem_->AddResidualBlock(cost, prior_loss_.get(), pose.position);
        } else {
          problem_->AddResidualBlock(cost, prior_loss_.get(), pose.rotation,
                                     pose.position);
        }
      };
      if (prior.HasPosition()) {
        const Eigen::Matrix3d W =
            PositionPriorSqrtInformation(prior, prior_options);
        if (use_centers_) {
          add(PositionPriorCost::Create(prior.position, W),
              Arguments::kPosition);
        } else {
          add(PositionPriorFromTranslationCost::Create(prior.position, W),
              Arguments::kRotationAndPosition);
        }
        ++num_position_priors_;
      }
      if (prior.HasGravity()) {
        add(GravityPriorCost::Create(prior.gravity,
                                     DegToRad(prior_options.gravity_std_deg)),
            Arguments::kRotation);
        ++num_gravity_priors_;
      }
    }
    return num_position_priors_ >= prior_options.min_num_positions;
  }

  const BundleAdjustmentOptions& options_;
  Reconstruction* reconstruction_;
  const PosePriors* priors_;
  int num_position_priors_ = 0;
  int num_gravity_priors_ = 0;
  const bool huber_;
  std::string backend_reason_;  // ChooseSchurBackend's
  const bool schur_;            // solved by SchurBundleAdjuster
  const bool weighted_;         // residuals reweighted or filtered: weights_
  // Keypoint scale bins (FindScaleBins); the bins' median errors are
  // estimated from a few thousand observations at least.
  static constexpr int kNumKeypointScaleBins = 8;
  static constexpr size_t kMinObservationsPerScaleBin = 500;
  KeypointScaleNoise noise_;
  std::vector<double> bin_noise_;              // px
  std::unique_ptr<ceres::LossFunction> loss_;  // outlives the problem
  std::unique_ptr<ceres::LossFunction> prior_loss_;
  // Each image's weights, by keypoint; vectors never resized once built
  // (the costs hold their addresses).
  std::unordered_map<image_t, std::vector<double>> weights_;
  std::vector<point3D_t> held_points_;
  // parameterize_centers (with refine_poses): each image's centre, the
  // parameter block.
  const bool use_centers_ =
      options_.parameterize_centers && options_.refine_poses;
  std::map<image_t, Eigen::Vector3d> centers_;
  // The solved parameters (CopyParameters) and where each block's copy is.
  std::unique_ptr<ParameterBlockCopies> copies_;
  struct PoseBlocks {
    double* rotation;
    double* position;
    int schur_index = -1;  // the Schur solver's pose
  };
  std::unordered_map<image_t, PoseBlocks> poses_;
  std::unordered_map<camera_t, double*> cameras_;
  std::vector<std::pair<point3D_t, double*>> points_;  // by id
  std::unique_ptr<ceres::Problem> problem_;
  std::unique_ptr<SchurBundleAdjuster> schur_adjuster_;
  std::unordered_map<camera_t, int> schur_cameras_;  // the solver's index
  // Images whose pose the solves move (the others stay bit for bit).
  std::unordered_set<image_t> refined_poses_;
  std::shared_ptr<ceres::ParameterBlockOrdering> ordering_;
  int num_images_ = 0;
  int num_pieces_ = 0;
  int num_joints_ = 0;
  int num_images_left_out_ = 0;
  int num_focal_priors_ = 0;
  int num_intrinsics_held_ = 0;
  double schur_density_ = -1;  // computed for linear_solver auto only

 public:
  const std::string& LinearSolverReason() const {
    return linear_solver_reason_;
  }
  double SchurDensity() const { return schur_density_; }

 private:
  std::string linear_solver_reason_;
};

// The priors' residuals of the whole model moved by a similarity x ->
// scale R (x - pivot) + pivot + t (log scale, angle-axis R, t), for
// FitPriorFrame.
struct SimilarityPositionPriorCost {
  SimilarityPositionPriorCost(const Eigen::Vector3d& center_from_pivot,
                              const Eigen::Vector3d& prior_from_pivot,
                              const Eigen::Matrix3d& sqrt_information)
      : center_(center_from_pivot),
        prior_cost_(prior_from_pivot, sqrt_information) {}
  template <typename T>
  bool operator()(const T* log_scale, const T* angle_axis, const T* shift,
                  T* residuals) const {
    const T c[3] = {T(center_[0]), T(center_[1]), T(center_[2])};
    T moved[3];
    ceres::AngleAxisRotatePoint(angle_axis, c, moved);
    const T scale = ceres::exp(log_scale[0]);
    for (int k = 0; k < 3; ++k) moved[k] = scale * moved[k] + shift[k];
    return prior_cost_(moved, residuals);
  }
  const Eigen::Vector3d center_;
  const PositionPriorCost prior_cost_;
};

struct SimilarityGravityPriorCost {
  SimilarityGravityPriorCost(const Eigen::Quaterniond& cam_from_world,
                             const Eigen::Vector3d& gravity, double std_rad)
      : cam_from_world_(cam_from_world), gravity_cost_(gravity, std_rad) {}
  template <typename T>
  bool operator()(const T* angle_axis, T* residuals) const {
    // The moved camera's rotation cam_from_world R^T (x, y, z, w).
    T R[4], inverse[4];
    ceres::AngleAxisToQuaternion(angle_axis, R);  // w, x, y, z
    inverse[0] = R[0];
    for (int k = 1; k < 4; ++k) inverse[k] = -R[k];
    const T q[4] = {T(cam_from_world_.w()), T(cam_from_world_.x()),
                    T(cam_from_world_.y()), T(cam_from_world_.z())};
    T moved[4];
    ceres::QuaternionProduct(q, inverse, moved);
    const T xyzw[4] = {moved[1], moved[2], moved[3], moved[0]};
    return gravity_cost_(xyzw, residuals);
  }
  const Eigen::Quaterniond cam_from_world_;
  const GravityPriorCost gravity_cost_;
};

// Bundle adjustment's stopping rule (relative decrease of the whole cost)
// ends while the model's similarity to the priors, a direction the images
// do not see, still moves: the prior terms are a small part of the cost
// (measured: a 12-image model 0.25 m off its priors' least-squares frame,
// a second adjustment moving it no further). The model is then moved, as
// one rigid body (its reprojection errors unchanged), by the similarity
// that minimises the same prior terms: a 7-parameter solve. Returns whether
// the model moved.
bool FitPriorFrame(const PosePriors& priors, const PosePriorOptions& options,
                   Reconstruction* reconstruction) {
  Eigen::Vector3d pivot = Eigen::Vector3d::Zero();
  int num_positions = 0;
  for (const auto& [image_id, image] : reconstruction->images) {
    const auto it = priors.find(image_id);
    if (it == priors.end() || !it->second.HasPosition()) continue;
    pivot += image.ProjectionCenter();
    ++num_positions;
  }
  if (num_positions < options.min_num_positions) return false;
  pivot /= num_positions;
  double log_scale = 0;
  double angle_axis[3] = {0, 0, 0};
  double shift[3] = {0, 0, 0};
  QuadraticCauchyTailLoss loss(options.quadratic_std, options.loss_scale);
  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  for (const auto& [image_id, image] : reconstruction->images) {
    const auto it = priors.find(image_id);
    if (it == priors.end()) continue;
    const PosePrior& prior = it->second;
    if (prior.HasPosition()) {
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<SimilarityPositionPriorCost, 3, 1, 3,
                                          3>(new SimilarityPositionPriorCost(
              image.ProjectionCenter() - pivot, prior.position - pivot,
              PositionPriorSqrtInformation(prior, options))),
          &loss, &log_scale, angle_axis, shift);
    }
    if (prior.HasGravity()) {
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<SimilarityGravityPriorCost, 3, 3>(
              new SimilarityGravityPriorCost(
                  image.cam_from_world.rotation, prior.gravity,
                  DegToRad(options.gravity_std_deg))),
          &loss, angle_axis);
    }
  }
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::DENSE_QR;
  solver_options.max_num_iterations = 50;
  solver_options.function_tolerance = 1e-12;
  solver_options.gradient_tolerance = 1e-12;
  solver_options.parameter_tolerance = 1e-12;
  solver_options.num_threads = 1;
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &problem, &summary);
  if (!summary.IsSolutionUsable() ||
      !(summary.final_cost <= summary.initial_cost)) {
    return false;
  }
  Sim3d sim;
  sim.scale = std::exp(log_scale);
  ceres::AngleAxisToRotationMatrix(angle_axis,
                                   ceres::ColumnMajorAdapter3x3(sim.R.data()));
  sim.t = pivot + Eigen::Map<const Eigen::Vector3d>(shift) -
          sim.scale * (sim.R * pivot);
  TransformReconstruction(sim, reconstruction);
  VLOG(1) << "Bundle adjustment: model moved onto its priors' frame by "
          << (sim.scale - 1) * 100 << "% scale, "
          << RadToDeg(Eigen::AngleAxisd(sim.R).angle()) << " deg, "
          << sim.t.norm() << " m (prior cost " << summary.initial_cost << " -> "
          << summary.final_cost << ")";
  return true;
}

// The images whose residual (`residuals`, in standard deviations) exceeds
// gate_std max(1, s), s = their median / `valid_median` (GatePosePriors).
std::vector<image_t> BeyondGate(const std::map<image_t, double>& residuals,
                                double gate_std, double valid_median,
                                double* spread) {
  std::vector<image_t> beyond;
  *spread = 0;
  if (residuals.empty()) return beyond;
  std::vector<double> values;
  values.reserve(residuals.size());
  for (const auto& [image_id, r] : residuals) values.push_back(r);
  *spread = Median(values) / valid_median;
  if (gate_std <= 0) return beyond;
  const double gate = gate_std * std::max(1.0, *spread);
  for (const auto& [image_id, r] : residuals) {
    if (r > gate) beyond.push_back(image_id);
  }
  return beyond;
}

}  // namespace

PosePriorGate GatePosePriors(const Reconstruction& reconstruction,
                             const PosePriors& priors,
                             const PosePriorOptions& options) {
  // Medians of the norm of a valid whitened residual: chi with 3 degrees of
  // freedom (a position) and 2 (a direction's angle).
  constexpr double kPositionMedian = 1.5382;  // sqrt(2.3660)
  constexpr double kGravityMedian = 1.1774;   // sqrt(2 ln 2)
  std::map<image_t, double> positions, gravity;
  const double gravity_std = DegToRad(options.gravity_std_deg);
  for (const auto& [image_id, image] : reconstruction.images) {
    const auto it = priors.find(image_id);
    if (it == priors.end()) continue;
    const PosePrior& prior = it->second;
    if (prior.HasPosition()) {
      positions[image_id] = (PositionPriorSqrtInformation(prior, options) *
                             (image.ProjectionCenter() - prior.position))
                                .norm();
    }
    if (prior.HasGravity()) {
      // The angle, not GravityPriorCost's sine: a direction turned over
      // (sine near 0) is far off.
      const Eigen::Vector3d down =
          image.cam_from_world.rotation * Eigen::Vector3d(0, 0, -1);
      gravity[image_id] = std::atan2(prior.gravity.cross(down).norm(),
                                     prior.gravity.dot(down)) /
                          gravity_std;
    }
  }
  PosePriorGate gate;
  gate.kept = priors;
  gate.rejected_positions = BeyondGate(positions, options.gate_std,
                                       kPositionMedian, &gate.position_spread);
  if (positions.size() - gate.rejected_positions.size() <
      static_cast<size_t>(options.min_num_positions)) {
    gate.rejected_positions.clear();
  }
  gate.rejected_gravity = BeyondGate(gravity, options.gate_std, kGravityMedian,
                                     &gate.gravity_spread);
  for (const image_t image_id : gate.rejected_positions) {
    gate.kept.at(image_id).position.setConstant(PosePrior::kNaN);
  }
  for (const image_t image_id : gate.rejected_gravity) {
    gate.kept.at(image_id).gravity.setConstant(PosePrior::kNaN);
  }
  return gate;
}

std::string ChooseLinearSolver(const BundleAdjustmentOptions& options,
                               int num_images, double schur_density,
                               ceres::Solver::Options* ceres_options) {
  using Solver = BundleAdjustmentLinearSolver;
  const Solver solver = options.linear_solver;
  std::ostringstream size;
  size << num_images << " images";
  if (schur_density >= 0) {
    size << ", " << std::fixed << std::setprecision(1) << 100 * schur_density
         << "% of pairs share a point";
  }
  std::string reason;
  if (solver == Solver::kDenseSchur ||
      (solver == Solver::kAuto && num_images < 50)) {
    ceres_options->linear_solver_type = ceres::DENSE_SCHUR;
    reason = solver == Solver::kAuto ? "fewer than 50 images" : "asked";
  } else if (solver == Solver::kIterativeSchur ||
             (solver == Solver::kAuto &&
              (num_images >= options.iterative_schur_min_num_images ||
               schur_density >= options.iterative_schur_min_density))) {
    ceres_options->linear_solver_type = ceres::ITERATIVE_SCHUR;
    ceres_options->preconditioner_type = ceres::SCHUR_JACOBI;
    reason = solver != Solver::kAuto ? "asked"
             : num_images >= options.iterative_schur_min_num_images
                 ? "at least " +
                       std::to_string(options.iterative_schur_min_num_images) +
                       " images"
                 : "dense reduced camera system";
  } else {
    ceres_options->linear_solver_type = ceres::SPARSE_SCHUR;
    reason = solver == Solver::kAuto ? "sparse reduced camera system" : "asked";
  }
  return std::string(ceres::LinearSolverTypeToString(
             ceres_options->linear_solver_type)) +
         ": " + reason + " (" + size.str() + ")";
}

template <>
const EnumNames<BundleAdjustmentLoss>& NamesOf<BundleAdjustmentLoss>() {
  static const EnumNames<BundleAdjustmentLoss> names = {
      {BundleAdjustmentLoss::kHuber, "huber"},
      {BundleAdjustmentLoss::kHuberCeres, "huber_ceres"},
      {BundleAdjustmentLoss::kCauchy, "cauchy"},
      {BundleAdjustmentLoss::kTrivial, "trivial"}};
  return names;
}

template <>
const EnumNames<BundleAdjustmentSolverBackend>&
NamesOf<BundleAdjustmentSolverBackend>() {
  static const EnumNames<BundleAdjustmentSolverBackend> names = {
      {BundleAdjustmentSolverBackend::kAuto, "auto"},
      {BundleAdjustmentSolverBackend::kCeres, "ceres"},
      {BundleAdjustmentSolverBackend::kSchur, "schur"}};
  return names;
}

bool ChooseSchurBackend(const BundleAdjustmentOptions& options,
                        size_t num_observations, std::string* reason) {
  using Backend = BundleAdjustmentSolverBackend;
  std::string why;
  bool schur = false;
  if (options.solver_backend == Backend::kCeres) {
    why = "ceres: asked";
  } else if (options.loss_function != BundleAdjustmentLoss::kHuber &&
             options.loss_function != BundleAdjustmentLoss::kTrivial) {
    why = "ceres: loss " + EnumName(options.loss_function) +
          " (the Schur solver takes weights only)";
  } else if (options.solver_backend == Backend::kSchur) {
    schur = true;
    why = "schur: asked";
  } else if (num_observations >=
             static_cast<size_t>(options.schur_min_num_observations)) {
    schur = true;
    why = "schur: " + std::to_string(num_observations) +
          " observations (auto from " +
          std::to_string(options.schur_min_num_observations) + ")";
  } else {
    why = "ceres: " + std::to_string(num_observations) +
          " observations (auto: schur from " +
          std::to_string(options.schur_min_num_observations) + ")";
  }
  if (reason != nullptr) *reason = why;
  return schur;
}

template <>
const EnumNames<SchurLinearSolver>& NamesOf<SchurLinearSolver>() {
  static const EnumNames<SchurLinearSolver> names = {
      {SchurLinearSolver::kAuto, "auto"},
      {SchurLinearSolver::kSimplicial, "simplicial"},
      {SchurLinearSolver::kSupernodal, "supernodal"},
      {SchurLinearSolver::kIterative, "iterative"}};
  return names;
}

template <>
const EnumNames<BundleAdjustmentLinearSolver>&
NamesOf<BundleAdjustmentLinearSolver>() {
  static const EnumNames<BundleAdjustmentLinearSolver> names = {
      {BundleAdjustmentLinearSolver::kAuto, "auto"},
      {BundleAdjustmentLinearSolver::kSparseSchur, "sparse_schur"},
      {BundleAdjustmentLinearSolver::kDenseSchur, "dense_schur"},
      {BundleAdjustmentLinearSolver::kIterativeSchur, "iterative_schur"}};
  return names;
}

BundleAdjustmentOptions::BundleAdjustmentOptions() {
  solver.ceres.max_num_iterations = 100;
  solver.ceres.function_tolerance = 1e-5;
  solver.ceres.gradient_tolerance = 1e-10;
  solver.ceres.parameter_tolerance = 1e-8;
  solver.ceres.initial_trust_region_radius = 1e16;
}

void BundleAdjustmentOptions::Check() const {
  if (!(rejected_start_trust_region_radius >= 0)) {
    throw OptionError(&rejected_start_trust_region_radius,
                      "BundleAdjustment.rejected_start_trust_region_radius",
                      "must be >= 0 (0: off)");
  }
  if (!(loss_scale > 0))
    throw OptionError(&loss_scale, "BundleAdjustment.loss_scale",
                      "must be positive");
  if (num_rounds < 1)
    throw OptionError(&num_rounds, "BundleAdjustment.num_rounds",
                      "must be at least 1");
  if (!(min_filtered_fraction >= 0 && min_filtered_fraction < 1)) {
    throw OptionError(&min_filtered_fraction,
                      "BundleAdjustmentOptions::min_filtered_fraction",
                      "must be in [0, 1)");
  }
  if (!(max_reproj_error >= 0)) {
    throw OptionError(&max_reproj_error, "BundleAdjustment.max_reproj_error",
                      "must be >= 0");
  }
  if (!(iterative_schur_min_density > 0)) {
    throw OptionError(&iterative_schur_min_density,
                      "BundleAdjustment.iterative_schur_min_density",
                      "must be positive (above 1: never by density)");
  }
  if (schur_min_num_observations < 0) {
    throw OptionError(&schur_min_num_observations,
                      "BundleAdjustment.schur_min_num_observations",
                      "must be >= 0");
  }
  if (!(focal_prior_std >= 0)) {
    throw OptionError(&focal_prior_std, "BundleAdjustment.focal_prior_std",
                      "must be >= 0 (0: no prior)");
  }
  if (!(guessed_focal_prior_std >= 0)) {
    throw OptionError(&guessed_focal_prior_std,
                      "BundleAdjustment.guessed_focal_prior_std",
                      "must be >= 0 (0: no prior)");
  }
  if (min_num_intrinsics_observations < 0) {
    throw OptionError(&min_num_intrinsics_observations,
                      "BundleAdjustment.min_num_intrinsics_observations",
                      "must be >= 0");
  }
  if (min_num_image_observations < 0) {
    throw OptionError(&min_num_image_observations,
                      "BundleAdjustment.min_num_image_observations",
                      "must be >= 0");
  }
  if (stall_num_iterations < 0) {
    throw OptionError(&stall_num_iterations,
                      "BundleAdjustment.stall_num_iterations", "must be >= 0");
  }
  if (stall_min_num_images < 0) {
    throw OptionError(&stall_min_num_images,
                      "BundleAdjustment.stall_min_num_images", "must be >= 0");
  }
  if (last_stall_num_iterations < 0) {
    throw OptionError(&last_stall_num_iterations,
                      "BundleAdjustment.last_stall_num_iterations",
                      "must be >= 0");
  }
  if (!(last_stall_relative_decrease >= 0)) {
    throw OptionError(&last_stall_relative_decrease,
                      "BundleAdjustment.last_stall_relative_decrease",
                      "must be >= 0");
  }
  if (!(stall_relative_decrease >= 0)) {
    throw OptionError(&stall_relative_decrease,
                      "BundleAdjustment.stall_relative_decrease",
                      "must be >= 0");
  }
  if (!(schur_max_factor_mib > 0)) {
    throw OptionError(&schur_max_factor_mib,
                      "BundleAdjustment.schur_max_factor_mib",
                      "must be positive");
  }
  if (!(schur_max_factor_gflops > 0)) {
    throw OptionError(&schur_max_factor_gflops,
                      "BundleAdjustment.schur_max_factor_gflops",
                      "must be positive");
  }
  if (!(schur_max_cell_table_mib >= 0)) {
    throw OptionError(&schur_max_cell_table_mib,
                      "BundleAdjustment.schur_max_cell_table_mib",
                      "must be >= 0");
  }
  if (!(schur_max_jacobian_store_mib >= 0)) {
    throw OptionError(&schur_max_jacobian_store_mib,
                      "BundleAdjustment.schur_max_jacobian_store_mib",
                      "must be >= 0");
  }
  if (!(schur_locality_order_min_mib >= 0)) {
    throw OptionError(&schur_locality_order_min_mib,
                      "BundleAdjustment.schur_locality_order_min_mib",
                      "must be >= 0");
  }
  if (!(schur_prefetch_updates_min_mib >= 0)) {
    throw OptionError(&schur_prefetch_updates_min_mib,
                      "BundleAdjustment.schur_prefetch_updates_min_mib",
                      "must be >= 0");
  }
  if (last_gauge_min_shared_points < 0) {
    throw OptionError(&last_gauge_min_shared_points,
                      "BundleAdjustment.last_gauge_min_shared_points",
                      "must be >= 0");
  }
  if (gauge_min_shared_points < 1) {
    throw OptionError(&gauge_min_shared_points,
                      "BundleAdjustment.gauge_min_shared_points",
                      "must be >= 1");
  }
  if (schur_point_iterations < 0) {
    throw OptionError(&schur_point_iterations,
                      "BundleAdjustment.schur_point_iterations",
                      "must be >= 0");
  }
  if (!(schur_reuse_min_radius >= 0)) {
    throw OptionError(&schur_reuse_min_radius,
                      "BundleAdjustment.schur_reuse_min_radius",
                      "must be >= 0");
  }
  if (!(schur_implicit_min_mib >= 0)) {
    throw OptionError(&schur_implicit_min_mib,
                      "BundleAdjustment.schur_implicit_min_mib",
                      "must be at least 0");
  }
  if (!(schur_iterative_eta > 0 && schur_iterative_eta < 1)) {
    throw OptionError(&schur_iterative_eta,
                      "BundleAdjustment.schur_iterative_eta",
                      "must be in (0, 1)");
  }
  if (!(schur_iterative_model_tolerance >= 0 &&
        schur_iterative_model_tolerance < 1)) {
    throw OptionError(&schur_iterative_model_tolerance,
                      "BundleAdjustment.schur_iterative_model_tolerance",
                      "must be in [0, 1) (0: off)");
  }
  if (schur_iterative_model_min_num_images < 0) {
    throw OptionError(&schur_iterative_model_min_num_images,
                      "BundleAdjustment.schur_iterative_model_min_num_images",
                      "must be >= 0");
  }
  if (schur_max_cg_iterations < 1) {
    throw OptionError(&schur_max_cg_iterations,
                      "BundleAdjustment.schur_max_cg_iterations",
                      "must be at least 1");
  }
  if (schur_coarse_cluster_size < 0) {
    throw OptionError(&schur_coarse_cluster_size,
                      "BundleAdjustment.schur_coarse_cluster_size",
                      "must be at least 0 (0: no coarse level)");
  }
  if (schur_coarse_max_clusters < 1) {
    throw OptionError(&schur_coarse_max_clusters,
                      "BundleAdjustment.schur_coarse_max_clusters",
                      "must be at least 1");
  }
  if (iterative_schur_min_num_images < 1) {
    throw OptionError(&iterative_schur_min_num_images,
                      "BundleAdjustment.iterative_schur_min_num_images",
                      "must be positive");
  }
  solver.Check("BundleAdjustment.");
  pose_priors.Check();
}

bool RunBundleAdjustment(const BundleAdjustmentOptions& options,
                         Reconstruction* reconstruction,
                         BundleAdjustmentSummary* summary,
                         const PosePriors* priors) {
  options.Check();
  Timer timer;
  BundleAdjustmentSummary local_summary;
  local_summary.initial_mean_reproj_error =
      UpdateReprojectionErrors(reconstruction);
  bool success = true;
  // The last round's filter works on the model alone (nothing is solved
  // after it); the problem is gone by then.
  bool filter_model = false;
  // Priors far off the model as handed in are left out of this adjustment.
  PosePriorGate gate;
  if (priors != nullptr && options.refine_poses) {
    gate = GatePosePriors(*reconstruction, *priors, options.pose_priors);
    local_summary.rejected_position_priors = gate.rejected_positions;
    local_summary.rejected_gravity_priors = gate.rejected_gravity;
    if (!gate.rejected_positions.empty() || !gate.rejected_gravity.empty()) {
      VLOG(1) << "Bundle adjustment: " << gate.rejected_positions.size()
              << " position and " << gate.rejected_gravity.size()
              << " gravity priors beyond " << options.pose_priors.gate_std
              << " std (spread " << gate.position_spread << ", "
              << gate.gravity_spread << ") left out";
    }
    priors = &gate.kept;
  }
  {
    Timer build_timer;
    BundleAdjustmentProblem problem(options, reconstruction, priors);
    local_summary.backend = problem.Schur() ? "schur" : "ceres";
    local_summary.backend_reason = problem.BackendReason();
    VLOG(1) << "Bundle adjustment backend " << problem.BackendReason();
    local_summary.num_position_priors = problem.NumPositionPriors();
    local_summary.num_gravity_priors = problem.NumGravityPriors();
    local_summary.num_pieces = problem.NumPieces();
    local_summary.num_joints = problem.NumJoints();
    local_summary.num_images_left_out = problem.NumImagesLeftOut();
    local_summary.num_focal_priors = problem.NumFocalPriors();
    local_summary.num_intrinsics_held = problem.NumIntrinsicsHeld();
    if (local_summary.num_intrinsics_held > 0) {
      VLOG(1) << "Bundle adjustment: " << local_summary.num_intrinsics_held
              << " camera(s) of fewer than "
              << options.min_num_intrinsics_observations
              << " observations held";
    }
    if (local_summary.num_focal_priors > 0) {
      VLOG(1) << "Bundle adjustment: " << local_summary.num_focal_priors
              << " camera(s) with a focal length prior";
    }
    if (local_summary.num_images_left_out > 0) {
      VLOG(1) << "Bundle adjustment: " << local_summary.num_images_left_out
              << " image(s) of fewer than "
              << options.min_num_image_observations << " observations left out";
    }
    if (local_summary.num_pieces > 1 || local_summary.num_joints > 0) {
      LOG(INFO) << "Bundle adjustment: the model is "
                << local_summary.num_pieces
                << " part(s) sharing no point with each other, with "
                << local_summary.num_joints
                << " block(s) joined to the rest through one image only; "
                   "each holds its own gauge (no relative pose or scale)";
    }
    local_summary.problem_seconds += build_timer.ElapsedSeconds();
    for (int round = 0; round < options.num_rounds && !problem.Empty();
         ++round) {
      // Huber by reweighting: a few solves, each from the last one's errors.
      const int num_solves =
          options.loss_function == BundleAdjustmentLoss::kHuber ? 3 : 1;
      BundleAdjustmentProblem::SolveSummary solver_summary;
      for (int solve = 0; solve < num_solves; ++solve) {
        build_timer.Restart();
        problem.Reweight();
        local_summary.problem_seconds += build_timer.ElapsedSeconds();
        const auto solve_from = [&](double initial_trust_region_radius) {
          solver_summary = problem.Solve(initial_trust_region_radius);
          local_summary.num_iterations += solver_summary.num_iterations;
          local_summary.num_stalled_solves += solver_summary.stalled;
          local_summary.num_linear_iterations +=
              solver_summary.num_linear_iterations;
          ++local_summary.num_solves;
          local_summary.preprocessor_seconds +=
              solver_summary.preprocessor_seconds;
          local_summary.linear_solver_seconds +=
              solver_summary.linear_solver_seconds;
        };
        solve_from(0);
        // From the undamped start (initial_trust_region_radius 1e16: nearly
        // Gauss-Newton's step) a numerically singular reduced camera system
        // fails the Cholesky factorisation at every step, and the solve gives
        // up after max_num_consecutive_invalid_steps while the damping is
        // still negligible (issue 23/24: a 998-image model of blocks tied by
        // fewer than model_rigidity's 15 points, with 26000 two-view points).
        // A failed solve (Ceres' or ours) leaves the parameters as they were,
        // so the same solve starts again, damped.
        if (solver_summary.termination == ceres::FAILURE &&
            options.solver.ceres.initial_trust_region_radius >
                kDampedTrustRegionRadius) {
          LOG(WARNING) << "Bundle adjustment: " << solver_summary.message
                       << "; solving again from a damped start (initial "
                          "trust region radius "
                       << kDampedTrustRegionRadius << ")";
          ++local_summary.num_damped_restarts;
          solve_from(kDampedTrustRegionRadius);
        }
        local_summary.linear_solver = solver_summary.linear_solver;
        local_summary.linear_solver_reason = problem.LinearSolverReason();
        local_summary.schur_density = problem.SchurDensity();
        if (solver_summary.termination == ceres::FAILURE ||
            solver_summary.num_iterations <= 2) {
          break;
        }
      }
      ++local_summary.num_rounds;
      local_summary.converged =
          solver_summary.termination == ceres::CONVERGENCE;
      if (solver_summary.termination == ceres::FAILURE) {
        LOG(WARNING) << "Bundle adjustment: " << solver_summary.message;
        success = false;
        break;
      }
      if (options.max_reproj_error <= 0) break;
      if (round + 1 == options.num_rounds) {
        filter_model = true;
        break;
      }
      build_timer.Restart();
      const size_t num_filtered = problem.Filter(options.max_reproj_error);
      local_summary.problem_seconds += build_timer.ElapsedSeconds();
      local_summary.num_observations_filtered += num_filtered;
      if (num_filtered == 0 ||
          num_filtered < options.min_filtered_fraction *
                             NumObservations(*reconstruction)) {
        break;
      }
    }
    if (!problem.ScaleBinNoise().empty()) {
      local_summary.scale_bin_edges_px = problem.ScaleBinEdges();
      local_summary.scale_bin_noise_px = problem.ScaleBinNoise();
      if (options.filter_by_keypoint_noise) {
        local_summary.keypoint_noise = problem.Noise();
      }
    }
  }  // the problem deletes the points its filter held
  if (success && priors != nullptr && options.refine_poses &&
      local_summary.num_position_priors >=
          options.pose_priors.min_num_positions) {
    FitPriorFrame(*priors, options.pose_priors, reconstruction);
  }
  if (filter_model) {
    local_summary.num_observations_filtered +=
        FilterObservationsWithLargeReprojectionError(
            options.max_reproj_error, reconstruction,
            &local_summary.keypoint_noise);
  }
  local_summary.final_mean_reproj_error =
      UpdateReprojectionErrors(reconstruction);
  local_summary.num_images = reconstruction->images.size();
  local_summary.num_points = reconstruction->points3D.size();
  local_summary.num_observations = NumObservations(*reconstruction);
  local_summary.seconds = timer.ElapsedSeconds();
  VLOG(1) << "Bundle adjustment: " << local_summary.num_rounds << " rounds, "
          << local_summary.num_iterations << " iterations ("
          << local_summary.num_linear_iterations
          << " conjugate gradient), reprojection error "
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
