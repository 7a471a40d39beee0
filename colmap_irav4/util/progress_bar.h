#pragma once

#include <cstdint>
#include <ostream>
#include <string>

#include "colmap_irav4/util/timer.h"

namespace colmap_irav4 {

// A progress bar for long stages. On a terminal it redraws one line
//   bundle adjustment [=========>          ]  45% (45/100) 12.3 s
// in place; otherwise (a log file, CI) it prints a line at every 10% step so
// that logs stay short. Disabled bars print nothing.
class ProgressBar {
 public:
  // `stream` defaults to std::cerr; `interactive` -1 = detect (isatty).
  ProgressBar(std::string label, int64_t total, bool enabled = true,
              std::ostream* stream = nullptr, int interactive = -1);
  ~ProgressBar();

  // Sets the amount of work done (clamped to [0, total]).
  void Update(int64_t done);
  // Marks the work complete and ends the line.
  void Finish();

  int64_t total() const { return total_; }

 private:
  void Draw();

  std::string label_;
  int64_t total_;
  int64_t done_ = 0;
  bool enabled_;
  std::ostream* stream_;
  bool interactive_;
  int last_decile_ = -1;
  int last_width_ = -1;
  bool finished_ = false;
  Timer timer_;
};

}  // namespace colmap_irav4
