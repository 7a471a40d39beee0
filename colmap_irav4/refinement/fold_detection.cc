#include "colmap_irav4/refinement/fold_detection.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <set>
#include <sstream>
#include <tuple>

#include <glog/logging.h>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/refinement/model_rigidity.h"
#include "colmap_irav4/scene/camera_models.h"
#include "colmap_irav4/scene/reconstruction_utils.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/statistics.h"
#include "colmap_irav4/util/union_find.h"

namespace colmap_irav4 {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

// The share of an image's points its depth range holds: not all, lest one
// far point (a false track triangulated far away) set it.
constexpr double kDepthRangeQuantile = 0.95;

// A registered image as the detector sees it.
struct View {
  image_t image_id = kInvalidImageId;
  const Camera* camera = nullptr;
  Eigen::Matrix3d R;  // cam_from_world
  Eigen::Vector3d t;
  Eigen::Vector3d center;
  Eigen::Vector3d axis;  // viewing direction in world coordinates
  std::vector<Eigen::Vector3d> points;  // sampled model points it observes
  int num_points = 0;                   // all the model points it observes
  // What the predicted overlap is scaled to: num_points, or the image's
  // observations in all the tracks (DetectFold's `tracks`).
  double num_scaled_points = 0;
  double radius = 0;  // largest distance from the centre to those points
  // Distance from the centre within which nearly all the model points it
  // observes lie (kDepthRangeQuantile).
  double depth_range = 0;
};

// Farthest that the centre of a camera expecting a point can be from the
// centre of the camera observing it, as a multiple of the observer's distance
// to the point: the two rays are at most the view angle apart and their
// lengths differ by at most the scale ratio, so the distance between the
// centres is at most max over t in [1/s, s] of sqrt(t^2 + 1 - 2 t cos a),
// reached at an end of the interval (the function is convex in t).
double MaxCenterDistanceFactor(double cos_max_angle, double max_scale_ratio) {
  double factor = 0;
  for (const double t : {max_scale_ratio, 1.0 / max_scale_ratio}) {
    factor = std::max(
        factor, std::sqrt(std::max(0.0, t * t + 1 - 2 * t * cos_max_angle)));
  }
  return factor;
}

// Whether `view` is expected to match the point X that `from` observes:
// in front, inside the image, from a similar direction and distance, and
// (max_depth > 0) no farther from it than max_depth.
// *cos_angle: the cosine of the angle between the two rays, and
// *log_scale: |log| of the ratio of their lengths, where expected.
bool ExpectsPoint(const View& view, const Eigen::Vector3d& from_center,
                  const Eigen::Vector3d& X, double cos_max_angle,
                  double max_scale_ratio, double max_depth, double* cos_angle,
                  double* log_scale) {
  const Eigen::Vector3d x = view.R * X + view.t;
  if (x.z() <= 0) return false;
  const Eigen::Vector3d ray_view = view.center - X;
  const Eigen::Vector3d ray_from = from_center - X;
  const double n_view = ray_view.norm();
  const double n_from = ray_from.norm();
  if (n_view <= 0 || n_from <= 0) return false;
  if (ray_view.dot(ray_from) < cos_max_angle * n_view * n_from) return false;
  if (n_view > max_scale_ratio * n_from || n_from > max_scale_ratio * n_view) {
    return false;
  }
  if (max_depth > 0 && n_view > max_depth) return false;
  *cos_angle = ray_view.dot(ray_from) / (n_view * n_from);
  *log_scale = std::abs(std::log(n_view / n_from));
  const Eigen::Vector2d pixel = CameraCameraToImage(
      *view.camera, Eigen::Vector2d(x.x() / x.z(), x.y() / x.z()));
  return pixel.allFinite() && pixel.x() >= 0 && pixel.y() >= 0 &&
         pixel.x() <= static_cast<double>(view.camera->width) &&
         pixel.y() <= static_cast<double>(view.camera->height);
}

std::pair<image_t, image_t> Ordered(image_t a, image_t b) {
  return a < b ? std::make_pair(a, b) : std::make_pair(b, a);
}

// The q-quantile of `values` (0 for none).
double Quantile(std::vector<double> values, double q) {
  if (values.empty()) return 0;
  const size_t k =
      std::min(values.size() - 1, static_cast<size_t>(q * values.size()));
  std::nth_element(values.begin(), values.begin() + k, values.end());
  return values[k];
}

// Bins of the rate model's two pair covariates (view angle, deg, and
// |log| of the distance ratio of the two cameras to the co-visible
// points) and the fewest pairs a bin or an image needs for an effect of
// its own.
constexpr double kAngleBinDeg = 5.0;
constexpr double kLogScaleBin = 0.1;
constexpr int kNumBins = 6;
constexpr int kMinBinPairs = 10;
constexpr int kMinImagePairs = 3;
// The fewest strong pairs that set an image's effect above its upper
// quartile (FitPairRates).
constexpr int kMinStrongPairs = 2;
// A bin's effect where fewer than a quarter of its predicted pairs matched:
// its pairs are not expected to match at all.
constexpr double kNoMatchEffect = -1e6;

int AngleBin(double angle_deg) {
  return std::clamp(static_cast<int>(angle_deg / kAngleBinDeg), 0,
                    kNumBins - 1);
}

int ScaleBin(double log_scale) {
  return std::clamp(static_cast<int>(log_scale / kLogScaleBin), 0,
                    kNumBins - 1);
}

// A predicted pair as the rate model sees it.
struct RatePair {
  int node1 = 0;
  int node2 = 0;
  double view_angle_deg = 0;
  double log_scale = 0;
  // log(inliers per predicted co-visible point); matched: it passed the
  // verification (else its ratio is unknown, below what would have).
  double log_ratio = 0;
  bool matched = false;
};

// The typical inliers per predicted co-visible point of a pair
// (weak_pair_rate_model): log ratio = image_effect[i] + image_effect[j] +
// angle_effect[angle bin] + scale_effect[scale bin]. Without the model, the
// typical ratio of all pairs.
struct RateModel {
  std::vector<double> image_effect;  // by node
  std::vector<double> angle_effect = std::vector<double>(kNumBins, 0.0);
  std::vector<double> scale_effect = std::vector<double>(kNumBins, 0.0);
  double typical = 0;  // > 0: the ratio of every pair (no model)
  // Median of the fitted pairs' log ratios less the model's (the model
  // follows upper quartiles; this brings it to the middle).
  double median_residual = 0;
  double Ratio(int i, int j, double angle_deg, double log_scale) const {
    if (typical > 0) return typical;
    const double bins =
        angle_effect[AngleBin(angle_deg)] + scale_effect[ScaleBin(log_scale)];
    if (bins <= kNoMatchEffect) return 0;
    return std::exp(image_effect[i] + image_effect[j] + bins);
  }
};

// Bin of each bin after merging those with fewer than kMinBinPairs pairs
// into their neighbour (towards the populated middle): downwards, then
// upwards.
std::vector<int> MergeSparseBins(std::vector<int> count) {
  std::vector<int> merged(kNumBins);
  for (int b = 0; b < kNumBins; ++b) merged[b] = b;
  auto move = [&](int from, int to) {
    count[to] += count[from];
    count[from] = 0;
    for (int& m : merged) {
      if (m == from) m = to;
    }
  };
  for (int b = kNumBins - 1; b > 0; --b) {
    if (count[b] < kMinBinPairs) move(b, b - 1);
  }
  for (int b = 0; b + 1 < kNumBins && count[b] < kMinBinPairs; ++b) {
    int next = b + 1;
    while (next < kNumBins && count[next] == 0) ++next;
    if (next == kNumBins) break;
    move(b, next);
  }
  return merged;
}

// The upper quartile of a bin's residuals, its unmatched pairs counted
// below every matched one: an upper quartile is known as long as at least
// a quarter of the pairs matched, however low the others fell (left
// censoring); kNoMatchEffect otherwise.
double CensoredUpperQuartile(const std::vector<double>& matched,
                             int num_unmatched) {
  const size_t total = matched.size() + static_cast<size_t>(num_unmatched);
  if (total == 0) return 0;
  const size_t k = std::min(total - 1, static_cast<size_t>(0.75 * total));
  if (k < static_cast<size_t>(num_unmatched)) return kNoMatchEffect;
  std::vector<double> values = matched;
  const size_t rank = k - static_cast<size_t>(num_unmatched);
  std::nth_element(values.begin(), values.begin() + rank, values.end());
  return values[rank];
}

// Fits the rate model to the predicted pairs' ratios by alternating upper
// quartiles of the residuals (robust to a minority of weak pairs at each
// image and in each bin; where false pairs are the majority the upper
// quartile still follows the true ones). The images' effects have median 0,
// so that an image with too few pairs for its own is judged as a typical
// one; bins with too few pairs share their neighbour's effect.
// The bins are shared by the whole model and see every predicted pair,
// matched or not: fitted to the matched pairs alone, a bin where most
// pairs fail the verification (wide angles, a large change of scale) keeps
// only its lucky pairs and expects the others to match as well. An
// image's own effect sees only its matched pairs: a camera a fold turned
// has its predicted pairs unmatched for the fold's reason, and counting
// them would explain the fold away.
RateModel FitPairRates(const std::vector<RatePair>& pairs, int num_nodes,
                       double weak_pair_ratio) {
  const int n = num_nodes;
  std::vector<int> angle_count(kNumBins, 0), scale_count(kNumBins, 0);
  for (const RatePair& pair : pairs) {
    ++angle_count[AngleBin(pair.view_angle_deg)];
    ++scale_count[ScaleBin(pair.log_scale)];
  }
  const std::vector<int> angle_merged = MergeSparseBins(angle_count);
  const std::vector<int> scale_merged = MergeSparseBins(scale_count);
  std::vector<int> angle_bin, scale_bin;  // by pair
  for (const RatePair& pair : pairs) {
    angle_bin.push_back(angle_merged[AngleBin(pair.view_angle_deg)]);
    scale_bin.push_back(scale_merged[ScaleBin(pair.log_scale)]);
  }
  RateModel model;
  model.image_effect.assign(n, 0.0);
  std::vector<double>& image_effect = model.image_effect;
  std::vector<double> angle_effect(kNumBins, 0.0);
  std::vector<double> scale_effect(kNumBins, 0.0);
  std::vector<std::vector<size_t>> image_pairs(n);
  for (size_t m = 0; m < pairs.size(); ++m) {
    if (!pairs[m].matched) continue;
    image_pairs[pairs[m].node1].push_back(m);
    image_pairs[pairs[m].node2].push_back(m);
  }
  auto bins_of = [&](size_t m) {
    return angle_effect[angle_bin[m]] + scale_effect[scale_bin[m]];
  };
  // One covariate's effects: the censored upper quartile of each bin's
  // residuals against everything else.
  auto fit_bins = [&](const std::vector<int>& bin, std::vector<double>* effect,
                      const std::vector<double>& other_effect,
                      const std::vector<int>& other_bin) {
    std::vector<std::vector<double>> residuals(kNumBins);
    std::vector<int> num_unmatched(kNumBins, 0);
    for (size_t m = 0; m < pairs.size(); ++m) {
      if (!pairs[m].matched) {
        ++num_unmatched[bin[m]];
      } else if (other_effect[other_bin[m]] > kNoMatchEffect) {
        residuals[bin[m]].push_back(
            pairs[m].log_ratio - image_effect[pairs[m].node1] -
            image_effect[pairs[m].node2] - other_effect[other_bin[m]]);
      }
    }
    for (int b = 0; b < kNumBins; ++b) {
      if (residuals[b].empty() && num_unmatched[b] == 0) continue;
      (*effect)[b] = CensoredUpperQuartile(residuals[b], num_unmatched[b]);
    }
  };
  // The weak band (log ratio) below a rate.
  const double weak_gap =
      weak_pair_ratio > 0 ? -std::log(weak_pair_ratio) : 0.0;
  for (int iteration = 0; iteration < 20; ++iteration) {
    fit_bins(angle_bin, &angle_effect, scale_effect, scale_bin);
    fit_bins(scale_bin, &scale_effect, angle_effect, angle_bin);
    // Gauge: the smallest change of scale has effect 0 (the angle bins
    // take the level).
    const double scale_level = scale_effect[scale_merged[0]];
    if (scale_level > kNoMatchEffect) {
      for (double& effect : scale_effect) {
        if (effect > kNoMatchEffect) effect -= scale_level;
      }
      for (double& effect : angle_effect) {
        if (effect > kNoMatchEffect) effect += scale_level;
      }
    }
    std::vector<double> effects;
    std::vector<char> own_effect(n, 0);
    for (int i = 0; i < n; ++i) {
      std::vector<double> own;
      for (const size_t m : image_pairs[i]) {
        if (bins_of(m) <= kNoMatchEffect) continue;
        const int other = pairs[m].node1 == i ? pairs[m].node2 : pairs[m].node1;
        own.push_back(pairs[m].log_ratio - image_effect[other] - bins_of(m));
      }
      if (static_cast<int>(own.size()) < kMinImagePairs) {
        image_effect[i] = 0;
        continue;
      }
      own_effect[i] = 1;
      image_effect[i] = Quantile(own, 0.75);
      // An image whose upper quartile is at the weak level while a few of
      // its pairs are strong both at the typical level and above that
      // quartile's weak band: most of its pairs are a fold's false ones (an
      // image that keeps few of its points has them all low), and its
      // effect follows the strong few, lest it absorb the fold's evidence.
      if (weak_pair_ratio > 0 && image_effect[i] < -weak_gap) {
        double lowest_strong = std::numeric_limits<double>::infinity();
        int num_strong = 0;
        for (const double r : own) {
          if (r >= -weak_gap && r > image_effect[i] + weak_gap) {
            ++num_strong;
            lowest_strong = std::min(lowest_strong, r);
          }
        }
        if (num_strong >= kMinStrongPairs) image_effect[i] = lowest_strong;
      }
      effects.push_back(image_effect[i]);
    }
    // Gauge: the median image has effect 0 (the bins take the level).
    const double shift = Median(effects);
    for (int i = 0; i < n; ++i) {
      if (own_effect[i]) image_effect[i] -= shift;
    }
  }
  for (int b = 0; b < kNumBins; ++b) {
    model.angle_effect[b] = angle_effect[angle_merged[b]];
    model.scale_effect[b] = scale_effect[scale_merged[b]];
  }
  std::vector<double> residuals;
  for (size_t m = 0; m < pairs.size(); ++m) {
    if (!pairs[m].matched || bins_of(m) <= kNoMatchEffect) continue;
    residuals.push_back(pairs[m].log_ratio - image_effect[pairs[m].node1] -
                        image_effect[pairs[m].node2] - bins_of(m));
  }
  model.median_residual = Median(residuals);
  return model;
}

// Marks the weak pairs of report->pair_support and finds the cut that best
// separates the weak consistent predicted pairs from the strong ones
// (FoldReport: typical_ratio ... weak_fold). `index`: image id -> node.
// Returns the rate model (every effect 0 but the level, the typical ratio,
// without weak_pair_rate_model).
RateModel WeakPairCut(const FoldDetectionOptions& options,
                      const std::map<image_t, int>& index,
                      const std::vector<RatePair>& unmatched,
                      FoldReport* report) {
  std::vector<double> ratios;
  for (PairSupport& support : report->pair_support) {
    const double predicted =
        std::sqrt(support.num_predicted12 * support.num_predicted21);
    support.ratio = predicted > 0 ? support.num_inliers / predicted : 0;
    // Only the predicted pairs: the overlap of the others (wide baselines,
    // few predicted points) is predicted too poorly for a ratio.
    if (support.predicted) ratios.push_back(support.ratio);
  }
  report->num_support_pairs = static_cast<int>(ratios.size());
  RateModel model;
  model.image_effect.assign(index.size(), 0.0);
  if (ratios.empty()) return model;
  report->typical_ratio = Quantile(ratios, 0.75);
  if (options.weak_pair_rate_model) {
    std::vector<RatePair> pairs = unmatched;
    for (const PairSupport& support : report->pair_support) {
      if (!support.predicted || !(support.ratio > 0)) continue;
      RatePair pair;
      pair.node1 = index.at(support.image_id1);
      pair.node2 = index.at(support.image_id2);
      pair.view_angle_deg = support.view_angle_deg;
      pair.log_scale = support.log_scale;
      pair.log_ratio = std::log(support.ratio);
      pair.matched = true;
      pairs.push_back(pair);
    }
    model = FitPairRates(pairs, static_cast<int>(index.size()),
                         options.weak_pair_ratio);
  } else {
    model.typical = report->typical_ratio;
  }
  for (PairSupport& support : report->pair_support) {
    support.expected_ratio =
        model.Ratio(index.at(support.image_id1), index.at(support.image_id2),
                    support.view_angle_deg, support.log_scale);
  }
  if (options.weak_pair_ratio <= 0) return model;
  // Signed graph over the images: strong predicted pairs pull together (+1),
  // weak ones push apart (scaled so that both kinds weigh the same).
  std::vector<std::tuple<int, int, double>> edges;
  int num_strong = 0;
  for (PairSupport& support : report->pair_support) {
    support.weak =
        support.ratio < options.weak_pair_ratio * support.expected_ratio;
    if (!support.predicted) continue;
    report->num_weak_pairs += support.weak;
    num_strong += !support.weak;
  }
  if (report->num_weak_pairs < options.min_weak_cut_pairs || num_strong == 0) {
    return model;
  }
  const double negative =
      static_cast<double>(num_strong) / report->num_weak_pairs;
  for (const PairSupport& support : report->pair_support) {
    if (!support.predicted) continue;
    edges.emplace_back(index.at(support.image_id1), index.at(support.image_id2),
                       support.weak ? -negative : 1.0);
  }
  const int n = static_cast<int>(index.size());
  const std::vector<int> side = SignedGraphCut(n, edges);
  int side_size[2] = {0, 0};
  for (const int x : side) ++side_size[x > 0];
  const int smaller = side_size[1] <= side_size[0] ? 1 : -1;
  bool smaller_side_has_strong_pair = false;
  for (const auto& [a, b, w] : edges) {
    if (side[a] != side[b]) {
      (w < 0 ? report->num_weak_cut_pairs : report->num_strong_cut_pairs) += 1;
    } else if (w > 0 && side[a] == smaller) {
      smaller_side_has_strong_pair = true;
    }
  }
  const int cut = report->num_weak_cut_pairs + report->num_strong_cut_pairs;
  report->weak_fold =
      smaller_side_has_strong_pair &&
      report->num_weak_cut_pairs >= options.min_weak_cut_pairs &&
      report->num_weak_cut_pairs >= options.min_weak_cut_fraction * cut;
  return model;
}

// The verified pairs the model agrees with (consistent) or contradicts.
struct JudgedPairs {
  std::vector<std::pair<int, int>> consistent;  // (node, node)
  std::vector<int> consistent_inliers;
  std::vector<int> inconsistent_inliers;
  std::vector<int> contradicted;  // per node: contradicted pairs at it
};

// One fold check's registered images (views, by node), its verified pairs
// and the overlap the model predicts between the views; its steps fill a
// FoldReport (DetectFold).
class FoldDetector {
 public:
  FoldDetector(const FoldDetectionOptions& options,
               const Reconstruction& reconstruction,
               const FoldEvidence& evidence, const std::vector<Track>* tracks);

