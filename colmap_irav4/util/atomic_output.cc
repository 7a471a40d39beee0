#include "colmap_irav4/util/atomic_output.h"

#include <dirent.h>
#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <climits>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include <glog/logging.h>

#include "colmap_irav4/util/error.h"

namespace colmap_irav4 {
namespace {

namespace fs = std::filesystem;

const char* const kOwnNames[] = {"cameras.bin",  "images.bin", "points3D.bin",
                                 "cameras.txt",  "images.txt", "points3D.txt",
                                 "summary.json", "project.ini"};

// Async-signal-safe version of IsOwnOutputFileName (no allocation).
bool IsOwnName(const char* name) {
  for (const char* own : kOwnNames) {
    if (std::strcmp(name, own) == 0) return true;
  }
  return std::strstr(name, kTemporaryMarker) != nullptr;
}

bool IsNumber(const std::string& name) {
  return !name.empty() && name.size() < 9 &&
         std::all_of(name.begin(), name.end(),
                     [](char c) { return c >= '0' && c <= '9'; });
}

std::string Errno() { return std::strerror(errno); }

// ---------------------------------------------------------------------------
// Signal handling: only async-signal-safe calls (openat, getdents64, unlinkat,
// close, sigaction, raise) on a path copied in advance.

char g_temporary[PATH_MAX];
volatile sig_atomic_t g_armed = 0;
struct sigaction g_old_int, g_old_term;

struct LinuxDirent64 {
  ino64_t d_ino;
  off64_t d_off;
  unsigned short d_reclen;
  unsigned char d_type;
  char d_name[];
};

// Removes own files below parent_fd/name (depth-limited), then the directory
// if it became empty. Two passes: unlinking while listing may skip entries.
void RemoveOwnTreeSignalSafe(int parent_fd, const char* name, int depth) {
  const int fd = openat(parent_fd, name, O_RDONLY | O_DIRECTORY | O_NOFOLLOW);
  if (fd < 0) return;
  for (int pass = 0; pass < 2; ++pass) {
    lseek(fd, 0, SEEK_SET);
    alignas(8) char buffer[4096];
    for (;;) {
      const long n = syscall(SYS_getdents64, fd, buffer, sizeof(buffer));
      if (n <= 0) break;
      for (long offset = 0; offset < n;) {
        const LinuxDirent64* entry =
            reinterpret_cast<const LinuxDirent64*>(buffer + offset);
        offset += entry->d_reclen;
        const char* entry_name = entry->d_name;
        if (std::strcmp(entry_name, ".") == 0 ||
            std::strcmp(entry_name, "..") == 0) {
          continue;
        }
        if (entry->d_type == DT_DIR) {
          if (depth < 3) RemoveOwnTreeSignalSafe(fd, entry_name, depth + 1);
        } else if (IsOwnName(entry_name)) {
          unlinkat(fd, entry_name, 0);
        }
      }
    }
  }
  close(fd);
  unlinkat(parent_fd, name, AT_REMOVEDIR);  // fails (kept) if not empty
}

void HandleSignal(int signal_number) {
  if (g_armed) {
    g_armed = 0;
    RemoveOwnTreeSignalSafe(AT_FDCWD, g_temporary, 0);
  }
  // The default action (terminate with the signal's status).
  struct sigaction action;
  std::memset(&action, 0, sizeof(action));
  action.sa_handler = SIG_DFL;
  sigaction(signal_number, &action, nullptr);
  raise(signal_number);
}

void ArmCleanup(const std::string& temporary) {
  std::snprintf(g_temporary, sizeof(g_temporary), "%s", temporary.c_str());
  struct sigaction action;
  std::memset(&action, 0, sizeof(action));
  action.sa_handler = HandleSignal;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, &g_old_int);
  sigaction(SIGTERM, &action, &g_old_term);
  g_armed = 1;
}

void DisarmCleanup() {
  if (!g_armed) return;
  g_armed = 0;
  sigaction(SIGINT, &g_old_int, nullptr);
  sigaction(SIGTERM, &g_old_term, nullptr);
}

// Blocks SIGINT/SIGTERM for its lifetime (the installation's renames).
class BlockInterrupts {
 public:
  BlockInterrupts() {
    sigset_t set;
    sigemptyset(&set);
    sigaddset(&set, SIGINT);
    sigaddset(&set, SIGTERM);
    pthread_sigmask(SIG_BLOCK, &set, &old_);
  }
  ~BlockInterrupts() { pthread_sigmask(SIG_SETMASK, &old_, nullptr); }

