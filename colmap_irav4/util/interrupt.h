#pragma once

// Stopping a run from inside the process. The command line stops on Ctrl-C
// through its signal handler (util/atomic_output.h: the temporary output is
// removed, then the process ends); a host that must survive the interrupt
// (the Python module: KeyboardInterrupt) requests it here instead, and the
// long stages stop at their next checkpoint by throwing Interrupted, which
// unwinds through OutputTransaction's destructor (no partial output).
// Checkpoints: every stage (StageTimer), every item of ParallelFor, every
// Ceres iteration of SolveProblem, every vertex the incremental rotation
// engine adds and every L1-IRLS iteration.

#include <stdexcept>

namespace colmap_irav4 {

// Thrown at a checkpoint after RequestInterrupt().
class Interrupted : public std::runtime_error {
 public:
  Interrupted() : std::runtime_error("interrupted") {}
};

// Process-wide; thread-safe (an atomic flag).
void RequestInterrupt();
void ClearInterrupt();
bool InterruptRequested();

// A checkpoint: throws Interrupted if an interrupt was requested.
void ThrowIfInterrupted();

}  // namespace colmap_irav4
