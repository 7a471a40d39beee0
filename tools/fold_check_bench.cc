// Cost of the fold check (refinement/fold_detection.h) on a mapped model:
//   fold_check_bench DATABASE MODEL_DIR
// runs DetectFold on MODEL_DIR with the database's evidence (verified pairs
// and their inlier counts; no measured rotations, so the contradicted-pair
// and suspect figures are left out) with and without the distant-pair skip,
// and prints wall and CPU seconds and the report of each (they must agree).

#include <ctime>
#include <iomanip>
#include <iostream>
#include <set>

#include "colmap_irav4/io/database.h"
#include "colmap_irav4/io/model_io.h"
#include "colmap_irav4/pipeline/component_mapper.h"
#include "colmap_irav4/refinement/fold_detection.h"
#include "colmap_irav4/util/timer.h"

using namespace colmap_irav4;

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: " << argv[0] << " DATABASE MODEL_DIR\n";
    return 2;
  }
  try {
    const DatabaseContents database = ReadDatabase(argv[1]);
    const Reconstruction model = ReadReconstruction(argv[2]);
    std::set<image_t> images;
    for (const auto& [image_id, image] : model.images) images.insert(image_id);
    const FoldEvidence evidence = BuildFoldEvidence(database, {}, images);
    std::cout << model.images.size() << " images, " << model.points3D.size()
              << " points, " << evidence.pairs.size() << " pairs of evidence\n";
    for (const bool skip : {true, false}) {
      FoldDetectionOptions options;
      options.skip_distant_pairs = skip;
      Timer timer;
      const std::clock_t cpu_start = std::clock();
      const FoldReport report = DetectFold(options, model, evidence);
      const double cpu =
          static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC;
      std::cout << "skip_distant_pairs " << skip << ": " << std::fixed
                << std::setprecision(2) << timer.ElapsedSeconds() << " s wall, "
                << cpu << " s cpu; " << report.Describe() << "\n";
    }
  } catch (const std::exception& error) {
    std::cerr << "ERROR: " << error.what() << "\n";
    return 1;
  }
  return 0;
}
