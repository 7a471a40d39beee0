#include "colmap_irav4/refinement/fold_detection.h"

#include "colmap_irav4/pipeline/component_mapper.h"

#include <cmath>
#include <functional>
#include <memory>
#include <random>
#include <set>

#include <gtest/gtest.h>

#include "colmap_irav4/util/error.h"

namespace colmap_irav4 {
namespace {

// A courtyard whose opposite walls look alike: points on four walls of a
// square, symmetric under M = 180 deg about the vertical (y) axis; cameras
// on a circle around the centre looking outward. The truth model, and a
// folded one where the cameras of one half sit at their mirrored twin's place
// (centre M c, rotation R M^T: the twin sees M X where the camera sees X).
struct Courtyard {
  Reconstruction truth;
  Reconstruction folded;
  FoldEvidence evidence;
  std::set<image_t> folded_images;
  std::set<std::pair<image_t, image_t>> false_pairs;
};

Eigen::Matrix3d Mirror() {
  return Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitY()).toRotationMatrix();
}

// Visible points of each image: in front, inside the image.
std::vector<point3D_t> Visible(const Reconstruction& model,
                               const Image& image) {
  const Camera& camera = model.cameras.at(image.camera_id);
  std::vector<point3D_t> visible;
  for (const auto& [id, point] : model.points3D) {
    const Eigen::Vector3d x = image.cam_from_world * point.xyz;
    if (x.z() <= 0.1) continue;
    const double u = camera.params[0] * x.x() / x.z() + camera.params[2];
    const double v = camera.params[1] * x.y() / x.z() + camera.params[3];
    if (u >= 0 && v >= 0 && u <= camera.width && v <= camera.height) {
      visible.push_back(id);
    }
  }
  return visible;
}

Courtyard MakeCourtyard(int num_cameras, double false_pair_rate,
                        uint64_t seed) {
  Courtyard scene;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uniform(-1, 1);
  Camera camera;
  camera.camera_id = 1;
  camera.model_id = 1;  // PINHOLE
  camera.width = 1000;
  camera.height = 800;
  camera.params = {600, 600, 500, 400};
  scene.truth.cameras[1] = camera;
  // Points: walls z = +-10 and x = +-10, each point and its mirror (ids 2k,
  // 2k + 1).
  const Eigen::Matrix3d M = Mirror();
  point3D_t next_id = 0;
  std::map<point3D_t, point3D_t> mirror_of;
  for (int k = 0; k < 600; ++k) {
    Eigen::Vector3d X;
    const double s = 10 * uniform(rng);
    const double h = 3 * uniform(rng);
    X = k % 2 == 0 ? Eigen::Vector3d(s, h, 10) : Eigen::Vector3d(10, h, s);
    scene.truth.points3D[next_id].xyz = X;
    scene.truth.points3D[next_id + 1].xyz = M * X;
    mirror_of[next_id] = next_id + 1;
    mirror_of[next_id + 1] = next_id;
    next_id += 2;
  }
  // Cameras on a circle of radius 3 looking outward.
  for (int i = 0; i < num_cameras; ++i) {
    const double angle = 2 * M_PI * i / num_cameras + 0.01;
    const Eigen::Vector3d center(3 * std::sin(angle), 0.2 * uniform(rng),
                                 3 * std::cos(angle));
    // Camera z axis (world) = outward direction; y axis = world y (down).
    const Eigen::Vector3d z(std::sin(angle), 0, std::cos(angle));
    const Eigen::Vector3d y = Eigen::Vector3d::UnitY();
    const Eigen::Vector3d x = y.cross(z);
    Eigen::Matrix3d R;
    R.row(0) = x.transpose();
    R.row(1) = y.transpose();
    R.row(2) = z.transpose();
    Image image;
    image.image_id = i + 1;
    image.name = "image" + std::to_string(i + 1);
    image.camera_id = 1;
    image.cam_from_world.rotation = Eigen::Quaterniond(R);
    image.cam_from_world.translation = -R * center;
    scene.truth.images[image.image_id] = image;
  }
  // Observations.
  std::map<image_t, std::set<point3D_t>> seen;
  for (auto& [image_id, image] : scene.truth.images) {
    for (const point3D_t id : Visible(scene.truth, image)) {
      seen[image_id].insert(id);
      Point2D point2D;
      point2D.point3D_id = id;
      image.points2D.push_back(point2D);
      scene.truth.points3D[id].track.push_back(
          {image_id, static_cast<point2D_t>(image.points2D.size() - 1)});
    }
  }
  // Evidence: true pairs (common points) and false mirror-twin pairs (points
  // of one image whose mirror the other sees), a fraction of them, with
  // fewer inliers.
  std::uniform_real_distribution<double> unit(0, 1);
  for (const auto& [i, image_i] : scene.truth.images) {
    for (const auto& [j, image_j] : scene.truth.images) {
      if (j <= i) continue;
      int common = 0;
      int mirrored = 0;
      for (const point3D_t id : seen[i]) {
        common += seen[j].count(id);
        mirrored += seen[j].count(mirror_of.at(id));
      }
      const Eigen::Matrix3d Ri =
          image_i.cam_from_world.rotation.toRotationMatrix();
      const Eigen::Matrix3d Rj =
          image_j.cam_from_world.rotation.toRotationMatrix();
      PairEvidence pair;
      pair.image_id1 = i;
      pair.image_id2 = j;
      if (common >= 15) {
        pair.num_inliers = common;
        pair.has_rotation = true;
        pair.R = Rj * Ri.transpose();
      } else if (mirrored >= 30 && unit(rng) < false_pair_rate) {
        pair.num_inliers = mirrored / 2;
        pair.has_rotation = true;
        pair.R = Rj * M * Ri.transpose();
        scene.false_pairs.insert({i, j});
      }
      scene.evidence.pairs.push_back(pair);  // every pair was tried
    }
  }
  // The folded model: cameras looking towards +x (the east half) are
  // replaced by their twins and their observations relinked to the mirrors.
  scene.folded = scene.truth;
  for (auto& [id, point] : scene.folded.points3D) point.track.clear();
  for (auto& [image_id, image] : scene.folded.images) {
    const Eigen::Matrix3d R = image.cam_from_world.rotation.toRotationMatrix();
    const Eigen::Vector3d center = image.ProjectionCenter();
    const bool fold = center.x() > 0;
    if (fold) {
      scene.folded_images.insert(image_id);
      const Eigen::Matrix3d R_twin = R * M.transpose();
      image.cam_from_world.rotation = Eigen::Quaterniond(R_twin);
      image.cam_from_world.translation = -R_twin * (M * center);
    }
    for (size_t k = 0; k < image.points2D.size(); ++k) {
      point3D_t& id = image.points2D[k].point3D_id;
      if (fold) id = mirror_of.at(id);
      scene.folded.points3D[id].track.push_back(
          {image_id, static_cast<point2D_t>(k)});
    }
  }
  return scene;
}

TEST(FoldDetection, CorrectModelIsClean) {
  const Courtyard scene = MakeCourtyard(40, 0.3, 1);
  ASSERT_GT(scene.false_pairs.size(), 10u);
  const FoldReport report =
      DetectFold(FoldDetectionOptions(), scene.truth, scene.evidence);
  EXPECT_FALSE(report.folded) << report.Describe();
  EXPECT_GT(report.num_predicted_pairs, 50);
  EXPECT_LT(report.fold_score, 0.02) << report.Describe();
  EXPECT_EQ(report.num_contradictory_tracks, 0);
  // The false pairs are what the correct model contradicts.
  EXPECT_EQ(report.num_inconsistent_pairs,
            static_cast<int>(scene.false_pairs.size()));
  EXPECT_TRUE(report.suspect_pairs.empty()) << report.suspect_pairs.size();
}

TEST(FoldDetection, FoldedModelIsDetectedAndItsFalsePairsSuspected) {
  const Courtyard scene = MakeCourtyard(40, 0.3, 2);
  ASSERT_GT(scene.folded_images.size(), 10u);
  const FoldReport report =
      DetectFold(FoldDetectionOptions(), scene.folded, scene.evidence);
  EXPECT_TRUE(report.folded) << report.Describe();
  EXPECT_GT(report.fold_score, 0.3) << report.Describe();
  // True pairs across the fold are contradicted, with their full inliers.
  EXPECT_GT(report.num_strong_inconsistent_pairs, 5);
  // Suspects are the false pairs the fold made consistent.
  ASSERT_FALSE(report.suspect_pairs.empty());
  int num_false = 0;
  for (const auto& pair : report.suspect_pairs) {
    num_false += scene.false_pairs.count(pair);
  }
  // A few true pairs at the fold's border are suspected too (their images'
  // predicted neighbours across the fold do not match them).
  EXPECT_GE(num_false * 5, static_cast<int>(report.suspect_pairs.size()) * 4)
      << num_false << " of " << report.suspect_pairs.size();
  // Most false pairs the fold made consistent are suspected.
  int num_consistent_false = 0;
  for (const auto& [a, b] : scene.false_pairs) {
    const Eigen::Matrix3d Ra =
        scene.folded.images.at(a).cam_from_world.rotation.toRotationMatrix();
    const Eigen::Matrix3d Rb =
        scene.folded.images.at(b).cam_from_world.rotation.toRotationMatrix();
    for (const PairEvidence& pair : scene.evidence.pairs) {
      if (pair.image_id1 == a && pair.image_id2 == b &&
          (pair.R - Rb * Ra.transpose()).norm() < 1e-6) {
        ++num_consistent_false;
      }
    }
  }
  EXPECT_GE(num_false * 2, num_consistent_false)
      << num_false << " of " << num_consistent_false;
}

TEST(FoldDetection, CutSeparatesTheFoldedHalf) {
  const Courtyard scene = MakeCourtyard(40, 0.3, 3);
  const FoldDetectionOptions options;
  const FoldReport report = DetectFold(options, scene.folded, scene.evidence);
  ASSERT_TRUE(report.folded);
  const auto [side1, side2] =
      FoldCut(options, scene.folded, scene.evidence, report);
  ASSERT_FALSE(side2.empty());
  EXPECT_EQ(side1.size() + side2.size(), scene.folded.images.size());
  // Each side is (almost) entirely folded or entirely unfolded.
  for (const std::vector<image_t>* side : {&side1, &side2}) {
    int folded = 0;
    for (const image_t image_id : *side) {
      folded += scene.folded_images.count(image_id);
    }
    const int n = static_cast<int>(side->size());
    EXPECT_TRUE(folded <= n / 10 || folded >= n - n / 10)
        << folded << " of " << n;
  }
}

// A folded courtyard (A, images 1-40) and a correct one (B, images
// 1001-1040) placed over it, sharing no point (a photo collection's
// landmarks, placed by false pairs), with a few missing pairs within B (no
// fold: a poor overlap prediction) and many between B and A: B's east half
// with A's folded images, its west half with A's others. The cut of the
// whole model divides B by them.
struct TwoLandmarks {
  static constexpr image_t kOffset = 1000;  // B's image ids
  Courtyard a = MakeCourtyard(40, 0.3, 3);
  Reconstruction model;
  FoldEvidence evidence;
  FoldReport report;

