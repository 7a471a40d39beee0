#include "colmap_irav4/geometry/two_view_geometry.h"

#include <algorithm>
#include <cmath>
#include <functional>

#include <Eigen/Dense>
#include <Eigen/SVD>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/scene/camera_models.h"
#include "colmap_irav4/util/error.h"

namespace colmap_irav4 {
namespace {

const char* const kConfigNames[] = {
    "UNDEFINED", "DEGENERATE",          "CALIBRATED", "UNCALIBRATED", "PLANAR",
    "PANORAMIC", "PLANAR_OR_PANORAMIC", "WATERMARK",  "MULTIPLE"};
constexpr int kNumConfigs = 9;

Eigen::Matrix3d CrossMatrix(const Eigen::Vector3d& v) {
  Eigen::Matrix3d M;
  M << 0, -v(2), v(1), v(2), 0, -v(0), -v(1), v(0), 0;
  return M;
}

// A less preferred candidate source must have a truncated cost below this
// fraction of the preferred one's to win.
constexpr double kCostTolerance = 1.1;
// Fraction of the matches within the threshold of H above which the scene
// is treated as near-planar.
constexpr double kMinPlanarFraction = 0.5;
// A refined pose is kept unless it loses more than this fraction of the
// support (a refinement that drifts, e.g. to a planar twin, loses many).
constexpr double kMinRefinedSupport = 0.95;

bool IsZero(const Eigen::Matrix3d& M) { return M.cwiseAbs().maxCoeff() == 0; }

// Whether two non-zero matrices are equal up to a (signed) scale, to
// rounding.
bool SameUpToScale(const Eigen::Matrix3d& A, const Eigen::Matrix3d& B) {
  const Eigen::Matrix3d a = A / A.norm();
  const Eigen::Matrix3d b = B / B.norm();
  return std::min((a - b).norm(), (a + b).norm()) < 1e-9;
}

// A candidate cam2_from_cam1; pure_rotation candidates have no translation.
struct Candidate {
  RelativePoseSource source = RelativePoseSource::kNone;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  bool pure_rotation = false;
  // Truncated squared error (pixels^2) summed over the matches, and the
  // number of matches under the threshold and in front of both cameras.
  double cost = 0;
  int support = 0;
  // Set by Refine: the rotation's standard deviation at the start (deg) and
  // the number of passes over the matches.
  double rotation_std_deg = -1;
  int num_refine_passes = 0;
  // Consecutive candidates with the same group share one essential matrix up
  // to sign (the four decompositions of an E; a homography's (R, t) and
  // (R, -t)): ScoreGroup computes their epipolar errors once.
  int group = -1;
  // Per match: whether it supports the candidate (set with cost, support).
  std::vector<char> supporting;
};

// Normalised correspondences of the inlier matches.
struct Correspondences {
  std::vector<Eigen::Vector2d> x1;
  std::vector<Eigen::Vector2d> x2;
};

// Per-match error (pixels^2) and whether the match supports the candidate.
bool MatchError(const Candidate& candidate, const Eigen::Matrix3d& E,
                const Eigen::Vector2d& x1, const Eigen::Vector2d& x2,
                double focal, double max_error_sq, double* error_sq) {
  if (candidate.pure_rotation) {
    const Eigen::Vector3d p = candidate.R * x1.homogeneous();
    if (p.z() <= 0) return false;
    *error_sq = (p.hnormalized() - x2).squaredNorm() * focal * focal;
    return *error_sq < max_error_sq;
  }
  *error_sq = SampsonErrorSquared(E, x1, x2) * focal * focal;
  if (*error_sq >= max_error_sq) return false;
  double depth1 = 0, depth2 = 0;
  TriangulateDepths(candidate.R, candidate.t, x1, x2, &depth1, &depth2);
  // Far beyond 1000 baselines the depth's sign is noise (as COLMAP's check).
  return depth1 > 0 && depth2 > 0 && depth1 < 1000 && depth2 < 1000;
}

void Score(const Correspondences& corrs, double focal, double max_error_px,
           Candidate* candidate) {
  const double max_error_sq = max_error_px * max_error_px;
  const Eigen::Matrix3d E = EssentialFromPose(candidate->R, candidate->t);
  candidate->cost = 0;
  candidate->support = 0;
  candidate->supporting.assign(corrs.x1.size(), 0);
  for (size_t i = 0; i < corrs.x1.size(); ++i) {
    double error_sq = max_error_sq;
    if (MatchError(*candidate, E, corrs.x1[i], corrs.x2[i], focal, max_error_sq,
                   &error_sq)) {
      candidate->cost += error_sq;
      ++candidate->support;
      candidate->supporting[i] = 1;
    } else {
      candidate->cost += max_error_sq;
    }
  }
}

// Scores candidates [begin, end) of one group at once: [t]x R is the same
// essential matrix up to sign for each of them (the Sampson error ignores
// sign and scale), so a match's error is computed once, and its depths once
// per distinct rotation (negating t negates both depths exactly). The costs
// are those Score gives each candidate alone.
void ScoreGroup(const Correspondences& corrs, double focal, double max_error_px,
                Candidate* begin, Candidate* end) {
  const int num = static_cast<int>(end - begin);
  if (num == 1 || begin->pure_rotation) {
    for (Candidate* candidate = begin; candidate != end; ++candidate) {
      Score(corrs, focal, max_error_px, candidate);
    }
    return;
  }
  constexpr int kMaxGroup = 4;
  CHECK_LE(num, kMaxGroup);
  // twin[k]: an earlier candidate with the same R and the opposite t, or -1.
  int twin[kMaxGroup];
  for (int k = 0; k < num; ++k) {
    twin[k] = -1;
    CHECK(!begin[k].pure_rotation);
    for (int j = 0; j < k && twin[k] < 0; ++j) {
      if (twin[j] < 0 && begin[j].R == begin[k].R &&
          begin[j].t == -begin[k].t) {
        twin[k] = j;
      }
    }
    begin[k].cost = 0;
    begin[k].support = 0;
    begin[k].supporting.assign(corrs.x1.size(), 0);
  }
  const double max_error_sq = max_error_px * max_error_px;
  const double focal_sq = focal * focal;
  const Eigen::Matrix3d E = EssentialFromPose(begin->R, begin->t);
  for (size_t i = 0; i < corrs.x1.size(); ++i) {
    const double error_sq =
        SampsonErrorSquared(E, corrs.x1[i], corrs.x2[i]) * focal_sq;
    if (!(error_sq < max_error_sq)) {
      for (int k = 0; k < num; ++k) begin[k].cost += max_error_sq;
      continue;
    }
    double depth1[kMaxGroup], depth2[kMaxGroup];
    for (int k = 0; k < num; ++k) {
      if (twin[k] >= 0) {
        depth1[k] = -depth1[twin[k]];
        depth2[k] = -depth2[twin[k]];
      } else {
        TriangulateDepths(begin[k].R, begin[k].t, corrs.x1[i], corrs.x2[i],
                          &depth1[k], &depth2[k]);
      }
      // As MatchError.
      if (depth1[k] > 0 && depth2[k] > 0 && depth1[k] < 1000 &&
          depth2[k] < 1000) {
        begin[k].cost += error_sq;
        ++begin[k].support;
        begin[k].supporting[i] = 1;
      } else {
        begin[k].cost += max_error_sq;
      }
    }
  }
}

void AddEssentialCandidates(const Eigen::Matrix3d& E, RelativePoseSource source,
                            int group, std::vector<Candidate>* candidates) {
  std::vector<Eigen::Matrix3d> Rs;
  std::vector<Eigen::Vector3d> ts;
  DecomposeEssentialMatrix(E, &Rs, &ts);
  for (size_t i = 0; i < Rs.size(); ++i) {
    Candidate candidate;
    candidate.source = source;
    candidate.R = Rs[i];
    candidate.t = ts[i];
    candidate.group = group;
    candidates->push_back(candidate);
  }
}

// Sum of the Cauchy costs b log(1 + s_i / b) with one log per block of
// eight matches (the log of the product) instead of one log1p per match:
// log1p took a fifth of the refinement's time. The rounding of 1 + s / b
// costs ~1e-16 b per match, far below the convergence test's 1e-6 of the
// total.
class CauchyCostSum {
 public:
  explicit CauchyCostSum(double b) : b_(b) {}
  void Add(double s) {
    const double term = 1.0 + s / b_;
    if (!(term < 1e30)) {  // huge or NaN: alone (NaN stays NaN)
      log_sum_ += std::log1p(s / b_);
      return;
    }
    product_ *= term;
    if (++count_ == 8) Flush();
  }
  double Total() {
    Flush();
    return b_ * log_sum_;
  }

