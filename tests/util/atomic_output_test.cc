#include "colmap_irav4/util/atomic_output.h"

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>

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
  WriteText(out + "/0/cameras.bin", "old");
  WriteText(out + "/0/images.bin", "old");
  WriteText(out + "/0/notes.txt", "mine");
  WriteText(out + "/5/cameras.bin", "stale");
  std::vector<std::string> warnings;
  {
    OutputTransaction output(out);
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
  EXPECT_THROW(OutputTransaction output(out), InputError);
  EXPECT_EQ(ReadText(out + "/0/thesis.tex"), "mine");
  fs::remove_all(out + "/0");
  fs::create_directories(out + "/summary.json");
  EXPECT_THROW(OutputTransaction output(out), InputError);
  fs::remove_all(out + "/summary.json");
  // A later model directory that is not a model: refused at Commit, before
  // anything is installed.
  WriteText(out + "/1/thesis.tex", "mine");
  {
    OutputTransaction output(out);
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
  { OutputTransaction output(out); }
  EXPECT_FALSE(fs::exists(stale));
  EXPECT_TRUE(fs::exists(alive + "/0/cameras.bin"));  // a live run's
}

TEST(AtomicOutput, SignalRemovesTheTemporaryDirectory) {
  TempDir temp;
  const std::string out = temp.File("sparse");
  fs::create_directories(out);
  const pid_t child = fork();
  if (child == 0) {
    OutputTransaction output(out);
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

}  // namespace
}  // namespace colmap_irav4