  TwoLandmarks() {
    const Courtyard b = MakeCourtyard(40, 0.0, 6);
    report = DetectFold(FoldDetectionOptions(), a.folded, a.evidence);
    model = a.folded;
    evidence = a.evidence;
    std::vector<image_t> a_folded;
    std::vector<image_t> a_unfolded;
    for (const auto& [image_id, image] : a.folded.images) {
      (a.folded_images.count(image_id) ? a_folded : a_unfolded)
          .push_back(image_id);
    }
    const point3D_t point_offset = 100000;
    for (const auto& [point_id, point] : b.truth.points3D) {
      Point3D copy = point;
      for (TrackElement& element : copy.track) element.image_id += kOffset;
      model.points3D[point_id + point_offset] = copy;
    }
    for (const auto& [image_id, image] : b.truth.images) {
      Image copy = image;
      copy.image_id = image_id + kOffset;
      for (Point2D& point2D : copy.points2D) {
        point2D.point3D_id += point_offset;
      }
      model.images[copy.image_id] = copy;
      const std::vector<image_t>& across =
          image.ProjectionCenter().x() > 0 ? a_folded : a_unfolded;
      for (size_t k = 0; k < 8; ++k) {
        report.missing_pairs.emplace_back(
            across[(image_id * 7 + k * 3) % across.size()], copy.image_id);
      }
    }
    for (image_t image_id = 1; image_id <= 40; image_id += 5) {
      report.missing_pairs.emplace_back(image_id + kOffset,
                                        (image_id + 1) % 40 + 1 + kOffset);
    }
    for (PairEvidence pair : b.evidence.pairs) {
      pair.image_id1 += kOffset;
      pair.image_id2 += kOffset;
      evidence.pairs.push_back(pair);
    }
  }