 private:
  void Flush() {
    log_sum_ += std::log(product_);
    product_ = 1;
    count_ = 0;
  }
  const double b_;
  double log_sum_ = 0;
  double product_ = 1;
  int count_ = 0;
};

// The matches the refinement uses: those supporting the candidate, thinned
// evenly to at most max_num_matches (<= 0: all) to bound a pair's cost.
std::vector<size_t> SelectRefinementMatches(const Correspondences& corrs,
                                            const std::vector<char>& supporting,
                                            int max_num_matches) {
  std::vector<size_t> used;
  size_t num_supporting = 0;
  for (const char s : supporting) num_supporting += s;
  const double stride =
      max_num_matches > 0 &&
              num_supporting > static_cast<size_t>(max_num_matches)
          ? static_cast<double>(num_supporting) / max_num_matches
          : 1.0;
  double next_sample = 0;
  size_t rank = 0;  // index among the supporting matches
  for (size_t i = 0; i < corrs.x1.size(); ++i) {
    if (!supporting[i]) continue;
    if (static_cast<double>(rank++) < next_sample) continue;
    next_sample += stride;
    used.push_back(i);
  }
  return used;
}

// The refinement's robust cost (Cauchy: b log(1 + r^2 / b)) over the used
// matches, and optionally the normal equations at (R, t): the gradient
// J^T rho' r, and in JtJ the Gauss-Newton Hessian of the robust cost with
// each match's second-order term of the loss (Triggs et al.'s correction),
// clamped at zero where the loss bends down (r^2 > b). Iteratively
// reweighted least squares (rho' J^T J alone) over-estimates that Hessian
// for matches near the loss scale and converged linearly, halving the step
// each pass (8 passes per pair on the synthetic courtyards, 4 with the
// correction). JtJ_irls, when given, gets rho' J^T J: the information the
// rotation_std gate is defined on. Each evaluation counts one pass.
class RefinementCost {
 public:
  RefinementCost(const Correspondences& corrs, const std::vector<size_t>& used,
                 double focal, double b, bool pure_rotation, int* num_passes)
      : corrs_(corrs),
        used_(used),
        focal_(focal),
        b_(b),
        pure_rotation_(pure_rotation),
        num_passes_(num_passes) {}

  double Evaluate(const Eigen::Matrix3d& R, const Eigen::Vector3d& t,
                  Eigen::Matrix<double, 5, 5>* JtJ,
                  Eigen::Matrix<double, 5, 1>* Jtr,
                  Eigen::Matrix<double, 5, 5>* JtJ_irls = nullptr) const {
    ++*num_passes_;
    if (JtJ != nullptr) {
      JtJ->setZero();
      Jtr->setZero();
    }
    if (JtJ_irls != nullptr) JtJ_irls->setZero();
    return pure_rotation_ ? EvaluateRotation(R, JtJ, Jtr, JtJ_irls)
                          : EvaluateEssential(R, t, JtJ, Jtr, JtJ_irls);
  }

 private:
  // Transfer error of a pure rotation; parameters: the rotation (3).
  double EvaluateRotation(const Eigen::Matrix3d& R,
                          Eigen::Matrix<double, 5, 5>* JtJ,
                          Eigen::Matrix<double, 5, 1>* Jtr,
                          Eigen::Matrix<double, 5, 5>* JtJ_irls) const {
    CauchyCostSum cost(b_);
    for (const size_t i : used_) {
      const Eigen::Vector3d p = R * corrs_.x1[i].homogeneous();
      if (!(p.z() > 1e-12)) {
        cost.Add(1e6 * b_);  // behind: a large, finite cost
        continue;
      }
      const double inv_z = 1.0 / p.z();
      const Eigen::Vector2d r =
          focal_ *
          (Eigen::Vector2d(p.x() * inv_z, p.y() * inv_z) - corrs_.x2[i]);
      const double r2 = r.squaredNorm();
      cost.Add(r2);
      if (JtJ == nullptr) continue;
      const double weight = 1.0 / (1.0 + r2 / b_);
      Eigen::Matrix<double, 2, 3> dproj;
      dproj << inv_z, 0, -p.x() * inv_z * inv_z, 0, inv_z,
          -p.y() * inv_z * inv_z;
      // d(exp([w]x) p)/dw at 0 = -[p]x.
      const Eigen::Matrix<double, 2, 3> J = -focal_ * dproj * CrossMatrix(p);
      const Eigen::Matrix3d JtJ_i = J.transpose() * J;
      // The loss's Hessian in r: rho' (I - 2 rho' / b r r^T); along r its
      // eigenvalue rho' (1 - r^2/b) / (1 + r^2/b), clamped at zero.
      const Eigen::Vector3d Jr = J.transpose() * r;
      const double along_r =
          weight * std::max(0.0, (1 - r2 / b_) / (1 + r2 / b_));
      JtJ->topLeftCorner<3, 3>() += weight * JtJ_i;
      if (r2 > 0) {
        JtJ->topLeftCorner<3, 3>() +=
            (along_r - weight) / r2 * Jr * Jr.transpose();
      }
      if (JtJ_irls != nullptr) {
        JtJ_irls->topLeftCorner<3, 3>() += weight * JtJ_i;
      }
      Jtr->head<3>() += weight * Jr;
    }
    return cost.Total();
  }

