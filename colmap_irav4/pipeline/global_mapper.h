#pragma once

// The global mapper: from a COLMAP database to COLMAP sparse models.
//   view graph (filters, connected components)
//   -> per component: rotation averaging -> rotation-consistency filter
//   -> tracks from the inlier matches -> global positioning
//   -> bundle adjustment rounds with filtering -> retriangulation
//   -> final filtering -> normalisation -> point colours.
// Every stage lives in its own folder; this file only wires them together.

#include <map>
#include <string>
#include <utility>
#include <vector>

#include "colmap_irav4/io/database.h"
#include "colmap_irav4/positioning/global_positioning.h"
#include "colmap_irav4/positioning/track_builder.h"
#include "colmap_irav4/positioning/translation_averaging.h"
#include "colmap_irav4/refinement/triangulation.h"
#include "colmap_irav4/refinement/bundle_adjustment.h"
#include "colmap_irav4/refinement/filtering.h"
#include "colmap_irav4/rotation_averaging/rotation_averager_factory.h"
#include "colmap_irav4/scene/reconstruction.h"
#include "colmap_irav4/view_graph/view_graph_builder.h"

namespace colmap_irav4 {

class OptionManager;

// The rotation-consistency filter between rotation averaging and tracks.
struct RotationFilterOptions {
  // Pairs whose relative rotation disagrees with the averaged rotations
  // (angle of R_ij^T R_j R_i^T) by more than this are dropped (deg).
  double max_rotation_error_deg = 5.0;
  void Check() const;  // throws InputError naming the option
};

struct GlobalMapperOptions {
  // Components of the view graph with fewer images give no model
  // (COLMAP's min_model_size; 3 is the least a global model needs).
  int min_model_size = 3;
  // Rotation averaging method: irav4 (the default once registered), ira,
  // l1_irls, spanning_tree (see RotationAveragerMethods()).
  std::string rotation_method;
  // global_positioning or translation_averaging.
  std::string positioning_method = "global_positioning";
  // Intrinsics refined by bundle adjustment (COLMAP's names and defaults).
  bool ba_refine_focal_length = true;
  bool ba_refine_principal_point = false;
  bool ba_refine_extra_params = true;
  // Ceres / worker threads of every stage; -1: all cores.
  int num_threads = -1;
  // Progress bars on the iterative stages (positioning, bundle adjustment):
  // 1 on, 0 off, -1 on a terminal or for long work (>= 100 images).
  int progress = -1;
  // Rounds of (bundle adjustment, filtering) before retriangulation; each
  // bundle adjustment itself filters by reprojection error between its solves.
  int num_ba_iterations = 2;
  // Global positioning uses the longest tracks until every image has this
  // many observations (0: all tracks); the rest are triangulated after the
  // first bundle adjustment. Fewer unknowns, same poses, much faster.
  int positioning_tracks_per_image = 500;

  // Skip flags of the optional stages. The view graph, rotation averaging,
  // tracks and positioning cannot be skipped: nothing downstream exists
  // without them.
  bool skip_rotation_filter = false;
  bool skip_bundle_adjustment = false;
  bool skip_retriangulation = false;
  bool skip_filtering = false;
  bool skip_normalization = false;
  bool skip_colors = false;
  // Point colours come from the images decoded at 1/downscale of their size
  // (1, 2, 4 or 8): JPEG decoding at half size is several times faster and a
  // point's colour is a mean over its track anyway.
  int color_image_downscale = 2;
  // Cameras with invalid intrinsics (non-positive or non-finite focal,
  // implausible distortion) are an error; with this flag they start from a
  // default focal and are refined (see DatabaseReadOptions).
  bool reset_invalid_cameras = false;

  ViewGraphBuilderOptions view_graph;
  RotationAveragerOptions rotation_averaging;
  RotationFilterOptions rotation_filter;
  TrackBuilderOptions tracks;
  GlobalPositionerOptions global_positioning;
  TranslationAveragingOptions translation_averaging;
  TriangulationOptions triangulation;
  BundleAdjustmentOptions bundle_adjustment;
  FilterOptions filtering;
  NormalizationOptions normalization;