  // False pairs between A and B that the model agrees with (as a photo
  // collection's random pairs that placed B), each at its own images.
  void AddAgreedFalsePairs(int num_pairs) {
    for (image_t k = 1; k <= static_cast<image_t>(num_pairs); ++k) {
      PairEvidence pair;
      pair.image_id1 = 7 * k;
      pair.image_id2 = kOffset + 7 * k + 2;
      pair.num_inliers = 40;
      pair.verified = true;
      pair.has_rotation = true;
      pair.R = model.images.at(pair.image_id2)
                   .cam_from_world.rotation.toRotationMatrix() *
               model.images.at(pair.image_id1)
                   .cam_from_world.rotation.toRotationMatrix()
                   .transpose();
      evidence.pairs.push_back(pair);
    }
  }

  int NumB(const std::vector<image_t>& side) const {
    return static_cast<int>(std::count_if(
        side.begin(), side.end(), [](image_t id) { return id > kOffset; }));
  }

  // B whole on the first side, each side's images of A (nearly) all folded
  // or all not.
  void ExpectBWholeAndAPure(const std::vector<image_t>& side1,
                            const std::vector<image_t>& side2) const {
    EXPECT_EQ(NumB(side1), 40);
    EXPECT_EQ(NumB(side2), 0);
    for (const std::vector<image_t>* side : {&side1, &side2}) {
      int folded = 0;
      int n = 0;
      for (const image_t image_id : *side) {
        if (image_id > kOffset) continue;
        folded += a.folded_images.count(image_id);
        ++n;
      }
      EXPECT_TRUE(folded <= n / 10 || folded >= n - n / 10)
          << folded << " of " << n;
    }
  }
};

TEST(FoldDetection, CutPerPartKeepsAPartWithoutAFoldWhole) {
  TwoLandmarks scene;
  ASSERT_TRUE(scene.report.folded);
  FoldDetectionOptions options;
  // One cut through the whole model splits B, which has no fold.
  options.cut_keep_unfolded_parts = false;
  const auto [whole1, whole2] =
      FoldCut(options, scene.model, scene.evidence, scene.report);
  ASSERT_FALSE(whole2.empty());
  EXPECT_GT(scene.NumB(whole1), 0);
  EXPECT_GT(scene.NumB(whole2), 0);
  // The same cut with B, whose own cut finds no fold, kept whole (on the
  // side holding most of it); A's sides are the whole model's cut's.
  options.cut_keep_unfolded_parts = true;
  const auto [kept1, kept2] =
      FoldCut(options, scene.model, scene.evidence, scene.report);
  ASSERT_FALSE(kept2.empty());
  EXPECT_TRUE(scene.NumB(kept1) == 40 || scene.NumB(kept2) == 40)
      << scene.NumB(kept1) << " | " << scene.NumB(kept2);
  const auto a_images = [](const std::vector<image_t>& side) {
    std::set<image_t> a;
    for (const image_t id : side) {
      if (id <= TwoLandmarks::kOffset) a.insert(id);
    }
    return a;
  };
  EXPECT_EQ(a_images(kept1), a_images(whole1));
  EXPECT_EQ(a_images(kept2), a_images(whole2));
  // Cut part by part: B whole, A's folded half still separated.
  for (const FoldCutParts parts :
       {FoldCutParts::kRigidParts, FoldCutParts::kAgreeingParts}) {
    SCOPED_TRACE(EnumName(parts));
    options.cut_parts = parts;
    const auto [side1, side2] =
        FoldCut(options, scene.model, scene.evidence, scene.report);
    ASSERT_FALSE(side2.empty());
    scene.ExpectBWholeAndAPure(side1, side2);
  }
}

TEST(FoldDetection, AgreeingPartsAreNotJoinedByPairsOutsideTriangles) {
  TwoLandmarks scene;
  scene.AddAgreedFalsePairs(5);
  FoldDetectionOptions options;
  options.cut_parts = FoldCutParts::kAgreeingParts;
  const auto [side1, side2] =
      FoldCut(options, scene.model, scene.evidence, scene.report);
  ASSERT_FALSE(side2.empty());
  scene.ExpectBWholeAndAPure(side1, side2);
  // Counting every agreed pair, the false ones join A and B into one part,
  // cut as the whole model is.
  options.cut_min_pair_triangles = 0;
  const auto [joined1, joined2] =
      FoldCut(options, scene.model, scene.evidence, scene.report);
  ASSERT_FALSE(joined2.empty());
  EXPECT_GT(scene.NumB(joined1), 0);
  EXPECT_GT(scene.NumB(joined2), 0);
}

// The true pairs across the fold, which the folded model contradicts all by
// the symmetry's rotation, separate the folded half on their own
// (--Fold.cut_fold_rotation_pairs): here the report's missing pairs are
// taken away and its weak pairs no longer push apart (they are still not
// trusted), and without them the cut finds nothing.
TEST(FoldDetection, FoldRotationPairsSeparateTheFoldedHalf) {
  const Courtyard scene = MakeCourtyard(40, 0.3, 3);
  FoldDetectionOptions options;
  FoldReport report = DetectFold(options, scene.folded, scene.evidence);
  ASSERT_TRUE(report.folded);
  report.missing_pairs.clear();
  for (PairSupport& support : report.pair_support) support.predicted = false;
  const auto [without1, without2] =
      FoldCut(options, scene.folded, scene.evidence, report);
  EXPECT_TRUE(without2.empty());
  options.cut_fold_rotation_pairs = true;
  const auto [side1, side2] =
      FoldCut(options, scene.folded, scene.evidence, report);
  ASSERT_FALSE(side2.empty());
  EXPECT_EQ(side1.size() + side2.size(), scene.folded.images.size());
  int folded1 = 0;
  int folded2 = 0;
  for (const image_t image_id : side1) {
    folded1 += scene.folded_images.count(image_id);
  }
  for (const image_t image_id : side2) {
    folded2 += scene.folded_images.count(image_id);
  }
  // One side the folded images, the other the rest (at most 10% astray).
  const int n1 = static_cast<int>(side1.size());
  const int n2 = static_cast<int>(side2.size());
  EXPECT_TRUE((folded1 <= n1 / 10 && folded2 >= n2 - n2 / 10) ||
              (folded2 <= n2 / 10 && folded1 >= n1 - n1 / 10))
      << folded1 << " of " << n1 << ", " << folded2 << " of " << n2;
  // Too few such pairs for the option's minimum: no fold rotation, no cut.
  options.cut_min_fold_rotation_pairs = 100000;
  EXPECT_TRUE(
      FoldCut(options, scene.folded, scene.evidence, report).second.empty());
}

TEST(FoldDetection, NoCutOnACorrectModel) {
  const Courtyard scene = MakeCourtyard(40, 0.3, 4);
  const FoldDetectionOptions options;
  const FoldReport report = DetectFold(options, scene.truth, scene.evidence);
  const auto [side1, side2] =
      FoldCut(options, scene.truth, scene.evidence, report);
  EXPECT_TRUE(side2.empty());
  EXPECT_EQ(side1.size(), scene.truth.images.size());
}

TEST(FoldDetection, UntriedPairsAreNotMissing) {
  Courtyard scene = MakeCourtyard(40, 0.3, 5);
  // Only the verified pairs are recorded, as from a database whose raw
  // matches were deleted... and absent pairs are then not counted as tried.
  FoldEvidence evidence;
  for (const PairEvidence& pair : scene.evidence.pairs) {
    if (pair.num_inliers > 0) evidence.pairs.push_back(pair);
  }
  evidence.absent_pairs_were_tried = false;
  const FoldReport report =
      DetectFold(FoldDetectionOptions(), scene.folded, evidence);
  EXPECT_EQ(report.num_missing_pairs, 0);
  evidence.absent_pairs_were_tried = true;
  EXPECT_TRUE(
      DetectFold(FoldDetectionOptions(), scene.folded, evidence).folded);
}

// A signed graph with a small eigenvalue gap, as a large model's: a ring of
// n images, each pulled to its 3 neighbours on either side within its half,
// the two halves pushed apart by pairs of opposite images, and a few false
// pairs the other way. 300
// power iterations leave the eigenvector near its start and the cut mixes
// the halves; iterated until it converges, the cut is the halves.
TEST(FoldDetection, SignedGraphCutConvergesOnASmallGap) {
  const int n = 400;
  std::vector<std::tuple<int, int, double>> edges;
  for (int i = 0; i < n; ++i) {
    for (int d = 1; d <= 3; ++d) {
      const int j = (i + d) % n;
      if ((i < n / 2) == (j < n / 2)) edges.emplace_back(i, j, 1.0);
    }
    if (i < n / 2) edges.emplace_back(i, i + n / 2, -1.0);
    // A few false pairs: one image in four pushed from a neighbour of its
    // half and pulled to one of the other.
    if (i % 4 == 0) {
      edges.emplace_back(i, (i + 5) % n, -0.5);
      edges.emplace_back(i, (i + n / 2 + 7) % n, 0.5);
    }
  }
  const auto num_astray = [&](const std::vector<int>& side) {
    int astray = 0;  // images not on their half's majority side
    for (int i = 0; i < n; ++i)
      astray += side[i] != side[i < n / 2 ? 0 : n - 1];
    return std::min(astray, n - astray);
  };
  const std::vector<int> fixed = SignedGraphCut(n, edges);
  EXPECT_GT(num_astray(fixed), 0);
  const std::vector<int> converged = SignedGraphCut(n, edges, 20000);
  EXPECT_EQ(num_astray(converged), 0);
  EXPECT_NE(converged[0], converged[n - 1]);
}

TEST(FoldDetection, CheckNamesTheOption) {
  FoldResolutionOptions options;
  EXPECT_NO_THROW(options.Check());
  options.detection.max_fold_score = 2;
  try {
    options.Check();
    FAIL();
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("--Fold.max_fold_score"),
              std::string::npos);
  }
  options = FoldResolutionOptions();
  options.max_iterations = -1;
  EXPECT_THROW(options.Check(), InputError);
}

