#include "colmap_irav4/util/atomic_output.h"

#include <signal.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <thread>

#include <gtest/gtest.h>

#include "colmap_irav4/util/error.h"
#include "tests/test_utils/database_test_utils.h"

namespace colmap_irav4 {
namespace {

namespace fs = std::filesystem;
using test::TempDir;

std::string ReadText(const std::string& path) {
  std::ifstream file(path);
  return std::string(std::istreambuf_iterator<char>(file),
                     std::istreambuf_iterator<char>());
}

void WriteText(const std::string& path, const std::string& text) {
  fs::create_directories(fs::path(path).parent_path());
  std::ofstream(path) << text;
}

// The tests' stand-in for reading a model: its three files hold a word.
void CheckWordModel(const std::string& dir, bool binary) {
  for (const char* name : {"cameras", "images", "points3D"}) {
    const std::string path = dir + "/" + name + (binary ? ".bin" : ".txt");
    if (ReadText(path).empty() || ReadText(path) == "junk") {
      throw InputError(path, "not a model file");
    }
  }
}

void WriteWordModel(const std::string& dir, const std::string& word) {
  for (const char* name : {"cameras.bin", "images.bin", "points3D.bin"}) {
    WriteText(dir + "/" + name, word);
  }
}

TEST(AtomicOutput, WriteFileReplacesAndLeavesNoTemporary) {
  TempDir temp;
  const std::string path = temp.File("out/a.txt");
  fs::create_directories(temp.File("out"));
  WriteFileAtomically(path, "one");
  WriteFileAtomically(path, "two");
  EXPECT_EQ(ReadText(path), "two");
  EXPECT_EQ(std::distance(fs::directory_iterator(temp.File("out")),
                          fs::directory_iterator()),
            1);
  fs::create_directories(temp.File("out/dir"));
  EXPECT_THROW(WriteFileAtomically(temp.File("out/dir"), "x"), InputError);
  EXPECT_THROW(CheckFileWritable(temp.File("out/dir")), InputError);
  WriteText(temp.File("file"), "x");
  EXPECT_THROW(CheckFileWritable(temp.File("file/sub/a.txt")), InputError);
  EXPECT_NO_THROW(CheckFileWritable(temp.File("new/sub/a.txt")));
}

TEST(AtomicOutput, TransactionInstallsModelsKeepsUserFilesWarnsStale) {
  TempDir temp;
  const std::string out = temp.File("sparse");
  WriteWordModel(out + "/0", "old");
  WriteText(out + "/0/notes.txt", "mine");
  WriteText(out + "/5/cameras.bin", "stale");
  std::vector<std::string> warnings;
  {
    OutputTransaction output(out, {}, CheckWordModel);
    WriteText(output.StagingModelPath(0) + "/cameras.bin", "new");
    WriteText(output.StagingModelPath(1) + "/cameras.bin", "new1");
    WriteFileAtomically(output.StagingFilePath("summary.json"), "{}");
    warnings = output.Commit(2, {"summary.json"});
  }
  EXPECT_EQ(ReadText(out + "/0/cameras.bin"), "new");
  EXPECT_FALSE(fs::exists(out + "/0/images.bin"));  // the old model's file
  EXPECT_EQ(ReadText(out + "/0/notes.txt"), "mine");
  EXPECT_EQ(ReadText(out + "/1/cameras.bin"), "new1");
  EXPECT_EQ(ReadText(out + "/summary.json"), "{}");
  EXPECT_EQ(ReadText(out + "/5/cameras.bin"), "stale");
  ASSERT_EQ(warnings.size(), 2u);
  EXPECT_NE(warnings[0].find("notes.txt"), std::string::npos);
  EXPECT_NE(warnings[1].find("/5: left over"), std::string::npos);
  for (const auto& entry : fs::directory_iterator(out)) {
    EXPECT_EQ(entry.path().filename().string().find(kTemporaryMarker),
              std::string::npos);
  }
}

TEST(AtomicOutput, RefusesBeforeWorkAndCleansUp) {
  TempDir temp;
  const std::string out = temp.File("sparse");
  WriteText(out + "/0/thesis.tex", "mine");
  EXPECT_THROW(OutputTransaction output(out, {}, CheckWordModel), InputError);
  EXPECT_EQ(ReadText(out + "/0/thesis.tex"), "mine");
  fs::remove_all(out + "/0");
  fs::create_directories(out + "/summary.json");
  EXPECT_THROW(OutputTransaction output(out, {}, CheckWordModel), InputError);
  fs::remove_all(out + "/summary.json");
  // A later model directory that is not a model: refused at Commit, before
  // anything is installed.
  WriteText(out + "/1/thesis.tex", "mine");
  {
    OutputTransaction output(out, {}, CheckWordModel);
    WriteText(output.StagingModelPath(0) + "/cameras.bin", "new");
    WriteText(output.StagingModelPath(1) + "/cameras.bin", "new");
    EXPECT_THROW(output.Commit(2, {}), InputError);
  }
  EXPECT_FALSE(fs::exists(out + "/0"));
  EXPECT_EQ(ReadText(out + "/1/thesis.tex"), "mine");
  for (const auto& entry : fs::directory_iterator(out)) {
    EXPECT_EQ(entry.path().filename().string().find(kTemporaryMarker),
              std::string::npos);
  }
}

TEST(AtomicOutput, DeadRunsTemporaryIsCleanedButNotForeignFiles) {
  TempDir temp;
  const std::string out = temp.File("sparse");
  const pid_t dead = fork();
  if (dead == 0) _exit(0);
  waitpid(dead, nullptr, 0);
  const std::string stale = out + "/" + kTemporaryMarker + std::to_string(dead);
  WriteText(stale + "/0/cameras.bin", "x");
  WriteText(stale + "/summary.json", "x");
  const std::string alive =
      out + "/" + kTemporaryMarker + std::to_string(getppid());
  WriteText(alive + "/0/cameras.bin", "x");
  WriteText(out + "/" + kTemporaryMarker + "1234567x/keep", "x");
  { OutputTransaction output(out, {}, CheckWordModel); }
  EXPECT_FALSE(fs::exists(stale));
  EXPECT_TRUE(fs::exists(alive + "/0/cameras.bin"));  // a live run's
}

TEST(AtomicOutput, SignalRemovesTheTemporaryDirectory) {
  TempDir temp;
  const std::string out = temp.File("sparse");
  fs::create_directories(out);
  const pid_t child = fork();
  if (child == 0) {
    OutputTransaction output(out, {}, CheckWordModel);
    WriteText(output.StagingModelPath(0) + "/cameras.bin", "x");
    WriteText(
        output.StagingModelPath(0) + "/images.bin" + kTemporaryMarker + "1",
        "x");
    raise(SIGTERM);
    _exit(3);  // not reached
  }
  int status = 0;
  waitpid(child, &status, 0);
  EXPECT_TRUE(WIFSIGNALED(status));
  EXPECT_EQ(WTERMSIG(status), SIGTERM);
  EXPECT_TRUE(fs::is_empty(out));
}

// Issue 28, item 1: an output path that is an input is refused, through any
// spelling (a link, a hard link, the database's SQLite side files).
TEST(AtomicOutput, OutputThatIsAnInputIsRefused) {
  TempDir temp;
  const std::string input = temp.File("db.db");
  WriteText(input, "database");
  WriteText(input + "-wal", "wal");
  fs::create_symlink(input, temp.File("link.db"));
  fs::create_hard_link(input, temp.File("hard.db"));
  for (const std::string& output :
       {input, temp.File("link.db"), temp.File("hard.db"),
        temp.File("sub/../db.db"), input + "-wal"}) {
    EXPECT_THROW(CheckFileWritable(output, {input}), InputError) << output;
  }
  // Through the database as if it were a directory: the system refuses
  // "db.db/../link.db"; lexically it is the link, which stays a link (found
  // by output_paths_fuzzer).
  for (const std::string& output :
       {temp.File("db.db/../link.db"), temp.File("db.db/../new.txt")}) {
    EXPECT_THROW(CheckFileWritable(output, {input}), InputError) << output;
    EXPECT_THROW(WriteFileAtomically(output, "x"), InputError) << output;
    EXPECT_THROW(OutputTransaction(output, {input}, CheckWordModel), InputError)
        << output;
  }
  EXPECT_TRUE(fs::is_symlink(temp.File("link.db")));
  EXPECT_FALSE(fs::exists(temp.File("new.txt")));
  // Through a name that does not exist: once created, "missing/.." is the
  // directory itself, so these are the database, its link and hard link.
  for (const char* name : {"db.db", "link.db", "hard.db"}) {
    const std::string output = temp.File(std::string("missing/../") + name);
    EXPECT_THROW(CheckFileWritable(output, {input}), InputError) << output;
  }
  EXPECT_TRUE(fs::is_symlink(temp.File("link.db")));
  EXPECT_FALSE(fs::exists(temp.File("missing")));
  // A file's path that ends in a directory.
  for (const char* name : {"x.txt/", "x.txt/.", "sub/.."}) {
    EXPECT_THROW(WriteFileAtomically(temp.File(name), "x"), InputError) << name;
    EXPECT_THROW(CheckFileWritable(temp.File(name), {input}), InputError)
        << name;
  }
  EXPECT_FALSE(fs::exists(temp.File("x.txt")));
  // Two outputs in one file that does not exist yet.
  EXPECT_THROW(CheckNotAnInput(temp.File("x.txt"), {temp.File("./x.txt")}),
               InputError);
  EXPECT_NO_THROW(CheckFileWritable(temp.File("other.txt"), {input}));
  EXPECT_EQ(ReadText(input), "database");
  // The mapper's case: the database stored as OUT/summary.json or as a
  // model file of OUT/0 is refused before anything is created.
  const std::string out = temp.File("sparse");
  WriteText(out + "/summary.json", "database");
  EXPECT_THROW(OutputTransaction(out, {out + "/summary.json"}, CheckWordModel),
               InputError);
  fs::remove(out + "/summary.json");
  WriteWordModel(out + "/0", "old");
  EXPECT_THROW(OutputTransaction(out, {out + "/0/images.bin"}, CheckWordModel),
               InputError);
  EXPECT_EQ(ReadText(out + "/0/images.bin"), "old");
  EXPECT_EQ(
      std::distance(fs::directory_iterator(out), fs::directory_iterator()), 1);
}

// Issue 28, item 2: a named pipe (or a device) is written into, never
// replaced; a socket is refused; a link's target is replaced, not the link.
TEST(AtomicOutput, SpecialFilesAreWrittenIntoNotReplaced) {
  TempDir temp;
  const std::string fifo = temp.File("fifo");
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  std::string received;
  std::thread reader([&] { received = ReadText(fifo); });
  EXPECT_NO_THROW(CheckFileWritable(fifo));
  WriteFileAtomically(fifo, "through the pipe\n");
  reader.join();
  EXPECT_EQ(received, "through the pipe\n");
  struct stat status;
  ASSERT_EQ(lstat(fifo.c_str(), &status), 0);
  EXPECT_TRUE(S_ISFIFO(status.st_mode));
  // A device node of our own (root only; never a real /dev entry): the
  // full device's ENOSPC is an error, the node stays a device.
  const std::string device = temp.File("full");
  if (mknod(device.c_str(), S_IFCHR | 0600, makedev(1, 7)) == 0) {
    EXPECT_THROW(WriteFileAtomically(device, "x"), InputError);
    ASSERT_EQ(lstat(device.c_str(), &status), 0);
    EXPECT_TRUE(S_ISCHR(status.st_mode));
  }
  // A socket.
  const std::string socket_path = temp.File("sock");
  const int fd = socket(AF_UNIX, SOCK_STREAM, 0);
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  std::snprintf(address.sun_path, sizeof(address.sun_path), "%s",
                socket_path.c_str());
  if (socket_path.size() < sizeof(address.sun_path) &&
      bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)) == 0) {
    EXPECT_THROW(CheckFileWritable(socket_path), InputError);
    EXPECT_THROW(WriteFileAtomically(socket_path, "x"), InputError);
    ASSERT_EQ(lstat(socket_path.c_str(), &status), 0);
    EXPECT_TRUE(S_ISSOCK(status.st_mode));
  }
  close(fd);
  // Links: the target is replaced (a dangling link's is created).
  WriteText(temp.File("target.txt"), "old");
  fs::create_symlink("target.txt", temp.File("link.txt"));
  WriteFileAtomically(temp.File("link.txt"), "new");
  EXPECT_TRUE(fs::is_symlink(temp.File("link.txt")));
  EXPECT_EQ(ReadText(temp.File("target.txt")), "new");
  fs::create_symlink("made/by/link.txt", temp.File("dangling.txt"));
  EXPECT_NO_THROW(CheckFileWritable(temp.File("dangling.txt")));
  WriteFileAtomically(temp.File("dangling.txt"), "created");
  EXPECT_TRUE(fs::is_symlink(temp.File("dangling.txt")));
  EXPECT_EQ(ReadText(temp.File("made/by/link.txt")), "created");
}

