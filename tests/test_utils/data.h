#pragma once

// The shared real data of the end-to-end tests (../shared/data, never copied
// into the project). Tests that need it skip cleanly when it is absent:
//   COLMAP_IRAV4_REQUIRE_DATA("strecha/fountain-P11");
// The environment variable COLMAP_IRAV4_DATA_DIR overrides the folder chosen
// at configure time (CMake cache variable of the same name), e.g. to check
// that every such test skips: COLMAP_IRAV4_DATA_DIR=/nonexistent ctest ...

#include <cstdlib>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

namespace colmap_irav4 {

inline std::string DataDir() {
  const char* dir = std::getenv("COLMAP_IRAV4_DATA_DIR");
  return dir != nullptr && dir[0] != '\0' ? std::string(dir)
                                          : std::string(COLMAP_IRAV4_DATA_DIR);
}

// Whether DataDir()/relative exists.
inline bool HaveData(const std::string& relative) {
  return std::filesystem::exists(DataDir() + "/" + relative);
}

}  // namespace colmap_irav4

// Skips the current test (from its body or a fixture's SetUp) when
// DataDir()/relative is absent.
#define COLMAP_IRAV4_REQUIRE_DATA(relative)                         \
  do {                                                              \
    if (!::colmap_irav4::HaveData(relative)) {                      \
      GTEST_SKIP() << "shared data absent: "                        \
                   << ::colmap_irav4::DataDir() + "/" + (relative); \
    }                                                               \
  } while (false)
