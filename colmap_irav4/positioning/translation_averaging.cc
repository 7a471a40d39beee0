#include "colmap_irav4/positioning/translation_averaging.h"

#include <cmath>
#include <random>
#include <tuple>

#include <Eigen/Dense>

#include <ceres/ceres.h>
#include <glog/logging.h>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/positioning/direction_cost.h"
#include "colmap_irav4/positioning/global_positioning.h"
#include "colmap_irav4/scene/reconstruction_utils.h"
#include "colmap_irav4/util/ceres_solve.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/timer.h"

namespace colmap_irav4 {
namespace {

// Scale-free direction residuals of c2 - c1 = u against the measured unit
// direction v. "chordal": v - u / |u| (1DSfM's nonlinear translation
// averaging). "bata": v - u max(<u, v>, 0) / |u|^2, the residual of BATA
// with its per-pair scale eliminated: its norm is the sine of the angle
// (below 90 deg), 1 beyond: bounded, hence insensitive to wrong pairs.
struct NormalizedDirectionCost {
  NormalizedDirectionCost(const Eigen::Vector3d& direction, bool bata)
      : direction_(direction), bata_(bata) {}

  template <typename T>
  bool operator()(const T* c1, const T* c2, T* residuals) const {
    const T u[3] = {c2[0] - c1[0], c2[1] - c1[1], c2[2] - c1[2]};
    const T squared_norm = u[0] * u[0] + u[1] * u[1] + u[2] * u[2] + T(1e-24);
    T factor;
    if (bata_) {
      T dot = u[0] * T(direction_[0]) + u[1] * T(direction_[1]) +
              u[2] * T(direction_[2]);
      if (dot < T(0)) dot = T(0);
      factor = dot / squared_norm;
    } else {
      factor = T(1) / sqrt(squared_norm);
    }
    for (int k = 0; k < 3; ++k) residuals[k] = T(direction_[k]) - factor * u[k];
    return true;
  }

  static ceres::CostFunction* Create(const Eigen::Vector3d& direction,
                                     bool bata) {
    return new ceres::AutoDiffCostFunction<NormalizedDirectionCost, 3, 3, 3>(
        new NormalizedDirectionCost(direction, bata));
  }

