#include "colmap_irav4/util/run_summary.h"

#include <sys/resource.h>
#if defined(__GLIBC__)
#include <malloc.h>
#endif
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iomanip>

#include <glog/logging.h>

#include "colmap_irav4/util/interrupt.h"

namespace colmap_irav4 {
namespace {

std::string FormatFigure(double value) {
  std::ostringstream stream;
  if (value == std::floor(value) && std::abs(value) < 1e15) {
    stream << static_cast<long long>(value);
  } else {
    stream << std::fixed << std::setprecision(3) << value;
  }
  return stream.str();
}

}  // namespace

ProcessMemory ReadProcessMemory() {
  ProcessMemory memory;
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    // "VmHWM:    123456 kB"
    double* target = line.rfind("VmRSS:", 0) == 0   ? &memory.current_mib
                     : line.rfind("VmHWM:", 0) == 0 ? &memory.peak_mib
                                                    : nullptr;
    if (target != nullptr) *target = std::atof(line.c_str() + 6) / 1024.0;
  }
  if (memory.peak_mib <= 0) {
    struct rusage usage;
    if (getrusage(RUSAGE_SELF, &usage) == 0) {
      memory.peak_mib = usage.ru_maxrss / 1024.0;  // KiB on Linux and BSD
    }
  }
  return memory;
}

std::string StageReport::LogLine() const {
  std::ostringstream line;
  line << name << ": " << std::fixed << std::setprecision(2) << seconds
       << " s (cpu " << cpu_seconds << " s, peak " << std::setprecision(0)
       << peak_memory_mib << " MiB)" << std::setprecision(2);
  for (const auto& [figure, value] : figures) {
    line << ", " << figure << " " << FormatFigure(value);
  }
  return line.str();
}

void ReleaseFreedMemory() {
#if defined(__GLIBC__)
  malloc_trim(0);
#endif
}

StageTimer::StageTimer(std::string name)
    : report_(std::move(name)), cpu_start_(std::clock()) {
  ThrowIfInterrupted();  // every stage is a checkpoint (util/interrupt.h)
  ReleaseFreedMemory();
  peak_start_mib_ = ReadProcessMemory().peak_mib;
}

const StageReport& StageTimer::Finish(const std::string& prefix,
                                      std::vector<StageReport>* stages) {
  ThrowIfInterrupted();
  report_.seconds = timer_.ElapsedSeconds();
  report_.cpu_seconds =
      static_cast<double>(std::clock() - cpu_start_) / CLOCKS_PER_SEC;
  const ProcessMemory memory = ReadProcessMemory();
  report_.memory_mib = memory.current_mib;
  report_.peak_memory_mib = memory.peak_mib;
  report_.peak_rise_mib = std::max(0.0, memory.peak_mib - peak_start_mib_);
  LOG(INFO) << prefix << report_.LogLine();
  if (stages == nullptr) return report_;
  stages->push_back(report_);
  return stages->back();
}

std::string PeakMemoryStage(
    const std::vector<const std::vector<StageReport>*>& stages) {
  std::string name;
  double peak = 0;
  for (const std::vector<StageReport>* list : stages) {
    for (const StageReport& stage : *list) {
      // A stage that raised the peak to a new highest value; of nested
      // stages ending at the same peak, the first finished (the inner one).
      // Rises under 1 MiB are the kernel counters' lag (a few pages), not
      // the stage's.
      if (stage.peak_rise_mib >= 1 && stage.peak_memory_mib > peak) {
        peak = stage.peak_memory_mib;
        name = stage.name;
      }
    }
  }
  return name;
}

std::string JsonString(const std::string& text) {
  std::string out = "\"";
  for (const char c : text) {
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\t':
        out += "\\t";
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char buffer[8];
          std::snprintf(buffer, sizeof(buffer), "\\u%04x", c);
          out += buffer;
        } else {
          out += c;
        }
    }
  }
  return out + "\"";
}

std::string JsonNumber(double value) {
  if (!std::isfinite(value)) return "null";
  std::ostringstream stream;
  stream << std::setprecision(10) << value;
  return stream.str();
}

void AppendStagesJson(const std::vector<StageReport>& stages,
                      const std::string& indent, std::ostringstream* out) {
  *out << "[";
  for (size_t i = 0; i < stages.size(); ++i) {
    const StageReport& stage = stages[i];
    *out << (i ? "," : "") << "\n"
         << indent << "  {\"name\": " << JsonString(stage.name)
         << ", \"seconds\": " << JsonNumber(stage.seconds)
         << ", \"cpu_seconds\": " << JsonNumber(stage.cpu_seconds)
         << ", \"memory_mib\": " << JsonNumber(stage.memory_mib)
         << ", \"peak_memory_mib\": " << JsonNumber(stage.peak_memory_mib)
         << ", \"peak_rise_mib\": " << JsonNumber(stage.peak_rise_mib);
    for (const auto& [name, value] : stage.figures) {
      *out << ", " << JsonString(name) << ": " << JsonNumber(value);
    }
    for (const auto& [name, text] : stage.texts) {
      *out << ", " << JsonString(name) << ": " << JsonString(text);
    }
    *out << "}";
  }
  *out << (stages.empty() ? "" : "\n" + indent) << "]";
}

}  // namespace colmap_irav4
