#include "colmap_irav4/geometry/two_view_geometry.h"

#include <algorithm>
#include <cmath>

#include <ceres/ceres.h>
#include <ceres/rotation.h>
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
           Candidate* candidate, std::vector<char>* supporting = nullptr) {
  const double max_error_sq = max_error_px * max_error_px;
  const Eigen::Matrix3d E = EssentialFromPose(candidate->R, candidate->t);
  candidate->cost = 0;
  candidate->support = 0;
  if (supporting != nullptr) supporting->assign(corrs.x1.size(), 0);
  for (size_t i = 0; i < corrs.x1.size(); ++i) {
    double error_sq = max_error_sq;
    if (MatchError(*candidate, E, corrs.x1[i], corrs.x2[i], focal,
                   max_error_sq, &error_sq)) {
      candidate->cost += error_sq;
      ++candidate->support;
      if (supporting != nullptr) (*supporting)[i] = 1;
    } else {
      candidate->cost += max_error_sq;
    }
  }
}

void AddEssentialCandidates(const Eigen::Matrix3d& E, RelativePoseSource source,
                            std::vector<Candidate>* candidates) {
  std::vector<Eigen::Matrix3d> Rs;
  std::vector<Eigen::Vector3d> ts;
  DecomposeEssentialMatrix(E, &Rs, &ts);
  for (size_t i = 0; i < Rs.size(); ++i) {
    Candidate candidate;
    candidate.source = source;
    candidate.R = Rs[i];
    candidate.t = ts[i];
    candidates->push_back(candidate);
  }
}

// Sampson error of x2^T [t]x R x1 = 0, scaled to pixels.
struct SampsonCost {
  SampsonCost(const Eigen::Vector2d& x1, const Eigen::Vector2d& x2,
              double scale)
      : x1_(x1), x2_(x2), scale_(scale) {}

  template <typename T>
  bool operator()(const T* q, const T* t, T* residual) const {
    T R[9];
    ceres::QuaternionToRotation(q, R);  // row-major
    // E = [t]x R, row-major.
    const T tx[9] = {T(0), -t[2], t[1], t[2], T(0), -t[0], -t[1], t[0], T(0)};
    T E[9];
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) {
        E[3 * r + c] = tx[3 * r] * R[c] + tx[3 * r + 1] * R[3 + c] +
                       tx[3 * r + 2] * R[6 + c];
      }
    }
    const T x1[3] = {T(x1_(0)), T(x1_(1)), T(1)};
    const T x2[3] = {T(x2_(0)), T(x2_(1)), T(1)};
    T Ex1[3], Etx2[3];
    for (int r = 0; r < 3; ++r) {
      Ex1[r] = E[3 * r] * x1[0] + E[3 * r + 1] * x1[1] + E[3 * r + 2] * x1[2];
      Etx2[r] = E[r] * x2[0] + E[3 + r] * x2[1] + E[6 + r] * x2[2];
    }
    const T numerator = x2[0] * Ex1[0] + x2[1] * Ex1[1] + x2[2] * Ex1[2];
    const T denominator = Ex1[0] * Ex1[0] + Ex1[1] * Ex1[1] +
                          Etx2[0] * Etx2[0] + Etx2[1] * Etx2[1];
    residual[0] = T(scale_) * numerator / ceres::sqrt(denominator + T(1e-30));
    return true;
  }

  Eigen::Vector2d x1_, x2_;
  double scale_;
};

// Transfer error of x2 ~ R x1 (pure rotation), scaled to pixels.
struct RotationTransferCost {
  RotationTransferCost(const Eigen::Vector2d& x1, const Eigen::Vector2d& x2,
                       double scale)
      : x1_(x1), x2_(x2), scale_(scale) {}

