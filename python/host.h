#pragma once

// Running the library's work from Python: its glog messages go to Python's
// logging, long work runs without the GIL, and Ctrl-C stops it cleanly.

#include <functional>

namespace colmap_irav4 {
namespace python {

// glog for the module, called at import: no log files and nothing on stderr
// below FATAL (the messages reach Python's logging through RunInPython). If
// the process already initialised glog (another module), its set-up stays.
void InitLogging();

// Runs `work` (C++ only: it must not touch Python objects) on a worker
// thread with the GIL released, one run at a time per process. Meanwhile the
// calling thread forwards the library's log messages to the Python logger
// "colmap_irav4" and checks for signals every 50 ms: a KeyboardInterrupt
// (or an exception of a logging handler) requests an interrupt
// (util/interrupt.h), the work stops at its next checkpoint, unwinding
// through its destructors (a mapper's temporary output is removed), and the
// Python exception is raised once the worker has finished. Exceptions of
// `work` are rethrown (the module translates InputError to ValueError).
void RunInPython(const std::function<void()>& work);

}  // namespace python
}  // namespace colmap_irav4
