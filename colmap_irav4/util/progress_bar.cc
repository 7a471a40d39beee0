#include "colmap_irav4/util/progress_bar.h"

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <iomanip>
#include <iostream>
#include <sstream>

namespace colmap_irav4 {
namespace {
constexpr int kBarWidth = 30;
}  // namespace

ProgressBar::ProgressBar(std::string label, int64_t total, bool enabled,
                         std::ostream* stream, int interactive)
    : label_(std::move(label)),
      total_(std::max<int64_t>(total, 1)),
      enabled_(enabled),
      stream_(stream != nullptr ? stream : &std::cerr),
      interactive_(interactive < 0 ? isatty(fileno(stderr)) != 0
                                   : interactive != 0) {}

ProgressBar::~ProgressBar() {
  if (enabled_ && !finished_ && interactive_ && last_width_ >= 0) {
    *stream_ << std::endl;  // leave the partial bar on its own line
  }
}

void ProgressBar::Update(int64_t done) {
  done_ = std::clamp<int64_t>(done, 0, total_);
  if (enabled_) Draw();
}

void ProgressBar::Finish() {
  if (finished_) return;
  done_ = total_;
  if (enabled_) {
    Draw();
    if (interactive_) *stream_ << std::endl;
  }
  finished_ = true;
}

void ProgressBar::Draw() {
  const int percent = static_cast<int>(100 * done_ / total_);
  std::ostringstream line;
  if (interactive_) {
    const int filled = static_cast<int>(kBarWidth * done_ / total_);
    if (filled == last_width_ && done_ != total_) return;
    last_width_ = filled;
    line << '\r' << label_ << " [" << std::string(filled, '=')
         << (filled < kBarWidth ? ">" : "")
         << std::string(std::max(0, kBarWidth - filled - 1), ' ') << "] "
         << std::setw(3) << percent << "% (" << done_ << "/" << total_ << ") "
         << std::fixed << std::setprecision(1) << timer_.ElapsedSeconds()
         << " s";
    *stream_ << line.str() << std::flush;
  } else {
    const int decile = percent / 10;
    if (decile == last_decile_) return;
    last_decile_ = decile;
    line << label_ << ": " << percent << "% (" << done_ << "/" << total_ << ") "
         << std::fixed << std::setprecision(1) << timer_.ElapsedSeconds()
         << " s\n";
    *stream_ << line.str() << std::flush;
  }
}

}  // namespace colmap_irav4