// Issue 28, item 3: model-named files that are not a model (a user's
// cameras.txt) are neither deleted nor replaced.
TEST(AtomicOutput, UserFilesNamedLikeModelFilesAreKept) {
  for (const std::string name :
       {"cameras.txt", "images.txt", "points3D.bin", "cameras.bin"}) {
    TempDir temp;
    const std::string out = temp.File("sparse");
    WriteText(out + "/0/" + name, "junk");
    EXPECT_NE(ModelDirectoryProblem(out + "/0", CheckWordModel), "");
    EXPECT_THROW(OutputTransaction(out, {}, CheckWordModel), InputError);
    EXPECT_EQ(ReadText(out + "/0/" + name), "junk");
  }
  // A complete set that does not read as a model: kept too.
  TempDir temp;
  const std::string out = temp.File("sparse");
  WriteWordModel(out + "/0", "junk");
  EXPECT_NE(ModelDirectoryProblem(out + "/0", CheckWordModel)
                .find("do not read as a model"),
            std::string::npos);
  // A model plus a junk file of the other format: refused (the junk file
  // would otherwise be deleted with the old model).
  WriteWordModel(out + "/0", "old");
  WriteText(out + "/0/cameras.txt", "junk");
  EXPECT_NE(ModelDirectoryProblem(out + "/0", CheckWordModel), "");
  // summary.json inside a model directory is the user's: carried over; the
  // old model's project.ini goes with it (the new one's replaces it).
  fs::remove(out + "/0/cameras.txt");
  WriteText(out + "/0/summary.json", "mine");
  WriteText(out + "/0/project.ini", "old options");
  std::vector<std::string> warnings;
  {
    OutputTransaction output(out, {}, CheckWordModel);
    WriteWordModel(output.StagingModelPath(0), "new");
    WriteText(output.StagingModelPath(0) + "/project.ini", "new options");
    warnings = output.Commit(1, {});
  }
  EXPECT_EQ(ReadText(out + "/0/summary.json"), "mine");
  EXPECT_EQ(ReadText(out + "/0/images.bin"), "new");
  EXPECT_EQ(ReadText(out + "/0/project.ini"), "new options");
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("summary.json: not a model file"),
            std::string::npos);
  // A project.ini alone (COLMAP's GUI project, say) is not ours.
  TempDir other;
  WriteText(other.File("sparse/0/project.ini"), "a user's project");
  EXPECT_THROW(OutputTransaction(other.File("sparse"), {}, CheckWordModel),
               InputError);
  EXPECT_EQ(ReadText(other.File("sparse/0/project.ini")), "a user's project");
}