  const Eigen::Vector3d direction_;
  const bool bata_;
};

// Linear initialisation: each pair asks v_ij x (c_j - c_i) = 0. With the
// first centre at the origin the centres are the eigenvector of the smallest
// eigenvalue of A^T A (dense: fine up to ~1500 images), its sign chosen so
// that most baselines agree with their directions.
bool LinearInitialization(
    const std::vector<std::tuple<image_t, image_t, Eigen::Vector3d>>&
        constraints,
    std::map<image_t, Eigen::Vector3d>* centers) {
  const int n = centers->size();
  if (n < 2 || n > 1500) return false;
  std::map<image_t, int> index;
  for (const auto& [image_id, center] : *centers) {
    const int k = index.size();
    index[image_id] = k;
  }
  // Unknowns: centres 1..n-1 (the first is the origin).
  const int m = 3 * (n - 1);
  Eigen::MatrixXd AtA = Eigen::MatrixXd::Zero(m, m);
  for (const auto& [id1, id2, v] : constraints) {
    Eigen::Matrix3d V;
    V << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
    const Eigen::Matrix3d VtV = V.transpose() * V;
    const int i = index.at(id1) - 1, j = index.at(id2) - 1;
    // Row block: V c_j - V c_i.
    if (j >= 0) AtA.block<3, 3>(3 * j, 3 * j) += VtV;
    if (i >= 0) AtA.block<3, 3>(3 * i, 3 * i) += VtV;
    if (i >= 0 && j >= 0) {
      AtA.block<3, 3>(3 * i, 3 * j) -= VtV;
      AtA.block<3, 3>(3 * j, 3 * i) -= VtV;
    }
  }
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(AtA);
  if (eigen.info() != Eigen::Success) return false;
  Eigen::VectorXd x = eigen.eigenvectors().col(0);
  std::vector<Eigen::Vector3d> solution(n, Eigen::Vector3d::Zero());
  for (int k = 1; k < n; ++k) solution[k] = x.segment<3>(3 * (k - 1));
  int num_agree = 0;
  for (const auto& [id1, id2, v] : constraints) {
    num_agree +=
        (solution[index.at(id2)] - solution[index.at(id1)]).dot(v) > 0 ? 1 : -1;
  }
  const double sign = num_agree >= 0 ? 1.0 : -1.0;
  // Scale so that the median baseline is ~100 (away from the degenerate 0).
  std::vector<double> baselines;
  for (const auto& [id1, id2, v] : constraints) {
    baselines.push_back(
        (solution[index.at(id2)] - solution[index.at(id1)]).norm());
  }
  std::nth_element(baselines.begin(), baselines.begin() + baselines.size() / 2,
                   baselines.end());
  const double median = baselines[baselines.size() / 2];
  if (!(median > 0)) return false;
  for (auto& [image_id, center] : *centers) {
    center = sign * 100.0 / median * solution[index.at(image_id)];
  }
  return true;
}

}  // namespace

template <>
const EnumNames<TranslationAveragingCost>& NamesOf<TranslationAveragingCost>() {
  static const EnumNames<TranslationAveragingCost> names = {
      {TranslationAveragingCost::kBata, "bata"},
      {TranslationAveragingCost::kChordal, "chordal"}};
  return names;
}

TranslationAveragingOptions::TranslationAveragingOptions() {
  solver.ceres.max_num_iterations = 200;
  solver.ceres.function_tolerance = 1e-7;
  solver.ceres.gradient_tolerance = 1e-10;
  solver.ceres.parameter_tolerance = 1e-8;
}

void TranslationAveragingOptions::Check() const {
  if (!(loss_scale > 0))
    throw OptionError(&loss_scale, "TranslationAveraging.loss_scale",
                      "must be positive");
  if (!(initialization_box > 0)) {
    throw OptionError(&initialization_box,
                      "TranslationAveragingOptions::initialization_box",
                      "must be positive");
  }
  if (!(max_angular_error_deg >= 0 && max_angular_error_deg < 180)) {
    throw OptionError(&max_angular_error_deg,
                      "TranslationAveragingOptions::max_angular_error_deg",
                      "must be in [0, 180)");
  }
  solver.Check("TranslationAveraging.");
}

bool RunTranslationAveraging(const TranslationAveragingOptions& options,
                             const std::vector<ImagePairGeometry>& pairs,
                             Reconstruction* reconstruction,
                             TranslationAveragingSummary* summary) {
  options.Check();
  Timer timer;
  TranslationAveragingSummary local_summary;

  struct Constraint {
    image_t image_id1, image_id2;
    Eigen::Vector3d direction;  // of c2 - c1, world frame
  };
  std::vector<Constraint> constraints;
  std::map<image_t, Eigen::Vector3d> centers;
  for (const ImagePairGeometry& pair : pairs) {
    if (pair.image_id1 == pair.image_id2) continue;
    auto it2 = reconstruction->images.find(pair.image_id2);
    if (!reconstruction->images.count(pair.image_id1) ||
        it2 == reconstruction->images.end()) {
      continue;
    }
    const double norm = pair.t.norm();
    if (!(norm > 1e-12)) continue;
    constraints.push_back(
        {pair.image_id1, pair.image_id2,
         -(it2->second.cam_from_world.rotation.inverse() * (pair.t / norm))});
    centers[pair.image_id1];
    centers[pair.image_id2];
  }
  std::vector<image_t> dropped;
  for (const auto& [image_id, image] : reconstruction->images) {
    if (!centers.count(image_id)) dropped.push_back(image_id);
  }
  for (image_t image_id : dropped) DeleteImage(image_id, reconstruction);
  local_summary.num_images_dropped = dropped.size();
  if (centers.size() < 2) {
    LOG(WARNING)
        << "Translation averaging: fewer than two images in usable pairs";
    if (summary != nullptr) *summary = local_summary;
    return false;
  }

  std::vector<std::tuple<image_t, image_t, Eigen::Vector3d>> init_constraints;
  for (const Constraint& c : constraints)
    init_constraints.emplace_back(c.image_id1, c.image_id2, c.direction);
  bool initialized = false;
  if (options.linear_initialization) {
    initialized = LinearInitialization(init_constraints, &centers);
  }
  if (!initialized) {
    std::mt19937_64 rng(options.random_seed);
    std::uniform_real_distribution<double> uniform(-options.initialization_box,
                                                   options.initialization_box);
    for (auto& [image_id, center] : centers) {
      center = Eigen::Vector3d(uniform(rng), uniform(rng), uniform(rng));
    }
  }
  const image_t gauge_image_id = centers.begin()->first;
  centers.at(gauge_image_id).setZero();

  {
    ceres::Problem::Options problem_options;
    problem_options.loss_function_ownership = ceres::TAKE_OWNERSHIP;
    ceres::Problem problem(problem_options);
    for (size_t k = 0; k < constraints.size(); ++k) {
      const Constraint& constraint = constraints[k];
      double* c1 = centers.at(constraint.image_id1).data();
      double* c2 = centers.at(constraint.image_id2).data();
      problem.AddResidualBlock(
          NormalizedDirectionCost::Create(
              constraint.direction,
              options.cost == TranslationAveragingCost::kBata),
          CreateLossFunction(options.loss_function, options.loss_scale), c1,
          c2);
    }
    problem.SetParameterBlockConstant(centers.at(gauge_image_id).data());

    SolverOptions solver = options.solver;
    // One block per image and pair: a sparse Cholesky of the normal equations.
    solver.ceres.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
    const ceres::Solver::Summary solver_summary =
        SolveProblem("translation averaging", solver, &problem);
    local_summary.num_iterations += solver_summary.iterations.size();
    local_summary.num_pairs = constraints.size();
    if (!solver_summary.IsSolutionUsable()) {
      LOG(WARNING) << "Translation averaging: " << solver_summary.message;
      if (summary != nullptr) *summary = local_summary;
      return false;
    }
  }
  for (auto& [image_id, image] : reconstruction->images) {
    image.cam_from_world.translation =
        -(image.cam_from_world.rotation * centers.at(image_id));
  }
  if (options.max_angular_error_deg > 0) {
    const double min_cos = std::cos(DegToRad(options.max_angular_error_deg));
    for (const Constraint& constraint : constraints) {
      const Eigen::Vector3d baseline =
          centers.at(constraint.image_id2) - centers.at(constraint.image_id1);
      if (baseline.dot(constraint.direction) < min_cos * baseline.norm()) {
        ++local_summary.num_outlier_pairs;
      }
    }
  }
  local_summary.num_images = centers.size();
  local_summary.seconds = timer.ElapsedSeconds();
  if (summary != nullptr) *summary = local_summary;
  return true;
}

}  // namespace colmap_irav4
