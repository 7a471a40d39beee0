// Accuracy of every model a mapper wrote against a ground-truth model, for
// the symmetric-scene benchmark (scripts/symmetric_benchmark.sh):
//   fold_eval GT_MODEL_DIR SPARSE_DIR
// prints one line
//   models N registered R turned T centre_median_m C centre_mean_m D
// where, per model (SPARSE_DIR/0, /1, ...), the model is aligned onto the
// ground truth by a robust similarity over the camera centres, T counts the
// cameras whose rotation is off by more than 30 deg (summed over models), C
// is the median centre error over all registered cameras and D their mean
// (metres of the ground truth). Models that cannot be aligned count all
// their cameras as turned and are left out of the centre errors.

#include <algorithm>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <numeric>
#include <vector>

#include "colmap_irav4/eval/model_alignment.h"
#include "colmap_irav4/io/model_io.h"

namespace fs = std::filesystem;
using namespace colmap_irav4;

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: " << argv[0] << " GT_MODEL_DIR SPARSE_DIR\n";
    return 2;
  }
  try {
    const Reconstruction truth = ReadReconstruction(argv[1]);
    const std::map<std::string, Rigid3d> reference = PosesByName(truth);
    int num_models = 0;
    int num_registered = 0;
    int num_turned = 0;
    std::vector<double> center_errors;
    for (int k = 0;; ++k) {
      const fs::path path = fs::path(argv[2]) / std::to_string(k);
      if (!ExistsBinaryModel(path.string()) &&
          !ExistsTextModel(path.string())) {
        break;
      }
      const Reconstruction model = ReadReconstruction(path.string());
      ++num_models;
      num_registered += static_cast<int>(model.images.size());
      SimilarityRansacOptions options;
      PoseComparison comparison;
      if (!ComparePoses(PosesByName(model), reference, options, &comparison)) {
        num_turned += static_cast<int>(model.images.size());
        continue;
      }
      for (size_t i = 0; i < comparison.names.size(); ++i) {
        num_turned += comparison.rotation_errors_deg[i] > 30.0;
        center_errors.push_back(comparison.center_errors[i]);
      }
    }
    double median = -1;
    double mean = -1;
    if (!center_errors.empty()) {
      std::vector<double> sorted = center_errors;
      std::sort(sorted.begin(), sorted.end());
      median = sorted[sorted.size() / 2];
      mean = std::accumulate(sorted.begin(), sorted.end(), 0.0) / sorted.size();
    }
    std::cout << std::fixed << std::setprecision(4) << "models " << num_models
              << " registered " << num_registered << " turned " << num_turned
              << " centre_median_m " << median << " centre_mean_m " << mean
              << "\n";
  } catch (const std::exception& error) {
    std::cerr << "ERROR: " << error.what() << "\n";
    return 1;
  }
  return 0;
}