// Found by output_paths_fuzzer: an output spelled through a link and ".."
// names one directory for every operation (the one the system resolves).
TEST(AtomicOutput, OutputThroughLinkAndDotDotIsOneDirectory) {
  TempDir temp;
  fs::create_directories(temp.File("deep/b"));
  fs::create_directories(temp.File("a"));
  fs::create_directory_symlink(temp.File("deep/b"), temp.File("a/link"));
  const std::string out = temp.File("a/link/../out");
  {
    OutputTransaction output(out, {}, CheckWordModel);
    WriteWordModel(output.StagingModelPath(0), "new");
    WriteFileAtomically(output.StagingFilePath("summary.json"), "{}");
    output.Commit(1, {"summary.json"});
  }
  EXPECT_EQ(ReadText(temp.File("deep/out/0/images.bin")), "new");
  EXPECT_EQ(ReadText(temp.File("deep/out/summary.json")), "{}");
  EXPECT_EQ(std::distance(fs::directory_iterator(temp.File("deep/out")),
                          fs::directory_iterator()),
            2);
  WriteFileAtomically(temp.File("a/link/../new/x/../file.txt"), "text");
  EXPECT_EQ(ReadText(temp.File("deep/new/file.txt")), "text");
}

// Found by output_paths_fuzzer: "dangling/../dir/file" names nothing the
// system can open (the link leads nowhere); resolved lexically it was the
// user's dir/file, which the writer replaced. Refused, naming the link, and
// nothing changes.
TEST(AtomicOutput, OutputThroughDanglingLinkIsRefused) {
  TempDir temp;
  WriteText(temp.File("dir/cameras.bin"), "user's");
  fs::create_symlink("nowhere/x", temp.File("dangling"));
  const std::string path = temp.File("dangling/../dir/cameras.bin");
  try {
    CheckFileWritable(path);
    ADD_FAILURE() << "CheckFileWritable accepted " << path;
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("dangling is a symbolic link"),
              std::string::npos)
        << error.what();
  }
  EXPECT_THROW(WriteFileAtomically(path, "bytes"), InputError);
  EXPECT_THROW(
      OutputTransaction(temp.File("dangling/../dir"), {}, CheckWordModel),
      InputError);
  EXPECT_EQ(ReadText(temp.File("dir/cameras.bin")), "user's");
  EXPECT_FALSE(fs::exists(temp.File("nowhere")));
  // An input behind such a link names nothing: no false match.
  EXPECT_NO_THROW(CheckNotAnInput(temp.File("out.txt"),
                                  {temp.File("dangling/../out.txt")}));
}

