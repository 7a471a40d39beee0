#include "colmap_irav4/pipeline/prior_fold.h"

#include <algorithm>
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

}  // namespace colmap_irav4
