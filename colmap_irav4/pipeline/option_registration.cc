#include "colmap_irav4/pipeline/option_registration.h"

#include <sstream>

namespace colmap_irav4 {

void AddPosePriorOptions(OptionManager* manager, GlobalMapperOptions* options) {
  manager->Add("Mapper.use_pose_priors", &options->use_pose_priors,
               "use pose priors (GPS positions, gravity) when there are any: "
               "the database's (COLMAP >= 3.10 pose_priors table; 3.8/3.9 "
               "images.prior_t*, EXIF GPS) or --Mapper.pose_prior_path's; "
               "models with 3+ position priors are written in their frame "
               "(metres; WGS84 as east-north-up, origin in prior_frame.txt)");
  manager->Add("Mapper.pose_prior_path", &options->pose_prior_path,
               "text file of priors instead of the database's: IMAGE_NAME X "
               "Y Z [GX GY GZ] per line (COLMAP model_aligner's "
               "--ref_images_path format; G: gravity, down in the camera)");
  manager->Add("Mapper.pose_prior_wgs84", &options->pose_prior_wgs84,
               "pose_prior_path's X Y Z are latitude, longitude (deg), "
               "altitude (m)");
  manager->Add("Mapper.prior_position_std", &options->pose_priors.position_std,
               "standard deviation (m) of a position prior stored without a "
               "covariance");
  manager->Add("Mapper.prior_gravity_std",
               &options->pose_priors.gravity_std_deg,
               "standard deviation of a gravity prior (deg)");
  manager->Add("Mapper.prior_quadratic_std",
               &options->pose_priors.quadratic_std,
               "prior residuals up to this many standard deviations weigh as "
               "least squares, beyond it the Cauchy tail of prior_loss_scale");
  manager->Add("Mapper.prior_loss_scale", &options->pose_priors.loss_scale,
               "Cauchy loss scale of prior residuals beyond "
               "prior_quadratic_std (standard deviations)");
  manager->Add("Mapper.prior_gate_std", &options->pose_priors.gate_std,
               "bundle adjustment leaves out priors whose residual exceeds "
               "this many standard deviations (times their median spread "
               "where wider) once the model is in their frame (0: never)");
  manager->Add("Mapper.prior_min_num_positions",
               &options->pose_priors.min_num_positions,
               "fewest position priors that place a model in their frame");
}

void AddFocalCalibrationOptions(OptionManager* manager,
                                FocalCalibrationOptions* options) {
  manager->Add("ViewGraph.calibrate_focal", &options->calibrate_focal,
               "self-calibrate the focal length of cameras without a prior "
               "focal from the pairs' fundamental matrices");
  manager->Add("ViewGraph.calibration_min_focal_ratio",
               &options->min_focal_ratio,
               "lower end of the focal search, times the current focal");
  manager->Add("ViewGraph.calibration_max_focal_ratio",
               &options->max_focal_ratio,
               "upper end of the focal search, times the current focal");
  manager->Add("ViewGraph.calibration_min_num_pairs", &options->min_num_pairs,
               "a camera is calibrated from at least this many pairs");
  manager->Add("ViewGraph.calibration_loss_scale", &options->loss_scale,
               "Cauchy scale of the per-pair singular value cost");
  manager->Add("ViewGraph.calibration_max_agreeing_cost",
               &options->max_agreeing_cost,
               "a pair agrees with a focal if its cost there is below this");
  manager->Add("ViewGraph.calibration_prior_max_ratio",
               &options->prior_max_ratio,
               "above 1, cameras with a prior focal are calibrated too, within "
               "this factor of the prior (1: priors fixed)");
  manager->Add("ViewGraph.calibration_num_sweeps", &options->num_sweeps,
               "coordinate-descent sweeps over several cameras");
  manager->Add("ViewGraph.calibration_min_cost_increase",
               &options->min_cost_increase,
               "the cost at 1.25x / 1/1.25x the focal must exceed the minimum "
               "by this factor, otherwise the focal is kept");
}

void AddViewGraphOptions(OptionManager* manager,
                         ViewGraphBuilderOptions* options,
                         const std::string& min_num_inliers_flag,
                         bool with_threads_and_components) {
  manager->Add(min_num_inliers_flag, &options->min_num_inliers,
               "minimum inlier matches of an image pair");
  manager->Add("ViewGraph.min_inlier_ratio", &options->min_inlier_ratio,
               "minimum inliers / raw matches (where raw matches are stored)");
  manager->Add("ViewGraph.drop_configs", &options->drop_configs,
               "comma-separated two-view configurations to drop");
  if (with_threads_and_components) {
    manager->Add("ViewGraph.keep_largest_component",
                 &options->keep_largest_component,
                 "keep only the largest connected component");
    manager->Add("ViewGraph.num_threads", &options->num_threads,
                 "threads deriving the relative poses (-1: all cores)");
  }
  AddFocalCalibrationOptions(manager, &options->focal_calibration);
  RelativePoseOptions& rp = options->relative_pose;
  manager->Add("RelativePose.max_error_px", &rp.max_error_px,
               "epipolar error threshold of a supporting match (pixels)");
  manager->Add("RelativePose.retry_max_error_px", &rp.retry_max_error_px,
               "score once more within this threshold (pixels) a pair no "
               "pose supports with 5 matches (0: drop it)");
  manager->Add("RelativePose.refine", &rp.refine,
               "refine each pose on its inliers (robust Sampson error)");
  manager->Add("RelativePose.refine_loss_scale_px", &rp.refine_loss_scale_px,
               "Cauchy loss scale of the refinement (pixels)");
  manager->Add("RelativePose.refine_max_num_iterations",
               &rp.refine_max_num_iterations, "refinement iterations");
  manager->Add("RelativePose.refine_max_num_matches",
               &rp.refine_max_num_matches,
               "refine on at most this many matches (0: all)");
  manager->Add("RelativePose.min_stored_pose_support",
               &rp.min_stored_pose_support,
               "use a stored qvec/tvec if it has this fraction of the best "
               "derived pose's support");
  manager->Add("RelativePose.min_tri_angle_deg", &rp.min_tri_angle_deg,
               "median triangulation angle below which t is undefined (deg)");
  manager->Add("RelativePose.refine_max_rotation_std_deg",
               &rp.refine_max_rotation_std_deg,
               "refine a pose only where its inliers determine the rotation "
               "to this first-order standard deviation (deg)");
  manager->Add("RelativePose.skip_eight_point_min_support",
               &rp.skip_eight_point_min_support,
               "skip the eight-point re-estimate where a stored-geometry "
               "candidate is supported by this fraction of the inliers "
               "(above 1: never skip)");
}

void AddIrav4Options(OptionManager* manager, Irav4Options* options) {
  manager->Add("RotationAveraging.min_community_size",
               &options->communities.min_community_size,
               "smaller communities merge into their best-connected "
               "neighbour");
  manager->Add("RotationAveraging.max_community_size",
               &options->communities.max_community_size,
               "larger communities are split (0 = no limit)");
  manager->Add("RotationAveraging.preselect_clusters",
               &options->preselect_clusters,
               "IRAv4 clustering: a cluster takes only its community and "
               "boundary cameras tied to it at least as strongly as to "
               "their own (IRAv3's pre-selection); false = any camera");
  manager->Add("RotationAveraging.consensus_check", &options->consensus_check,
               "IRAv4: check the clusters' alignment to the reference by the "
               "consensus of all edges between each pair of clusters");
  manager->Add("RotationAveraging.consensus_min_support",
               &options->consensus_min_support,
               "IRAv4 consensus check: agreeing edges needed to overrule the "
               "reference's relation of two clusters");
  manager->Add("RotationAveraging.max_cluster_size", &options->max_cluster_size,
               "IRAv4 clustering: a cluster stops competing at this size "
               "until the fallback pass (0 = no cap)");
  manager->Add("RotationAveraging.reference_method", &options->reference_method,
               "alignment reference: " + EnumNameList<ReferenceMethod>());
  manager->Add("RotationAveraging.weighted_greedy_cds",
               &options->weighted_greedy_cds,
               "greedy CDS counts neighbours by inlier count");
  manager->Add("RotationAveraging.num_random_cds", &options->num_random_cds,
               "random CDSs united in the random_cds reference");
  manager->Add("RotationAveraging.num_final_rounds", &options->num_final_rounds,
               "rounds of inlier selection + global optimisation at the end");
  manager->Add("RotationAveraging.final_refinement", &options->final_refinement,
               "IRAv4 after its final optimisation: " +
                   EnumNameList<Irav4FinalRefinement>() +
                   " (guarded: l1_irls, L1 then Geman-McClure IRLS on all "
                   "edges, kept only if it lowers the Geman-McClure cost, "
                   "else irls, IRLS only; none: the paper)");
  manager->Add("RotationAveraging.reseed_vertices", &options->reseed_vertices,
               "IRAv4 refinement: re-initialise badly supported "
               "vertices from their best pre-computation, refine again");
  manager->Add("RotationAveraging.reseed_threshold_deg",
               &options->reseed_threshold_deg,
               "IRAv4 re-seeding: agreement threshold (deg)");
  manager->Add("RotationAveraging.reseed_support_fraction",
               &options->reseed_support_fraction,
               "IRAv4 re-seeding: vertices agreeing with fewer than this "
               "fraction of their edges are checked");
}

void AddRotationAveragerOptions(OptionManager* options,
                                RotationAveragerOptions* o,
                                bool with_threads_and_seed) {
  const std::string p = "RotationAveraging.";
  // The incremental engine (IRA and the methods built on it).
  IncrementalOptions* engine = &o->irav4.engine;
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
  if (with_threads_and_seed) {
    options->Add(p + "num_threads", &engine->num_threads,
                 "IRA/IRAv4: threads (IRAv4: cluster seeds, clusters beside "
                 "the reference, same result for any count; Ceres with "
                 "use_ceres)");
    options->Add(p + "seed", &o->irav4.seed,
                 "seed of the random choices (random_cds)");
  }
  options->Add(p + "use_ceres", &engine->use_ceres,
               "IRA: Ceres for Eq. 3/10/12 instead of Gauss-Newton on the "
               "sparse Laplacian (the previous, slower engine)");
  options->Add(p + "intermediate_global_iterations",
               &engine->intermediate_global_iterations,
               "IRA: Gauss-Newton steps of an intermediate global "
               "optimisation (the final ones converge)");
  AddIrav4Options(options, &o->irav4);
  L1IrlsOptions* l1 = &o->irav4.refinement;
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
               "L1-IRLS: " + EnumNameList<L1IrlsLinearSolver>());
  options->Add(p + "max_cholesky_flops", &l1->max_cholesky_flops,
               "L1-IRLS: auto uses Cholesky up to this factorisation cost");
}