  template <typename T>
  bool operator()(const T* q, T* residual) const {
    const T x1[3] = {T(x1_(0)), T(x1_(1)), T(1)};
    T p[3];
    ceres::UnitQuaternionRotatePoint(q, x1, p);
    residual[0] = T(scale_) * (p[0] / p[2] - T(x2_(0)));
    residual[1] = T(scale_) * (p[1] / p[2] - T(x2_(1)));
    return true;
  }

  Eigen::Vector2d x1_, x2_;
  double scale_;
};

// Robust refinement of a candidate on the matches that support it.
void Refine(const Correspondences& corrs, const std::vector<char>& supporting,
            double focal, const RelativePoseOptions& options,
            Candidate* candidate) {
  const Eigen::Vector4d qvec = RotationToQuaternion(candidate->R);
  double q[4] = {qvec(0), qvec(1), qvec(2), qvec(3)};
  double t[3] = {candidate->t(0), candidate->t(1), candidate->t(2)};
  ceres::Problem problem;
  size_t num_supporting = 0;
  for (const char s : supporting) num_supporting += s;
  const double stride =
      options.refine_max_num_matches > 0 &&
              num_supporting > static_cast<size_t>(options.refine_max_num_matches)
          ? static_cast<double>(num_supporting) / options.refine_max_num_matches
          : 1.0;
  double next_sample = 0;
  size_t rank = 0;  // index among the supporting matches
  for (size_t i = 0; i < corrs.x1.size(); ++i) {
    if (!supporting[i]) continue;
    if (static_cast<double>(rank++) < next_sample) continue;
    next_sample += stride;
    ceres::LossFunction* loss =
        new ceres::CauchyLoss(options.refine_loss_scale_px);
    if (candidate->pure_rotation) {
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<RotationTransferCost, 2, 4>(
              new RotationTransferCost(corrs.x1[i], corrs.x2[i], focal)),
          loss, q);
    } else {
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<SampsonCost, 1, 4, 3>(
              new SampsonCost(corrs.x1[i], corrs.x2[i], focal)),
          loss, q, t);
    }
  }
  if (problem.NumResidualBlocks() == 0) return;
  problem.SetManifold(q, new ceres::QuaternionManifold);
  if (!candidate->pure_rotation) {
    problem.SetManifold(t, new ceres::SphereManifold<3>);
  }
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::DENSE_QR;
  solver_options.max_num_iterations = options.refine_max_num_iterations;
  solver_options.num_threads = 1;
  solver_options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &problem, &summary);
  if (!summary.IsSolutionUsable()) return;
  candidate->R = QuaternionToRotation(Eigen::Vector4d(q[0], q[1], q[2], q[3]));
  if (!candidate->pure_rotation) {
    candidate->t = Eigen::Vector3d(t[0], t[1], t[2]).normalized();
  }
}