 private:
  sigset_t old_;
};

// Atomically swaps two existing paths; two renames (through `aside`) where
// the file system has no RENAME_EXCHANGE.
void ExchangeOrReplace(const std::string& staged, const std::string& target,
                       const std::string& aside) {
#ifdef RENAME_EXCHANGE
  if (renameat2(AT_FDCWD, staged.c_str(), AT_FDCWD, target.c_str(),
                RENAME_EXCHANGE) == 0) {
    if (std::rename(staged.c_str(), aside.c_str()) != 0) {
      throw InputError(staged, "cannot move the old model aside: " + Errno());
    }
    return;
  }
  if (errno != EINVAL && errno != ENOSYS && errno != ENOTSUP) {
    throw InputError(target, "cannot install the new model: " + Errno());
  }
#endif
  if (std::rename(target.c_str(), aside.c_str()) != 0) {
    throw InputError(target, "cannot move the old model aside: " + Errno());
  }
  if (std::rename(staged.c_str(), target.c_str()) != 0) {
    const std::string problem = Errno();
    std::rename(aside.c_str(), target.c_str());  // put the old one back
    throw InputError(target, "cannot install the new model: " + problem);
  }
}

}  // namespace

bool IsOwnOutputFileName(const std::string& name) {
  return IsOwnName(name.c_str());
}