void AddRotationFilterOptions(OptionManager* manager,
                              RotationFilterOptions* o) {
  manager->Add("RotationFilter.max_rotation_error_deg",
               &o->max_rotation_error_deg,
               "drop pairs disagreeing with the averaged rotations (deg)");
}

void AddTrackOptions(OptionManager* manager, TrackBuilderOptions* o) {
  manager->Add("Tracks.min_track_length", &o->min_track_length,
               "shorter tracks are dropped");
  manager->Add("Tracks.max_track_length", &o->max_track_length,
               "longer tracks are dropped");
  manager->Add("Tracks.max_duplicate_distance", &o->max_duplicate_distance,
               "two observations of a track in one image closer than this "
               "(px) are merged, farther: the track is dropped");
}

void AddGlobalPositioningOptions(OptionManager* manager,
                                 GlobalPositionerOptions* o) {
  GlobalPositionerOptions& gp = *o;
  manager->Add("GlobalPositioning.min_track_length", &gp.min_track_length,
               "tracks positioned (shorter: retriangulated later)");
  manager->Add("GlobalPositioning.loss_function", &gp.loss_function,
               EnumNameList<LossFunctionType>());
  manager->Add("GlobalPositioning.loss_scale", &gp.loss_scale,
               "robust loss scale");
  manager->Add("GlobalPositioning.max_angular_error_deg",
               &gp.max_angular_error_deg,
               "observations disagreeing more are unlinked (deg)");
  manager->Add("GlobalPositioning.linear_solver", &gp.linear_solver,
               EnumNameList<PositioningLinearSolver>());
  manager->Add("GlobalPositioning.iterative_schur_min_num_images",
               &gp.iterative_schur_min_num_images,
               "linear_solver auto: iterative_schur from this many images "
               "(sparse_schur from 50)");
  manager->Add("GlobalPositioning.iterative_schur_dense_min_num_images",
               &gp.iterative_schur_dense_min_num_images,
               "... or from this many when the reduced camera system is "
               "dense (iterative_schur_min_density)");
  manager->Add("GlobalPositioning.iterative_schur_min_density",
               &gp.iterative_schur_min_density,
               "... at least this fraction of the image pairs sharing a "
               "point (above 1: never)");
  manager->Add("GlobalPositioning.iterative_schur_min_pairs_per_image",
               &gp.iterative_schur_min_pairs_per_image,
               "... or each image sharing points with this many others on "
               "average");
  manager->Add(
      "GlobalPositioning.iterative_schur_min_products_per_observation",
      &gp.iterative_schur_min_products_per_observation,
      "... or at any size from this many camera-block products an "
      "observation in forming the reduced system (long tracks; 0: off)");
  AddSolverOptions(manager, "GlobalPositioning.", &gp.solver);
}