  int NumViews() const { return static_cast<int>(views_.size()); }
  // Image id -> node.
  const std::map<image_t, int>& Index() const { return index_; }

  // expected_ and predicted_: the points of each view another should match,
  // and the pairs predicted to overlap (and tried).
  void PredictOverlap();
  // The verified pairs with a rotation and enough inliers, judged against
  // the model's rotations; report->pair_support for the consistent ones.
  JudgedPairs JudgeVerifiedPairs(FoldReport* report) const;
  // The predicted pairs without matches (to the rate model).
  std::vector<RatePair> UnmatchedPredictedPairs() const;
  // Counts the predicted pairs without matches (report's missing and
  // predicted pairs) and drops those not expected to pass verification;
  // returns each node's predicted neighbours.
  std::vector<std::vector<int>> CountMissingPairs(const RateModel& rates,
                                                  FoldReport* report);
  void FindWeakAloneImages(const RateModel& rates,
                           const std::vector<int>& contradicted,
                           FoldReport* report) const;
  void FindSuspectPairs(
      const std::vector<std::pair<int, int>>& consistent,
      const std::vector<std::vector<int>>& predicted_neighbours,
      FoldReport* report) const;
  void CountContradictoryTracks(FoldReport* report) const;

 private:
  // Of view i: the points of i that view j should match, with the sum of
  // the angles between the two rays to them.
  struct Expected {
    int j = 0;
    int count = 0;
    double angle_sum_deg = 0;
    double log_scale_sum = 0;
  };