// The model `choose` picks from an attempt's pairs (the truth or the folded
// one).
typedef std::function<const Reconstruction&(
    const std::vector<ImagePairGeometry>&)>
    ChooseModel;

// A stand-in GlobalMapper: its stages "map" the attempt's images by copying
// the chosen model; the fold checks are GlobalMapper's own.
class StandInMapper : public GlobalMapper {
 public:
  StandInMapper(const GlobalMapperOptions& options,
                const std::vector<image_t>& images,
                const std::vector<ImagePairGeometry>& pairs,
                const std::string& prefix, const FoldEvidence* evidence,
                const ChooseModel& choose)
      : GlobalMapper(options, database_, cameras_, images, pairs, prefix,
                     evidence),
        choose_(choose) {}

  bool RotationAveraging() override {
    reconstruction() = choose_(pairs());
    const std::set<image_t> keep(images().begin(), images().end());
    auto& model_images = reconstruction().images;
    for (auto it = model_images.begin(); it != model_images.end();) {
      it = keep.count(it->first) ? std::next(it) : model_images.erase(it);
    }
    return true;
  }
  bool RotationFilter() override { return true; }
  bool BuildTracks() override { return true; }
  bool Positioning() override { return true; }
  bool IterativeBundleAdjustment() override { return true; }
  bool Finalize() override { return true; }

