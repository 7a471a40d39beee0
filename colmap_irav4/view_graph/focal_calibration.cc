#include "colmap_irav4/view_graph/focal_calibration.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <set>
#include <sstream>
#include <utility>

#include <glog/logging.h>

#include "colmap_irav4/geometry/two_view_geometry.h"
#include "colmap_irav4/scene/camera_models.h"
#include "colmap_irav4/util/error.h"

namespace colmap_irav4 {
namespace {

// K of a camera with its focal length(s) multiplied by scale.
Eigen::Matrix3d ScaledK(const Camera& camera, double scale) {
  Eigen::Matrix3d K = CameraCalibrationMatrix(camera);
  K(0, 0) *= scale;
  K(1, 1) *= scale;
  return K;
}

// Minimises cost over x in [lo, hi] (log-spaced grid, then golden-section
// search in log x around the best grid point).
double Minimize1D(const std::function<double(double)>& cost, double lo,
                  double hi, int num_grid_points) {
  const double log_lo = std::log(lo);
  const double log_hi = std::log(hi);
  const double step = (log_hi - log_lo) / (num_grid_points - 1);
  int best = 0;
  double best_cost = std::numeric_limits<double>::infinity();
  for (int k = 0; k < num_grid_points; ++k) {
    const double c = cost(std::exp(log_lo + k * step));
    if (c < best_cost) {
      best_cost = c;
      best = k;
    }
  }
  double a = log_lo + std::max(0, best - 1) * step;
  double b = log_lo + std::min(num_grid_points - 1, best + 1) * step;
  const double ratio = (std::sqrt(5.0) - 1) / 2;
  double x1 = b - ratio * (b - a);
  double x2 = a + ratio * (b - a);
  double c1 = cost(std::exp(x1));
  double c2 = cost(std::exp(x2));
  for (int iteration = 0; iteration < 40 && b - a > 1e-7; ++iteration) {
    if (c1 < c2) {
      b = x2;
      x2 = x1;
      c2 = c1;
      x1 = b - ratio * (b - a);
      c1 = cost(std::exp(x1));
    } else {
      a = x1;
      x1 = x2;
      c1 = c2;
      x2 = a + ratio * (b - a);
      c2 = cost(std::exp(x2));
    }
  }
  const double x = std::exp((a + b) / 2);
  // The grid point may still beat the refined one (non-smooth costs).
  const double grid_x = std::exp(log_lo + best * step);
  return cost(x) <= best_cost ? x : grid_x;
}

class Calibrator {
 public:
  Calibrator(const std::vector<FocalCalibrationPair>& pairs,
             const FocalCalibrationOptions& options,
             const std::map<camera_t, Camera>& cameras)
      : pairs_(pairs), options_(options), cameras_(cameras) {}

  // Scale of each camera's focal (1 for fixed ones).
  std::map<camera_t, double> scale;

  double PairCost(size_t i) const {
    const FocalCalibrationPair& pair = pairs_[i];
    return EssentialSingularValueCost(
        pair.F, ScaledK(cameras_.at(pair.camera_id1), Scale(pair.camera_id1)),
        ScaledK(cameras_.at(pair.camera_id2), Scale(pair.camera_id2)));
  }

  // Weighted mean Cauchy cost of the pairs with indices in `subset`.
  double Cost(const std::vector<size_t>& subset) const {
    double sum = 0;
    double weight = 0;
    for (const size_t i : subset) {
      const FocalCalibrationPair& pair = pairs_[i];
      const double c = PairCost(i);
      const double r = c / options_.loss_scale;
      sum += pair.weight * std::log1p(r * r);
      weight += pair.weight;
    }
    return weight > 0 ? sum / weight : 0.0;
  }