// Issue 28, item 4: a run killed at any step of the installation leaves a
// state the next run finishes: the new models and summary, the user's file
// in OUT/0, no temporary directory.
int g_exit_at_step = -1;
void ExitAtStep(int step) {
  if (step == g_exit_at_step) _exit(9);
}
void InterruptAtStep(int step) {
  if (step == g_exit_at_step) raise(SIGINT);
}

TEST(AtomicOutput, KilledInstallationIsFinishedByTheNextRun) {
  for (const int step : {0, 10, 1, 11, 12, 20, 21, 22, 30}) {
    TempDir temp;
    const std::string out = temp.File("sparse");
    WriteWordModel(out + "/0", "old");
    WriteText(out + "/0/notes.txt", "mine");
    WriteWordModel(out + "/1", "old1");
    WriteText(out + "/summary.json", "old summary");
    const pid_t child = fork();
    if (child == 0) {
      g_exit_at_step = step;
      internal::SetInstallHookForTesting(ExitAtStep);
      OutputTransaction output(out, {}, CheckWordModel);
      WriteWordModel(output.StagingModelPath(0), "new");
      WriteWordModel(output.StagingModelPath(1), "new1");
      WriteText(output.StagingFilePath("summary.json"), "new summary");
      output.Commit(2, {"summary.json"});
      _exit(0);
    }
    int status = 0;
    waitpid(child, &status, 0);
    ASSERT_TRUE(WIFEXITED(status));
    EXPECT_EQ(WEXITSTATUS(status), 9) << "step " << step << " not reached";
    // At every instant OUT/0 is a complete model.
    const std::string word = ReadText(out + "/0/images.bin");
    EXPECT_TRUE(word == "old" || word == "new") << step;
    { OutputTransaction next(out, {}, CheckWordModel); }
    EXPECT_EQ(ReadText(out + "/0/images.bin"), "new") << step;
    EXPECT_EQ(ReadText(out + "/0/points3D.bin"), "new") << step;
    EXPECT_EQ(ReadText(out + "/0/notes.txt"), "mine") << step;
    EXPECT_EQ(ReadText(out + "/1/cameras.bin"), "new1") << step;
    EXPECT_EQ(ReadText(out + "/summary.json"), "new summary") << step;
    for (const auto& entry : fs::directory_iterator(out)) {
      EXPECT_EQ(entry.path().filename().string().find(kTemporaryMarker),
                std::string::npos)
          << step;
    }
  }
}

