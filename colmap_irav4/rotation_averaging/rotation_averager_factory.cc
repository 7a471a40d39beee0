#include "colmap_irav4/rotation_averaging/rotation_averager_factory.h"

#include <functional>

#include "colmap_irav4/rotation_averaging/spanning_tree.h"
#include "colmap_irav4/util/error.h"

namespace colmap_irav4 {
namespace {

using Factory = std::function<std::unique_ptr<RotationAverager>(
    const RotationAveragerOptions&)>;

// Adding a method is one line here.
const std::vector<std::pair<std::string, Factory>>& Methods() {
  static const std::vector<std::pair<std::string, Factory>> methods = {
      {"irav4",
       [](const RotationAveragerOptions& o) {
         Irav4Options irav4 = o.irav4;
         irav4.log_progress = irav4.log_progress || o.log_progress;
         return std::make_unique<Irav4>(irav4);
       }},
      // IRAv4 exactly as the paper describes it (final_refinement none,
      // whatever --RotationAveraging.final_refinement says), to compare.
      {"irav4_paper",
       [](const RotationAveragerOptions& o) {
         Irav4Options irav4 = o.irav4;
         irav4.final_refinement = Irav4FinalRefinement::kNone;
         irav4.log_progress = irav4.log_progress || o.log_progress;
         return std::make_unique<Irav4>(irav4);
       }},
      {"ira",
       [](const RotationAveragerOptions& o) {
         IraOptions ira;
         ira.engine = o.irav4.engine;
         ira.progress = o.log_progress;
         return std::make_unique<Ira>(ira);
       }},
      {"l1_irls",
       [](const RotationAveragerOptions& o) {
         L1IrlsOptions l1_irls = o.irav4.refinement;
         l1_irls.log_progress = l1_irls.log_progress || o.log_progress;
         return std::make_unique<L1IrlsAverager>(l1_irls);
       }},
      {"spanning_tree",
       [](const RotationAveragerOptions&) {
         return std::make_unique<SpanningTreeAverager>();
       }},
  };
  return methods;
}

}  // namespace

void RotationAveragerOptions::Check() const { irav4.Check(); }

std::vector<std::string> RotationAveragerMethods() {
  std::vector<std::string> names;
  for (const auto& [name, factory] : Methods()) names.push_back(name);
  return names;
}

std::string RotationAveragerMethodList() {
  std::string list;
  for (const std::string& name : RotationAveragerMethods()) {
    list += (list.empty() ? "" : ", ") + name;
  }
  return list;
}

std::unique_ptr<RotationAverager> CreateRotationAverager(
    const std::string& method, const RotationAveragerOptions& options) {
  options.Check();
  for (const auto& [name, factory] : Methods()) {
    if (name == method) return factory(options);
  }
  throw InputError("--method", "unknown method '" + method + "' (one of " +
                                   RotationAveragerMethodList() + ")");
}

}  // namespace colmap_irav4
