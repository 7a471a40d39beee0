// The mapper on photo collections from the project's generator
// (eval/scene_generator.h, SceneLayout::kPhoto): one camera per image,
// 30% of them without a prior focal (COLMAP's guess 1.2 x max(width,
// height), off by up to a factor 3), radial distortion, two landmarks that
// no true pair joins, 10% random false pairs (some of them across the
// landmarks) and mirror-twin pairs. Each landmark must come out as its own
// model (no model mixes the two), holding most of its images, with the focal
// lengths recovered.

#include <algorithm>
#include <cstdio>
#include <map>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "colmap_irav4/eval/model_alignment.h"
#include "colmap_irav4/eval/scene_generator.h"
#include "colmap_irav4/io/database.h"
#include "colmap_irav4/pipeline/global_pipeline.h"
#include "colmap_irav4/util/statistics.h"
#include "tests/test_utils/database_test_utils.h"

namespace colmap_irav4 {
namespace {

SceneGeneratorOptions PhotoOptions(uint64_t seed) {
  SceneGeneratorOptions options;
  options.layout = SceneLayout::kPhoto;
  options.num_images = 50;
  options.num_parts = 2;
  options.point_density = 10;
  options.noise_px = 0.5;
  options.random_pair_rate = 0.1;
  options.mirror_pair_rate = 0.05;
  options.seed = seed;
  return options;
}

// Maps the scene of `seed` with `options` and checks the models (above);
// *summary gets the run's summary.
void MapAndCheckPhotoCollection(uint64_t seed,
                                const GlobalMapperOptions& options,
                                GlobalMapperSummary* summary_out) {
  {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const GeneratedScene scene = GenerateScene(PhotoOptions(seed));
    test::TempDir temp;
    WriteSceneDatabase(scene, temp.File("database.db"));
    const DatabaseContents contents = ReadDatabase(temp.File("database.db"));
    GlobalMapperSummary& summary = *summary_out;
    const std::vector<Reconstruction> models =
        RunGlobalMapper(options, contents, "", &summary);
    ASSERT_FALSE(models.empty());

    // The images a true pair connects, by part.
    std::set<image_t> connected;
    std::vector<int> num_connected(2, 0);
    for (const GeneratedPair& pair : scene.pairs) {
      if (pair.kind != PairKind::kTrue) continue;
      for (const image_t image_id : {pair.image_id1, pair.image_id2}) {
        if (connected.insert(image_id).second) {
          ++num_connected[scene.image_parts.at(image_id - 1)];
        }
      }
    }
    ASSERT_GT(num_connected[1], 10);

    std::vector<int> largest_share(2, 0);
    std::vector<double> with_prior, without_prior, rotation_medians;
    for (const Reconstruction& model : models) {
      std::map<int, int> parts;
      for (const auto& [image_id, image] : model.images) {
        if (connected.count(image_id)) {
          ++parts[scene.image_parts.at(image_id - 1)];
        }
      }
      // No model mixes the landmarks (only false pairs join them).
      EXPECT_LE(parts.size(), 1u);
      for (const auto& [part, count] : parts) {
        largest_share[part] = std::max(largest_share[part], count);
      }
      const FocalErrors focal = CompareFocalLengths(model, scene.truth);
      for (const auto& [image_id, image] : model.images) {
        if (!connected.count(image_id)) continue;
        const double error = focal.relative_errors.at(image.name);
        (scene.database_cameras.at(image.camera_id).has_prior_focal_length
             ? with_prior
             : without_prior)
            .push_back(error);
      }
      PoseComparison comparison;
      if (model.images.size() >= 3 &&
          ComparePoses(PosesByName(model), PosesByName(scene.truth),
                       SimilarityRansacOptions(), &comparison)) {
        rotation_medians.push_back(comparison.rotation_error_median_deg);
      }
    }
    // Most of each landmark in one model (the mapper's own rule for a
    // re-mapped model that keeps "most" of the images: 3 of 4).
    for (int part = 0; part < 2; ++part) {
      EXPECT_GE(4 * largest_share[part], 3 * num_connected[part])
          << "part " << part;
    }
    // The focal lengths: better than the EXIF priors themselves (uniform
    // within +-5%: median error 2.5%), for the images with a prior and for
    // those that had only COLMAP's guess.
    ASSERT_GT(with_prior.size(), 10u);
    ASSERT_GT(without_prior.size(), 5u);
    EXPECT_LT(Median(with_prior), 0.025);
    EXPECT_LT(Median(without_prior), 0.025);
    // 0.5 px of keypoint noise at focal lengths >= 700 px: 0.04 deg per
    // observation; a camera's rotation from hundreds of them is far better,
    // so a median 10 times that bounds a correct model.
    for (const double median : rotation_medians) EXPECT_LT(median, 0.4);
  }
}

TEST(PhotoCollectionE2E, PartsAreSeparateModelsWithTheirFocalLengths) {
  for (const uint64_t seed : {1, 2, 3}) {
    GlobalMapperSummary summary;
    MapAndCheckPhotoCollection(seed, GlobalMapperOptions(), &summary);
  }
}

// The second pass (relative poses derived again with the first mapping's
// refined cameras) runs on every registered image's camera and keeps the
// models' properties.
TEST(PhotoCollectionE2E, RecalibratedSecondPassKeepsTheModels) {
  GlobalMapperOptions options;
  options.recalibrated_second_pass = true;
  GlobalMapperSummary summary;
  MapAndCheckPhotoCollection(1, options, &summary);
  int num_view_graphs = 0;
  for (const StageReport& stage : summary.stages) {
    num_view_graphs += stage.name.rfind("view graph", 0) == 0;
  }
  EXPECT_EQ(num_view_graphs, 2);
  int num_registered = 0;
  for (const ComponentReport& component : summary.components) {
    num_registered += component.num_registered_images;
  }
  bool noted = false;
  for (const std::string& note : summary.notes) {
    // One camera per image: at least as many cameras as the second pass
    // registers, less the few only the second pass registers.
    int num_cameras = 0;
    if (std::sscanf(note.c_str(), "second pass with %d camera", &num_cameras) ==
        1) {
      noted = true;
      EXPECT_GE(num_cameras, num_registered * 9 / 10);
    }
  }
  EXPECT_TRUE(noted);
}

}  // namespace
}  // namespace colmap_irav4