  void CollectViews(const std::vector<Track>* tracks);
  void ComputeExpectedOverlap();
  bool Matched(image_t a, image_t b) const;
  bool Tried(image_t a, image_t b) const;
  const Expected* FindExpected(int i, int j) const;
  int ExpectedCount(int i, int j) const;
  bool IsPredicted(int i, int j) const;
  double ScaledCount(int i, int j) const;
  double MeanViewAngle(int i, int j) const;
  double MeanLogScale(int i, int j) const;

  const FoldDetectionOptions& options_;
  const Reconstruction& reconstruction_;
  const FoldEvidence& evidence_;
  std::vector<View> views_;
  std::map<image_t, int> index_;
  std::map<std::pair<image_t, image_t>, const PairEvidence*> by_pair_;
  // Sparse: expected_[i] holds the views j with points of i that j should
  // match, by increasing j.
  std::vector<std::vector<Expected>> expected_;
  std::set<std::pair<int, int>> predicted_;  // (i, j), i < j
};

FoldDetector::FoldDetector(const FoldDetectionOptions& options,
                           const Reconstruction& reconstruction,
                           const FoldEvidence& evidence,
                           const std::vector<Track>* tracks)
    : options_(options), reconstruction_(reconstruction), evidence_(evidence) {
  CollectViews(tracks);
  for (const PairEvidence& pair : evidence.pairs) {
    if (!index_.count(pair.image_id1) || !index_.count(pair.image_id2)) {
      continue;
    }
    by_pair_[Ordered(pair.image_id1, pair.image_id2)] = &pair;
  }
}

// The registered images with a sample of their model points.
void FoldDetector::CollectViews(const std::vector<Track>* tracks) {
  std::map<image_t, int> track_points;  // image -> observations in tracks
  if (tracks != nullptr) {
    for (const Track& track : *tracks) {
      for (const TrackElement& element : track) {
        ++track_points[element.image_id];
      }
    }
  }
  for (const auto& [image_id, image] : reconstruction_.images) {
    View view;
    view.image_id = image_id;
    view.camera = &reconstruction_.cameras.at(image.camera_id);
    view.R = image.cam_from_world.rotation.normalized().toRotationMatrix();
    view.t = image.cam_from_world.translation;
    view.center = -view.R.transpose() * view.t;
    view.axis = view.R.row(2).transpose();
    std::vector<point3D_t> ids;
    for (const Point2D& point2D : image.points2D) {
      if (point2D.point3D_id != kInvalidPoint3DId &&
          reconstruction_.points3D.count(point2D.point3D_id)) {
        ids.push_back(point2D.point3D_id);
      }
    }
    std::sort(ids.begin(), ids.end());
    ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
    view.num_points = static_cast<int>(ids.size());
    std::vector<double> depths;
    for (const point3D_t id : ids) {
      depths.push_back(
          (reconstruction_.points3D.at(id).xyz - view.center).norm());
    }
    view.depth_range = Quantile(std::move(depths), kDepthRangeQuantile);
    const auto image_track_points = track_points.find(image_id);
    view.num_scaled_points =
        image_track_points != track_points.end()
            ? std::max(image_track_points->second, view.num_points)
            : view.num_points;
    const size_t n =
        std::min<size_t>(ids.size(), options_.max_points_per_image);
    for (size_t k = 0; k < n; ++k) {
      // Evenly spaced over the sorted ids: deterministic.
      view.points.push_back(
          reconstruction_.points3D.at(ids[k * ids.size() / n]).xyz);
      view.radius =
          std::max(view.radius, (view.points.back() - view.center).norm());
    }
    index_[image_id] = static_cast<int>(views_.size());
    views_.push_back(std::move(view));
  }
}

bool FoldDetector::Matched(image_t a, image_t b) const {
  const auto it = by_pair_.find(Ordered(a, b));
  return it != by_pair_.end() &&
         it->second->num_inliers >= options_.min_num_matches;
}

// Matching was attempted: verified (or at least its raw matches too few
// to verify); raw matches without a verification say nothing.
bool FoldDetector::Tried(image_t a, image_t b) const {
  const auto it = by_pair_.find(Ordered(a, b));
  if (it == by_pair_.end()) return evidence_.absent_pairs_were_tried;
  const PairEvidence& pair = *it->second;
  return pair.num_matches < options_.min_num_matches || pair.verified ||
         pair.has_rotation || pair.num_inliers > 0;
}

// Two cameras whose optical axes are further apart than the view angle
// plus both half fields of view cannot share a point, nor can two cameras
// further apart than the view angle and scale ratio allow for the points
// one of them sees (MaxCenterDistanceFactor): skip them cheaply, so that
// the cost is images^2 distance tests plus the points of the pairs that
// are near each other (exact: only pairs that expect no point are skipped).
void FoldDetector::ComputeExpectedOverlap() {
  const int num_views = NumViews();
  const double cos_max_angle =
      std::cos(options_.max_view_angle_deg * kDegToRad);
  const double distance_factor =
      MaxCenterDistanceFactor(cos_max_angle, options_.max_scale_ratio);
  expected_.assign(num_views, {});
  for (int i = 0; i < num_views; ++i) {
    if (views_[i].points.empty()) continue;
    const double max_distance_squared =
        options_.skip_distant_pairs
            ? std::pow(distance_factor * views_[i].radius * (1 + 1e-9), 2)
            : std::numeric_limits<double>::infinity();
    for (int j = 0; j < num_views; ++j) {
      if (i == j) continue;
      if ((views_[i].center - views_[j].center).squaredNorm() >
          max_distance_squared) {
        continue;
      }
      if (views_[i].axis.dot(views_[j].axis) < -0.5) continue;
      Expected entry;
      entry.j = j;
      for (const Eigen::Vector3d& X : views_[i].points) {
        double cos_angle = 1;
        double log_scale = 0;
        if (ExpectsPoint(
                views_[j], views_[i].center, X, cos_max_angle,
                options_.max_scale_ratio,
                options_.within_observed_depth ? views_[j].depth_range : 0.0,
                &cos_angle, &log_scale)) {
          ++entry.count;
          entry.angle_sum_deg +=
              std::acos(std::clamp(cos_angle, -1.0, 1.0)) / kDegToRad;
          entry.log_scale_sum += log_scale;
        }
      }
      if (entry.count > 0) expected_[i].push_back(entry);
    }
  }
}

const FoldDetector::Expected* FoldDetector::FindExpected(int i, int j) const {
  const auto it = std::lower_bound(
      expected_[i].begin(), expected_[i].end(), j,
      [](const Expected& entry, int key) { return entry.j < key; });
  return it != expected_[i].end() && it->j == j ? &*it : nullptr;
}

int FoldDetector::ExpectedCount(int i, int j) const {
  const Expected* entry = FindExpected(i, j);
  return entry != nullptr ? entry->count : 0;
}

bool FoldDetector::IsPredicted(int i, int j) const {
  return predicted_.count(i < j ? std::make_pair(i, j) : std::make_pair(j, i)) >
         0;
}

// Points of i that j should match, scaled to all of i's points.
double FoldDetector::ScaledCount(int i, int j) const {
  return static_cast<double>(ExpectedCount(i, j)) *
         views_[i].num_scaled_points / views_[i].points.size();
}

double FoldDetector::MeanViewAngle(int i, int j) const {
  const Expected* ij = FindExpected(i, j);
  const Expected* ji = FindExpected(j, i);
  return (ij->angle_sum_deg + ji->angle_sum_deg) / (ij->count + ji->count);
}

double FoldDetector::MeanLogScale(int i, int j) const {
  const Expected* ij = FindExpected(i, j);
  const Expected* ji = FindExpected(j, i);
  return (ij->log_scale_sum + ji->log_scale_sum) / (ij->count + ji->count);
}

// Those without matches are judged later (CountMissingPairs), once the rate
// model is known.
void FoldDetector::PredictOverlap() {
  ComputeExpectedOverlap();
  // Rigid part of each view (-1: tied to no other image): across parts the
  // model does not determine where one camera is relative to another.
  std::vector<int> part(NumViews(), 0);
  if (options_.within_rigid_parts) {
    std::fill(part.begin(), part.end(), -1);
    const ModelRigidity rigidity = AnalyzeModelRigidity(
        ModelRigidityOptions(), reconstruction_, /*min_model_size=*/1);
    for (size_t b = 0; b < rigidity.blocks.size(); ++b) {
      for (const image_t image_id : rigidity.blocks[b]) {
        part[index_.at(image_id)] = static_cast<int>(b);
      }
    }
  }
  for (int i = 0; i < NumViews(); ++i) {
    for (const Expected& entry : expected_[i]) {
      const int j = entry.j;
      const int e_ij = entry.count;
      if (j <= i) continue;
      const int e_ji = ExpectedCount(j, i);
      const double ni = static_cast<double>(views_[i].points.size());
      const double nj = static_cast<double>(views_[j].points.size());
      if (std::min(e_ij, e_ji) < options_.min_overlap_points) continue;
      if (e_ij < options_.min_overlap_fraction * ni ||
          e_ji < options_.min_overlap_fraction * nj) {
        continue;
      }
      if (!Tried(views_[i].image_id, views_[j].image_id)) continue;
      if (part[i] != part[j] || part[i] < 0) continue;
      predicted_.insert({i, j});
    }
  }
}

JudgedPairs FoldDetector::JudgeVerifiedPairs(FoldReport* report) const {
  JudgedPairs judged;
  judged.contradicted.assign(NumViews(), 0);
  for (const auto& [key, pair] : by_pair_) {
    if (!pair->has_rotation || pair->num_inliers < options_.min_num_matches) {
      continue;
    }
    const int i = index_.at(pair->image_id1);
    const int j = index_.at(pair->image_id2);
    const double error =
        AngularDistanceDeg(pair->R, views_[j].R * views_[i].R.transpose());
    if (!(error <= options_.max_rotation_error_deg)) {  // NaN: contradicted
      judged.inconsistent_inliers.push_back(pair->num_inliers);
      ++judged.contradicted[i];
      ++judged.contradicted[j];
      continue;
    }
    judged.consistent.emplace_back(i, j);
    judged.consistent_inliers.push_back(pair->num_inliers);
    if (ExpectedCount(i, j) > 0 && ExpectedCount(j, i) > 0) {
      PairSupport support;
      support.image_id1 = pair->image_id1;
      support.image_id2 = pair->image_id2;
      support.num_inliers = pair->num_inliers;
      support.num_predicted12 = ScaledCount(i, j);
      support.num_predicted21 = ScaledCount(j, i);
      support.predicted = IsPredicted(i, j);
      support.view_angle_deg = MeanViewAngle(i, j);
      support.log_scale = MeanLogScale(i, j);
      report->pair_support.push_back(support);
    }
  }
  return judged;
}

std::vector<RatePair> FoldDetector::UnmatchedPredictedPairs() const {
  std::vector<RatePair> pairs;
  for (const auto& [i, j] : predicted_) {
    if (Matched(views_[i].image_id, views_[j].image_id)) continue;
    RatePair pair;
    pair.node1 = i;
    pair.node2 = j;
    pair.view_angle_deg = MeanViewAngle(i, j);
    pair.log_scale = MeanLogScale(i, j);
    pairs.push_back(pair);
  }
  return pairs;
}

// Missing pairs: predicted, tried, not matched, and (with the rate model)
// expected to keep enough inliers to pass the verification: where the
// images keep few of their points or the angle is wide, a true pair may
// fail it, and its absence says nothing.
std::vector<std::vector<int>> FoldDetector::CountMissingPairs(
    const RateModel& rates, FoldReport* report) {
  std::vector<std::vector<int>> predicted_neighbours(NumViews());
  for (auto it = predicted_.begin(); it != predicted_.end();) {
    const auto [i, j] = *it;
    const image_t a = views_[i].image_id;
    const image_t b = views_[j].image_id;
    const bool is_matched = Matched(a, b);
    const double expected_inliers =
        std::sqrt(ScaledCount(i, j) * ScaledCount(j, i)) *
        rates.Ratio(i, j, MeanViewAngle(i, j), MeanLogScale(i, j)) *
        std::exp(rates.median_residual);
    VLOG(2) << "pair " << a << " " << b
            << (is_matched ? " matched" : " without") << " matches: predicted "
            << ScaledCount(i, j) << " / " << ScaledCount(j, i) << " points "
            << MeanViewAngle(i, j) << " deg scale "
            << std::exp(MeanLogScale(i, j)) << " expected " << expected_inliers
            << " inliers";
    if (!is_matched && options_.weak_pair_rate_model &&
        report->num_support_pairs > 0 &&
        expected_inliers <
            options_.missing_pair_inlier_factor * options_.min_num_matches) {
      ++report->num_unexpected_pairs;
      it = predicted_.erase(it);
      continue;
    }
    ++it;
    predicted_neighbours[i].push_back(j);
    predicted_neighbours[j].push_back(i);
    ++report->num_predicted_pairs;
    ++report->image_predicted_pairs[a];
    ++report->image_predicted_pairs[b];
    if (!is_matched) {
      ++report->num_missing_pairs;
      ++report->image_missing_pairs[a];
      ++report->image_missing_pairs[b];
      report->missing_pairs.push_back(Ordered(a, b));
    }
  }
  std::sort(report->missing_pairs.begin(), report->missing_pairs.end());
  return predicted_neighbours;
}

// Images weak alone: every consistent predicted pair at them weak, and
// verified pairs at them contradicted. Judged without the image's own
// effect of the rate model (which a turned camera's weak pairs set).
void FoldDetector::FindWeakAloneImages(const RateModel& rates,
                                       const std::vector<int>& contradicted,
                                       FoldReport* report) const {
  std::vector<int> num_support(NumViews(), 0);
  std::vector<int> num_weak(NumViews(), 0);
  for (const PairSupport& support : report->pair_support) {
    if (!support.predicted) continue;
    for (const image_t image_id : {support.image_id1, support.image_id2}) {
      const int i = index_.at(image_id);
      ++num_support[i];
      num_weak[i] += support.ratio < options_.weak_pair_ratio *
                                         support.expected_ratio /
                                         std::exp(rates.image_effect[i]);
    }
  }
  for (int i = 0; i < NumViews(); ++i) {
    if (num_support[i] >= options_.min_weak_alone_pairs &&
        num_weak[i] == num_support[i] &&
        contradicted[i] >= options_.min_weak_alone_pairs) {
      report->weak_alone_images.push_back(views_[i].image_id);
    }
  }
}

// Suspects: consistent pairs (a, b) whose common predicted neighbours
// mostly match only one of them. A true pair's neighbours see what both
// see and match both; a false pair joins images of two different places
// that the fold has put together.
void FoldDetector::FindSuspectPairs(
    const std::vector<std::pair<int, int>>& consistent,
    const std::vector<std::vector<int>>& predicted_neighbours,
    FoldReport* report) const {
  for (const auto& [i, j] : consistent) {
    if (!IsPredicted(i, j)) continue;
    int support = 0;
    int conflict = 0;
    for (const int c : predicted_neighbours[i]) {
      if (c == j || !IsPredicted(j, c)) continue;
      const bool mi = Matched(views_[i].image_id, views_[c].image_id);
      const bool mj = Matched(views_[j].image_id, views_[c].image_id);
      if (mi && mj) {
        ++support;
      } else if (mi != mj) {
        ++conflict;
      }
    }
    if (conflict >= options_.min_suspect_conflicts && conflict > support) {
      report->suspect_pairs.push_back(
          Ordered(views_[i].image_id, views_[j].image_id));
    }
  }
  std::sort(report->suspect_pairs.begin(), report->suspect_pairs.end());
}

// Tracks seen from contradictory sides.
void FoldDetector::CountContradictoryTracks(FoldReport* report) const {
  const double cos_contradictory =
      std::cos(options_.contradictory_ray_angle_deg * kDegToRad);
  for (const auto& [point3D_id, point] : reconstruction_.points3D) {
    if (point.track.size() < 2) continue;
    ++report->num_tracks;
    std::vector<Eigen::Vector3d> rays;
    for (const TrackElement& element : point.track) {
      const auto it = index_.find(element.image_id);
      if (it == index_.end()) continue;
      const Eigen::Vector3d ray = views_[it->second].center - point.xyz;
      if (ray.norm() > 0) rays.push_back(ray.normalized());
      if (rays.size() >= 32) break;  // long tracks: a sample is enough
    }
    bool contradictory = false;
    for (size_t a = 0; a < rays.size() && !contradictory; ++a) {
      for (size_t b = a + 1; b < rays.size(); ++b) {
        if (rays[a].dot(rays[b]) < cos_contradictory) {
          contradictory = true;
          break;
        }
      }
    }
    report->num_contradictory_tracks += contradictory;
  }
}

// The fold score and verdict from the missing pairs and the weak pairs' cut.
void ScoreFold(const FoldDetectionOptions& options, FoldReport* report) {
  report->fold_score = report->num_predicted_pairs > 0
                           ? static_cast<double>(report->num_missing_pairs) /
                                 report->num_predicted_pairs
                           : 0.0;
  report->missing_fold = report->fold_score > options.max_fold_score &&
                         report->num_missing_pairs >= options.min_missing_pairs;
  report->folded = report->missing_fold;
  if (report->weak_fold) {
    report->fold_score = std::max(
        report->fold_score, static_cast<double>(report->num_weak_cut_pairs) /
                                report->num_support_pairs);
    report->folded = true;
  }
}

// Contradicted pairs with at least the median inliers of the consistent ones.
int CountStrongInconsistentPairs(const JudgedPairs& judged) {
  if (judged.consistent_inliers.empty()) return 0;
  std::vector<int> sorted = judged.consistent_inliers;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2,
                   sorted.end());
  const int median = sorted[sorted.size() / 2];
  int count = 0;
  for (const int inliers : judged.inconsistent_inliers) {
    count += inliers >= median;
  }
  return count;
}

}  // namespace

