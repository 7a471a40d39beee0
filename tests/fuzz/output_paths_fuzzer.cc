// libFuzzer target: output paths (issue 28). A scratch tree holds an input
// database, a link to it, a hard link, a directory, an old model directory
// with a user's file and a file named like a model file; the input spells
// an output path from those names ("..", ".", "", links) and picks a writer:
// one file (WriteFileAtomically after CheckFileWritable with the database
// as input) or a model directory (OutputTransaction + Commit). Whatever the
// path: the database, the user's files and the links are never changed, and
// no temporary name is left behind.

#include <sys/stat.h>
#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <utility>
#include <vector>

#include "colmap_irav4/util/atomic_output.h"
#include "colmap_irav4/util/error.h"
#include "tests/fuzz/fuzz_utils.h"

namespace {

namespace fs = std::filesystem;
using namespace colmap_irav4;

const char* const kNames[] = {
    "db.db",       "link.db",   "hard.db",      "dir",     "model", "0",
    "cameras.bin", "notes.txt", "summary.json", "..",      ".",     "",
    "new",         "db.db-wal", "dangling",     "dir_link"};

std::string ReadText(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(file),
                     std::istreambuf_iterator<char>());
}

void Write(const std::string& path, const std::string& text) {
  fs::create_directories(fs::path(path).parent_path());
  std::ofstream(path, std::ios::binary) << text;
}

void Require(bool condition) {
  if (!condition) __builtin_trap();
}

// Whether a name of the tree (below root) holds the temporary marker.
bool HasTemporary(const fs::path& root) {
  std::error_code error;
  for (auto it = fs::recursive_directory_iterator(root, error);
       it != fs::recursive_directory_iterator(); it.increment(error)) {
    if (error) break;
    if (it->path().filename().string().find(kTemporaryMarker) !=
        std::string::npos) {
      return true;
    }
  }
  return false;
}

void CheckModel(const std::string& dir, bool binary) {
  const std::string text =
      ReadText(dir + (binary ? "/cameras.bin" : "/cameras.txt"));
  if (text != "model") throw InputError(dir, "not a model");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 2) return 0;
  const fs::path root = fs::path(fuzz::ScratchDir()) / "tree";
  std::error_code error;
  fs::remove_all(root, error);
  const std::string db = (root / "db.db").string();
  Write(db, "database");
  Write(db + "-wal", "wal");
  fs::create_symlink("db.db", root / "link.db", error);
  fs::create_hard_link(db, root / "hard.db", error);
  fs::create_directories(root / "dir");
  fs::create_directory_symlink("dir", root / "dir_link", error);
  fs::create_symlink("nowhere/x", root / "dangling", error);
  for (const char* name : {"cameras.bin", "images.bin", "points3D.bin"}) {
    Write((root / "model/0" / name).string(), "model");
  }
  Write((root / "model/0/notes.txt").string(), "mine");
  Write((root / "dir/cameras.bin").string(), "user's");

  // The path: up to 5 names, kept inside the tree (no absolute path, no
  // escape through "..").
  const bool as_model = data[0] & 1;
  fs::path relative;
  for (size_t k = 1; k < size && k < 6; ++k) {
    relative /= kNames[data[k] % (sizeof(kNames) / sizeof(kNames[0]))];
  }
  const fs::path normal = (root / relative).lexically_normal();
  if (normal.string().rfind(root.string(), 0) != 0) return 0;
  const std::string path = (root / relative).string();
  const std::string bytes(reinterpret_cast<const char*>(data),
                          std::min<size_t>(size, 64));
  bool wrote_file = false;
  try {
    if (as_model) {
      OutputTransaction output(path, {db}, CheckModel);
      Write(output.StagingModelPath(0) + "/cameras.bin", "model");
      Write(output.StagingModelPath(0) + "/images.bin", "model");
      Write(output.StagingModelPath(0) + "/points3D.bin", "model");
      WriteFileAtomically(output.StagingFilePath("summary.json"), bytes);
      output.Commit(1, {"summary.json"});
    } else {
      CheckFileWritable(path, {db});
      WriteFileAtomically(path, bytes);
      wrote_file = true;
    }
  } catch (const InputError&) {
  }
  Require(ReadText(db) == "database");
  Require(ReadText(db + "-wal") == "wal");
  Require(fs::is_symlink(root / "link.db"));
  Require(fs::is_symlink(root / "dangling"));
  Require(fs::is_symlink(root / "dir_link"));
  // A user's file changes only as the one file the single-file writer was
  // asked to write: the file the path names once its missing directories
  // exist ("dir/new/../x" is dir/x), so they are created here and the
  // system's own resolution (canonical) says which file that is.
  fs::path written;
  if (wrote_file) {
    fs::create_directories(fs::path(path).parent_path(), error);
    written = fs::canonical(path, error);
  }
  for (const auto& [file, text] :
       {std::pair<std::string, std::string>{"dir/cameras.bin", "user's"},
        {"model/0/notes.txt", "mine"}}) {
    if (fs::canonical(root / file, error) != written) {
      Require(ReadText((root / file).string()) == text);
    }
  }
  Require(!HasTemporary(root));
  return 0;
}
