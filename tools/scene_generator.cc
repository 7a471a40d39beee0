// Generates a synthetic scene with exact ground truth: a new COLMAP 3.8
// database (cameras, images, keypoints, matches, verified two-view
// geometries) and the true model, for benchmarks and the symmetric-scene
// protocol (see colmap_irav4/eval/scene_generator.h):
//   scene_generator --output_path OUT --layout courtyard --num_images 1000
//       [--mirror_pair_rate 0.1] [--random_pair_rate 0.02] [--seed 3] ...
// writes OUT/database.db, OUT/gt/{cameras,images,points3D}.bin and
// OUT/pairs.txt (one line per written pair: IMAGE_ID1 IMAGE_ID2 KIND
// NUM_INLIERS, KIND true|mirror|random); the photo layout also
// OUT/image_parts.txt (IMAGE_NAME PART, its landmark); with --pose_priors 1
// also GPS-like
// priors and gravity (database_colmap311.db, database_colmap4.db,
// pose_priors_enu.txt, pose_priors_wgs84.txt, gt_prior: the truth in their
// frame).

#include <filesystem>
#include <fstream>
#include <functional>
#include <iomanip>
#include <iostream>
#include <sstream>

#include <glog/logging.h>

#include "colmap_irav4/eval/scene_generator.h"
#include "colmap_irav4/io/model_io.h"
#include "colmap_irav4/scene/reconstruction_utils.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/option_manager.h"
#include "colmap_irav4/util/timer.h"

using namespace colmap_irav4;