void AddTranslationAveragingOptions(OptionManager* manager,
                                    TranslationAveragingOptions* o) {
  TranslationAveragingOptions& ta = *o;
  manager->Add("TranslationAveraging.cost", &ta.cost,
               EnumNameList<TranslationAveragingCost>());
  manager->Add("TranslationAveraging.loss_function", &ta.loss_function,
               EnumNameList<LossFunctionType>());
  manager->Add("TranslationAveraging.loss_scale", &ta.loss_scale,
               "robust loss scale");
  AddSolverOptions(manager, "TranslationAveraging.", &ta.solver);
}

void AddSolverOptions(OptionManager* manager, const std::string& prefix,
                      SolverOptions* options) {
  ceres::Solver::Options& ceres = options->ceres;
  manager->Add(prefix + "max_num_iterations", &ceres.max_num_iterations,
               "Ceres iterations per solve");
  manager->Add(prefix + "function_tolerance", &ceres.function_tolerance,
               "Ceres: stop when the cost changes by less than this fraction");
  manager->Add(prefix + "gradient_tolerance", &ceres.gradient_tolerance,
               "Ceres: stop when the gradient's max-norm falls below this "
               "(relative)");
  manager->Add(prefix + "parameter_tolerance", &ceres.parameter_tolerance,
               "Ceres: stop when a step changes the parameters by less than "
               "this fraction");
  manager->Add(prefix + "initial_trust_region_radius",
               &ceres.initial_trust_region_radius,
               "Levenberg-Marquardt's initial trust region radius (large: "
               "solves reach the optimum's flat directions)");
  manager->Add(prefix + "print_progress", &ceres.minimizer_progress_to_stdout,
               "print Ceres' iterations and full report");
}

void AddTriangulationOptions(OptionManager* manager, TriangulationOptions* o) {
  manager->Add("Triangulation.max_reproj_error", &o->max_reproj_error,
               "inlier threshold of (re)triangulation (px)");
  manager->Add("Triangulation.min_tri_angle", &o->min_tri_angle,
               "minimum triangulation angle (deg)");
  manager->Add("Triangulation.ignore_two_view_tracks",
               &o->ignore_two_view_tracks,
               "do not (re)triangulate tracks of two observations (COLMAP's "
               "ignore_two_view_tracks)");
  manager->Add("Triangulation.complete_tracks", &o->complete_tracks,
               "retriangulation first adds a track's free observations to "
               "the point the track already has when they reproject onto it "
               "(track completion), then triangulates the rest");
}

void AddTwoViewCheckOptions(OptionManager* manager, TwoViewCheckOptions* o) {
  manager->Add("TwoViewCheck.enabled", &o->enabled,
               "after retriangulation, check the two-view points against "
               "poses adjusted without them (repeated structure)");
  manager->Add("TwoViewCheck.min_multi_view_observations",
               &o->min_multi_view_observations,
               "only two-view points between images with at least this many "
               "observations of points seen 3 times or more are checked");
  manager->Add("TwoViewCheck.withhold_poorly_constrained",
               &o->withhold_poorly_constrained,
               "two-view points of images their multi-view points hold "
               "poorly (PoseConstraint.*) do not come back");
  manager->Add("TwoViewCheck.max_reproj_error", &o->max_reproj_error,
               "a checked two-view point is kept when both its observations "
               "are within this reprojection error (px, in noise units with "
               "BundleAdjustment.filter_by_keypoint_noise)");
}

void AddPointMergingOptions(OptionManager* manager, PointMergingOptions* o) {
  manager->Add("PointMerging.enabled", &o->enabled,
               "after retriangulation and the two-view check, merge the "
               "points of different tracks that are one 3D point (one "
               "position reprojects onto all their observations)");
  manager->Add("PointMerging.search_radius", &o->search_radius,
               "a candidate: an observation of another point this close "
               "(px) to the point's projection");
  manager->Add("PointMerging.max_reproj_error", &o->max_reproj_error,
               "the merged point must reproject within this onto every "
               "observation (px, in noise units with "
               "BundleAdjustment.filter_by_keypoint_noise)");
  manager->Add("PointMerging.max_cost_increase", &o->max_cost_increase,
               "and its summed squared reprojection error may exceed the two "
               "points' own by at most this many noise variances "
               "(chi-square, 3 degrees of freedom; 0: no such test)");
  manager->Add("PointMerging.max_passes", &o->max_passes,
               "passes over the points (merged points searched again)");
}

void AddPoseConstraintOptions(OptionManager* manager,
                              PoseConstraintOptions* o) {
  manager->Add("PoseConstraint.min_track_length", &o->min_track_length,
               "an image's pose uncertainty is that of a resection on its "
               "points seen in at least this many images");
  manager->Add("PoseConstraint.max_relative_uncertainty",
               &o->max_relative_uncertainty,
               "images whose rotation uncertainty exceeds this multiple of "
               "the model's median are reported as poorly constrained");
}

