#include "colmap_irav4/refinement/schur_bundle_adjuster.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <ctime>
#include <functional>
#include <iomanip>
#include <limits>
#include <numeric>
#include <sstream>
#include <type_traits>
#include <unordered_set>

#include <cholmod.h>
#include <glog/logging.h>
#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>

#include "colmap_irav4/refinement/implicit_product.h"
#include "colmap_irav4/refinement/reprojection_cost.h"
#include "colmap_irav4/util/huge_pages.h"
#include "colmap_irav4/util/interrupt.h"
#include "colmap_irav4/util/timer.h"

namespace colmap_irav4 {

// One observation linearised: weighted residual r, its Jacobian B by the
// point and A by the reduced system's variables of its pose block and its
// camera block (A's columns: the blocks' free variables in that order).
struct SchurBundleAdjuster::Linearization {
  static constexpr int kMaxCols = 6 + 12;
  Eigen::Vector2d r;
  Eigen::Matrix<double, 2, 3> B;
  Eigen::Matrix<double, 2, Eigen::Dynamic, Eigen::RowMajor, 2, kMaxCols> A;
  int num_blocks = 0;
  int blocks[2];
  int cols[2];  // first column of each block in A
};

namespace {

constexpr int kMaxNumParams = 12;

// The residual of ReprojectionCost (unweighted).
bool EvaluateReprojection(int num_params, int model_id,
                          const Eigen::Vector2d& xy, bool center,
                          double const* const* parameters, double* residual) {
  bool ok = false;
  CHECK(WithNumCameraParams(num_params,
                            [&](auto n) {
                              const ReprojectionCost<decltype(n)::value> cost(
                                  model_id, xy, nullptr, center);
                              ok = cost(parameters[0], parameters[1],
                                        parameters[2], parameters[3], residual);
                            }))
      << "unsupported camera model " << model_id;
  return ok;
}

// The residual and its Jacobians (LinearizeReprojection): the rotation's in
// the manifold's tangent, the camera's num_params columns in `dc`.
bool LinearizeObservation(
    int num_params, int model_id, const Eigen::Vector2d& xy, bool center,
    double const* const* parameters, double* residual,
    Eigen::Matrix<double, 2, 3>* drotation, Eigen::Matrix<double, 2, 3>* dp,
    Eigen::Matrix<double, 2, 3>* dx,
    Eigen::Matrix<double, 2, Eigen::Dynamic, Eigen::RowMajor, 2, kMaxNumParams>*
        dc) {
  bool ok = false;
  CHECK(WithNumCameraParams(num_params,
                            [&](auto n) {
                              constexpr int kNumParams = decltype(n)::value;
                              ReprojectionJacobians<kNumParams> jacobians;
                              ok = LinearizeReprojection<kNumParams>(
                                  model_id, xy, center, parameters[0],
                                  parameters[1], parameters[2], parameters[3],
                                  residual, &jacobians);
                              *drotation = jacobians.rotation;
                              *dp = jacobians.position;
                              *dx = jacobians.point;
                              *dc = jacobians.params;
                            }))
      << "unsupported camera model " << model_id;
  return ok;
}

using SparseMatrix = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;

// values(r, c) -= sum_t a(r, t) b(c, t) (r < rows, c < cols, t < 3): a cell
// of the Schur complement's -Q_k W_l^T, added straight into the reduced
// system's cell (column-major, leading dimension `height`: the cell's rows
// in the cell layout) without the (up to
// 18x18) product as a dynamic-size matrix. a and b are column-major with
// leading dimensions lda and ldb. Each sum runs t = 0, 1, 2 in turn, as
// Eigen's product of main did but for the rows its vectorisation peels off
// an odd-sized block (t0 + (t1 + t2) there): rounding, not the algorithm.
// kRows: the rows known at compile time (a pose block's 6), 0: `rows`.
template <int kRows>
void SubtractProduct(const double* a, int lda, const double* b, int ldb,
                     int rows, int cols, double* values, int height) {
  const int num_rows = kRows > 0 ? kRows : rows;
  for (int c = 0; c < cols; ++c) {
    const double b0 = b[c], b1 = b[ldb + c], b2 = b[2 * ldb + c];
    double* column = values + static_cast<size_t>(c) * height;
    for (int r = 0; r < num_rows; ++r) {
      column[r] -= a[r] * b0 + a[lda + r] * b1 + a[2 * lda + r] * b2;
    }
  }
}

void SubtractProduct(const double* a, int lda, const double* b, int ldb,
                     int rows, int cols, double* values, int height) {
  if (rows == 6) {
    SubtractProduct<6>(a, lda, b, ldb, rows, cols, values, height);
  } else {
    SubtractProduct<0>(a, lda, b, ldb, rows, cols, values, height);
  }
}

// The same for a diagonal cell of a pair of observations sharing a block
// (e.g. a camera): M + M^T of M(r, c) = sum_t a(r, t) b(c, t), summed as
// (M + M^T)(r, c) before it is subtracted, as add_pair adds it.
void SubtractSymmetricProduct(const double* a, int lda, const double* b,
                              int ldb, int size, double* values, int height) {
  for (int c = 0; c < size; ++c) {
    double* column = values + static_cast<size_t>(c) * height;
    for (int r = 0; r < size; ++r) {
      const double m_rc = a[r] * b[c] + a[lda + r] * b[ldb + c] +
                          a[2 * lda + r] * b[2 * ldb + c];
      const double m_cr = a[c] * b[r] + a[lda + c] * b[ldb + r] +
                          a[2 * lda + c] * b[2 * ldb + r];
      column[r] -= m_rc + m_cr;
    }
  }
}

// One update of the reduced system by a pair of a point's observations
// (SchurBundleAdjuster::Solve): kProduct: values -= a b^T (rows x cols, a
// and b column-major with leading dimensions lda and ldb: SubtractProduct);
// kSymmetric: SubtractSymmetricProduct's; kOddPair: the pair (k, l) formed
// as one Eigen product (values null).
struct PairUpdate {
  enum Kind : int { kProduct, kSymmetric, kOddPair };
  const double* a;
  const double* b;
  double* values;
  int lda, ldb, rows, cols;
  Kind kind;
  uint32_t k, l;
};

// The updates prefetched ahead of the one running: measured on random cells
// of 8 x 8 out of the caches, 2 ahead halves an update's time, 4-16 about
// 2.3x less (docs/notes/2026-12-06-ba-iteration-cost.md).
constexpr size_t kPrefetchUpdates = 8;

// Asks for the cache lines of `count` values from `values` (for writing).
inline void PrefetchCell(const double* values, int count) {
#if defined(__GNUC__)
  const uintptr_t line = 64;
  const uintptr_t begin = reinterpret_cast<uintptr_t>(values) & ~(line - 1);
  const uintptr_t end = reinterpret_cast<uintptr_t>(values + count);
  for (uintptr_t p = begin; p < end; p += line) {
    __builtin_prefetch(reinterpret_cast<const void*>(p), 1, 3);
  }
#else
  (void)values;
  (void)count;
#endif
}

// The cell of an update (an odd pair's: none).
inline void Prefetch(const PairUpdate& update) {
  if (update.values != nullptr) {
    PrefetchCell(update.values, update.rows * update.cols);
  }
}

}  // namespace

// CHOLMOD's workspace and the supernodal factor of the reduced system, its
// pattern analysed once (CHOLMOD's ordering: AMD, or METIS when AMD fills
// in much). CHOLMOD (SuiteSparse 5, Debian) runs its factorisation in the
// calling thread; its BLAS follows LimitBlasThreads (util/threading.h).
struct SchurBundleAdjuster::Cholmod {
  cholmod_common common;
  cholmod_factor* factor = nullptr;

  Cholmod() {
    cholmod_start(&common);
    // Failures (not positive definite, out of memory) are read from the
    // status and handled by the caller; CHOLMOD prints nothing.
    common.print = 0;
  }
  ~Cholmod() {
    if (factor != nullptr) cholmod_free_factor(&factor, &common);
    cholmod_finish(&common);
  }
  Cholmod(const Cholmod&) = delete;
  Cholmod& operator=(const Cholmod&) = delete;

