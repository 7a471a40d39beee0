#include "colmap_irav4/pipeline/prior_fold.h"

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>

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
    agreement.residuals[image_id] = r;
    ++agreement.num_priors;
    agreement.num_within += r < 3.0;
    agreement.capped_cost += std::min(r * r, 9.0);
  }
  return agreement;
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

std::string PriorSettledOutcome(size_t num_turned_back, size_t num_removed,
                                size_t num_alone_removed,
                                size_t num_alone_restored) {
  std::string outcome =
      "resolved by pose priors (" + std::to_string(num_turned_back) +
      " images turned back, " + std::to_string(num_removed) + " pairs removed)";
  if (num_alone_removed > 0 || num_alone_restored > 0) {
    outcome += ", cameras turned alone re-oriented (" +
               std::to_string(num_alone_removed) + " pairs at them removed, " +
               std::to_string(num_alone_restored) + " restored)";
  }
  return outcome;
}

}  // namespace colmap_irav4
