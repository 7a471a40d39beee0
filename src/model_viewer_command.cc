// colmap_irav4 model_viewer: a PNG (or JPEG) picture of a sparse model, top
// and side views of the points and camera frusta, without a display:
//   colmap_irav4 model_viewer --input_path sparse/0 --output_path view.png

#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include <glog/logging.h>
#include <opencv2/imgcodecs.hpp>

#include "colmap_irav4/eval/model_render.h"
#include "colmap_irav4/io/model_io.h"
#include "colmap_irav4/util/atomic_output.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/option_manager.h"
#include "src/command.h"

namespace colmap_irav4 {
namespace {

int RunModelViewer(int argc, char** argv) {
  std::string input_path;
  std::string output_path;
  ModelRenderOptions options;
  OptionManager manager(
      "model_viewer",
      "Renders a COLMAP model's points and camera frusta (top and side views)\n"
      "into an image file.");
  manager.AddRequired("input_path", &input_path,
                      "model directory (.bin or .txt)");
  manager.AddRequired("output_path", &output_path, "image file (.png or .jpg)");
  manager.Add("width", &options.width, "picture width (px)");
  manager.Add("height", &options.height, "picture height (px)");
  manager.Add("point_radius", &options.point_radius_px,
              "point radius (px, 0: one pixel)");
  manager.Add("frustum_scale", &options.frustum_scale,
              "frustum depth, fraction of the model's extent");
  manager.Add("extent_percentile", &options.extent_percentile,
              "view extent: this percentile range of points and centres");
  if (!manager.Parse(argc, argv)) return 0;
  options.Check();
  const std::string extension =
      std::filesystem::path(output_path).extension().string();
  if (extension != ".png" && extension != ".jpg" && extension != ".jpeg") {
    throw InputError(output_path, "output must end in .png, .jpg or .jpeg");
  }
  std::vector<std::string> inputs;
  for (const char* name : {"cameras", "images", "points3D"}) {
    for (const char* extension : {".bin", ".txt"}) {
      inputs.push_back(input_path + "/" + name + extension);
    }
  }
  CheckFileWritable(output_path, inputs);  // before any work
  const Reconstruction model = ReadReconstruction(input_path);
  if (model.images.empty()) throw InputError(input_path, "model has no images");
  const cv::Mat picture = RenderModel(model, options);
  // Encoded in memory, then written as every output file is (complete or
  // absent; a pipe or device written into, never replaced).
  std::vector<uchar> bytes;
  bool encoded = false;
  try {
    encoded =
        cv::imencode(extension == ".png" ? ".png" : ".jpg", picture, bytes);
  } catch (const cv::Exception& error) {
    encoded = false;
  }
  if (!encoded) throw InputError(output_path, "cannot encode the image");
  WriteFileAtomically(output_path, std::string(bytes.begin(), bytes.end()));
  LOG(INFO) << "Wrote " << output_path << " (" << picture.cols << "x"
            << picture.rows << "): " << model.images.size() << " cameras, "
            << model.points3D.size() << " points";
  return 0;
}

CommandRegistrar registrar("model_viewer",
                           "Renders a model (points, camera frusta) into a PNG",
                           RunModelViewer);

}  // namespace
}  // namespace colmap_irav4