  GlobalMapperOptions();
  // Throws InputError naming the offending option.
  void Check() const;
};

// Registers the options in COLMAP's dotted style (--Mapper.*, --ViewGraph.*,
// --RelativePose.*, --RotationAveraging.*, --Tracks.*, --GlobalPositioning.*,
// --BundleAdjustment.*, --Filter.*, --Normalization.*).
void AddGlobalMapperOptions(OptionManager* manager,
                            GlobalMapperOptions* options);

// The rotation method used when none is given: irav4 when registered in the
// factory, else the best available baseline.
std::string DefaultRotationMethod();

// One stage's figures (also the log line and the summary.json entry).
struct StageReport {
  StageReport() = default;
  explicit StageReport(std::string stage_name) : name(std::move(stage_name)) {}
  std::string name;
  double seconds = 0;
  // Named counts in order, e.g. {"pairs", 55}, {"points", 1234}.
  std::vector<std::pair<std::string, double>> figures;
};

// One model (connected component) of the run.
struct ComponentReport {
  int index = 0;  // output directory SPARSE/<index>
  int num_images_in_graph = 0;
  int num_pairs_in_graph = 0;
  int num_registered_images = 0;
  int num_points = 0;
  int num_observations = 0;
  double mean_track_length = 0;
  double mean_reprojection_error = 0;
  std::vector<StageReport> stages;
};

struct GlobalMapperSummary {
  std::string database_path;
  std::string rotation_method;
  std::string positioning_method;
  int num_database_images = 0;
  int num_database_pairs = 0;
  std::vector<StageReport> stages;  // database reading, view graph
  std::vector<ComponentReport> components;
  double total_seconds = 0;
  std::vector<std::string> notes;  // warnings, skipped stages

  std::string ToJson() const;
};

// Maps every component with >= min_model_size images into its own model,
// largest first. `image_path` (may be empty) is where point colours are read
// from. Throws InputError when no component is large enough.
std::vector<Reconstruction> RunGlobalMapper(const GlobalMapperOptions& options,
                                            const DatabaseContents& database,
                                            const std::string& image_path,
                                            GlobalMapperSummary* summary);

// The whole command: reads the database read-only, maps, writes
// SPARSE/<k>/{cameras,images,points3D}.bin and SPARSE/summary.json through a
// temporary directory renamed into place once complete.
GlobalMapperSummary RunGlobalMapperOnDatabase(
    const GlobalMapperOptions& options, const std::string& database_path,
    const std::string& image_path, const std::string& output_path,
    const std::string& output_type = "BIN");

// Point colours: mean over each track of the image pixel at the observation
// (images read from image_path with OpenCV); points whose images are all
// missing stay grey (128). Returns the number of images that could not be
// read (each logged once).
// `downscale` (1, 2, 4, 8): the images are decoded at that fraction of their
// size (JPEG's DCT scaling) and sampled at the scaled positions.
int ColorPointsFromImages(const std::string& image_path,
                          Reconstruction* reconstruction, int downscale = 1);

// Drops pairs whose rotation disagrees with the averaged rotations by more
// than max_rotation_error_deg (rotations: cam_from_world by image id; pairs
// with an image without rotation are dropped too). Returns the kept pairs.
std::vector<ImagePairGeometry> FilterPairsByRotation(
    const std::vector<ImagePairGeometry>& pairs,
    const std::map<image_t, Eigen::Matrix3d>& rotations,
    double max_rotation_error_deg);

// Connected components of the images of `pairs`, largest first (ties: the
// component with the smallest image id first); each sorted ascending.
std::vector<std::vector<image_t>> PairComponents(
    const std::vector<ImagePairGeometry>& pairs);

}  // namespace colmap_irav4
