#pragma once

// Output safety: files and model directories appear complete or not at all,
// and the program deletes only what it wrote.
//
// Files: written to "<path>.colmap_irav4_tmp.<pid>" in the same directory,
// then renamed over <path> (rename is atomic on POSIX).
//
// Model directories (OutputTransaction): every model of a run is written
// into OUT/.colmap_irav4_tmp.<pid>/<k>; only once all are complete each is
// swapped with OUT/<k> by one atomic exchange (renameat2 RENAME_EXCHANGE;
// two renames where the file system lacks it), so that at every instant
// OUT/<k> is the complete old or the complete new model. The old model ends
// up in the temporary directory and its model files are removed there.
//
// What is ours: the model files (cameras/images/points3D .bin/.txt),
// project.ini, summary.json and names holding ".colmap_irav4_tmp.". Anything
// else inside an old OUT/<k> (a user's notes, a database, ...) is moved into
// the new OUT/<k> with a warning, never deleted. An OUT/<k> that holds files
// but no model is not replaced (error before anything is installed).
//
// Interrupts: SIGINT/SIGTERM during the run remove the temporary directory's
// own files (an async-signal-safe walk) before the default action; during
// the installation (a few renames) the two signals are blocked. Temporary
// directories of killed runs (their PID no longer alive) are cleaned the
// same way when a later run starts in the same OUT.

#include <string>
#include <utility>
#include <vector>

namespace colmap_irav4 {

// The marker of every temporary name this program creates.
constexpr char kTemporaryMarker[] = ".colmap_irav4_tmp.";

// Whether `name` (a file name, no directory) is one this program writes:
// model files, project.ini, summary.json, or a temporary name.
bool IsOwnOutputFileName(const std::string& name);

// Writes `bytes` to `path` (its directory must exist) through a temporary
// file in the same directory, flushed to disk, and an atomic rename. Throws
// InputError naming the path on failure (the temporary file is removed; an
// existing file at `path` is untouched).
void WriteFileAtomically(const std::string& path, const std::string& bytes);

// Writes several files of one directory (created if missing): all temporary
// files first, then the renames; a directory in the way of any of them fails
// before the first rename.
void WriteFilesAtomically(
    const std::string& dir,
    const std::vector<std::pair<std::string, std::string>>& names_and_bytes);

// Throws InputError unless `path`'s directory exists (or can be created) and a
// file can be created in it; an existing directory at `path` is an error too.
// Call before any long work.
void CheckFileWritable(const std::string& path);

// Removes the files of a directory tree that IsOwnOutputFileName accepts and
// the directories left empty, leaving (and returning) any other entries.
std::vector<std::string> RemoveOwnFiles(const std::string& dir);

class OutputTransaction {
 public:
  // Checks that `output_dir` can be written (created if missing) before any
  // work: a probe file, OUT/0 replaceable, OUT/summary.json not a directory.
  // Cleans temporary directories of dead runs, creates this run's and arms
  // the SIGINT/SIGTERM cleanup. Throws InputError.
  explicit OutputTransaction(const std::string& output_dir);
  // Removes this run's temporary directory (only its own files) if Commit
  // did not run or failed.
  ~OutputTransaction();
  OutputTransaction(const OutputTransaction&) = delete;
  OutputTransaction& operator=(const OutputTransaction&) = delete;

  // Where model k is to be written before Commit.
  std::string StagingModelPath(int k) const;
  // Where summary.json is to be written before Commit.
  std::string StagingFilePath(const std::string& name) const;

  // Installs models 0..num_models-1 and the staged top-level files (e.g.
  // summary.json), in that order. Returns warnings (user files carried over,
  // stale OUT/k of earlier runs beyond num_models). Throws InputError before
  // the first installation if any target cannot be replaced.
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
  bool committed_ = false;
};

// Checks whether `dir` is a directory OutputTransaction may replace: "" if
// it is missing, empty or holds a model; else the problem.
std::string ModelDirectoryProblem(const std::string& dir);

}  // namespace colmap_irav4
