#pragma once

#include <cstddef>

#include "colmap_irav4/scene/reconstruction.h"

namespace colmap_irav4 {

// What a model's bundle adjustment rests on: how many points and
// observations it keeps, how long its tracks are, how they spread over each
// image. Used to compare two models of the same images (ours and COLMAP's):
// given the same poses, the accuracy of the adjusted cameras depends only on
// this observation set.
struct ObservationStatistics {
  int num_images = 0;
  size_t num_points = 0;
  size_t num_observations = 0;
  double mean_track_length = 0;
  double two_view_point_fraction = 0;  // points seen by exactly two images
  double median_observations_per_image = 0;
  int min_observations_per_image = 0;
  double mean_reproj_error = 0;     // px, over observations
  double median_tri_angle_deg = 0;  // largest angle per point, median
  // Mean over images of the fraction of grid_size x grid_size cells of the
  // image holding at least one observation.
  double mean_grid_coverage = 0;
};

ObservationStatistics ComputeObservationStatistics(
    const Reconstruction& reconstruction, int grid_size = 4);

// Replaces the poses of `target`'s images by those of the images of `source`
// with the same names, after mapping `source` onto `target` by the
// least-squares similarity over the common camera centres (so that
// `target`'s points stay in a consistent frame). With copy_intrinsics, each
// target camera also takes the parameters of the source camera of its first
// image with a counterpart (same camera model required). Returns the number
// of poses replaced; throws InputError with fewer than 3 common images or
// degenerate centres.
int TransferPoses(const Reconstruction& source, bool copy_intrinsics,
                  Reconstruction* target);

// The observations of a model checked against the exact model of a
// synthetic scene (same image names, same keypoint indices): an observation
// is correct when its keypoint is the truth's projection of the truth point
// most of its track's keypoints belong to.
struct TrackCorrectness {
  size_t num_observations = 0;
  size_t num_wrong = 0;  // another truth point, or clutter
  size_t num_points = 0;
  size_t num_points_with_wrong = 0;
  // Truth observations (of the model's images) the model does not use.
  size_t num_truth_missing = 0;
};

TrackCorrectness CompareTracksWithTruth(const Reconstruction& model,
                                        const Reconstruction& truth);

// Deletes the points with fewer than min_track_length observations.
// Returns the number deleted.
size_t DeleteShortTracks(int min_track_length, Reconstruction* reconstruction);

}  // namespace colmap_irav4