  // Searches one factor applied to the cameras in `group` (on top of
  // `base`), over the pairs `subset`; false (scales restored) with a reason
  // if the minimum is at the range's end or the cost is flat around it.
  bool Search(const std::vector<camera_t>& group,
              const std::map<camera_t, double>& base,
              const std::vector<size_t>& subset, std::string* reason) {
    const std::map<camera_t, double> before = scale;
    auto apply = [&](double x) {
      for (const camera_t id : group) scale[id] = base.at(id) * x;
    };
    auto cost = [&](double x) {
      apply(x);
      return Cost(subset);
    };
    const double lo = options_.min_focal_ratio;
    const double hi = options_.max_focal_ratio;
    const double x = Minimize1D(cost, lo, hi, options_.num_grid_points);
    // Conditioning is judged on the pairs that agree with the minimum
    // (outliers add a constant floor to the robust cost).
    apply(x);
    std::vector<size_t> inliers;
    for (const size_t i : subset) {
      if (PairCost(i) < options_.max_agreeing_cost) inliers.push_back(i);
    }
    auto inlier_cost = [&](double y) {
      apply(y);
      double sum = 0, weight = 0;
      for (const size_t i : inliers) {
        sum += pairs_[i].weight * PairCost(i);
        weight += pairs_[i].weight;
      }
      return weight > 0 ? sum / weight : 0.0;
    };
    const double at = inlier_cost(x);
    const double below = inlier_cost(std::max(lo, x / 1.25));
    const double above = inlier_cost(std::min(hi, x * 1.25));
    std::ostringstream why;
    if (x < lo * 1.02 || x > hi / 1.02) {
      why << "minimum at the end of the search range (x" << x << ")";
    } else if (static_cast<int>(inliers.size()) < options_.min_num_pairs) {
      why << "only " << inliers.size() << " of " << subset.size()
          << " pairs agree with the minimum";
    } else if (!(below > options_.min_cost_increase * at &&
                 above > options_.min_cost_increase * at &&
                 std::min(below, above) - at > 1e-4)) {
      why << "flat cost (mean " << at << " at the minimum, " << below << " / "
          << above << " at x/1.25 / x1.25)";
    }
    if (!why.str().empty()) {
      scale = before;
      *reason = why.str();
      return false;
    }
    apply(x);
    return true;
  }

  double Scale(camera_t id) const {
    const auto it = scale.find(id);
    return it == scale.end() ? 1.0 : it->second;
  }

