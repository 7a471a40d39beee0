#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "colmap_irav4/refinement/keypoint_noise.h"
#include "colmap_irav4/scene/reconstruction.h"
#include "colmap_irav4/scene/track.h"

namespace colmap_irav4 {

// The point closest to a bundle of rays in the least-squares sense (sum of
// squared distances to the rays: the multi-view midpoint). `directions` need
// not be unit. Returns false if the rays are (nearly) parallel: also when
// the normal matrix's smallest eigenvalue is under `min_relative_eigenvalue`
// times its largest (a stricter test for callers that need the point fixed
// in every direction).
bool TriangulateMidpoint(const std::vector<Eigen::Vector3d>& centers,
                         const std::vector<Eigen::Vector3d>& directions,
                         Eigen::Vector3d* xyz,
                         double min_relative_eigenvalue = 0);

// Multi-view DLT from cam_from_world matrices and normalised image points
// (x/z, y/z). Returns false if degenerate or the point is at infinity.
bool TriangulateDLT(
    const std::vector<Eigen::Matrix<double, 3, 4>>& cams_from_world,
    const std::vector<Eigen::Vector2d>& points, Eigen::Vector3d* xyz);

// The ray of keypoint `xy` of `image`, seen by `camera`: the undistorted
// normalised point (x/z, y/z) and the unit direction in the world frame.
// False when the camera cannot undistort the keypoint.
bool ObservationRay(const Camera& camera, const Image& image,
                    const Eigen::Vector2d& xy, Eigen::Vector2d* normalized,
                    Eigen::Vector3d* direction);

// One observation of a point as RefinePointPosition weighs it: its
// image's cam_from_world (R, t), the keypoint in the undistorted normalised
// plane, and the focal length (px per normalised unit) scaling its residual.
struct NormalizedObservation {
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
  Eigen::Vector2d normalized;
  double focal;
};

// Gauss-Newton (at most 10 steps) on the reprojection error of one point
// over `observations`: the midpoint is not the maximum-likelihood point,
// and bundle adjustment converges much faster from refined points. `xyz`
// is left as it is when the point falls behind a camera or a step is not
// finite.
void RefinePointPosition(const std::vector<NormalizedObservation>& observations,
                         Eigen::Vector3d* xyz);

struct TriangulationOptions {
  // Inlier threshold on the reprojection error, px (COLMAP's
  // complete_max_reproj_error / create_max_angle_error analogue).
  double max_reproj_error = 4.0;
  // A point needs two inlier rays at least this far apart, deg (COLMAP's
  // min_tri_angle).
  double min_tri_angle = 1.5;
  // RANSAC over pairs of observations: every pair if there are at most this
  // many, else this many random pairs.
  int max_num_trials = 100;
  // Points found per track at most (observations left over after a point
  // may form another one, e.g. when a wrong match merged two tracks).
  int max_points_per_track = 2;
  uint64_t random_seed = 0;
  // Tracks of exactly two observations are not triangulated (COLMAP's
  // ignore_two_view_tracks, on in COLMAP's incremental mapper): a match no
  // third image confirms is more often wrong, and its point constrains the
  // poses little. Off by default: it helps fountain-P11 but hurts
  // Herz-Jesus-P8 and the synthetic courtyards
  // (docs/notes/2026-12-01-results-2b39f55.md).
  bool ignore_two_view_tracks = false;
  // Track completion: an observation no point uses yet joins the point its
  // track already has (the one with the smallest reprojection error, one
  // observation per image) when it reprojects within max_reproj_error;
  // only the others are triangulated as new points. Off: every free
  // observation of a track goes to new points, and a single one is lost.
  bool complete_tracks = true;

  // Throws InputError naming the offending option.
  void Check() const;
};

struct TriangulationSummary {
  size_t num_tracks_tried = 0;  // tracks with >= 2 unlinked observations
  size_t num_points_added = 0;
  size_t num_observations_added = 0;
  // Observations added to a point their track already had (complete_tracks).
  size_t num_observations_completed = 0;
};

// For every track, adds its observations in registered images that no point
// uses yet to the track's existing point where they reproject onto it
// (complete_tracks), then triangulates the rest (robustly: RANSAC over pairs,
// cheirality, reprojection error, triangulation angle; then the midpoint of the
// inliers) and adds the points with their inlier observations. Tracks that
// failed positioning and observations removed by filtering are recovered this
// way; on a model without points it triangulates everything (translation
// averaging path). With `noise`, an observation's inlier threshold is
// max_reproj_error times the noise factor of its keypoint's scale.
TriangulationSummary TriangulateTracks(
    const TriangulationOptions& options, const std::vector<Track>& tracks,
    Reconstruction* reconstruction, const KeypointScaleNoise* noise = nullptr);

}  // namespace colmap_irav4
