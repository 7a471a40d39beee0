#pragma once

// The project's only source of worker threads (besides Ceres, which receives
// the same thread count): a bounded parallel loop, the resolution of the
// user's --*.num_threads (-1: all cores), and a run-time limit on the threads
// of the BLAS / OpenMP runtime that Ceres or Eigen may have been linked with.

#include <cstddef>
#include <functional>

namespace colmap_irav4 {

// The number of threads to use for a user setting: num_threads if > 0, else
// (-1 or 0) the number of cores (at least 1).
int ResolveNumThreads(int num_threads);

// Calls body(i) for every i in [0, n) on at most ResolveNumThreads(num_threads)
// threads (the calling thread is one of them; no more threads than items).
// Items are handed out one by one, so uneven items balance; each body(i)
// must write only its own slot of the output, which makes the result
// independent of the thread count and of the scheduling. An exception thrown
// by a body stops the handing out of further items and is rethrown here
// (the first one, if several threads throw).
void ParallelFor(int num_threads, size_t n,
                 const std::function<void(size_t)>& body);

// Limits the threads of the BLAS / OpenMP runtime in this process, when one
// is loaded (OpenBLAS's openblas_set_num_threads / goto_set_num_threads,
// OpenMP's omp_set_num_threads, looked up at run time: no link dependency on a
// specific BLAS). num_threads as ResolveNumThreads. Returns the number of
// runtime functions called (0: no such runtime in the process). Call it at
// the start of a command, before any solve.
int LimitBlasThreads(int num_threads);

}  // namespace colmap_irav4