template <>
const EnumNames<FoldCutParts>& NamesOf<FoldCutParts>() {
  static const EnumNames<FoldCutParts> names = {
      {FoldCutParts::kModel, "model"},
      {FoldCutParts::kRigidParts, "rigid"},
      {FoldCutParts::kAgreeingParts, "agreeing"}};
  return names;
}

void FoldDetectionOptions::Check() const {
  if (!(max_view_angle_deg > 0 && max_view_angle_deg < 180)) {
    throw OptionError(&max_view_angle_deg, "Fold.max_view_angle_deg",
                      "must be in (0, 180)");
  }
  if (!(max_scale_ratio >= 1)) {
    throw OptionError(&max_scale_ratio, "FoldDetectionOptions::max_scale_ratio",
                      "must be >= 1");
  }
  if (!(min_overlap_fraction > 0 && min_overlap_fraction <= 1)) {
    throw OptionError(&min_overlap_fraction, "Fold.min_overlap_fraction",
                      "must be in (0, 1]");
  }
  if (min_overlap_points < 1) {
    throw OptionError(&min_overlap_points,
                      "FoldDetectionOptions::min_overlap_points",
                      "must be >= 1");
  }
  if (max_points_per_image < 1) {
    throw OptionError(&max_points_per_image,
                      "FoldDetectionOptions::max_points_per_image",
                      "must be >= 1");
  }
  if (min_num_matches < 0) {
    // Set from --Mapper.min_num_matches (GlobalMapperOptions::ForStages).
    throw OptionError(&min_num_matches, "Mapper.min_num_matches",
                      "must be >= 0");
  }
  if (!(max_fold_score >= 0 && max_fold_score <= 1)) {
    throw OptionError(&max_fold_score, "Fold.max_fold_score",
                      "must be in [0, 1]");
  }
  if (min_missing_pairs < 1) {
    throw OptionError(&min_missing_pairs, "Fold.min_missing_pairs",
                      "must be >= 1");
  }
  if (!(max_rotation_error_deg > 0 && max_rotation_error_deg <= 180)) {
    throw OptionError(&max_rotation_error_deg,
                      "FoldDetectionOptions::max_rotation_error_deg",
                      "must be in (0, 180]");
  }
  if (!(contradictory_ray_angle_deg > 0 &&
        contradictory_ray_angle_deg <= 180)) {
    throw OptionError(&contradictory_ray_angle_deg,
                      "FoldDetectionOptions::contradictory_ray_angle_deg",
                      "must be in (0, 180]");
  }
  if (!(weak_pair_ratio >= 0 && weak_pair_ratio < 1)) {
    throw OptionError(&weak_pair_ratio, "Fold.weak_pair_ratio",
                      "must be in [0, 1)");
  }
  if (!(missing_pair_inlier_factor >= 0)) {
    throw InputError("--Fold.missing_pair_inlier_factor", "must be >= 0");
  }
  if (min_weak_cut_pairs < 1) {
    throw OptionError(&min_weak_cut_pairs, "Fold.min_weak_cut_pairs",
                      "must be >= 1");
  }
  if (!(min_weak_cut_fraction > 0.5 && min_weak_cut_fraction <= 1)) {
    throw OptionError(&min_weak_cut_fraction, "Fold.min_weak_cut_fraction",
                      "must be in (0.5, 1]");
  }
  if (cut_max_power_iterations < 1) {
    throw OptionError(&cut_max_power_iterations,
                      "Fold.cut_max_power_iterations", "must be >= 1");
  }
  if (!(cut_min_fold_rotation_share >= 0 && cut_min_fold_rotation_share <= 1)) {
    throw OptionError(&cut_min_fold_rotation_share,
                      "Fold.cut_min_fold_rotation_share", "must be in [0, 1]");
  }
  if (!(cut_min_fold_rotation_deg > max_rotation_error_deg &&
        cut_min_fold_rotation_deg <= 180)) {
    throw OptionError(&cut_min_fold_rotation_deg,
                      "Fold.cut_min_fold_rotation_deg",
                      "must be in (--Fold.max_rotation_error_deg, 180]");
  }
  if (cut_min_fold_rotation_pairs < 1) {
    throw OptionError(&cut_min_fold_rotation_pairs,
                      "Fold.cut_min_fold_rotation_pairs", "must be >= 1");
  }
  if (cut_min_pair_triangles < 0) {
    throw OptionError(&cut_min_pair_triangles, "Fold.cut_min_pair_triangles",
                      "must be >= 0");
  }
  if (min_weak_alone_pairs < 1) {
    throw OptionError(&min_weak_alone_pairs, "Fold.min_weak_alone_pairs",
                      "must be >= 1");
  }
  if (min_suspect_conflicts < 1) {
    throw OptionError(&min_suspect_conflicts,
                      "FoldDetectionOptions::min_suspect_conflicts",
                      "must be >= 1");
  }
}

