#include "colmap_irav4/util/interrupt.h"

#include <signal.h>

#include <atomic>
#include <cstring>
#include <filesystem>

#include <gtest/gtest.h>

#include "colmap_irav4/util/atomic_output.h"
#include "colmap_irav4/util/ceres_solve.h"
#include "colmap_irav4/util/run_summary.h"
#include "colmap_irav4/util/threading.h"

namespace colmap_irav4 {
namespace {

namespace fs = std::filesystem;

// Clears the flag whatever a test does.
class InterruptTest : public ::testing::Test {
 protected:
  void SetUp() override { ClearInterrupt(); }
  void TearDown() override { ClearInterrupt(); }
};

TEST_F(InterruptTest, ParallelForStopsAtTheNextItem) {
  for (int num_threads : {1, 2}) {
    std::atomic<int> num_run(0);
    EXPECT_THROW(ParallelFor(num_threads, 1000,
                             [&](size_t i) {
                               if (i == 10) RequestInterrupt();
                               ++num_run;
                             }),
                 Interrupted);
    EXPECT_LT(num_run.load(), 1000);
    ClearInterrupt();
    num_run = 0;
    ParallelFor(num_threads, 1000, [&](size_t) { ++num_run; });
    EXPECT_EQ(num_run.load(), 1000);
  }
}

TEST_F(InterruptTest, StagesAreCheckpoints) {
  RequestInterrupt();
  EXPECT_THROW(StageTimer("stage"), Interrupted);
  ClearInterrupt();
  StageTimer stage("stage");
  RequestInterrupt();
  EXPECT_THROW(stage.Finish("", nullptr), Interrupted);
}

// f(x) = (x - 3)^2, with an interrupt requested during the first
// evaluation: the solve stops and throws instead of converging.
struct InterruptingCost {
  template <typename T>
  bool operator()(const T* x, T* residual) const {
    RequestInterrupt();
    residual[0] = x[0] - T(3.0);
    return true;
  }
};

TEST_F(InterruptTest, SolveProblemStopsAndThrows) {
  double x = 0;
  ceres::Problem problem;
  problem.AddResidualBlock(
      new ceres::AutoDiffCostFunction<InterruptingCost, 1, 1>(
          new InterruptingCost),
      nullptr, &x);
  SolverOptions options;
  options.ceres.num_threads = 1;
  EXPECT_THROW(SolveProblem("test", options, &problem), Interrupted);
}

bool g_host_handler_called = false;
void HostHandler(int) { g_host_handler_called = true; }

// A host's own SIGINT handler (Python's) stays in place during a
// transaction: the host stops the run, the destructor cleans up.
TEST_F(InterruptTest, OutputTransactionKeepsTheHostsSigintHandler) {
  struct sigaction host, old, during;
  std::memset(&host, 0, sizeof(host));
  host.sa_handler = HostHandler;
  sigemptyset(&host.sa_mask);
  ASSERT_EQ(sigaction(SIGINT, &host, &old), 0);
  const fs::path dir =
      fs::temp_directory_path() /
      ("colmap_irav4_interrupt_test_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  std::string temporary;
  {
    // No old model in the fresh directory: nothing for the check to read.
    OutputTransaction output(dir.string(), {}, [](const std::string&, bool) {});
    temporary = output.TemporaryPath();
    ASSERT_EQ(sigaction(SIGINT, nullptr, &during), 0);
    EXPECT_EQ(during.sa_handler, &HostHandler);
    raise(SIGINT);  // the host's handler runs; the process goes on
    EXPECT_TRUE(g_host_handler_called);
    EXPECT_TRUE(fs::exists(temporary));
  }
  EXPECT_FALSE(fs::exists(temporary));  // removed, no partial output
  ASSERT_EQ(sigaction(SIGINT, nullptr, &during), 0);
  EXPECT_EQ(during.sa_handler, &HostHandler);
  sigaction(SIGINT, &old, nullptr);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace colmap_irav4
