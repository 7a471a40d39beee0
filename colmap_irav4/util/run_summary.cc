#include "colmap_irav4/util/run_summary.h"

#include <cmath>
#include <cstdio>
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

std::string StageReport::LogLine() const {
  std::ostringstream line;
  line << name << ": " << std::fixed << std::setprecision(2) << seconds
       << " s (cpu " << cpu_seconds << " s)";
  for (const auto& [figure, value] : figures) {
    line << ", " << figure << " " << FormatFigure(value);
  }
  return line.str();
}

StageTimer::StageTimer(std::string name)
    : report_(std::move(name)), cpu_start_(std::clock()) {
  ThrowIfInterrupted();  // every stage is a checkpoint (util/interrupt.h)
}

const StageReport& StageTimer::Finish(const std::string& prefix,
                                      std::vector<StageReport>* stages) {
  ThrowIfInterrupted();
  report_.seconds = timer_.ElapsedSeconds();
  report_.cpu_seconds =
      static_cast<double>(std::clock() - cpu_start_) / CLOCKS_PER_SEC;
  LOG(INFO) << prefix << report_.LogLine();
  if (stages == nullptr) return report_;
  stages->push_back(report_);
  return stages->back();
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
         << ", \"cpu_seconds\": " << JsonNumber(stage.cpu_seconds);
    for (const auto& [name, value] : stage.figures) {
      *out << ", " << JsonString(name) << ": " << JsonNumber(value);
    }
    *out << "}";
  }
  *out << (stages.empty() ? "" : "\n" + indent) << "]";
}

}  // namespace colmap_irav4
