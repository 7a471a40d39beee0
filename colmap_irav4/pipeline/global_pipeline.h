#pragma once

// The global mapping pipeline (COLMAP's controllers/global_pipeline): reads a
// COLMAP database (read-only), builds the view graph (filters, relative
// poses, connected components), maps every large enough component with a
// GlobalMapper, colours the points, and writes one COLMAP sparse model per
// component and summary.json.

#include <string>
#include <vector>

#include "colmap_irav4/io/database.h"
#include "colmap_irav4/pipeline/global_mapper.h"
#include "colmap_irav4/scene/reconstruction.h"
#include "colmap_irav4/util/atomic_output.h"
#include "colmap_irav4/util/run_summary.h"

namespace colmap_irav4 {

// One model (connected component) of the run.
struct ComponentReport {
  int index = 0;  // output directory SPARSE/<index>
  int num_images_in_graph = 0;
  int num_pairs_in_graph = 0;
  int num_registered_images = 0;
  int num_points = 0;
  int num_observations = 0;
  double mean_track_length = 0;
  // Mean reprojection error (px) over all observations (what bundle
  // adjustment minimises) and over points (each point's mean over its track
  // first: COLMAP model_analyzer's "Mean reprojection error"). The
  // per-observation mean is larger: long tracks, seen from more angles, tend
  // to have larger errors.
  double mean_reprojection_error_per_observation = 0;
  double mean_reprojection_error_per_point = 0;
  // Fold check (refinement/fold_detection.h) of the model as written;
  // fold_score -1: not run.
  double fold_score = -1;
  bool folded = false;
  int fold_predicted_pairs = 0;
  int fold_missing_pairs = 0;
  // "clean", "resolved (...)", "split", "folded (...)".
  std::string fold_outcome;
  std::vector<StageReport> stages;
  // Each image's observations and pose constraint, least constrained first
  // (refinement/pose_constraint.h).
  std::vector<ImagePoseConstraint> images;
};

struct GlobalMapperSummary {
  std::string database_path;
  std::string rotation_method;
  std::string positioning_method;
  int num_database_images = 0;
  int num_database_pairs = 0;
  std::vector<StageReport> stages;  // database reading, view graph, writing
  std::vector<ComponentReport> components;
  double total_seconds = 0;
  // Peak resident memory of the process (getrusage ru_maxrss), MiB, when
  // the summary is written.
  double peak_memory_mib = 0;
  std::vector<std::string> notes;  // warnings, skipped stages

  // Models written although the fold check still flags them (folded).
  int NumFoldedModels() const;
  std::string ToJson() const;
};

// Exit code of the mapper command when it wrote its models but at least one
// of them is still flagged folded (summary.json: num_folded_models > 0).
constexpr int kFoldedExitCode = 3;

// Maps every component with >= min_model_size images into its own model,
// largest first. `image_path` (may be empty) is where point colours are read
// from. Throws InputError when no component is large enough.
std::vector<Reconstruction> RunGlobalMapper(const GlobalMapperOptions& options,
                                            const DatabaseContents& database,
                                            const std::string& image_path,
                                            GlobalMapperSummary* summary);

// Writes OUTPUT/<k>/{cameras,images,points3D}.<bin|txt> for every model and
// OUTPUT/summary.json into the transaction's temporary directory, then
// installs them (util/atomic_output.h: each OUTPUT/<k> is swapped atomically,
// the user's files in an old OUTPUT/<k> are kept, stale OUTPUT/<k> warned
// about). Appends the "writing" stage to the summary.
void WriteMapperOutput(const std::vector<Reconstruction>& models,
                       const std::string& output_type, const Timer& total_timer,
                       OutputTransaction* output, GlobalMapperSummary* summary);

// The whole command: reads the database read-only, maps, writes the output
// with WriteMapperOutput.
GlobalMapperSummary RunGlobalMapperOnDatabase(
    const GlobalMapperOptions& options, const std::string& database_path,
    const std::string& image_path, const std::string& output_path,
    const std::string& output_type = "BIN");

}  // namespace colmap_irav4
