#pragma once

#include <cmath>
#include <limits>
#include <map>

#include <Eigen/Core>
#include <Eigen/Dense>

#include "colmap_irav4/scene/types.h"
#include "colmap_irav4/util/error.h"

namespace colmap_irav4 {

// What is known of an image's pose from other sensors, in the priors' frame
// (metres; WGS84 priors converted to a local east-north-up frame, z up).
struct PosePrior {
  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  // The camera centre; NaN when unknown.
  Eigen::Vector3d position = Eigen::Vector3d::Constant(kNaN);
  // Its covariance (m^2); NaN when unknown (a default standard deviation is
  // used).
  Eigen::Matrix3d position_covariance = Eigen::Matrix3d::Constant(kNaN);
  // The direction of gravity (down) in the camera frame (COLMAP 4's
  // convention), unit length; NaN when unknown. In the priors' frame down is
  // -z.
  Eigen::Vector3d gravity = Eigen::Vector3d::Constant(kNaN);

  bool HasPosition() const { return position.allFinite(); }
  bool HasPositionCovariance() const { return position_covariance.allFinite(); }
  bool HasGravity() const { return gravity.allFinite(); }
};

// Priors by image id.
using PosePriors = std::map<image_t, PosePrior>;

// How priors are weighed where they are used (global positioning, bundle
// adjustment).
struct PosePriorOptions {
  // Standard deviation (m, each axis) of a position prior stored without a
  // covariance (COLMAP's EXIF priors have none; consumer GPS: 3-10 m).
  double position_std = 5.0;
  // The loss on the whitened prior residuals (geometry/pose_prior_cost.h's
  // QuadraticCauchyTailLoss): least squares up to quadratic_std standard
  // deviations (4: 99.9% of valid 3-d residuals), then a Cauchy tail of
  // scale loss_scale: a prior 15 std off (a GPS outlier) pulls about 24
  // times less than least squares would.
  double quadratic_std = 4.0;
  double loss_scale = 3.0;
  // Once the model is in the priors' frame, bundle adjustment leaves out
  // every prior whose whitened residual exceeds gate_std standard
  // deviations (times the priors' own spread where it is wider than their
  // covariance says: GatePosePriors, refinement/bundle_adjustment.h): a GPS
  // outlier then pulls nothing, where the Cauchy tail still pulls a little.
  // 6: a valid 3-d residual lies beyond it with probability 7.5e-8; the
  // benchmark's GPS outliers lie 8-33 std off, while at 5 a valid fix 4.9
  // std off its true centre was left out of two models (docs/notes/
  // 2026-12-03-prior-outlier-gate.md). 0: none left out.
  double gate_std = 6.0;
  // Standard deviation of a gravity direction (deg).
  double gravity_std_deg = 2.0;
  // Fewest position priors that place a model in the priors' frame (a
  // similarity needs 3 points not on a line).
  int min_num_positions = 3;

  void Check() const {
    if (!(position_std > 0)) {
      throw OptionError(&position_std, "Mapper.prior_position_std",
                        "must be positive");
    }
    if (!(quadratic_std >= 0)) {
      throw OptionError(&quadratic_std, "Mapper.prior_quadratic_std",
                        "must be >= 0");
    }
    if (!(loss_scale > 0)) {
      throw OptionError(&loss_scale, "Mapper.prior_loss_scale",
                        "must be positive");
    }
    if (!(gate_std == 0 || gate_std >= 3)) {
      throw OptionError(&gate_std, "Mapper.prior_gate_std",
                        "must be 0 (off) or at least 3 (a gate inside 3 std "
                        "leaves out valid priors)");
    }
    if (!(gravity_std_deg > 0 && gravity_std_deg < 90)) {
      throw OptionError(&gravity_std_deg, "Mapper.prior_gravity_std",
                        "must be in (0, 90) deg");
    }
    if (min_num_positions < 3) {
      throw OptionError(&min_num_positions, "Mapper.prior_min_num_positions",
                        "must be >= 3");
    }
  }
};

// W with W^T W = covariance^-1 (the stored one, or position_std^2 I):
// W (c - prior) is the prior's residual in standard deviations.
inline Eigen::Matrix3d PositionPriorSqrtInformation(
    const PosePrior& prior, const PosePriorOptions& options) {
  if (!prior.HasPositionCovariance()) {
    return Eigen::Matrix3d::Identity() / options.position_std;
  }
  const Eigen::Matrix3d L = prior.position_covariance.llt().matrixL();
  return L.inverse();
}

// The largest standard deviation of a position prior (m).
inline double PositionPriorStd(const PosePrior& prior,
                               const PosePriorOptions& options) {
  if (!prior.HasPositionCovariance()) return options.position_std;
  return std::sqrt(prior.position_covariance.diagonal().maxCoeff());
}

}  // namespace colmap_irav4
