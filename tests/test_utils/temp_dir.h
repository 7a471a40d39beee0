#pragma once

// A fresh temporary directory for a test's files, removed with its contents
// on destruction, so test runs leave nothing behind in /tmp.

#include <filesystem>
#include <random>
#include <string>
#include <system_error>

namespace colmap_irav4 {
namespace test {

class TempDir {
 public:
  TempDir() {
    std::random_device device;
    path_ = (std::filesystem::temp_directory_path() /
             ("colmap_irav4_test_" + std::to_string(device()) + "_" +
              std::to_string(device())))
                .string();
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code error;
    std::filesystem::remove_all(path_, error);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  const std::string& path() const { return path_; }
  std::string File(const std::string& name) const {
    return (std::filesystem::path(path_) / name).string();
  }

 private:
  std::string path_;
};

}  // namespace test
}  // namespace colmap_irav4