 private:
  static inline const DatabaseContents database_{};
  static inline const std::map<camera_t, Camera> cameras_{};
  ChooseModel choose_;
};

// The component mapper around the stand-in; counts the attempts.
class StandInComponentMapper : public ComponentMapper {
 public:
  StandInComponentMapper(const GlobalMapperOptions& options, ChooseModel choose,
                         int* num_runs)
      : ComponentMapper(options, database_, cameras_),
        choose_(std::move(choose)),
        num_runs_(num_runs) {}

 protected:
  std::unique_ptr<GlobalMapper> NewMapper(
      const std::vector<image_t>& images,
      const std::vector<ImagePairGeometry>& pairs, const std::string& prefix,
      const FoldEvidence* evidence) const override {
    ++*num_runs_;
    return std::make_unique<StandInMapper>(options(), images, pairs, prefix,
                                           evidence, choose_);
  }

 private:
  static inline const DatabaseContents database_{};
  static inline const std::map<camera_t, Camera> cameras_{};
  ChooseModel choose_;
  int* num_runs_;
};

// Mapper options with min_model_size 3 and the given fold options.
GlobalMapperOptions WithFold(const FoldResolutionOptions& fold) {
  GlobalMapperOptions options;
  options.min_model_size = 3;
  options.fold = fold;
  return options;
}