void AddBundleAdjustmentOptions(OptionManager* manager,
                                BundleAdjustmentOptions* o) {
  BundleAdjustmentOptions& ba = *o;
  manager->Add("BundleAdjustment.loss_function", &ba.loss_function,
               EnumNameList<BundleAdjustmentLoss>());
  manager->Add("BundleAdjustment.loss_scale", &ba.loss_scale,
               "robust loss scale (px)");
  manager->Add("BundleAdjustment.num_rounds", &ba.num_rounds,
               "solve + filter rounds per bundle adjustment");
  manager->Add("BundleAdjustment.max_reproj_error", &ba.max_reproj_error,
               "observations over this error are removed between rounds (px)");
  manager->Add("BundleAdjustment.focal_prior_std", &ba.focal_prior_std,
               "prior on the focal length of cameras with a focal prior at "
               "its value when an adjustment starts, relative std (0: none)");
  manager->Add("BundleAdjustment.guessed_focal_prior_std",
               &ba.guessed_focal_prior_std,
               "the same for cameras without a focal prior (0: none)");
  manager->Add("BundleAdjustment.min_num_intrinsics_observations",
               &ba.min_num_intrinsics_observations,
               "a camera whose images have fewer observations in a bundle "
               "adjustment has its intrinsics held (0: none)");
  manager->Add("BundleAdjustment.min_num_image_observations",
               &ba.min_num_image_observations,
               "an image with fewer observations is left out of a bundle "
               "adjustment (its pose held, its observations weightless; the "
               "filters after it judge them)");
  manager->Add("BundleAdjustment.linear_solver", &ba.linear_solver,
               EnumNameList<BundleAdjustmentLinearSolver>());
  manager->Add("BundleAdjustment.solver_backend", &ba.solver_backend,
               EnumNameList<BundleAdjustmentSolverBackend>());
  manager->Add("BundleAdjustment.schur_min_num_observations",
               &ba.schur_min_num_observations,
               "solver_backend auto: the Schur solver from this many "
               "observations");
  manager->Add("BundleAdjustment.schur_linear_solver", &ba.schur_linear_solver,
               EnumNameList<SchurLinearSolver>());
  manager->Add("BundleAdjustment.schur_max_factor_mib",
               &ba.schur_max_factor_mib,
               "Schur solver, schur_linear_solver auto: iterative when the "
               "Cholesky factor would take more MiB");
  manager->Add("BundleAdjustment.schur_max_factor_gflops",
               &ba.schur_max_factor_gflops,
               "Schur solver, schur_linear_solver auto: iterative when a "
               "factorisation would take more GFlop (one an iteration)");
  manager->Add("BundleAdjustment.schur_max_cell_table_mib",
               &ba.schur_max_cell_table_mib,
               "Schur solver: its per-point cell tables take at most this "
               "many MiB (the points beyond search their cells at each "
               "iteration)");
  manager->Add("BundleAdjustment.schur_max_jacobian_store_mib",
               &ba.schur_max_jacobian_store_mib,
               "Schur solver: the observations' Jacobians of an elimination "
               "are kept in at most this many MiB for its back-substitution "
               "and the tries after a rejected step (the same result to the "
               "bit; 0: none kept)");
  manager->Add("BundleAdjustment.schur_locality_order_min_mib",
               &ba.schur_locality_order_min_mib,
               "Schur solver: from this many MiB of reduced system, the "
               "points are eliminated in an order that keeps their cells "
               "in the caches (the same solution up to rounding)");
  manager->Add("BundleAdjustment.schur_prefetch_updates_min_mib",
               &ba.schur_prefetch_updates_min_mib,
               "Schur solver: from this many MiB of reduced system, each "
               "point's updates of it are listed and their cells prefetched "
               "(the same result to the bit)");
  manager->Add("BundleAdjustment.schur_reuse_min_radius",
               &ba.schur_reuse_min_radius,
               "Schur solver: after a rejected step, while the trust region "
               "radius is at least this, the next try re-damps the cameras "
               "of the same reduced system instead of eliminating the "
               "points again (0: off)");
  manager->Add("BundleAdjustment.gauge_min_shared_points",
               &ba.gauge_min_shared_points,
               "parts of the model tied to the rest by fewer points than "
               "this hold a gauge of their own (their placement relative to "
               "the rest held; 1: only exact gauge freedoms; the rigidity "
               "check writes parts tied by fewer than 15 as separate models)");
  manager->Add("BundleAdjustment.last_gauge_min_shared_points",
               &ba.last_gauge_min_shared_points,
               "gauge_min_shared_points for the mapper's last adjustment "
               "only (0: gauge_min_shared_points)");
  manager->Add("BundleAdjustment.gauge_scale_farthest",
               &ba.gauge_scale_farthest,
               "the gauge's scale is held on the image farthest from the "
               "held first image (0: on the second image)");
  manager->Add("BundleAdjustment.schur_point_iterations",
               &ba.schur_point_iterations,
               "Schur solver: after each step every point takes up to this "
               "many Gauss-Newton steps of its own with the cameras held "
               "(embedded point iterations; 0: off)");
  manager->Add("BundleAdjustment.stall_num_iterations",
               &ba.stall_num_iterations,
               "the mapper's adjustments before the last stop once their "
               "last this many accepted steps together lowered the cost by "
               "less than stall_relative_decrease of it (0: off; the last "
               "adjustment always runs to its tolerances)");
  manager->Add("BundleAdjustment.stall_relative_decrease",
               &ba.stall_relative_decrease,
               "see stall_num_iterations (a fraction of the cost)");
  manager->Add("BundleAdjustment.stall_min_num_images",
               &ba.stall_min_num_images,
               "stall_num_iterations applies to adjustments of at least this "
               "many images (0: all)");
  manager->Add("BundleAdjustment.last_stall_num_iterations",
               &ba.last_stall_num_iterations,
               "the mapper's last adjustment stops once its last this many "
               "accepted steps together lowered the cost by less than "
               "last_stall_relative_decrease of it (0: off)");
  manager->Add("BundleAdjustment.last_stall_relative_decrease",
               &ba.last_stall_relative_decrease,
               "see last_stall_num_iterations (a fraction of the cost)");
  manager->Add("BundleAdjustment.schur_iterative_eta", &ba.schur_iterative_eta,
               "Schur solver, iterative: conjugate gradients stop at a "
               "residual of min(eta, sqrt(|b| / |b_0|)) |b|");
  manager->Add("BundleAdjustment.schur_iterative_model_tolerance",
               &ba.schur_iterative_model_tolerance,
               "Schur solver, iterative: conjugate gradients also stop once "
               "i (Q_i - Q_i-1) / Q_i is below this, Q_i the quadratic "
               "model's value (0: off), in models of at least "
               "schur_iterative_model_min_num_images images");
  manager->Add("BundleAdjustment.schur_iterative_model_min_num_images",
               &ba.schur_iterative_model_min_num_images,
               "see schur_iterative_model_tolerance");
  manager->Add("BundleAdjustment.schur_implicit_min_mib",
               &ba.schur_implicit_min_mib,
               "Schur solver, iterative: from this many MiB of reduced "
               "system, multiply by it without forming it, from every "
               "observation's Jacobians kept (implicit Schur complement; "
               "0: always)");
  manager->Add("BundleAdjustment.schur_implicit_single_precision",
               &ba.schur_implicit_single_precision,
               "Schur solver, implicit: the conjugate gradients multiply "
               "from a single-precision copy of the kept Jacobians (half "
               "the bytes read; accumulated in double)");
  manager->Add("BundleAdjustment.schur_implicit_avx2", &ba.schur_implicit_avx2,
               "Schur solver, implicit in single precision: multiply with "
               "AVX2 and FMA when the processor has them (0: the portable "
               "code, the same bits on every x86-64 processor)");
  manager->Add("BundleAdjustment.schur_max_cg_iterations",
               &ba.schur_max_cg_iterations,
               "Schur solver, iterative: at most this many conjugate gradient "
               "iterations per step");
  manager->Add("BundleAdjustment.schur_coarse_cluster_size",
               &ba.schur_coarse_cluster_size,
               "Schur solver, iterative: the preconditioner's coarse level, "
               "images in clusters of about this many (those sharing the "
               "most points) moving as rigid bodies with a scale, solved "
               "exactly besides each image's block (0: Schur-Jacobi alone)");
  manager->Add("BundleAdjustment.schur_coarse_max_clusters",
               &ba.schur_coarse_max_clusters,
               "Schur solver, iterative: at most this many coarse clusters "
               "(a dense system of 7 rows a cluster; larger clusters past "
               "it)");
  manager->Add("BundleAdjustment.rejected_start_trust_region_radius",
               &ba.rejected_start_trust_region_radius,
               "Schur solver: after a rejected first step, the trust "
               "region cuts down to this radius are made without trying "
               "their steps (0: every cut tried, as Ceres)");
  manager->Add("BundleAdjustment.iterative_schur_min_num_images",
               &ba.iterative_schur_min_num_images,
               "linear_solver auto: iterative_schur from this many images "
               "(sparse_schur from 50)");
  manager->Add("BundleAdjustment.iterative_schur_min_density",
               &ba.iterative_schur_min_density,
               "linear_solver auto: iterative_schur when this fraction of "
               "the image pairs share a point (above 1: never)");
  manager->Add("BundleAdjustment.parameterize_centers",
               &ba.parameterize_centers,
               "poses as rotation and projection centre (0: rotation and "
               "translation)");
  manager->Add("BundleAdjustment.weight_by_keypoint_scale",
               &ba.weight_by_keypoint_scale,
               "weigh each observation by the reprojection noise estimated "
               "for keypoints of its scale (keypoints stored with a shape)");
  manager->Add("BundleAdjustment.filter_by_keypoint_noise",
               &ba.filter_by_keypoint_noise,
               "with weight_by_keypoint_scale, the reprojection filters' and "
               "the triangulation's thresholds scale with the noise of each "
               "keypoint's scale");
  AddSolverOptions(manager, "BundleAdjustment.", &ba.solver);
}