namespace {

std::string TemporaryName(const std::string& path) {
  return path + kTemporaryMarker + std::to_string(static_cast<long>(getpid()));
}

// Writes `bytes` to path's temporary name (flushed to disk); returns it.
std::string WriteTemporary(const std::string& path, const std::string& bytes) {
  const std::string temporary = TemporaryName(path);
  const int fd =
      open(temporary.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
  if (fd < 0) throw InputError(path, "cannot write file: " + Errno());
  size_t written = 0;
  bool ok = true;
  while (ok && written < bytes.size()) {
    const ssize_t n = write(fd, bytes.data() + written, bytes.size() - written);
    if (n < 0 && errno == EINTR) continue;
    ok = n > 0;
    if (ok) written += static_cast<size_t>(n);
  }
  const std::string problem = ok ? "" : Errno();
  // Data on disk before the rename makes it visible (no empty file after a
  // crash).
  ok = ok && fsync(fd) == 0;
  ok = close(fd) == 0 && ok;
  if (!ok) {
    unlink(temporary.c_str());
    throw InputError(
        path, "cannot write file" + (problem.empty() ? "" : ": " + problem));
  }
  return temporary;
}

}  // namespace

void WriteFileAtomically(const std::string& path, const std::string& bytes) {
  const fs::path parent = fs::path(path).parent_path();
  if (!parent.empty() && !fs::is_directory(parent)) {
    throw InputError(path, "cannot write file: directory " + parent.string() +
                               " does not exist");
  }
  WriteFilesAtomically(parent.string(),
                       {{fs::path(path).filename().string(), bytes}});
}

void WriteFilesAtomically(
    const std::string& dir,
    const std::vector<std::pair<std::string, std::string>>& names_and_bytes) {
  const std::string directory = dir.empty() ? "." : dir;
  std::error_code error;
  fs::create_directories(directory, error);
  if (!fs::is_directory(directory)) {
    throw InputError(directory, "cannot create the output directory" +
                                    (error ? ": " + error.message() : ""));
  }
  // A directory in the way would make a later rename fail after earlier
  // ones; every temporary file is complete before the first rename.
  for (const auto& name_and_bytes : names_and_bytes) {
    const fs::path final_path = fs::path(directory) / name_and_bytes.first;
    if (fs::is_directory(final_path)) {
      throw InputError(final_path.string(),
                       "is a directory, cannot write the file");
    }
  }
  std::vector<std::string> temporaries;
  try {
    for (const auto& [name, bytes] : names_and_bytes) {
      temporaries.push_back(
          WriteTemporary((fs::path(directory) / name).string(), bytes));
    }
  } catch (...) {
    for (const std::string& temporary : temporaries) unlink(temporary.c_str());
    throw;
  }
  for (size_t k = 0; k < names_and_bytes.size(); ++k) {
    const std::string path =
        (fs::path(directory) / names_and_bytes[k].first).string();
    if (std::rename(temporaries[k].c_str(), path.c_str()) != 0) {
      const std::string problem = Errno();
      for (size_t i = k; i < temporaries.size(); ++i) {
        unlink(temporaries[i].c_str());
      }
      throw InputError(
          path, "cannot rename the temporary file into place: " + problem);
    }
  }
}

void CheckFileWritable(const std::string& path) {
  const fs::path file(path);
  fs::path dir = file.parent_path();
  if (dir.empty()) dir = ".";
  std::error_code error;
  fs::create_directories(dir, error);
  if (!fs::is_directory(dir)) {
    throw InputError(path, "cannot create its directory " + dir.string() +
                               (error ? ": " + error.message() : ""));
  }
  if (fs::is_directory(file)) {
    throw InputError(path, "is a directory, cannot write the file");
  }
  const std::string probe = (dir / (std::string(kTemporaryMarker) +
                                    std::to_string(getpid()) + ".probe"))
                                .string();
  const int fd = open(probe.c_str(), O_WRONLY | O_CREAT | O_EXCL, 0600);
  if (fd < 0) {
    throw InputError(path, "cannot write in " + dir.string() + ": " + Errno());
  }
  close(fd);
  unlink(probe.c_str());
}

std::vector<std::string> RemoveOwnFiles(const std::string& dir) {
  std::vector<std::string> kept;
  std::error_code error;
  if (!fs::is_directory(fs::symlink_status(dir, error))) return kept;
  std::vector<fs::path> entries;
  for (const auto& entry : fs::directory_iterator(dir, error)) {
    entries.push_back(entry.path());
  }
  for (const fs::path& entry : entries) {
    if (fs::is_directory(fs::symlink_status(entry, error))) {
      const std::vector<std::string> below = RemoveOwnFiles(entry.string());
      kept.insert(kept.end(), below.begin(), below.end());
    } else if (IsOwnOutputFileName(entry.filename().string())) {
      fs::remove(entry, error);
    } else {
      kept.push_back(entry.string());
    }
  }
  if (fs::is_empty(dir, error)) fs::remove(dir, error);
  return kept;
}

std::string ModelDirectoryProblem(const std::string& dir) {
  std::error_code error;
  const fs::file_status status = fs::symlink_status(dir, error);
  if (!fs::exists(status)) return "";
  if (!fs::is_directory(status)) {
    return "exists and is not a directory; not replaced";
  }
  bool has_model_file = false;
  bool has_other = false;
  for (const auto& entry : fs::directory_iterator(dir, error)) {
    const std::string name = entry.path().filename().string();
    if (IsOwnOutputFileName(name) &&
        name.find(kTemporaryMarker) == std::string::npos) {
      if (fs::is_directory(entry.symlink_status(error))) {
        return "holds a directory named " + name + "; not replaced";
      }
      has_model_file = true;
    } else if (name.find(kTemporaryMarker) == std::string::npos) {
      has_other = true;
    }
  }
  if (has_other && !has_model_file) {
    return "exists and holds no COLMAP model (files of someone else's?); "
           "not replaced";
  }
  return "";
}

OutputTransaction::OutputTransaction(const std::string& output_dir)
    : output_dir_(output_dir) {
  std::error_code error;
  fs::create_directories(output_dir, error);
  if (!fs::is_directory(output_dir)) {
    throw InputError(output_dir, "cannot create the output directory" +
                                     (error ? ": " + error.message() : ""));
  }
  const fs::path out = fs::absolute(output_dir, error);
  // Temporary directories of runs that were killed (their process is gone).
  for (const auto& entry : fs::directory_iterator(out, error)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind(kTemporaryMarker, 0) != 0) continue;
    const std::string pid_text = name.substr(std::strlen(kTemporaryMarker));
    char* end = nullptr;
    const long pid = std::strtol(pid_text.c_str(), &end, 10);
    if (end == pid_text.c_str() || *end != '\0' || pid <= 0) continue;
    if (pid != static_cast<long>(getpid()) &&
        !(kill(static_cast<pid_t>(pid), 0) == -1 && errno == ESRCH)) {
      continue;  // a run in progress
    }
    for (const std::string& kept : RemoveOwnFiles(entry.path().string())) {
      LOG(WARNING) << kept << ": left in the temporary directory of a killed "
                   << "run (not written by this program)";
    }
  }
  temporary_ = (out / (std::string(kTemporaryMarker) +
                       std::to_string(static_cast<long>(getpid()))))
                   .string();
  if (mkdir(temporary_.c_str(), 0777) != 0) {
    throw InputError(output_dir,
                     "cannot write in the output directory: " + Errno());
  }
  ArmCleanup(temporary_);
  try {
    const std::string problem = ModelDirectoryProblem((out / "0").string());
    if (!problem.empty()) throw InputError((out / "0").string(), problem);
    if (fs::is_directory(out / "summary.json")) {
      throw InputError((out / "summary.json").string(),
                       "is a directory, cannot write the run summary");
    }
  } catch (...) {
    DisarmCleanup();
    RemoveOwnFiles(temporary_);
    throw;
  }
}

