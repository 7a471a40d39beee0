#pragma once

#include <memory>
#include <string>
#include <vector>

#include "colmap_irav4/rotation_averaging/ira.h"
#include "colmap_irav4/rotation_averaging/irav4.h"
#include "colmap_irav4/rotation_averaging/l1_irls.h"
#include "colmap_irav4/rotation_averaging/rotation_graph.h"

namespace colmap_irav4 {

// The options of every rotation averaging method, exposed on the command
// line as --RotationAveraging.<name>. One set each: IRAv4's engine is also
// the ira method's, and IRAv4's refinement (L1-IRLS' settings) also the
// l1_irls method's.
struct RotationAveragerOptions {
  Irav4Options irav4;
  // Log progress lines during long runs.
  bool log_progress = false;

  // Throws InputError naming the offending option.
  void Check() const;
};

// The methods, in the order the help text lists them.
std::vector<std::string> RotationAveragerMethods();
// "a, b, c" for help texts and error messages.
std::string RotationAveragerMethodList();

// The averager called `method`; throws InputError("--method", ...) for an
// unknown name.
std::unique_ptr<RotationAverager> CreateRotationAverager(
    const std::string& method, const RotationAveragerOptions& options);

}  // namespace colmap_irav4
