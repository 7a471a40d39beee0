#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "colmap_irav4/rotation_averaging/cluster_alignment.h"
#include "colmap_irav4/rotation_averaging/community_detection.h"
#include "colmap_irav4/rotation_averaging/incremental_engine.h"
#include "colmap_irav4/rotation_averaging/l1_irls.h"
#include "colmap_irav4/rotation_averaging/rotation_graph.h"

namespace colmap_irav4 {

// How the global alignment reference is built.
enum class ReferenceMethod {
  kIrav4,      // task-specific CDS: the engine grown until dominating
  kGreedyCds,  // Guha-Khuller greedy CDS (WCDS-style), estimated by engine
  kRandomCds,  // union of random CDSs (IRAv3+-style), estimated by engine
};
// irav4, greedy_cds, random_cds.
template <>
const EnumNames<ReferenceMethod>& NamesOf<ReferenceMethod>();

// IRAv4's ending after its final optimisation (Irav4Options::
// final_refinement): none, irls, l1_irls, guarded.
enum class Irav4FinalRefinement { kNone, kIrls, kL1Irls, kGuarded };
template <>
const EnumNames<Irav4FinalRefinement>& NamesOf<Irav4FinalRefinement>();

struct Irav4Options {
  // Engine parameters (theta = outlier threshold, 5% global growth ratio),
  // shared by the reference, the clusters and the final optimisation; in
  // RotationAveragerOptions also the ira method's.
  IncrementalOptions engine;
  // Community detection for the cluster seeds.
  CommunityDetectionOptions communities;
  // IRAv3's potential cluster and vertex pre-selection: a cluster may take
  // the cameras of its own community, and boundary cameras whose edge weight
  // into its community is at least their weight into their own; clusters
  // compete by reward per edge into their potential cluster, not raw sums
  // (raw sums let the largest cluster take every camera: Madrid 3/380/11).
  // A fallback pass lets any adjacent cluster take what remains.
  bool preselect_clusters = true;
  // A cluster stops competing at this size until the fallback pass; 0 = no
  // cap.
  int max_cluster_size = 0;
  // After the alignment to the reference: check it by the consensus of all
  // edges between each pair of clusters and correct the clusters that
  // follow a wrong part of the reference (CheckAlignmentByClusterConsensus,
  // a relation overruled only by at least consensus_min_support agreeing
  // edges, kept only if it adds inlier edges).
  bool consensus_check = true;
  int consensus_min_support = 2;
  // irav4 (the paper), greedy_cds or random_cds (baselines).
  ReferenceMethod reference_method = ReferenceMethod::kIrav4;
  // Greedy CDS: count neighbours by inlier count instead of one each.
  bool weighted_greedy_cds = false;
  // Random CDS reference: how many random CDSs are united.
  int num_random_cds = 3;
  // Seed of everything random (only the random CDS reference draws).
  int seed = 0;
  // Rounds of the final global optimisation (each re-selects the inlier
  // edges of the whole graph within theta, then optimises Eq. 12).
  int num_final_rounds = 1;
  // After the final optimisation: none (the paper: truncated least squares
  // on the edges within theta), irls (L1-IRLS's Geman-McClure IRLS stage
  // over ALL edges between estimated vertices, from IRAv4's rotations),
  // l1_irls (L1-IRLS's L1 stage then its IRLS stage, from IRAv4's
  // rotations) or guarded (l1_irls, kept only if it lowers the
  // Geman-McClure cost over all edges below that of IRAv4's own rotations,
  // else irls: the global L1 stage may not move a correct IRAv4 solution
  // into the basin of consistent structured outliers). Default guarded: the
  // L1 stage brings IRAv4's median error to L1-IRLS's on both protocols, at
  // the cost of one O(E) evaluation
  // (docs/notes/2026-12-01-rotation-averaging.md).
  Irav4FinalRefinement final_refinement = Irav4FinalRefinement::kGuarded;
  // With a final refinement: after it, vertices whose
  // rotation agrees (within reseed_threshold_deg) with fewer than
  // reseed_support_fraction of their edges' chained predictions R_mp R_m
  // (Eq. 5) are re-initialised from their best-supported pre-computation
  // (Eq. 6-8 with this threshold) if it has more support than the current
  // rotation, and the refinement runs again. Catches vertices placed through
  // outlier edges, which a local refinement cannot bring back.
  bool reseed_vertices = true;
  double reseed_threshold_deg = 15.0;
  double reseed_support_fraction = 0.5;
  // Parameters of the refinement (l1_*, irls_*, gm_sigma_deg, linear
  // solver); in RotationAveragerOptions also the l1_irls method's.
  L1IrlsOptions refinement;
  // Log a line per stage and every 10% of the on-the-fly clustering.
  bool log_progress = false;