void AddFilterOptions(OptionManager* manager, FilterOptions* o) {
  manager->Add("Filter.max_reproj_error", &o->max_reproj_error,
               "observations over this reprojection error are removed (px)");
  manager->Add("Filter.min_tri_angle", &o->min_tri_angle,
               "points with a smaller largest triangulation angle are removed "
               "(deg)");
  manager->Add("Filter.min_num_observations_per_image",
               &o->min_num_observations_per_image,
               "images left with fewer observations after a filtering are "
               "removed from the model (1: those no point is seen in)");
}

void AddNormalizationOptions(OptionManager* manager, NormalizationOptions* o) {
  manager->Add("Normalization.extent", &o->extent,
               "extent of the central part of the normalised scene");
}

void AddComparerOptions(OptionManager* manager,
                        SimilarityRansacOptions* options) {
  manager->Add("Comparer.max_relative_error", &options->max_relative_error,
               "RANSAC inlier threshold, fraction of the reference's median "
               "centre distance to its centroid");
}

void AddFoldResolutionOptions(OptionManager* manager,
                              FoldResolutionOptions* options) {
  FoldResolutionOptions& o = *options;
  FoldDetectionOptions& d = o.detection;
  manager->Add("Fold.detect", &o.detect,
               "test every model for a fold (symmetric scenes)");
  manager->Add("Fold.resolve", &o.resolve,
               "resolve a detected fold: remove the suspect pairs and map "
               "again, else split the model at the weakest cut");
  manager->Add("Fold.max_iterations", &o.max_iterations,
               "rounds of removing suspect pairs before a split");
  manager->Add("Fold.settle_with_priors", &o.settle_with_priors,
               "map a clean model in the priors' frame again across candidate "
               "fold cuts; keep what the position priors agree with clearly "
               "better");
  manager->Add("Fold.max_fold_score", &d.max_fold_score,
               "models with a larger fraction of predicted overlapping pairs "
               "without matches are folded");
  manager->Add("Fold.min_missing_pairs", &d.min_missing_pairs,
               "... and at least this many such pairs");
  manager->Add("Fold.max_view_angle_deg", &d.max_view_angle_deg,
               "two cameras are expected to match a point only from rays "
               "closer than this (deg)");
  manager->Add("Fold.min_overlap_fraction", &d.min_overlap_fraction,
               "a pair is predicted to overlap when each image expects this "
               "fraction of the other's points");
  manager->Add("Fold.weak_pair_ratio", &d.weak_pair_ratio,
               "a consistent pair with fewer inliers per predicted co-visible "
               "point than this fraction of the typical is weak (0: off)");
  manager->Add("Fold.weak_pair_rate_model", &d.weak_pair_rate_model,
               "judge a pair's ratio against its images' own match rates and "
               "its view angle (0: one typical ratio for the model)");
  manager->Add("Fold.within_observed_depth", &d.within_observed_depth,
               "expect a camera to match only points no farther from it than "
               "the farthest model point it observes");
  manager->Add("Fold.within_rigid_parts", &d.within_rigid_parts,
               "predict overlap only between images of one rigid part of the "
               "model (parts joined through single images have a free scale)");
  manager->Add("Fold.cut_parts", &d.cut_parts,
               "the parts a folded model's cut divides, each on its own (the "
               "whole model, its rigid parts, or the components of the pairs "
               "it agrees with): " +
                   EnumNameList<FoldCutParts>());
  manager->Add("Fold.cut_keep_unfolded_parts", &d.cut_keep_unfolded_parts,
               "with --Fold.cut_parts model: the parts of the pairs the model "
               "agrees with whose own cut finds no fold are not divided by "
               "the model's cut (when another part's cut finds one)");
  manager->Add("Fold.cut_min_pair_triangles", &d.cut_min_pair_triangles,
               "with --Fold.cut_parts agreeing: a pair joins its images' part "
               "only in this many triangles of agreeing pairs");
  manager->Add("Fold.cut_max_power_iterations", &d.cut_max_power_iterations,
               "the fold cut's eigenvector: power iterations until it "
               "converges, at most this many (300: exactly 300, the cut "
               "before 2026-12-07)");
  manager->Add("Fold.cut_fold_rotation_pairs", &d.cut_fold_rotation_pairs,
               "the cut also separates the images of the verified pairs the "
               "model contradicts by the fold's own rotation (the most "
               "common discrepancy of the contradicted pairs)");
  manager->Add("Fold.cut_min_fold_rotation_pairs",
               &d.cut_min_fold_rotation_pairs,
               "with --Fold.cut_fold_rotation_pairs 1: the pairs that must "
               "share a discrepancy for it to be taken as the fold's rotation");
  manager->Add("Fold.cut_min_fold_rotation_deg", &d.cut_min_fold_rotation_deg,
               "with --Fold.cut_fold_rotation_pairs 1: only pairs contradicted "
               "by at least this many degrees may share the fold's rotation");
  manager->Add("Fold.cut_min_fold_rotation_share",
               &d.cut_min_fold_rotation_share,
               "with --Fold.cut_fold_rotation_pairs 1: the fraction of those "
               "pairs that must share the fold's rotation");
  manager->Add("Fold.missing_pair_inlier_factor", &d.missing_pair_inlier_factor,
               "a predicted pair without matches is missing only where the "
               "rate model expects this many times min_num_matches inliers");
  manager->Add("Fold.min_weak_cut_pairs", &d.min_weak_cut_pairs,
               "a cut with at least this many weak pairs across it...");
  manager->Add("Fold.min_weak_cut_fraction", &d.min_weak_cut_fraction,
               "... making this fraction of the consistent pairs across it "
               "is a fold");
  manager->Add("Fold.min_weak_alone_pairs", &d.min_weak_alone_pairs,
               "an image with this many consistent pairs, all weak, and this "
               "many contradicted ones may be turned alone");
}

