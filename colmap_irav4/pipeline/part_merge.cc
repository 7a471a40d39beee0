#include "colmap_irav4/pipeline/part_merge.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <random>

#include <glog/logging.h>
#include <Eigen/Dense>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/scene/camera_models.h"
#include "colmap_irav4/scene/reconstruction_utils.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/union_find.h"

namespace colmap_irav4 {
namespace {

// The point closest (least squares) to the lines through `points` along
// the unit `rays` of `indices`; false when the rays are (near) parallel.
bool FitCenter(const std::vector<Eigen::Vector3d>& points,
               const std::vector<Eigen::Vector3d>& rays,
               const std::vector<int>& indices, Eigen::Vector3d* center) {
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
  Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
  for (const int k : indices) {
    const Eigen::Matrix3d P =
        Eigen::Matrix3d::Identity() - rays[k] * rays[k].transpose();
    A += P;
    rhs += P * points[k];
  }
  // Parallel rays leave the centre free along them: A is then singular.
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(A);
  if (!(eigen.eigenvalues()(0) > 1e-8 * eigen.eigenvalues()(2))) return false;
  *center = A.ldlt().solve(rhs);
  return center->allFinite();
}

// The indices of the points whose ray from `center` is within
// `max_angle_rad` of the measured one (in front of the camera).
std::vector<int> MetPoints(const std::vector<Eigen::Vector3d>& points,
                           const std::vector<Eigen::Vector3d>& rays,
                           const Eigen::Vector3d& center,
                           double max_angle_rad) {
  const double min_cos = std::cos(max_angle_rad);
  std::vector<int> met;
  for (size_t k = 0; k < points.size(); ++k) {
    const Eigen::Vector3d to_point = points[k] - center;
    const double norm = to_point.norm();
    if (norm > 0 && to_point.dot(rays[k]) >= min_cos * norm) {
      met.push_back(static_cast<int>(k));
    }
  }
  return met;
}

// Cam_b_from_cam_a of the pair oriented from `a`.
Eigen::Matrix3d RotationFrom(const ImagePairGeometry& pair, image_t a) {
  return pair.image_id1 == a ? pair.R : Eigen::Matrix3d(pair.R.transpose());
}

// Two checks hypothesise a join's similarity only when their placed
// centres lie apart by this many times their tolerances' sum: closer, the
// direction between them (what fixes the scale and tests the rotation) is
// within the centres' errors; at 2 the two checks' residuals bound the
// angle between their displacements in the two frames to 30 deg.
constexpr double kMinJoinBaseline = 2;

// The rotation J between the frames of parts part1 and part2 that a
// confirmed check gives: their corrections (PartMergePlan::correction)
// satisfy C_part2 = J * C_part1. The check places b: R_b(model) * C_b =
// R_b(check) * C_a.
Eigen::Matrix3d JoinRotation(const CrossPairCheck& check,
                             const Reconstruction& reconstruction, int part1,
                             int part2) {
  const Eigen::Matrix3d R_b_model =
      reconstruction.images.at(check.image_id_b)
          .cam_from_world.rotation.toRotationMatrix();
  const Eigen::Matrix3d b_from_a = R_b_model.transpose() * check.R_b;
  CHECK((check.part_a == part1 && check.part_b == part2) ||
        (check.part_a == part2 && check.part_b == part1));
  return check.part_a == part1 ? b_from_a
                               : Eigen::Matrix3d(b_from_a.transpose());
}

// Each image of `parts` (those in the model) -> its part.
std::map<image_t, int> PartOfImages(
    const Reconstruction& reconstruction,
    const std::vector<std::vector<image_t>>& parts) {
  std::map<image_t, int> part_of;
  for (int p = 0; p < static_cast<int>(parts.size()); ++p) {
    for (const image_t image_id : parts[p]) {
      if (reconstruction.images.count(image_id)) part_of[image_id] = p;
    }
  }
  return part_of;
}

// Whether images a and b lie in two different parts.
bool Across(const std::map<image_t, int>& part_of, image_t a, image_t b) {
  const auto part_a = part_of.find(a);
  const auto part_b = part_of.find(b);
  return part_a != part_of.end() && part_b != part_of.end() &&
         part_a->second != part_b->second;
}

// The pair's geometry in `by_pair` (null when it has none).
const TwoViewGeometry* FindGeometry(
    const std::map<image_pair_t, const TwoViewGeometry*>& by_pair,
    const ImagePairGeometry& pair) {
  const auto it =
      by_pair.find(ImagePairToPairId(pair.image_id1, pair.image_id2));
  return it == by_pair.end() ? nullptr : it->second;
}

// The geometries of the pairs across two parts, by pair id (only those are
// looked up; the database holds every pair).
std::map<image_pair_t, const TwoViewGeometry*> GeometriesAcross(
    const std::map<image_t, int>& part_of,
    const std::vector<TwoViewGeometry>& geometries) {
  std::map<image_pair_t, const TwoViewGeometry*> by_pair;
  for (const TwoViewGeometry& geometry : geometries) {
    if (!Across(part_of, geometry.image_id1, geometry.image_id2)) continue;
    by_pair[ImagePairToPairId(geometry.image_id1, geometry.image_id2)] =
        &geometry;
  }
  return by_pair;
}

// Joins the observations (image1, idx1) and (image2, idx2) into one point,
// as track building joins a match: a keypoint without a point joins the
// other's point; two points become one (at most one observation per image
// kept); two keypoints without points make a new point.
void JoinObservations(image_t image_id1, point2D_t idx1, image_t image_id2,
                      point2D_t idx2, Reconstruction* reconstruction) {
  std::vector<Point2D>& points1 = reconstruction->images.at(image_id1).points2D;
  std::vector<Point2D>& points2 = reconstruction->images.at(image_id2).points2D;
  if (idx1 >= points1.size() || idx2 >= points2.size()) return;
  point3D_t id1 = points1[idx1].point3D_id;
  point3D_t id2 = points2[idx2].point3D_id;
  if (id1 == kInvalidPoint3DId && id2 == kInvalidPoint3DId) {
    AddPoint3D(Eigen::Vector3d::Zero(), {{image_id1, idx1}, {image_id2, idx2}},
               reconstruction);
    return;
  }
  if (id1 == id2) return;
  std::vector<TrackElement> added;
  if (id1 == kInvalidPoint3DId) {
    std::swap(id1, id2);
    added.push_back({image_id1, idx1});
  } else if (id2 == kInvalidPoint3DId) {
    added.push_back({image_id2, idx2});
  } else {
    // The larger track absorbs the smaller one.
    if (reconstruction->points3D.at(id1).track.size() <
        reconstruction->points3D.at(id2).track.size()) {
      std::swap(id1, id2);
    }
    added = std::move(reconstruction->points3D.at(id2).track);
    reconstruction->points3D.erase(id2);
  }
  std::vector<TrackElement>& track = reconstruction->points3D.at(id1).track;
  for (const TrackElement& element : added) {
    const bool seen = std::any_of(track.begin(), track.end(),
                                  [&element](const TrackElement& other) {
                                    return other.image_id == element.image_id;
                                  });
    reconstruction->images.at(element.image_id)
        .points2D[element.point2D_idx]
        .point3D_id = seen ? kInvalidPoint3DId : id1;
    if (!seen) track.push_back(element);
  }
}

// The agreeing set of the confirmed checks `indices` (into `checks`)
// between parts part1 < part2: the checks one similarity between the parts
// explains, x2 = s J x1 + t (J within the spread of the checks' rotations,
// b's placed centre within max_join_center_error of its distance to its
// met points), hypothesised from two checks placing images in one
// direction, apart (else they fix no scale); the set gathering most
// distinct pairs (ties: most met points). A ghost pose gives its own
// rotation and centre: two false pairs seldom agree on both. Checks placing
// one image agree when their centres and rotations do. Returns indices into
// `checks`; *num_agreeing is the set's number of distinct pairs.
std::vector<int> AgreeingChecks(const PartMergeOptions& options,
                                const Reconstruction& reconstruction,
                                const std::vector<CrossPairCheck>& checks,
                                const std::vector<int>& indices, int part1,
                                int part2, int* num_agreeing) {
  *num_agreeing = 0;
  const int n = static_cast<int>(indices.size());
  std::vector<Eigen::Matrix3d> rotations(n);
  std::vector<Eigen::Vector3d> placed(n), model(n);
  std::vector<double> tolerance(n);
  std::vector<bool> forward(n);  // b placed in part2 from part1's points
  for (int i = 0; i < n; ++i) {
    const CrossPairCheck& check = checks[indices[i]];
    rotations[i] = JoinRotation(check, reconstruction, part1, part2);
    placed[i] = check.center_b;
    model[i] = reconstruction.images.at(check.image_id_b).ProjectionCenter();
    double depth = 0;
    for (const point3D_t id : check.met_point_ids) {
      depth += (reconstruction.points3D.at(id).xyz - check.center_b).norm();
    }
    tolerance[i] = options.max_join_center_error * depth /
                   std::max<size_t>(check.met_point_ids.size(), 1);
    forward[i] = check.part_a == part1;
  }
  const auto pair_of = [&](int i) {
    const CrossPairCheck& check = checks[indices[i]];
    return std::minmax(check.image_id_a, check.image_id_b);
  };
  std::vector<int> agreeing;
  int most_met = -1;
  const auto consider = [&](const std::vector<int>& members) {
    std::set<std::pair<image_t, image_t>> member_pairs;
    int met = 0;
    for (const int i : members) {
      member_pairs.insert(pair_of(i));
      met += checks[indices[i]].num_met;
    }
    const int num = static_cast<int>(member_pairs.size());
    if (num > *num_agreeing || (num == *num_agreeing && met > most_met)) {
      *num_agreeing = num;
      most_met = met;
      agreeing.clear();
      for (const int i : members) agreeing.push_back(indices[i]);
    }
  };
  for (int i = 0; i < n; ++i) {
    // Checks placing the same image (which fixes no scale): its placed
    // centres and rotations must agree.
    std::vector<int> same_image = {i};
    const CrossPairCheck& check_i = checks[indices[i]];
    for (int k = 0; k < n; ++k) {
      const CrossPairCheck& check_k = checks[indices[k]];
      if (k != i && check_k.image_id_b == check_i.image_id_b &&
          AngularDistanceDeg(rotations[i], rotations[k]) <=
              options.max_join_spread_deg &&
          (placed[k] - placed[i]).norm() <= tolerance[i] + tolerance[k]) {
        same_image.push_back(k);
      }
    }
    consider(same_image);
  }
  // The two-check hypotheses: checks placing images in one direction,
  // of two pairs, agreeing on the rotation, placed apart; at most
  // max_ransac_samples of them (random ones, seeded by the parts).
  std::vector<std::pair<int, int>> hypotheses;
  for (int i = 0; i < n; ++i) {
    for (int j = i + 1; j < n; ++j) {
      if (forward[i] == forward[j] && pair_of(i) != pair_of(j) &&
          AngularDistanceDeg(rotations[i], rotations[j]) <=
              options.max_join_spread_deg &&
          (placed[j] - placed[i]).norm() >
              kMinJoinBaseline * (tolerance[i] + tolerance[j])) {
        hypotheses.emplace_back(i, j);
      }
    }
  }
  if (static_cast<int>(hypotheses.size()) > options.max_ransac_samples) {
    std::mt19937 random(static_cast<uint32_t>(part1 * 7919 + part2));
    std::shuffle(hypotheses.begin(), hypotheses.end(), random);
    hypotheses.resize(options.max_ransac_samples);
  }
  for (const auto& [i, j] : hypotheses) {
    // (x1, x2) of i and j: the placed centre in its part's frame, the
    // model's in the other's.
    const Eigen::Vector3d& x1_i = forward[i] ? placed[i] : model[i];
    const Eigen::Vector3d& x1_j = forward[i] ? placed[j] : model[j];
    const Eigen::Vector3d& x2_i = forward[i] ? model[i] : placed[i];
    const Eigen::Vector3d& x2_j = forward[i] ? model[j] : placed[j];
    const Eigen::Matrix3d& J = rotations[i];
    const Eigen::Vector3d d1 = J * (x1_j - x1_i);
    const double scale = (x2_j - x2_i).dot(d1) / d1.squaredNorm();
    if (!(scale > 0) || !std::isfinite(scale)) continue;
    const Eigen::Vector3d t =
        0.5 * (x2_i + x2_j) - scale * J * (0.5 * (x1_i + x1_j));
    std::vector<int> members;
    for (int k = 0; k < n; ++k) {
      if (AngularDistanceDeg(J, rotations[k]) > options.max_join_spread_deg) {
        continue;
      }
      // b's centre predicted in the frame it was placed in.
      const Eigen::Vector3d predicted =
          forward[k] ? Eigen::Vector3d(J.transpose() * (model[k] - t) / scale)
                     : Eigen::Vector3d(scale * J * model[k] + t);
      if ((placed[k] - predicted).norm() <= tolerance[k]) {
        members.push_back(k);
      }
    }
    consider(members);
  }
  return agreeing;
}

}  // namespace

void PartMergeOptions::Check() const {
  if (!(max_ray_error_deg > 0 && max_ray_error_deg < 90)) {
    throw OptionError(&max_ray_error_deg, "PartMerge.max_ray_error_deg",
                      "must be in (0, 90)");
  }
  if (!(max_join_turn_deg > 0 && max_join_turn_deg <= 180)) {
    throw OptionError(&max_join_turn_deg, "PartMerge.max_join_turn_deg",
                      "must be in (0, 180]");
  }
  if (min_met_points < 2) {
    throw OptionError(&min_met_points, "PartMerge.min_met_points",
                      "must be >= 2 (two rays always meet a centre)");
  }
  if (!(min_met_fraction >= 0 && min_met_fraction <= 1)) {
    throw OptionError(&min_met_fraction, "PartMerge.min_met_fraction",
                      "must be in [0, 1]");
  }
  if (min_join_pairs < 1) {
    throw OptionError(&min_join_pairs, "PartMerge.min_join_pairs",
                      "must be >= 1");
  }
  if (!(max_join_center_error > 0)) {
    throw OptionError(&max_join_center_error, "PartMerge.max_join_center_error",
                      "must be > 0");
  }
  if (!(max_join_spread_deg > 0 && max_join_spread_deg <= 180)) {
    throw OptionError(&max_join_spread_deg, "PartMerge.max_join_spread_deg",
                      "must be in (0, 180]");
  }
  if (!(max_rotation_error_deg > 0 && max_rotation_error_deg <= 180)) {
    throw OptionError(&max_rotation_error_deg,
                      "PartMerge.max_rotation_error_deg",
                      "must be in (0, 180]");
  }
  if (max_rounds < 1) {
    throw OptionError(&max_rounds, "PartMerge.max_rounds", "must be >= 1");
  }
  if (!(min_image_fraction >= 0 && min_image_fraction <= 1)) {
    throw OptionError(&min_image_fraction, "PartMerge.min_image_fraction",
                      "must be in [0, 1]");
  }
  if (max_ransac_samples < 1) {
    throw OptionError(&max_ransac_samples, "PartMerge.max_ransac_samples",
                      "must be >= 1");
  }
}

CrossPairCheck CheckCrossPair(
    const PartMergeOptions& options, const Reconstruction& reconstruction,
    const std::set<image_t>& part_a, image_t image_id_a, image_t image_id_b,
    const Eigen::Matrix3d& R_ab,
    const std::vector<std::pair<point2D_t, point2D_t>>& matches) {
  CrossPairCheck check;
  check.image_id_a = image_id_a;
  check.image_id_b = image_id_b;
  const Image& image_a = reconstruction.images.at(image_id_a);
  const Image& image_b = reconstruction.images.at(image_id_b);
  const Camera& camera_b = reconstruction.cameras.at(image_b.camera_id);
  check.R_b = R_ab * image_a.cam_from_world.rotation.toRotationMatrix();
  const Eigen::Matrix3d world_from_cam_b = check.R_b.transpose();
  // The points of part A (seen by two of its images: placed by the part
  // itself) at a's matched keypoints, and b's rays to them in A's frame.
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector3d> rays;
  std::vector<point3D_t> point_ids;
  std::set<point3D_t> used;
  for (const auto& [idx_a, idx_b] : matches) {
    if (idx_a >= image_a.points2D.size() || idx_b >= image_b.points2D.size()) {
      continue;
    }
    const point3D_t point3D_id = image_a.points2D[idx_a].point3D_id;
    if (point3D_id == kInvalidPoint3DId || !used.insert(point3D_id).second) {
      continue;
    }
    const Point3D& point = reconstruction.points3D.at(point3D_id);
    int num_in_part = 0;
    for (const TrackElement& element : point.track) {
      num_in_part += part_a.count(element.image_id) ? 1 : 0;
    }
    if (num_in_part < 2) continue;
    const Eigen::Vector3d ray =
        CameraImageToRay(camera_b, image_b.points2D[idx_b].xy);
    if (!ray.allFinite() || !(ray.norm() > 0)) continue;
    points.push_back(point.xyz);
    point_ids.push_back(point3D_id);
    rays.push_back((world_from_cam_b * ray).normalized());
  }
  const int n = static_cast<int>(points.size());
  check.num_points = n;
  if (n < 2) return check;
  const double max_angle = options.max_ray_error_deg * kPi / 180;
  // RANSAC over 2-point sets: every set when few, else random ones (seeded
  // by the pair: the same model gives the same answer).
  std::vector<std::pair<int, int>> samples;
  const long long num_sets = static_cast<long long>(n) * (n - 1) / 2;
  if (num_sets <= options.max_ransac_samples) {
    for (int i = 0; i < n; ++i) {
      for (int j = i + 1; j < n; ++j) samples.emplace_back(i, j);
    }
  } else {
    std::mt19937 random(static_cast<uint32_t>(image_id_a * 7919u + image_id_b));
    std::uniform_int_distribution<int> pick(0, n - 1);
    while (static_cast<int>(samples.size()) < options.max_ransac_samples) {
      const int i = pick(random);
      const int j = pick(random);
      if (i != j) samples.emplace_back(i, j);
    }
  }
  std::vector<int> best;
  Eigen::Vector3d best_center = Eigen::Vector3d::Zero();
  for (const auto& [i, j] : samples) {
    Eigen::Vector3d center;
    if (!FitCenter(points, rays, {i, j}, &center)) continue;
    std::vector<int> met = MetPoints(points, rays, center, max_angle);
    if (met.size() > best.size()) {
      best = std::move(met);
      best_center = center;
    }
  }
  // Refit on the inliers while that meets more points.
  for (int iteration = 0; iteration < 5 && best.size() >= 2; ++iteration) {
    Eigen::Vector3d center;
    if (!FitCenter(points, rays, best, &center)) break;
    std::vector<int> met = MetPoints(points, rays, center, max_angle);
    if (met.size() < best.size()) break;
    const bool grew = met.size() > best.size();
    best = std::move(met);
    best_center = center;
    if (!grew) break;
  }
  check.num_met = static_cast<int>(best.size());
  for (const int k : best) check.met_point_ids.push_back(point_ids[k]);
  check.center_b = best_center;
  check.confirmed = check.num_met >= options.min_met_points &&
                    check.num_met >= options.min_met_fraction * n;
  return check;
}

PartMergePlan PlanPartMerge(const PartMergeOptions& options,
                            const Reconstruction& reconstruction,
                            const std::vector<std::vector<image_t>>& parts,
                            const std::vector<ImagePairGeometry>& pairs,
                            const std::vector<TwoViewGeometry>& geometries) {
  PartMergePlan plan;
  const int num_parts = static_cast<int>(parts.size());
  plan.num_parts = num_parts;
  const std::map<image_t, int> part_of = PartOfImages(reconstruction, parts);
  std::vector<std::set<image_t>> part_sets(num_parts);
  for (const auto& [image_id, p] : part_of) part_sets[p].insert(image_id);
  for (int p = 0; p < num_parts; ++p) {
    plan.part_sizes.push_back(part_sets[p].size());
  }
  const std::map<image_pair_t, const TwoViewGeometry*> by_pair =
      GeometriesAcross(part_of, geometries);
  // Each pair across parts, both directions.
  std::vector<const ImagePairGeometry*> across;
  for (const ImagePairGeometry& pair : pairs) {
    if (!Across(part_of, pair.image_id1, pair.image_id2)) continue;
    across.push_back(&pair);
    const TwoViewGeometry* geometry = FindGeometry(by_pair, pair);
    if (geometry == nullptr) continue;
    const TwoViewGeometry& g = *geometry;
    bool confirmed = false;
    bool testable = false;  // some direction has enough points to test
    bool met_enough = false;
    for (const image_t a : {pair.image_id1, pair.image_id2}) {
      const image_t b = a == pair.image_id1 ? pair.image_id2 : pair.image_id1;
      std::vector<std::pair<point2D_t, point2D_t>> matches;
      matches.reserve(g.inlier_matches.size());
      for (const FeatureMatch& match : g.inlier_matches) {
        matches.emplace_back(
            g.image_id1 == a ? match.point2D_idx1 : match.point2D_idx2,
            g.image_id1 == a ? match.point2D_idx2 : match.point2D_idx1);
      }
      CrossPairCheck check =
          CheckCrossPair(options, reconstruction, part_sets[part_of.at(a)], a,
                         b, RotationFrom(pair, a), matches);
      check.part_a = part_of.at(a);
      check.part_b = part_of.at(b);
      confirmed = confirmed || check.confirmed;
      testable = testable || check.num_points >= options.min_met_points;
      met_enough = met_enough || (check.num_points > 0 &&
                                  check.num_met >= options.min_met_fraction *
                                                       check.num_points);
      plan.checks.push_back(check);
    }
    plan.num_confirmed += confirmed ? 1 : 0;
    if (!confirmed && testable && !met_enough) {
      plan.refuted.insert(std::minmax(pair.image_id1, pair.image_id2));
    }
  }
  plan.num_pairs_across = static_cast<int>(across.size());
  // The joins: per pair of parts, the confirmed checks between them, and
  // the most of them (distinct pairs) that one similarity explains.
  std::map<std::pair<int, int>, std::vector<int>> checks_by_parts;
  for (size_t k = 0; k < plan.checks.size(); ++k) {
    const CrossPairCheck& check = plan.checks[k];
    if (!check.confirmed) continue;
    checks_by_parts[std::minmax(check.part_a, check.part_b)].push_back(
        static_cast<int>(k));
  }
  for (const auto& [parts_key, checks] : checks_by_parts) {
    PartJoin join;
    join.part1 = parts_key.first;
    join.part2 = parts_key.second;
    std::set<std::pair<image_t, image_t>> pair_ids;
    for (const int k : checks) {
      const CrossPairCheck& check = plan.checks[k];
      pair_ids.insert(std::minmax(check.image_id_a, check.image_id_b));
    }
    join.num_pairs = static_cast<int>(pair_ids.size());
    std::vector<int> agreeing =
        AgreeingChecks(options, reconstruction, plan.checks, checks, join.part1,
                       join.part2, &join.num_agreeing);
    join.agreed = join.num_agreeing >= options.min_join_pairs;
    std::set<point3D_t> met_in_part1;
    std::set<point3D_t> met_in_part2;
    for (const int k : agreeing) {
      const CrossPairCheck& check = plan.checks[k];
      std::set<point3D_t>& met =
          check.part_a == join.part1 ? met_in_part1 : met_in_part2;
      met.insert(check.met_point_ids.begin(), check.met_point_ids.end());
      if (join.best_check < 0 ||
          check.num_met > plan.checks[join.best_check].num_met) {
        join.best_check = k;
      }
    }
    join.num_points =
        static_cast<int>(std::max(met_in_part1.size(), met_in_part2.size()));
    plan.joins.push_back(join);
  }
  std::stable_sort(plan.joins.begin(), plan.joins.end(),
                   [](const PartJoin& x, const PartJoin& y) {
                     if (x.agreed != y.agreed) return x.agreed;
                     return x.num_points > y.num_points;
                   });
  // The join: a spanning tree of the parts over the agreed joins, most met
  // points first.
  UnionFind union_find(num_parts);
  std::vector<std::vector<const CrossPairCheck*>> tree(num_parts);
  for (const PartJoin& join : plan.joins) {
    if (!join.agreed) continue;
    const CrossPairCheck* check = &plan.checks[join.best_check];
    if (union_find.Union(check->part_a, check->part_b)) {
      tree[check->part_a].push_back(check);
      tree[check->part_b].push_back(check);
    }
  }
  // Corrections from each group's first part (kept as it is) outwards:
  // a tree edge says R_b(model) * C_B = R_b(check) * C_A.
  plan.group.assign(num_parts, -1);
  plan.correction.assign(num_parts, Eigen::Matrix3d::Identity());
  for (int root = 0; root < num_parts; ++root) {
    if (plan.group[root] >= 0) continue;
    ++plan.num_groups;
    plan.group[root] = root;
    std::vector<int> stack = {root};
    while (!stack.empty()) {
      const int p = stack.back();
      stack.pop_back();
      for (const CrossPairCheck* check : tree[p]) {
        const int q = check->part_a == p ? check->part_b : check->part_a;
        if (plan.group[q] >= 0) continue;
        plan.group[q] = root;
        const Eigen::Matrix3d R_b_model =
            reconstruction.images.at(check->image_id_b)
                .cam_from_world.rotation.toRotationMatrix();
        plan.correction[q] =
            check->part_a == p
                ? Eigen::Matrix3d(R_b_model.transpose() * check->R_b *
                                  plan.correction[p])
                : Eigen::Matrix3d(check->R_b.transpose() * R_b_model *
                                  plan.correction[p]);
        stack.push_back(q);
      }
    }
  }
  // Pairs across parts of one group that the joined rotations contradict.
  for (const ImagePairGeometry* pair : across) {
    const int p1 = part_of.at(pair->image_id1);
    const int p2 = part_of.at(pair->image_id2);
    if (plan.group[p1] != plan.group[p2]) continue;
    const Eigen::Matrix3d R1 = reconstruction.images.at(pair->image_id1)
                                   .cam_from_world.rotation.toRotationMatrix() *
                               plan.correction[p1];
    const Eigen::Matrix3d R2 = reconstruction.images.at(pair->image_id2)
                                   .cam_from_world.rotation.toRotationMatrix() *
                               plan.correction[p2];
    if (RelativeRotationErrorDeg(*pair, R1, R2) >
        options.max_rotation_error_deg) {
      plan.contradicted.insert(std::minmax(pair->image_id1, pair->image_id2));
    }
  }
  return plan;
}

std::vector<double> JoinTurnsDeg(
    const PartMergePlan& plan, const Reconstruction& reconstruction,
    const std::vector<std::vector<image_t>>& parts,
    const std::map<image_t, Eigen::Matrix3d>& rotations) {
  const int num_parts = static_cast<int>(parts.size());
  // Each part's frame change: new = model x correction x change.
  std::vector<Eigen::Matrix3d> change(num_parts, Eigen::Matrix3d::Identity());
  std::vector<bool> has_change(num_parts, false);
  for (int p = 0; p < num_parts; ++p) {
    Eigen::Matrix3d sum = Eigen::Matrix3d::Zero();
    for (const image_t image_id : parts[p]) {
      const auto image = reconstruction.images.find(image_id);
      const auto rotation = rotations.find(image_id);
      if (image == reconstruction.images.end() || rotation == rotations.end()) {
        continue;
      }
      const Eigen::Matrix3d corrected =
          image->second.cam_from_world.rotation.toRotationMatrix() *
          plan.correction[p];
      sum += corrected.transpose() * rotation->second;
      has_change[p] = true;
    }
    if (!has_change[p]) continue;
    // The rotation nearest the sum (chordal L2 mean).
    change[p] = ProjectToRotation(sum);
  }
  std::vector<double> turns(num_parts, 0.0);
  for (int p = 0; p < num_parts; ++p) {
    const int root = plan.group[p];
    if (root == p) continue;
    if (!has_change[p] || !has_change[root]) {
      turns[p] = 180;
      continue;
    }
    turns[p] = AngularDistanceDeg(change[root], change[p]);
  }
  return turns;
}

ModelRigidity JoinedRigidity(const Reconstruction& reconstruction,
                             const std::vector<std::vector<image_t>>& parts,
                             const std::vector<ImagePairGeometry>& pairs,
                             const std::vector<TwoViewGeometry>& geometries,
                             int min_model_size) {
  Reconstruction joined = reconstruction;
  const std::map<image_t, int> part_of = PartOfImages(reconstruction, parts);
  const std::map<image_pair_t, const TwoViewGeometry*> by_pair =
      GeometriesAcross(part_of, geometries);
  for (const ImagePairGeometry& pair : pairs) {
    if (!Across(part_of, pair.image_id1, pair.image_id2)) continue;
    const TwoViewGeometry* geometry = FindGeometry(by_pair, pair);
    if (geometry == nullptr) continue;
    const TwoViewGeometry& g = *geometry;
    for (const FeatureMatch& match : g.inlier_matches) {
      JoinObservations(g.image_id1, match.point2D_idx1, g.image_id2,
                       match.point2D_idx2, &joined);
    }
  }
  return AnalyzeModelRigidity(ModelRigidityOptions(), joined, min_model_size);
}

int NumLargeGroupsKept(const PartMergePlan& plan,
                       const std::vector<double>& turns, double max_turn_deg,
                       int min_size) {
  std::map<int, size_t> group_sizes;
  for (int p = 0; p < plan.num_parts; ++p) {
    const bool kept = plan.group[p] != p && turns[p] <= max_turn_deg;
    group_sizes[kept ? plan.group[p] : p] += plan.part_sizes[p];
  }
  int num_large = 0;
  for (const auto& [group, size] : group_sizes) {
    num_large += static_cast<int>(size) >= min_size ? 1 : 0;
  }
  return num_large;
}

}  // namespace colmap_irav4
