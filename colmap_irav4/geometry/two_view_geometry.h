#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "colmap_irav4/scene/camera.h"
#include "colmap_irav4/scene/features.h"
#include "colmap_irav4/scene/types.h"

namespace colmap_irav4 {

// A verified image pair as COLMAP's matcher stores it in two_view_geometries,
// oriented image_id1 -> image_id2 (the database's order is image_id1 <
// image_id2). Conventions (COLMAP's): x2^T F x1 = 0 in pixels, x2^T E x1 = 0
// in normalised camera coordinates, x2 ~ H x1 in pixels, and the stored pose
// is cam2_from_cam1 (x2 = R x1 + t). inlier_matches' first column indexes
// image_id1's keypoints.
struct TwoViewGeometry {
  // COLMAP's TwoViewGeometry::ConfigurationType.
  enum ConfigurationType {
    UNDEFINED = 0,
    DEGENERATE = 1,
    CALIBRATED = 2,
    UNCALIBRATED = 3,
    PLANAR = 4,
    PANORAMIC = 5,
    PLANAR_OR_PANORAMIC = 6,
    WATERMARK = 7,
    MULTIPLE = 8,
  };

  image_t image_id1 = kInvalidImageId;
  image_t image_id2 = kInvalidImageId;
  int config = UNDEFINED;
  FeatureMatches inlier_matches;
  // All-zero (or absent in the database) means "not estimated".
  Eigen::Matrix3d F = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d E = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  // Stored cam2_from_cam1; COLMAP 3.8 leaves it zero by default, COLMAP <= 3.7
  // has no such columns: has_pose tells whether a usable one was stored.
  bool has_pose = false;
  Eigen::Vector4d qvec = Eigen::Vector4d(1, 0, 0, 0);  // (qw, qx, qy, qz)
  Eigen::Vector3d tvec = Eigen::Vector3d::Zero();

  // The same geometry seen from image_id2 to image_id1: swapped match columns,
  // F^T, E^T, H^-1, inverse pose.
  TwoViewGeometry Inverse() const;
};

// Name of a configuration ("CALIBRATED"), "UNKNOWN(<n>)" if out of range.
std::string TwoViewConfigName(int config);
// -1 for an unknown name.
int TwoViewConfigFromName(const std::string& name);

struct RelativePoseOptions {
  // Epipolar (Sampson) / transfer error threshold in pixels that a match must
  // meet to support a candidate pose (COLMAP's two-view max_error is 4 px).
  double max_error_px = 4.0;
  // Refine the chosen pose on the inlier matches (robust Sampson error).
  bool refine = true;
  // Cauchy loss scale of the refinement, pixels.
  double refine_loss_scale_px = 1.0;
  int refine_max_num_iterations = 50;
  // Refine on at most this many supporting matches, evenly spread over them
  // (the pose has 5 degrees of freedom; thousands of matches add time, little
  // accuracy). 0: all.
  int refine_max_num_matches = 0;
  // The pose is refined only where its inliers determine the rotation to
  // within this standard deviation (deg, first order, noise estimated from
  // the residuals): elsewhere (near-planar scenes, short baselines with few
  // matches) the cost is flat along a valley, refinement fits the noise and
  // walks degrees away, and the matcher's estimate is kept. 100-image
  // synthetic courtyard (exact stored E): refined poses > 5 deg off 29 -> 1
  // of 1,043, median 0.067 -> 0.059 deg; Strecha unchanged (1.0 would also
  // skip a fountain-P11 pair that refinement improves, 3.1 -> 2.3 deg).
  double refine_max_rotation_std_deg = 2.0;
  // Skip the eight-point re-estimate where a candidate from the stored
  // geometry is supported by at least this fraction of the inlier matches:
  // refinement then starts from an equally good pose (fountain-P11,
  // Herz-Jesus-P8, 300-image courtyard: rotations within 0.003 deg of those
  // with it). Above 1: always estimated.
  double skip_eight_point_min_support = 0.99;
  // Use the pose stored in the database when it is non-zero and supported by
  // at least this fraction of the support of the best derived candidate (it
  // is refined like a derived one: COLMAP 3.8's stored poses were measured
  // less accurate than refined derived ones).
  double min_stored_pose_support = 0.9;
  // Below this median triangulation angle of the supporting matches the
  // translation direction is marked unreliable (near pure rotation).
  double min_tri_angle_deg = 0.5;
  // Where no candidate is supported by 5 matches within max_error_px, score
  // the candidates once more within this threshold (pixels) before dropping
  // the pair; 0 (or not above max_error_px): no second scoring. Photo
  // collections with focal priors a few percent off and unmodelled
  // distortion lose wide-angle true pairs of hundreds of inliers at 4 px
  // (docs/notes/2026-12-05-photo-100-registration.md).
  double retry_max_error_px = 0.0;