void FoldResolutionOptions::Check() const {
  if (max_iterations < 0) {
    throw OptionError(&max_iterations, "Fold.max_iterations", "must be >= 0");
  }
  detection.Check();
}

std::string FoldReport::Describe() const {
  std::ostringstream line;
  line << "fold score " << std::fixed << std::setprecision(3) << fold_score
       << " (" << num_missing_pairs << " of " << num_predicted_pairs
       << " predicted overlapping pairs have no matches; "
       << num_unexpected_pairs << " more expected too few inliers), "
       << num_strong_inconsistent_pairs << " strong pairs of "
       << num_inconsistent_pairs << " contradicted, "
       << num_contradictory_tracks << " of " << num_tracks
       << " tracks seen from contradictory sides, " << suspect_pairs.size()
       << " suspect pairs, " << num_weak_pairs << " of " << num_support_pairs
       << " consistent predicted pairs weak (typical " << std::setprecision(2)
       << typical_ratio << " inliers per predicted point; "
       << num_weak_cut_pairs << " weak and " << num_strong_cut_pairs
       << " strong across their cut" << (weak_fold ? ": a fold)" : ")") << ", "
       << weak_alone_images.size() << " images weak alone";
  return line.str();
}

FoldReport DetectFold(const FoldDetectionOptions& options,
                      const Reconstruction& reconstruction,
                      const FoldEvidence& evidence,
                      const std::vector<Track>* tracks) {
  FoldReport report;
  FoldDetector detector(options, reconstruction, evidence, tracks);
  report.num_images = detector.NumViews();
  detector.PredictOverlap();
  const JudgedPairs judged = detector.JudgeVerifiedPairs(&report);
  report.num_inconsistent_pairs =
      static_cast<int>(judged.inconsistent_inliers.size());
  const RateModel rates = WeakPairCut(
      options, detector.Index(), detector.UnmatchedPredictedPairs(), &report);
  const std::vector<std::vector<int>> predicted_neighbours =
      detector.CountMissingPairs(rates, &report);
  ScoreFold(options, &report);
  detector.FindWeakAloneImages(rates, judged.contradicted, &report);
  report.num_strong_inconsistent_pairs = CountStrongInconsistentPairs(judged);
  detector.FindSuspectPairs(judged.consistent, predicted_neighbours, &report);
  detector.CountContradictoryTracks(&report);
  return report;
}