double MedianTriAngleDeg(const Correspondences& corrs,
                         const std::vector<char>& supporting,
                         const Eigen::Matrix3d& R) {
  std::vector<double> angles;
  for (size_t i = 0; i < corrs.x1.size(); ++i) {
    if (!supporting[i]) continue;
    const Eigen::Vector3d ray1 = corrs.x1[i].homogeneous().normalized();
    const Eigen::Vector3d ray2 =
        (R.transpose() * corrs.x2[i].homogeneous()).normalized();
    angles.push_back(std::acos(std::clamp(ray1.dot(ray2), -1.0, 1.0)));
  }
  if (angles.empty()) return 0;
  std::nth_element(angles.begin(), angles.begin() + angles.size() / 2,
                   angles.end());
  return RadToDeg(angles[angles.size() / 2]);
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
    throw OptionError(&max_error_px, "RelativePose.max_error_px", "must be > 0");
  }
  if (!(refine_loss_scale_px > 0)) {
    throw OptionError(&refine_loss_scale_px, "RelativePose.refine_loss_scale_px", "must be > 0");
  }
  if (refine_max_num_matches < 0) {
    throw OptionError(&refine_max_num_matches, "RelativePose.refine_max_num_matches", "must be >= 0");
  }
  if (refine_max_num_iterations < 0) {
    throw OptionError(&refine_max_num_iterations, "RelativePose.refine_max_num_iterations",
                     "must be >= 0");
  }
  if (!(min_stored_pose_support >= 0 && min_stored_pose_support <= 1)) {
    throw OptionError(&min_stored_pose_support, "RelativePose.min_stored_pose_support",
                     "must be in [0, 1]");
  }
  if (!(min_tri_angle_deg >= 0)) {
    throw OptionError(&min_tri_angle_deg, "RelativePose.min_tri_angle_deg", "must be >= 0");
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
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(E,
                                        Eigen::ComputeFullU | Eigen::ComputeFullV);
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

bool EstimateEssentialEightPoint(const std::vector<Eigen::Vector2d>& points1,
                                 const std::vector<Eigen::Vector2d>& points2,
                                 Eigen::Matrix3d* E) {
  const size_t num = points1.size();
  if (num < 8 || points2.size() != num) return false;
  // Hartley normalisation of each point set for conditioning.
  auto normalisation = [](const std::vector<Eigen::Vector2d>& points) {
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
  };
  const Eigen::Matrix3d T1 = normalisation(points1);
  const Eigen::Matrix3d T2 = normalisation(points2);
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
  Eigen::Matrix3d En;
  En << e(0), e(1), e(2), e(3), e(4), e(5), e(6), e(7), e(8);
  const Eigen::Matrix3d M = T2.transpose() * En * T1;
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(M,
                                        Eigen::ComputeFullU | Eigen::ComputeFullV);
  *E = svd.matrixU() * Eigen::Vector3d(1, 1, 0).asDiagonal() *
       svd.matrixV().transpose();
  return true;
}

double SampsonErrorSquared(const Eigen::Matrix3d& E, const Eigen::Vector2d& x1,
                           const Eigen::Vector2d& x2) {
  const Eigen::Vector3d x1h = x1.homogeneous();
  const Eigen::Vector3d x2h = x2.homogeneous();
  const Eigen::Vector3d Ex1 = E * x1h;
  const Eigen::Vector3d Etx2 = E.transpose() * x2h;
  const double numerator = x2h.dot(Ex1);
  const double denominator = Ex1.head<2>().squaredNorm() +
                             Etx2.head<2>().squaredNorm();
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

RelativePose EstimateRelativePose(const TwoViewGeometry& geometry,
                                  const Camera& camera1, const Camera& camera2,
                                  const FeatureKeypoints& keypoints1,
                                  const FeatureKeypoints& keypoints2,
                                  const RelativePoseOptions& options) {
  RelativePose result;
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
  if (corrs.x1.size() < 5) {
    result.failure = "fewer than 5 inlier matches";
    return result;
  }
  const double focal =
      0.5 * (CameraMeanFocalLength(camera1) + CameraMeanFocalLength(camera2));

  std::vector<Candidate> candidates;
  if (geometry.has_pose) {
    Candidate stored;
    stored.source = RelativePoseSource::kStored;
    stored.R = QuaternionToRotation(geometry.qvec);
    const double norm = geometry.tvec.norm();
    stored.pure_rotation = !(norm > 0);
    if (norm > 0) stored.t = geometry.tvec / norm;
    candidates.push_back(stored);
  }
  if (!IsZero(geometry.E)) {
    AddEssentialCandidates(geometry.E, RelativePoseSource::kEssential,
                           &candidates);
  }
  const Eigen::Matrix3d K1 = CameraCalibrationMatrix(camera1);
  const Eigen::Matrix3d K2 = CameraCalibrationMatrix(camera2);
  if (!IsZero(geometry.F)) {
    AddEssentialCandidates(K2.transpose() * geometry.F * K1,
                           RelativePoseSource::kFundamental, &candidates);
  }
  if (!IsZero(geometry.H)) {
    const Eigen::Matrix3d Hn = K2.inverse() * geometry.H * K1;
    // The sign of H is arbitrary: decompose both and let cheirality decide.
    for (const double sign : {1.0, -1.0}) {
      std::vector<Eigen::Matrix3d> Rs;
      std::vector<Eigen::Vector3d> ts, ns;
      DecomposeHomographyMatrix(sign * Hn, &Rs, &ts, &ns);
      for (size_t i = 0; i < Rs.size(); ++i) {
        if (!IsRotation(Rs[i], 1e-6)) continue;
        Candidate candidate;
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
    candidates.push_back(rotation);
  }
  Eigen::Matrix3d E8;
  if (EstimateEssentialEightPoint(corrs.x1, corrs.x2, &E8)) {
    AddEssentialCandidates(E8, RelativePoseSource::kEightPoint, &candidates);
  }

  // Sources in order of preference. A planar scene fits the true pose and
  // the homography's twin solution equally well (both pass cheirality), so the
  // truncated cost alone cannot tell them apart: the preferred source wins
  // unless another fits clearly better.
  const RelativePoseSource kPreference[] = {
      RelativePoseSource::kEssential, RelativePoseSource::kFundamental,
      RelativePoseSource::kHomography, RelativePoseSource::kRotation,
      RelativePoseSource::kEightPoint};
  double min_cost = std::numeric_limits<double>::infinity();
  for (Candidate& candidate : candidates) {
    Score(corrs, focal, options.max_error_px, &candidate);
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
          p.z() != 0 && (p.hnormalized() - corrs.x2[i]).norm() * focal <
                            options.max_error_px;
    }
  }
  const bool near_planar =
      num_homography_inliers >= kMinPlanarFraction * corrs.x1.size();
  int best_derived = -1;
  for (const RelativePoseSource source : kPreference) {
    for (size_t i = 0; i < candidates.size(); ++i) {
      if (candidates[i].source != source ||
          candidates[i].cost > (near_planar ? kCostTolerance : 1.0) * min_cost +
                                   tolerance) {
        continue;
      }
      if (best_derived < 0 || candidates[i].cost < candidates[best_derived].cost) {
        best_derived = static_cast<int>(i);
      }
    }
    if (best_derived >= 0) break;
  }
  int best = best_derived;
  const bool use_stored =
      geometry.has_pose && candidates[0].support > 0 &&
      (best_derived < 0 ||
       candidates[0].support >=
           options.min_stored_pose_support * candidates[best_derived].support);
  if (use_stored) best = 0;
  if (best < 0 || candidates[best].support < 5) {
    result.failure = "no candidate pose is supported by 5 inlier matches";
    return result;
  }

  Candidate chosen = candidates[best];
  std::vector<char> supporting;
  Score(corrs, focal, options.max_error_px, &chosen, &supporting);
  if (options.refine && options.refine_max_num_iterations > 0) {
    Candidate refined = chosen;
    Refine(corrs, supporting, focal, options, &refined);
    std::vector<char> refined_supporting;
    Score(corrs, focal, options.max_error_px, &refined, &refined_supporting);
    // Refinement minimises a robust cost, not the truncated one: accept it
    // unless it loses support clearly.
    if (refined.support >= kMinRefinedSupport * chosen.support) {
      chosen = refined;
      supporting = refined_supporting;
      result.refined = true;
    }
  }

  result.success = true;
  result.source = chosen.source;
  result.R = chosen.R;
  result.num_supporting = chosen.support;
  result.median_tri_angle_deg = MedianTriAngleDeg(corrs, supporting, chosen.R);
  result.has_translation = !chosen.pure_rotation &&
                           result.median_tri_angle_deg >= options.min_tri_angle_deg;
  result.t = result.has_translation ? chosen.t : Eigen::Vector3d::Zero();
  return result;
}

}  // namespace colmap_irav4