void AddPartMergeOptions(OptionManager* manager, PartMergeOptions* o) {
  manager->Add("PartMerge.merge", &o->merge,
               "join the rigid parts of a split model through the pairs "
               "across them that the parts' 3D points confirm, and map the "
               "component again (kept only when less split, not folded and "
               "no fewer images)");
  manager->Add("PartMerge.max_ray_error_deg", &o->max_ray_error_deg,
               "a point is met when the placed image's ray reaches it within "
               "this angle (deg)");
  manager->Add("PartMerge.min_met_points", &o->min_met_points,
               "a pair across parts is confirmed with at least this many met "
               "points...");
  manager->Add("PartMerge.min_met_fraction", &o->min_met_fraction,
               "... making at least this fraction of its points");
  manager->Add("PartMerge.min_join_pairs", &o->min_join_pairs,
               "two parts are joined only by at least this many confirmed "
               "pairs one similarity between them explains (a false pair "
               "fitting a ghost pose is confirmed alone)");
  manager->Add("PartMerge.max_join_spread_deg", &o->max_join_spread_deg,
               "confirmed pairs agree when one similarity between the "
               "parts explains them: their rotations between the parts "
               "within this angle (deg)...");
  manager->Add("PartMerge.max_join_center_error", &o->max_join_center_error,
               "... and each placed image's centre within this fraction of "
               "its distance to its met points");
  manager->Add("PartMerge.max_rotation_error_deg", &o->max_rotation_error_deg,
               "pairs across joined parts contradicting the join by more "
               "than this are removed before mapping again (deg)");
  manager->Add("PartMerge.check_rigid_joins", &o->check_rigid_joins,
               "map again only when the model's rigidity check, with the "
               "joins' observations added, finds it less split (skips "
               "articulation joins)");
  manager->Add("PartMerge.max_join_turn_deg", &o->max_join_turn_deg,
               "map again only when the remaining pairs' rotation averaging "
               "keeps the joined parts within this angle of the join (deg)");
  manager->Add("PartMerge.remove_refuted", &o->remove_refuted,
               "also remove the pairs across parts (joined or not) that the "
               "parts' points refute before mapping again");
  manager->Add("PartMerge.max_rounds", &o->max_rounds,
               "rounds of joining and mapping again while the model stays "
               "split");
  manager->Add("PartMerge.min_image_fraction", &o->min_image_fraction,
               "the re-mapped model must write this fraction of the split "
               "model's images");
  manager->Add("PartMerge.max_ransac_samples", &o->max_ransac_samples,
               "2-point samples for an image's centre (every set when "
               "fewer)");
}

