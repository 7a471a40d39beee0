#pragma once

// Merging the points that are one 3D point seen through different tracks.
// A matcher keeps only part of a point's correspondences per pair, so the
// union of its matches can fall apart into several tracks (images A, B and
// C, D matched, never A with C): each gives its own point, each constraining
// fewer cameras together. After retriangulation the poses are good enough
// to see that such points coincide: a point projects onto an observation of
// another point in an image it is not seen in, and one position reprojects
// within the threshold onto every observation of both. Matches cannot join
// them (none link the tracks); only the geometry can.

#include <cstddef>

#include "colmap_irav4/refinement/keypoint_noise.h"
#include "colmap_irav4/scene/reconstruction.h"

namespace colmap_irav4 {

struct PointMergingOptions {
  // Merge the points of different tracks that are one 3D point, after
  // retriangulation (and the two-view check), before the last bundle
  // adjustment. Off by default: on the synthetic photo scenes it makes the
  // tracks as long as COLMAP's and the rotations no worse, but the centres
  // worse and about 1 in 40 merges joins two true points
  // (docs/notes/2026-12-05-track-completion.md).
  bool enabled = false;
  // A candidate: an observation of another point within this distance (px)
  // of the point's projection in an image the point is not seen in.
  double search_radius = 4.0;
  // The merged point must reproject within this (px; times the keypoint
  // noise factor of each observation's scale when bundle adjustment
  // estimated one) onto every observation of both points.
  double max_reproj_error = 4.0;
  // And the merged point's sum of squared reprojection errors may exceed
  // the two points' own sums by at most this many times the model's
  // per-coordinate noise variance (estimated from the median of its
  // squared residuals, in noise units): a chi-square test of one point against
  // two, 3 degrees of freedom (7.8: 95%). Two nearby points seen from similar
  // directions pass the per-observation threshold, not this. 0: no such test.
  double max_cost_increase = 7.8;
  // Passes over all points (a merged point may reach further ones).
  int max_passes = 2;

  // Throws InputError naming the offending option.
  void Check() const;
};

struct PointMergingSummary {
  size_t num_candidates = 0;  // pairs of points tested
  size_t num_merges = 0;      // points merged into another
  size_t num_observations_moved = 0;
  // The per-coordinate noise variance the test used (px^2, noise units).
  double noise_variance = 0;
};

// Merges pairs of points that share no image, one of which projects within
// search_radius of an observation of the other, when the least-squares
// position over all their observations reprojects within max_reproj_error
// onto each and fits them nearly as well as the two points apart
// (max_cost_increase); the merged point keeps the smaller id. Candidate images
// of a point: those sharing a point with one of its images. Deterministic
// (points in id order).
PointMergingSummary MergePoints(const PointMergingOptions& options,
                                Reconstruction* reconstruction,
                                const KeypointScaleNoise* noise = nullptr);

}  // namespace colmap_irav4
