#pragma once

// Synthetic scenes with known answers for testing the stages after rotation
// averaging: cameras on an arc looking at a point cloud, noisy keypoints,
// pairwise matches with optional wrong matches.

#include <cstdint>
#include <vector>

#include "colmap_irav4/scene/features.h"
#include "colmap_irav4/scene/reconstruction.h"

namespace colmap_irav4 {

struct SyntheticSceneOptions {
  int num_images = 15;
  int num_points = 1000;
  // COLMAP camera model id (0 SIMPLE_PINHOLE, 1 PINHOLE, 2 SIMPLE_RADIAL, ...).
  int camera_model_id = 1;
  int width = 1600;
  int height = 1200;
  double focal_length = 1200.0;  // px
  // Value of every extra (distortion) parameter, e.g. k of SIMPLE_RADIAL.
  double extra_param = 0.0;
  // One camera for all images (else one per image).
  bool shared_camera = true;
  // Cameras on a horizontal arc of this angle and radius, centred on the
  // origin, each looking at a point near the origin.
  double arc_angle_deg = 90.0;
  double arc_radius = 10.0;
  // Random vertical offsets of the cameras, as a fraction of the radius.
  double height_jitter = 0.1;
  // Points uniform in a cube of this half size around the origin.
  double point_half_extent = 3.0;
  // Probability that a point is detected in an image where it projects.
  double visibility = 1.0;
  // Gaussian keypoint noise, px (standard deviation per coordinate).
  double noise_px = 0.0;
  // Wrong matches added per pair, as a fraction of its true matches.
  double outlier_match_ratio = 0.0;
  uint64_t seed = 1;
};

struct SyntheticScene {
  // Ground truth: poses, points with tracks, keypoints (with noise) linked to
  // their points. Keypoint indices are those of `matches`.
  Reconstruction truth;
  // Every image pair with at least one common point: true matches, plus wrong
  // ones (random keypoint pairs of different points) if asked.
  std::vector<ImagePairMatches> matches;
};

SyntheticScene GenerateSyntheticScene(const SyntheticSceneOptions& options);

// A copy of `truth` with its points removed and keypoints unlinked (cameras,
// keypoints and the true poses remain).
Reconstruction StripPoints(const Reconstruction& truth);

}  // namespace colmap_irav4