// The resolution around a stand-in mapper that folds the courtyard while
// enough false pairs join the two halves, and maps it right otherwise.
TEST(FoldResolution, ReorientsAcrossTheCutOrSplitsNeverWritesAFold) {
  const Courtyard scene = MakeCourtyard(40, 0.3, 6);
  std::vector<ImagePairGeometry> pairs;
  std::vector<image_t> images;
  for (const auto& [image_id, image] : scene.truth.images) {
    images.push_back(image_id);
  }
  for (const PairEvidence& evidence : scene.evidence.pairs) {
    if (!evidence.has_rotation) continue;
    ImagePairGeometry pair;
    pair.image_id1 = evidence.image_id1;
    pair.image_id2 = evidence.image_id2;
    pair.R = evidence.R;
    pair.num_inliers = evidence.num_inliers;
    pairs.push_back(pair);
  }
  int num_runs = 0;
  const ChooseModel choose =
      [&](const std::vector<ImagePairGeometry>& map_pairs)
      -> const Reconstruction& {
    int num_cross_false = 0;
    for (const ImagePairGeometry& pair : map_pairs) {
      num_cross_false +=
          scene.false_pairs.count({pair.image_id1, pair.image_id2}) &&
          scene.folded_images.count(pair.image_id1) !=
              scene.folded_images.count(pair.image_id2);
    }
    return num_cross_false > 5 ? scene.folded : scene.truth;
  };
  FoldResolutionOptions options;
  StandInComponentMapper mapper(WithFold(options), choose, &num_runs);
  const std::vector<ComponentModel> models =
      mapper.Map(scene.evidence, images, pairs);
  ASSERT_FALSE(models.empty()) << mapper.failure();
  for (const ComponentModel& model : models) {
    EXPECT_TRUE(model.mapper->fold_checked());
    EXPECT_FALSE(model.folded) << model.fold_outcome;
    EXPECT_FALSE(model.mapper->fold().folded) << model.fold_outcome;
    EXPECT_EQ(model.fold_outcome.find("folded"), std::string::npos)
        << model.fold_outcome;
  }
  EXPECT_GE(num_runs, 2);
  EXPECT_FALSE(mapper.notes().empty());

  // Without resolution the fold is reported, not hidden.
  options.resolve = false;
  StandInComponentMapper unresolving(WithFold(options), choose, &num_runs);
  const std::vector<ComponentModel> unresolved =
      unresolving.Map(scene.evidence, images, pairs);
  ASSERT_EQ(unresolved.size(), 1u);
  EXPECT_TRUE(unresolved[0].folded);
  EXPECT_GT(unresolved[0].mapper->fold().fold_score, 0.1);
  EXPECT_EQ(unresolved[0].fold_outcome, "folded (not resolved)");
  ASSERT_EQ(unresolving.notes().size(), 1u);
  EXPECT_NE(unresolving.notes()[0].find("folded"), std::string::npos);
}

