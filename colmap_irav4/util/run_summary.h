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

// One stage's figures.
struct StageReport {
  StageReport() = default;
  explicit StageReport(std::string stage_name) : name(std::move(stage_name)) {}
  std::string name;
  double seconds = 0;      // wall time
  double cpu_seconds = 0;  // process CPU time (all threads) during the stage
  // Named figures in order, e.g. {"pairs", 55}, {"points", 1234}.
  std::vector<std::pair<std::string, double>> figures;

  void Add(const std::string& figure, double value) {
    figures.emplace_back(figure, value);
  }
  // "name: 1.23 s (cpu 0.45 s), pairs 55, ..." (integers without decimals).
  std::string LogLine() const;
};

// Times one stage from construction: Finish() stops the clocks, logs the
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

  // Stops the clocks, logs, appends to *stages (if not null) and returns the
  // report.
  const StageReport& Finish(const std::string& prefix,
                            std::vector<StageReport>* stages);

 private:
  StageReport report_;
  Timer timer_;
  std::clock_t cpu_start_;
};

// JSON pieces: a quoted, escaped string; a number (non-finite: null); a list
// of stages [{"name": ..., "seconds": ..., <figures>}, ...] indented by
// `indent`.
std::string JsonString(const std::string& text);
std::string JsonNumber(double value);
void AppendStagesJson(const std::vector<StageReport>& stages,
                      const std::string& indent, std::ostringstream* out);

}  // namespace colmap_irav4
