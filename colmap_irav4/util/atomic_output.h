#pragma once

// Output safety: files and model directories appear complete or not at all,
// the program deletes or replaces only what it wrote, and never writes over
// one of its inputs.
//
// Files: written to "<path>.colmap_irav4_tmp.<pid>" in the same directory,
// then renamed over <path> (rename is atomic on POSIX). A symbolic link is
// followed (its target is replaced, the link stays). A named pipe, a
// character device (/dev/null, a terminal) and any path under /dev or /proc
// (/dev/stdout) are written into, never replaced; a block device, a socket
// or a directory is refused.
//
// Model directories (OutputTransaction): every model of a run is written
// into OUT/.colmap_irav4_tmp.<pid>/<k>; only once all are complete, an
// install journal is written and each is swapped with OUT/<k> by one atomic
// exchange (renameat2 RENAME_EXCHANGE; two renames where the file system
// lacks it), so that at every instant OUT/<k> is the complete old or the
// complete new model; summary.json follows. A run killed during the
// installation leaves the journal: the next run in the same OUT finishes
// the installation before anything else, so a user's file never stays in a
// temporary directory and the models and summary.json end up of one run.
//
// What is ours: the model files (cameras/images/points3D .bin/.txt) and
// project.ini of an old OUT/<k> that holds a model (complete and readable,
// checked by the caller's ModelCheck), summary.json at the top of OUT, and
// names holding ".colmap_irav4_tmp.". An OUT/<k> with model-named files that
// do not form a readable model (a user's cameras.txt), or with only a
// project.ini, is not replaced (error before any work). Anything else inside
// an old OUT/<k> (a user's notes, a database, ...) is moved into the new
// OUT/<k> with a warning, never deleted.
//
// Interrupts: SIGINT/SIGTERM during the run remove the temporary directory's
// own files (an async-signal-safe walk) and the directories the run created
// before the default action (a signal the host program handles itself, as
// Python does SIGINT, is left to it: it stops the run through
// util/interrupt.h and the destructor cleans); during the installation the two
// signals are blocked, and one that arrives then is reported and ignored (the
// run is complete). Temporary directories of killed runs (their PID no longer
// alive) are cleaned, or their installation finished, when a later run
// starts in the same OUT.

#include <functional>
#include <string>
#include <utility>
#include <vector>

namespace colmap_irav4 {

// The marker of every temporary name this program creates.
constexpr char kTemporaryMarker[] = ".colmap_irav4_tmp.";

// Whether `name` (a file name, no directory) is one this program writes:
// model files, project.ini, summary.json, or a temporary name.
bool IsOwnOutputFileName(const std::string& name);

// Throws InputError naming `output` if it is the same file as one of
// `inputs` (also through a link or another spelling) or as an input's SQLite
// side file (-wal, -shm, -journal). Missing paths never match.
void CheckNotAnInput(const std::string& output,
                     const std::vector<std::string>& inputs);

// Writes `bytes` to `path` through a temporary file in the same directory
// (created if missing), flushed to disk, and an atomic rename; special files
// are written into (see above). Throws InputError naming the path on failure
// (the temporary file and the directories created are removed; an existing
// file at `path` is untouched).
void WriteFileAtomically(const std::string& path, const std::string& bytes);

// Writes several files of one directory (created if missing): all temporary
// files first, then the renames; a directory in the way of any of them fails
// before the first rename.
void WriteFilesAtomically(
    const std::string& dir,
    const std::vector<std::pair<std::string, std::string>>& names_and_bytes);

// Throws InputError unless a file can be written at `path`: not one of
// `inputs` (CheckNotAnInput), not a directory, block device or socket, and
// its nearest existing directory is one a file can be created in. Creates
// nothing (the directories are created when the file is written). Call
// before any long work.
void CheckFileWritable(const std::string& path,
                       const std::vector<std::string>& inputs = {});

// Removes the files of a directory tree that IsOwnOutputFileName accepts and
// the directories left empty, leaving (and returning) any other entries.
std::vector<std::string> RemoveOwnFiles(const std::string& dir);

// Throws InputError if directory `dir` does not hold a readable model of
// the given format (binary: .bin files, else .txt); supplied by the caller
// (util does not read models).
using ModelCheck = std::function<void(const std::string& dir, bool binary)>;

class OutputTransaction {
 public:
  // Checks that `output_dir` can be written before any work: not under /dev
  // or /proc, no input among the files the run would replace (OUT/
  // summary.json, the model files of OUT/<k>), OUT/0 replaceable (see
  // ModelDirectoryProblem), OUT/summary.json not a directory. Finishes or
  // cleans temporary directories of dead runs, creates OUT (if missing) and
  // this run's temporary directory, and arms the SIGINT/SIGTERM cleanup.
  // Throws InputError.
  OutputTransaction(const std::string& output_dir,
                    const std::vector<std::string>& inputs,
                    ModelCheck model_check);
  // Removes this run's temporary directory (only its own files) and the
  // directories it created if Commit did not run or failed.
  ~OutputTransaction();
  OutputTransaction(const OutputTransaction&) = delete;
  OutputTransaction& operator=(const OutputTransaction&) = delete;

  // Where model k is to be written before Commit.
  std::string StagingModelPath(int k) const;
  // Where summary.json is to be written before Commit.
  std::string StagingFilePath(const std::string& name) const;

  // Installs models 0..num_models-1 and the staged top-level files (e.g.
  // summary.json), in that order. Returns warnings (user files carried over,
  // stale OUT/k of earlier runs beyond num_models, an interrupt that came
  // during the installation). Throws InputError before the first
  // installation if any target cannot be replaced.
  std::vector<std::string> Commit(int num_models,
                                  const std::vector<std::string>& files);

  // OUT/<k> directories with k >= num_models (earlier runs' models, also
  // after a gap), sorted; never removed.
  std::vector<std::string> StaleModelDirectories(int num_models) const;

  const std::string& TemporaryPath() const { return temporary_; }
  const std::string& OutputPath() const { return output_dir_; }

 private:
  std::string output_dir_;
  std::string temporary_;
  ModelCheck model_check_;
  // Directories this run created (deepest last), removed if it fails.
  std::vector<std::string> created_;
  bool committed_ = false;
};

// Checks whether `dir` is a directory OutputTransaction may replace: "" if
// it is missing, empty or holds a model (its model-named files complete and
// accepted by `model_check`); else the problem.
std::string ModelDirectoryProblem(const std::string& dir,
                                  const ModelCheck& model_check);

namespace internal {
// Tests only: `hook(step)` runs after each step of an installation (a test
// that exits there is a run killed at that moment).
void SetInstallHookForTesting(void (*hook)(int step));
}  // namespace internal

}  // namespace colmap_irav4