TEST(FoldResolution, CleanModelIsMappedOnceAndCheckedTwice) {
  const Courtyard scene = MakeCourtyard(40, 0.0, 7);
  std::vector<image_t> images;
  for (const auto& [image_id, image] : scene.truth.images) {
    images.push_back(image_id);
  }
  int num_runs = 0;
  StandInComponentMapper mapper(
      WithFold(FoldResolutionOptions()),
      [&](const std::vector<ImagePairGeometry>&) -> const Reconstruction& {
        return scene.truth;
      },
      &num_runs);
  const std::vector<ComponentModel> models =
      mapper.Map(scene.evidence, images, {});
  ASSERT_EQ(models.size(), 1u);
  EXPECT_EQ(num_runs, 1);
  EXPECT_EQ(models[0].fold_outcome, "clean");
  EXPECT_LT(models[0].mapper->fold().fold_score, 0.02);
  // After positioning and after refinement (then the rigidity check), in the
  // order they ran.
  std::vector<std::string> names;
  for (const StageReport& stage : models[0].mapper->stages()) {
    names.push_back(stage.name);
  }
  EXPECT_EQ(names, (std::vector<std::string>{"fold check (after positioning)",
                                             "fold check (after refinement)",
                                             "rigidity check"}));
  EXPECT_TRUE(mapper.notes().empty());
}

}  // namespace
}  // namespace colmap_irav4
