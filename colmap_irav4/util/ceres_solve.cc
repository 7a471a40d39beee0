#include "colmap_irav4/util/ceres_solve.h"

#include <algorithm>
#include <thread>

namespace colmap_irav4 {

int EffectiveNumThreads(int num_threads) {
  if (num_threads > 0) return num_threads;
  return static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
}

}  // namespace colmap_irav4