OutputTransaction::~OutputTransaction() {
  if (committed_) return;
  DisarmCleanup();
  for (const std::string& kept : RemoveOwnFiles(temporary_)) {
    LOG(WARNING) << kept << ": left in the temporary directory";
  }
}

std::vector<std::string> OutputTransaction::StaleModelDirectories(
    int num_models) const {
  std::error_code error;
  std::vector<std::pair<int, std::string>> stale;
  for (const auto& entry : fs::directory_iterator(output_dir_, error)) {
    const std::string name = entry.path().filename().string();
    if (IsNumber(name) && std::stoi(name) >= num_models &&
        entry.is_directory(error)) {
      stale.emplace_back(std::stoi(name), entry.path().string());
    }
  }
  std::sort(stale.begin(), stale.end());
  std::vector<std::string> paths;
  for (const auto& [k, path] : stale) paths.push_back(path);
  return paths;
}

std::string OutputTransaction::StagingModelPath(int k) const {
  return (fs::path(temporary_) / std::to_string(k)).string();
}

std::string OutputTransaction::StagingFilePath(const std::string& name) const {
  return (fs::path(temporary_) / name).string();
}

std::vector<std::string> OutputTransaction::Commit(
    int num_models, const std::vector<std::string>& files) {
  CHECK(!committed_);
  std::vector<std::string> warnings;
  const fs::path out(output_dir_);
  // Everything that could fail is checked before the first installation.
  for (int k = 0; k < num_models; ++k) {
    const std::string target = (out / std::to_string(k)).string();
    const std::string problem = ModelDirectoryProblem(target);
    if (!problem.empty()) throw InputError(target, problem);
    if (!fs::is_directory(StagingModelPath(k))) {
      throw InputError(StagingModelPath(k), "model was not written");
    }
  }
  for (const std::string& name : files) {
    if (fs::is_directory(out / name)) {
      throw InputError((out / name).string(),
                       "is a directory, cannot write it");
    }
    if (!fs::exists(StagingFilePath(name))) {
      throw InputError(StagingFilePath(name), "was not written");
    }
  }
  {
    const BlockInterrupts block;
    std::error_code error;
    for (int k = 0; k < num_models; ++k) {
      const fs::path target = out / std::to_string(k);
      const fs::path staged = StagingModelPath(k);
      if (!fs::exists(fs::symlink_status(target, error))) {
        if (std::rename(staged.c_str(), target.c_str()) != 0) {
          throw InputError(target.string(),
                           "cannot install the new model: " + Errno());
        }
        continue;
      }
      // The user's files in the old model directory go into the new one.
      for (const auto& entry : fs::directory_iterator(target, error)) {
        const std::string name = entry.path().filename().string();
        if (IsOwnOutputFileName(name)) continue;
        if (std::rename(entry.path().c_str(), (staged / name).c_str()) != 0) {
          throw InputError(entry.path().string(),
                           "cannot keep this file in the new model "
                           "directory: " +
                               Errno());
        }
        warnings.push_back(target.string() + "/" + name +
                           ": not a model file; kept in the new model "
                           "directory");
      }
      const fs::path aside =
          fs::path(temporary_) / ("old." + std::to_string(k));
      ExchangeOrReplace(staged.string(), target.string(), aside.string());
      for (const std::string& kept : RemoveOwnFiles(aside.string())) {
        warnings.push_back(kept + ": left in the temporary directory");
      }
    }
    for (const std::string& name : files) {
      if (std::rename(StagingFilePath(name).c_str(), (out / name).c_str()) !=
          0) {
        throw InputError((out / name).string(), "cannot install: " + Errno());
      }
    }
    committed_ = true;
    DisarmCleanup();
  }
  for (const std::string& kept : RemoveOwnFiles(temporary_)) {
    warnings.push_back(kept + ": left in the temporary directory");
  }
  for (const std::string& path : StaleModelDirectories(num_models)) {
    warnings.push_back(path +
                       ": left over from an earlier run (this run made " +
                       std::to_string(num_models) + " model(s)); not removed");
  }
  for (const std::string& warning : warnings) LOG(WARNING) << warning;
  return warnings;
}

}  // namespace colmap_irav4
