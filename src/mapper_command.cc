// colmap_irav4 mapper: COLMAP database -> COLMAP sparse models, with the
// global pipeline of colmap_irav4/pipeline/global_pipeline.h:
//   colmap_irav4 mapper --database_path DB --image_path IMAGES
//                       --output_path SPARSE
// writes SPARSE/0, SPARSE/1, ... (largest first, each with its
// project.ini) and SPARSE/summary.json. `colmap_irav4 global_mapper` is the
// same command accepting COLMAP 4's flags of its global_mapper as well
// (AddColmap4GlobalMapperFlags).

#include <iostream>
#include <optional>

#include "colmap_irav4/pipeline/global_pipeline.h"
#include "colmap_irav4/pipeline/option_registration.h"
#include "colmap_irav4/util/option_manager.h"
#include "colmap_irav4/util/threading.h"
#include "src/command.h"

namespace colmap_irav4 {
namespace {

int RunMapper(int argc, char** argv, bool colmap4_names) {
  std::string database_path;
  std::string image_path;
  std::string output_path;
  std::string output_type = "BIN";
  GlobalMapperOptions options;
  OptionManager manager(
      colmap4_names ? "global_mapper" : "mapper",
      "Global Structure-from-Motion: reads a COLMAP database (read-only) and\n"
      "writes one COLMAP sparse model per connected component of at least\n"
      "--Mapper.min_model_size images into OUTPUT/0, OUTPUT/1, ... (largest\n"
      "first), and OUTPUT/summary.json with the figures of every stage.\n"
      "Exit code 3: the models were written, but at least one is still\n"
      "flagged folded (symmetric scene; see --Fold.* and summary.json).\n"
      "Pose priors (GPS, gravity): read from the database (COLMAP >= 3.9's\n"
      "feature_extractor stores EXIF GPS there) or --Mapper.pose_prior_path\n"
      "(IMAGE_NAME X Y Z lines, COLMAP 3.8 model_aligner's format). A model\n"
      "with 3+ position priors is placed in their frame (robust to outliers;\n"
      "gravity sets the up axis), refined with them (priors beyond\n"
      "--Mapper.prior_gate_std standard deviations left out; summary.json\n"
      "lists them) and written there: metres, WGS84 as east-north-up at\n"
      "the origin in OUTPUT/k/prior_frame.txt; no normalisation. A fold\n"
      "the images leave silent is settled by them: candidate turned groups\n"
      "are mapped again and kept where the priors agree clearly better\n"
      "(--Fold.settle_with_priors).\n"
      "--Mapper.use_pose_priors 0: ignore.");
  manager.AddRequired("database_path", &database_path,
                      "COLMAP database (opened read-only)");
  manager.Add("image_path", &image_path,
              "images, for point colours (empty: grey points)");
  manager.AddRequired("output_path", &output_path,
                      "output directory (created if missing)");
  manager.Add("output_type", &output_type, "BIN or TXT");
  AddGlobalMapperOptions(&manager, &options);
  if (colmap4_names) AddColmap4GlobalMapperFlags(&manager);
  if (!manager.Parse(argc, argv)) return 0;
  // The pipeline checks the options; the manager names a flag as typed.
  std::optional<GlobalPipeline> optional_pipeline;
  manager.Check([&] {
    optional_pipeline.emplace(options, database_path, image_path, output_path,
                              output_type);
  });
  GlobalPipeline& pipeline = *optional_pipeline;
  // Before any solve: a BLAS / OpenMP runtime loaded with Ceres would
  // otherwise start one thread per core.
  LimitBlasThreads(options.num_threads);
  pipeline.Run();
  const GlobalMapperSummary& summary = pipeline.summary();
  if (summary.components.empty()) return 1;
  return summary.NumFoldedModels() > 0 ? kFoldedExitCode : 0;
}

static CommandRegistrar registrar(
    "mapper",
    "Global SfM: COLMAP database -> COLMAP sparse models (IRAv4 rotations)",
    [](int argc, char** argv) { return RunMapper(argc, argv, false); });
static CommandRegistrar global_mapper_registrar(
    "global_mapper",
    "mapper under COLMAP 4's name, accepting its --GlobalMapper.* flags",
    [](int argc, char** argv) { return RunMapper(argc, argv, true); });

}  // namespace
}  // namespace colmap_irav4
