#include "colmap_irav4/pipeline/prior_fold.h"

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/refinement/triangulation.h"

namespace colmap_irav4 {

std::string PriorAgreement::Describe() const {
  std::ostringstream line;
  line.setf(std::ios::fixed);
  line.precision(1);
  line << num_within << " of " << num_priors
       << " position priors within 3 std, capped cost " << capped_cost;
  return line.str();
}

PriorAgreement MeasurePriorAgreement(const Reconstruction& reconstruction,
                                     const PosePriors& priors,
                                     const PosePriorOptions& options) {
  PriorAgreement agreement;
  for (const auto& [image_id, image] : reconstruction.images) {
    const auto it = priors.find(image_id);
    if (it == priors.end() || !it->second.HasPosition()) continue;
    const double r = (PositionPriorSqrtInformation(it->second, options) *
                      (image.ProjectionCenter() - it->second.position))
                         .norm();
    agreement.Add(image_id, r);
  }
  return agreement;
}

void PriorAgreement::Add(image_t image_id, double r) {
  residuals[image_id] = r;
  ++num_priors;
  num_within += r < 3.0;
  capped_cost += std::min(r * r, 9.0);
}

bool PriorsAgreeBetter(const PriorAgreement& before,
                       const PriorAgreement& after) {
  // A model placed from the same priors on the same images: with no fold in
  // either, the two costs differ by the shape's small changes (a few units
  // on 100 priors). A fold undone moves every camera of the turned group by
  // metres: the cost falls by several units per turned camera. A quarter of
  // the cost is far above the first and far below the second (the tower and
  // courtyard folds of docs/notes/2026-12-03-priors-components-and-folds.md
  // lose more than half). The re-mapped model must also keep the priors'
  // inliers (no fewer within 3 std) and every image with a prior.
  if (after.num_priors < before.num_priors) return false;
  if (after.num_within < before.num_within) return false;
  return after.capped_cost < 0.75 * before.capped_cost;
}

std::vector<image_t> PriorOutlierGroups(
    const PriorAgreement& agreement,
    const std::vector<ImagePairGeometry>& pairs, int min_group_size) {
  std::set<image_t> outliers;
  for (const auto& [image_id, r] : agreement.residuals) {
    if (r >= 3.0) outliers.insert(image_id);
  }
  const size_t min_size =
      std::max<size_t>(static_cast<size_t>(std::max(min_group_size, 1)),
                       static_cast<size_t>(0.1 * agreement.num_priors + 0.5));
  std::vector<image_t> group;
  for (const std::vector<image_t>& component :
       PairComponents(PairsWithin(pairs, outliers))) {
    if (component.size() < min_size) break;  // largest first
    group.insert(group.end(), component.begin(), component.end());
  }
  std::sort(group.begin(), group.end());
  return group;
}

namespace {

// The prior covariance of an image (the stored one, or position_std^2 I).
Eigen::Matrix3d PriorCovariance(const PosePrior& prior,
                                const PosePriorOptions& options) {
  if (prior.HasPositionCovariance()) return prior.position_covariance;
  return Eigen::Matrix3d::Identity() * options.position_std *
         options.position_std;
}

double Median(std::vector<double> values) {
  std::nth_element(values.begin(), values.begin() + values.size() / 2,
                   values.end());
  return values[values.size() / 2];
}

}  // namespace

double PriorPairContrast(const Reconstruction& reconstruction,
                         const PosePriors& priors,
                         const PosePriorOptions& options,
                         const std::vector<ImagePairGeometry>& pairs,
                         const std::vector<image_t>& side) {
  const std::set<image_t> in_side(side.begin(), side.end());
  std::vector<double> across, within;
  for (const ImagePairGeometry& pair : pairs) {
    const auto image1 = reconstruction.images.find(pair.image_id1);
    const auto image2 = reconstruction.images.find(pair.image_id2);
    const auto prior1 = priors.find(pair.image_id1);
    const auto prior2 = priors.find(pair.image_id2);
    if (image1 == reconstruction.images.end() ||
        image2 == reconstruction.images.end() || prior1 == priors.end() ||
        prior2 == priors.end() || !prior1->second.HasPosition() ||
        !prior2->second.HasPosition()) {
      continue;
    }
    const Eigen::Vector3d residual =
        (image2->second.ProjectionCenter() -
         image1->second.ProjectionCenter()) -
        (prior2->second.position - prior1->second.position);
    const Eigen::Matrix3d covariance =
        PriorCovariance(prior1->second, options) +
        PriorCovariance(prior2->second, options);
    const double r = std::sqrt(residual.dot(covariance.ldlt().solve(residual)));
    (in_side.count(pair.image_id1) != in_side.count(pair.image_id2) ? across
                                                                    : within)
        .push_back(r);
  }
  if (across.size() < 5 || within.size() < 5) return 0;
  const double median_within = Median(within);
  return median_within > 0 ? Median(across) / median_within : 0;
}

bool ContradictedByModel(const ImagePairGeometry& pair,
                         const Reconstruction& reconstruction,
                         double max_rotation_error_deg) {
  const auto image1 = reconstruction.images.find(pair.image_id1);
  const auto image2 = reconstruction.images.find(pair.image_id2);
  if (image1 == reconstruction.images.end() ||
      image2 == reconstruction.images.end()) {
    return false;
  }
  return RelativeRotationErrorDeg(
             pair, image1->second.cam_from_world.rotation.toRotationMatrix(),
             image2->second.cam_from_world.rotation.toRotationMatrix()) >
         max_rotation_error_deg;
}

TurnedBackPose TurnBackAlone(const Reconstruction& reconstruction,
                             const std::vector<ImagePairGeometry>& pairs,
                             image_t image_id, double max_rotation_error_deg) {
  TurnedBackPose turned;
  const auto image = reconstruction.images.find(image_id);
  if (image == reconstruction.images.end()) return turned;
  // Per pair the model contradicts: the camera's rotation it implies, the
  // neighbour's centre and the direction from it to the camera (world).
  struct Vote {
    const ImagePairGeometry* pair;
    Eigen::Matrix3d R;
    Eigen::Vector3d center;
    Eigen::Vector3d direction;
  };
  std::vector<Vote> votes;
  for (const ImagePairGeometry& pair : pairs) {
    if (pair.image_id1 != image_id && pair.image_id2 != image_id) continue;
    const bool first = pair.image_id1 == image_id;
    const auto other =
        reconstruction.images.find(first ? pair.image_id2 : pair.image_id1);
    if (other == reconstruction.images.end()) continue;
    if (!ContradictedByModel(pair, reconstruction, max_rotation_error_deg)) {
      turned.num_agreeing_inliers += pair.num_inliers;
      continue;  // the model agrees: not a vote to turn
    }
    if (pair.t.norm() == 0) continue;
    const Eigen::Matrix3d R_other =
        other->second.cam_from_world.rotation.toRotationMatrix();
    // pair.R = R2 R1^T and c2 - c1 along -R2^T t (cam2_from_cam1).
    const Eigen::Vector3d t = pair.t.normalized();
    Vote vote;
    vote.pair = &pair;
    if (first) {
      vote.R = pair.R.transpose() * R_other;
      vote.direction = R_other.transpose() * t;
    } else {
      vote.R = pair.R * R_other;
      vote.direction = -(R_other.transpose() * pair.R.transpose() * t);
    }
    vote.center = other->second.ProjectionCenter();
    votes.push_back(vote);
  }
  // The rotation most votes agree on.
  std::vector<size_t> best;
  for (size_t i = 0; i < votes.size(); ++i) {
    std::vector<size_t> agreeing;
    for (size_t j = 0; j < votes.size(); ++j) {
      if (AngularDistanceDeg(votes[i].R, votes[j].R) <=
          max_rotation_error_deg) {
        agreeing.push_back(j);
      }
    }
    if (agreeing.size() > best.size()) best = std::move(agreeing);
  }
  if (static_cast<int>(best.size()) < kMinTurnBackPairs) return turned;
  Eigen::Matrix3d sum = Eigen::Matrix3d::Zero();
  for (const size_t i : best) sum += votes[i].R;
  const Eigen::Matrix3d R = ProjectToRotation(sum);
  // The centre nearest the rays from the neighbours (least squares over the
  // distances to the rays), solved again without the rays it leaves more
  // than the rotation tolerance off.
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  std::vector<size_t> rays = best;
  for (int round = 0; round < 2; ++round) {
    if (static_cast<int>(rays.size()) < kMinTurnBackPairs) return turned;
    std::vector<Eigen::Vector3d> centers;
    std::vector<Eigen::Vector3d> directions;
    for (const size_t i : rays) {
      centers.push_back(votes[i].center);
      directions.push_back(votes[i].direction);
    }
    // Parallel rays (all neighbours on one line with the camera) leave the
    // centre free along them.
    if (!TriangulateMidpoint(centers, directions, &center,
                             /*min_relative_eigenvalue=*/1e-3)) {
      return turned;
    }
    std::vector<size_t> kept;
    for (const size_t i : rays) {
      const Eigen::Vector3d to_camera = center - votes[i].center;
      const double cosine = to_camera.normalized().dot(votes[i].direction);
      if (to_camera.norm() > 0 &&
          cosine >= std::cos(max_rotation_error_deg * M_PI / 180)) {
        kept.push_back(i);
      }
    }
    if (kept.size() == rays.size()) break;
    rays = std::move(kept);
  }
  if (static_cast<int>(rays.size()) < kMinTurnBackPairs) return turned;
  turned.found = true;
  turned.cam_from_world.rotation = Eigen::Quaterniond(R);
  turned.cam_from_world.translation = -(R * center);
  for (const size_t i : best) turned.pairs.push_back(*votes[i].pair);
  return turned;
}

bool TurnedAloneByItsPairs(const Reconstruction& reconstruction,
                           const std::vector<ImagePairGeometry>& pairs,
                           image_t image_id, double max_rotation_error_deg) {
  const TurnedBackPose turned =
      TurnBackAlone(reconstruction, pairs, image_id, max_rotation_error_deg);
  if (!turned.found) return false;
  int64_t num_against = 0;
  for (const ImagePairGeometry& pair : turned.pairs) {
    num_against += pair.num_inliers;
  }
  return 2 * num_against >= turned.num_agreeing_inliers;
}

bool LoneTurnSettled(const PriorAgreement& before, const PriorAgreement& after,
                     const std::vector<image_t>& turned, double max_std) {
  const std::set<image_t> moved(turned.begin(), turned.end());
  for (const image_t image_id : turned) {
    const auto it = after.residuals.find(image_id);
    const auto was = before.residuals.find(image_id);
    if (it == after.residuals.end() || was == before.residuals.end() ||
        it->second >= std::min(max_std, 0.5 * was->second)) {
      return false;
    }
  }
  // The others: each side's priors without the turned cameras.
  auto others = [&moved](const PriorAgreement& agreement) {
    PriorAgreement rest;
    for (const auto& [image_id, r] : agreement.residuals) {
      if (!moved.count(image_id)) rest.Add(image_id, r);
    }
    return rest;
  };
  const PriorAgreement others_before = others(before);
  const PriorAgreement others_after = others(after);
  return others_after.num_priors >= others_before.num_priors &&
         others_after.num_within >= others_before.num_within &&
         others_after.capped_cost <= 1.1 * others_before.capped_cost;
}

std::string PriorSettledOutcome(size_t num_turned_back, size_t num_removed,
                                size_t num_alone_removed,
                                size_t num_alone_restored,
                                size_t num_lone_turned) {
  std::string outcome =
      "resolved by pose priors (" + std::to_string(num_turned_back) +
      " images turned back, " + std::to_string(num_removed) + " pairs removed)";
  if (num_alone_removed > 0 || num_alone_restored > 0) {
    outcome += ", cameras turned alone re-oriented (" +
               std::to_string(num_alone_removed) + " pairs at them removed, " +
               std::to_string(num_alone_restored) + " restored)";
  }
  if (num_lone_turned > 0) {
    outcome += ", " + std::to_string(num_lone_turned) +
               " cameras turned alone turned back to their priors";
  }
  return outcome;
}

}  // namespace colmap_irav4
