#include "colmap_irav4/refinement/triangulation.h"

#include <algorithm>
#include <cmath>
#include <random>

#include <glog/logging.h>
#include <Eigen/Dense>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/scene/camera_models.h"
#include "colmap_irav4/scene/reconstruction_utils.h"
#include "colmap_irav4/util/error.h"

namespace colmap_irav4 {
namespace {

struct Ray {
  TrackElement element;
  Eigen::Vector3d center;
  Eigen::Vector3d direction;  // unit, world frame
  const Camera* camera;
  const Image* image;
  Eigen::Vector2d xy;
  Eigen::Vector2d normalized;  // undistorted x/z, y/z
  double focal;                // px per normalised unit, to weigh residuals
  double max_reproj_error;     // inlier threshold, px
};

// RefinePointPosition over the rays of `subset`.
void RefinePoint(const std::vector<Ray>& rays, const std::vector<int>& subset,
                 Eigen::Vector3d* xyz) {
  std::vector<NormalizedObservation> observations;
  observations.reserve(subset.size());
  for (const int r : subset) {
    const Rigid3d& cam_from_world = rays[r].image->cam_from_world;
    observations.push_back({cam_from_world.rotation.toRotationMatrix(),
                            cam_from_world.translation, rays[r].normalized,
                            rays[r].focal});
  }
  RefinePointPosition(observations, xyz);
}

// Inliers of `xyz` among `rays` (in front, within each ray's threshold).
std::vector<int> Inliers(const std::vector<Ray>& rays,
                         const std::vector<int>& candidates,
                         const Eigen::Vector3d& xyz, double* sum_error) {
  std::vector<int> inliers;
  *sum_error = 0;
  for (int r : candidates) {
    const double error =
        ReprojectionError(*rays[r].camera, *rays[r].image, xyz, rays[r].xy);
    if (error <= rays[r].max_reproj_error) {
      inliers.push_back(r);
      *sum_error += error;
    }
  }
  return inliers;
}

double MaxAngleCos(const std::vector<Ray>& rays, const std::vector<int>& subset,
                   const Eigen::Vector3d& xyz) {
  double min_cos = 1.0;
  for (size_t a = 0; a < subset.size(); ++a) {
    const Eigen::Vector3d ra = (xyz - rays[subset[a]].center).normalized();
    for (size_t b = a + 1; b < subset.size(); ++b) {
      min_cos = std::min(min_cos,
                         ra.dot((xyz - rays[subset[b]].center).normalized()));
    }
  }
  return min_cos;
}

// Adds the free observation `element` to the one of `candidates` (points of
// its track) onto which it reprojects best, within `max_reproj_error` px,
// if that point has no observation in its image yet.
bool CompleteTrack(const std::vector<point3D_t>& candidates,
                   const TrackElement& element, double max_reproj_error,
                   Reconstruction* reconstruction) {
  Image& image = reconstruction->images.at(element.image_id);
  Point2D& point2D = image.points2D.at(element.point2D_idx);
  const Camera& camera = reconstruction->cameras.at(image.camera_id);
  point3D_t best_id = kInvalidPoint3DId;
  double best_error = max_reproj_error;
  for (const point3D_t point3D_id : candidates) {
    const Point3D& point = reconstruction->points3D.at(point3D_id);
    const bool seen_in_image = std::any_of(
        point.track.begin(), point.track.end(), [&](const TrackElement& other) {
          return other.image_id == element.image_id;
        });
    if (seen_in_image) continue;
    const double error =
        ReprojectionError(camera, image, point.xyz, point2D.xy);
    if (error <= best_error) {
      best_error = error;
      best_id = point3D_id;
    }
  }
  if (best_id == kInvalidPoint3DId) return false;
  point2D.point3D_id = best_id;
  reconstruction->points3D.at(best_id).track.push_back(element);
  return true;
}

}  // namespace

bool ObservationRay(const Camera& camera, const Image& image,
                    const Eigen::Vector2d& xy, Eigen::Vector2d* normalized,
                    Eigen::Vector3d* direction) {
  *normalized = CameraImageToCamera(camera, xy);
  if (!normalized->allFinite()) return false;
  *direction =
      (image.cam_from_world.rotation.inverse() * normalized->homogeneous())
          .normalized();
  return true;
}

void RefinePointPosition(const std::vector<NormalizedObservation>& observations,
                         Eigen::Vector3d* xyz) {
  Eigen::Vector3d X = *xyz;
  for (int iteration = 0; iteration < 10; ++iteration) {
    Eigen::Matrix3d JtJ = Eigen::Matrix3d::Zero();
    Eigen::Vector3d Jtr = Eigen::Vector3d::Zero();
    for (const NormalizedObservation& observation : observations) {
      const Eigen::Vector3d p = observation.R * X + observation.t;
      if (p.z() <= 0) return;
      const double inv_z = 1.0 / p.z();
      const Eigen::Vector2d residual =
          observation.focal * (Eigen::Vector2d(p.x() * inv_z, p.y() * inv_z) -
                               observation.normalized);
      Eigen::Matrix<double, 2, 3> J;
      J << inv_z, 0, -p.x() * inv_z * inv_z, 0, inv_z, -p.y() * inv_z * inv_z;
      const Eigen::Matrix<double, 2, 3> JR =
          observation.focal * J * observation.R;
      JtJ += JR.transpose() * JR;
      Jtr += JR.transpose() * residual;
    }
    const Eigen::Vector3d step = JtJ.ldlt().solve(-Jtr);
    if (!step.allFinite()) return;
    X += step;
    if (step.norm() < 1e-10 * X.norm()) break;
  }
  if (X.allFinite()) *xyz = X;
}

bool TriangulateMidpoint(const std::vector<Eigen::Vector3d>& centers,
                         const std::vector<Eigen::Vector3d>& directions,
                         Eigen::Vector3d* xyz, double min_relative_eigenvalue) {
  CHECK_EQ(centers.size(), directions.size());
  if (centers.size() < 2) return false;
  // sum_i (I - d_i d_i^T) (X - c_i) = 0.
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < centers.size(); ++i) {
    const Eigen::Vector3d d = directions[i].normalized();
    const Eigen::Matrix3d P = Eigen::Matrix3d::Identity() - d * d.transpose();
    A += P;
    b += P * centers[i];
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(A);
  // Parallel rays: A has a (near) null direction along them.
  if (eigen.eigenvalues()(0) < 1e-12 * centers.size() ||
      eigen.eigenvalues()(0) <
          min_relative_eigenvalue * eigen.eigenvalues()(2)) {
    return false;
  }
  *xyz = A.ldlt().solve(b);
  return xyz->allFinite();
}

bool TriangulateDLT(
    const std::vector<Eigen::Matrix<double, 3, 4>>& cams_from_world,
    const std::vector<Eigen::Vector2d>& points, Eigen::Vector3d* xyz) {
  CHECK_EQ(cams_from_world.size(), points.size());
  if (points.size() < 2) return false;
  Eigen::MatrixXd A(2 * points.size(), 4);
  for (size_t i = 0; i < points.size(); ++i) {
    const auto& P = cams_from_world[i];
    A.row(2 * i) = points[i].x() * P.row(2) - P.row(0);
    A.row(2 * i + 1) = points[i].y() * P.row(2) - P.row(1);
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(A, Eigen::ComputeFullV);
  const Eigen::Vector4d X = svd.matrixV().col(3);
  if (std::abs(X(3)) < 1e-12 * X.head<3>().norm()) return false;
  *xyz = X.head<3>() / X(3);
  return xyz->allFinite();
}

void TriangulationOptions::Check() const {
  if (!(max_reproj_error > 0)) {
    throw OptionError(&max_reproj_error, "Triangulation.max_reproj_error",
                      "must be positive");
  }
  if (!(min_tri_angle >= 0 && min_tri_angle < 180)) {
    throw OptionError(&min_tri_angle, "Triangulation.min_tri_angle",
                      "must be in [0, 180)");
  }
  if (max_num_trials < 1)
    throw OptionError(&max_num_trials, "TriangulationOptions::max_num_trials",
                      "must be positive");
  if (max_points_per_track < 1) {
    throw OptionError(&max_points_per_track,
                      "TriangulationOptions::max_points_per_track",
                      "must be positive");
  }
}

TriangulationSummary TriangulateTracks(const TriangulationOptions& options,
                                       const std::vector<Track>& tracks,
                                       Reconstruction* reconstruction,
                                       const KeypointScaleNoise* noise) {
  options.Check();
  TriangulationSummary summary;
  std::mt19937_64 rng(options.random_seed);
  const double min_angle_cos = std::cos(DegToRad(options.min_tri_angle));
  std::map<image_t, Eigen::Vector3d> centers;
  for (const auto& [image_id, image] : reconstruction->images) {
    centers[image_id] = image.ProjectionCenter();
  }

  std::vector<Ray> rays;
  std::vector<point3D_t> track_points;
  for (const Track& track : tracks) {
    rays.clear();
    if (options.ignore_two_view_tracks && track.size() == 2) continue;
    track_points.clear();
    if (options.complete_tracks) {
      for (const TrackElement& element : track) {
        auto image_it = reconstruction->images.find(element.image_id);
        if (image_it == reconstruction->images.end()) continue;
        const point3D_t point3D_id =
            image_it->second.points2D.at(element.point2D_idx).point3D_id;
        if (point3D_id != kInvalidPoint3DId &&
            std::find(track_points.begin(), track_points.end(), point3D_id) ==
                track_points.end()) {
          track_points.push_back(point3D_id);
        }
      }
    }
    for (const TrackElement& element : track) {
      auto image_it = reconstruction->images.find(element.image_id);
      if (image_it == reconstruction->images.end()) continue;
      const Image& image = image_it->second;
      const Point2D& point2D = image.points2D.at(element.point2D_idx);
      if (point2D.point3D_id != kInvalidPoint3DId) continue;
      const double max_reproj_error =
          noise == nullptr
              ? options.max_reproj_error
              : options.max_reproj_error * noise->Factor(point2D.scale);
      if (!track_points.empty() &&
          CompleteTrack(track_points, element, max_reproj_error,
                        reconstruction)) {
        ++summary.num_observations_completed;
        continue;
      }
      Ray ray;
      ray.element = element;
      ray.image = &image;
      ray.camera = &reconstruction->cameras.at(image.camera_id);
      ray.xy = point2D.xy;
      ray.max_reproj_error = max_reproj_error;
      if (!ObservationRay(*ray.camera, image, point2D.xy, &ray.normalized,
                          &ray.direction)) {
        continue;
      }
      ray.focal = CameraMeanFocalLength(*ray.camera);
      ray.center = centers.at(element.image_id);
      rays.push_back(ray);
    }
    if (rays.size() < 2) continue;
    ++summary.num_tracks_tried;

    std::vector<int> remaining(rays.size());
    for (size_t r = 0; r < rays.size(); ++r) remaining[r] = r;
    for (int found = 0;
         found < options.max_points_per_track && remaining.size() >= 2;
         ++found) {
      // Candidate pairs.
      std::vector<std::pair<int, int>> pairs;
      const size_t n = remaining.size();
      if (n * (n - 1) / 2 <= static_cast<size_t>(options.max_num_trials)) {
        for (size_t a = 0; a < n; ++a) {
          for (size_t b = a + 1; b < n; ++b)
            pairs.emplace_back(remaining[a], remaining[b]);
        }
      } else {
        std::uniform_int_distribution<size_t> dist(0, n - 1);
        while (static_cast<int>(pairs.size()) < options.max_num_trials) {
          const size_t a = dist(rng), b = dist(rng);
          if (a != b) pairs.emplace_back(remaining[a], remaining[b]);
        }
      }
      std::vector<int> best_inliers;
      double best_error = 0;
      Eigen::Vector3d best_xyz;
      for (const auto& [a, b] : pairs) {
        if (rays[a].direction.dot(rays[b].direction) > min_angle_cos) continue;
        Eigen::Vector3d xyz;
        if (!TriangulateMidpoint({rays[a].center, rays[b].center},
                                 {rays[a].direction, rays[b].direction},
                                 &xyz)) {
          continue;
        }
        double error;
        std::vector<int> inliers = Inliers(rays, remaining, xyz, &error);
        if (inliers.size() > best_inliers.size() ||
            (inliers.size() == best_inliers.size() && error < best_error)) {
          best_inliers = std::move(inliers);
          best_error = error;
          best_xyz = xyz;
        }
      }
      if (best_inliers.size() < 2) break;
      // Least squares over the inliers, kept only if it keeps them all.
      std::vector<Eigen::Vector3d> inlier_centers, inlier_directions;
      for (int r : best_inliers) {
        inlier_centers.push_back(rays[r].center);
        inlier_directions.push_back(rays[r].direction);
      }
      Eigen::Vector3d refined;
      if (TriangulateMidpoint(inlier_centers, inlier_directions, &refined)) {
        RefinePoint(rays, best_inliers, &refined);
        double error;
        std::vector<int> inliers = Inliers(rays, remaining, refined, &error);
        if (inliers.size() >= best_inliers.size()) {
          best_inliers = std::move(inliers);
          best_xyz = refined;
        }
      }
      if (MaxAngleCos(rays, best_inliers, best_xyz) > min_angle_cos) break;
      std::vector<TrackElement> point_track;
      for (int r : best_inliers) point_track.push_back(rays[r].element);
      AddPoint3D(best_xyz, point_track, reconstruction);
      ++summary.num_points_added;
      summary.num_observations_added += point_track.size();
      std::vector<int> rest;
      std::set_difference(remaining.begin(), remaining.end(),
                          best_inliers.begin(), best_inliers.end(),
                          std::back_inserter(rest));
      remaining = std::move(rest);
    }
  }
  VLOG(1) << "Triangulation: " << summary.num_points_added << " points, "
          << summary.num_observations_added << " observations from "
          << summary.num_tracks_tried << " tracks; "
          << summary.num_observations_completed
          << " observations added to their track's point";
  return summary;
}

}  // namespace colmap_irav4