std::vector<int> SignedGraphCut(
    int n, const std::vector<std::tuple<int, int, double>>& edges,
    int max_power_iterations) {
  if (n == 0) return {};
  // Leading eigenvector of the signed adjacency (power iteration with a
  // shift that makes the matrix positive definite), then single flips while
  // they increase the agreement sum_ij w_ij x_i x_j.
  std::vector<double> degree(n, 0);
  for (const auto& [a, b, w] : edges) {
    degree[a] += std::abs(w);
    degree[b] += std::abs(w);
  }
  const double shift = *std::max_element(degree.begin(), degree.end()) + 1;
  Eigen::VectorXd x(n);
  for (int k = 0; k < n; ++k) x[k] = std::sin(1.0 + k);  // deterministic
  // The shift slows the iteration down by the ratio of the eigenvalue gap to
  // it: a large model's gap is small, and 300 iterations had left the
  // vector of a 2,816-image folded model near its start (its cut mixed the
  // fold's halves 40/60; converged after 1,598 it is exact).
  int iteration = 0;
  double change = 0;
  for (; iteration < max_power_iterations; ++iteration) {
    Eigen::VectorXd y = shift * x;
    for (const auto& [a, b, w] : edges) {
      y[a] += w * x[b];
      y[b] += w * x[a];
    }
    y /= y.norm();
    change = (y - x).norm();
    x = std::move(y);
    if (max_power_iterations > kSignedCutFixedIterations &&
        change < kSignedCutTolerance) {
      break;
    }
  }
  VLOG(2) << "signed cut of " << n << " nodes: " << iteration
          << " power iterations, last change " << change;
  std::vector<int> side(n);
  for (int k = 0; k < n; ++k) side[k] = x[k] >= 0 ? 1 : -1;
  std::vector<std::vector<std::pair<int, double>>> adjacency(n);
  for (const auto& [a, b, w] : edges) {
    adjacency[a].emplace_back(b, w);
    adjacency[b].emplace_back(a, w);
  }
  for (bool improved = true; improved;) {
    improved = false;
    for (int k = 0; k < n; ++k) {
      double gain = 0;  // agreement change if k flips: -2 * sum w x_k x_l
      for (const auto& [l, w] : adjacency[k]) gain -= 2 * w * side[k] * side[l];
      if (gain > 1e-9) {
        side[k] = -side[k];
        improved = true;
      }
    }
  }
  return side;
}

