#pragma once

// Focal length self-calibration from fundamental matrices: COLMAP guesses
// f = 1.2 * max(width, height) for images without EXIF focal, and with a
// wrong focal E = K2^T F K1 is no essential matrix (its two non-zero singular
// values differ), so the relative poses derived from it fail. The focal of
// each camera without a prior is chosen so that the E of its pairs have two
// equal singular values.

#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "colmap_irav4/scene/camera.h"
#include "colmap_irav4/scene/types.h"

namespace colmap_irav4 {

struct FocalCalibrationOptions {
  // Calibrate the focal of cameras without a prior focal length.
  bool calibrate_focal = true;
  // Search range of the focal, as factors of the camera's current focal.
  double min_focal_ratio = 0.25;
  double max_focal_ratio = 4.0;
  // Cameras with a prior focal: 1 keeps the prior fixed; above 1 each such
  // camera is calibrated too, within [1 / prior_max_ratio, prior_max_ratio]
  // x its prior, after the cameras without one (an EXIF focal is a few
  // percent off, enough to turn the relative rotations derived from F by
  // degrees), and keeps its prior where the minimum is at the range's end
  // or ill-conditioned.
  double prior_max_ratio = 1.0;
  // Log-spaced grid points of the search before golden-section refinement.
  int num_grid_points = 61;
  // A camera needs at least this many pairs with a fundamental matrix.
  int min_num_pairs = 3;
  // Cauchy scale of the per-pair cost (s1 - s2) / (s1 + s2); small, so that
  // the pairs agreeing most closely decide (on Strecha fountain with the focal
  // x1.3, scale 0.05 gave -4.9%, 0.002 -1.4%, 0.001 -0.7%: pairs with a
  // strongly curved but biased cost otherwise pull the estimate).
  double loss_scale = 0.001;
  // Coordinate-descent sweeps over the cameras (several free cameras), each
  // a common factor for all, then one factor per camera.
  int num_sweeps = 10;
  // A pair agrees with a focal if its cost there is below this.
  double max_agreeing_cost = 0.01;
  // Ill-conditioning guard: the mean cost of the pairs agreeing with the
  // minimum (at least min_num_pairs of them are needed) at the focal x / 1.25
  // and x 1.25 must both exceed the one at the minimum by this factor. The
  // shared Maupertuis database (focal guess 2302.8, reference 1847.53) has 1.41
  // and would give 1737.8 (-5.9%), with which its relative rotations are
  // 0.8-2.9 deg off the reference model (< 1 deg at 1847.53): such weak
  // estimates are not used.
  double min_cost_increase = 1.5;

  // Throws InputError naming the option if invalid.
  void Check() const;
};

// One pair's fundamental matrix (x2^T F x1 = 0, pixels) between two cameras.
struct FocalCalibrationPair {
  camera_t camera_id1 = kInvalidCameraId;
  camera_t camera_id2 = kInvalidCameraId;
  Eigen::Matrix3d F = Eigen::Matrix3d::Zero();
  double weight = 1.0;  // e.g. the number of inlier matches
};

struct FocalCalibrationResult {
  camera_t camera_id = kInvalidCameraId;
  double guess_focal = 0.0;  // mean focal before
  double focal = 0.0;        // mean focal after (= guess if not calibrated)
  int num_pairs = 0;
  bool calibrated = false;
  std::string reason;  // why the guess was kept
};

// (s1 - s2) / (s1 + s2) of the two largest singular values of K2^T F K1: 0 for
// a valid essential matrix, up to 1.
double EssentialSingularValueCost(const Eigen::Matrix3d& F,
                                  const Eigen::Matrix3d& K1,
                                  const Eigen::Matrix3d& K2);

// Calibrates the focal length(s) of the cameras without a prior focal length
// that appear in the pairs (all focal parameters scaled by one factor, the
// principal point and distortion untouched); cameras with a prior stay fixed
// and constrain the others (then, with options.prior_max_ratio > 1, are
// calibrated within that ratio of their prior). Updates *cameras and returns
// one result per calibrated or considered camera seen in the pairs.
std::vector<FocalCalibrationResult> CalibrateFocalLengths(
    const std::vector<FocalCalibrationPair>& pairs,
    const FocalCalibrationOptions& options,
    std::map<camera_t, Camera>* cameras);

}  // namespace colmap_irav4
