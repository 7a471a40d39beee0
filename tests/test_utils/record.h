#pragma once

// Figures a test measures go into its report (RecordProperty, key "figures":
// `TEST_BINARY --gtest_output=json:out.json`) instead of stdout:
//   COLMAP_IRAV4_FIGURES << "median " << median << " deg";
//   RecordFiguresF("median %.3f deg", median);
// Several records in one test are joined by newlines.

#include <cstdarg>
#include <cstdio>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

namespace colmap_irav4 {
namespace test {

inline void RecordFigures(std::string text) {
  while (!text.empty() && text.back() == '\n') text.pop_back();
  static std::string current_test;
  static std::string figures;
  const ::testing::TestInfo* info =
      ::testing::UnitTest::GetInstance()->current_test_info();
  const std::string name =
      info == nullptr
          ? std::string()
          : std::string(info->test_suite_name()) + "." + info->name();
  if (name != current_test) {
    current_test = name;
    figures.clear();
  }
  if (!figures.empty()) figures += "\n";
  figures += text;
  ::testing::Test::RecordProperty("figures", figures);
}

__attribute__((format(printf, 1, 2))) inline void RecordFiguresF(
    const char* format, ...) {
  va_list args;
  va_start(args, format);
  va_list copy;
  va_copy(copy, args);
  const int size = std::vsnprintf(nullptr, 0, format, copy);
  va_end(copy);
  std::string text(size > 0 ? size : 0, '\0');
  if (size > 0) std::vsnprintf(&text[0], text.size() + 1, format, args);
  va_end(args);
  RecordFigures(text);
}

// A stream whose text is recorded when the statement ends.
class FigureStream : public std::ostringstream {
 public:
  ~FigureStream() override { RecordFigures(str()); }
};

}  // namespace test
}  // namespace colmap_irav4

#define COLMAP_IRAV4_FIGURES ::colmap_irav4::test::FigureStream()
