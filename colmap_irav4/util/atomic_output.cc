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
#include <fstream>
#include <iostream>
#include <iterator>
#include <sstream>

#include <glog/logging.h>

#include "colmap_irav4/util/error.h"

namespace colmap_irav4 {
namespace {

namespace fs = std::filesystem;

const char* const kModelNames[] = {"cameras.bin", "images.bin", "points3D.bin",
                                   "cameras.txt", "images.txt", "points3D.txt"};
// Written beside every model (the run's options, as COLMAP's project.ini);
// ours only beside a model.
constexpr char kProjectName[] = "project.ini";
constexpr char kSummaryName[] = "summary.json";
// The install journal of a run's temporary directory (an own name).
const std::string kJournalName = std::string(kTemporaryMarker) + "journal";

bool IsModelName(const char* name) {
  for (const char* own : kModelNames) {
    if (std::strcmp(name, own) == 0) return true;
  }
  return false;
}

// A file of a model directory this program writes.
bool IsModelDirectoryName(const char* name) {
  return IsModelName(name) || std::strcmp(name, kProjectName) == 0;
}

bool IsTemporaryName(const char* name) {
  return std::strstr(name, kTemporaryMarker) != nullptr;
}

// Async-signal-safe version of IsOwnOutputFileName (no allocation).
bool IsOwnName(const char* name) {
  return IsModelDirectoryName(name) || std::strcmp(name, kSummaryName) == 0 ||
         IsTemporaryName(name);
}

bool IsNumber(const std::string& name) {
  return !name.empty() && name.size() < 9 &&
         std::all_of(name.begin(), name.end(),
                     [](char c) { return c >= '0' && c <= '9'; });
}

std::string Errno() { return std::strerror(errno); }

// Test hook: called after each step of an installation.
void (*g_install_hook)(int step) = nullptr;

// ---------------------------------------------------------------------------
// Signal handling: only async-signal-safe calls (openat, getdents64, unlinkat,
// close, sigaction, raise) on paths copied in advance.

constexpr int kMaxCreated = 8;
char g_temporary[PATH_MAX];
char g_created[kMaxCreated][PATH_MAX];
volatile sig_atomic_t g_num_created = 0;
volatile sig_atomic_t g_armed = 0;
// During an installation a signal is only recorded (the output is then
// complete either way; the run finishes and says so).
volatile sig_atomic_t g_installing = 0;
volatile sig_atomic_t g_pending_signal = 0;
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
  if (g_installing) {
    g_pending_signal = signal_number;
    return;
  }
  if (g_armed) {
    g_armed = 0;
    RemoveOwnTreeSignalSafe(AT_FDCWD, g_temporary, 0);
    // The directories the run created, deepest first (kept if not empty).
    for (int i = g_num_created - 1; i >= 0; --i) {
      unlinkat(AT_FDCWD, g_created[i], AT_REMOVEDIR);
    }
  }
  // The default action (terminate with the signal's status).
  struct sigaction action;
  std::memset(&action, 0, sizeof(action));
  action.sa_handler = SIG_DFL;
  sigaction(signal_number, &action, nullptr);
  raise(signal_number);
}

// Whether our handler replaced the signal's (see ArmCleanup).
bool g_handles_int = false, g_handles_term = false;

// Installs HandleSignal for `signal_number` unless the host program handles
// the signal itself (a handler function, as Python's interpreter has for
// SIGINT): that handler then returns, the host stops the run through
// util/interrupt.h and the transaction's destructor removes the temporary
// directory. Returns whether it installed.
bool InstallHandler(int signal_number, struct sigaction* old_action) {
  sigaction(signal_number, nullptr, old_action);
  const bool host_handler =
      (old_action->sa_flags & SA_SIGINFO) != 0 ||
      (old_action->sa_handler != SIG_DFL && old_action->sa_handler != SIG_IGN);
  if (host_handler) return false;
  struct sigaction action;
  std::memset(&action, 0, sizeof(action));
  action.sa_handler = HandleSignal;
  action.sa_flags = SA_RESTART;
  sigemptyset(&action.sa_mask);
  sigaction(signal_number, &action, nullptr);
  return true;
}

void ArmCleanup(const std::string& temporary,
                const std::vector<std::string>& created) {
  std::snprintf(g_temporary, sizeof(g_temporary), "%s", temporary.c_str());
  int num_created = 0;
  for (const std::string& path : created) {
    if (num_created == kMaxCreated || path.size() >= PATH_MAX) break;
    std::snprintf(g_created[num_created++], PATH_MAX, "%s", path.c_str());
  }
  g_num_created = num_created;
  g_pending_signal = 0;
  g_handles_int = InstallHandler(SIGINT, &g_old_int);
  g_handles_term = InstallHandler(SIGTERM, &g_old_term);
  g_armed = 1;
}

void DisarmCleanup() {
  if (!g_armed) return;
  g_armed = 0;
  if (g_handles_int) sigaction(SIGINT, &g_old_int, nullptr);
  if (g_handles_term) sigaction(SIGTERM, &g_old_term, nullptr);
}

// The system stops at a file named as a directory on the way: "db.db/../x"
// names nothing it can open, while resolved lexically it would name x
// beside db.db (a link to the database, say). Refused, naming the file.
void ThrowIfThroughAFile(const std::string& path) {
  const fs::path raw(path);
  fs::path prefix;
  for (auto it = raw.begin(); it != raw.end(); ++it) {
    prefix /= *it;
    if (std::next(it) == raw.end()) break;
    struct stat status;
    if (stat(prefix.c_str(), &status) == 0 && !S_ISDIR(status.st_mode)) {
      throw InputError(path, prefix.string() + " is a file, not a directory");
    }
  }
}

// A file's path: it ends in a name ("x/", "x/." and "x/.." are
// directories) and runs through no file.
void ThrowUnlessFilePath(const std::string& path) {
  const fs::path last = fs::path(path).filename();
  if (last.empty() || last == "." || last == "..") {
    throw InputError(path,
                     "ends in a directory (\"/\", \".\" or \"..\"), not a "
                     "file name");
  }
  ThrowIfThroughAFile(path);
}

// `path` as the system resolves it once its missing directories exist:
// each existing prefix made canonical (links and ".." followed), ".." after
// a missing name back to that name's parent, as after creating it.
// weakly_canonical stops following links at the first missing name, so
// "missing/../link.db" would stay the link, not the file it names. A link
// on the way that leads nowhere (dangling, or a loop) is refused: the
// system cannot go through it, and "dangling/../x" resolved lexically
// would name a file beside the link that the user did not name (found by
// output_paths_fuzzer). A dangling link as the last name is followed by
// FollowLinks (its target is created).
fs::path ResolveAsSystem(const std::string& path) {
  std::error_code error;
  const fs::path absolute = fs::absolute(path, error);
  fs::path resolved;
  for (auto it = absolute.begin(); it != absolute.end(); ++it) {
    const fs::path& name = *it;
    if (name.empty() || name == ".") continue;
    if (name == "..") {
      resolved = resolved.parent_path();
      continue;
    }
    resolved /= name;
    const fs::path canonical = fs::canonical(resolved, error);
    if (!error) {
      resolved = canonical;
    } else if (std::next(it) != absolute.end() &&
               fs::is_symlink(fs::symlink_status(resolved, error))) {
      throw InputError(path, resolved.string() + " is a symbolic link to " +
                                 fs::read_symlink(resolved, error).string() +
                                 ", which does not exist (create it or "
                                 "remove the link)");
    }
  }
  return resolved;
}

// The missing directories of `path` created top-down; returns them in that
// order (absolute). Throws InputError if one cannot be created.
// The directory `path` names as the system resolves it: the links and
// ".." of its existing part followed, so that every later operation sees
// the same directory. A dangling link on the way is an error.
fs::path ResolvedDirectory(const std::string& path) {
  ThrowIfThroughAFile(path);
  std::error_code error;
  const fs::path raw = fs::absolute(path, error);
  for (fs::path p = raw; !p.empty(); p = p.parent_path()) {
    if (fs::is_symlink(fs::symlink_status(p, error)) &&
        !fs::exists(fs::status(p, error))) {
      throw InputError(path, p.string() + " is a symbolic link to " +
                                 fs::read_symlink(p, error).string() +
                                 ", which does not exist (create it or "
                                 "remove the link)");
    }
    if (p == p.parent_path()) break;
  }
  fs::path dir = ResolveAsSystem(path);
  if (!dir.empty() && !dir.has_filename()) dir = dir.parent_path();
  return dir;
}

std::vector<std::string> CreateDirectories(const std::string& path) {
  std::error_code error;
  const fs::path dir = ResolvedDirectory(path);
  std::vector<fs::path> missing;
  for (fs::path p = dir; !p.empty(); p = p.parent_path()) {
    if (fs::exists(fs::symlink_status(p, error))) break;
    missing.push_back(p);
    if (p == p.parent_path()) break;
  }
  std::vector<std::string> created;
  for (auto it = missing.rbegin(); it != missing.rend(); ++it) {
    if (mkdir(it->c_str(), 0777) == 0) {
      created.push_back(it->string());
    } else if (errno != EEXIST) {
      const std::string problem = Errno();
      for (auto c = created.rbegin(); c != created.rend(); ++c) {
        rmdir(c->c_str());
      }
      throw InputError(
          path, "cannot create the directory " + it->string() + ": " + problem);
    }
  }
  if (!fs::is_directory(dir)) {
    for (auto c = created.rbegin(); c != created.rend(); ++c) {
      rmdir(c->c_str());
    }
    throw InputError(path, "cannot create the directory: a file is in the way");
  }
  return created;
}

// Removes the directories of CreateDirectories, deepest first, if empty.
void RemoveCreatedDirectories(const std::vector<std::string>& created) {
  for (auto it = created.rbegin(); it != created.rend(); ++it) {
    rmdir(it->c_str());
  }
}

// Atomically swaps two existing paths; two renames (through `aside`) where
// the file system has no RENAME_EXCHANGE. Afterwards `staged` is gone and
// the old target is at `aside`.
void ExchangeOrReplace(const std::string& staged, const std::string& target,
                       const std::string& aside) {
#ifdef RENAME_EXCHANGE
  if (renameat2(AT_FDCWD, staged.c_str(), AT_FDCWD, target.c_str(),
                RENAME_EXCHANGE) == 0) {
    if (g_install_hook) g_install_hook(1);
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

// Where a write to `path` goes.
enum class OutputKind {
  kFile,       // a regular file or none: replaced through a temporary name
  kStream,     // a pipe, a character device, /dev or /proc: written into
  kDirectory,  // refused
  kSpecial,    // a block device or a socket: refused
};

bool IsUnderSystemTree(const std::string& path) {
  std::error_code error;
  const std::string normal =
      fs::absolute(path, error).lexically_normal().string();
  return normal.rfind("/dev/", 0) == 0 || normal.rfind("/proc/", 0) == 0 ||
         normal == "/dev" || normal == "/proc";
}

OutputKind KindOf(const std::string& path) {
  if (IsUnderSystemTree(path)) return OutputKind::kStream;
  struct stat status;
  if (stat(path.c_str(), &status) != 0) return OutputKind::kFile;
  if (S_ISREG(status.st_mode)) return OutputKind::kFile;
  if (S_ISDIR(status.st_mode)) return OutputKind::kDirectory;
  if (S_ISFIFO(status.st_mode) || S_ISCHR(status.st_mode)) {
    return OutputKind::kStream;
  }
  return OutputKind::kSpecial;
}

// `path` with its symbolic links followed to the file they name (which may
// not exist yet): the file replaced, so that the link stays a link.
std::string FollowLinks(const std::string& path) {
  fs::path current(path);
  std::error_code error;
  for (int hops = 0; hops < 40; ++hops) {
    if (!fs::is_symlink(fs::symlink_status(current, error))) {
      return current.string();
    }
    const fs::path target = fs::read_symlink(current, error);
    if (error) break;
    current = target.is_absolute() ? target : current.parent_path() / target;
  }
  throw InputError(path, "too many levels of symbolic links");
}

void ThrowUnlessWritableKind(const std::string& path, OutputKind kind) {
  if (kind == OutputKind::kDirectory) {
    throw InputError(path, "is a directory, cannot write the file");
  }
  if (kind == OutputKind::kSpecial) {
    throw InputError(path,
                     "is a special file (block device or socket); not "
                     "written, not replaced");
  }
}

// The descriptor `path` names (/dev/stdout, /dev/stderr, /dev/fd/N,
// /proc/self/fd/N), else -1.
int NamedDescriptor(const std::string& path) {
  std::error_code error;
  const std::string normal =
      fs::absolute(path, error).lexically_normal().string();
  if (normal == "/dev/stdout") return 1;
  if (normal == "/dev/stderr") return 2;
  for (const std::string prefix : {"/dev/fd/", "/proc/self/fd/"}) {
    if (normal.rfind(prefix, 0) != 0) continue;
    const std::string number = normal.substr(prefix.size());
    if (!IsNumber(number)) return -1;
    return std::stoi(number);
  }
  return -1;
}

// Writes into an existing pipe or device (no temporary, no rename); a
// named descriptor (/dev/stdout) is written through itself, so that the
// bytes follow what the program printed there before (a file behind it
// keeps one offset).
void WriteIntoStream(const std::string& path, const std::string& bytes) {
  const int named = NamedDescriptor(path);
  if (named >= 0) {
    std::cout.flush();
    std::cerr.flush();
    std::fflush(nullptr);
  }
  const int fd = named >= 0 ? named
                            : open(path.c_str(),
                                   O_WRONLY | O_APPEND | O_NOCTTY | O_CLOEXEC);
  if (fd < 0 || (named >= 0 && fcntl(fd, F_GETFL) < 0)) {
    throw InputError(path, errno == ENOENT
                               ? "does not exist (no file is created under "
                                 "/dev or /proc)"
                               : "cannot open for writing: " + Errno());
  }
  size_t written = 0;
  while (written < bytes.size()) {
    const ssize_t n = write(fd, bytes.data() + written, bytes.size() - written);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const std::string problem =
          errno == EPIPE ? "the reader closed the pipe" : Errno();
      if (named < 0) close(fd);
      throw InputError(path, "cannot write: " + problem);
    }
    written += static_cast<size_t>(n);
  }
  if (named < 0 && close(fd) != 0) {
    throw InputError(path, "cannot write: " + Errno());
  }
}

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

// Moves the entries of `from` that are not model files (a user's notes, an
// old summary.json of theirs) into `to`; never over an existing name.
void CarryOverUserFiles(const fs::path& from, const fs::path& to,
                        const std::string& shown_as,
                        std::vector<std::string>* warnings) {
  std::error_code error;
  std::vector<fs::path> entries;
  for (const auto& entry : fs::directory_iterator(from, error)) {
    const std::string name = entry.path().filename().string();
    if (!IsModelDirectoryName(name.c_str()) && !IsTemporaryName(name.c_str())) {
      entries.push_back(entry.path());
    }
  }
  for (const fs::path& entry : entries) {
    const fs::path destination = to / entry.filename();
    if (fs::exists(fs::symlink_status(destination, error)) ||
        std::rename(entry.c_str(), destination.c_str()) != 0) {
      warnings->push_back(entry.string() +
                          ": could not be moved into the new model directory " +
                          to.string() + "; left there");
      continue;
    }
    warnings->push_back(shown_as + "/" + entry.filename().string() +
                        ": not a model file; kept in the new model directory");
  }
}

struct Journal {
  std::vector<std::pair<int, ino_t>> models;  // k, inode of the staged model
  std::vector<std::string> files;
};

std::string JournalText(const Journal& journal) {
  std::ostringstream text;
  for (const auto& [k, inode] : journal.models) {
    text << "model " << k << " " << inode << "\n";
  }
  for (const std::string& name : journal.files) text << "file " << name << "\n";
  return text.str();
}

bool ReadJournal(const fs::path& temporary, Journal* journal) {
  std::ifstream file(temporary / kJournalName);
  if (!file) return false;
  std::string kind;
  while (file >> kind) {
    if (kind == "model") {
      int k = 0;
      unsigned long long inode = 0;
      if (!(file >> k >> inode) || k < 0) return false;
      journal->models.emplace_back(k, static_cast<ino_t>(inode));
    } else if (kind == "file") {
      std::string name;
      if (!(file >> name) || name.find('/') != std::string::npos) return false;
      journal->files.push_back(name);
    } else {
      return false;
    }
  }
  return true;
}

// Performs (or, after a kill, finishes) the installation the journal of
// `temporary` describes. Every step can be redone: a staged model whose
// inode is the journal's is not installed yet; another directory at its
// place is the old model after the exchange.
std::vector<std::string> FinishInstall(const fs::path& temporary,
                                       const fs::path& out,
                                       const Journal& journal) {
  std::vector<std::string> warnings;
  std::error_code error;
  int step = 10;
  for (const auto& [k, inode] : journal.models) {
    const fs::path staged = temporary / std::to_string(k);
    const fs::path target = out / std::to_string(k);
    const fs::path aside = temporary / ("old." + std::to_string(k));
    struct stat status;
    if (lstat(staged.c_str(), &status) == 0) {
      if (status.st_ino == inode) {
        if (!fs::exists(fs::symlink_status(target, error))) {
          if (std::rename(staged.c_str(), target.c_str()) != 0) {
            throw InputError(target.string(),
                             "cannot install the new model: " + Errno());
          }
        } else {
          // The user's files in the old model directory go into the new one.
          CarryOverUserFiles(target, staged, target.string(), &warnings);
          if (g_install_hook) g_install_hook(step);
          ExchangeOrReplace(staged.string(), target.string(), aside.string());
        }
      } else if (std::rename(staged.c_str(), aside.c_str()) != 0) {
        throw InputError(staged.string(),
                         "cannot move the old model aside: " + Errno());
      }
    }
    if (g_install_hook) g_install_hook(step + 1);
    if (fs::is_directory(aside)) {
      CarryOverUserFiles(aside, target, target.string(), &warnings);
      for (const std::string& kept : RemoveOwnFiles(aside.string())) {
        warnings.push_back(kept + ": left in the temporary directory");
      }
    }
    if (g_install_hook) g_install_hook(step + 2);
    step += 10;
  }
  for (const std::string& name : journal.files) {
    const fs::path staged = temporary / name;
    if (!fs::exists(fs::symlink_status(staged, error))) continue;
    if (std::rename(staged.c_str(), (out / name).c_str()) != 0) {
      throw InputError((out / name).string(), "cannot install: " + Errno());
    }
    if (g_install_hook) g_install_hook(step++);
  }
  return warnings;
}

}  // namespace

namespace internal {
void SetInstallHookForTesting(void (*hook)(int step)) { g_install_hook = hook; }
}  // namespace internal

bool IsOwnOutputFileName(const std::string& name) {
  return IsOwnName(name.c_str());
}

namespace {
// Whether `path` resolves to `target`; an input through a dangling link
// names nothing, so it matches nothing.
bool ResolvesTo(const std::string& path, const fs::path& target) {
  try {
    return ResolveAsSystem(path) == target;
  } catch (const InputError&) {
    return false;
  }
}
}  // namespace

void CheckNotAnInput(const std::string& output,
                     const std::vector<std::string>& inputs) {
  if (output.empty()) return;
  // Resolved first: "missing/../hard.db" is the hard link once "missing"
  // exists.
  const fs::path output_path = ResolveAsSystem(output);
  struct stat out;
  const bool exists = stat(output_path.c_str(), &out) == 0;
  // A pipe or device may well be both (two outputs to /dev/stdout).
  if (exists && !S_ISREG(out.st_mode)) return;
  for (const std::string& input : inputs) {
    if (input.empty()) continue;
    for (const char* suffix : {"", "-wal", "-shm", "-journal"}) {
      const std::string path = input + suffix;
      struct stat in;
      const bool same =
          exists ? stat(path.c_str(), &in) == 0 && in.st_dev == out.st_dev &&
                       in.st_ino == out.st_ino
                 : !output_path.empty() && ResolvesTo(path, output_path);
      if (same) {
        throw InputError(output, "is the same file as " + path +
                                     " (an input, or another output of this "
                                     "run); writing it would destroy that: "
                                     "choose another output path");
      }
    }
  }
}

void WriteFileAtomically(const std::string& path, const std::string& bytes) {
  ThrowUnlessFilePath(path);
  const OutputKind kind = KindOf(path);
  ThrowUnlessWritableKind(path, kind);
  if (kind == OutputKind::kStream) {
    WriteIntoStream(path, bytes);
    return;
  }
  const fs::path target(FollowLinks(ResolveAsSystem(path).string()));
  WriteFilesAtomically(target.parent_path().string(),
                       {{target.filename().string(), bytes}});
}

void WriteFilesAtomically(
    const std::string& dir,
    const std::vector<std::pair<std::string, std::string>>& names_and_bytes) {
  // Links and ".." resolved once: the directories created, the temporary
  // files and the renames all name the same directory.
  const std::string directory =
      ResolvedDirectory(dir.empty() ? "." : dir).string();
  if (IsUnderSystemTree(directory)) {
    throw InputError(dir, "is under /dev or /proc; no files are created there");
  }
  const std::vector<std::string> created = CreateDirectories(directory);
  try {
    // Anything but a regular file (or none) in the way would make a later
    // rename fail, or replace a device; every temporary file is complete
    // before the first rename.
    for (const auto& name_and_bytes : names_and_bytes) {
      const std::string final_path =
          (fs::path(directory) / name_and_bytes.first).string();
      const OutputKind kind = KindOf(final_path);
      ThrowUnlessWritableKind(final_path, kind);
      if (kind == OutputKind::kStream) {
        throw InputError(final_path,
                         "is a named pipe or device, not replaced by a "
                         "model file");
      }
    }
    std::vector<std::string> temporaries;
    try {
      for (const auto& [name, bytes] : names_and_bytes) {
        temporaries.push_back(
            WriteTemporary((fs::path(directory) / name).string(), bytes));
      }
    } catch (...) {
      for (const std::string& temporary : temporaries) {
        unlink(temporary.c_str());
      }
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
  } catch (...) {
    RemoveCreatedDirectories(created);
    throw;
  }
}

void CheckFileWritable(const std::string& path,
                       const std::vector<std::string>& inputs) {
  ThrowUnlessFilePath(path);
  CheckNotAnInput(path, inputs);
  const OutputKind kind = KindOf(path);
  ThrowUnlessWritableKind(path, kind);
  if (kind == OutputKind::kStream) {
    if (access(path.c_str(), W_OK) != 0) {
      throw InputError(path, errno == ENOENT
                                 ? "does not exist (no file is created under "
                                   "/dev or /proc)"
                                 : "cannot write: " + Errno());
    }
    return;
  }
  // The nearest existing directory of the file (a link's target) must take
  // a new file; the missing ones are created when the file is written.
  std::error_code error;
  fs::path dir =
      fs::path(FollowLinks(ResolveAsSystem(path).string())).parent_path();
  while (!fs::exists(fs::symlink_status(dir, error)) &&
         dir != dir.parent_path()) {
    dir = dir.parent_path();
  }
  if (!fs::is_directory(dir)) {
    throw InputError(
        path, "cannot create its directory: " + dir.string() + " is a file");
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

std::string ModelDirectoryProblem(const std::string& dir,
                                  const ModelCheck& model_check) {
  std::error_code error;
  const fs::file_status status = fs::symlink_status(dir, error);
  if (!fs::exists(status)) return "";
  if (fs::is_symlink(status)) {
    return "is a symbolic link (to " + fs::read_symlink(dir, error).string() +
           "), not a model directory of this program; not replaced";
  }
  if (!fs::is_directory(status)) {
    return "exists and is not a directory; not replaced";
  }
  std::vector<std::string> present[2];  // [binary]
  bool has_other = false;
  for (const auto& entry : fs::directory_iterator(dir, error)) {
    const std::string name = entry.path().filename().string();
    if (IsModelName(name.c_str())) {
      if (!fs::is_regular_file(entry.symlink_status(error))) {
        return "holds " + name + ", which is not a regular file; not replaced";
      }
      present[name.size() > 4 && name.substr(name.size() - 4) == ".bin"]
          .push_back(name);
    } else if (!IsTemporaryName(name.c_str())) {
      // A project.ini is ours beside a model only.
      has_other = true;
    }
  }
  for (const bool binary : {true, false}) {
    const std::vector<std::string>& names = present[binary];
    if (names.empty()) continue;
    if (names.size() < 3) {
      std::string listed;
      for (const std::string& name : names) {
        listed += (listed.empty() ? "" : ", ") + name;
      }
      return "holds " + listed +
             " but not a complete model (cameras, images and points3D " +
             (binary ? ".bin" : ".txt") +
             "): not written by this program, not replaced (move the "
             "files away or choose another --output_path)";
    }
    if (model_check) {
      try {
        model_check(dir, binary);
      } catch (const std::exception& problem) {
        return std::string("holds model files that do not read as a model (") +
               problem.what() +
               "): not written by this program, not replaced (move the "
               "files away or choose another --output_path)";
      }
    }
  }
  if (has_other && present[0].empty() && present[1].empty()) {
    return "exists and holds no COLMAP model (files of someone else's?); "
           "not replaced";
  }
  return "";
}

OutputTransaction::OutputTransaction(const std::string& output_dir,
                                     const std::vector<std::string>& inputs,
                                     ModelCheck model_check)
    : output_dir_(output_dir), model_check_(std::move(model_check)) {
  if (IsUnderSystemTree(output_dir)) {
    throw InputError(output_dir,
                     "is under /dev or /proc; no model directory is "
                     "created there");
  }
  std::error_code error;
  // One spelling for every operation (links and ".." resolved once).
  const fs::path out = ResolvedDirectory(output_dir);
  if (IsUnderSystemTree(out.string())) {
    throw InputError(output_dir,
                     "leads under /dev or /proc; no model directory is "
                     "created there");
  }
  output_dir_ = out.string();
  const fs::file_status out_status = fs::status(out, error);
  if (fs::exists(out_status) && !fs::is_directory(out_status)) {
    throw InputError(output_dir, "exists and is not a directory");
  }
  if (fs::is_directory(out_status)) {
    // No input among the files the run replaces or removes.
    CheckNotAnInput((out / kSummaryName).string(), inputs);
    for (const auto& entry : fs::directory_iterator(out, error)) {
      if (!IsNumber(entry.path().filename().string())) continue;
      for (const char* name : kModelNames) {
        CheckNotAnInput((entry.path() / name).string(), inputs);
      }
    }
    // Temporary directories of runs that were killed (their process is
    // gone): an interrupted installation is finished, else they are removed.
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
      Journal journal;
      if (ReadJournal(entry.path(), &journal)) {
        LOG(WARNING) << entry.path().string()
                     << ": a killed run's installation was interrupted; "
                        "finishing it";
        for (const std::string& warning :
             FinishInstall(entry.path(), out, journal)) {
          LOG(WARNING) << warning;
        }
      }
      for (const std::string& kept : RemoveOwnFiles(entry.path().string())) {
        LOG(WARNING) << kept << ": left in the temporary directory of a killed "
                     << "run (not written by this program)";
      }
    }
    const std::string problem =
        ModelDirectoryProblem((out / "0").string(), model_check_);
    if (!problem.empty()) throw InputError((out / "0").string(), problem);
    if (fs::is_directory(out / kSummaryName)) {
      throw InputError((out / kSummaryName).string(),
                       "is a directory, cannot write the run summary");
    }
  }
  created_ = CreateDirectories(out.string());
  temporary_ = (out / (std::string(kTemporaryMarker) +
                       std::to_string(static_cast<long>(getpid()))))
                   .string();
  if (mkdir(temporary_.c_str(), 0777) != 0) {
    const std::string problem = Errno();
    RemoveCreatedDirectories(created_);
    throw InputError(output_dir,
                     "cannot write in the output directory: " + problem);
  }
  ArmCleanup(temporary_, created_);
}

OutputTransaction::~OutputTransaction() {
  if (committed_) return;
  DisarmCleanup();
  if (fs::exists(fs::path(temporary_) / kJournalName)) {
    // The installation failed half-way: the journal lets the next run in
    // OUT finish it.
    LOG(WARNING) << temporary_ << ": installation incomplete; the next run in "
                 << output_dir_ << " finishes it";
    return;
  }
  for (const std::string& kept : RemoveOwnFiles(temporary_)) {
    LOG(WARNING) << kept << ": left in the temporary directory";
  }
  RemoveCreatedDirectories(created_);
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
  const fs::path out(output_dir_);
  // Everything that could fail is checked before the first installation.
  Journal journal;
  for (int k = 0; k < num_models; ++k) {
    const std::string target = (out / std::to_string(k)).string();
    const std::string problem = ModelDirectoryProblem(target, model_check_);
    if (!problem.empty()) throw InputError(target, problem);
    struct stat status;
    if (stat(StagingModelPath(k).c_str(), &status) != 0 ||
        !S_ISDIR(status.st_mode)) {
      throw InputError(StagingModelPath(k), "model was not written");
    }
    journal.models.emplace_back(k, status.st_ino);
  }
  for (const std::string& name : files) {
    if (fs::is_directory(out / name)) {
      throw InputError((out / name).string(),
                       "is a directory, cannot write it");
    }
    if (!fs::exists(StagingFilePath(name))) {
      throw InputError(StagingFilePath(name), "was not written");
    }
    journal.files.push_back(name);
  }
  // From the journal on, a kill leaves an installation the next run
  // finishes; SIGINT/SIGTERM are only recorded.
  g_installing = 1;
  std::vector<std::string> warnings;
  try {
    WriteFilesAtomically(temporary_, {{kJournalName, JournalText(journal)}});
    if (g_install_hook) g_install_hook(0);
    warnings = FinishInstall(temporary_, out, journal);
  } catch (...) {
    g_installing = 0;
    throw;
  }
  committed_ = true;
  for (const std::string& kept : RemoveOwnFiles(temporary_)) {
    warnings.push_back(kept + ": left in the temporary directory");
  }
  DisarmCleanup();
  g_installing = 0;
  if (g_pending_signal != 0) {
    warnings.push_back(std::string(strsignal(g_pending_signal)) +
                       " received while installing the output: the output "
                       "is complete; the run finishes");
    g_pending_signal = 0;
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