  // Sampson error of the essential matrix of (R, t); parameters: the
  // rotation (3) and the translation on its tangent plane (2).
  double EvaluateEssential(const Eigen::Matrix3d& R, const Eigen::Vector3d& t,
                           Eigen::Matrix<double, 5, 5>* JtJ,
                           Eigen::Matrix<double, 5, 1>* Jtr,
                           Eigen::Matrix<double, 5, 5>* JtJ_irls) const {
    CauchyCostSum cost(b_);
    const Eigen::Matrix3d E = EssentialFromPose(R, t);
    // dE/dparam: rotation exp([w]x) R (3), translation on its tangent
    // plane (2).
    Eigen::Matrix<double, 9, 5> dE;
    Eigen::Vector3d b1 = t.unitOrthogonal();
    Eigen::Vector3d b2 = t.cross(b1);
    const Eigen::Matrix3d tx = CrossMatrix(t);
    for (int k = 0; k < 5; ++k) {
      Eigen::Matrix3d D;
      if (k < 3) {
        D = tx * CrossMatrix(Eigen::Vector3d::Unit(k)) * R;
      } else {
        D = CrossMatrix(k == 3 ? b1 : b2) * R;
      }
      dE.col(k) = Eigen::Map<const Eigen::Matrix<double, 9, 1>>(D.data());
    }
    for (const size_t i : used_) {
      const Eigen::Vector3d x1 = corrs_.x1[i].homogeneous();
      const Eigen::Vector3d x2 = corrs_.x2[i].homogeneous();
      const Eigen::Vector3d Ex1 = E * x1;
      const Eigen::Vector3d Etx2 = E.transpose() * x2;
      const double n = x2.dot(Ex1);
      const double d = Ex1(0) * Ex1(0) + Ex1(1) * Ex1(1) + Etx2(0) * Etx2(0) +
                       Etx2(1) * Etx2(1) + 1e-30;
      const double inv_sqrt_d = 1.0 / std::sqrt(d);
      const double r = focal_ * n * inv_sqrt_d;
      const double r2 = r * r;
      cost.Add(r2);
      if (JtJ == nullptr) continue;
      const double weight = 1.0 / (1.0 + r2 / b_);
      // dr/dE (column-major, as dE's rows): E(a, c) at a + 3 c.
      Eigen::Matrix<double, 9, 1> drdE;
      const double k_n = focal_ * inv_sqrt_d;
      const double k_d = -0.5 * focal_ * n * inv_sqrt_d / d;
      for (int c = 0; c < 3; ++c) {
        for (int a = 0; a < 3; ++a) {
          double dd = 0;
          if (a < 2) dd += 2 * Ex1(a) * x1(c);
          if (c < 2) dd += 2 * Etx2(c) * x2(a);
          drdE(a + 3 * c) = k_n * x2(a) * x1(c) + k_d * dd;
        }
      }
      const Eigen::Matrix<double, 5, 1> J = dE.transpose() * drdE;
      const Eigen::Matrix<double, 5, 5> JJt = J * J.transpose();
      // The loss's second derivative in r: rho' (1 - r^2/b) / (1 + r^2/b).
      const double hessian_weight =
          weight * std::max(0.0, (1 - r2 / b_) / (1 + r2 / b_));
      *JtJ += hessian_weight * JJt;
      if (JtJ_irls != nullptr) *JtJ_irls += weight * JJt;
      *Jtr += weight * r * J;
    }
    return cost.Total();
  }

