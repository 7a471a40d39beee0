#pragma once

// The figures of a run's stages: a stage timer that measures wall and CPU
// time, the per-stage report (also the log line and a summary.json entry),
// and the small JSON writer summary.json is made of.

#include <ctime>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "colmap_irav4/util/timer.h"

namespace colmap_irav4 {

// The process's resident memory (Linux: /proc/self/status VmRSS and VmHWM;
// elsewhere the peak from getrusage and no current figure: 0).
struct ProcessMemory {
  double current_mib = 0;  // resident now
  double peak_mib = 0;     // highest resident so far (never reset)
};
ProcessMemory ReadProcessMemory();

// One stage's figures.
struct StageReport {
  StageReport() = default;
  explicit StageReport(std::string stage_name) : name(std::move(stage_name)) {}
  std::string name;
  double seconds = 0;      // wall time
  double cpu_seconds = 0;  // process CPU time (all threads) during the stage
  // Resident memory at the end of the stage, the process's peak so far, and
  // how much the stage raised that peak: the stage whose rise reaches the
  // run's peak holds it (the allocator may keep freed memory resident, so
  // the current figure is an upper bound of what the stage left).
  double memory_mib = 0;
  double peak_memory_mib = 0;
  double peak_rise_mib = 0;
  // Named figures in order, e.g. {"pairs", 55}, {"points", 1234}.
  std::vector<std::pair<std::string, double>> figures;

  // Named texts in order (e.g. {"linear solver", "SPARSE_SCHUR: ..."}):
  // summary.json strings, not in the log line.
  std::vector<std::pair<std::string, std::string>> texts;

  void Add(const std::string& figure, double value) {
    figures.emplace_back(figure, value);
  }
  void AddText(const std::string& name, const std::string& text) {
    texts.emplace_back(name, text);
  }
  // "name: 1.23 s (cpu 0.45 s, peak 120 MiB), pairs 55, ..." (integers
  // without decimals).
  std::string LogLine() const;
};

// Gives the pages of freed heap memory back to the system (glibc's
// malloc_trim; nothing elsewhere). glibc keeps them resident in the middle
// of its heap: without this, a stage's peak sits on the heap an earlier
// stage grew (5,000 photo images: the second positioning peaked as high
// with the first model's 377 MiB of keypoints released as without).
void ReleaseFreedMemory();

// Times one stage from construction (first releasing the memory freed
// before it, ReleaseFreedMemory): Finish() stops the clocks, logs the
// stage's line (prefixed, e.g. "[component 1] ") and appends the report to
// `stages`. CPU time is the process's, so that a loaded machine (wall time
// alone) or extra threads (CPU over wall) show.
class StageTimer {
 public:
  explicit StageTimer(std::string name);

  StageReport& report() { return report_; }
  void Add(const std::string& figure, double value) {
    report_.Add(figure, value);
  }
  void AddText(const std::string& name, const std::string& text) {
    report_.AddText(name, text);
  }

  // Stops the clocks, logs, appends to *stages (if not null) and returns the
  // report.
  const StageReport& Finish(const std::string& prefix,
                            std::vector<StageReport>* stages);

 private:
  StageReport report_;
  Timer timer_;
  std::clock_t cpu_start_;
  double peak_start_mib_;
};

// The stage that raised the process's memory to its highest peak among
// `stages` (lists in any order; "" when none raised it).
std::string PeakMemoryStage(
    const std::vector<const std::vector<StageReport>*>& stages);

// JSON pieces: a quoted, escaped string; a number (non-finite: null); a list
// of stages [{"name": ..., "seconds": ..., "cpu_seconds": ..., "memory_mib":
// ..., "peak_memory_mib": ..., "peak_rise_mib": ..., <figures>}, ...]
// indented by `indent`.
std::string JsonString(const std::string& text);
std::string JsonNumber(double value);
void AppendStagesJson(const std::vector<StageReport>& stages,
                      const std::string& indent, std::ostringstream* out);

}  // namespace colmap_irav4
