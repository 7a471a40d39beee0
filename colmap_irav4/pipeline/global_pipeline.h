#pragma once

// The global mapping pipeline (COLMAP's controllers/global_pipeline): reads a
// COLMAP database (read-only), builds the view graph (filters, relative
// poses, connected components), maps every large enough component
// (pipeline/component_mapper.h, pipeline/global_mapper.h), colours the
// points, and writes one COLMAP sparse model per model with the options of
// the run (project.ini), and summary.json.

#include <map>
#include <string>
#include <vector>

#include "colmap_irav4/io/database.h"
#include "colmap_irav4/io/pose_priors.h"
#include "colmap_irav4/pipeline/component_mapper.h"
#include "colmap_irav4/pipeline/global_mapper.h"
#include "colmap_irav4/scene/reconstruction.h"
#include "colmap_irav4/util/atomic_output.h"
#include "colmap_irav4/util/run_summary.h"
#include "colmap_irav4/util/timer.h"
#include "colmap_irav4/view_graph/view_graph.h"

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
  // The joining of a split model's rigid parts (ComponentModel::part_merge).
  std::string part_merge;
  // Placed in the pose priors' frame (metric; prior_frame.txt beside it).
  bool in_prior_frame = false;
  // The images whose position / gravity prior the last bundle adjustment
  // left out (beyond the gate: GatePosePriors), by name.
  std::vector<std::string> rejected_position_priors;
  std::vector<std::string> rejected_gravity_priors;
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
  // Peak resident memory of the process (VmHWM), MiB, when the summary is
  // written; the stage that reached it; and the peak per observation of the
  // models written and per verified pair of the database (bytes), the
  // figures that say how memory scales.
  double peak_memory_mib = 0;
  std::string peak_memory_stage;
  double peak_bytes_per_observation = 0;
  double peak_bytes_per_pair = 0;
  std::vector<std::string> notes;  // warnings, skipped stages
  // The pose priors read (source, frame, counts; not the priors).
  LocalPosePriors pose_priors;

  // Sets the peak figures above from the process and the stages (and logs
  // them): called once every stage has finished.
  void RecordPeakMemory();
  // Models written although the fold check still flags them (folded).
  int NumFoldedModels() const;
  std::string ToJson() const;
};

// Exit code of the mapper command when it wrote its models but at least one
// of them is still flagged folded (summary.json: num_folded_models > 0).
constexpr int kFoldedExitCode = 3;

// The run of the mapper command (COLMAP's GlobalPipeline): Run() reads the
// database, builds the view graph, maps every component of at least
// min_model_size images (ComponentMapper: GlobalMapper::Solve with the fold
// check and resolution), colours the points and writes the models, their
// options and summary.json.
class GlobalPipeline {
 public:
  // Checks the options (the run's one check: errors name the flags) and the
  // output arguments; throws InputError. `image_path` (may be empty) is where
  // point colours are read from; `output_type` BIN or TXT.
  GlobalPipeline(const GlobalMapperOptions& options, std::string database_path,
                 std::string image_path, std::string output_path,
                 std::string output_type = "BIN");

  // Reads the database (read-only), Reconstruct()s and writes
  // OUTPUT/<k>/{cameras,images,points3D}.<bin|txt> and project.ini (the
  // options of the run) for every model, largest first, and
  // OUTPUT/summary.json, installed atomically (util/atomic_output.h: each
  // OUTPUT/<k> is swapped atomically, the user's files in an old OUTPUT/<k>
  // are kept, stale OUTPUT/<k> warned about). Throws InputError when the
  // database gives no model.
  void Run();

  // Run's mapping on a database already read: the view graph, the models of
  // its components (largest first), coloured from image_path. Throws
  // InputError when no component gives a model.
  std::vector<Reconstruction> Reconstruct(const DatabaseContents& database);

  const GlobalMapperSummary& summary() const { return summary_; }

 private:
  DatabaseContents ReadDatabase();
  // The view graph and its connected components, largest first.
  // `cameras`: see colmap_irav4::BuildViewGraph (nullptr: the database's);
  // `stage_name` names the stage in the summary.
  ViewGraph BuildViewGraph(const DatabaseContents& database,
                           std::vector<std::vector<image_t>>* components,
                           const std::map<camera_t, Camera>* cameras = nullptr,
                           const std::string& stage_name = "view graph");
  // The models of every large enough component.
  std::vector<ComponentModel> MapComponents(
      const DatabaseContents& database, const ViewGraph& view_graph,
      const std::vector<std::vector<image_t>>& components);
  // Colours the models' points and reports them (summary_.components).
  std::vector<Reconstruction> FinishModels(std::vector<ComponentModel> models);
  void Write(const std::vector<Reconstruction>& models,
             const Timer& total_timer, OutputTransaction* output);

  const GlobalMapperOptions options_;
  GlobalMapperOptions stage_options_;  // options_.ForStages, once per run
  const std::string database_path_;
  const std::string image_path_;
  const std::string output_path_;
  const std::string output_type_;
  GlobalMapperSummary summary_;
};

// The cameras of `database` with those of the images the `models` registered
// replaced by the models' refined cameras (a camera in several models: from
// the model holding most of its images; ties: the first), each marked as
// having a prior focal length. *num_replaced (optional): how many were.
std::map<camera_t, Camera> RefinedCameras(
    const DatabaseContents& database, const std::vector<ComponentModel>& models,
    int* num_replaced = nullptr);

// The whole command in one call (for bindings):
// GlobalPipeline(...).Run(), returning its summary.
GlobalMapperSummary RunGlobalMapperOnDatabase(
    const GlobalMapperOptions& options, const std::string& database_path,
    const std::string& image_path, const std::string& output_path,
    const std::string& output_type = "BIN");

// The mapping of a database already read (GlobalPipeline::Reconstruct),
// without output; *summary gets its figures.
std::vector<Reconstruction> RunGlobalMapper(const GlobalMapperOptions& options,
                                            const DatabaseContents& database,
                                            const std::string& image_path,
                                            GlobalMapperSummary* summary);

}  // namespace colmap_irav4