namespace {

// The signed cut of the images `nodes` (dense indices, ascending): the
// trusted pairs among them (a, b, inliers) pull together, scaled by
// `trusted_scale`; the missing and weak pairs among them and the pairs
// contradicted by the fold's rotation (a, b, weight each) push apart.
// Returns the side to re-orient (the smaller; dense indices), empty when the
// cut explains neither the missing and weak pairs nor the fold rotation's.
std::vector<int> SignedFoldCut(
    const std::vector<int>& nodes,
    const std::vector<std::tuple<int, int, double>>& trusted,
    const std::vector<std::tuple<int, int, double>>& missing,
    const std::vector<std::tuple<int, int, double>>& rotation,
    double trusted_scale, int max_power_iterations) {
  const int n = static_cast<int>(nodes.size());
  if (n < 2 || (missing.empty() && rotation.empty()) || trusted.empty()) {
    return {};
  }
  std::vector<int> local(nodes.back() + 1, -1);
  for (int k = 0; k < n; ++k) local[nodes[k]] = k;
  std::vector<std::tuple<int, int, double>> edges;
  edges.reserve(trusted.size() + missing.size() + rotation.size());
  for (const auto& [a, b, w] : trusted) {
    edges.emplace_back(local[a], local[b], w * trusted_scale);
  }
  for (const auto* negatives : {&missing, &rotation}) {
    for (const auto& [a, b, w] : *negatives) {
      edges.emplace_back(local[a], local[b], -w);
    }
  }
  const std::vector<int> side = SignedGraphCut(n, edges, max_power_iterations);
  // Edges cut: trusted, missing or weak, fold rotation (in `edges`' order).
  int cut[3] = {0, 0, 0};
  for (size_t e = 0; e < edges.size(); ++e) {
    const auto& [a, b, w] = edges[e];
    if (side[a] == side[b]) continue;
    ++cut[e < trusted.size() ? 0 : e < trusted.size() + missing.size() ? 1 : 2];
  }
  std::vector<int> positive;
  std::vector<int> negative_side;
  for (int k = 0; k < n; ++k) {
    (side[k] > 0 ? positive : negative_side).push_back(nodes[k]);
  }
  VLOG(1) << "fold cut: " << positive.size() << " | " << negative_side.size()
          << " images, " << cut[1] << " of " << missing.size()
          << " missing or weak, " << cut[2] << " of " << rotation.size()
          << " fold rotation and " << cut[0] << " trusted pairs cut";
  // The cut explains the fold when most of the pairs that push apart cross
  // it (the pairs it cuts that the model trusts are then the ones that
  // folded it), or when it separates more of them than it cuts trusted
  // ones; the missing and weak pairs and the fold rotation's are judged
  // each on their own (a symmetric scene's false pairs within one side share
  // the fold's rotation too and stay uncut).
  const auto explains = [&](int num_cut, size_t num) {
    return num > 0 &&
           (static_cast<size_t>(num_cut) * 5 >= num * 4 || num_cut > cut[0]);
  };
  if (positive.empty() || negative_side.empty() ||
      !(explains(cut[1], missing.size()) ||
        explains(cut[2], rotation.size()))) {
    return {};
  }
  return positive.size() < negative_side.size() ? positive : negative_side;
}

// A verified pair `reconstruction` agrees with: dense indices (`index`:
// image id -> dense index), ids and verified inliers.
struct AgreedPair {
  int a = -1;
  int b = -1;
  image_t image_id1 = kInvalidImageId;
  image_t image_id2 = kInvalidImageId;
  int num_inliers = 0;
};

// Calls visit(pair, R1, R2) for each verified pair among the images of
// `index` with a measured rotation and at least min_num_matches inliers, in
// the evidence's order (`pair` with its dense indices; R1, R2: the model's
// rotations of its images). visit returns whether to keep the pair; returns
// the kept ones.
template <typename Visit>
std::vector<AgreedPair> SelectRotatedPairs(const FoldDetectionOptions& options,
                                           const Reconstruction& reconstruction,
                                           const FoldEvidence& evidence,
                                           const std::map<image_t, int>& index,
                                           Visit visit) {
  std::vector<AgreedPair> kept;
  for (const PairEvidence& pair : evidence.pairs) {
    if (!pair.has_rotation || pair.num_inliers < options.min_num_matches) {
      continue;
    }
    const auto i1 = index.find(pair.image_id1);
    const auto i2 = index.find(pair.image_id2);
    if (i1 == index.end() || i2 == index.end()) continue;
    const Eigen::Matrix3d R1 = reconstruction.images.at(pair.image_id1)
                                   .cam_from_world.rotation.toRotationMatrix();
    const Eigen::Matrix3d R2 = reconstruction.images.at(pair.image_id2)
                                   .cam_from_world.rotation.toRotationMatrix();
    if (visit(pair, R1, R2)) {
      kept.push_back({i1->second, i2->second, pair.image_id1, pair.image_id2,
                      pair.num_inliers});
    }
  }
  return kept;
}

// The verified pairs (as SelectRotatedPairs) whose relative rotation the
// model matches within max_rotation_error_deg.
std::vector<AgreedPair> AgreedPairs(const FoldDetectionOptions& options,
                                    const Reconstruction& reconstruction,
                                    const FoldEvidence& evidence,
                                    const std::map<image_t, int>& index) {
  return SelectRotatedPairs(
      options, reconstruction, evidence, index,
      [&](const PairEvidence& pair, const Eigen::Matrix3d& R1,
          const Eigen::Matrix3d& R2) {
        return !(AngularDistanceDeg(pair.R, R2 * R1.transpose()) >
                 options.max_rotation_error_deg);
      });
}

// The verified pairs among the images of `index` (with a measured rotation
// and at least min_num_matches inliers) that the model contradicts by the
// fold's rotation (FoldDetectionOptions::cut_fold_rotation_pairs): the most
// common discrepancy W = R_j^T R_ij R_i of the pairs contradicted by at
// least cut_min_fold_rotation_deg, W and its
// inverse alike (the pair's order says which image is the folded one),
// found among at most 256 of them taken evenly as candidates. Empty when
// fewer than cut_min_fold_rotation_pairs, or than cut_min_fold_rotation_share
// of those pairs, share it.
std::vector<AgreedPair> FoldRotationPairs(const FoldDetectionOptions& options,
                                          const Reconstruction& reconstruction,
                                          const FoldEvidence& evidence,
                                          const std::map<image_t, int>& index) {
  std::vector<Eigen::Quaterniond> discrepancy;
  const std::vector<AgreedPair> contradicted = SelectRotatedPairs(
      options, reconstruction, evidence, index,
      [&](const PairEvidence& pair, const Eigen::Matrix3d& R1,
          const Eigen::Matrix3d& R2) {
        // The discrepancy turns by the angle the pair is contradicted by.
        if (!(AngularDistanceDeg(pair.R, R2 * R1.transpose()) >=
              options.cut_min_fold_rotation_deg)) {
          return false;
        }
        discrepancy.emplace_back(Eigen::Matrix3d(R2.transpose() * pair.R * R1));
        return true;
      });
  const size_t num = contradicted.size();
  if (num < static_cast<size_t>(options.cut_min_fold_rotation_pairs)) {
    return {};
  }
  // |cos(half angle)| between unit quaternions: W and -W are one rotation;
  // W's inverse is its conjugate.
  const double min_cos = std::cos(DegToRad(options.max_rotation_error_deg) / 2);
  auto near = [&](const Eigen::Quaterniond& w, const Eigen::Quaterniond& c) {
    return std::abs(w.dot(c)) >= min_cos ||
           std::abs(w.conjugate().dot(c)) >= min_cos;
  };
  const size_t num_candidates = std::min<size_t>(num, 256);
  size_t best_support = 0;
  Eigen::Quaterniond best = Eigen::Quaterniond::Identity();
  for (size_t c = 0; c < num_candidates; ++c) {
    const Eigen::Quaterniond& candidate = discrepancy[c * num / num_candidates];
    size_t support = 0;
    for (const Eigen::Quaterniond& w : discrepancy)
      support += near(w, candidate);
    if (support > best_support) {
      best_support = support;
      best = candidate;
    }
  }
  VLOG(1) << "fold rotation: " << best_support << " of " << num
          << " contradicted pairs share the most common discrepancy ("
          << RadToDeg(2 * std::acos(std::min(1.0, std::abs(best.w()))))
          << " deg)";
  if (best_support < static_cast<size_t>(options.cut_min_fold_rotation_pairs) ||
      best_support < options.cut_min_fold_rotation_share * num) {
    return {};
  }
  std::vector<AgreedPair> pairs;
  for (size_t k = 0; k < num; ++k) {
    if (near(discrepancy[k], best)) pairs.push_back(contradicted[k]);
  }
  return pairs;
}

// The components of the `agreed` pairs (AgreedPairs), each pair joining its
// images only when it lies in at least cut_min_pair_triangles triangles of
// such pairs. Sets (*part_of)[dense index] (-1: in no joining pair) and
// returns the number of parts.
int AgreeingParts(const FoldDetectionOptions& options,
                  const std::vector<AgreedPair>& agreed,
                  std::vector<int>* part_of) {
  const int n = static_cast<int>(part_of->size());
  std::vector<std::vector<int>> neighbors(n);
  for (const AgreedPair& pair : agreed) {
    neighbors[pair.a].push_back(pair.b);
    neighbors[pair.b].push_back(pair.a);
  }
  for (std::vector<int>& list : neighbors) std::sort(list.begin(), list.end());
  UnionFind parts(n);
  for (const AgreedPair& pair : agreed) {
    const int a = pair.a;
    const int b = pair.b;
    // Common neighbours, stopping at the number needed.
    int triangles = 0;
    auto i = neighbors[a].begin();
    auto j = neighbors[b].begin();
    while (i != neighbors[a].end() && j != neighbors[b].end() &&
           triangles < options.cut_min_pair_triangles) {
      if (*i < *j) {
        ++i;
      } else if (*j < *i) {
        ++j;
      } else {
        ++triangles;
        ++i;
        ++j;
      }
    }
    if (triangles >= options.cut_min_pair_triangles) parts.Union(a, b);
  }
  // Parts numbered in image order; an image no pair joins is in none.
  std::map<size_t, int> number;
  for (int k = 0; k < n; ++k) {
    if (parts.SetSize(k) < 2) {
      (*part_of)[k] = -1;
      continue;
    }
    const auto [it, inserted] =
        number.emplace(parts.Find(k), static_cast<int>(number.size()));
    (*part_of)[k] = it->second;
  }
  return static_cast<int>(number.size());
}

// The model's cut `reoriented` (dense indices) with each part whose own cut
// found no fold (part_cut[p] empty) put whole on the side holding most of
// its images: a landmark that cannot fold is otherwise split along its own
// weakest seam, and the resolution removes its true pairs across it. Left
// as it was when no part keeps a cut (the model's cut then sees a fold the
// parts' cuts do not).
void KeepUnfoldedPartsWhole(const std::vector<std::vector<int>>& part_nodes,
                            const std::vector<std::vector<int>>& part_cut,
                            std::vector<int>* reoriented) {
  bool any_folded = false;
  for (const std::vector<int>& cut : part_cut) any_folded |= !cut.empty();
  if (!any_folded) return;
  std::set<int> side(reoriented->begin(), reoriented->end());
  int num_moved = 0;
  for (size_t p = 0; p < part_nodes.size(); ++p) {
    if (!part_cut[p].empty()) continue;
    size_t num_in = 0;
    for (const int k : part_nodes[p]) num_in += side.count(k);
    const bool to_side = 2 * num_in > part_nodes[p].size();
    if (num_in == 0 || num_in == part_nodes[p].size()) continue;
    num_moved +=
        static_cast<int>(to_side ? part_nodes[p].size() - num_in : num_in);
    for (const int k : part_nodes[p]) {
      if (to_side) {
        side.insert(k);
      } else {
        side.erase(k);
      }
    }
  }
  VLOG(1) << "fold cut: " << num_moved
          << " images of parts without a fold of their own moved to the "
             "side holding most of their part";
  reoriented->assign(side.begin(), side.end());
}

}  // namespace

