#pragma once

// The one place where options structs become command-line flags (COLMAP's
// dotted style, --Prefix.name). Every struct has one registration function,
// used by every command that exposes it, so a flag has one name and one help
// text everywhere; the structs' Check() name these flags (OptionError), and
// OptionManager::Check() renames a member registered under another flag.
// Algorithm headers never include the option manager: only this file and the
// commands do.

#include <string>
#include <vector>

#include "colmap_irav4/geometry/sim3d.h"
#include "colmap_irav4/pipeline/global_mapper.h"
#include "colmap_irav4/util/option_manager.h"

namespace colmap_irav4 {

// --ViewGraph.calibrate_focal, --ViewGraph.calibration_*.
// --Mapper.use_pose_priors, pose_prior_path, prior_* (GlobalMapperOptions).
void AddPosePriorOptions(OptionManager* manager, GlobalMapperOptions* options);
void AddFocalCalibrationOptions(OptionManager* manager,
                                FocalCalibrationOptions* options);
// --ViewGraph.* (filters; focal self-calibration) and --RelativePose.*.
// min_num_inliers is registered as `min_num_inliers_flag`;
// keep_largest_component and num_threads only with
// with_threads_and_components (the mapper sets both itself).
void AddViewGraphOptions(
    OptionManager* manager, ViewGraphBuilderOptions* options,
    const std::string& min_num_inliers_flag = "ViewGraph.min_num_inliers",
    bool with_threads_and_components = true);
// --RotationAveraging.*: IRAv4's own settings.
void AddIrav4Options(OptionManager* manager, Irav4Options* options);
// --RotationAveraging.*: every rotation averaging method's settings;
// num_threads and seed only with with_threads_and_seed (the mapper sets both
// from --Mapper.num_threads and --Mapper.seed).
void AddRotationAveragerOptions(OptionManager* options,
                                RotationAveragerOptions* averager_options,
                                bool with_threads_and_seed = true);
// --RotationFilter.*, --Tracks.*, --GlobalPositioning.*,
// --TranslationAveraging.*, --Triangulation.*, --BundleAdjustment.*,
// --Filter.*, --Normalization.*.
void AddRotationFilterOptions(OptionManager* manager,
                              RotationFilterOptions* options);
void AddTrackOptions(OptionManager* manager, TrackBuilderOptions* options);
void AddGlobalPositioningOptions(OptionManager* manager,
                                 GlobalPositionerOptions* options);
void AddTranslationAveragingOptions(OptionManager* manager,
                                    TranslationAveragingOptions* options);
// --<prefix>max_num_iterations, function_tolerance, gradient_tolerance,
// parameter_tolerance, initial_trust_region_radius, print_progress (the
// stages' Ceres settings; their threads and progress bars are --Mapper.*).
void AddSolverOptions(OptionManager* manager, const std::string& prefix,
                      SolverOptions* options);
void AddTriangulationOptions(OptionManager* manager,
                             TriangulationOptions* options);
void AddTwoViewCheckOptions(OptionManager* manager,
                            TwoViewCheckOptions* options);
void AddPointMergingOptions(OptionManager* manager,
                            PointMergingOptions* options);
void AddPoseConstraintOptions(OptionManager* manager,
                              PoseConstraintOptions* options);
void AddBundleAdjustmentOptions(OptionManager* manager,
                                BundleAdjustmentOptions* options);
void AddFilterOptions(OptionManager* manager, FilterOptions* options);
void AddNormalizationOptions(OptionManager* manager,
                             NormalizationOptions* options);
// --Comparer.max_relative_error (model_comparer, the Python module's
// compare_models and align_models).
void AddComparerOptions(OptionManager* manager,
                        SimilarityRansacOptions* options);
// The mapper: --Mapper.* and every stage's struct above.
void AddFoldResolutionOptions(OptionManager* manager,
                              FoldResolutionOptions* options);
// --PartMerge.*: the rigid parts of a split model joined again.
void AddPartMergeOptions(OptionManager* manager, PartMergeOptions* options);
void AddGlobalMapperOptions(OptionManager* manager,
                            GlobalMapperOptions* options);

// COLMAP 4.1's flags of its `global_mapper` command, for ours of the same
// name: a COLMAP 4 user swaps the program name only. `ours`: the flag of the
// same meaning (an alias); empty: `fixed` is the only value ours implements
// (-1: none, the flag is not supported). docs/usage.md holds this table.
struct Colmap4Flag {
  std::string colmap4;
  std::string ours;
  int fixed;
  std::string note;
};
const std::vector<Colmap4Flag>& Colmap4GlobalMapperFlags();
// Registers those names (after AddGlobalMapperOptions and the command's
// database_path, image_path and output_path): aliases parse into our
// members, a fixed flag accepts its value only, an unsupported one throws
// naming itself.
void AddColmap4GlobalMapperFlags(OptionManager* manager);

// The mapper's options as COLMAP's project.ini writes them (OptionManager::
// Write over AddGlobalMapperOptions): what a run used, beside its models.
std::string GlobalMapperOptionsIni(const GlobalMapperOptions& options);

}  // namespace colmap_irav4