void AddGlobalMapperOptions(OptionManager* manager,
                            GlobalMapperOptions* options) {
  GlobalMapperOptions& o = *options;
  manager->Add("Mapper.min_model_size", &o.min_model_size,
               "components with fewer images give no model");
  manager->Add("Mapper.rotation_method", &o.rotation_method,
               "rotation averaging: " + RotationAveragerMethodList());
  manager->Add("Mapper.positioning_method", &o.positioning_method,
               EnumNameList<PositioningMethod>());
  // COLMAP's names for the bundle adjustment's intrinsics flags.
  BundleAdjustmentOptions& ba = o.bundle_adjustment;
  manager->Add("Mapper.ba_refine_focal_length", &ba.refine_focal_length,
               "refine focal lengths in bundle adjustment");
  manager->Add("Mapper.ba_refine_principal_point", &ba.refine_principal_point,
               "refine principal points in bundle adjustment");
  manager->Add("Mapper.ba_refine_extra_params", &ba.refine_extra_params,
               "refine distortion parameters in bundle adjustment");
  // COLMAP's names for the limits of the filter of bogus cameras.
  FilterOptions& filtering = o.filtering;
  manager->Add("Mapper.min_focal_length_ratio",
               &filtering.min_focal_length_ratio,
               "after each bundle adjustment, images whose camera's focal "
               "length is under this fraction of the larger image side are "
               "removed");
  manager->Add("Mapper.max_focal_length_ratio",
               &filtering.max_focal_length_ratio,
               "... or over this multiple of it");
  manager->Add("Mapper.max_extra_param", &filtering.max_extra_param,
               "... or whose camera has a distortion parameter larger in "
               "absolute value (or its principal point outside the image)");
  manager->Add("Mapper.reset_invalid_cameras", &o.reset_invalid_cameras,
               "start cameras with invalid intrinsics from a default focal "
               "(refined) instead of failing");
  manager->Add("Mapper.recalibrated_second_pass", &o.recalibrated_second_pass,
               "map twice: the second time with the relative poses derived "
               "again with the cameras (focal, distortion) the first "
               "mapping refined");
  manager->Add("Mapper.num_threads", &o.num_threads,
               "threads of every stage (-1: all cores)");
  manager->Add("Mapper.seed", &o.seed,
               "seed of every random choice (random initialisation of "
               "positioning, RANSAC triangulation, random CDSs): same seed, "
               "same model");
  manager->Add("Mapper.progress", &o.progress,
               "progress bars: 1 on, 0 off, -1 on a terminal or >= 100 "
               "images");
  manager->Add("Mapper.num_ba_iterations", &o.num_ba_iterations,
               "rounds of bundle adjustment + filtering");
  PositioningTrackSelectionOptions& selection = o.positioning_tracks;
  manager->Add("Mapper.positioning_tracks_per_image",
               &selection.tracks_per_image,
               "global positioning uses the longest tracks until each image "
               "has this many observations (0: all tracks)");
  manager->Add("Mapper.positioning_grid_size", &selection.grid_size,
               "... spread over each image: a grid of this many cells per "
               "side, each cell's share of the quota first (1: the longest "
               "tracks only)");
  manager->Add("Mapper.max_num_tracks", &o.max_num_tracks,
               "at most this many tracks (points): positioning's first, then "
               "the longest; a warning says how many were dropped (0: no "
               "cap)");
  manager->Add("Mapper.weak_part_min_shared_points",
               &o.weak_part_min_shared_points,
               "before each bundle adjustment, images in no rigid part of "
               "min_model_size images at ties of this many points leave the "
               "model and the parts' ties are cut (0: off)");
  manager->Add("Mapper.weak_image_min_pair_triangles",
               &o.weak_image_min_pair_triangles,
               "before each bundle adjustment, images in fewer triangles of "
               "the model's pairs leave the model (0: off)");
  manager->Add("Mapper.positioning_tracks_per_pair", &selection.tracks_per_pair,
               "... and every view-graph pair keeps this many of its tracks "
               "(0: no pair quota)");
  manager->Add("Mapper.positioning_quota_pairs_per_image",
               &selection.quota_pairs_per_image,
               "... the pairs of a maximum spanning forest by inliers and "
               "each image's this many strongest pairs (-1: every pair)");
  manager->Add("Mapper.positioning_max_observations_per_image",
               &selection.max_observations_per_image,
               "a selected track gives positioning only its observations in "
               "images with fewer than this many yet (and those that selected "
               "it, at least 3); the others are added back after it (0: all)");
  manager->Add("Mapper.positioning_max_observations_min_num_images",
               &selection.max_observations_min_num_images,
               "... from this many images in the tracks (0: always)");
  manager->Add("Mapper.skip_rotation_filter", &o.skip_rotation_filter,
               "skip the rotation-consistency filter");
  manager->Add("Mapper.skip_bundle_adjustment", &o.skip_bundle_adjustment,
               "skip bundle adjustment");
  manager->Add("Mapper.skip_retriangulation", &o.skip_retriangulation,
               "skip retriangulation");
  manager->Add("Mapper.skip_filtering", &o.skip_filtering,
               "skip the final filtering");
  manager->Add("Mapper.skip_normalization", &o.skip_normalization,
               "skip normalising the scene's centre and scale");
  AddPosePriorOptions(manager, options);
  manager->Add("Mapper.color_image_downscale", &o.color_image_downscale,
               "images are decoded at 1/1, 1/2, 1/4 or 1/8 of their size for "
               "the point colours");
  manager->Add("Mapper.skip_colors", &o.skip_colors,
               "do not read images for point colours (grey)");

  // The stages' structs, each under its own prefix; the view graph's
  // min_num_inliers under COLMAP's --Mapper.min_num_matches, its threads are
  // --Mapper.num_threads.
  AddViewGraphOptions(manager, &o.view_graph, "Mapper.min_num_matches",
                      /*with_threads_and_components=*/false);
  AddRotationAveragerOptions(manager, &o.rotation_averaging,
                             /*with_threads_and_seed=*/false);
  AddRotationFilterOptions(manager, &o.rotation_filter);
  AddTrackOptions(manager, &o.tracks);
  AddGlobalPositioningOptions(manager, &o.global_positioning);
  AddTranslationAveragingOptions(manager, &o.translation_averaging);
  AddTriangulationOptions(manager, &o.triangulation);
  AddTwoViewCheckOptions(manager, &o.two_view_check);
  AddPointMergingOptions(manager, &o.point_merging);
  AddBundleAdjustmentOptions(manager, &o.bundle_adjustment);
  AddFilterOptions(manager, &o.filtering);
  AddNormalizationOptions(manager, &o.normalization);
  AddPoseConstraintOptions(manager, &o.pose_constraint);
  AddFoldResolutionOptions(manager, &o.fold);
  AddPartMergeOptions(manager, &o.part_merge);
}