 private:
  const std::vector<FocalCalibrationPair>& pairs_;
  const FocalCalibrationOptions& options_;
  const std::map<camera_t, Camera>& cameras_;
};

}  // namespace

void FocalCalibrationOptions::Check() const {
  if (!(min_focal_ratio > 0 && min_focal_ratio < 1)) {
    throw OptionError(&min_focal_ratio, "ViewGraph.calibration_min_focal_ratio",
                      "must be in (0, 1)");
  }
  if (!(max_focal_ratio > 1)) {
    throw OptionError(&max_focal_ratio, "ViewGraph.calibration_max_focal_ratio",
                      "must be > 1");
  }
  if (num_grid_points < 3) {
    throw OptionError(&num_grid_points,
                      "FocalCalibrationOptions::num_grid_points",
                      "must be >= 3");
  }
  if (min_num_pairs < 1) {
    throw OptionError(&min_num_pairs, "ViewGraph.calibration_min_num_pairs",
                      "must be >= 1");
  }
  if (!(loss_scale > 0)) {
    throw OptionError(&loss_scale, "ViewGraph.calibration_loss_scale",
                      "must be > 0");
  }
  if (!(max_agreeing_cost > 0)) {
    throw OptionError(&max_agreeing_cost,
                      "ViewGraph.calibration_max_agreeing_cost", "must be > 0");
  }
  if (num_sweeps < 1) {
    throw OptionError(&num_sweeps, "ViewGraph.calibration_num_sweeps",
                      "must be >= 1");
  }
  if (!(prior_max_ratio >= 1 && prior_max_ratio < max_focal_ratio)) {
    throw OptionError(&prior_max_ratio, "ViewGraph.calibration_prior_max_ratio",
                      "must be in [1, calibration_max_focal_ratio)");
  }
  if (!(min_cost_increase >= 1)) {
    throw OptionError(&min_cost_increase,
                      "ViewGraph.calibration_min_cost_increase",
                      "must be >= 1");
  }
}

double EssentialSingularValueCost(const Eigen::Matrix3d& F,
                                  const Eigen::Matrix3d& K1,
                                  const Eigen::Matrix3d& K2) {
  // Without an SVD (90% of the view graph's time on photo collections, the
  // focal search evaluating this per pair dozens of times): E is rank 2 (F
  // is), so its two singular values are those of E restricted to its row
  // space, a 3x2 matrix E [a b] whose QR factor R = [r00 r01; 0 r11] has
  // them too; for a 2x2 triangular matrix s1 + s2 = |(r00 + r11, r01)| and
  // s1 - s2 = |(r00 - r11, r01)|, with no cancellation near s1 = s2.
  const Eigen::Matrix3d E = K2.transpose() * F * K1;
  // The right null vector: the largest cross product of two rows.
  Eigen::Vector3d null = E.row(0).cross(E.row(1)).transpose();
  int row = 0;
  for (const auto& [i, j] : {std::pair<int, int>(0, 2), {1, 2}}) {
    const Eigen::Vector3d cross = E.row(i).cross(E.row(j)).transpose();
    if (cross.squaredNorm() > null.squaredNorm()) {
      null = cross;
      row = i;
    }
  }
  if (!(null.squaredNorm() > 0)) return 1.0;  // rank < 2 (or not finite)
  // An orthonormal basis (a, b) of the row space.
  const Eigen::Vector3d a = E.row(row).transpose().normalized();
  const Eigen::Vector3d b = null.cross(a).normalized();
  const Eigen::Vector3d c0 = E * a;
  const Eigen::Vector3d c1 = E * b;
  const double r00 = c0.norm();
  if (!(r00 > 0)) return 1.0;
  const double r01 = c0.dot(c1) / r00;
  const double r11 = c0.cross(c1).norm() / r00;
  const double sum = std::sqrt((r00 + r11) * (r00 + r11) + r01 * r01);
  return sum > 0 ? std::sqrt((r00 - r11) * (r00 - r11) + r01 * r01) / sum : 1.0;
}

std::vector<FocalCalibrationResult> CalibrateFocalLengths(
    const std::vector<FocalCalibrationPair>& pairs,
    const FocalCalibrationOptions& options,
    std::map<camera_t, Camera>* cameras) {
  options.Check();
  std::vector<FocalCalibrationResult> results;
  if (!options.calibrate_focal) return results;

  // Free cameras (no prior focal, or any with prior_max_ratio > 1; a model
  // with a focal and principal point) and the usable pairs touching each.
  std::map<camera_t, std::vector<size_t>> camera_pairs;
  const bool calibrate_priors = options.prior_max_ratio > 1;
  std::set<camera_t> unusable;
  for (size_t i = 0; i < pairs.size(); ++i) {
    const FocalCalibrationPair& pair = pairs[i];
    if (pair.F.isZero() || !(pair.weight > 0) ||
        !cameras->count(pair.camera_id1) || !cameras->count(pair.camera_id2)) {
      continue;
    }
    for (const camera_t id : {pair.camera_id1, pair.camera_id2}) {
      const Camera& camera = cameras->at(id);
      if (camera.has_prior_focal_length && !calibrate_priors) continue;
      if (!CameraHasValidParams(camera) ||
          CameraModelFocalLengthIdxs(camera.model_id).empty() ||
          CameraModelPrincipalPointIdxs(camera.model_id).size() != 2) {
        unusable.insert(id);
        continue;
      }
      if (camera_pairs[id].empty() || camera_pairs[id].back() != i) {
        camera_pairs[id].push_back(i);
      }
    }
  }
  for (const camera_t id : unusable) camera_pairs.erase(id);
  // The other cameras (priors unless prior_max_ratio > 1, too few pairs)
  // stay fixed at scale 1.
  std::vector<camera_t> free;
  for (const auto& [id, indices] : camera_pairs) {
    FocalCalibrationResult result;
    result.camera_id = id;
    result.guess_focal = CameraMeanFocalLength(cameras->at(id));
    result.focal = result.guess_focal;
    result.num_pairs = static_cast<int>(indices.size());
    if (result.num_pairs < options.min_num_pairs) {
      result.reason = "too few pairs with a fundamental matrix (" +
                      std::to_string(result.num_pairs) + " < " +
                      std::to_string(options.min_num_pairs) + ")";
    } else {
      free.push_back(id);
    }
    results.push_back(result);
  }

  Calibrator calibrator(pairs, options, *cameras);
  for (const camera_t id : free) calibrator.scale[id] = 1.0;
  std::map<camera_t, double> common = calibrator.scale;
  std::string common_reason;
  std::vector<size_t> common_subset;
  if (free.size() > 1) {
    // One factor for all free cameras first (typically one guess for all,
    // wrong by the same factor), then each camera on its own.
    std::set<size_t> subset_set;
    for (const camera_t id : free) {
      subset_set.insert(camera_pairs[id].begin(), camera_pairs[id].end());
    }
    common_subset.assign(subset_set.begin(), subset_set.end());
    std::map<camera_t, double> ones = calibrator.scale;
    if (calibrator.Search(free, ones, common_subset, &common_reason)) {
      common = calibrator.scale;
    }
  }
  std::map<camera_t, std::string> reasons;
  std::map<camera_t, bool> accepted;
  const int num_sweeps = free.size() > 1 ? options.num_sweeps : 1;
  for (int sweep = 0; sweep < num_sweeps; ++sweep) {
    if (sweep > 0 && !common_subset.empty()) {
      // A common factor on top of the current ones moves along the valley
      // that single-camera steps crawl along.
      std::string reason;
      const std::map<camera_t, double> current = calibrator.scale;
      calibrator.Search(free, current, common_subset, &reason);
    }
    for (const camera_t id : free) {
      // Each camera searched relative to its guess: base scale 1.
      std::map<camera_t, double> base{{id, 1.0}};
      std::string reason;
      if (calibrator.Search({id}, base, camera_pairs[id], &reason)) {
        accepted[id] = true;
        reasons.erase(id);
      } else if (!accepted[id]) {
        calibrator.scale[id] = common.at(id);
        reasons[id] = reason;
      }
    }
  }

  // Cameras with a prior focal (option) were calibrated as the others, from
  // their prior; one whose own fit failed, or that moved beyond
  // prior_max_ratio, keeps its prior (the pairs disagree with it, or the
  // estimate is poorly conditioned).
  for (const camera_t id : free) {
    if (!cameras->at(id).has_prior_focal_length) continue;
    const double x = calibrator.Scale(id);
    if (!accepted[id]) {
      reasons[id] = "prior kept: " + reasons[id];
      calibrator.scale.erase(id);
    } else if (x * options.prior_max_ratio < 1 || x > options.prior_max_ratio) {
      std::ostringstream why;
      why << "prior kept: the calibration gives x" << x << ", beyond the "
          << "prior's ratio " << options.prior_max_ratio;
      reasons[id] = why.str();
      calibrator.scale.erase(id);
    }
  }

  for (FocalCalibrationResult& result : results) {
    Camera& camera = cameras->at(result.camera_id);
    const auto it = calibrator.scale.find(result.camera_id);
    if (it != calibrator.scale.end() && it->second != 1.0) {
      for (const int idx : CameraModelFocalLengthIdxs(camera.model_id)) {
        camera.params[idx] *= it->second;
      }
      result.calibrated = true;
      result.focal = CameraMeanFocalLength(camera);
      if (reasons.count(result.camera_id)) {
        result.reason = "own fit rejected (" + reasons[result.camera_id] +
                        "): the common factor of all cameras is used";
      }
    } else if (result.reason.empty()) {
      result.reason = reasons.count(result.camera_id)
                          ? reasons[result.camera_id]
                          : common_reason;
    }
    if (result.calibrated) {
      LOG(INFO) << "Focal calibration: camera " << result.camera_id << " "
                << result.guess_focal << " -> " << result.focal << " px from "
                << result.num_pairs << " pairs"
                << (result.reason.empty() ? "" : "; " + result.reason);
    } else {
      LOG(INFO) << "Focal calibration: camera " << result.camera_id
                << " keeps its focal " << result.guess_focal << " px ("
                << result.num_pairs << " pairs): " << result.reason;
    }
  }
  return results;
}

}  // namespace colmap_irav4
