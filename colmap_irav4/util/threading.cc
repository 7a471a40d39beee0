#include "colmap_irav4/util/threading.h"

#include <dlfcn.h>

#include <algorithm>
#include <atomic>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

#include <glog/logging.h>

#include "colmap_irav4/util/interrupt.h"

namespace colmap_irav4 {

int ResolveNumThreads(int num_threads) {
  if (num_threads > 0) return num_threads;
  return static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
}

void ParallelFor(int num_threads, size_t n,
                 const std::function<void(size_t)>& body) {
  if (n == 0) return;
  const size_t num_workers =
      std::min<size_t>(static_cast<size_t>(ResolveNumThreads(num_threads)), n);
  // Every item is an interrupt checkpoint (util/interrupt.h).
  if (num_workers == 1) {
    for (size_t i = 0; i < n; ++i) {
      ThrowIfInterrupted();
      body(i);
    }
    return;
  }
  std::atomic<size_t> next(0);
  std::atomic<bool> failed(false);
  std::exception_ptr first_error;
  std::mutex error_mutex;
  auto worker = [&]() {
    while (!failed.load(std::memory_order_relaxed)) {
      const size_t i = next.fetch_add(1);
      if (i >= n) return;
      try {
        ThrowIfInterrupted();
        body(i);
      } catch (...) {
        std::lock_guard<std::mutex> lock(error_mutex);
        if (!first_error) first_error = std::current_exception();
        failed = true;
      }
    }
  };
  std::vector<std::thread> threads;
  threads.reserve(num_workers - 1);
  for (size_t t = 1; t < num_workers; ++t) threads.emplace_back(worker);
  worker();
  for (std::thread& thread : threads) thread.join();
  if (first_error) std::rethrow_exception(first_error);
}

int LimitBlasThreads(int num_threads) {
  const int resolved = ResolveNumThreads(num_threads);
  int num_called = 0;
  // RTLD_DEFAULT searches every library loaded into the process: the symbols
  // exist only when Ceres / SuiteSparse / LAPACK pulled in such a runtime.
  for (const char* name : {"openblas_set_num_threads", "goto_set_num_threads",
                           "omp_set_num_threads", "bli_thread_set_num_threads",
                           "MKL_Set_Num_Threads"}) {
    void* symbol = dlsym(RTLD_DEFAULT, name);
    if (symbol == nullptr) continue;
    reinterpret_cast<void (*)(int)>(symbol)(resolved);
    VLOG(1) << name << "(" << resolved << ")";
    ++num_called;
  }
  return num_called;
}

}  // namespace colmap_irav4
