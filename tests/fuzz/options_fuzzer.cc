// libFuzzer target: random flag values through the option parser into the
// options structs' Check() (issue 28). The first byte picks a command's
// option set (mapper, view_graph, rotation_averager); then pairs of (flag
// number, value) from the input become a command line. Parse and Check must
// end in InputError or accept; an accepted set of mapper options must hold
// no non-finite value where a finite one is needed (extent, thresholds) and
// give per-stage options (ForStages) without a CHECK failure.

#include <cmath>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "colmap_irav4/pipeline/option_registration.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/option_manager.h"
#include "tests/fuzz/fuzz_utils.h"

namespace {

using namespace colmap_irav4;

// Values worth trying beside the input's own bytes.
const char* const kValues[] = {"0",
                               "1",
                               "-1",
                               "2",
                               "nan",
                               "inf",
                               "-inf",
                               "1e309",
                               "1e-300",
                               "2147483648",
                               "-2147483649",
                               "0x10",
                               "1,5",
                               "",
                               " ",
                               "true",
                               "false",
                               "yes",
                               "BIN",
                               "irav4",
                               "global_positioning",
                               "1.5",
                               "-0",
                               "1e300",
                               "9999999999999999999",
                               "0.5"};

// Builds argv from the input and runs parse + check; returns whether the
// options were accepted.
bool ParseAndCheck(OptionManager* manager, const std::function<void()>& check,
                   const uint8_t* data, size_t size) {
  const std::vector<std::pair<std::string, std::string>> flags =
      manager->Options();
  std::vector<std::string> arguments = {"fuzz"};
  size_t offset = 0;
  while (offset + 2 <= size && arguments.size() < 40) {
    const size_t flag = data[offset] % (flags.size() + 1);
    const uint8_t how = data[offset + 1];
    offset += 2;
    const std::string name =
        flag < flags.size() ? flags[flag].first : "no_such_flag";
    std::string value;
    if (how < 128) {
      value = kValues[how % (sizeof(kValues) / sizeof(kValues[0]))];
    } else {
      // A value from the input's bytes (up to 12, ending at a 0 byte).
      while (offset < size && data[offset] != 0 && value.size() < 12) {
        value += static_cast<char>(data[offset++]);
      }
      if (offset < size) ++offset;
    }
    if (how % 3 == 0) {
      arguments.push_back("--" + name + "=" + value);
    } else {
      arguments.push_back("--" + name);
      if (how % 7 != 0) arguments.push_back(value);  // else: value missing
    }
  }
  std::vector<char*> argv;
  for (std::string& argument : arguments) argv.push_back(argument.data());
  argv.push_back(nullptr);
  try {
    if (!manager->Parse(static_cast<int>(arguments.size()), argv.data())) {
      return false;
    }
    manager->Check(check);
  } catch (const InputError&) {
    return false;
  }
  return true;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const int command = data[0] % 3;
  ++data;
  --size;
  if (command == 0) {
    GlobalMapperOptions options;
    OptionManager manager("mapper");
    AddGlobalMapperOptions(&manager, &options);
    if (ParseAndCheck(
            &manager, [&] { options.Check(); }, data, size)) {
      // Accepted options are usable: a finite normalisation, and per-stage
      // options for any database size without a CHECK failure.
      if (!std::isfinite(options.normalization.extent)) __builtin_trap();
      for (const size_t num_images : {size_t{2}, size_t{1000}}) {
        options.ForStages(num_images).Check();
      }
    }
  } else if (command == 1) {
    ViewGraphBuilderOptions options;
    OptionManager manager("view_graph");
    AddViewGraphOptions(&manager, &options);
    ParseAndCheck(
        &manager, [&] { options.Check(); }, data, size);
  } else {
    RotationAveragerOptions averager_options;
    ViewGraphBuilderOptions builder_options;
    OptionManager manager("rotation_averager");
    AddViewGraphOptions(&manager, &builder_options, "ViewGraph.min_num_inliers",
                        /*with_threads_and_components=*/false);
    AddRotationAveragerOptions(&manager, &averager_options);
    ParseAndCheck(
        &manager,
        [&] {
          builder_options.Check();
          averager_options.Check();
        },
        data, size);
  }
  return 0;
}