const std::vector<Colmap4Flag>& Colmap4GlobalMapperFlags() {
  constexpr int kUnsupported = -1;
  static const std::vector<Colmap4Flag> flags = {
      // The command's general options (COLMAP's BaseOptionManager).
      {"project_path", "", kUnsupported, "give the options as flags"},
      {"default_random_seed", "", kUnsupported, "see --Mapper.seed"},
      {"log_target", "", kUnsupported, "logs go to stderr"},
      {"log_path", "", kUnsupported, "logs go to stderr"},
      {"log_level", "", kUnsupported, "logs go to stderr"},
      {"log_severity", "", kUnsupported, "logs go to stderr"},
      {"log_color", "", kUnsupported, "logs go to stderr"},
      // --GlobalMapper.*
      {"GlobalMapper.image_list_path", "", kUnsupported,
       "every image of the database is used"},
      {"GlobalMapper.min_num_matches", "Mapper.min_num_matches", 0,
       "same default, 15"},
      {"GlobalMapper.ignore_watermarks", "", 1,
       "watermark pairs are dropped; --ViewGraph.drop_configs lists the "
       "dropped configurations"},
      {"GlobalMapper.num_threads", "Mapper.num_threads", 0, ""},
      {"GlobalMapper.random_seed", "Mapper.seed", 0,
       "COLMAP's -1 (a seed from the clock) is not supported: ours defaults "
       "to 0, every run reproducible"},
      {"GlobalMapper.decompose_relative_pose", "", 1,
       "relative poses are always derived from the two-view geometries"},
      {"GlobalMapper.ba_num_iterations", "Mapper.num_ba_iterations", 0,
       "COLMAP 3, ours 2"},
      {"GlobalMapper.skip_rotation_averaging", "", 0,
       "nothing downstream exists without it"},
      {"GlobalMapper.skip_track_establishment", "", 0,
       "nothing downstream exists without it"},
      {"GlobalMapper.skip_global_positioning", "", 0,
       "nothing downstream exists without it"},
      {"GlobalMapper.skip_bundle_adjustment", "Mapper.skip_bundle_adjustment",
       0, ""},
      {"GlobalMapper.skip_retriangulation", "Mapper.skip_retriangulation", 0,
       ""},
      {"GlobalMapper.track_intra_image_consistency_threshold",
       "Tracks.max_duplicate_distance", 0, "pixels; COLMAP 10, ours 4"},
      {"GlobalMapper.track_required_tracks_per_view", "", kUnsupported,
       "--Mapper.positioning_tracks_per_image selects the tracks of global "
       "positioning only"},
      {"GlobalMapper.track_min_num_views_per_track", "Tracks.min_track_length",
       0, "COLMAP 3, ours 2"},
      {"GlobalMapper.keep_max_num_tracks", "Mapper.max_num_tracks", 0,
       "no cap: COLMAP's default 2147483647, ours 0"},
      {"GlobalMapper.gp_use_gpu", "", 0, "CPU only"},
      {"GlobalMapper.gp_gpu_index", "", kUnsupported, "CPU only"},
      {"GlobalMapper.gp_optimize_positions", "", 1,
       "global positioning always solves for the positions"},
      {"GlobalMapper.gp_optimize_points", "", 1,
       "global positioning always solves for the points"},
      {"GlobalMapper.gp_optimize_scales", "", 1,
       "global positioning always solves for the scales"},
      {"GlobalMapper.gp_loss_function_scale", "GlobalPositioning.loss_scale", 0,
       "same default, 0.1 (ours: of a Cauchy loss)"},
      {"GlobalMapper.gp_max_num_iterations",
       "GlobalPositioning.max_num_iterations", 0, ""},
      {"GlobalMapper.ba_refine_focal_length", "Mapper.ba_refine_focal_length",
       0, ""},
      {"GlobalMapper.ba_refine_principal_point",
       "Mapper.ba_refine_principal_point", 0, ""},
      {"GlobalMapper.ba_refine_extra_params", "Mapper.ba_refine_extra_params",
       0, ""},
      {"GlobalMapper.refine_sensor_from_rig", "", kUnsupported,
       "no camera rigs"},
      {"GlobalMapper.ba_refine_rig_from_world", "", 1,
       "bundle adjustment always refines the poses"},
      {"GlobalMapper.ba_refine_points3D", "", 1,
       "bundle adjustment always refines the points"},
      {"GlobalMapper.ba_min_track_length", "", kUnsupported,
       "bundle adjustment uses every point"},
      {"GlobalMapper.ba_ceres_use_gpu", "", 0, "CPU only"},
      {"GlobalMapper.ba_ceres_gpu_index", "", kUnsupported, "CPU only"},
      {"GlobalMapper.ba_ceres_loss_function_scale",
       "BundleAdjustment.loss_scale", 0,
       "pixels; ours applies it with --BundleAdjustment.loss_function huber "
       "or cauchy (default trivial)"},
      {"GlobalMapper.ba_ceres_max_num_iterations",
       "BundleAdjustment.max_num_iterations", 0, ""},
      {"GlobalMapper.ba_skip_fixed_rotation_stage", "", 1,
       "ours has no fixed-rotation stage"},
      {"GlobalMapper.ba_skip_joint_optimization_stage", "", 0,
       "ours has no fixed-rotation stage"},
      {"GlobalMapper.tri_complete_max_reproj_error", "", kUnsupported,
       "one threshold: --Triangulation.max_reproj_error"},
      {"GlobalMapper.tri_merge_max_reproj_error", "", kUnsupported,
       "one threshold: --Triangulation.max_reproj_error"},
      {"GlobalMapper.tri_min_angle", "Triangulation.min_tri_angle", 0,
       "degrees; COLMAP 1, ours 1.5"},
      {"GlobalMapper.ra_use_gravity", "", 0, "no gravity priors"},
      {"GlobalMapper.ra_use_stratified", "", kUnsupported,
       "see --Mapper.rotation_method"},
      {"GlobalMapper.ra_max_rotation_error_deg",
       "RotationFilter.max_rotation_error_deg", 0, ""},
      {"GlobalMapper.max_angular_reproj_error_deg",
       "GlobalPositioning.max_angular_error_deg", 0,
       "degrees; COLMAP 1, ours 5"},
      {"GlobalMapper.max_normalized_reproj_error", "", kUnsupported,
       "ours in pixels: --BundleAdjustment.max_reproj_error, "
       "--Filter.max_reproj_error"},
      {"GlobalMapper.min_tri_angle_deg", "Filter.min_tri_angle", 0,
       "degrees; COLMAP 1, ours 1.5"},
  };
  return flags;
}

void AddColmap4GlobalMapperFlags(OptionManager* manager) {
  for (const Colmap4Flag& flag : Colmap4GlobalMapperFlags()) {
    if (!flag.ours.empty()) {
      manager->AddAlias(flag.colmap4, flag.ours);
    } else if (flag.fixed >= 0) {
      manager->AddFixed(flag.colmap4, flag.fixed == 1, flag.note);
    } else {
      manager->AddUnsupported(flag.colmap4, flag.note);
    }
  }
}

std::string GlobalMapperOptionsIni(const GlobalMapperOptions& options) {
  GlobalMapperOptions registered = options;
  OptionManager manager("mapper");
  AddGlobalMapperOptions(&manager, &registered);
  std::ostringstream ini;
  manager.Write(ini);
  return ini.str();
}

}  // namespace colmap_irav4