namespace {

std::vector<std::string> SplitComma(const std::string& text) {
  std::vector<std::string> parts;
  std::stringstream stream(text);
  std::string part;
  while (std::getline(stream, part, ',')) {
    if (!part.empty()) parts.push_back(part);
  }
  return parts;
}

// Writes `path` through `write`, to a temporary name renamed when complete.
void WriteTextFile(const std::string& path,
                   const std::function<void(std::ostream&)>& write) {
  std::ofstream file(path + ".tmp");
  write(file);
  file.close();
  if (!file) throw InputError(path, "cannot write");
  std::filesystem::rename(path + ".tmp", path);
}

// Pose prior options (scene_generator.h's PosePriorGeneratorOptions).
void AddPosePriorOptions(OptionManager* manager, bool* pose_priors,
                         PosePriorGeneratorOptions* options) {
  manager->Add("pose_priors", pose_priors,
               "GPS-like priors and gravity: database.db's images.prior_t* "
               "(COLMAP 3.8), database_colmap311.db / database_colmap4.db "
               "(pose_priors tables), pose_priors_enu.txt, "
               "pose_priors_wgs84.txt and gt_prior (the truth in their "
               "east-north-up frame)");
  manager->Add("prior_horizontal_std", &options->horizontal_std,
               "GPS noise east and north (m)");
  manager->Add("prior_vertical_std", &options->vertical_std,
               "GPS noise up (m)");
  manager->Add("prior_outlier_fraction", &options->outlier_fraction,
               "fraction of GPS outliers");
  manager->Add("prior_outlier_min_distance", &options->outlier_min_distance,
               "outliers' smallest offset (m)");
  manager->Add("prior_outlier_max_distance", &options->outlier_max_distance,
               "outliers' largest offset (m)");
  manager->Add("prior_gravity_std", &options->gravity_std_deg,
               "gravity noise per tilt axis (deg)");
}

// Writes the priors next to the scene (see AddPosePriorOptions).
void WriteScenePosePriors(const GeneratedScene& scene,
                          const PosePriorGeneratorOptions& options,
                          const std::filesystem::path& out) {
  const GeneratedPosePriors priors = GeneratePosePriors(scene, options);
  const std::string database = (out / "database.db").string();
  for (const char* schema : {"colmap311", "colmap4"}) {
    const std::string path =
        (out / ("database_" + std::string(schema) + ".db")).string();
    std::filesystem::remove(path);
    std::filesystem::copy_file(
        database, path + ".tmp",
        std::filesystem::copy_options::overwrite_existing);
    WritePosePriorsToDatabase(path + ".tmp", PosePriorSchemaFromName(schema),
                              priors.wgs84);
    std::filesystem::rename(path + ".tmp", path);
  }
  WritePosePriorsToDatabase(database, PosePriorSchema::kColmap38, priors.wgs84);
  WritePosePriorText(scene, priors, false,
                     (out / "pose_priors_enu.txt").string());
  WritePosePriorText(scene, priors, true,
                     (out / "pose_priors_wgs84.txt").string());
  std::filesystem::remove_all(out / "gt_prior");
  WriteReconstruction(TruthInPriorFrame(scene, priors),
                      (out / "gt_prior").string(), "BIN");
  std::cout << "pose priors: " << priors.wgs84.size() << " ("
            << priors.outliers.size() << " outliers), ENU origin "
            << std::setprecision(12) << priors.enu_origin.latitude << ", "
            << priors.enu_origin.longitude << ", " << priors.enu_origin.altitude
            << std::setprecision(6) << "\n";
}

int Run(int argc, char** argv) {
  std::string output_path;
  std::string layout = "courtyard";
  std::string camera_models = "SIMPLE_RADIAL";
  int seed = 1;
  bool overwrite = false;
  SceneGeneratorOptions options;
  // The command writes what a matcher would (the stored pose fitted to the
  // noisy inliers), so that benchmarks against mappers that decompose E
  // without refining it are fair; the library keeps the exact geometry its
  // tests were written against.
  options.exact_two_view_geometry = false;
  OptionManager manager("scene_generator",
                        "Writes OUTPUT/database.db (COLMAP 3.8), OUTPUT/gt "
                        "(the exact model) and\n"
                        "OUTPUT/pairs.txt (pair kinds) for a synthetic scene.");
  manager.AddRequired("output_path", &output_path, "output directory");
  manager.Add("overwrite", &overwrite, "replace an existing output");
  manager.Add("layout", &layout, "courtyard | street | tower | photo");
  manager.Add("num_images", &options.num_images, "number of images");
  manager.Add("image_spacing", &options.image_spacing,
              "camera path length per image (m)");
  manager.Add("point_density", &options.point_density,
              "points per m^2 of wall");
  manager.Add("unique_point_fraction", &options.unique_point_fraction,
              "fraction of points without a mirror twin");
  manager.Add("wall_relief", &options.wall_relief, "depth relief of walls (m)");
  manager.Add("density_skew", &options.density_skew,
              "uneven density in [0, 1): cameras crowd at hot spots");
  manager.Add("num_hotspots", &options.num_hotspots,
              "hot spots of density_skew");
  manager.Add("corner_turn_length", &options.corner_turn_length,
              "cameras turn gradually within this arc length (m) of the "
              "path's corners (0: abruptly)");
  manager.Add("camera_models", &camera_models,
              "comma-separated COLMAP model names, one per camera in turn");
  manager.Add("num_cameras", &options.num_cameras, "number of cameras");
  manager.Add("width", &options.width, "image width (px)");
  manager.Add("height", &options.height, "image height (px)");
  manager.Add("focal_length", &options.focal_length, "focal length (px)");
  manager.Add("detection_probability", &options.detection_probability,
              "probability a visible point gives a keypoint");
  manager.Add("max_view_distance", &options.max_view_distance,
              "farthest detected point (m)");
  manager.Add("noise_px", &options.noise_px, "keypoint noise (px)");
  manager.Add("keypoint_scales", &options.keypoint_scales,
              "a scale per keypoint, log-uniform in [1.5, 12] px (4 columns)");
  manager.Add("noise_scale_exponent", &options.noise_scale_exponent,
              "noise grows as scale^exponent (1: proportional; needs "
              "keypoint_scales 1)");
  manager.Add("max_keypoints_per_image", &options.max_keypoints_per_image,
              "each image keeps a random subset of at most this many "
              "keypoints of points (detector repeatability; 0: all)");
  manager.Add("match_angle_falloff_deg", &options.match_angle_falloff_deg,
              "a pair keeps exp(-(a / this)^2) of its matches, a the angle "
              "(deg) between its rays (0: all)");
  manager.Add("match_distance_falloff", &options.match_distance_falloff,
              "... times near/far distance / (1 + mean distance / this) "
              "(m; 0: no falloff)");
  manager.Add("match_rate_sigma", &options.match_rate_sigma,
              "... times a per-pair log-normal factor of this sigma");
  manager.Add("clutter_fraction", &options.clutter_fraction,
              "keypoints of nothing, fraction of each image's");
  manager.Add("min_num_inliers", &options.min_num_inliers,
              "fewest inliers of a written pair");
  manager.Add("max_pairs_per_image", &options.max_pairs_per_image,
              "keep each image's best pairs only (0: all)");
  manager.Add("raw_outlier_ratio", &options.raw_outlier_ratio,
              "wrong raw matches per inlier");
  manager.Add("mirror_pair_rate", &options.mirror_pair_rate,
              "fraction of mirror-twin false pairs");
  manager.Add("random_pair_rate", &options.random_pair_rate,
              "fraction of random false pairs");
  manager.Add("false_pair_inlier_fraction", &options.false_pair_inlier_fraction,
              "fraction of its possible matches a false pair keeps");
  manager.Add("num_parts", &options.num_parts,
              "photo: landmarks with no true pair between them");
  manager.Add("min_focal_ratio", &options.min_focal_ratio,
              "photo: shortest focal length (x image width)");
  manager.Add("max_focal_ratio", &options.max_focal_ratio,
              "photo: longest focal length (x image width)");
  manager.Add("prior_focal_fraction", &options.prior_focal_fraction,
              "photo: share of cameras with a prior focal (EXIF); the others "
              "get COLMAP's guess 1.2 x max(width, height)");
  manager.Add("prior_focal_error", &options.prior_focal_error,
              "photo: a prior focal is within this relative error");
  manager.Add("max_radial_distortion", &options.max_radial_distortion,
              "photo: radial coefficient k drawn in [-this, this]");
  manager.Add("store_relative_pose", &options.store_relative_pose,
              "write two_view_geometries.qvec/tvec");
  manager.Add("exact_two_view_geometry", &options.exact_two_view_geometry,
              "E, F of the pose re-estimated on the noisy inliers, as a "
              "matcher's (1: of the true relative pose, which leaks the "
              "truth to a mapper that decomposes E without refining)");
  // -1: on for the photo layout (its database cameras differ from the true
  // ones, as a user's;
  // docs/notes/2026-12-05-matcher-consistent-photo-scenes.md), off for the
  // others (their database holds the true cameras).
  int matcher_geometry = -1;
  manager.Add("matcher_geometry", &matcher_geometry,
              "store what a matcher would: inliers within 4 px of a pinhole F "
              "fitted to the matches, E with the database's cameras, H, "
              "COLMAP's configuration rule, unverified pairs not written (1); "
              "the true geometry (0); -1: 1 for --layout photo, else 0");
  manager.Add("seed", &seed, "random seed");
  bool pose_priors = false;
  PosePriorGeneratorOptions prior_options;
  AddPosePriorOptions(&manager, &pose_priors, &prior_options);
  if (!manager.Parse(argc, argv)) return 0;
  options.layout = SceneLayoutFromName(layout);
  options.camera_models = SplitComma(camera_models);
  options.seed = static_cast<uint64_t>(seed);
  if (matcher_geometry < -1 || matcher_geometry > 1) {
    throw InputError("--matcher_geometry", "must be -1, 0 or 1");
  }
  options.matcher_geometry = matcher_geometry < 0
                                 ? options.layout == SceneLayout::kPhoto
                                 : matcher_geometry == 1;
  options.Check();

  const std::filesystem::path out(output_path);
  if (std::filesystem::exists(out / "database.db") ||
      std::filesystem::exists(out / "gt")) {
    if (!overwrite) {
      throw InputError(output_path,
                       "already holds database.db or gt "
                       "(--overwrite 1 replaces them)");
    }
    std::filesystem::remove(out / "database.db");
    std::filesystem::remove_all(out / "gt");
    std::filesystem::remove(out / "pairs.txt");
    std::filesystem::remove(out / "image_parts.txt");
    std::filesystem::remove_all(out / "gt_prior");
  }
  std::filesystem::create_directories(out);

  Timer timer;
  const GeneratedScene scene = GenerateScene(options);
  const double generate_seconds = timer.ElapsedSeconds();
  std::vector<int> num_inliers;
  WriteSceneDatabase(scene, (out / "database.db").string(), &num_inliers);
  WriteReconstruction(scene.truth, (out / "gt").string(), "BIN");
  int num_written = 0;
  WriteTextFile((out / "pairs.txt").string(), [&](std::ostream& file) {
    for (size_t k = 0; k < scene.pairs.size(); ++k) {
      if (num_inliers[k] == 0) continue;  // not verified (matcher_geometry)
      ++num_written;
      const GeneratedPair& pair = scene.pairs[k];
      file << pair.image_id1 << ' ' << pair.image_id2 << ' '
           << PairKindName(pair.kind) << ' ' << pair.num_candidates << '\n';
    }
  });
  if (!scene.image_parts.empty()) {
    WriteTextFile((out / "image_parts.txt").string(), [&](std::ostream& file) {
      for (const auto& [image_id, image] : scene.truth.images) {
        file << image.name << ' ' << scene.image_parts.at(image_id - 1) << '\n';
      }
    });
  }
  if (pose_priors) {
    prior_options.seed = options.seed;
    WriteScenePosePriors(scene, prior_options, out);
  }
  size_t num_keypoints = 0;
  for (const auto& [id, image] : scene.truth.images)
    num_keypoints += image.points2D.size();
  const int total =
      scene.num_true_pairs + scene.num_mirror_pairs + scene.num_random_pairs;
  std::cout << std::fixed << std::setprecision(1)
            << SceneLayoutName(options.layout) << ": "
            << scene.truth.images.size() << " images, "
            << scene.truth.cameras.size() << " cameras, "
            << scene.truth.points3D.size() << " points (mean track length "
            << std::setprecision(2) << MeanTrackLength(scene.truth) << "), "
            << num_keypoints << " keypoints, " << total
            << " pairs: " << scene.num_true_pairs << " true, "
            << scene.num_mirror_pairs << " mirror-twin (of "
            << scene.num_mirror_candidates << " candidates), "
            << scene.num_random_pairs << " random; generated in "
            << std::setprecision(1) << generate_seconds << " s, written in "
            << timer.ElapsedSeconds() - generate_seconds << " s to "
            << output_path << "\n";
  if (num_written < total) {
    std::cout << num_written << " of the " << total
              << " pairs verified and written (matcher_geometry)\n";
  }
  const std::vector<int> across = PairsAcrossCorners(scene);
  if (!across.empty()) {
    std::cout << "true pairs across the path's corners:";
    for (const int count : across) std::cout << ' ' << count;
    std::cout << "\n";
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  google::InitGoogleLogging(argv[0]);
  FLAGS_logtostderr = true;
  try {
    return Run(argc, argv);
  } catch (const InputError& error) {
    std::cerr << "ERROR: " << error.what() << "\n";
    return 1;
  }
}
