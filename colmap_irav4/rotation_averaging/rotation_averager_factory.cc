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
      {"irav4",
       [](const RotationAveragerOptions& o) {
         Irav4Options irav4 = o.irav4;
         irav4.engine = o.ira.engine;  // one set of engine options
         irav4.refinement = o.l1_irls;  // one set of IRLS options
         irav4.log_progress = irav4.log_progress || o.log_progress;
         return std::make_unique<Irav4>(irav4);
       }},
      // IRAv4 exactly as the paper describes it (final_refinement none,
      // whatever --RotationAveraging.final_refinement says), to compare.
      {"irav4_paper",
       [](const RotationAveragerOptions& o) {
         Irav4Options irav4 = o.irav4;
         irav4.engine = o.ira.engine;
         irav4.refinement = o.l1_irls;
         irav4.final_refinement = "none";
         irav4.log_progress = irav4.log_progress || o.log_progress;
         return std::make_unique<Irav4>(irav4);
       }},
      {"ira",
       [](const RotationAveragerOptions& o) {
         IraOptions ira = o.ira;
         ira.progress = ira.progress || o.log_progress;
         return std::make_unique<Ira>(ira);
       }},
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

void RotationAveragerOptions::Check() const {
  ira.Check();
  Irav4Options irav4_with_engine = irav4;
  irav4_with_engine.engine = ira.engine;
  irav4_with_engine.refinement = l1_irls;
  irav4_with_engine.Check();
  l1_irls.Check();
}

void AddRotationAveragerOptions(OptionManager* options,
                                RotationAveragerOptions* o) {
  const std::string p = "RotationAveraging.";
  // The incremental engine (IRA and the methods built on it).
  IncrementalOptions* engine = &o->ira.engine;
  options->Add(p + "theta_deg", &engine->theta_deg,
               "IRA: outlier threshold theta (deg)");
  options->Add(p + "global_growth_ratio", &engine->global_growth_ratio,
               "IRA: global optimisation each time the set grows by this");
  options->Add(p + "max_num_iterations", &engine->max_num_iterations,
               "IRA: Ceres iterations of a global optimisation");
  options->Add(p + "max_num_local_iterations",
               &engine->max_num_local_iterations,
               "IRA: Ceres iterations of a local optimisation");
  options->Add(p + "function_tolerance", &engine->function_tolerance,
               "IRA: Ceres function tolerance of the global problems");
  options->Add(p + "max_seed_triplets", &engine->max_seed_triplets,
               "IRA: seed triangles optimised (0 = all)");
  options->Add(p + "max_precomputations", &engine->max_precomputations,
               "IRA: pre-computations evaluated per recomputation (0 = all)");
  options->Add(p + "max_direct_solver_vertices",
               &engine->max_direct_solver_vertices,
               "IRA (use_ceres): sparse Cholesky up to this many cameras, "
               "CG above");
  options->Add(p + "num_threads", &engine->num_threads,
               "IRA: Ceres threads (with use_ceres)");
  options->Add(p + "use_ceres", &engine->use_ceres,
               "IRA: Ceres for Eq. 3/10/12 instead of Gauss-Newton on the "
               "sparse Laplacian (the previous, slower engine)");
  options->Add(p + "intermediate_global_iterations",
               &engine->intermediate_global_iterations,
               "IRA: Gauss-Newton steps of an intermediate global "
               "optimisation (the final ones converge)");
  AddIrav4Options(options, &o->irav4);
  L1IrlsOptions* l1 = &o->l1_irls;
  options->Add(p + "l1_max_iterations", &l1->l1_max_iterations,
               "L1-IRLS: relinearised L1 steps");
  options->Add(p + "l1_step_tolerance_deg", &l1->l1_step_tolerance_deg,
               "L1-IRLS: L1 stops below this mean step (deg)");
  options->Add(p + "l1_epsilon_deg", &l1->l1_epsilon_deg,
               "L1-IRLS: residual floor of the L1 weights (deg)");
  options->Add(p + "irls_max_iterations", &l1->irls_max_iterations,
               "L1-IRLS (and IRAv4's irls refinement): Geman-McClure IRLS "
               "iterations");
  options->Add(p + "irls_step_tolerance_deg", &l1->irls_step_tolerance_deg,
               "L1-IRLS: IRLS stops below this mean step (deg)");
  options->Add(p + "gm_sigma_deg", &l1->gm_sigma_deg,
               "L1-IRLS (and IRAv4's irls refinement): Geman-McClure scale "
               "(deg)");
  options->Add(p + "linear_solver", &l1->linear_solver,
               "L1-IRLS: auto, cholesky or cg");
  options->Add(p + "max_cholesky_flops", &l1->max_cholesky_flops,
               "L1-IRLS: auto uses Cholesky up to this factorisation cost");
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
