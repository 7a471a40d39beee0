#include "colmap_irav4/util/threading.h"

#include <atomic>
#include <chrono>
#include <cmath>
#include <mutex>
#include <numeric>
#include <set>
#include <stdexcept>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

namespace colmap_irav4 {
namespace {

TEST(ResolveNumThreads, MinusOneIsAllCoresPositiveIsKept) {
  const int cores =
      static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  EXPECT_EQ(ResolveNumThreads(-1), cores);
  EXPECT_EQ(ResolveNumThreads(0), cores);
  EXPECT_EQ(ResolveNumThreads(1), 1);
  EXPECT_EQ(ResolveNumThreads(7), 7);
}

TEST(ParallelFor, EveryIndexOnceSameResultForEveryThreadCount) {
  const size_t n = 1000;
  std::vector<double> reference;
  for (const int num_threads : {1, 2, 3, 8, -1}) {
    std::vector<double> out(n, 0);
    std::vector<std::atomic<int>> calls(n);
    ParallelFor(num_threads, n, [&](size_t i) {
      ++calls[i];
      out[i] = std::sqrt(static_cast<double>(i)) * 3.0;
    });
    for (size_t i = 0; i < n; ++i) ASSERT_EQ(calls[i].load(), 1) << i;
    if (reference.empty()) reference = out;
    EXPECT_EQ(out, reference) << num_threads << " threads";
  }
  ParallelFor(4, 0, [](size_t) { FAIL() << "no item"; });
}

TEST(ParallelFor, UsesAtMostTheGivenNumberOfThreads) {
  for (const int num_threads : {1, 2, 3}) {
    std::mutex mutex;
    std::set<std::thread::id> ids;
    std::atomic<int> running(0);
    std::atomic<int> max_running(0);
    ParallelFor(num_threads, 64, [&](size_t) {
      const int now = ++running;
      int seen = max_running.load();
      while (now > seen && !max_running.compare_exchange_weak(seen, now)) {
      }
      {
        std::lock_guard<std::mutex> lock(mutex);
        ids.insert(std::this_thread::get_id());
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
      --running;
    });
    EXPECT_LE(static_cast<int>(ids.size()), num_threads);
    EXPECT_LE(max_running.load(), num_threads);
    if (num_threads == 1) {
      EXPECT_EQ(*ids.begin(), std::this_thread::get_id());
    }
  }
  // Never more threads than items.
  std::mutex mutex;
  std::set<std::thread::id> ids;
  ParallelFor(8, 2, [&](size_t) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    std::lock_guard<std::mutex> lock(mutex);
    ids.insert(std::this_thread::get_id());
  });
  EXPECT_LE(ids.size(), 2u);
}

TEST(ParallelFor, RethrowsTheBodysException) {
  for (const int num_threads : {1, 3}) {
    std::atomic<int> calls(0);
    std::atomic<bool> thrown(false);
    EXPECT_THROW(ParallelFor(num_threads, 10000,
                             [&](size_t i) {
                               ++calls;
                               if (i == 5) {
                                 thrown = true;
                                 throw std::runtime_error("item 5");
                               }
                               // Items after the throw take 1 ms, so that
                               // the other threads cannot run out all
                               // 10,000 while the throwing one is
                               // descheduled before it stops the handing
                               // out (seen on a loaded 2-core machine);
                               // they can only if it never stops (3 s).
                               if (thrown) {
                                 std::this_thread::sleep_for(
                                     std::chrono::milliseconds(1));
                               }
                             }),
                 std::runtime_error);
    // Handing out stops after the failure (a few items already taken by
    // other threads may still run).
    EXPECT_LT(calls.load(), 10000);
  }
}

TEST(LimitBlasThreads, CallsOnlyRuntimesPresentInTheProcess) {
  // This test binary links no BLAS / OpenMP runtime of its own; whatever
  // Ceres pulled in is limited, and the call never fails.
  const int called = LimitBlasThreads(1);
  EXPECT_GE(called, 0);
  EXPECT_LE(called, 5);
  EXPECT_EQ(LimitBlasThreads(-1), called);
}

}  // namespace
}  // namespace colmap_irav4