std::pair<std::vector<image_t>, std::vector<image_t>> FoldCut(
    const FoldDetectionOptions& options, const Reconstruction& reconstruction,
    const FoldEvidence& evidence, const FoldReport& report) {
  const DenseImageIndex dense(reconstruction);
  const std::vector<image_t>& ids = dense.ids;
  const std::map<image_t, int>& index = dense.index;
  const int n = static_cast<int>(ids.size());
  // Signed graph: trusted pairs pull together, missing and weak pairs push
  // apart.
  std::set<std::pair<image_t, image_t>> suspects(report.suspect_pairs.begin(),
                                                 report.suspect_pairs.end());
  // Weak pairs are not trusted; the weak predicted ones push apart as the
  // missing pairs do (a fold's false pairs are the weak ones across it).
  std::vector<std::pair<image_t, image_t>> negative_pairs =
      report.missing_pairs;
  for (const PairSupport& support : report.pair_support) {
    if (!support.weak) continue;
    suspects.insert({support.image_id1, support.image_id2});
    if (support.predicted)
      negative_pairs.emplace_back(support.image_id1, support.image_id2);
  }
  const std::vector<AgreedPair> agreed =
      AgreedPairs(options, reconstruction, evidence, index);
  std::vector<std::tuple<int, int, double>> trusted;
  for (const AgreedPair& pair : agreed) {
    if (suspects.count(Ordered(pair.image_id1, pair.image_id2))) continue;
    trusted.emplace_back(pair.a, pair.b, pair.num_inliers);
  }
  std::pair<std::vector<image_t>, std::vector<image_t>> sides;
  sides.first = ids;
  if (n < 2 || trusted.empty()) return sides;
  // Trusted pairs pull in proportion to their verified inliers (normalised
  // to a mean of one): a false pair keeps only part of what a true pair
  // matches, so an image with true pairs on one side and false pairs the
  // fold agrees with on the other is drawn to its true side. Missing and
  // weak pairs weigh as much in total (one scale for the whole model).
  const int num_trusted = static_cast<int>(trusted.size());
  double total = 0;
  for (const auto& edge : trusted) total += std::get<2>(edge);
  const double trusted_scale = num_trusted / total;
  const double negative_weight = static_cast<double>(num_trusted) /
                                 std::max<size_t>(negative_pairs.size(), 1);
  std::vector<std::tuple<int, int, double>> missing;
  for (const auto& [a, b] : negative_pairs) {
    const auto i1 = index.find(a);
    const auto i2 = index.find(b);
    if (i1 == index.end() || i2 == index.end()) continue;
    missing.emplace_back(i1->second, i2->second, negative_weight);
  }
  std::vector<std::tuple<int, int, double>> rotation;
  if (options.cut_fold_rotation_pairs) {
    // True pairs across the fold: each as strong as a trusted pair of its
    // inliers.
    for (const AgreedPair& pair :
         FoldRotationPairs(options, reconstruction, evidence, index)) {
      rotation.emplace_back(pair.a, pair.b, pair.num_inliers * trusted_scale);
    }
  }
  if (missing.empty() && rotation.empty()) return sides;
  // The parts (rigid or agreeing), each cut on its own: pairs between parts
  // are left out (the model does not say where a part sits relative to
  // another, or the model's pairs do not join them, and no re-orientation
  // mends that). Images in no part are not cut. part_cut[p]: part p's own
  // cut (empty: no fold in it). With `only_if_several` a single part (the
  // model's cut already) is not cut.
  std::vector<std::vector<int>> part_nodes;
  std::vector<std::vector<int>> part_cut;
  const auto cut_each_part = [&](bool only_if_several) {
    std::vector<int> part_of(n, -1);
    int num_parts = 0;
    if (options.cut_parts == FoldCutParts::kRigidParts) {
      const ModelRigidity rigidity = AnalyzeModelRigidity(
          ModelRigidityOptions(), reconstruction, /*min_model_size=*/1);
      num_parts = static_cast<int>(rigidity.blocks.size());
      for (int p = 0; p < num_parts; ++p) {
        for (const image_t image_id : rigidity.blocks[p]) {
          part_of[index.at(image_id)] = p;
        }
      }
    } else {
      num_parts = AgreeingParts(options, agreed, &part_of);
    }
    part_nodes.assign(num_parts, {});
    part_cut.assign(num_parts, {});
    if (only_if_several && num_parts < 2) return;
    for (int k = 0; k < n; ++k) {
      if (part_of[k] >= 0) part_nodes[part_of[k]].push_back(k);
    }
    // The edges within each part.
    typedef std::vector<std::tuple<int, int, double>> Edges;
    const auto by_part = [&](const Edges& edges) {
      std::vector<Edges> parts(num_parts);
      for (const auto& edge : edges) {
        const int p = part_of[std::get<0>(edge)];
        if (p >= 0 && p == part_of[std::get<1>(edge)]) {
          parts[p].push_back(edge);
        }
      }
      return parts;
    };
    const std::vector<Edges> part_trusted = by_part(trusted);
    const std::vector<Edges> part_missing = by_part(missing);
    const std::vector<Edges> part_rotation = by_part(rotation);
    for (int p = 0; p < num_parts; ++p) {
      if (part_missing[p].empty() && part_rotation[p].empty()) continue;
      part_cut[p] = SignedFoldCut(
          part_nodes[p], part_trusted[p], part_missing[p], part_rotation[p],
          trusted_scale, options.cut_max_power_iterations);
      VLOG(1) << "fold cut of part " << p << " (" << part_nodes[p].size()
              << " images, " << part_missing[p].size()
              << " missing or weak pairs, " << part_rotation[p].size()
              << " fold rotation pairs): " << part_cut[p].size()
              << " to re-orient";
    }
  };
  std::vector<int> reoriented;
  if (options.cut_parts == FoldCutParts::kModel) {
    std::vector<int> all(n);
    for (int k = 0; k < n; ++k) all[k] = k;
    reoriented = SignedFoldCut(all, trusted, missing, rotation, trusted_scale,
                               options.cut_max_power_iterations);
    // The parts are cut only when the model's cut found something to keep
    // them out of.
    if (options.cut_keep_unfolded_parts && !reoriented.empty()) {
      cut_each_part(/*only_if_several=*/true);
      if (part_nodes.size() >= 2) {
        KeepUnfoldedPartsWhole(part_nodes, part_cut, &reoriented);
      }
    }
  } else {
    cut_each_part(/*only_if_several=*/false);
    for (const std::vector<int>& side : part_cut) {
      reoriented.insert(reoriented.end(), side.begin(), side.end());
    }
  }
  if (reoriented.empty()) return sides;
  std::vector<bool> is_reoriented(n, false);
  for (const int k : reoriented) is_reoriented[k] = true;
  sides.first.clear();
  for (int k = 0; k < n; ++k) {
    (is_reoriented[k] ? sides.second : sides.first).push_back(ids[k]);
  }
  if (VLOG_IS_ON(3)) {
    // The images of each side, to compare a cut with the truth on synthetic
    // scenes.
    for (const std::vector<image_t>* side : {&sides.first, &sides.second}) {
      std::ostringstream line;
      line << "fold cut side " << (side == &sides.first ? 1 : 2) << ":";
      for (const image_t image_id : *side) line << ' ' << image_id;
      VLOG(3) << line.str();
    }
  }
  return sides;
}

}  // namespace colmap_irav4