// Issue 28, item 4: SIGINT while the output is installed: the run
// completes and exits normally, leaving no temporary directory.
TEST(AtomicOutput, InterruptDuringInstallationCompletesTheRun) {
  TempDir temp;
  const std::string out = temp.File("sparse");
  WriteWordModel(out + "/0", "old");
  WriteText(out + "/0/notes.txt", "mine");
  const pid_t child = fork();
  if (child == 0) {
    g_exit_at_step = 10;
    internal::SetInstallHookForTesting(InterruptAtStep);
    OutputTransaction output(out, {}, CheckWordModel);
    WriteWordModel(output.StagingModelPath(0), "new");
    WriteText(output.StagingFilePath("summary.json"), "new summary");
    const std::vector<std::string> warnings =
        output.Commit(1, {"summary.json"});
    bool reported = false;
    for (const std::string& warning : warnings) {
      reported |= warning.find("output is complete") != std::string::npos;
    }
    _exit(reported ? 0 : 4);
  }
  int status = 0;
  waitpid(child, &status, 0);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0);
  EXPECT_EQ(ReadText(out + "/0/images.bin"), "new");
  EXPECT_EQ(ReadText(out + "/0/notes.txt"), "mine");
  EXPECT_EQ(ReadText(out + "/summary.json"), "new summary");
  EXPECT_EQ(
      std::distance(fs::directory_iterator(out), fs::directory_iterator()), 2);
}