  // The reduced system's upper triangle (CSC, sorted rows) as CHOLMOD's
  // symmetric matrix, without a copy; entries below the diagonal of the
  // diagonal blocks are ignored (stype 1).
  static cholmod_sparse View(int n, std::vector<int>* outer,
                             std::vector<int>* inner,
                             std::vector<double>* values) {
    cholmod_sparse a{};
    a.nrow = n;
    a.ncol = n;
    a.nzmax = values->size();
    a.p = outer->data();
    a.i = inner->data();
    a.x = values->data();
    a.stype = 1;
    a.itype = CHOLMOD_INT;
    a.xtype = CHOLMOD_REAL;
    a.dtype = CHOLMOD_DOUBLE;
    a.sorted = 1;
    a.packed = 1;
    return a;
  }
};

SchurBundleAdjuster::SchurBundleAdjuster(bool center,
                                         SchurLinearSolver linear_solver)
    : SchurBundleAdjuster(center, SchurSolverOptions{linear_solver}) {}

SchurBundleAdjuster::SchurBundleAdjuster(bool center,
                                         const SchurSolverOptions& options)
    : center_(center), solver_options_(options) {
  CHECK_GT(options.max_factor_mib, 0);
  CHECK_GT(options.max_factor_gflops, 0);
  CHECK_GE(options.max_cell_table_mib, 0);
  CHECK_GE(options.max_jacobian_store_mib, 0);
  CHECK_GE(options.prefetch_updates_min_mib, 0);
  CHECK(options.eta > 0 && options.eta < 1);
  CHECK_GE(options.implicit_min_mib, 0);
  CHECK_GT(options.max_cg_iterations, 0);
}

SchurBundleAdjuster::~SchurBundleAdjuster() = default;

int SchurBundleAdjuster::AddCamera(double* params, int model_id) {
  CameraBlock camera;
  camera.params = params;
  camera.model_id = model_id;
  camera.num_params = CameraModelNumParams(model_id);
  CHECK(camera.num_params > 0 && camera.num_params <= kMaxNumParams);
  cameras_.push_back(std::move(camera));
  SetCameraConstant(static_cast<int>(cameras_.size()) - 1, {});
  return static_cast<int>(cameras_.size()) - 1;
}

void SchurBundleAdjuster::SetCameraConstant(int camera,
                                            const std::vector<int>& constant) {
  CameraBlock& block = cameras_.at(camera);
  block.free.clear();
  for (int i = 0; i < block.num_params; ++i) {
    if (std::find(constant.begin(), constant.end(), i) == constant.end()) {
      block.free.push_back(i);
    }
  }
}

void SchurBundleAdjuster::SetCameraPrior(int camera, int param, double value,
                                         double std) {
  CameraBlock& block = cameras_.at(camera);
  CHECK(param >= 0 && param < block.num_params);
  CHECK(std > 0 && std::isfinite(std) && std::isfinite(value));
  block.prior_param = param;
  block.prior_value = value;
  block.prior_std = std;
}

double SchurBundleAdjuster::CameraPriorResidual(
    int camera, const std::vector<double>& cameras) const {
  const CameraBlock& block = cameras_[camera];
  return (cameras[kMaxNumParams * camera + block.prior_param] -
          block.prior_value) /
         block.prior_std;
}

int SchurBundleAdjuster::CameraPriorColumn(int camera) const {
  const CameraBlock& block = cameras_[camera];
  if (block.prior_param < 0 || camera_block_[camera] < 0) return -1;
  const auto it =
      std::find(block.free.begin(), block.free.end(), block.prior_param);
  if (it == block.free.end()) return -1;
  return camera_column_[camera] + static_cast<int>(it - block.free.begin());
}

int SchurBundleAdjuster::AddPose(double* rotation, double* position, int camera,
                                 const std::vector<Point2D>* points2D,
                                 const std::vector<double>* weights) {
  CHECK(camera >= 0 && camera < static_cast<int>(cameras_.size()));
  poses_.push_back({rotation, position, camera, points2D, weights, {}});
  SetPoseConstant(static_cast<int>(poses_.size()) - 1, false, -1);
  return static_cast<int>(poses_.size()) - 1;
}

void SchurBundleAdjuster::SetPoseConstant(int pose, bool constant,
                                          int fixed_coordinate) {
  CHECK(values_.empty()) << "after the first solve";
  PoseBlock& block = poses_.at(pose);
  block.free.clear();
  if (constant) return;
  for (int i = 0; i < 6; ++i) {
    if (fixed_coordinate < 0 || i != 3 + fixed_coordinate) {
      block.free.push_back(i);
    }
  }
}

void SchurBundleAdjuster::AddPoint(
    double* xyz, bool constant,
    const std::vector<std::pair<int, point2D_t>>& observations) {
  point_blocks_.push_back(xyz);
  point_constant_.push_back(constant);
  for (const auto& [pose, idx] : observations) {
    CHECK(pose >= 0 && pose < static_cast<int>(poses_.size()));
    observations_.push_back(
        {static_cast<uint32_t>(pose), static_cast<uint32_t>(idx)});
  }
  point_begin_.push_back(static_cast<uint32_t>(observations_.size()));
}

void SchurBundleAdjuster::AddPoseResidual(
    int pose, PoseArguments arguments,
    std::unique_ptr<ceres::CostFunction> cost,
    const ceres::LossFunction* loss) {
  CHECK(pose >= 0 && pose < static_cast<int>(poses_.size()));
  const std::vector<int32_t>& sizes = cost->parameter_block_sizes();
  CHECK_EQ(sizes.size(),
           arguments == PoseArguments::kRotationAndPosition ? 2u : 1u);
  CHECK_EQ(sizes.front(), arguments == PoseArguments::kPosition ? 3 : 4);
  if (sizes.size() == 2) CHECK_EQ(sizes.back(), 3);
  pose_residuals_.push_back({pose, arguments, std::move(cost), loss});
}

bool SchurBundleAdjuster::EvaluatePoseResidual(const PoseResidual& residual,
                                               const std::vector<double>& poses,
                                               double* cost,
                                               PoseLinearization* lin) const {
  const int m = residual.cost->num_residuals();
  const double* rotation = &poses[7 * residual.pose];
  const double* position = &poses[7 * residual.pose + 4];
  const bool uses_rotation = residual.arguments != PoseArguments::kPosition;
  const bool uses_position = residual.arguments != PoseArguments::kRotation;
  const double* parameters[2];
  int num_blocks = 0;
  if (uses_rotation) parameters[num_blocks++] = rotation;
  if (uses_position) parameters[num_blocks++] = position;
  using RowMajor =
      Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  RowMajor dq(m, 4), dp(m, 3);
  double* jacobians[2];
  num_blocks = 0;
  if (uses_rotation) jacobians[num_blocks++] = dq.data();
  if (uses_position) jacobians[num_blocks++] = dp.data();
  Eigen::VectorXd r(m);
  if (!residual.cost->Evaluate(parameters, r.data(),
                               lin != nullptr ? jacobians : nullptr) ||
      !r.allFinite()) {
    return false;
  }
  const double s = r.squaredNorm();
  double rho[3] = {s, 1.0, 0.0};
  if (residual.loss != nullptr) residual.loss->Evaluate(s, rho);
  *cost = 0.5 * rho[0];
  if (!std::isfinite(*cost)) return false;
  if (lin == nullptr) return true;
  lin->cost = *cost;
  const PoseBlock& pose = poses_[residual.pose];
  // Jacobian by the tangent (rotation as ceres::EigenQuaternionManifold's,
  // then position), the free variables only.
  Eigen::MatrixXd tangent = Eigen::MatrixXd::Zero(m, 6);
  if (uses_rotation) {
    Eigen::Matrix<double, 4, 3, Eigen::RowMajor> plus;
    ceres::EigenQuaternionManifold().PlusJacobian(rotation, plus.data());
    tangent.leftCols<3>() = dq * plus;
  }
  if (uses_position) tangent.rightCols<3>() = dp;
  lin->A.resize(m, static_cast<Eigen::Index>(pose.free.size()));
  for (size_t j = 0; j < pose.free.size(); ++j) {
    lin->A.col(j) = tangent.col(pose.free[j]);
  }
  // The loss as Ceres' residual blocks apply it (Triggs et al.'s
  // correction): the Gauss-Newton model of rho(|r|^2) / 2 is |r'|^2 / 2 with
  // r' = sqrt(rho') r / (1 - alpha) and J' = sqrt(rho') (J - alpha r r^T J /
  // |r|^2), alpha from 1 - sqrt(1 + 2 |r|^2 rho'' / rho'); rho'' <= 0 (a
  // concave tail) leaves the scaling by sqrt(rho') alone.
  const double sqrt_rho1 = std::sqrt(rho[1]);
  if (s == 0 || rho[2] <= 0) {
    lin->A *= sqrt_rho1;
    lin->r = sqrt_rho1 * r;
  } else {
    const double alpha = 1 - std::sqrt(1 + 2 * s * rho[2] / rho[1]);
    lin->A = sqrt_rho1 * (lin->A - (alpha / s) * r * (r.transpose() * lin->A));
    lin->r = (sqrt_rho1 / (1 - alpha)) * r;
  }
  return lin->A.allFinite() && lin->r.allFinite();
}

bool SchurBundleAdjuster::Evaluate(size_t k, const double* point,
                                   const std::vector<double>& poses,
                                   const std::vector<double>& cameras,
                                   double residual[2],
                                   Linearization* lin) const {
  const Observation& observation = observations_[k];
  const PoseBlock& pose = poses_[observation.pose];
  const CameraBlock& camera = cameras_[pose.camera];
  const double* parameters[4] = {&poses[7 * observation.pose],
                                 &poses[7 * observation.pose + 4], point,
                                 &cameras[kMaxNumParams * pose.camera]};
  const Eigen::Vector2d& xy = (*pose.points2D)[observation.point2D_idx].xy;
  const double weight = Weight(k);
  if (lin == nullptr) {
    if (!EvaluateReprojection(camera.num_params, camera.model_id, xy, center_,
                              parameters, residual)) {
      return false;
    }
    residual[0] *= weight;
    residual[1] *= weight;
    return std::isfinite(residual[0]) && std::isfinite(residual[1]);
  }
  Eigen::Matrix<double, 2, 3> drotation, dp, dx;
  Eigen::Matrix<double, 2, Eigen::Dynamic, Eigen::RowMajor, 2, kMaxNumParams>
      dcam;
  if (!LinearizeObservation(camera.num_params, camera.model_id, xy, center_,
                            parameters, residual, &drotation, &dp, &dx,
                            &dcam)) {
    return false;
  }
  lin->r = weight * Eigen::Vector2d(residual[0], residual[1]);
  residual[0] = lin->r[0];
  residual[1] = lin->r[1];
  lin->B = weight * dx;
  Describe(observation, lin);
  int col = 0;
  if (pose_block_[observation.pose] >= 0) {
    Eigen::Matrix<double, 2, 6> tangent;
    tangent.leftCols<3>() = drotation;
    tangent.rightCols<3>() = dp;
    for (const int i : pose.free) lin->A.col(col++) = weight * tangent.col(i);
  }
  if (camera_block_[pose.camera] >= 0) {
    for (const int i : camera.free) lin->A.col(col++) = weight * dcam.col(i);
  }
  return std::isfinite(residual[0]) && std::isfinite(residual[1]) &&
         lin->A.allFinite() && lin->B.allFinite();
}

int SchurBundleAdjuster::NumColumns(const Observation& observation) const {
  const PoseBlock& pose = poses_[observation.pose];
  int num_cols = 0;
  if (pose_block_[observation.pose] >= 0) {
    num_cols += static_cast<int>(pose.free.size());
  }
  if (camera_block_[pose.camera] >= 0) {
    num_cols += static_cast<int>(cameras_[pose.camera].free.size());
  }
  return num_cols;
}

SchurBundleAdjuster::ObservationBlocks SchurBundleAdjuster::Blocks(
    uint32_t pose) const {
  ObservationBlocks blocks;
  const int pose_block = pose_block_[pose];
  const int camera_block = camera_block_[poses_[pose].camera];
  int col = 0;
  if (pose_block >= 0) {
    blocks.block[blocks.count] = pose_block;
    blocks.col[blocks.count++] = col;
    col += static_cast<int>(poses_[pose].free.size());
  }
  // (A camera joined to the pose's block: its columns follow the pose's.)
  if (camera_block >= 0 && camera_block != pose_block) {
    blocks.block[blocks.count] = camera_block;
    blocks.col[blocks.count++] = col;
  }
  return blocks;
}

void SchurBundleAdjuster::Describe(const Observation& observation,
                                   Linearization* lin) const {
  const ObservationBlocks blocks = Blocks(observation.pose);
  lin->num_blocks = blocks.count;
  std::copy(blocks.block, blocks.block + blocks.count, lin->blocks);
  std::copy(blocks.col, blocks.col + blocks.count, lin->cols);
  lin->A.resize(2, NumColumns(observation));
}

bool SchurBundleAdjuster::AddPointCost(size_t p, const double* point,
                                       const std::vector<double>& poses,
                                       const std::vector<double>& cameras,
                                       double* cost) const {
  for (uint32_t k = point_begin_[p]; k < point_begin_[p + 1]; ++k) {
    if (!(Weight(k) > 0)) continue;
    double residual[2];
    if (!Evaluate(k, point, poses, cameras, residual, nullptr)) return false;
    *cost += 0.5 * (residual[0] * residual[0] + residual[1] * residual[1]);
  }
  return true;
}

double SchurBundleAdjuster::Cost(const std::vector<double>& poses,
                                 const std::vector<double>& cameras,
                                 const std::vector<double>& points) const {
  double cost = 0;
  for (size_t p = 0; p + 1 < point_begin_.size(); ++p) {
    if (!AddPointCost(p, &points[3 * p], poses, cameras, &cost)) {
      return std::numeric_limits<double>::infinity();
    }
  }
  for (const PoseResidual& residual : pose_residuals_) {
    double term = 0;
    if (!EvaluatePoseResidual(residual, poses, &term, nullptr)) {
      return std::numeric_limits<double>::infinity();
    }
    cost += term;
  }
  for (size_t i = 0; i < cameras_.size(); ++i) {
    if (cameras_[i].prior_param < 0) continue;
    const double r = CameraPriorResidual(static_cast<int>(i), cameras);
    cost += 0.5 * r * r;
  }
  return cost;
}

void SchurBundleAdjuster::NumberBlocks() {
  block_size_.clear();
  block_offset_.clear();
  num_scalars_ = 0;
  auto add = [this](int size) {
    if (size == 0) return -1;
    block_size_.push_back(size);
    block_offset_.push_back(num_scalars_);
    num_scalars_ += size;
    return static_cast<int>(block_size_.size()) - 1;
  };
  // A refined camera of one pose only (a photo collection's camera per
  // image, COLMAP's default) joins its pose's block (the pose's columns,
  // then the camera's): an observation pair then updates one contiguous
  // cell instead of four in four places (SchurSolverOptions).
  std::vector<int> num_users(cameras_.size(), 0);
  for (const PoseBlock& pose : poses_) ++num_users[pose.camera];
  pose_block_.clear();
  camera_block_.assign(cameras_.size(), -1);
  camera_column_.assign(cameras_.size(), 0);
  for (const PoseBlock& pose : poses_) {
    const int pose_size = static_cast<int>(pose.free.size());
    const int camera_size = static_cast<int>(cameras_[pose.camera].free.size());
    const bool join = solver_options_.join_own_camera_blocks && pose_size > 0 &&
                      camera_size > 0 && num_users[pose.camera] == 1;
    pose_block_.push_back(add(pose_size + (join ? camera_size : 0)));
    if (join) {
      camera_block_[pose.camera] = pose_block_.back();
      camera_column_[pose.camera] = pose_size;
    }
  }
  // The other cameras last: shared by many images, they are the dense rows.
  for (size_t c = 0; c < cameras_.size(); ++c) {
    if (camera_block_[c] < 0) {  // not joined
      camera_block_[c] = add(static_cast<int>(cameras_[c].free.size()));
    }
  }
}

void SchurBundleAdjuster::BuildStructure(bool local_only) {
  // Cells (row block <= column block) coupled by an observation or (unless
  // local_only) a point.
  std::unordered_set<uint64_t> cells;
  auto key = [](int a, int b) {
    return static_cast<uint64_t>(std::min(a, b)) << 32 |
           static_cast<uint32_t>(std::max(a, b));
  };
  for (size_t b = 0; b < block_size_.size(); ++b) cells.insert(key(b, b));
  std::vector<int> blocks;
  for (size_t p = 0; p + 1 < point_begin_.size(); ++p) {
    blocks.clear();
    int num_live = 0;
    for (uint32_t k = point_begin_[p]; k < point_begin_[p + 1]; ++k) {
      if (!(Weight(k) > 0)) continue;
      ++num_live;
      const PoseBlock& pose = poses_[observations_[k].pose];
      const int a = pose_block_[observations_[k].pose];
      const int c = camera_block_[pose.camera];
      if (a >= 0 && c >= 0) cells.insert(key(a, c));
      if (a >= 0) blocks.push_back(a);
      if (c >= 0) blocks.push_back(c);
    }
    if (local_only || point_constant_[p] || num_live < 2) continue;
    std::sort(blocks.begin(), blocks.end());
    blocks.erase(std::unique(blocks.begin(), blocks.end()), blocks.end());
    for (size_t i = 0; i < blocks.size(); ++i) {
      for (size_t j = i + 1; j < blocks.size(); ++j) {
        cells.insert(key(blocks[i], blocks[j]));
      }
    }
  }
  cell_offset_.assign(cells.size(), {0, 0});
  std::transform(cells.begin(), cells.end(), cell_offset_.begin(),
                 [](uint64_t cell) {
                   // Sorted by column block, then row block.
                   return std::make_pair(cell << 32 | cell >> 32, 0);
                 });
  cells = {};
  std::sort(cell_offset_.begin(), cell_offset_.end());
  const int num_blocks = static_cast<int>(block_size_.size());
  column_begin_.assign(num_blocks, 0);
  column_height_.assign(num_blocks, 0);
  for (auto& [cell, offset] : cell_offset_) {
    const int column = static_cast<int>(cell >> 32);
    const int row = static_cast<int>(cell & 0xffffffffu);
    offset = column_height_[column];
    column_height_[column] += block_size_[row];
  }
  size_t num_values = 0;
  for (int b = 0; b < num_blocks; ++b) {
    column_begin_[b] = num_values;
    num_values += static_cast<size_t>(block_size_[b]) * column_height_[b];
  }
  // (Value indexes are ints in the scalar pattern, 32 bits in the tables.)
  CHECK_LT(num_values, static_cast<size_t>(std::numeric_limits<int>::max()));
  num_values_ = num_values;
  column_cells_.assign(num_blocks + 1, 0);
  for (const auto& [cell, offset] : cell_offset_) {
    ++column_cells_[(cell >> 32) + 1];
  }
  for (int b = 0; b < num_blocks; ++b) {
    column_cells_[b + 1] += column_cells_[b];
  }
}

void SchurBundleAdjuster::LayOutValues(bool local_only) {
  // Scattered over the whole array by every point's updates (huge pages:
  // 12% less CPU an iteration at 5,000 photo images,
  // docs/notes/2026-12-05-schur-locality.md).
  AssignWithHugePages(num_values_, 0.0, &values_);
  std::vector<int> blocks;
  // The points' cell tables: the pattern is the same at every iteration, so
  // the searches of ValueIndex run once here instead of for every block pair
  // of every point at every iteration (a sixth of an iteration's time on
  // dense photo collections).
  const size_t num_points = point_blocks_.size();
  // A point's blocks, sorted; false when it is held or has fewer than two
  // weighed observations (no table).
  auto live_blocks = [&](size_t p) {
    blocks.clear();
    if (point_constant_[p]) return false;
    int num_live = 0;
    for (uint32_t k = point_begin_[p]; k < point_begin_[p + 1]; ++k) {
      if (!(Weight(k) > 0)) continue;
      ++num_live;
      const int a = pose_block_[observations_[k].pose];
      const int c = camera_block_[poses_[observations_[k].pose].camera];
      if (a >= 0) blocks.push_back(a);
      if (c >= 0) blocks.push_back(c);
    }
    if (num_live < 2) return false;
    std::sort(blocks.begin(), blocks.end());
    blocks.erase(std::unique(blocks.begin(), blocks.end()), blocks.end());
    return true;
  };
  // Two passes: the tables' sizes first, so that they are allocated once at
  // their size (grown by push_back and shrunk to fit, the largest took up to
  // twice its size while copied).
  // Every entry saves the same search per iteration: the points in order
  // while the budget lasts.
  point_block_ids_begin_.assign(num_points + 1, 0);
  point_cells_begin_.assign(num_points + 1, 0);
  size_t num_block_ids = 0;
  size_t num_cells = 0;
  // (The local structure's few cells need no tables, order or prefetches.)
  const double max_bytes = use_cell_tables_ && !local_only
                               ? solver_options_.max_cell_table_mib * 1048576.0
                               : 0;
  // The locality order's keys (below) from the same pass: each point's
  // three largest blocks, descending.
  const double values_bytes =
      static_cast<double>(values_.size()) * sizeof(double);
  const bool locality_order =
      !local_only &&
      values_bytes >= solver_options_.locality_order_min_mib * 1048576.0;
  prefetch_updates_ =
      !local_only &&
      values_bytes >= solver_options_.prefetch_updates_min_mib * 1048576.0;
  std::vector<std::array<int, 3>> keys(locality_order ? num_points : 0,
                                       {-1, -1, -1});
  // The block pairs an elimination updates (VLOG 1: an iteration's work
  // grows with it, the sum over points of m (m + 1) / 2).
  size_t num_points_eliminated = 0;
  double num_pairs = 0;
  for (size_t p = 0; p < num_points; ++p) {
    point_block_ids_begin_[p] = num_block_ids;
    point_cells_begin_[p] = num_cells;
    if (!live_blocks(p)) continue;
    ++num_points_eliminated;
    num_pairs += 0.5 * static_cast<double>(blocks.size()) *
                 static_cast<double>(blocks.size() + 1);
    if (locality_order) {
      for (size_t i = 0; i < 3 && i < blocks.size(); ++i) {
        keys[p][i] = blocks[blocks.size() - 1 - i];
      }
    }
    const size_t point_cells = blocks.size() * (blocks.size() + 1) / 2;
    if ((num_block_ids + blocks.size()) * sizeof(int) +
            (num_cells + point_cells) * sizeof(uint32_t) >
        max_bytes) {
      continue;
    }
    num_block_ids += blocks.size();
    num_cells += point_cells;
  }
  point_block_ids_begin_[num_points] = num_block_ids;
  point_cells_begin_[num_points] = num_cells;
  point_block_ids_ = std::vector<int>(num_block_ids);
  point_cells_ = std::vector<uint32_t>(num_cells);
  for (size_t p = 0; p < num_points; ++p) {
    const size_t num_ids =
        point_block_ids_begin_[p + 1] - point_block_ids_begin_[p];
    if (num_ids == 0 || !live_blocks(p)) continue;
    CHECK_EQ(blocks.size(), num_ids);
    std::copy(blocks.begin(), blocks.end(),
              point_block_ids_.begin() + point_block_ids_begin_[p]);
    uint32_t* cells_out = point_cells_.data() + point_cells_begin_[p];
    for (size_t j = 0; j < blocks.size(); ++j) {
      for (size_t i = 0; i <= j; ++i) {
        *cells_out++ = static_cast<uint32_t>(ValueIndex(blocks[i], blocks[j]));
      }
    }
  }
  // The order the points are eliminated in: by their three largest blocks
  // (descending), so that consecutive points update the same cells while
  // they are in the caches, once the reduced system is too large for them
  // (locality_order_min_mib). Smaller systems keep the points' order.
  point_order_.clear();
  if (locality_order) {
    point_order_.resize(num_points);
    std::iota(point_order_.begin(), point_order_.end(), 0u);
    std::stable_sort(
        point_order_.begin(), point_order_.end(),
        [&keys](uint32_t a, uint32_t b) { return keys[a] < keys[b]; });
  }
  VLOG(1) << "Schur bundle adjustment: " << values_.size()
          << " reduced system entries, cell tables " << point_cells_.size()
          << " entries (" << CellTableBytes() / 1048576.0 << " MiB); "
          << num_points_eliminated << " points eliminated, " << num_pairs
          << " block pairs (sum of m (m + 1) / 2 over their m blocks)";
}

void SchurBundleAdjuster::BuildScalarPattern() {
  outer_.assign(num_scalars_ + 1, 0);
  for (size_t b = 0; b < block_size_.size(); ++b) {
    for (int c = 0; c < block_size_[b]; ++c) {
      outer_[block_offset_[b] + c] = static_cast<int>(
          column_begin_[b] + static_cast<size_t>(c) * column_height_[b]);
    }
  }
  outer_[num_scalars_] = static_cast<int>(values_.size());
  inner_.assign(values_.size(), 0);
  for (const auto& [cell, offset] : cell_offset_) {
    const int column = static_cast<int>(cell >> 32);
    const int row = static_cast<int>(cell & 0xffffffffu);
    for (int c = 0; c < block_size_[column]; ++c) {
      int* rows =
          &inner_[column_begin_[column] + c * column_height_[column] + offset];
      for (int r = 0; r < block_size_[row]; ++r) {
        rows[r] = block_offset_[row] + r;
      }
    }
  }
}

void SchurBundleAdjuster::ToScalarLayout() {
  std::vector<double> scratch;
  for (size_t cb = 0; cb < block_size_.size(); ++cb) {
    const int cols = block_size_[cb];
    const size_t height = column_height_[cb];
    double* column = &values_[column_begin_[cb]];
    scratch.assign(column, column + cols * height);
    for (size_t k = column_cells_[cb]; k < column_cells_[cb + 1]; ++k) {
      const int rows =
          block_size_[static_cast<int>(cell_offset_[k].first & 0xffffffffu)];
      const size_t offset = cell_offset_[k].second;
      const double* cell = &scratch[offset * cols];
      for (int c = 0; c < cols; ++c) {
        std::copy(cell + c * rows, cell + (c + 1) * rows,
                  column + c * height + offset);
      }
    }
  }
}

SchurBundleAdjuster::FactorEstimate SchurBundleAdjuster::EstimateFactor()
    const {
  const int num_blocks = static_cast<int>(block_size_.size());
  const double n = num_scalars_;
  // A dense factor: n (n + 1) / 2 entries, the sum of c^2 for c = 1..n
  // flops.
  const FactorEstimate dense{n * (n + 1) / 2, n * (n + 1) * (2 * n + 1) / 6};
  if (num_blocks == 0) return {};
  // The block pattern (upper triangle, one entry a cell) as CHOLMOD's
  // symmetric pattern matrix; cell_offset_ is sorted by column, then row.
  std::vector<int> outer(column_cells_.begin(), column_cells_.end());
  std::vector<int> inner(cell_offset_.size());
  for (size_t k = 0; k < cell_offset_.size(); ++k) {
    inner[k] = static_cast<int>(cell_offset_[k].first & 0xffffffffu);
  }
  cholmod_common common;
  cholmod_start(&common);
  common.print = 0;
  common.supernodal = CHOLMOD_SIMPLICIAL;  // column counts, no row indexes
  cholmod_sparse pattern{};
  pattern.nrow = num_blocks;
  pattern.ncol = num_blocks;
  pattern.nzmax = inner.size();
  pattern.p = outer.data();
  pattern.i = inner.data();
  pattern.stype = 1;
  pattern.itype = CHOLMOD_INT;
  pattern.xtype = CHOLMOD_PATTERN;
  pattern.dtype = CHOLMOD_DOUBLE;
  pattern.sorted = 1;
  pattern.packed = 1;
  cholmod_factor* factor = cholmod_analyze(&pattern, &common);
  FactorEstimate estimate = dense;  // the analysis failed: dense
  if (factor != nullptr) {
    // Column j of the block factor is block perm[j] with count[j] blocks
    // (its diagonal one included): its diagonal block's upper triangle and
    // the rows below at the mean block size. Its t-th scalar column has
    // size - t + below entries.
    const int* perm = static_cast<const int*>(factor->Perm);
    const int* count = static_cast<const int*>(factor->ColCount);
    const double mean_size = n / num_blocks;
    estimate = {};
    for (int j = 0; j < num_blocks; ++j) {
      const int size = block_size_[perm[j]];
      const double below = (count[j] - 1) * mean_size;
      estimate.entries += size * (size + 1) / 2.0 + size * below;
      for (int t = 0; t < size; ++t) {
        const double column = size - t + below;
        estimate.flops += column * column;
      }
    }
    cholmod_free_factor(&factor, &common);
  }
  cholmod_finish(&common);
  return {std::min(estimate.entries, dense.entries),
          std::min(estimate.flops, dense.flops)};
}

void SchurBundleAdjuster::MultiplyReduced(const Eigen::VectorXd& x,
                                          Eigen::VectorXd* y) const {
  y->setZero(num_scalars_);
  double* out = y->data();
  const double* in = x.data();
  for (size_t cb = 0; cb < block_size_.size(); ++cb) {
    const int cols = block_size_[cb];
    const int col_offset = block_offset_[cb];
    const double* column = &values_[column_begin_[cb]];
    for (size_t k = column_cells_[cb]; k < column_cells_[cb + 1]; ++k) {
      const int rb = static_cast<int>(cell_offset_[k].first & 0xffffffffu);
      const double* cell =
          column + static_cast<size_t>(cell_offset_[k].second) * cols;
      const int rows = block_size_[rb];
      const int row_offset = block_offset_[rb];
      if (rb == static_cast<int>(cb)) {
        // The diagonal block: its upper triangle, mirrored.
        for (int c = 0; c < cols; ++c) {
          const double* values = cell + static_cast<size_t>(c) * rows;
          double sum = values[c] * in[col_offset + c];
          for (int r = 0; r < c; ++r) {
            out[row_offset + r] += values[r] * in[col_offset + c];
            sum += values[r] * in[row_offset + r];
          }
          out[col_offset + c] += sum;
        }
        continue;
      }
      // An off-diagonal block M: y_r += M x_c and y_c += M^T x_r.
      for (int c = 0; c < cols; ++c) {
        const double* values = cell + static_cast<size_t>(c) * rows;
        const double xc = in[col_offset + c];
        double sum = 0;
        for (int r = 0; r < rows; ++r) {
          out[row_offset + r] += values[r] * xc;
          sum += values[r] * in[row_offset + r];
        }
        out[col_offset + c] += sum;
      }
    }
  }
}

bool SchurBundleAdjuster::SolveIterative(const Eigen::VectorXd& rhs,
                                         double relative_tolerance,
                                         const VectorFunction& multiply,
                                         const VectorFunction* coarse,
                                         Eigen::VectorXd* step,
                                         int* iterations) const {
  const int n = num_scalars_;
  *iterations = 0;
  // The Schur-Jacobi preconditioner: the inverse of each group's diagonal
  // block of the reduced system (PreconditionerGroups; diagonal blocks' upper
  // triangles mirrored), packed.
  constexpr int kMaxGroupSize = 6 + kMaxNumParams;
  using Block = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0,
                              kMaxGroupSize, kMaxGroupSize>;
  using Vector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxGroupSize, 1>;
  const size_t num_groups = preconditioner_groups_.size();
  auto group_size = [&](size_t g) {
    const auto& [first, second] = preconditioner_groups_[g];
    return block_size_[first] + (second >= 0 ? block_size_[second] : 0);
  };
  std::vector<size_t> inverse_begin(num_groups + 1, 0);
  for (size_t g = 0; g < num_groups; ++g) {
    inverse_begin[g + 1] =
        inverse_begin[g] + static_cast<size_t>(group_size(g)) * group_size(g);
  }
  std::vector<double> inverses(inverse_begin[num_groups]);
  for (size_t g = 0; g < num_groups; ++g) {
    const auto& [first, second] = preconditioner_groups_[g];
    const int size = group_size(g);
    Block d(size, size);
    int offset = 0;
    for (const int b : {first, second}) {
      if (b < 0) continue;
      const double* cell = &values_[ValueIndex(b, b)];
      for (int c = 0; c < block_size_[b]; ++c) {
        for (int r = 0; r <= c; ++r) {
          d(offset + r, offset + c) = d(offset + c, offset + r) =
              cell[static_cast<size_t>(c) * block_size_[b] + r];
        }
      }
      offset += block_size_[b];
    }
    if (second >= 0) {
      // The coupling cell (first < second: stored in second's column).
      const double* cell = &values_[ValueIndex(first, second)];
      const int rows = block_size_[first];
      for (int c = 0; c < block_size_[second]; ++c) {
        for (int r = 0; r < rows; ++r) {
          d(r, rows + c) = d(rows + c, r) =
              cell[static_cast<size_t>(c) * rows + r];
        }
      }
    }
    const Eigen::LLT<Block> llt(d);
    if (llt.info() != Eigen::Success) return false;
    Eigen::Map<Block>(&inverses[inverse_begin[g]], size, size) =
        llt.solve(Block::Identity(size, size));
  }
  auto precondition = [&](const Eigen::VectorXd& r, Eigen::VectorXd* z) {
    Vector local;
    for (size_t g = 0; g < num_groups; ++g) {
      const auto& [first, second] = preconditioner_groups_[g];
      const int size = group_size(g);
      const Eigen::Map<const Block> inverse(&inverses[inverse_begin[g]], size,
                                            size);
      if (second < 0) {
        z->segment(block_offset_[first], size).noalias() =
            inverse * r.segment(block_offset_[first], size);
        continue;
      }
      const int rows = block_size_[first];
      local.resize(size);
      local.head(rows) = r.segment(block_offset_[first], rows);
      local.tail(size - rows) = r.segment(block_offset_[second], size - rows);
      local = (inverse * local).eval();
      z->segment(block_offset_[first], rows) = local.head(rows);
      z->segment(block_offset_[second], size - rows) = local.tail(size - rows);
    }
    if (coarse != nullptr) (*coarse)(r, z);
  };
  step->setZero(n);
  const double rhs_norm = rhs.norm();
  if (!(rhs_norm > 0)) return std::isfinite(rhs_norm);
  const double tolerance = relative_tolerance * rhs_norm;
  Eigen::VectorXd r = rhs, z(n), p(n), q(n);
  precondition(r, &z);
  p = z;
  double rz = r.dot(z);
  double model = 0;  // Q_i = x_i^T S x_i / 2 - b^T x_i = -x_i^T (b + r_i) / 2
  for (int i = 0; i < solver_options_.max_cg_iterations; ++i) {
    multiply(p, &q);
    const double pq = p.dot(q);
    if (!(pq > 0)) {
      // Not positive definite along p: a failure before any step, else the
      // step so far (a descent direction of the model).
      return i > 0;
    }
    const double alpha = rz / pq;
    *step += alpha * p;
    r -= alpha * q;
    *iterations = i + 1;
    if (r.norm() <= tolerance) break;
    if (model_tolerance_ > 0) {
      const double next_model = -0.5 * step->dot(rhs + r);
      if (next_model < 0 &&
          (i + 1) * (next_model - model) / next_model < model_tolerance_) {
        break;
      }
      model = next_model;
    }
    precondition(r, &z);
    const double rz_next = r.dot(z);
    p = z + (rz_next / rz) * p;
    rz = rz_next;
  }
  return true;
}

void SchurBundleAdjuster::BuildPreconditionerGroups() {
  // Each camera block's refined pose blocks (-2: more than one).
  std::vector<int> user(block_size_.size(), -1);
  for (size_t i = 0; i < poses_.size(); ++i) {
    const int a = pose_block_[i];
    const int c = camera_block_[poses_[i].camera];
    // (A camera joined to its pose's block is in that block's group.)
    if (a < 0 || c < 0 || a == c) continue;
    user[c] = user[c] == -1 ? a : -2;
  }
  std::vector<int> partner(block_size_.size(), -1);
  std::vector<bool> grouped(block_size_.size(), false);
  for (size_t c = 0; c < block_size_.size(); ++c) {
    const int a = user[c];
    if (a < 0) continue;
    // The coupling cell exists when the pose has a weighed observation.
    if (FindCell(a, static_cast<int>(c)) < 0) continue;
    partner[a] = static_cast<int>(c);
    grouped[c] = true;
  }
  for (size_t b = 0; b < block_size_.size(); ++b) {
    if (!grouped[b]) {
      preconditioner_groups_.push_back({static_cast<int>(b), partner[b]});
    }
  }
}

void SchurBundleAdjuster::BuildCoarseClusters() {
  coarse_cluster_.assign(poses_.size(), -1);
  num_coarse_clusters_ = 0;
  const int size = solver_options_.coarse_cluster_size;
  if (size <= 0) return;
  // The nodes: the refined poses (held ones do not move).
  std::vector<int> node(poses_.size(), -1), node_pose;
  for (size_t i = 0; i < poses_.size(); ++i) {
    if (pose_block_[i] < 0 || poses_[i].free.empty()) continue;
    node[i] = static_cast<int>(node_pose.size());
    node_pose.push_back(static_cast<int>(i));
  }
  const int num_nodes = static_cast<int>(node_pose.size());
  if (num_nodes < 2) return;
  std::vector<double> num_observations(num_nodes, 0.0);
  for (size_t k = 0; k < observations_.size(); ++k) {
    const int a = node[observations_[k].pose];
    if (a >= 0 && Weight(k) > 0) ++num_observations[a];
  }
  // A point's pairs from at most this many of its observations (evenly
  // spread), each weighed by its share of the point's pairs: a track of 60
  // images would count 1,770 pairs.
  constexpr int kMaxSampled = 16;
  CouplingGraph graph(num_nodes);
  std::vector<int> seen;
  for (size_t p = 0; p + 1 < point_begin_.size(); ++p) {
    seen.clear();
    for (uint32_t k = point_begin_[p]; k < point_begin_[p + 1]; ++k) {
      const int a = node[observations_[k].pose];
      if (a >= 0 && Weight(k) > 0) seen.push_back(a);
    }
    const int num_seen = static_cast<int>(seen.size());
    if (num_seen < 2) continue;
    const int m = std::min(num_seen, kMaxSampled);
    const double scale =
        static_cast<double>(num_seen) * (num_seen - 1) / (m * (m - 1));
    for (int i = 1; i < m; ++i) {
      const int a = seen[static_cast<size_t>(i) * num_seen / m];
      for (int j = 0; j < i; ++j) {
        const int b = seen[static_cast<size_t>(j) * num_seen / m];
        graph.Add(a, b,
                  scale / std::sqrt(num_observations[a] * num_observations[b]));
      }
    }
  }
  const int max_clusters = std::max(1, solver_options_.coarse_max_clusters);
  const int cluster_size =
      std::max(size, (num_nodes + max_clusters - 1) / max_clusters);
  const std::vector<int> cluster =
      AggregateClusters(graph, cluster_size, &num_coarse_clusters_);
  for (int a = 0; a < num_nodes; ++a) {
    coarse_cluster_[node_pose[a]] = cluster[a];
  }
  std::ostringstream why;
  why << "; coarse level: " << num_coarse_clusters_ << " clusters of up to "
      << cluster_size << " images";
  linear_solver_reason_ += why.str();
}

void SchurBundleAdjuster::AddCellsToCoarseSystem(
    const std::vector<CoarsePose>& coarse_poses, CoarseSystem* system) const {
  // The pose whose free coordinates open each block (-1: a camera's).
  std::vector<int> block_pose(block_size_.size(), -1);
  for (size_t i = 0; i < poses_.size(); ++i) {
    if (pose_block_[i] >= 0 && coarse_poses[i].cluster >= 0) {
      block_pose[pose_block_[i]] = static_cast<int>(i);
    }
  }
  for (size_t cb = 0; cb < block_size_.size(); ++cb) {
    if (block_pose[cb] < 0) continue;
    const CoarsePose& col_pose = coarse_poses[block_pose[cb]];
    const int cols = block_size_[cb];
    const double* column = &values_[column_begin_[cb]];
    for (size_t k = column_cells_[cb]; k < column_cells_[cb + 1]; ++k) {
      const int rb = static_cast<int>(cell_offset_[k].first & 0xffffffffu);
      if (block_pose[rb] < 0) continue;
      const CoarsePose& row_pose = coarse_poses[block_pose[rb]];
      const int rows = block_size_[rb];
      const Eigen::Map<const Eigen::MatrixXd> cell(
          column + static_cast<size_t>(cell_offset_[k].second) * cols, rows,
          cols);
      // (A diagonal block: its upper triangle, mirrored.)
      const Eigen::MatrixXd pose_cell =
          rb == static_cast<int>(cb)
              ? Eigen::MatrixXd(
                    cell.topLeftCorner(row_pose.num_free, col_pose.num_free)
                        .selfadjointView<Eigen::Upper>())
              : Eigen::MatrixXd(
                    cell.topLeftCorner(row_pose.num_free, col_pose.num_free));
      const Eigen::Matrix<double, kNumCoarseModes, kNumCoarseModes> update =
          row_pose.motion.topRows(row_pose.num_free).transpose() * pose_cell *
          col_pose.motion.topRows(col_pose.num_free);
      if (rb == static_cast<int>(cb)) {
        system->AddDiagonal(row_pose.cluster, update);
      } else {
        system->AddPair(row_pose.cluster, col_pose.cluster, update);
      }
    }
  }
}

size_t SchurBundleAdjuster::CellTableBytes() const {
  return point_block_ids_begin_.capacity() * sizeof(size_t) +
         point_cells_begin_.capacity() * sizeof(size_t) +
         point_block_ids_.capacity() * sizeof(int) +
         point_cells_.capacity() * sizeof(uint32_t);
}

void SchurBundleAdjuster::AnalyzeReducedSystem() {
  cholmod_.reset();
  iterative_ = false;
  factor_bytes_estimate_ = 0;
  factor_flops_estimate_ = 0;
  preconditioner_groups_.clear();
  const SchurLinearSolver type = solver_options_.linear_solver;
  // Iterative, or auto: the factor's size before it is allocated.
  std::string estimate;
  if (num_scalars_ > 0 && (type == SchurLinearSolver::kAuto ||
                           type == SchurLinearSolver::kIterative)) {
    const FactorEstimate factor = EstimateFactor();
    factor_bytes_estimate_ = sizeof(double) * factor.entries;
    factor_flops_estimate_ = factor.flops;
    const double mib = factor_bytes_estimate_ / 1048576.0;
    const double gflops = factor.flops * 1e-9;
    std::ostringstream size, rule;
    size << std::setprecision(3) << "factor ~" << mib << " MiB, ~" << gflops
         << " GFlop by the block pattern";
    rule << " (auto: iterative above " << solver_options_.max_factor_mib
         << " MiB or " << solver_options_.max_factor_gflops << " GFlop)";
    const bool too_large = mib > solver_options_.max_factor_mib ||
                           gflops > solver_options_.max_factor_gflops;
    if (type == SchurLinearSolver::kIterative || too_large) {
      BuildPreconditionerGroups();
    }
    if (type == SchurLinearSolver::kIterative) {
      iterative_ = true;
      linear_solver_reason_ =
          "iterative (conjugate gradients, Schur-Jacobi): asked, " + size.str();
      return;
    }
    if (too_large) {
      iterative_ = true;
      linear_solver_reason_ =
          "iterative (conjugate gradients, Schur-Jacobi): " + size.str() +
          rule.str();
      return;
    }
    estimate = "; " + size.str() + rule.str();
  }
  LayOutValues(/*local_only=*/false);
  BuildScalarPattern();
  if (num_scalars_ == 0 || type == SchurLinearSolver::kSimplicial) {
    linear_solver_reason_ = "simplicial (Eigen): asked";
    return;
  }
  auto cholmod = std::make_unique<Cholmod>();
  cholmod_common& common = cholmod->common;
  const bool automatic = type == SchurLinearSolver::kAuto;
  common.supernodal = automatic ? CHOLMOD_AUTO : CHOLMOD_SUPERNODAL;
  common.supernodal_switch = kSupernodalMinFlopsPerEntry;
  cholmod_sparse reduced =
      Cholmod::View(num_scalars_, &outer_, &inner_, &values_);
  cholmod->factor = cholmod_analyze(&reduced, &common);
  if (cholmod->factor == nullptr) {
    linear_solver_reason_ =
        "simplicial (Eigen): CHOLMOD's analysis failed (status " +
        std::to_string(common.status) + ")" + estimate;
    LOG(WARNING) << "Schur bundle adjustment: " << linear_solver_reason_;
    return;
  }
  std::ostringstream why;
  why << std::setprecision(3) << ": factor " << common.lnz << " entries, "
      << common.fl << " flops, " << common.fl / std::max(1.0, common.lnz)
      << " per entry ("
      << (automatic
              ? "auto: supernodal from " + std::to_string(static_cast<int>(
                                               kSupernodalMinFlopsPerEntry))
              : std::string("asked"))
      << ")";
  if (!cholmod->factor->is_super) {
    linear_solver_reason_ = "simplicial (Eigen)" + why.str() + estimate;
    return;
  }
  linear_solver_reason_ = "supernodal (CHOLMOD)" + why.str() + estimate;
  cholmod_ = std::move(cholmod);
}

bool SchurBundleAdjuster::SolveSupernodal(const Eigen::VectorXd& rhs,
                                          Eigen::VectorXd* step) {
  cholmod_common& common = cholmod_->common;
  cholmod_factor* factor = cholmod_->factor;
  cholmod_sparse reduced =
      Cholmod::View(num_scalars_, &outer_, &inner_, &values_);
  if (!cholmod_factorize(&reduced, factor, &common) ||
      common.status != CHOLMOD_OK || factor->minor < factor->n) {
    if (common.status < CHOLMOD_OK) {
      LOG(WARNING) << "Schur bundle adjustment: CHOLMOD's factorisation "
                      "failed (status "
                   << common.status << ")";
    }
    return false;  // not positive definite (minor: the failed column)
  }
  cholmod_dense b{};
  b.nrow = num_scalars_;
  b.ncol = 1;
  b.nzmax = num_scalars_;
  b.d = num_scalars_;
  b.x = const_cast<double*>(rhs.data());
  b.xtype = CHOLMOD_REAL;
  b.dtype = CHOLMOD_DOUBLE;
  cholmod_dense* x = cholmod_solve(CHOLMOD_A, factor, &b, &common);
  if (x == nullptr) return false;
  *step = Eigen::Map<const Eigen::VectorXd>(static_cast<const double*>(x->x),
                                            num_scalars_);
  cholmod_free_dense(&x, &common);
  return true;
}

int SchurBundleAdjuster::FindCell(int row_block, int col_block) const {
  // The column's cells, by row block.
  const auto begin = cell_offset_.begin() + column_cells_[col_block];
  const auto end = cell_offset_.begin() + column_cells_[col_block + 1];
  const uint64_t cell =
      static_cast<uint64_t>(col_block) << 32 | static_cast<uint32_t>(row_block);
  const auto it =
      std::lower_bound(begin, end, cell,
                       [](const std::pair<uint64_t, int>& entry,
                          uint64_t value) { return entry.first < value; });
  return it != end && it->first == cell ? it->second : -1;
}

size_t SchurBundleAdjuster::ValueIndex(int row_block, int col_block) const {
  const int offset = FindCell(row_block, col_block);
  CHECK_GE(offset, 0);
  return column_begin_[col_block] +
         static_cast<size_t>(offset) * block_size_[col_block];
}

CostStall::CostStall(int num_steps, double relative_decrease)
    : num_steps_(num_steps), relative_decrease_(relative_decrease) {}

bool CostStall::Add(double cost) {
  if (num_steps_ <= 0) return false;
  costs_.push_back(cost);
  if (static_cast<int>(costs_.size()) > num_steps_ + 1) costs_.pop_front();
  return static_cast<int>(costs_.size()) == num_steps_ + 1 &&
         costs_.front() - costs_.back() < relative_decrease_ * costs_.back();
}

SchurBundleAdjuster::Summary SchurBundleAdjuster::Solve(
    const ceres::Solver::Options& options, double rejected_start_radius,
    int stall_num_steps, double stall_relative_decrease,
    double model_tolerance) {
  CHECK(model_tolerance >= 0 && model_tolerance < 1);
  model_tolerance_ = model_tolerance;
  Summary summary;
  CostStall stall(stall_num_steps, stall_relative_decrease);
  Timer linear_timer;
  // The parameters: poses (7 each), cameras (kMaxNumParams each), points.
  const size_t num_points = point_blocks_.size();
  std::vector<double> poses(7 * poses_.size()),
      cameras(kMaxNumParams * cameras_.size()), points(3 * num_points);
  for (size_t i = 0; i < poses_.size(); ++i) {
    std::copy(poses_[i].rotation, poses_[i].rotation + 4, &poses[7 * i]);
    std::copy(poses_[i].position, poses_[i].position + 3, &poses[7 * i + 4]);
  }
  for (size_t i = 0; i < cameras_.size(); ++i) {
    std::copy(cameras_[i].params, cameras_[i].params + cameras_[i].num_params,
              &cameras[kMaxNumParams * i]);
  }
  for (size_t i = 0; i < num_points; ++i) {
    std::copy(point_blocks_[i], point_blocks_[i] + 3, &points[3 * i]);
  }
  // The observations' weights, read once (the weights may change between
  // solves, not within one).
  weights_.resize(observations_.size());
  for (size_t k = 0; k < observations_.size(); ++k) {
    const Observation& observation = observations_[k];
    weights_[k] = (*poses_[observation.pose].weights)[observation.point2D_idx];
  }
  // Which points are eliminated (the others are held in this solve).
  std::vector<bool> active(num_points, false);
  for (size_t p = 0; p < num_points; ++p) {
    if (point_constant_[p]) continue;
    int num_live = 0;
    for (uint32_t k = point_begin_[p]; k < point_begin_[p + 1]; ++k) {
      num_live += Weight(k) > 0;
    }
    active[p] = num_live >= 2;
  }
  if (values_.empty()) {
    NumberBlocks();
    BuildStructure(/*local_only=*/false);
    AnalyzeReducedSystem();
    // (The factorisations laid out the values in their analysis.)
    const double values_mib = num_values_ * sizeof(double) / 1048576.0;
    implicit_ = iterative_ && values_mib >= solver_options_.implicit_min_mib;
    if (implicit_) {
      // The full structure only chose the solver (its factor's size).
      BuildStructure(/*local_only=*/true);
      std::ostringstream why;
      why << std::setprecision(3) << "; implicit (the reduced system, "
          << values_mib << " MiB, not formed: from "
          << solver_options_.implicit_min_mib << " MiB)";
      linear_solver_reason_ += why.str();
    }
    if (iterative_) LayOutValues(/*local_only=*/implicit_);
    if (iterative_) BuildCoarseClusters();
    VLOG(1) << "Schur bundle adjustment: " << num_scalars_
            << " reduced parameters; " << linear_solver_reason_;
  }
  const int n = num_scalars_;
  const double reuse_min_radius = solver_options_.reuse_min_radius;
  const int point_iterations = solver_options_.point_iterations;
  summary.num_reduced_parameters = n;
  summary.num_reduced_nonzeros = values_.size();
  summary.supernodal = cholmod_ != nullptr;
  summary.iterative = iterative_;
  summary.implicit = implicit_;
  summary.factor_bytes_estimate = factor_bytes_estimate_;
  summary.factor_flops_estimate = factor_flops_estimate_;
  summary.linear_solver_reason = linear_solver_reason_;
  // The factorisations' view of the reduced system (not the iterative
  // solver's: it has no scalar pattern).
  const auto reduced = [&] {
    return Eigen::Map<const SparseMatrix>(
        n, n, static_cast<int>(values_.size()), outer_.data(), inner_.data(),
        values_.data());
  };
  const bool simplicial = n > 0 && cholmod_ == nullptr && !iterative_;
  Eigen::SimplicialLLT<SparseMatrix, Eigen::Upper> llt;
  if (simplicial) llt.analyzePattern(reduced());
  // Iterative: the first right-hand side's norm (the forcing term's scale).
  double first_rhs_norm = -1;

  auto damped = [&options](double diagonal, double radius) {
    return std::clamp(diagonal, options.min_lm_diagonal,
                      options.max_lm_diagonal) /
           radius;
  };
  // S(row_block, col_block) += M (row_block <= col_block) at `values`, the
  // cell's first value (the cell layout: column-major, M's rows high).
  auto add_at = [](double* values, const auto& m) {
    const int rows = static_cast<int>(m.rows());
    for (int c = 0; c < m.cols(); ++c) {
      for (int r = 0; r < rows; ++r) values[c * rows + r] += m(r, c);
    }
  };
  auto add_cell = [&](int row_block, int col_block, const auto& m) {
    add_at(&values_[ValueIndex(row_block, col_block)], m);
  };
  // Adds M (rows: lin_k's variables, columns: lin_l's) of a pair k < l (or
  // k == l with `same`) and its transpose to the upper block triangle.
  auto add_pair = [&](const Linearization& k, const Linearization& l,
                      const auto& m, bool same) {
    for (int i = 0; i < k.num_blocks; ++i) {
      const int rb = k.blocks[i];
      const int rows = block_size_[rb];
      for (int j = 0; j < l.num_blocks; ++j) {
        const int cb = l.blocks[j];
        const int cols = block_size_[cb];
        const auto sub = m.block(k.cols[i], l.cols[j], rows, cols);
        if (same) {
          if (rb <= cb) add_cell(rb, cb, sub);
        } else if (rb < cb) {
          add_cell(rb, cb, sub);
        } else if (rb > cb) {
          add_cell(cb, rb, sub.transpose());
        } else {
          add_cell(rb, cb, sub + sub.transpose());
        }
      }
    }
  };
  auto block_vector = [this](const Linearization& lin, Eigen::VectorXd* v,
                             const auto& local, double sign) {
    for (int i = 0; i < lin.num_blocks; ++i) {
      const int b = lin.blocks[i];
      v->segment(block_offset_[b], block_size_[b]) +=
          sign * local.segment(lin.cols[i], block_size_[b]);
    }
  };
  auto gather = [this](const Linearization& lin, const Eigen::VectorXd& v) {
    Eigen::Matrix<double, Eigen::Dynamic, 1, 0, Linearization::kMaxCols, 1>
        local(lin.A.cols());
    for (int i = 0; i < lin.num_blocks; ++i) {
      const int b = lin.blocks[i];
      local.segment(lin.cols[i], block_size_[b]) =
          v.segment(block_offset_[b], block_size_[b]);
    }
    return local;
  };
  using Matrix3 = Eigen::Matrix3d;
  // A point's damped 3x3 block inverted (a pseudo-inverse if singular).
  auto invert = [](const Matrix3& v) -> Matrix3 {
    const Eigen::LLT<Matrix3> llt(v);
    if (llt.info() == Eigen::Success) return llt.solve(Matrix3::Identity());
    return v.completeOrthogonalDecomposition().pseudoInverse();
  };

  std::vector<Linearization> lins;
  // The observations' linearisations kept from the last elimination, point
  // by point while within SchurSolverOptions::max_jacobian_store_mib: the
  // back-substitution, and the elimination of a try after a rejected step
  // (the same parameters), read them instead of evaluating the Jacobians
  // again; the same values, so the same result to the bit. Per weighed
  // observation: r (2), B (2 x 3, column-major), A (2 x its columns,
  // row-major). The members' buffers, laid out for this solve's weights.
  // (SchurSolverOptions::implicit_single_precision: in floats.)
  const bool single = implicit_ && solver_options_.implicit_single_precision;
  jacobian_store_begin_.assign(num_points + 1, 0);
  jacobian_stored_.assign(num_points, 0);
  size_t num_stored = 0;
  if (implicit_ || solver_options_.max_jacobian_store_mib > 0) {
    // (The implicit product reads every observation's.)
    const double max_values = implicit_
                                  ? std::numeric_limits<double>::infinity()
                                  : solver_options_.max_jacobian_store_mib *
                                        1048576.0 / sizeof(double);
    size_t size = 0;
    for (size_t p = 0; p < num_points; ++p) {
      jacobian_store_begin_[p] = size;
      size_t need = 0;
      for (uint32_t k = point_begin_[p]; k < point_begin_[p + 1]; ++k) {
        if (Weight(k) > 0) {
          need += 8 + 2 * static_cast<size_t>(NumColumns(observations_[k]));
        }
      }
      if (need > 0 && static_cast<double>(size + need) <= max_values) {
        jacobian_stored_[p] = 1;
        size += need;
        ++num_stored;
      }
    }
    jacobian_store_begin_[num_points] = size;
    // A solve uses one of the two stores: the other's memory is released
    // (up to max_jacobian_store_mib of doubles beside the floats).
    if (single) {
      jacobian_store_.reset();
      jacobian_store_capacity_ = 0;
    } else {
      jacobian_store_single_.reset();
      jacobian_store_single_capacity_ = 0;
    }
    // Not zeroed (a point's values are written before they are read), in
    // huge pages (a 4 KiB page's fault at each first write: 75,000 of them
    // for a 300-image courtyard's three adjustments).
    if (single && size > jacobian_store_single_capacity_) {
      jacobian_store_single_.reset();
      jacobian_store_single_.reset(new float[size]);
      AdviseHugePages(jacobian_store_single_.get(), size * sizeof(float));
      jacobian_store_single_capacity_ = size;
    } else if (!single && size > jacobian_store_capacity_) {
      jacobian_store_.reset();
      jacobian_store_.reset(new double[size]);
      AdviseHugePages(jacobian_store_.get(), size * sizeof(double));
      jacobian_store_capacity_ = size;
    }
  }
  const std::vector<size_t>& store_begin = jacobian_store_begin_;
  const std::vector<char>& stored = jacobian_stored_;
  double* const store = jacobian_store_.get();
  float* const store_single = jacobian_store_single_.get();
  summary.jacobian_store_bytes =
      store_begin[num_points] * (single ? sizeof(float) : sizeof(double));
  summary.jacobian_store_single = single;
  const bool avx2 =
      single && solver_options_.implicit_avx2 && Avx2ProductAvailable();
  summary.implicit_avx2 = avx2;
  // Implicit: the product's poses, the store's order.
  product_poses_begin_.assign(implicit_ ? num_points + 1 : 0, 0);
  product_poses_.clear();
  if (implicit_) {
    for (size_t p = 0; p < num_points; ++p) {
      product_poses_begin_[p] = product_poses_.size();
      for (uint32_t k = point_begin_[p]; k < point_begin_[p + 1]; ++k) {
        if (Weight(k) > 0) product_poses_.push_back(observations_[k].pose);
      }
    }
    product_poses_begin_[num_points] = product_poses_.size();
  }
  VLOG(1) << "Schur bundle adjustment: Jacobians kept for " << num_stored
          << " of " << num_points << " points ("
          << summary.jacobian_store_bytes / 1048576.0 << " MiB"
          << (single ? " in single precision" : "") << ")";
  // Whether the store holds the linearisations at the current parameters.
  bool store_valid = false;
  // lins into the store (point p's) and back.
  auto keep = [&](size_t p) {
    auto write = [&](auto* out) {
      using T = std::remove_pointer_t<decltype(out)>;
      for (const Linearization& lin : lins) {
        out[0] = static_cast<T>(lin.r[0]);
        out[1] = static_cast<T>(lin.r[1]);
        std::copy(lin.B.data(), lin.B.data() + 6, out + 2);
        std::copy(lin.A.data(), lin.A.data() + lin.A.size(), out + 8);
        out += 8 + lin.A.size();
      }
    };
    single ? write(&store_single[store_begin[p]])
           : write(&store[store_begin[p]]);
  };
  auto restore = [&](size_t p) {
    auto read = [&](const auto* in) {
      for (uint32_t k = point_begin_[p]; k < point_begin_[p + 1]; ++k) {
        if (!(Weight(k) > 0)) continue;
        lins.emplace_back();
        Linearization& lin = lins.back();
        Describe(observations_[k], &lin);
        lin.r = Eigen::Vector2d(in[0], in[1]);
        std::copy(in + 2, in + 8, lin.B.data());
        std::copy(in + 8, in + 8 + lin.A.size(), lin.A.data());
        in += 8 + lin.A.size();
      }
    };
    single ? read(&store_single[store_begin[p]]) : read(&store[store_begin[p]]);
  };
  // Each block's diagonal cell (its first value in values_).
  std::vector<size_t> diagonal_cells(block_size_.size());
  for (size_t b = 0; b < block_size_.size(); ++b) {
    diagonal_cells[b] = ValueIndex(static_cast<int>(b), static_cast<int>(b));
  }
  // Point p's weighed observations linearised at the current parameters
  // into lins: restored from the store when it holds them, else evaluated
  // (and kept when the store has room for them). `prefetch`: each
  // observation's diagonal cells, updated next by the elimination (A_k^T
  // A_k), prefetched while the next observations are linearised. False
  // when a residual or Jacobian is not finite (lins partly filled).
  auto linearize = [&](size_t p, bool prefetch) {
    lins.clear();
    if (store_valid && stored[p]) {
      restore(p);
      return true;
    }
    for (uint32_t k = point_begin_[p]; k < point_begin_[p + 1]; ++k) {
      if (!(Weight(k) > 0)) continue;
      lins.emplace_back();
      double residual[2];
      if (!Evaluate(k, &points[3 * p], poses, cameras, residual,
                    &lins.back())) {
        return false;
      }
      for (int i = 0; i < lins.back().num_blocks && prefetch; ++i) {
        const int b = lins.back().blocks[i];
        PrefetchCell(&values_[diagonal_cells[b]],
                     block_size_[b] * block_size_[b]);
      }
    }
    if (stored[p]) keep(p);
    return true;
  };
  // The current point's cell table and its observations' blocks in it.
  const uint32_t* cells = nullptr;
  std::vector<int> local;
  // The first value of the cell of the point's blocks i <= j (local).
  auto cell = [&](int i, int j) {
    return &values_[cells[static_cast<size_t>(j) * (j + 1) / 2 + i]];
  };
  // The same through the table (`cells` non-null) or the search: the cell
  // of row block rb and column block cb (rb <= cb), local indexes li, lj.
  auto find = [&](int rb, int li, int cb, int lj) {
    return cells != nullptr ? cell(li, lj) : &values_[ValueIndex(rb, cb)];
  };
  std::vector<PoseLinearization> pose_lins(pose_residuals_.size());
  using Wmat =
      Eigen::Matrix<double, Eigen::Dynamic, 3, 0, Linearization::kMaxCols, 3>;
  std::vector<Wmat> w, q;
  // Implicit (SchurSolverOptions::implicit): each point's damped V^-1 from
  // the elimination, and the camera priors' diagonal (the product's terms
  // besides the observations' and the damping's).
  std::vector<Matrix3> point_v_inv(implicit_ ? num_points : 0);
  Eigen::VectorXd prior_diagonal = Eigen::VectorXd::Zero(n);
  // Implicit: point p's share of the local cells of the Schur complement
  // (the diagonal blocks and each observation's pose and camera blocks, the
  // cells the preconditioner reads): S(b, c) -= G_b V^-1 G_c^T, G_b the sum
  // of the rows of block b in its observations' W_k (its Q_k likewise for
  // G_b V^-1): the same cells as the pairs' updates, the pairs summed first.
  std::vector<std::pair<int, int>> block_refs;  // (block, k << 1 | i)
  std::vector<int> distinct;
  std::vector<Wmat> g_sums, qg_sums;
  std::vector<std::pair<int, int>> observation_cells;
  auto subtract_local_schur = [&] {
    block_refs.clear();
    for (size_t k = 0; k < lins.size(); ++k) {
      for (int i = 0; i < lins[k].num_blocks; ++i) {
        block_refs.push_back({lins[k].blocks[i], static_cast<int>(k << 1) | i});
      }
    }
    std::sort(block_refs.begin(), block_refs.end());
    distinct.clear();
    g_sums.clear();
    qg_sums.clear();
    for (size_t r = 0; r < block_refs.size(); ++r) {
      const int b = block_refs[r].first;
      const int k = block_refs[r].second >> 1;
      const int col = lins[k].cols[block_refs[r].second & 1];
      if (distinct.empty() || distinct.back() != b) {
        distinct.push_back(b);
        g_sums.push_back(Wmat::Zero(block_size_[b], 3));
        qg_sums.push_back(Wmat::Zero(block_size_[b], 3));
      }
      g_sums.back() += w[k].middleRows(col, block_size_[b]);
      qg_sums.back() += q[k].middleRows(col, block_size_[b]);
    }
    auto subtract = [&](size_t i, size_t j) {
      const int rb = distinct[i], cb = distinct[j];
      Eigen::Map<Eigen::MatrixXd>(&values_[ValueIndex(rb, cb)], block_size_[rb],
                                  block_size_[cb])
          .noalias() -= qg_sums[i] * g_sums[j].transpose();
    };
    for (size_t i = 0; i < distinct.size(); ++i) subtract(i, i);
    observation_cells.clear();
    for (const Linearization& lin : lins) {
      if (lin.num_blocks < 2) continue;
      observation_cells.push_back({std::min(lin.blocks[0], lin.blocks[1]),
                                   std::max(lin.blocks[0], lin.blocks[1])});
    }
    std::sort(observation_cells.begin(), observation_cells.end());
    observation_cells.erase(
        std::unique(observation_cells.begin(), observation_cells.end()),
        observation_cells.end());
    auto index = [&](int b) {
      return static_cast<size_t>(
          std::lower_bound(distinct.begin(), distinct.end(), b) -
          distinct.begin());
    };
    for (const auto& [rb, cb] : observation_cells)
      subtract(index(rb), index(cb));
  };
  std::vector<PairUpdate> updates;
  Eigen::VectorXd rhs(n), diagonal(n), step(n);
  double cost = Cost(poses, cameras, points);
  summary.initial_cost = cost;
  double radius = options.initial_trust_region_radius;
  double decrease_factor = 2;
  bool step_accepted = false;  // any step of this solve
  // A rejected step or failed factorisation: Ceres' cut; after a step
  // rejected before the first accepted one (`skip`), the cuts down to
  // rejected_start_radius at once (the steps there repeat the rejected one:
  // too little damping to change it).
  auto reject = [&](bool skip) {
    do {
      radius /= decrease_factor;
      decrease_factor *= 2;
    } while (skip && !step_accepted && rejected_start_radius > 0 &&
             radius > rejected_start_radius);
  };
  int num_invalid = 0;
  std::vector<double> candidate_poses, candidate_cameras, candidate_points;
  summary.num_iterations = 1;
  if (!std::isfinite(cost)) {
    summary.termination = ceres::FAILURE;
    summary.message = "residual not finite at the initial point";
    return summary;
  }
  stall.Add(cost);
  // What moves in the crawl (VLOG 3): the parameters' total change over the
  // accepted steps that lowered the cost by less than kCrawlDecrease of it.
  constexpr double kCrawlDecrease = 1e-4;
  const bool crawl_report = VLOG_IS_ON(3);
  int num_crawl_steps = 0;
  std::vector<double> crawl_rotation, crawl_position, crawl_focal, crawl_extra;
  if (crawl_report) {
    crawl_rotation.assign(poses_.size(), 0.0);
    crawl_position.assign(poses_.size(), 0.0);
    crawl_focal.assign(cameras_.size(), 0.0);
    crawl_extra.assign(cameras_.size(), 0.0);
  }
  bool check_gradient = true;
  // The reduced system kept from the last elimination for a rejected try
  // (SchurSolverOptions::reuse_min_radius): the radius its points were
  // damped with, whether values_ is in the factorisations' scalar layout,
  // and the camera damping on its diagonal.
  bool reuse = false;
  double point_radius = radius;
  bool scalar_layout = false;
  Eigen::VectorXd applied_damping = Eigen::VectorXd::Zero(n);
  // The diagonal entry of scalar i of block b, whose diagonal cell starts at
  // `cell` (ValueIndex(b, b)) in the cell layout (that cell's offset in its
  // column of cells times the block size is its first value's).
  auto diagonal_entry = [&](int b, size_t cell, int i) {
    if (!scalar_layout) return &values_[cell + i * block_size_[b] + i];
    const size_t offset = (cell - column_begin_[b]) / block_size_[b];
    return &values_[column_begin_[b] + i * column_height_[b] + offset + i];
  };
  // Implicit (SchurSolverOptions::implicit): y = S x from the kept
  // Jacobians, point by point (MultiplyPoint); plus the damping, the camera
  // priors and the pose residuals (the terms the elimination adds to the
  // diagonal blocks).
  std::vector<ProductColumns> pose_columns(implicit_ ? poses_.size() : 0);
  for (size_t i = 0; i < pose_columns.size(); ++i) {
    const ObservationBlocks blocks = Blocks(static_cast<uint32_t>(i));
    ProductColumns& columns = pose_columns[i];
    columns.count = blocks.count;
    for (int j = 0; j < blocks.count; ++j) {
      columns.offset[j] = block_offset_[blocks.block[j]];
      columns.size[j] = block_size_[blocks.block[j]];
      columns.num_cols += columns.size[j];
    }
  }
  std::vector<Eigen::Vector2d> point_ax;
  Eigen::VectorXf x_float;
  // Calls visit(records, first, count, v_inv) for each point in the product:
  // its records in the store of the precision in use, its first pose entry,
  // their count, its V^-1 (null when inactive). A template call, inlined.
  const auto for_each_product_point = [&](auto&& visit) {
    for (size_t p = 0; p < num_points; ++p) {
      const size_t first = product_poses_begin_[p];
      const size_t count = product_poses_begin_[p + 1] - first;
      if (count == 0) continue;
      const Matrix3* v_inv = active[p] ? &point_v_inv[p] : nullptr;
      if (single) {
        visit(&store_single[store_begin[p]], first, count, v_inv);
      } else {
        visit(&store[store_begin[p]], first, count, v_inv);
      }
    }
  };
  const std::function<void(const Eigen::VectorXd&, Eigen::VectorXd*)>
      multiply_implicit = [&](const Eigen::VectorXd& x, Eigen::VectorXd* y) {
        if (single) x_float = x.cast<float>();
        *y = (applied_damping + prior_diagonal).cwiseProduct(x);
        for (size_t i = 0; i < pose_residuals_.size(); ++i) {
          const int b = pose_block_[pose_residuals_[i].pose];
          if (b < 0) continue;
          const Eigen::MatrixXd& a = pose_lins[i].A;
          const auto segment = x.segment(block_offset_[b], a.cols());
          y->segment(block_offset_[b], a.cols()) +=
              a.transpose() * (a * segment);
        }
        for_each_product_point([&](const auto* records, size_t first,
                                   size_t count, const Matrix3* v_inv) {
          using Real =
              std::remove_const_t<std::remove_pointer_t<decltype(records)>>;
          if constexpr (std::is_same_v<Real, float>) {
            if (avx2) {
              MultiplyPointAvx2(records, &product_poses_[first], count,
                                pose_columns.data(), v_inv, x.data(),
                                x_float.data(), y->data(), &point_ax);
            } else {
              MultiplyPoint(records, &product_poses_[first], count,
                            pose_columns.data(), v_inv, x.data(),
                            x_float.data(), y->data(), &point_ax);
            }
          } else {
            MultiplyPoint(records, &product_poses_[first], count,
                          pose_columns.data(), v_inv, x.data(), x.data(),
                          y->data(), &point_ax);
          }
        });
      };
  const std::function<void(const Eigen::VectorXd&, Eigen::VectorXd*)>
      multiply_explicit = [this](const Eigen::VectorXd& x, Eigen::VectorXd* y) {
        MultiplyReduced(x, y);
      };
  // The coarse level (SchurSolverOptions::coarse_cluster_size): its system
  // P^T S P at each iteration's parameters and damping, from the kept
  // Jacobians (implicit, the product's terms) or the formed cells.
  summary.num_coarse_clusters = num_coarse_clusters_;
  CoarseSystem coarse;
  std::vector<CoarsePose> coarse_poses(num_coarse_clusters_ > 0 ? poses_.size()
                                                                : 0);
  std::vector<std::pair<int, Eigen::Matrix<double, 3, kNumCoarseModes>>>
      coarse_shares;
  auto build_coarse = [&] {
    const std::clock_t coarse_clock = std::clock();
    for (size_t i = 0; i < coarse_poses.size(); ++i) {
      CoarsePose& pose = coarse_poses[i];
      pose.cluster = coarse_cluster_[i];
      if (pose.cluster < 0) continue;
      const CoarseMotion motion =
          SimilarityMotion(&poses[7 * i], &poses[7 * i + 4], center_);
      pose.num_free = static_cast<int>(poses_[i].free.size());
      for (int r = 0; r < pose.num_free; ++r) {
        pose.motion.row(r) = motion.row(poses_[i].free[r]);
      }
    }
    coarse.Reset(num_coarse_clusters_);
    if (!implicit_) {
      AddCellsToCoarseSystem(coarse_poses, &coarse);
    } else {
      // The product's terms besides the points': the damping and the
      // camera priors (diagonal), the pose residuals.
      const Eigen::VectorXd diagonal_terms = applied_damping + prior_diagonal;
      for (size_t i = 0; i < coarse_poses.size(); ++i) {
        const CoarsePose& pose = coarse_poses[i];
        if (pose.cluster < 0) continue;
        const auto motion = pose.motion.topRows(pose.num_free);
        coarse.AddDiagonal(
            pose.cluster,
            motion.transpose() *
                diagonal_terms
                    .segment(block_offset_[pose_block_[i]], pose.num_free)
                    .asDiagonal() *
                motion);
      }
      for (size_t i = 0; i < pose_residuals_.size(); ++i) {
        const CoarsePose& pose = coarse_poses[pose_residuals_[i].pose];
        if (pose.cluster < 0) continue;
        const Eigen::MatrixXd am =
            pose_lins[i].A * pose.motion.topRows(pose_lins[i].A.cols());
        coarse.AddDiagonal(pose.cluster, am.transpose() * am);
      }
      for_each_product_point([&](const auto* records, size_t first,
                                 size_t count, const Matrix3* v_inv) {
        AddPointToCoarseSystem(records, &product_poses_[first], count,
                               pose_columns.data(), v_inv, coarse_poses.data(),
                               &coarse, &coarse_shares);
      });
    }
    const bool factorized = coarse.Factorize();
    VLOG(2) << "Schur bundle adjustment: coarse system of "
            << num_coarse_clusters_ << " clusters "
            << (factorized ? "factorised" : "not positive definite (unused)")
            << " in "
            << static_cast<double>(std::clock() - coarse_clock) / CLOCKS_PER_SEC
            << " CPU s";
    return factorized;
  };
  Eigen::VectorXd coarse_values;
  const VectorFunction coarse_correction = [&](const Eigen::VectorXd& r,
                                               Eigen::VectorXd* z) {
    coarse_values.setZero(coarse.Size());
    for (size_t i = 0; i < coarse_poses.size(); ++i) {
      const CoarsePose& pose = coarse_poses[i];
      if (pose.cluster < 0) continue;
      coarse_values.segment<kNumCoarseModes>(kNumCoarseModes * pose.cluster)
          .noalias() += pose.motion.topRows(pose.num_free).transpose() *
                        r.segment(block_offset_[pose_block_[i]], pose.num_free);
    }
    coarse.Solve(&coarse_values);
    for (size_t i = 0; i < coarse_poses.size(); ++i) {
      const CoarsePose& pose = coarse_poses[i];
      if (pose.cluster < 0) continue;
      z->segment(block_offset_[pose_block_[i]], pose.num_free).noalias() +=
          pose.motion.topRows(pose.num_free) *
          coarse_values.segment<kNumCoarseModes>(kNumCoarseModes *
                                                 pose.cluster);
    }
  };
  summary.termination = ceres::NO_CONVERGENCE;
  summary.message = "maximum number of iterations reached";
  using Clock = std::chrono::steady_clock;
  const auto Seconds = [](Clock::duration d) {
    return std::chrono::duration<double>(d).count();
  };
  const bool time_parts = VLOG_IS_ON(2);
  // The parts of an iteration (VLOG 2), e.g. "elimination 2.1 CPU s
  // (Jacobians 0.5, pair updates 1.2 wall s of 2.0)".
  auto elimination_parts = [&](double cpu, double wall, double jacobians,
                               double updates) {
    std::ostringstream text;
    text << std::setprecision(3) << "elimination " << cpu
         << " CPU s (Jacobians " << jacobians << ", pair updates " << updates
         << " wall s of " << wall << ")";
    return text.str();
  };
  while (summary.num_iterations <= options.max_num_iterations) {
    ThrowIfInterrupted();
    // CPU time of the iteration and of its linear solve (VLOG 2; the
    // process's: the solver runs on one thread).
    const std::clock_t iteration_clock = std::clock();
    const bool reused = reuse;
    summary.num_reused_eliminations += reused;
    // The iteration's parts (VLOG 2): CPU s of the elimination pass;
    // within it, wall-clock seconds (a steady clock, cheap enough to read
    // per point; CPU clocks are system calls) of the observations'
    // linearisation and of the pair updates S -= Q_k W_l^T, the rest being
    // each point's own work (V, W_k, Q_k, the diagonal cells, rhs).
    double elimination_cpu = 0, elimination_wall = 0, jacobian_wall = 0,
           update_wall = 0;
    if (!reuse) {
      summary.num_eliminations_from_kept_jacobians +=
          store_valid && num_stored > 0;
      const std::clock_t elimination_clock = std::clock();
      const Clock::time_point elimination_start = Clock::now();
      // Linearise at x and eliminate the points (damped by the radius).
      point_radius = radius;
      scalar_layout = false;
      std::fill(values_.begin(), values_.end(), 0.0);
      rhs.setZero();
      diagonal.setZero();
      prior_diagonal.setZero();
      double gradient_max_norm = 0;
      Eigen::VectorXd camera_gradient = Eigen::VectorXd::Zero(n);
      bool finite = true;
      for (size_t pi = 0; pi < num_points && finite; ++pi) {
        const size_t p = point_order_.empty() ? pi : point_order_[pi];
        const Clock::time_point jacobian_start =
            time_parts ? Clock::now() : Clock::time_point();
        finite = linearize(p, prefetch_updates_);
        if (time_parts) jacobian_wall += Seconds(Clock::now() - jacobian_start);
        if (!finite) break;
        // The point's cell table (none: a point held, not eliminated when the
        // structure was built or beyond the budget, or SetUseCellTables(false))
        // and each observation's blocks' indexes in it.
        const size_t ids_begin = point_block_ids_begin_[p];
        const int num_ids =
            static_cast<int>(point_block_ids_begin_[p + 1] - ids_begin);
        const bool table = use_cell_tables_ && num_ids > 0;
        if (table) {
          const int* ids = &point_block_ids_[ids_begin];
          local.resize(2 * lins.size());
          for (size_t k = 0; k < lins.size(); ++k) {
            for (int i = 0; i < lins[k].num_blocks; ++i) {
              const int id = static_cast<int>(
                  std::lower_bound(ids, ids + num_ids, lins[k].blocks[i]) -
                  ids);
              CHECK(id < num_ids && ids[id] == lins[k].blocks[i]);
              local[2 * k + i] = id;
            }
          }
          cells = &point_cells_[point_cells_begin_[p]];
        } else {
          cells = nullptr;
        }
        // W_k = A_k^T B_k; Q_k = W_k V^-1; S -= Q_k W_l^T; rhs += Q_k g.
        // The updates S -= Q_k W_l^T of the point's pairs, cell by cell
        // (through the table or the search), in the order add_pair adds a
        // matrix's blocks: for_each_update(emit) calls emit with each (Q and
        // W are formed in place below, their storage fixed), run_update runs
        // one. On a system out of the caches (prefetch_updates_) they are
        // listed first, so that the cells of the updates a few ahead are
        // prefetched while the one before runs (the first ones while the
        // point's own work runs): the cells scatter over the reduced system,
        // and one at a time each waits for its cache misses. Otherwise each
        // runs as it is found. The same updates in the same order: the same
        // sums.
        w.resize(lins.size());
        q.resize(lins.size());
        auto for_each_update = [&](const auto& emit) {
          for (size_t k = 0; k < lins.size(); ++k) {
            const Linearization& lin_k = lins[k];
            const int ldq = static_cast<int>(lin_k.A.cols());
            for (size_t l = k; l < lins.size(); ++l) {
              const Linearization& lin_l = lins[l];
              const int ldw = static_cast<int>(lin_l.A.cols());
              // Eigen's lazy product (below its GEMM threshold, 20) sums the
              // rows it peels off an odd-sized product as t0 + (t1 + t2):
              // that product as main formed it, for the same result to the
              // bit.
              if (ldq % 2 == 1 && ldq + ldw + 3 < 20) {
                PairUpdate update{};
                update.kind = PairUpdate::kOddPair;
                update.k = static_cast<uint32_t>(k);
                update.l = static_cast<uint32_t>(l);
                emit(update);
                continue;
              }
              for (int i = 0; i < lin_k.num_blocks; ++i) {
                const int rb = lin_k.blocks[i];
                const int li = table ? local[2 * k + i] : -1;
                const double* qk = q[k].data() + lin_k.cols[i];
                for (int j = 0; j < lin_l.num_blocks; ++j) {
                  const int cb = lin_l.blocks[j];
                  const int lj = table ? local[2 * l + j] : -1;
                  const double* wl = w[l].data() + lin_l.cols[j];
                  if (rb < cb || (rb == cb && k == l)) {
                    emit(PairUpdate{qk, wl, find(rb, li, cb, lj), ldq, ldw,
                                    block_size_[rb], block_size_[cb],
                                    PairUpdate::kProduct, 0, 0});
                  } else if (rb > cb) {
                    if (k == l) continue;
                    emit(PairUpdate{wl, qk, find(cb, lj, rb, li), ldw, ldq,
                                    block_size_[cb], block_size_[rb],
                                    PairUpdate::kProduct, 0, 0});
                  } else {
                    emit(PairUpdate{qk, wl, find(rb, li, rb, li), ldq, ldw,
                                    block_size_[rb], block_size_[rb],
                                    PairUpdate::kSymmetric, 0, 0});
                  }
                }
              }
            }
          }
        };
        auto run_update = [&](const PairUpdate& update) {
          if (update.kind == PairUpdate::kProduct) {
            SubtractProduct(update.a, update.lda, update.b, update.ldb,
                            update.rows, update.cols, update.values,
                            update.rows);
            return;
          }
          if (update.kind == PairUpdate::kSymmetric) {
            SubtractSymmetricProduct(update.a, update.lda, update.b, update.ldb,
                                     update.rows, update.values, update.rows);
            return;
          }
          const size_t k = update.k, l = update.l;
          const Linearization& lin_k = lins[k];
          const Linearization& lin_l = lins[l];
          const auto m = (-(q[k] * w[l].transpose())).eval();
          for (int i = 0; i < lin_k.num_blocks; ++i) {
            const int rb = lin_k.blocks[i];
            const int li = table ? local[2 * k + i] : -1;
            for (int j = 0; j < lin_l.num_blocks; ++j) {
              const int cb = lin_l.blocks[j];
              const int lj = table ? local[2 * l + j] : -1;
              const auto sub = m.block(lin_k.cols[i], lin_l.cols[j],
                                       block_size_[rb], block_size_[cb]);
              if (rb < cb || (rb == cb && k == l)) {
                add_at(find(rb, li, cb, lj), sub);
              } else if (rb > cb) {
                if (k != l) add_at(find(cb, lj, rb, li), sub.transpose());
              } else {
                add_at(find(rb, li, rb, li), sub + sub.transpose());
              }
            }
          }
        };
        updates.clear();
        if (prefetch_updates_ && active[p]) {
          for_each_update(
              [&](const PairUpdate& update) { updates.push_back(update); });
        }
        const size_t num_updates = updates.size();
        const size_t ahead = std::min(kPrefetchUpdates, num_updates);
        for (size_t u = 0; u < ahead; ++u) Prefetch(updates[u]);
        Matrix3 v = Matrix3::Zero();
        Eigen::Vector3d g = Eigen::Vector3d::Zero();
        for (size_t k = 0; k < lins.size(); ++k) {
          const Linearization& lin = lins[k];
          const auto ata = (lin.A.transpose() * lin.A).eval();
          if (table) {
            for (int i = 0; i < lin.num_blocks; ++i) {
              for (int j = 0; j < lin.num_blocks; ++j) {
                const int rb = lin.blocks[i];
                const int cb = lin.blocks[j];
                if (rb > cb) continue;
                add_at(cell(local[2 * k + i], local[2 * k + j]),
                       ata.block(lin.cols[i], lin.cols[j], block_size_[rb],
                                 block_size_[cb]));
              }
            }
          } else {
            add_pair(lin, lin, ata, /*same=*/true);
          }
          const auto atr = (lin.A.transpose() * lin.r).eval();
          block_vector(lin, &camera_gradient, atr, 1.0);
          block_vector(lin, &diagonal, ata.diagonal(), 1.0);
          v += lin.B.transpose() * lin.B;
          g += lin.B.transpose() * lin.r;
        }
        if (!active[p]) continue;
        gradient_max_norm =
            std::max(gradient_max_norm, g.cwiseAbs().maxCoeff());
        for (int i = 0; i < 3; ++i) v(i, i) += damped(v(i, i), radius);
        const Matrix3 v_inv = invert(v);
        for (size_t k = 0; k < lins.size(); ++k) {
          w[k] = lins[k].A.transpose() * lins[k].B;
          q[k] = w[k] * v_inv;
          block_vector(lins[k], &rhs, (q[k] * g).eval(), 1.0);
        }
        const Clock::time_point update_start =
            time_parts ? Clock::now() : Clock::time_point();
        if (implicit_) {
          point_v_inv[p] = v_inv;
          subtract_local_schur();
        } else if (prefetch_updates_) {
          for (size_t u = 0; u < num_updates; ++u) {
            if (u + kPrefetchUpdates < num_updates) {
              Prefetch(updates[u + kPrefetchUpdates]);
            }
            run_update(updates[u]);
          }
        } else {
          for_each_update(run_update);
        }
        if (time_parts) update_wall += Seconds(Clock::now() - update_start);
      }
      // The pose residuals: into their pose's diagonal block.
      for (size_t i = 0; i < pose_residuals_.size() && finite; ++i) {
        PoseLinearization& lin = pose_lins[i];
        double term = 0;
        if (!EvaluatePoseResidual(pose_residuals_[i], poses, &term, &lin)) {
          finite = false;
          break;
        }
        const int b = pose_block_[pose_residuals_[i].pose];
        if (b < 0) continue;
        // The pose's columns lead its block (a joined camera's follow).
        const int size = static_cast<int>(lin.A.cols());
        Eigen::MatrixXd ata =
            Eigen::MatrixXd::Zero(block_size_[b], block_size_[b]);
        ata.topLeftCorner(size, size) = lin.A.transpose() * lin.A;
        add_cell(b, b, ata);
        camera_gradient.segment(block_offset_[b], size) +=
            lin.A.transpose() * lin.r;
        diagonal.segment(block_offset_[b], block_size_[b]) += ata.diagonal();
      }
      // The camera priors: into their camera's diagonal block.
      for (size_t i = 0; i < cameras_.size() && finite; ++i) {
        const int column = CameraPriorColumn(static_cast<int>(i));
        if (column < 0) continue;
        const int b = camera_block_[i];
        const double a = 1 / cameras_[i].prior_std;
        const double r = CameraPriorResidual(static_cast<int>(i), cameras);
        *diagonal_entry(b, ValueIndex(b, b), column) += a * a;
        prior_diagonal[block_offset_[b] + column] += a * a;
        camera_gradient[block_offset_[b] + column] += a * r;
        diagonal[block_offset_[b] + column] += a * a;
      }
      if (!finite) {
        summary.termination = ceres::FAILURE;
        summary.message = "residual or Jacobian not finite";
        break;
      }
      rhs -= camera_gradient;
      if (n > 0) {
        gradient_max_norm =
            std::max(gradient_max_norm, camera_gradient.cwiseAbs().maxCoeff());
      }
      if (check_gradient && gradient_max_norm <= options.gradient_tolerance) {
        summary.termination = ceres::CONVERGENCE;
        summary.message = "gradient tolerance reached";
        break;
      }
      store_valid = true;
      elimination_cpu = static_cast<double>(std::clock() - elimination_clock) /
                        CLOCKS_PER_SEC;
      elimination_wall = Seconds(Clock::now() - elimination_start);
    }
    // Damping; a variable no weighed observation sees is held (its row and
    // column are empty). A reused system trades its last damping for this.
    for (int b = 0; b < static_cast<int>(block_size_.size()); ++b) {
      const size_t cell = ValueIndex(b, b);
      for (int i = 0; i < block_size_[b]; ++i) {
        const int s = block_offset_[b] + i;
        const double add = diagonal[s] > 0 ? damped(diagonal[s], radius) : 1.0;
        *diagonal_entry(b, cell, i) += reused ? add - applied_damping[s] : add;
        applied_damping[s] = add;
      }
    }
    reuse = false;
    ++summary.num_iterations;
    linear_timer.Restart();
    const std::clock_t linear_clock = std::clock();
    bool solved = true;
    int cg_iterations = 0;
    if (n > 0 && iterative_) {
      const double rhs_norm = rhs.norm();
      if (first_rhs_norm < 0) first_rhs_norm = rhs_norm;
      const double eta = first_rhs_norm > 0
                             ? std::min(solver_options_.eta,
                                        std::sqrt(rhs_norm / first_rhs_norm))
                             : solver_options_.eta;
      const bool coarse_ready = num_coarse_clusters_ > 0 && build_coarse();
      solved = SolveIterative(rhs, eta,
                              implicit_ ? multiply_implicit : multiply_explicit,
                              coarse_ready ? &coarse_correction : nullptr,
                              &step, &cg_iterations) &&
               step.allFinite();
      summary.num_linear_iterations += cg_iterations;
    } else if (n > 0 && cholmod_ != nullptr) {
      if (!scalar_layout) ToScalarLayout();
      scalar_layout = true;
      solved = SolveSupernodal(rhs, &step) && step.allFinite();
    } else if (simplicial) {
      if (!scalar_layout) ToScalarLayout();
      scalar_layout = true;
      llt.factorize(reduced());
      solved = llt.info() == Eigen::Success;
      if (solved) step = llt.solve(rhs);
      solved = solved && step.allFinite();
    }
    summary.linear_solver_seconds += linear_timer.ElapsedSeconds();
    const double linear_cpu_seconds =
        static_cast<double>(std::clock() - linear_clock) / CLOCKS_PER_SEC;
    check_gradient = false;
    if (!solved) {
      if (++num_invalid > options.max_num_consecutive_invalid_steps) {
        summary.termination = ceres::FAILURE;
        summary.message = "too many consecutive failed linear solves";
        break;
      }
      VLOG(2) << "Schur bundle adjustment iteration " << summary.num_iterations
              << ": factorisation failed, radius " << radius
              << (reused ? " (reduced system reused)"
                         : "; " + elimination_parts(elimination_cpu,
                                                    elimination_wall,
                                                    jacobian_wall, update_wall))
              << "; linear solve " << linear_cpu_seconds << " CPU s";
      // As a rejected step: a system that cannot be factorised with the
      // damping of a radius above rejected_start_radius rarely can with the
      // next cut's (10,000 photo images: 175 CPU s a try).
      reject(/*skip=*/true);
      reuse = reuse_min_radius > 0 && radius >= reuse_min_radius;
      continue;
    }
    num_invalid = 0;
    // Back-substitution: each point's step from its Jacobians (kept or
    // evaluated again) and the cameras' step; the linear model's cost on the
    // way.
    const std::clock_t back_clock = std::clock();
    candidate_poses = poses;
    candidate_cameras = cameras;
    candidate_points = points;
    double model_cost = 0;
    double step_norm2 = 0, x_norm2 = 0;
    // The largest step of each kind and whose (VLOG 3).
    double max_point_step = 0, max_rotation_step = 0, max_position_step = 0,
           max_focal_step = 0, max_extra_step = 0;
    size_t max_point = 0, max_rotation = 0, max_position = 0, max_focal = 0,
           max_extra = 0;
    for (size_t p = 0; p < num_points; ++p) {
      // (Finite: the elimination linearised every point at these
      // parameters.)
      linearize(p, /*prefetch=*/false);
      Eigen::Vector3d dx = Eigen::Vector3d::Zero();
      if (active[p]) {
        Matrix3 v = Matrix3::Zero();
        Eigen::Vector3d g = Eigen::Vector3d::Zero();
        for (const Linearization& lin : lins) {
          v += lin.B.transpose() * lin.B;
          g += lin.B.transpose() * (lin.r + lin.A * gather(lin, step));
        }
        for (int i = 0; i < 3; ++i) v(i, i) += damped(v(i, i), point_radius);
        dx = -invert(v) * g;
        for (int i = 0; i < 3; ++i) {
          candidate_points[3 * p + i] += dx[i];
          x_norm2 += points[3 * p + i] * points[3 * p + i];
        }
        step_norm2 += dx.squaredNorm();
        if (dx.norm() > max_point_step) {
          max_point_step = dx.norm();
          max_point = p;
        }
      }
      for (const Linearization& lin : lins) {
        model_cost +=
            0.5 *
            (lin.r + lin.A * gather(lin, step) + lin.B * dx).squaredNorm();
      }
    }
    // The pose residuals' model: their cost less the decrease of their
    // Gauss-Newton model (Ceres' model cost change).
    for (size_t i = 0; i < pose_residuals_.size(); ++i) {
      const PoseLinearization& lin = pose_lins[i];
      model_cost += lin.cost;
      const int b = pose_block_[pose_residuals_[i].pose];
      if (b < 0) continue;
      const Eigen::VectorXd change =
          lin.A * step.segment(block_offset_[b], lin.A.cols());
      model_cost -=
          0.5 * lin.r.squaredNorm() - 0.5 * (lin.r + change).squaredNorm();
    }
    // The camera priors' model (linear: exact).
    for (size_t i = 0; i < cameras_.size(); ++i) {
      if (cameras_[i].prior_param < 0) continue;
      double r = CameraPriorResidual(static_cast<int>(i), cameras);
      const int column = CameraPriorColumn(static_cast<int>(i));
      if (column >= 0) {
        r += step[block_offset_[camera_block_[i]] + column] /
             cameras_[i].prior_std;
      }
      model_cost += 0.5 * r * r;
    }
    for (size_t i = 0; i < poses_.size(); ++i) {
      const int b = pose_block_[i];
      if (b < 0) continue;
      Eigen::Matrix<double, 6, 1> delta = Eigen::Matrix<double, 6, 1>::Zero();
      for (size_t j = 0; j < poses_[i].free.size(); ++j) {
        delta[poses_[i].free[j]] = step[block_offset_[b] + j];
      }
      ceres::EigenQuaternionManifold().Plus(&poses[7 * i], delta.data(),
                                            &candidate_poses[7 * i]);
      for (int j = 0; j < 3; ++j)
        candidate_poses[7 * i + 4 + j] += delta[3 + j];
      if (delta.head<3>().norm() > max_rotation_step) {
        max_rotation_step = delta.head<3>().norm();
        max_rotation = i;
      }
      if (delta.tail<3>().norm() > max_position_step) {
        max_position_step = delta.tail<3>().norm();
        max_position = i;
      }
      for (int j = 0; j < 7; ++j) {
        const double d = candidate_poses[7 * i + j] - poses[7 * i + j];
        step_norm2 += d * d;
        x_norm2 += poses[7 * i + j] * poses[7 * i + j];
      }
    }
    for (size_t i = 0; i < cameras_.size(); ++i) {
      const int b = camera_block_[i];
      if (b < 0) continue;
      for (size_t j = 0; j < cameras_[i].free.size(); ++j) {
        const double d = step[block_offset_[b] + camera_column_[i] + j];
        candidate_cameras[kMaxNumParams * i + cameras_[i].free[j]] += d;
        const int param = cameras_[i].free[j];
        const double value = cameras[kMaxNumParams * i + param];
        if (param == 0 && value != 0 && std::abs(d / value) > max_focal_step) {
          max_focal_step = std::abs(d / value);
          max_focal = i;
        } else if (param > 2 && std::abs(d) > max_extra_step) {
          max_extra_step = std::abs(d);
          max_extra = i;
        }
        step_norm2 += d * d;
      }
      for (int j = 0; j < cameras_[i].num_params; ++j) {
        x_norm2 +=
            cameras[kMaxNumParams * i + j] * cameras[kMaxNumParams * i + j];
      }
    }
    // Embedded point iterations (SchurSolverOptions::point_iterations):
    // each point's own Gauss-Newton steps with the candidate cameras held,
    // each kept only when it lowers the point's cost.
    for (size_t p = 0; p < num_points && point_iterations > 0; ++p) {
      if (!active[p]) continue;
      double* x = &candidate_points[3 * p];
      for (int it = 0; it < point_iterations; ++it) {
        Matrix3 v = Matrix3::Zero();
        Eigen::Vector3d g = Eigen::Vector3d::Zero();
        double point_cost = 0;
        bool finite = true;
        lins.clear();
        for (uint32_t k = point_begin_[p]; k < point_begin_[p + 1]; ++k) {
          if (!(Weight(k) > 0)) continue;
          lins.emplace_back();
          double residual[2];
          if (!Evaluate(k, x, candidate_poses, candidate_cameras, residual,
                        &lins.back())) {
            finite = false;
            break;
          }
          v += lins.back().B.transpose() * lins.back().B;
          g += lins.back().B.transpose() * lins.back().r;
          point_cost += 0.5 * lins.back().r.squaredNorm();
        }
        if (!finite) break;
        const Eigen::Vector3d dx = -invert(v) * g;
        if (!dx.allFinite()) break;
        const Eigen::Vector3d trial = Eigen::Map<Eigen::Vector3d>(x) + dx;
        double trial_cost = 0;
        if (!AddPointCost(p, trial.data(), candidate_poses, candidate_cameras,
                          &trial_cost) ||
            !(trial_cost < point_cost)) {
          break;
        }
        std::copy(trial.data(), trial.data() + 3, x);
      }
    }
    // (Guarded: a solve may have no camera or no point block.)
    VLOG(3) << "Schur bundle adjustment step parts: rotation "
            << max_rotation_step << " (pose " << max_rotation << "), position "
            << max_position_step << " (pose " << max_position
            << "), relative focal " << max_focal_step << " (camera "
            << max_focal << ", focal "
            << (cameras.empty() ? 0.0 : cameras[kMaxNumParams * max_focal])
            << "), extra " << max_extra_step << " (camera " << max_extra
            << "), point " << max_point_step << " (point " << max_point << ", "
            << (num_points == 0
                    ? 0
                    : point_begin_[max_point + 1] - point_begin_[max_point])
            << " observations)";
    const double x_norm = std::sqrt(x_norm2);
    if (std::sqrt(step_norm2) <=
        options.parameter_tolerance * (x_norm + options.parameter_tolerance)) {
      summary.termination = ceres::CONVERGENCE;
      summary.message = "parameter tolerance reached";
      break;
    }
    const std::clock_t cost_clock = std::clock();
    const double back_cpu =
        static_cast<double>(cost_clock - back_clock) / CLOCKS_PER_SEC;
    const double candidate_cost =
        Cost(candidate_poses, candidate_cameras, candidate_points);
    const double cost_cpu =
        static_cast<double>(std::clock() - cost_clock) / CLOCKS_PER_SEC;
    if (std::isfinite(candidate_cost) &&
        std::abs(cost - candidate_cost) <= options.function_tolerance * cost) {
      summary.termination = ceres::CONVERGENCE;
      summary.message = "function tolerance reached";
      break;
    }
    const double model_cost_change = cost - model_cost;
    const double rho = (cost - candidate_cost) / model_cost_change;
    VLOG(2) << "Schur bundle adjustment iteration " << summary.num_iterations
            << ": cost " << cost << " -> " << candidate_cost << " (model "
            << model_cost << "), step " << std::sqrt(step_norm2) << ", radius "
            << radius << (reused ? " (reduced system reused)" : "")
            << "; linear solve " << linear_cpu_seconds << " CPU s"
            << (iterative_ ? " (" + std::to_string(cg_iterations) +
                                 " conjugate gradient iterations)"
                           : std::string())
            << " of "
            << static_cast<double>(std::clock() - iteration_clock) /
                   CLOCKS_PER_SEC
            << (reused ? std::string()
                       : "; " + elimination_parts(elimination_cpu,
                                                  elimination_wall,
                                                  jacobian_wall, update_wall))
            << "; back-substitution " << back_cpu << ", cost " << cost_cpu
            << " CPU s";
    if (std::isfinite(candidate_cost) && model_cost_change > 0 &&
        rho > options.min_relative_decrease) {
      if (crawl_report && cost - candidate_cost < kCrawlDecrease * cost) {
        ++num_crawl_steps;
        for (size_t i = 0; i < poses_.size(); ++i) {
          const Eigen::Map<const Eigen::Quaterniond> q0(&poses[7 * i]);
          const Eigen::Map<const Eigen::Quaterniond> q1(
              &candidate_poses[7 * i]);
          crawl_rotation[i] += q0.angularDistance(q1);
          crawl_position[i] +=
              (Eigen::Map<const Eigen::Vector3d>(&candidate_poses[7 * i + 4]) -
               Eigen::Map<const Eigen::Vector3d>(&poses[7 * i + 4]))
                  .norm();
        }
        for (size_t i = 0; i < cameras_.size(); ++i) {
          const double* c0 = &cameras[kMaxNumParams * i];
          const double* c1 = &candidate_cameras[kMaxNumParams * i];
          if (c0[0] != 0) crawl_focal[i] += std::abs(c1[0] / c0[0] - 1);
          for (int j = 3; j < cameras_[i].num_params; ++j) {
            crawl_extra[i] += std::abs(c1[j] - c0[j]);
          }
        }
      }
      poses.swap(candidate_poses);
      store_valid = false;  // linearised at the old parameters
      cameras.swap(candidate_cameras);
      points.swap(candidate_points);
      cost = candidate_cost;
      radius = std::min(
          options.max_trust_region_radius,
          radius / std::max(1.0 / 3.0, 1.0 - std::pow(2 * rho - 1, 3)));
      decrease_factor = 2;
      check_gradient = true;
      step_accepted = true;
      if (stall.Add(cost)) {
        summary.termination = ceres::CONVERGENCE;
        summary.message = "the cost stalled";
        summary.stalled = true;
        break;
      }
    } else {
      reject(/*skip=*/true);
      if (radius < options.min_trust_region_radius) {
        summary.termination = ceres::CONVERGENCE;
        summary.message = "minimum trust region radius reached";
        break;
      }
      reuse = reuse_min_radius > 0 && radius >= reuse_min_radius;
    }
  }
  summary.final_cost = cost;
  if (crawl_report && num_crawl_steps > 0) {
    // The largest totals of each kind, largest first.
    auto largest = [](const std::vector<double>& totals) {
      std::vector<size_t> order(totals.size());
      std::iota(order.begin(), order.end(), 0);
      const size_t k = std::min<size_t>(6, order.size());
      std::partial_sort(
          order.begin(), order.begin() + k, order.end(),
          [&](size_t a, size_t b) { return totals[a] > totals[b]; });
      std::ostringstream out;
      for (size_t i = 0; i < k; ++i) {
        out << " " << order[i] << ":" << totals[order[i]];
      }
      return out.str();
    };
    VLOG(3) << "Schur bundle adjustment crawl: " << num_crawl_steps
            << " accepted steps lowered the cost by less than "
            << kCrawlDecrease << " of it; total change there: rotation (rad, "
            << "pose:total)" << largest(crawl_rotation) << "; position"
            << largest(crawl_position) << "; relative focal (camera:total)"
            << largest(crawl_focal) << "; extra" << largest(crawl_extra);
  }
  if (summary.termination != ceres::FAILURE) {
    for (size_t i = 0; i < poses_.size(); ++i) {
      std::copy(&poses[7 * i], &poses[7 * i + 4], poses_[i].rotation);
      std::copy(&poses[7 * i + 4], &poses[7 * i + 7], poses_[i].position);
    }
    for (size_t i = 0; i < cameras_.size(); ++i) {
      std::copy(&cameras[kMaxNumParams * i],
                &cameras[kMaxNumParams * i + cameras_[i].num_params],
                cameras_[i].params);
    }
    for (size_t i = 0; i < num_points; ++i) {
      std::copy(&points[3 * i], &points[3 * i + 3], point_blocks_[i]);
    }
  }
  return summary;
}

}  // namespace colmap_irav4