  void Check() const;  // throws InputError naming the option
};

// A reference: the selected vertices and their rotations (one entry per
// graph vertex, meaningful where `selected`).
struct AlignmentReference {
  std::vector<int> vertices;
  std::vector<bool> selected;
  std::vector<Eigen::Matrix3d> rotations;
  bool is_cds = false;  // connected and dominating on the graph
};

// Builds the reference with `method` on a connected graph. Empty vertices
// when no triplet passes the chaining check.
AlignmentReference BuildAlignmentReference(const RotationGraph& graph,
                                           const Irav4Options& options,
                                           ReferenceMethod method);

// IRAv4's re-seeding step (Irav4Options::reseed_vertices, reseed_*): every
// estimated vertex agreeing with fewer than reseed_support_fraction of its
// estimated neighbours' predictions R_mp R_m is set to its best-supported
// prediction if that has more support. Vertex order, each vertex seeing the
// previous ones' new rotations. Returns how many vertices changed.
int ReseedBadlySupportedVertices(const RotationGraph& graph,
                                 const Irav4Options& options,
                                 const std::vector<bool>& estimated,
                                 std::vector<Eigen::Matrix3d>* rotations);

// IRAv4's last resort for the vertices of a cluster that aligned to nothing
// (so that no camera is lost): every unestimated vertex with an estimated
// neighbour is placed at its best-supported prediction R_mp R_m (Eq. 5-8
// with `theta_deg`), in rounds of ascending vertex index (a round sees only
// the previous rounds' placements), until none can be placed. Returns how
// many were placed; on a connected graph with one estimated vertex, all.
int PlaceRemainingVertices(const RotationGraph& graph, double theta_deg,
                           std::vector<bool>* estimated,
                           std::vector<Eigen::Matrix3d>* rotations);

// What the last Estimate did, for reports and benchmarks.
struct Irav4Report {
  int num_vertices = 0;  // of the largest connected component
  int num_communities = 0;
  int num_clusters = 0;             // communities that produced a seed
  std::vector<int> cluster_sizes;   // after on-the-fly clustering
  int num_fallback_vertices = 0;    // affiliated by the fallback pass
  int num_failed_alignments = 0;    // clusters aligned to nothing
  int num_individually_placed = 0;  // vertices placed one by one instead
  ClusterConsensusCheck consensus;  // consensus_check
  int n_ref = 0;
  AlignmentReference reference;  // indices of the input graph
  int num_vertex_guided_alignments = 0;
  int num_final_inlier_edges = 0;
  int num_refinement_iterations = 0;  // final_refinement irls
  int num_reseeded_vertices = 0;      // reseed_vertices
  bool refinement_used_l1 = false;    // the kept refinement ran L1
};

// IRAv4 (the paper's section 4 with DESIGN.md's completions): communities ->
// cluster seeds -> on-the-fly clustering with local rotation averaging ->
// task-specific CDS reference -> common-vertex-guided alignment -> global
// alignment and optimisation over the inlier edges. Works on the largest
// connected component; other vertices are reported as not estimated.
class Irav4 : public RotationAverager {
 public:
  explicit Irav4(const Irav4Options& options = Irav4Options());
  std::string Name() const override { return "irav4"; }
  RotationAveragingResult Estimate(const RotationGraph& graph) override;
  const Irav4Report& LastReport() const { return report_; }

 private:
  // Estimate's steps, in order (3, the reference, is
  // BuildAlignmentReference); each fills its part of report_.
  struct Clusters;
  // 1. Communities (Eq. 1-4 inside each), one seed triplet each (or one
  // from the whole graph), and each cluster's potential vertices (IRAv3's
  // pre-selection). False when nothing could seed.
  bool SeedClusters(const RotationGraph& graph, int num_threads, Clusters* run);
  // 2. On-the-fly clustering: the best (vertex, cluster) pair over all
  // clusters joins, by normalised reward (a cluster's best candidate is
  // cached until it grows or loses it); a fallback pass lets every cluster
  // take any adjacent vertex no pre-selected pair reached. Returns the
  // seconds it took.
  double GrowClusters(int num_threads, Clusters* run);
  // 4. Common-vertex-guided alignment of each cluster to the reference (a
  // second round against the clusters aligned so far); what still fails is
  // placed vertex by vertex. Releases the clusters' engines.
  void AlignClusters(const RotationGraph& graph,
                     const AlignmentReference& reference, Clusters* run,
                     std::vector<Eigen::Matrix3d>* rotations,
                     std::vector<bool>* estimated);
  // 5. The final optimisation over the inlier edges of the whole graph
  // (Eq. 11-12), num_final_rounds times.
  void OptimizeOverInlierEdges(const RotationGraph& graph,
                               const std::vector<int>& estimated_vertices,
                               std::vector<Eigen::Matrix3d>* rotations);
  // 6. final_refinement over all edges (`root` held), then re-seeding.
  void RefineOverAllEdges(const RotationGraph& graph,
                          const std::vector<bool>& estimated, int root,
                          std::vector<Eigen::Matrix3d>* rotations);

  Irav4Options options_;
  Irav4Report report_;
};

}  // namespace colmap_irav4
