// colmap_irav4 model_converter: converts a COLMAP sparse model between the
// binary and text formats, as `colmap model_converter` does.

#include <iostream>
#include <string>

#include <glog/logging.h>

#include "colmap_irav4/io/model_io.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/option_manager.h"
#include "src/command.h"

namespace colmap_irav4 {
namespace {

int RunModelConverter(int argc, char** argv) {
  std::string input_path;
  std::string output_path;
  std::string output_type = "BIN";
  OptionManager options(
      "model_converter",
      "Converts a COLMAP model (cameras, images, points3D) between the "
      "binary and text formats.");
  options.AddRequired("input_path", &input_path,
                      "model directory (.bin or .txt files)");
  options.AddRequired("output_path", &output_path,
                      "output directory (created if missing)");
  options.Add("output_type", &output_type, "BIN or TXT");
  if (!options.Parse(argc, argv)) return 0;
  if (output_type != "BIN" && output_type != "TXT" && output_type != "bin" &&
      output_type != "txt") {
    throw InputError("--output_type",
                     "must be BIN or TXT, got '" + output_type + "'");
  }

  const Reconstruction reconstruction = ReadReconstruction(input_path);
  WriteReconstruction(reconstruction, output_path, output_type);
  LOG(INFO) << "Wrote " << reconstruction.cameras.size() << " cameras, "
            << reconstruction.images.size() << " images, "
            << reconstruction.points3D.size() << " points3D to " << output_path
            << " (" << output_type << ")";
  return 0;
}

CommandRegistrar registrar("model_converter",
                           "Converts a COLMAP model between BIN and TXT",
                           RunModelConverter);

}  // namespace
}  // namespace colmap_irav4
