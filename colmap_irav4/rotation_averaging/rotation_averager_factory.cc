#include "colmap_irav4/rotation_averaging/rotation_averager_factory.h"

#include <functional>

#include "colmap_irav4/rotation_averaging/spanning_tree.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/option_manager.h"

namespace colmap_irav4 {
namespace {

using Factory = std::function<std::unique_ptr<RotationAverager>(
    const RotationAveragerOptions&)>;

// Adding a method is one line here.
const std::vector<std::pair<std::string, Factory>>& Methods() {
  static const std::vector<std::pair<std::string, Factory>> methods = {
      {"l1_irls",
       [](const RotationAveragerOptions& o) {
         L1IrlsOptions l1_irls = o.l1_irls;
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

void RotationAveragerOptions::Check() const { l1_irls.Check(); }

void AddRotationAveragerOptions(OptionManager* options,
                                RotationAveragerOptions* o) {
  const std::string p = "RotationAveraging.";
  L1IrlsOptions* l1 = &o->l1_irls;
  options->Add(p + "l1_max_iterations", &l1->l1_max_iterations,
               "L1-IRLS: relinearised L1 steps");
  options->Add(p + "l1_step_tolerance_deg", &l1->l1_step_tolerance_deg,
               "L1-IRLS: L1 stops below this mean step (deg)");
  options->Add(p + "l1_epsilon_deg", &l1->l1_epsilon_deg,
               "L1-IRLS: residual floor of the L1 weights (deg)");
  options->Add(p + "irls_max_iterations", &l1->irls_max_iterations,
               "L1-IRLS: Geman-McClure IRLS iterations");
  options->Add(p + "irls_step_tolerance_deg", &l1->irls_step_tolerance_deg,
               "L1-IRLS: IRLS stops below this mean step (deg)");
  options->Add(p + "gm_sigma_deg", &l1->gm_sigma_deg,
               "L1-IRLS: Geman-McClure scale (deg)");
  options->Add(p + "linear_solver", &l1->linear_solver,
               "L1-IRLS: auto, cholesky or cg");
  options->Add(p + "max_vertices_for_cholesky", &l1->max_vertices_for_cholesky,
               "L1-IRLS: auto uses Cholesky up to this many cameras");
}

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