  const Correspondences& corrs_;
  const std::vector<size_t>& used_;
  const double focal_;
  const double b_;
  const bool pure_rotation_;
  int* const num_passes_;
};

// The pose after a step: the rotation by exp([w]x), the translation (unless
// a pure rotation) along its tangent plane, renormalised.
void StepPose(const Eigen::Matrix3d& R, const Eigen::Vector3d& t,
              const Eigen::Matrix<double, 5, 1>& step, bool pure_rotation,
              Eigen::Matrix3d* R_new, Eigen::Vector3d* t_new) {
  *R_new = AngleAxisToRotation(step.head<3>()) * R;
  if (pure_rotation) {
    *t_new = t;
    return;
  }
  const Eigen::Vector3d b1 = t.unitOrthogonal();
  const Eigen::Vector3d b2 = t.cross(b1);
  *t_new = (t + step(3) * b1 + step(4) * b2).normalized();
}

// How well the inliers determine the rotation (deg): the largest standard
// deviation of the rotation (first-order covariance from the IRLS
// information at the start, the translation marginalised, noise estimated
// from the residuals); infinite where the information is singular.
double RotationStdDeg(double cost, const Eigen::Matrix<double, 5, 5>& JtJ_irls,
                      size_t num_used, int num_params) {
  // Cauchy IRLS residuals at the start: b (exp(cost_i / b) - 1) = r_i^2;
  // the weighted squared residual is approximated by the robust cost.
  const double sum_weighted_sq = cost;
  const double dof = std::max<double>(1.0, num_used - num_params);
  const double sigma_sq = std::max(sum_weighted_sq / dof, 1e-12);
  const Eigen::MatrixXd information =
      JtJ_irls.topLeftCorner(num_params, num_params) / sigma_sq;
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(information);
  double std_rad = std::numeric_limits<double>::infinity();
  if (eigen.info() == Eigen::Success && eigen.eigenvalues()(0) > 0) {
    const Eigen::MatrixXd covariance = information.inverse();
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> rotation_eigen(
        covariance.topLeftCorner<3, 3>());
    std_rad = std::sqrt(std::max(0.0, rotation_eigen.eigenvalues()(2)));
  }
  return RadToDeg(std_rad);
}

// Levenberg-Marquardt from (R, t), whose cost and normal equations are
// given; leaves the last accepted pose in (R, t).
void MinimizeRefinementCost(const RefinementCost& refinement_cost,
                            int max_num_iterations, int num_params,
                            bool pure_rotation, double cost,
                            Eigen::Matrix<double, 5, 5> JtJ,
                            Eigen::Matrix<double, 5, 1> Jtr,
                            Eigen::Matrix3d* R_out, Eigen::Vector3d* t_out) {
  Eigen::Matrix3d R = *R_out;
  Eigen::Vector3d t = *t_out;
  double lambda = 1e-4;
  for (int iteration = 0; iteration < max_num_iterations; ++iteration) {
    Eigen::Matrix<double, 5, 5> A = JtJ;
    for (int k = 0; k < num_params; ++k) A(k, k) += lambda * (1.0 + JtJ(k, k));
    Eigen::Matrix<double, 5, 1> step = Eigen::Matrix<double, 5, 1>::Zero();
    step.head(num_params) = A.topLeftCorner(num_params, num_params)
                                .ldlt()
                                .solve(-Jtr.head(num_params));
    if (!step.allFinite()) break;
    // The decrease the quadratic model (gradient 2 Jtr, Hessian 2 JtJ)
    // predicts for the step: where it is negligible by the convergence test
    // below, the step is taken without the pass over the matches that would
    // confirm it (a quarter of the passes on the synthetic courtyards; the
    // poses are those of the confirmed steps to 0.01 deg).
    const double predicted_decrease = -2 * Jtr.dot(step) - step.dot(JtJ * step);
    Eigen::Matrix3d R_new;
    Eigen::Vector3d t_new;
    StepPose(R, t, step, pure_rotation, &R_new, &t_new);
    if (predicted_decrease <= 1e-6 * cost) {
      R = R_new;
      t = t_new;
      break;
    }
    // The normal equations at the trial pose come with its cost: most
    // steps are accepted, so this saves a pass per iteration.
    Eigen::Matrix<double, 5, 5> JtJ_new;
    Eigen::Matrix<double, 5, 1> Jtr_new;
    const double new_cost =
        refinement_cost.Evaluate(R_new, t_new, &JtJ_new, &Jtr_new);
    if (new_cost < cost) {
      const double decrease = cost - new_cost;
      R = R_new;
      t = t_new;
      cost = new_cost;
      JtJ = JtJ_new;
      Jtr = Jtr_new;
      lambda = std::max(1e-10, lambda / 10);
      // Converged: the step changes the cost by a negligible fraction (the
      // Ceres default function tolerance) or the pose by a negligible angle.
      if (decrease <= 1e-6 * (cost + decrease) || step.norm() < 1e-10) break;
    } else {
      lambda *= 10;
      if (lambda > 1e10) break;
    }
  }
  *R_out = R;
  *t_out = t;
}

// Robust refinement of a candidate on the matches that support it:
// Levenberg-Marquardt on the Sampson error (or, for a pure rotation, the
// transfer error) in pixels under a Cauchy loss, with analytic Jacobians
// and the loss's curvature in the Hessian. The pose has 5 (3) degrees of
// freedom, so each iteration is one pass over the matches and a 5x5 solve:
// a general solver's per-residual bookkeeping and automatic differentiation
// took most of the view-graph stage (300-image synthetic scene: ~60% of it).
// Stops as soon as a step no longer lowers the cost noticeably, so a pose
// that already explains its inliers costs one or two passes.
void Refine(const Correspondences& corrs, const std::vector<char>& supporting,
            double focal, const RelativePoseOptions& options,
            Candidate* candidate) {
  const std::vector<size_t> used = SelectRefinementMatches(
      corrs, supporting, options.refine_max_num_matches);
  const bool pure_rotation = candidate->pure_rotation;
  if (used.size() < (pure_rotation ? 2u : 5u)) return;
  const double b = options.refine_loss_scale_px * options.refine_loss_scale_px;
  const int num_params = pure_rotation ? 3 : 5;
  const RefinementCost refinement_cost(corrs, used, focal, b, pure_rotation,
                                       &candidate->num_refine_passes);

  Eigen::Matrix3d R = candidate->R;
  Eigen::Vector3d t = candidate->t;
  Eigen::Matrix<double, 5, 5> JtJ, JtJ_irls;
  Eigen::Matrix<double, 5, 1> Jtr;
  const double cost = refinement_cost.Evaluate(R, t, &JtJ, &Jtr, &JtJ_irls);
  // Where the rotation is poorly determined the cost is flat along a valley
  // (a near-planar scene, a short baseline with few matches) and minimising
  // it fits the noise: on the 100-image synthetic courtyard every refined
  // pose more than 5 deg off (29 of 1,043) came from such a walk away from
  // an exact start.
  candidate->rotation_std_deg =
      RotationStdDeg(cost, JtJ_irls, used.size(), num_params);
  if (!(candidate->rotation_std_deg <= options.refine_max_rotation_std_deg)) {
    return;
  }
  MinimizeRefinementCost(refinement_cost, options.refine_max_num_iterations,
                         num_params, pure_rotation, cost, JtJ, Jtr, &R, &t);
  candidate->R = R;
  if (!pure_rotation) candidate->t = t;
}

double MedianTriAngleDeg(const Correspondences& corrs,
                         const std::vector<char>& supporting,
                         const Eigen::Matrix3d& R) {
  // The median of the cosines, descending, is the cosine of the median
  // angle (acos decreases strictly): one acos instead of one per match.
  std::vector<double> cosines;
  for (size_t i = 0; i < corrs.x1.size(); ++i) {
    if (!supporting[i]) continue;
    const Eigen::Vector3d ray1 = corrs.x1[i].homogeneous().normalized();
    const Eigen::Vector3d ray2 =
        (R.transpose() * corrs.x2[i].homogeneous()).normalized();
    cosines.push_back(std::clamp(ray1.dot(ray2), -1.0, 1.0));
  }
  if (cosines.empty()) return 0;
  std::nth_element(cosines.begin(), cosines.begin() + cosines.size() / 2,
                   cosines.end(), std::greater<double>());
  return RadToDeg(std::acos(cosines[cosines.size() / 2]));
}

}  // namespace

TwoViewGeometry TwoViewGeometry::Inverse() const {
  TwoViewGeometry inverse = *this;
  std::swap(inverse.image_id1, inverse.image_id2);
  for (FeatureMatch& match : inverse.inlier_matches) {
    std::swap(match.point2D_idx1, match.point2D_idx2);
  }
  inverse.F = F.transpose();
  inverse.E = E.transpose();
  if (!IsZero(H)) {
    Eigen::FullPivLU<Eigen::Matrix3d> lu(H);
    inverse.H = lu.isInvertible() ? Eigen::Matrix3d(lu.inverse())
                                  : Eigen::Matrix3d::Zero();
  }
  if (has_pose) {
    const Eigen::Matrix3d R = QuaternionToRotation(qvec);
    inverse.qvec = RotationToQuaternion(R.transpose());
    inverse.tvec = -(R.transpose() * tvec);
  }
  return inverse;
}

std::string TwoViewConfigName(int config) {
  if (config < 0 || config >= kNumConfigs) {
    return "UNKNOWN(" + std::to_string(config) + ")";
  }
  return kConfigNames[config];
}

int TwoViewConfigFromName(const std::string& name) {
  for (int i = 0; i < kNumConfigs; ++i) {
    if (name == kConfigNames[i]) return i;
  }
  return -1;
}

void RelativePoseOptions::Check() const {
  if (!(max_error_px > 0)) {
    throw OptionError(&max_error_px, "RelativePose.max_error_px",
                      "must be > 0");
  }
  if (!(retry_max_error_px >= 0)) {
    throw OptionError(&retry_max_error_px, "RelativePose.retry_max_error_px",
                      "must be >= 0 (0: no second scoring)");
  }
  if (!(refine_loss_scale_px > 0)) {
    throw OptionError(&refine_loss_scale_px,
                      "RelativePose.refine_loss_scale_px", "must be > 0");
  }
  if (refine_max_num_matches < 0) {
    throw OptionError(&refine_max_num_matches,
                      "RelativePose.refine_max_num_matches", "must be >= 0");
  }
  if (refine_max_num_iterations < 0) {
    throw OptionError(&refine_max_num_iterations,
                      "RelativePose.refine_max_num_iterations", "must be >= 0");
  }
  if (!(skip_eight_point_min_support >= 0)) {
    throw OptionError(&skip_eight_point_min_support,
                      "RelativePose.skip_eight_point_min_support",
                      "must be >= 0 (above 1: never skipped)");
  }
  if (!(min_stored_pose_support >= 0 && min_stored_pose_support <= 1)) {
    throw OptionError(&min_stored_pose_support,
                      "RelativePose.min_stored_pose_support",
                      "must be in [0, 1]");
  }
  if (!(refine_max_rotation_std_deg > 0)) {
    throw OptionError(&refine_max_rotation_std_deg,
                      "RelativePose.refine_max_rotation_std_deg",
                      "must be > 0");
  }
  if (!(min_tri_angle_deg >= 0)) {
    throw OptionError(&min_tri_angle_deg, "RelativePose.min_tri_angle_deg",
                      "must be >= 0");
  }
}

std::string RelativePoseSourceName(RelativePoseSource source) {
  switch (source) {
    case RelativePoseSource::kNone:
      return "none";
    case RelativePoseSource::kStored:
      return "stored";
    case RelativePoseSource::kEssential:
      return "essential";
    case RelativePoseSource::kFundamental:
      return "fundamental";
    case RelativePoseSource::kHomography:
      return "homography";
    case RelativePoseSource::kRotation:
      return "rotation";
    case RelativePoseSource::kEightPoint:
      return "eight_point";
  }
  return "unknown";
}

Eigen::Matrix3d EssentialFromPose(const Eigen::Matrix3d& R,
                                  const Eigen::Vector3d& t) {
  return CrossMatrix(t) * R;
}

void DecomposeEssentialMatrix(const Eigen::Matrix3d& E,
                              std::vector<Eigen::Matrix3d>* R,
                              std::vector<Eigen::Vector3d>* t) {
  R->clear();
  t->clear();
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(
      E, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d U = svd.matrixU();
  Eigen::Matrix3d V = svd.matrixV();
  if (U.determinant() < 0) U = -U;
  if (V.determinant() < 0) V = -V;
  Eigen::Matrix3d W;
  W << 0, 1, 0, -1, 0, 0, 0, 0, 1;
  const Eigen::Matrix3d R1 = U * W * V.transpose();
  const Eigen::Matrix3d R2 = U * W.transpose() * V.transpose();
  const Eigen::Vector3d t1 = U.col(2).normalized();
  for (const Eigen::Matrix3d& Ri : {R1, R2}) {
    for (const Eigen::Vector3d& ti : {t1, Eigen::Vector3d(-t1)}) {
      R->push_back(Ri);
      t->push_back(ti);
    }
  }
}

void DecomposeHomographyMatrix(const Eigen::Matrix3d& H_in,
                               std::vector<Eigen::Matrix3d>* R,
                               std::vector<Eigen::Vector3d>* t,
                               std::vector<Eigen::Vector3d>* n) {
  R->clear();
  t->clear();
  n->clear();
  // Scale so that the middle singular value is 1: then H = R + t n^T.
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(H_in);
  const double sigma2 = svd.singularValues()(1);
  if (!(sigma2 > 0)) return;
  const Eigen::Matrix3d H = H_in / sigma2;
  // Eigen-decomposition of H^T H, eigenvalues descending.
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(H.transpose() * H);
  const Eigen::Vector3d values = eig.eigenvalues().reverse();
  const Eigen::Matrix3d V = eig.eigenvectors().rowwise().reverse();
  const double s1 = values(0);  // sigma1^2 >= 1
  const double s3 = values(2);  // sigma3^2 <= 1
  if (s1 - s3 < 1e-9) {
    // All singular values equal: a rotation (no translation, no plane).
    R->push_back(ProjectToRotation(H));
    t->push_back(Eigen::Vector3d::Zero());
    n->push_back(Eigen::Vector3d::Zero());
    return;
  }
  const Eigen::Vector3d v1 = V.col(0), v2 = V.col(1), v3 = V.col(2);
  const double a = std::sqrt(std::max(0.0, 1 - s3));
  const double b = std::sqrt(std::max(0.0, s1 - 1));
  const double c = std::sqrt(s1 - s3);
  const Eigen::Vector3d u1 = (a * v1 + b * v3) / c;
  const Eigen::Vector3d u2 = (a * v1 - b * v3) / c;
  for (const Eigen::Vector3d& u : {u1, u2}) {
    Eigen::Matrix3d U, W;
    U << v2, u, v2.cross(u);
    W << H * v2, H * u, (H * v2).cross(H * u);
    const Eigen::Matrix3d Ri = W * U.transpose();
    const Eigen::Vector3d ni = v2.cross(u);
    const Eigen::Vector3d ti = (H - Ri) * ni;
    R->push_back(Ri);
    t->push_back(ti);
    n->push_back(ni);
    R->push_back(Ri);
    t->push_back(-ti);
    n->push_back(-ni);
  }
}

namespace {

// Hartley's normalisation: the similarity taking the points' centroid to
// the origin and their mean distance from it to sqrt(2).
Eigen::Matrix3d HartleyNormalisation(
    const std::vector<Eigen::Vector2d>& points) {
  Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
  for (const auto& p : points) centroid += p;
  centroid /= points.size();
  double mean_dist = 0;
  for (const auto& p : points) mean_dist += (p - centroid).norm();
  mean_dist /= points.size();
  const double s = mean_dist > 0 ? std::sqrt(2.0) / mean_dist : 1.0;
  Eigen::Matrix3d T;
  T << s, 0, -s * centroid(0), 0, s, -s * centroid(1), 0, 0, 1;
  return T;
}

// Linear eight-point solution of x2^T M x1 = 0 from >= 8 correspondences,
// Hartley-normalised for conditioning, in the points' own coordinates (not
// projected onto any manifold).
Eigen::Matrix3d LinearEightPoint(const std::vector<Eigen::Vector2d>& points1,
                                 const std::vector<Eigen::Vector2d>& points2) {
  const size_t num = points1.size();
  const Eigen::Matrix3d T1 = HartleyNormalisation(points1);
  const Eigen::Matrix3d T2 = HartleyNormalisation(points2);
  Eigen::Matrix<double, 9, 9> AtA = Eigen::Matrix<double, 9, 9>::Zero();
  for (size_t i = 0; i < num; ++i) {
    const Eigen::Vector3d x1 = T1 * points1[i].homogeneous();
    const Eigen::Vector3d x2 = T2 * points2[i].homogeneous();
    Eigen::Matrix<double, 9, 1> row;
    row << x2(0) * x1(0), x2(0) * x1(1), x2(0), x2(1) * x1(0), x2(1) * x1(1),
        x2(1), x1(0), x1(1), 1;
    AtA += row * row.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 9, 9>> eig(AtA);
  const Eigen::Matrix<double, 9, 1> e = eig.eigenvectors().col(0);
  Eigen::Matrix3d Mn;
  Mn << e(0), e(1), e(2), e(3), e(4), e(5), e(6), e(7), e(8);
  return T2.transpose() * Mn * T1;
}

}  // namespace

bool EstimateEssentialEightPoint(const std::vector<Eigen::Vector2d>& points1,
                                 const std::vector<Eigen::Vector2d>& points2,
                                 Eigen::Matrix3d* E) {
  if (points1.size() < 8 || points2.size() != points1.size()) return false;
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(
      LinearEightPoint(points1, points2),
      Eigen::ComputeFullU | Eigen::ComputeFullV);
  *E = svd.matrixU() * Eigen::Vector3d(1, 1, 0).asDiagonal() *
       svd.matrixV().transpose();
  return true;
}

bool EstimateFundamentalEightPoint(const std::vector<Eigen::Vector2d>& points1,
                                   const std::vector<Eigen::Vector2d>& points2,
                                   Eigen::Matrix3d* F) {
  if (points1.size() < 8 || points2.size() != points1.size()) return false;
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(
      LinearEightPoint(points1, points2),
      Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Vector3d singular = svd.singularValues();
  singular(2) = 0;
  *F = svd.matrixU() * singular.asDiagonal() * svd.matrixV().transpose();
  const double norm = F->norm();
  if (!(norm > 0) || !F->allFinite()) return false;
  *F /= norm;
  return true;
}

bool EstimateHomographyDLT(const std::vector<Eigen::Vector2d>& points1,
                           const std::vector<Eigen::Vector2d>& points2,
                           Eigen::Matrix3d* H) {
  const size_t num = points1.size();
  if (num < 4 || points2.size() != num) return false;
  const Eigen::Matrix3d T1 = HartleyNormalisation(points1);
  const Eigen::Matrix3d T2 = HartleyNormalisation(points2);
  Eigen::Matrix<double, 9, 9> AtA = Eigen::Matrix<double, 9, 9>::Zero();
  for (size_t i = 0; i < num; ++i) {
    const Eigen::Vector3d x1 = T1 * points1[i].homogeneous();
    const Eigen::Vector3d x2 = T2 * points2[i].homogeneous();
    // x2 x (H x1) = 0: two independent rows per correspondence.
    Eigen::Matrix<double, 9, 1> row_u, row_v;
    row_u << -x1(0), -x1(1), -1, 0, 0, 0, x2(0) * x1(0), x2(0) * x1(1), x2(0);
    row_v << 0, 0, 0, -x1(0), -x1(1), -1, x2(1) * x1(0), x2(1) * x1(1), x2(1);
    AtA += row_u * row_u.transpose() + row_v * row_v.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 9, 9>> eig(AtA);
  const Eigen::Matrix<double, 9, 1> h = eig.eigenvectors().col(0);
  Eigen::Matrix3d Hn;
  Hn << h(0), h(1), h(2), h(3), h(4), h(5), h(6), h(7), h(8);
  *H = T2.inverse() * Hn * T1;
  const double norm = H->norm();
  if (!(norm > 0) || !H->allFinite()) return false;
  *H /= norm;
  return true;
}

double HomographyTransferErrorSquared(const Eigen::Matrix3d& H,
                                      const Eigen::Vector2d& x1,
                                      const Eigen::Vector2d& x2) {
  const Eigen::Vector3d p = H * x1.homogeneous();
  if (!(std::abs(p.z()) > 0)) return std::numeric_limits<double>::infinity();
  return (p.hnormalized() - x2).squaredNorm();
}

double SampsonErrorSquared(const Eigen::Matrix3d& E, const Eigen::Vector2d& x1,
                           const Eigen::Vector2d& x2) {
  const Eigen::Vector3d x1h = x1.homogeneous();
  const Eigen::Vector3d x2h = x2.homogeneous();
  const Eigen::Vector3d Ex1 = E * x1h;
  const Eigen::Vector3d Etx2 = E.transpose() * x2h;
  const double numerator = x2h.dot(Ex1);
  const double denominator =
      Ex1.head<2>().squaredNorm() + Etx2.head<2>().squaredNorm();
  if (!(denominator > 0)) return std::numeric_limits<double>::infinity();
  return numerator * numerator / denominator;
}

void TriangulateDepths(const Eigen::Matrix3d& R, const Eigen::Vector3d& t,
                       const Eigen::Vector2d& x1, const Eigen::Vector2d& x2,
                       double* depth1, double* depth2) {
  // depth2 * x2 = depth1 * R x1 + t, least squares in (depth1, depth2).
  Eigen::Matrix<double, 3, 2> A;
  A.col(0) = R * x1.homogeneous();
  A.col(1) = -x2.homogeneous();
  const Eigen::Matrix2d AtA = A.transpose() * A;
  const double det = AtA.determinant();
  if (std::abs(det) < 1e-14) {
    *depth1 = *depth2 = 0;
    return;
  }
  const Eigen::Vector2d depths = AtA.inverse() * (A.transpose() * -t);
  *depth1 = depths(0);
  *depth2 = depths(1);
}

Eigen::Matrix3d CameraCalibrationMatrix(const Camera& camera) {
  const std::vector<int> focal = CameraModelFocalLengthIdxs(camera.model_id);
  const std::vector<int> principal =
      CameraModelPrincipalPointIdxs(camera.model_id);
  CHECK(!focal.empty() && principal.size() == 2) << camera.model_id;
  Eigen::Matrix3d K = Eigen::Matrix3d::Identity();
  K(0, 0) = camera.params[focal[0]];
  K(1, 1) = camera.params[focal.size() > 1 ? focal[1] : focal[0]];
  K(0, 2) = camera.params[principal[0]];
  K(1, 2) = camera.params[principal[1]];
  return K;
}

namespace {

// EstimateRelativePose on the normalised (undistorted) inlier matches.
RelativePose EstimateFromCorrespondences(const TwoViewGeometry& geometry,
                                         const Camera& camera1,
                                         const Camera& camera2,
                                         const Correspondences& corrs,
                                         const RelativePoseOptions& options);

}  // namespace

RelativePose EstimateRelativePose(const TwoViewGeometry& geometry,
                                  const Camera& camera1, const Camera& camera2,
                                  const FeatureKeypoints& keypoints1,
                                  const FeatureKeypoints& keypoints2,
                                  const RelativePoseOptions& options) {
  Correspondences corrs;
  corrs.x1.reserve(geometry.inlier_matches.size());
  corrs.x2.reserve(geometry.inlier_matches.size());
  for (const FeatureMatch& match : geometry.inlier_matches) {
    CHECK_LT(match.point2D_idx1, keypoints1.size());
    CHECK_LT(match.point2D_idx2, keypoints2.size());
    corrs.x1.push_back(CameraImageToCamera(
        camera1, keypoints1[match.point2D_idx1].cast<double>()));
    corrs.x2.push_back(CameraImageToCamera(
        camera2, keypoints2[match.point2D_idx2].cast<double>()));
  }
  return EstimateFromCorrespondences(geometry, camera1, camera2, corrs,
                                     options);
}

RelativePose EstimateRelativePoseNormalized(
    const TwoViewGeometry& geometry, const Camera& camera1,
    const Camera& camera2, const std::vector<Eigen::Vector2d>& normalized1,
    const std::vector<Eigen::Vector2d>& normalized2,
    const RelativePoseOptions& options) {
  Correspondences corrs;
  corrs.x1.reserve(geometry.inlier_matches.size());
  corrs.x2.reserve(geometry.inlier_matches.size());
  for (const FeatureMatch& match : geometry.inlier_matches) {
    CHECK_LT(match.point2D_idx1, normalized1.size());
    CHECK_LT(match.point2D_idx2, normalized2.size());
    corrs.x1.push_back(normalized1[match.point2D_idx1]);
    corrs.x2.push_back(normalized2[match.point2D_idx2]);
  }
  return EstimateFromCorrespondences(geometry, camera1, camera2, corrs,
                                     options);
}

namespace {

// The candidate poses of the stored geometry, each group scored together
// later (a decomposition's twins): the stored pose, E's, F's (normalised by
// K1, K2), H's decompositions (both signs) and the rotation nearest to H.
// `*num_groups` counts the groups.
std::vector<Candidate> StoredGeometryCandidates(const TwoViewGeometry& geometry,
                                                const Eigen::Matrix3d& K1,
                                                const Eigen::Matrix3d& K2,
                                                int* num_groups) {
  std::vector<Candidate> candidates;
  if (geometry.has_pose) {
    Candidate stored;
    stored.source = RelativePoseSource::kStored;
    stored.group = (*num_groups)++;
    stored.R = QuaternionToRotation(geometry.qvec);
    const double norm = geometry.tvec.norm();
    stored.pure_rotation = !(norm > 0);
    if (norm > 0) stored.t = geometry.tvec / norm;
    candidates.push_back(stored);
  }
  if (!IsZero(geometry.E)) {
    AddEssentialCandidates(geometry.E, RelativePoseSource::kEssential,
                           (*num_groups)++, &candidates);
  }
  if (!IsZero(geometry.F)) {
    const Eigen::Matrix3d E_from_F = K2.transpose() * geometry.F * K1;
    // Where F is the stored E in pixels (a matcher that derived one from the
    // other, the synthetic scenes), its candidates are the E's again, which
    // are preferred at equal cost: scoring them would change nothing.
    if (IsZero(geometry.E) || !SameUpToScale(E_from_F, geometry.E)) {
      AddEssentialCandidates(E_from_F, RelativePoseSource::kFundamental,
                             (*num_groups)++, &candidates);
    }
  }
  if (!IsZero(geometry.H)) {
    const Eigen::Matrix3d Hn = K2.inverse() * geometry.H * K1;
    // The sign of H is arbitrary: decompose both and let cheirality decide.
    for (const double sign : {1.0, -1.0}) {
      std::vector<Eigen::Matrix3d> Rs;
      std::vector<Eigen::Vector3d> ts, ns;
      DecomposeHomographyMatrix(sign * Hn, &Rs, &ts, &ns);
      const int first_group = *num_groups;
      for (size_t i = 0; i < Rs.size(); ++i) {
        if (!IsRotation(Rs[i], 1e-6)) continue;
        Candidate candidate;
        // Solutions come as (R, t), (R, -t).
        candidate.group = first_group + static_cast<int>(i / 2);
        *num_groups = candidate.group + 1;
        candidate.source = RelativePoseSource::kHomography;
        candidate.R = Rs[i];
        candidate.t = ts[i].norm() > 0 ? Eigen::Vector3d(ts[i].normalized())
                                       : Eigen::Vector3d::Zero();
        candidate.pure_rotation = !(ts[i].norm() > 0);
        if (candidate.pure_rotation) {
          candidate.source = RelativePoseSource::kRotation;
        }
        candidates.push_back(candidate);
      }
    }
    // The rotation nearest to H, for pure rotations that are not exactly so.
    Eigen::Matrix3d Hr = Hn / std::cbrt(Hn.determinant());
    Candidate rotation;
    rotation.source = RelativePoseSource::kRotation;
    rotation.R = ProjectToRotation(Hr);
    rotation.pure_rotation = true;
    rotation.group = (*num_groups)++;
    candidates.push_back(rotation);
  }
  return candidates;
}

// Scores the candidates from index `first` on, group by group.
void ScoreCandidatesFrom(const Correspondences& corrs, double focal,
                         double max_error_px, size_t first,
                         std::vector<Candidate>* candidates) {
  for (size_t begin = first, end = first; begin < candidates->size();
       begin = end) {
    end = begin + 1;
    while (end < candidates->size() &&
           (*candidates)[end].group == (*candidates)[begin].group) {
      ++end;
    }
    ScoreGroup(corrs, focal, max_error_px, &(*candidates)[begin],
               candidates->data() + end);
  }
}

// The index of the scored candidate to keep (-1: none): the best derived
// one by source preference and cost, or the stored pose (candidates[0])
// when it has min_stored_pose_support of that one's support.
int ChooseCandidate(const TwoViewGeometry& geometry,
                    const Correspondences& corrs, double focal,
                    const Eigen::Matrix3d& K1, const Eigen::Matrix3d& K2,
                    const RelativePoseOptions& options,
                    const std::vector<Candidate>& candidates) {
  // Sources in order of preference. A planar scene fits the true pose and
  // the homography's twin solution equally well (both pass cheirality), so the
  // truncated cost alone cannot tell them apart: the preferred source wins
  // unless another fits clearly better.
  const RelativePoseSource kPreference[] = {
      RelativePoseSource::kEssential, RelativePoseSource::kFundamental,
      RelativePoseSource::kHomography, RelativePoseSource::kRotation,
      RelativePoseSource::kEightPoint};
  double min_cost = std::numeric_limits<double>::infinity();
  for (const Candidate& candidate : candidates) {
    if (candidate.source != RelativePoseSource::kStored) {
      min_cost = std::min(min_cost, candidate.cost);
    }
  }
  const double tolerance =
      options.max_error_px * options.max_error_px * 1e-6 * corrs.x1.size();
  // Only where the matches are mostly explained by H (a near-planar scene)
  // does the homography's twin compete; elsewhere the lowest cost wins.
  int num_homography_inliers = 0;
  if (!IsZero(geometry.H)) {
    const Eigen::Matrix3d Hn = K2.inverse() * geometry.H * K1;
    for (size_t i = 0; i < corrs.x1.size(); ++i) {
      const Eigen::Vector3d p = Hn * corrs.x1[i].homogeneous();
      num_homography_inliers +=
          p.z() != 0 &&
          (p.hnormalized() - corrs.x2[i]).norm() * focal < options.max_error_px;
    }
  }
  const bool near_planar =
      num_homography_inliers >= kMinPlanarFraction * corrs.x1.size();
  int best_derived = -1;
  for (const RelativePoseSource source : kPreference) {
    for (size_t i = 0; i < candidates.size(); ++i) {
      if (candidates[i].source != source ||
          candidates[i].cost >
              (near_planar ? kCostTolerance : 1.0) * min_cost + tolerance) {
        continue;
      }
      if (best_derived < 0 ||
          candidates[i].cost < candidates[best_derived].cost) {
        best_derived = static_cast<int>(i);
      }
    }
    if (best_derived >= 0) break;
  }
  const bool use_stored =
      geometry.has_pose && candidates[0].support > 0 &&
      (best_derived < 0 ||
       candidates[0].support >=
           options.min_stored_pose_support * candidates[best_derived].support);
  return use_stored ? 0 : best_derived;
}

RelativePose EstimateFromCorrespondences(const TwoViewGeometry& geometry,
                                         const Camera& camera1,
                                         const Camera& camera2,
                                         const Correspondences& corrs,
                                         const RelativePoseOptions& options) {
  RelativePose result;
  if (corrs.x1.size() < 5) {
    result.failure = "fewer than 5 inlier matches";
    return result;
  }
  const double focal =
      0.5 * (CameraMeanFocalLength(camera1) + CameraMeanFocalLength(camera2));
  const Eigen::Matrix3d K1 = CameraCalibrationMatrix(camera1);
  const Eigen::Matrix3d K2 = CameraCalibrationMatrix(camera2);

  int num_groups = 0;
  std::vector<Candidate> candidates =
      StoredGeometryCandidates(geometry, K1, K2, &num_groups);
  ScoreCandidatesFrom(corrs, focal, options.max_error_px, 0, &candidates);
  int max_support = 0;
  for (const Candidate& candidate : candidates) {
    max_support = std::max(max_support, candidate.support);
  }
  const size_t num_stored_candidates = candidates.size();
  Eigen::Matrix3d E8;
  if (max_support < options.skip_eight_point_min_support * corrs.x1.size() &&
      EstimateEssentialEightPoint(corrs.x1, corrs.x2, &E8)) {
    AddEssentialCandidates(E8, RelativePoseSource::kEightPoint, num_groups++,
                           &candidates);
    ScoreCandidatesFrom(corrs, focal, options.max_error_px,
                        num_stored_candidates, &candidates);
  }

  const int best =
      ChooseCandidate(geometry, corrs, focal, K1, K2, options, candidates);
  if (best < 0 || candidates[best].support < 5) {
    if (options.retry_max_error_px > options.max_error_px) {
      // Intrinsics a few percent off (a focal prior from EXIF, distortion the
      // database does not model) move every match of a wide-angle pair by
      // more than max_error_px from any essential matrix: score once more
      // with the looser threshold rather than lose the pair.
      RelativePoseOptions retry = options;
      retry.max_error_px = options.retry_max_error_px;
      retry.retry_max_error_px = 0;
      result =
          EstimateFromCorrespondences(geometry, camera1, camera2, corrs, retry);
      result.retried = result.success;
      return result;
    }
    result.failure = "no candidate pose is supported by 5 inlier matches";
    return result;
  }

  Candidate chosen = std::move(candidates[best]);
  if (options.refine && options.refine_max_num_iterations > 0) {
    Candidate refined = chosen;
    Refine(corrs, chosen.supporting, focal, options, &refined);
    result.rotation_std_deg = refined.rotation_std_deg;
    result.num_refine_passes = refined.num_refine_passes;
    // Refinement minimises a robust cost, not the truncated one: accept it
    // unless it loses support clearly. (Where the rotation_std gate stopped
    // it the pose is unchanged: no need to score it again.)
    if (refined.rotation_std_deg <= options.refine_max_rotation_std_deg) {
      Score(corrs, focal, options.max_error_px, &refined);
      if (refined.support >= kMinRefinedSupport * chosen.support) {
        chosen = std::move(refined);
        result.refined = true;
      }
    }
  }

  result.success = true;
  result.source = chosen.source;
  result.R = chosen.R;
  result.num_supporting = chosen.support;
  result.median_tri_angle_deg =
      MedianTriAngleDeg(corrs, chosen.supporting, chosen.R);
  result.has_translation =
      !chosen.pure_rotation &&
      result.median_tri_angle_deg >= options.min_tri_angle_deg;
  result.t = result.has_translation ? chosen.t : Eigen::Vector3d::Zero();
  return result;
}

}  // namespace

}  // namespace colmap_irav4
