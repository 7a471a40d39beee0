#pragma once

// Helpers of the libFuzzer targets: inputs become files in a per-process
// scratch directory (the readers take paths), split into parts by a small
// header of 16-bit lengths so that any mutation stays a valid input.

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace colmap_irav4 {
namespace fuzz {

inline const std::string& ScratchDir() {
  static const std::string dir = [] {
    const std::string path = std::filesystem::temp_directory_path() /
                             ("colmap_irav4_fuzz_" + std::to_string(getpid()));
    std::filesystem::create_directories(path);
    return path;
  }();
  return dir;
}

inline std::string WriteScratchFile(const std::string& name,
                                    const std::string& bytes) {
  const std::string path = ScratchDir() + "/" + name;
  std::ofstream file(path, std::ios::binary | std::ios::trunc);
  file.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  return path;
}

// Splits data into `num_parts`: the first num_parts - 1 parts' lengths are
// 16-bit little-endian numbers at the start; the last part is the rest.
inline std::vector<std::string> SplitInput(const uint8_t* data, size_t size,
                                           int num_parts) {
  std::vector<std::string> parts;
  size_t offset = 2 * static_cast<size_t>(num_parts - 1);
  if (size < offset) return parts;
  for (int k = 0; k + 1 < num_parts; ++k) {
    size_t length = data[2 * k] | (static_cast<size_t>(data[2 * k + 1]) << 8);
    if (length > size - offset) length = size - offset;
    parts.emplace_back(reinterpret_cast<const char*>(data + offset), length);
    offset += length;
  }
  parts.emplace_back(reinterpret_cast<const char*>(data + offset),
                     size - offset);
  return parts;
}

}  // namespace fuzz
}  // namespace colmap_irav4