// Issue 28, item 6: a run that fails (or is interrupted) leaves no
// directory it created; the checks before work create nothing.
TEST(AtomicOutput, FailedRunLeavesNoDirectory) {
  TempDir temp;
  EXPECT_NO_THROW(CheckFileWritable(temp.File("a/b/poses.txt")));
  EXPECT_FALSE(fs::exists(temp.File("a")));
  { OutputTransaction output(temp.File("x/y/sparse"), {}, CheckWordModel); }
  EXPECT_FALSE(fs::exists(temp.File("x")));
  const pid_t child = fork();
  if (child == 0) {
    OutputTransaction output(temp.File("p/q"), {}, CheckWordModel);
    WriteWordModel(output.StagingModelPath(0), "new");
    raise(SIGTERM);
    _exit(3);  // not reached
  }
  int status = 0;
  waitpid(child, &status, 0);
  EXPECT_TRUE(WIFSIGNALED(status));
  EXPECT_FALSE(fs::exists(temp.File("p")));
  // An existing output directory stays.
  fs::create_directories(temp.File("kept"));
  { OutputTransaction output(temp.File("kept"), {}, CheckWordModel); }
  EXPECT_TRUE(fs::is_directory(temp.File("kept")));
}

}  // namespace
}  // namespace colmap_irav4
