#include "colmap_irav4/pipeline/global_pipeline.h"

#include <unistd.h>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <map>
#include <memory>
#include <set>
#include <sstream>

#include <glog/logging.h>

#include "colmap_irav4/io/model_io.h"
#include "colmap_irav4/pipeline/option_registration.h"
#include "colmap_irav4/pipeline/pose_prior_setup.h"
#include "colmap_irav4/scene/reconstruction_utils.h"
#include "colmap_irav4/util/atomic_output.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/timer.h"
#include "colmap_irav4/view_graph/view_graph_builder.h"

namespace colmap_irav4 {

namespace fs = std::filesystem;

namespace {

// One warning naming the images whose pose their points hold least
// (`images`: least constrained first), so that a user doubts those cameras.
void LogPoorlyConstrainedImages(const std::vector<ImagePoseConstraint>& images,
                                const PoseConstraintOptions& options,
                                const std::string& prefix) {
  std::ostringstream list;
  int count = 0;
  for (const ImagePoseConstraint& image : images) {
    if (!image.poorly_constrained) continue;
    list << (count++ ? ", " : "") << image.name << " ("
         << image.num_multi_view_observations << " of "
         << image.num_observations << " observations on points seen 3+ times, "
         << std::setprecision(2) << image.relative_uncertainty << "x)";
  }
  if (count == 0) return;
  LOG(WARNING) << prefix << count << " image(s) poorly constrained by their "
               << "points (rotation uncertainty over "
               << options.max_relative_uncertainty
               << "x the model's median; summary.json lists every image): "
               << list.str();
}

// ["a", "b"].
std::string JsonStrings(const std::vector<std::string>& strings) {
  std::string json = "[";
  for (size_t k = 0; k < strings.size(); ++k) {
    json += (k ? ", " : "") + JsonString(strings[k]);
  }
  return json + "]";
}

}  // namespace

std::string GlobalMapperSummary::ToJson() const {
  std::ostringstream out;
  out << "{\n  \"database_path\": " << JsonString(database_path)
      << ",\n  \"rotation_method\": " << JsonString(rotation_method)
      << ",\n  \"positioning_method\": " << JsonString(positioning_method)
      << ",\n  \"num_database_images\": " << num_database_images
      << ",\n  \"num_database_pairs\": " << num_database_pairs
      << ",\n  \"total_seconds\": " << JsonNumber(total_seconds)
      << ",\n  \"peak_memory_mib\": " << JsonNumber(peak_memory_mib)
      << ",\n  \"peak_memory_stage\": " << JsonString(peak_memory_stage)
      << ",\n  \"peak_bytes_per_observation\": "
      << JsonNumber(peak_bytes_per_observation)
      << ",\n  \"peak_bytes_per_pair\": " << JsonNumber(peak_bytes_per_pair)
      << ",\n  \"num_folded_models\": " << NumFoldedModels()
      << ",\n  \"pose_priors\": " << PosePriorsJson(pose_priors)
      << ",\n  \"stages\": ";
  AppendStagesJson(stages, "  ", &out);
  out << ",\n  \"models\": [";
  for (size_t i = 0; i < components.size(); ++i) {
    const ComponentReport& c = components[i];
    out << (i ? "," : "") << "\n    {\"index\": " << c.index
        << ", \"path\": " << JsonString(std::to_string(c.index))
        << ", \"num_images_in_graph\": " << c.num_images_in_graph
        << ", \"num_pairs_in_graph\": " << c.num_pairs_in_graph
        << ", \"num_registered_images\": " << c.num_registered_images
        << ", \"num_points\": " << c.num_points
        << ", \"num_observations\": " << c.num_observations
        << ", \"mean_track_length\": " << JsonNumber(c.mean_track_length)
        << ",\n     \"mean_reprojection_error_per_observation\": "
        << JsonNumber(c.mean_reprojection_error_per_observation)
        << ", \"mean_reprojection_error_per_point\": "
        << JsonNumber(c.mean_reprojection_error_per_point)
        << ",\n     \"fold_score\": "
        << JsonNumber(c.fold_score < 0 ? std::nan("") : c.fold_score)
        << ", \"folded\": " << (c.folded ? "true" : "false")
        << ", \"fold_predicted_pairs\": " << c.fold_predicted_pairs
        << ", \"fold_missing_pairs\": " << c.fold_missing_pairs
        << ", \"fold_outcome\": " << JsonString(c.fold_outcome)
        << ", \"part_merge\": " << JsonString(c.part_merge)
        << ", \"in_prior_frame\": " << (c.in_prior_frame ? "true" : "false")
        << ",\n     \"rejected_position_priors\": "
        << JsonStrings(c.rejected_position_priors)
        << ", \"rejected_gravity_priors\": "
        << JsonStrings(c.rejected_gravity_priors) << ",\n     \"stages\": ";
    AppendStagesJson(c.stages, "     ", &out);
    out << ",\n     \"images\": [";
    for (size_t j = 0; j < c.images.size(); ++j) {
      const ImagePoseConstraint& image = c.images[j];
      out << (j ? "," : "") << "\n       {\"image_id\": " << image.image_id
          << ", \"name\": " << JsonString(image.name)
          << ", \"num_observations\": " << image.num_observations
          << ", \"num_multi_view_observations\": "
          << image.num_multi_view_observations
          << ", \"rotation_uncertainty_deg\": "
          << JsonNumber(image.rotation_uncertainty_deg)
          << ", \"relative_center_uncertainty\": "
          << JsonNumber(image.relative_center_uncertainty)
          << ", \"relative_uncertainty\": "
          << JsonNumber(image.relative_uncertainty)
          << ", \"poorly_constrained\": "
          << (image.poorly_constrained ? "true" : "false") << "}";
    }
    out << (c.images.empty() ? "" : "\n     ") << "]}";
  }
  out << (components.empty() ? "" : "\n  ") << "],\n  \"notes\": [";
  for (size_t i = 0; i < notes.size(); ++i) {
    out << (i ? ", " : "") << JsonString(notes[i]);
  }
  out << "]\n}\n";
  return out.str();
}

void GlobalMapperSummary::RecordPeakMemory() {
  peak_memory_mib = ReadProcessMemory().peak_mib;
  std::vector<const std::vector<StageReport>*> stage_lists = {&stages};
  double num_observations = 0;
  for (const ComponentReport& component : components) {
    stage_lists.push_back(&component.stages);
    num_observations += component.num_observations;
  }
  peak_memory_stage = PeakMemoryStage(stage_lists);
  const double peak_bytes = peak_memory_mib * 1024 * 1024;
  peak_bytes_per_observation =
      num_observations > 0 ? peak_bytes / num_observations : 0;
  peak_bytes_per_pair =
      num_database_pairs > 0 ? peak_bytes / num_database_pairs : 0;
  LOG(INFO) << "Peak memory: " << std::fixed << std::setprecision(1)
            << peak_memory_mib << " MiB (in "
            << (peak_memory_stage.empty() ? "?" : peak_memory_stage) << "; "
            << std::setprecision(0) << peak_bytes_per_observation
            << " bytes per observation, " << peak_bytes_per_pair
            << " per verified pair)";
}

int GlobalMapperSummary::NumFoldedModels() const {
  int count = 0;
  for (const ComponentReport& component : components) {
    count += component.folded;
  }
  return count;
}

GlobalPipeline::GlobalPipeline(const GlobalMapperOptions& options,
                               std::string database_path,
                               std::string image_path, std::string output_path,
                               std::string output_type)
    : options_(options),
      database_path_(std::move(database_path)),
      image_path_(std::move(image_path)),
      output_path_(std::move(output_path)),
      output_type_(std::move(output_type)) {
  options_.Check();
  if (output_type_ != "BIN" && output_type_ != "TXT" && output_type_ != "bin" &&
      output_type_ != "txt") {
    throw InputError("--output_type", "must be BIN or TXT");
  }
  if (!image_path_.empty() && !fs::is_directory(image_path_)) {
    throw InputError(image_path_, "image directory does not exist");
  }
}

void GlobalPipeline::Run() {
  // Output writable, OUT/0 replaceable, summary.json not a directory: checked
  // before any work; the models are staged in a temporary directory and
  // installed atomically (util/atomic_output.h).
  OutputTransaction output(
      output_path_, {database_path_}, [](const std::string& dir, bool binary) {
        binary ? ReadReconstructionBinary(dir) : ReadReconstructionText(dir);
      });
  Timer total_timer;
  summary_ = GlobalMapperSummary();
  summary_.database_path = database_path_;
  DatabaseContents database = ReadDatabase();
  summary_.pose_priors = LoadPosePriors(options_, &database);
  for (const std::string& warning : summary_.pose_priors.Warnings()) {
    summary_.notes.push_back(warning);
  }
  const std::vector<Reconstruction> models = Reconstruct(database);
  Write(models, total_timer, &output);
}

DatabaseContents GlobalPipeline::ReadDatabase() {
  StageTimer stage("database");
  DatabaseReadOptions read_options;
  read_options.reset_invalid_cameras = options_.reset_invalid_cameras;
  DatabaseContents database =
      colmap_irav4::ReadDatabase(database_path_, read_options);
  for (const std::string& warning : database.warnings) {
    summary_.notes.push_back(database_path_ + ": " + warning);
  }
  // Names images.txt cannot hold fail now, not after the reconstruction.
  if (output_type_ == "TXT" || output_type_ == "txt") {
    for (const auto& [image_id, image] : database.images) {
      const std::string problem = TextImageNameProblem(image.name);
      if (!problem.empty()) {
        throw InputError(database_path_, "image " + std::to_string(image_id) +
                                             ": " + problem +
                                             "; use --output_type BIN");
      }
    }
  }
  size_t num_keypoints = 0;
  for (const auto& [image_id, keypoints] : database.keypoints) {
    num_keypoints += keypoints.size();
  }
  stage.Add("cameras", static_cast<double>(database.cameras.size()));
  stage.Add("images", static_cast<double>(database.images.size()));
  stage.Add("keypoints", static_cast<double>(num_keypoints));
  stage.Add("verified pairs",
            static_cast<double>(database.two_view_geometries.size()));
  // Observations that never reach positioning or bundle adjustment.
  for (const auto& [reason, count] : database.num_keypoints_invalid) {
    stage.Add(reason + "s dropped", static_cast<double>(count));
  }
  if (database.num_matches_dropped_invalid_keypoint > 0) {
    stage.Add(
        "inlier matches dropped (invalid keypoint)",
        static_cast<double>(database.num_matches_dropped_invalid_keypoint));
  }
  stage.Finish("", &summary_.stages);
  return database;
}

std::vector<Reconstruction> GlobalPipeline::Reconstruct(
    const DatabaseContents& database) {
  Timer total_timer;
  // The mapper-wide settings reach every stage's options here, once.
  stage_options_ = options_.ForStages(database.images.size());
  summary_.rotation_method = options_.rotation_method;
  summary_.positioning_method = EnumName(options_.positioning_method);
  summary_.num_database_images = static_cast<int>(database.images.size());
  summary_.num_database_pairs =
      static_cast<int>(database.two_view_geometries.size());
  if (options_.skip_retriangulation) {
    summary_.notes.push_back("retriangulation skipped");
  }
  std::vector<std::vector<image_t>> components;
  const ViewGraph view_graph = BuildViewGraph(database, &components);
  std::vector<ComponentModel> first =
      MapComponents(database, view_graph, components);
  if (!options_.recalibrated_second_pass) {
    std::vector<Reconstruction> models = FinishModels(std::move(first));
    summary_.total_seconds += total_timer.ElapsedSeconds();
    return models;
  }
  // Second pass: the relative poses derived again with the cameras the
  // first mapping refined, then the whole mapping again on that graph.
  int num_replaced = 0;
  const std::map<camera_t, Camera> cameras =
      RefinedCameras(database, first, &num_replaced);
  first.clear();
  LOG(INFO) << "Second pass: the relative poses derived again with the "
            << num_replaced << " camera(s) the first mapping refined";
  summary_.notes.push_back("second pass with " + std::to_string(num_replaced) +
                           " camera(s) refined by the first mapping");
  std::vector<std::vector<image_t>> second_components;
  const ViewGraph second_graph = BuildViewGraph(
      database, &second_components, &cameras, "view graph (second pass)");
  std::vector<Reconstruction> models =
      FinishModels(MapComponents(database, second_graph, second_components));
  summary_.total_seconds += total_timer.ElapsedSeconds();
  return models;
}

std::map<camera_t, Camera> RefinedCameras(
    const DatabaseContents& database, const std::vector<ComponentModel>& models,
    int* num_replaced) {
  std::map<camera_t, Camera> cameras = database.cameras;
  // Per camera: (images in the model holding most of them, that model).
  std::map<camera_t, std::pair<int, const Reconstruction*>> source;
  for (const ComponentModel& model : models) {
    const Reconstruction& reconstruction = model.mapper->reconstruction();
    std::map<camera_t, int> counts;
    for (const auto& [image_id, image] : reconstruction.images) {
      ++counts[image.camera_id];
    }
    for (const auto& [camera_id, count] : counts) {
      auto it = source.find(camera_id);
      if (it == source.end() || count > it->second.first) {
        source[camera_id] = {count, &reconstruction};
      }
    }
  }
  for (const auto& [camera_id, count_and_model] : source) {
    Camera camera = count_and_model.second->cameras.at(camera_id);
    camera.has_prior_focal_length = true;
    cameras.at(camera_id) = camera;
  }
  if (num_replaced != nullptr) *num_replaced = static_cast<int>(source.size());
  return cameras;
}

ViewGraph GlobalPipeline::BuildViewGraph(
    const DatabaseContents& database,
    std::vector<std::vector<image_t>>* components,
    const std::map<camera_t, Camera>* cameras, const std::string& stage_name) {
  StageTimer stage(stage_name);
  ViewGraphSummary view_graph_summary;
  ViewGraph view_graph = colmap_irav4::BuildViewGraph(
      database, stage_options_.view_graph, &view_graph_summary, cameras);
  *components = PairComponents(view_graph.pairs);
  int num_dropped = 0;
  for (const auto& [reason, count] : view_graph_summary.num_dropped) {
    num_dropped += count;
  }
  const size_t largest = components->empty() ? 0 : (*components)[0].size();
  stage.Add("pairs read",
            static_cast<double>(view_graph_summary.num_pairs_read));
  stage.Add("pairs kept", static_cast<double>(view_graph.pairs.size()));
  stage.Add("pairs dropped", static_cast<double>(num_dropped));
  stage.Add("connected images",
            static_cast<double>(view_graph.image_names.size()));
  stage.Add("components", static_cast<double>(components->size()));
  stage.Add("largest component", static_cast<double>(largest));
  stage.Finish("", &summary_.stages);

  if (static_cast<int>(largest) < options_.min_model_size) {
    // Say what was dropped and why: "run a matcher" is wrong advice when the
    // pairs are there but a filter or their configuration removed them.
    std::string dropped;
    for (const auto& [reason, count] : view_graph_summary.num_dropped) {
      dropped +=
          (dropped.empty() ? "" : ", ") + std::to_string(count) + " " + reason;
    }
    throw InputError(
        database.path,
        "no model: the largest connected group of images has " +
            std::to_string(largest) + " image(s), at least " +
            std::to_string(options_.min_model_size) + " are needed (" +
            std::to_string(view_graph.pairs.size()) +
            " usable verified pairs of " +
            std::to_string(view_graph_summary.num_pairs_read) +
            (dropped.empty() ? "" : "; dropped: " + dropped) +
            (view_graph_summary.num_pairs_read == 0
                 ? "; run a matcher"
                 : "; see --ViewGraph.drop_configs, --Mapper.min_num_matches") +
            ")");
  }
  return view_graph;
}

std::vector<ComponentModel> GlobalPipeline::MapComponents(
    const DatabaseContents& database, const ViewGraph& view_graph,
    const std::vector<std::vector<image_t>>& components) {
  std::vector<ComponentModel> models;
  // Why each component gave no model, for the error if none did.
  std::vector<std::string> failures;
  for (size_t c = 0; c < components.size(); ++c) {
    if (static_cast<int>(components[c].size()) < options_.min_model_size) break;
    const std::set<image_t> images(components[c].begin(), components[c].end());
    std::vector<ImagePairGeometry> pairs =
        PairsWithin(view_graph.pairs, images);
    const std::string prefix =
        components.size() > 1 ? "[component " + std::to_string(c) + "] " : "";
    ComponentMapper mapper(stage_options_, database, view_graph.cameras,
                           prefix);
    const FoldEvidence evidence = BuildFoldEvidence(database, pairs, images);
    std::vector<ComponentModel> component_models =
        mapper.Map(evidence, components[c], pairs);
    summary_.notes.insert(summary_.notes.end(), mapper.notes().begin(),
                          mapper.notes().end());
    if (component_models.empty()) {
      LOG(WARNING) << prefix << "no model for the component of "
                   << components[c].size() << " images: " << mapper.failure();
      summary_.notes.push_back("component of " +
                               std::to_string(components[c].size()) +
                               " images gave no model: " + mapper.failure());
      failures.push_back("the component of " +
                         std::to_string(components[c].size()) +
                         " images: " + mapper.failure());
      continue;
    }
    for (ComponentModel& model : component_models) {
      models.push_back(std::move(model));
    }
  }
  if (models.empty()) {
    std::string reasons;
    for (const std::string& failure : failures) {
      reasons += (reasons.empty() ? "" : "; ") + failure;
    }
    throw InputError(
        database.path,
        "no model: no component could be reconstructed (" + reasons + ")");
  }
  // Largest first, by registered images (stable: graph order on ties).
  std::stable_sort(models.begin(), models.end(),
                   [](const ComponentModel& a, const ComponentModel& b) {
                     return a.mapper->reconstruction().images.size() >
                            b.mapper->reconstruction().images.size();
                   });
  return models;
}

std::vector<Reconstruction> GlobalPipeline::FinishModels(
    std::vector<ComponentModel> models) {
  std::vector<Reconstruction> reconstructions;
  for (size_t k = 0; k < models.size(); ++k) {
    GlobalMapper& mapper = *models[k].mapper;
    mapper.set_log_prefix(
        models.size() > 1 ? "[model " + std::to_string(k) + "] " : "");
    const int num_missing = mapper.ColorPoints(image_path_);
    if (num_missing > 0) {
      summary_.notes.push_back(std::to_string(num_missing) +
                               " image(s) missing under " + image_path_ +
                               ": their points are grey");
    }
    Reconstruction& reconstruction = mapper.reconstruction();
    // Keypoints the database held as NaN or inf are no 2D points of a model
    // (never observations; the others keep their order).
    for (const auto& [image_id, count] :
         RemoveNonFinitePoints2D(&reconstruction)) {
      summary_.notes.push_back(
          "image " + std::to_string(image_id) + " (" +
          reconstruction.images.at(image_id).name +
          "): " + std::to_string(count) +
          " non-finite keypoints left out of the model's 2D points (the "
          "others' indices shift down)");
    }
    ComponentReport report;
    report.index = static_cast<int>(k);
    report.num_images_in_graph = static_cast<int>(mapper.images().size());
    report.num_pairs_in_graph = static_cast<int>(mapper.num_component_pairs());
    report.stages = mapper.stages();
    report.in_prior_frame = mapper.in_prior_frame();
    report.rejected_position_priors = mapper.rejected_position_priors();
    report.rejected_gravity_priors = mapper.rejected_gravity_priors();
    if (mapper.fold_checked()) {
      report.fold_score = mapper.fold().fold_score;
      report.folded = models[k].folded;
      report.fold_predicted_pairs = mapper.fold().num_predicted_pairs;
      report.fold_missing_pairs = mapper.fold().num_missing_pairs;
      report.fold_outcome = models[k].fold_outcome;
    }
    report.part_merge = models[k].part_merge;
    report.mean_reprojection_error_per_observation =
        UpdateReprojectionErrors(&reconstruction);
    report.mean_reprojection_error_per_point =
        MeanPointReprojectionError(reconstruction);
    report.num_registered_images =
        static_cast<int>(reconstruction.images.size());
    report.num_points = static_cast<int>(reconstruction.points3D.size());
    report.num_observations = static_cast<int>(NumObservations(reconstruction));
    report.mean_track_length = MeanTrackLength(reconstruction);
    report.images = ComputePoseConstraints(mapper.options().pose_constraint,
                                           reconstruction);
    LogPoorlyConstrainedImages(
        report.images, mapper.options().pose_constraint,
        models.size() > 1 ? "[model " + std::to_string(k) + "] " : "");
    LOG(INFO) << "Model " << k << ": " << report.num_registered_images
              << " registered images (of " << report.num_images_in_graph
              << " in the component), " << report.num_points << " points, "
              << report.num_observations << " observations, mean track length "
              << std::fixed << std::setprecision(2) << report.mean_track_length
              << ", mean reprojection error per observation "
              << std::setprecision(3)
              << report.mean_reprojection_error_per_observation
              << " px, per point " << report.mean_reprojection_error_per_point
              << " px (COLMAP model_analyzer's figure)";
    summary_.components.push_back(report);
    reconstructions.push_back(std::move(reconstruction));
  }
  // A model the fold check still flags is written (the user may know
  // better), but never silently: the last warning names it, summary.json
  // counts it and the mapper command exits with kFoldedExitCode.
  for (const ComponentReport& report : summary_.components) {
    if (!report.folded) continue;
    LOG(WARNING) << "Model " << report.index << " ("
                 << report.num_registered_images
                 << " images) is likely FOLDED: fold score " << std::fixed
                 << std::setprecision(3) << report.fold_score << " ("
                 << report.fold_missing_pairs << " of "
                 << report.fold_predicted_pairs
                 << " predicted overlapping pairs have no matches), outcome \""
                 << report.fold_outcome
                 << "\"; some cameras may sit at their mirrored twin's place";
  }
  return reconstructions;
}

void GlobalPipeline::Write(const std::vector<Reconstruction>& models,
                           const Timer& total_timer,
                           OutputTransaction* output) {
  StageTimer stage("writing");
  // No model with a NaN or inf is written, whatever the options: all are
  // checked before the first is written.
  for (size_t k = 0; k < models.size(); ++k) {
    const std::string problem = NonFiniteValueProblem(models[k]);
    if (!problem.empty()) {
      throw InputError(
          (fs::path(output->OutputPath()) / std::to_string(k)).string(),
          "no model written: model " + std::to_string(k) + " has " + problem +
              " (a numerical failure; are options far from their defaults?)");
    }
  }
  // The options of the run beside every model, as COLMAP's project.ini.
  const std::string options_ini =
      "database_path=" + database_path_ + "\nimage_path=" + image_path_ +
      "\noutput_type=" + output_type_ + "\n" + GlobalMapperOptionsIni(options_);
  for (size_t k = 0; k < models.size(); ++k) {
    const std::string path = output->StagingModelPath(static_cast<int>(k));
    WriteReconstruction(models[k], path, output_type_);
    WriteFileAtomically(path + "/project.ini", options_ini);
    // Where a model in the pose priors' frame sits on the map.
    if (k < summary_.components.size() &&
        summary_.components[k].in_prior_frame) {
      WriteFileAtomically(path + "/prior_frame.txt",
                          PriorFrameText(summary_.pose_priors));
    }
  }
  for (const std::string& stale :
       output->StaleModelDirectories(static_cast<int>(models.size()))) {
    summary_.notes.push_back(stale + " is left over from an earlier run");
  }
  stage.Add("models", static_cast<double>(models.size()));
  stage.Finish("", &summary_.stages);
  summary_.total_seconds = total_timer.ElapsedSeconds();
  summary_.RecordPeakMemory();
  WriteFileAtomically(output->StagingFilePath("summary.json"),
                      summary_.ToJson());
  output->Commit(static_cast<int>(models.size()), {"summary.json"});
  LOG(INFO) << "Wrote " << models.size() << " model(s) and summary.json to "
            << output->OutputPath() << " in " << std::fixed
            << std::setprecision(2) << summary_.total_seconds << " s total";
}

GlobalMapperSummary RunGlobalMapperOnDatabase(
    const GlobalMapperOptions& options, const std::string& database_path,
    const std::string& image_path, const std::string& output_path,
    const std::string& output_type) {
  GlobalPipeline pipeline(options, database_path, image_path, output_path,
                          output_type);
  pipeline.Run();
  return pipeline.summary();
}

std::vector<Reconstruction> RunGlobalMapper(const GlobalMapperOptions& options,
                                            const DatabaseContents& database,
                                            const std::string& image_path,
                                            GlobalMapperSummary* summary) {
  GlobalPipeline pipeline(options, database.path, image_path, "");
  std::vector<Reconstruction> models = pipeline.Reconstruct(database);
  *summary = pipeline.summary();
  return models;
}

}  // namespace colmap_irav4
