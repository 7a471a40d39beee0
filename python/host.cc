#include "python/host.h"

#include <chrono>
#include <condition_variable>
#include <exception>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <glog/logging.h>
#include <pybind11/pybind11.h>

#include "colmap_irav4/util/interrupt.h"

namespace py = pybind11;

namespace colmap_irav4 {
namespace python {
namespace {

// Collects glog messages of any thread until the Python thread takes them.
class MessageQueue : public google::LogSink {
 public:
  void send(google::LogSeverity severity, const char* full_filename,
            const char* base_filename, int line, const struct ::tm* tm_time,
            const char* message, size_t message_len) override {
    std::lock_guard<std::mutex> lock(mutex_);
    messages_.emplace_back(severity, std::string(message, message_len));
  }

  std::vector<std::pair<google::LogSeverity, std::string>> Take() {
    std::lock_guard<std::mutex> lock(mutex_);
    return std::move(messages_);
  }

 private:
  std::mutex mutex_;
  std::vector<std::pair<google::LogSeverity, std::string>> messages_;
};

// Python's logging levels of glog's severities.
int PythonLevel(google::LogSeverity severity) {
  switch (severity) {
    case google::GLOG_INFO:
      return 20;
    case google::GLOG_WARNING:
      return 30;
    case google::GLOG_ERROR:
      return 40;
    default:
      return 50;
  }
}

void Forward(
    const std::vector<std::pair<google::LogSeverity, std::string>>& messages) {
  if (messages.empty()) return;
  const py::object logger =
      py::module_::import("logging").attr("getLogger")("colmap_irav4");
  for (const auto& [severity, message] : messages) {
    logger.attr("log")(PythonLevel(severity), message);
  }
}

// One run at a time: the interrupt flag and the log sink are process-wide.
std::mutex g_run_mutex;

}  // namespace

void InitLogging() {
  if (google::IsGoogleLoggingInitialized()) return;
  google::InitGoogleLogging("colmap_irav4");
  FLAGS_logtostderr = false;
  FLAGS_stderrthreshold = google::GLOG_FATAL;
  for (int severity = google::GLOG_INFO; severity < google::NUM_SEVERITIES;
       ++severity) {
    google::SetLogDestination(severity, "");  // "": no log file
  }
}

void RunInPython(const std::function<void()>& work) {
  std::unique_lock<std::mutex> run_lock(g_run_mutex, std::defer_lock);
  {
    py::gil_scoped_release release;
    run_lock.lock();
  }
  MessageQueue queue;
  google::AddLogSink(&queue);
  ClearInterrupt();
  std::mutex mutex;
  std::condition_variable finished_condition;
  bool finished = false;
  std::exception_ptr work_error;
  std::thread worker([&] {
    try {
      work();
    } catch (...) {
      work_error = std::current_exception();
    }
    std::lock_guard<std::mutex> lock(mutex);
    finished = true;
    finished_condition.notify_all();
  });
  std::unique_ptr<py::error_already_set> python_error;
  for (bool done = false; !done;) {
    {
      py::gil_scoped_release release;
      std::unique_lock<std::mutex> lock(mutex);
      done = finished_condition.wait_for(lock, std::chrono::milliseconds(50),
                                         [&] { return finished; });
    }
    if (python_error) continue;  // waiting for the work to stop
    try {
      Forward(queue.Take());
      if (PyErr_CheckSignals() != 0) throw py::error_already_set();
    } catch (py::error_already_set& error) {
      python_error = std::make_unique<py::error_already_set>(std::move(error));
      RequestInterrupt();
    }
  }
  worker.join();
  google::RemoveLogSink(&queue);
  ClearInterrupt();
  if (python_error) throw *python_error;
  Forward(queue.Take());
  if (work_error) std::rethrow_exception(work_error);
}

}  // namespace python
}  // namespace colmap_irav4