  void Check() const;  // throws InputError naming the option
};

// Where a relative pose came from.
enum class RelativePoseSource {
  kNone,
  kStored,       // two_view_geometries.qvec/tvec
  kEssential,    // decomposition of the stored E
  kFundamental,  // E = K2^T F K1
  kHomography,   // decomposition of K2^-1 H K1
  kRotation,     // pure rotation from H (translation undefined)
  kEightPoint,   // re-estimated from the undistorted inlier matches
};
std::string RelativePoseSourceName(RelativePoseSource source);

struct RelativePose {
  bool success = false;
  RelativePoseSource source = RelativePoseSource::kNone;
  // cam2_from_cam1: R = R_2 R_1^T, unit t (zero when !has_translation).
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  // False for (near) pure rotation: t is then undefined.
  bool has_translation = false;
  // Matches within max_error_px and in front of both cameras.
  int num_supporting = 0;
  double median_tri_angle_deg = 0.0;
  bool refined = false;
  // The rotation's standard deviation before refinement (deg; -1 when the
  // refinement did not run).
  double rotation_std_deg = -1;
  // Passes of the refinement over the supporting matches (0: not run).
  int num_refine_passes = 0;
  // Supported only within RelativePoseOptions::retry_max_error_px.
  bool retried = false;
  std::string failure;  // why success is false
};

// Derives cam2_from_cam1 of a verified pair from what the database stores:
// candidates from the stored pose, E, F with the intrinsics, H (up to four
// decompositions and the pure rotation) and an eight-point re-estimate on the
// undistorted inliers; the candidate with the lowest truncated error, where a
// match behind a camera costs the full threshold (cheirality), wins, and is
// then optionally refined. keypoints1/2 are the keypoints of image_id1/2.
RelativePose EstimateRelativePose(const TwoViewGeometry& geometry,
                                  const Camera& camera1, const Camera& camera2,
                                  const FeatureKeypoints& keypoints1,
                                  const FeatureKeypoints& keypoints2,
                                  const RelativePoseOptions& options);

// The same from the keypoints already normalised (undistorted, x/z y/z) by
// CameraImageToCamera of camera1/camera2, indexed as the keypoints: callers
// deriving many pairs undistort each image's keypoints once instead of once
// per pair.
RelativePose EstimateRelativePoseNormalized(
    const TwoViewGeometry& geometry, const Camera& camera1,
    const Camera& camera2, const std::vector<Eigen::Vector2d>& normalized1,
    const std::vector<Eigen::Vector2d>& normalized2,
    const RelativePoseOptions& options);

// Building blocks, exposed for tests.

// The four (R, t) of an essential matrix, t unit.
void DecomposeEssentialMatrix(const Eigen::Matrix3d& E,
                              std::vector<Eigen::Matrix3d>* R,
                              std::vector<Eigen::Vector3d>* t);
// Decompositions (R, t, n) of a calibrated homography x2 ~ H x1 with
// x2 = R x1 + t and the plane n^T x1 = 1 (t = translation / plane distance).
// Returns up to four solutions; a single (R, 0, 0) for a pure rotation.
void DecomposeHomographyMatrix(const Eigen::Matrix3d& H,
                               std::vector<Eigen::Matrix3d>* R,
                               std::vector<Eigen::Vector3d>* t,
                               std::vector<Eigen::Vector3d>* n);
// Essential matrix [t]x R.
Eigen::Matrix3d EssentialFromPose(const Eigen::Matrix3d& R,
                                  const Eigen::Vector3d& t);
// Linear eight-point estimate of E from >= 8 normalised correspondences,
// projected onto the essential manifold. False if fewer than 8.
bool EstimateEssentialEightPoint(const std::vector<Eigen::Vector2d>& points1,
                                 const std::vector<Eigen::Vector2d>& points2,
                                 Eigen::Matrix3d* E);
// Linear (Hartley-normalised) eight-point estimate of a fundamental matrix
// x2^T F x1 = 0 from >= 8 correspondences in pixels, rank 2, unit Frobenius
// norm. False if fewer than 8 or degenerate.
bool EstimateFundamentalEightPoint(const std::vector<Eigen::Vector2d>& points1,
                                   const std::vector<Eigen::Vector2d>& points2,
                                   Eigen::Matrix3d* F);
// Linear (Hartley-normalised) DLT estimate of a homography x2 ~ H x1 from
// >= 4 correspondences, unit Frobenius norm. False if fewer than 4 or
// degenerate.
bool EstimateHomographyDLT(const std::vector<Eigen::Vector2d>& points1,
                           const std::vector<Eigen::Vector2d>& points2,
                           Eigen::Matrix3d* H);
// Squared transfer error |x2 - H x1|^2 (infinite where H x1 is at infinity).
double HomographyTransferErrorSquared(const Eigen::Matrix3d& H,
                                      const Eigen::Vector2d& x1,
                                      const Eigen::Vector2d& x2);
// Squared Sampson error of x2^T E x1 = 0 (normalised coordinates; with F and
// pixel coordinates, in pixels squared).
double SampsonErrorSquared(const Eigen::Matrix3d& E, const Eigen::Vector2d& x1,
                           const Eigen::Vector2d& x2);
// Linear triangulation of x2 = R x1 + t; returns the depths in camera 1 and
// camera 2 (non-positive means behind).
void TriangulateDepths(const Eigen::Matrix3d& R, const Eigen::Vector3d& t,
                       const Eigen::Vector2d& x1, const Eigen::Vector2d& x2,
                       double* depth1, double* depth2);
// K of a camera from its focal length(s) and principal point.
Eigen::Matrix3d CameraCalibrationMatrix(const Camera& camera);

}  // namespace colmap_irav4
