#include "colmap_irav4/refinement/implicit_product.h"

#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Core>

namespace colmap_irav4 {
namespace {

// Random records of one point's observations in the store's layout (r, B
// column-major, A's two rows) beside the dense product they stand for.
struct PointRecords {
  std::vector<ProductColumns> pose_columns;
  std::vector<uint32_t> poses;
  std::vector<double> store;
  Eigen::Matrix3d v_inv;
  Eigen::VectorXd x;

  // y = sum_k A_k^T (A_k x - B_k s), s = v_inv sum_k B_k^T A_k x, from
  // dense A_k over all columns (or without s: a held point).
  Eigen::VectorXd Reference(bool held) const {
    std::vector<Eigen::MatrixXd> a;
    std::vector<Eigen::Matrix<double, 2, 3>> b;
    const double* at = store.data();
    for (const uint32_t pose : poses) {
      const ProductColumns& columns = pose_columns[pose];
      Eigen::Matrix<double, 2, 3> b_k;
      for (int i = 0; i < 6; ++i) b_k(i % 2, i / 2) = at[2 + i];
      Eigen::MatrixXd a_k = Eigen::MatrixXd::Zero(2, x.size());
      int col = 0;
      for (int i = 0; i < columns.count; ++i) {
        for (int j = 0; j < columns.size[i]; ++j, ++col) {
          a_k(0, columns.offset[i] + j) = at[8 + col];
          a_k(1, columns.offset[i] + j) = at[8 + columns.num_cols + col];
        }
      }
      a.push_back(a_k);
      b.push_back(b_k);
      at += 8 + 2 * columns.num_cols;
    }
    Eigen::Vector3d t = Eigen::Vector3d::Zero();
    for (size_t k = 0; k < a.size(); ++k) t += b[k].transpose() * (a[k] * x);
    const Eigen::Vector3d s =
        held ? Eigen::Vector3d::Zero().eval() : Eigen::Vector3d(v_inv * t);
    Eigen::VectorXd y = Eigen::VectorXd::Zero(x.size());
    for (size_t k = 0; k < a.size(); ++k) {
      y += a[k].transpose() * (a[k] * x - b[k] * s);
    }
    return y;
  }
};

// Observations of poses with `widths` columns each (one block; 0: a held
// pose, no columns), plus, with `shared_camera`, a pose whose camera is a
// second block elsewhere in the system (two blocks).
PointRecords MakePoint(const std::vector<int>& widths, bool shared_camera,
                       int seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uniform(-1, 1);
  PointRecords point;
  int num_scalars = 0;
  for (const int width : widths) {
    ProductColumns columns;
    if (width > 0) {
      columns.count = 1;
      columns.offset[0] = num_scalars;
      columns.size[0] = width;
      columns.num_cols = width;
      num_scalars += width + 3;  // other images' columns in between
    }
    point.pose_columns.push_back(columns);
  }
  if (shared_camera) {
    ProductColumns columns;
    columns.count = 2;
    columns.offset[0] = num_scalars;
    columns.size[0] = 6;
    columns.offset[1] = num_scalars + 20;
    columns.size[1] = 3;
    columns.num_cols = 9;
    num_scalars += 23;
    point.pose_columns.push_back(columns);
  }
  // The observations in an order unlike the poses'.
  for (size_t i = 0; i < point.pose_columns.size(); ++i) {
    point.poses.push_back(
        static_cast<uint32_t>((i * 5 + 2) % point.pose_columns.size()));
  }
  for (const uint32_t pose : point.poses) {
    for (int i = 0; i < 8 + 2 * point.pose_columns[pose].num_cols; ++i) {
      point.store.push_back(uniform(rng));
    }
  }
  const Eigen::Matrix3d m = Eigen::Matrix3d::Random();
  point.v_inv = m * m.transpose() + Eigen::Matrix3d::Identity();
  point.x = Eigen::VectorXd::Random(num_scalars);
  return point;
}

enum class Kernel { kDouble, kFloat, kAvx2 };

Eigen::VectorXd Multiply(const PointRecords& point, Kernel kernel, bool held) {
  const Eigen::VectorXd y0 = Eigen::VectorXd::LinSpaced(point.x.size(), 1, 2);
  Eigen::VectorXd y = y0;  // the product adds to y
  std::vector<Eigen::Vector2d> ax;
  const Eigen::Matrix3d* v_inv = held ? nullptr : &point.v_inv;
  if (kernel == Kernel::kDouble) {
    MultiplyPoint(point.store.data(), point.poses.data(), point.poses.size(),
                  point.pose_columns.data(), v_inv, point.x.data(),
                  point.x.data(), y.data(), &ax);
  } else {
    const std::vector<float> store(point.store.begin(), point.store.end());
    const Eigen::VectorXf x_float = point.x.cast<float>();
    if (kernel == Kernel::kFloat) {
      MultiplyPoint(store.data(), point.poses.data(), point.poses.size(),
                    point.pose_columns.data(), v_inv, point.x.data(),
                    x_float.data(), y.data(), &ax);
    } else {
      MultiplyPointAvx2(store.data(), point.poses.data(), point.poses.size(),
                        point.pose_columns.data(), v_inv, point.x.data(),
                        x_float.data(), y.data(), &ax);
    }
  }
  return y - y0;
}

// Every kind of point the kernels tell apart: one width throughout (the
// AVX2 kernel's one-stride path) at each width 6-10, mixed widths, a held
// pose among them, a shared camera's two blocks.
std::vector<PointRecords> Points() {
  std::vector<PointRecords> points;
  int seed = 1;
  for (int width = 6; width <= 10; ++width) {
    points.push_back(MakePoint(std::vector<int>(7, width), false, seed++));
  }
  points.push_back(MakePoint({8, 6, 10, 7, 9, 8}, false, seed++));
  points.push_back(MakePoint({8, 0, 8, 8}, false, seed++));
  points.push_back(MakePoint({8, 8, 8}, true, seed++));
  points.push_back(MakePoint({3, 8, 11}, true, seed++));
  return points;
}

TEST(ImplicitProduct, DoubleStoreIsTheDenseProduct) {
  for (const PointRecords& point : Points()) {
    for (const bool held : {false, true}) {
      const Eigen::VectorXd reference = point.Reference(held);
      const Eigen::VectorXd y = Multiply(point, Kernel::kDouble, held);
      EXPECT_LT((y - reference).norm(), 1e-12 * reference.norm())
          << point.poses.size() << " observations, held " << held;
    }
  }
}

// The float store's products against the dense double one: float rounding
// of the records and of x (1e-7 relative each), sums of a few dozen terms.
TEST(ImplicitProduct, FloatStoreIsTheDenseProductToFloatRounding) {
  for (const PointRecords& point : Points()) {
    for (const bool held : {false, true}) {
      const Eigen::VectorXd reference = point.Reference(held);
      const Eigen::VectorXd y = Multiply(point, Kernel::kFloat, held);
      const double error = (y - reference).norm() / reference.norm();
      EXPECT_LT(error, 1e-5) << point.poses.size() << " observations";
      // Not exact: the records were rounded (a check that can fail).
      EXPECT_GT(error, 1e-12);
    }
  }
}

TEST(ImplicitProduct, Avx2KernelIsThePortableProductToFloatRounding) {
  if (!Avx2ProductAvailable()) {
    GTEST_SKIP() << "this processor has no AVX2 and FMA";
  }
  for (const PointRecords& point : Points()) {
    for (const bool held : {false, true}) {
      const Eigen::VectorXd reference = point.Reference(held);
      const Eigen::VectorXd portable = Multiply(point, Kernel::kFloat, held);
      const Eigen::VectorXd avx2 = Multiply(point, Kernel::kAvx2, held);
      EXPECT_LT((avx2 - reference).norm(), 1e-5 * reference.norm())
          << point.poses.size() << " observations";
      EXPECT_LT((avx2 - portable).norm(), 1e-5 * reference.norm());
    }
  }
}

// The coarse system's share of a point (coarse_space.h): P^T S_p P, with
// S_p the point's dense Schur complement (the dense product's columns) and P
// the poses' motions in two clusters; from the double and the float store.
TEST(ImplicitProduct, CoarseShareIsTheProjectedSchurComplement) {
  constexpr int kNumClusters = 2;
  for (const PointRecords& point : Points()) {
    for (const bool held : {false, true}) {
      const int n = static_cast<int>(point.x.size());
      Eigen::MatrixXd s(n, n);
      PointRecords unit = point;
      for (int j = 0; j < n; ++j) {
        unit.x = Eigen::VectorXd::Unit(n, j);
        s.col(j) = unit.Reference(held);
      }
      // The poses with a pose block (6 columns first; the others held).
      std::vector<CoarsePose> coarse(point.pose_columns.size());
      Eigen::MatrixXd p =
          Eigen::MatrixXd::Zero(n, kNumCoarseModes * kNumClusters);
      for (size_t i = 0; i < coarse.size(); ++i) {
        const ProductColumns& columns = point.pose_columns[i];
        if (columns.count == 0 || columns.size[0] < 6) continue;
        coarse[i].cluster = static_cast<int>(i % kNumClusters);
        coarse[i].num_free = 6;
        coarse[i].motion = CoarseMotion::Random();
        p.block(columns.offset[0], kNumCoarseModes * coarse[i].cluster, 6,
                kNumCoarseModes) = coarse[i].motion;
      }
      const Eigen::MatrixXd reference = p.transpose() * s * p;
      const Eigen::Matrix3d* v_inv = held ? nullptr : &point.v_inv;
      std::vector<std::pair<int, Eigen::Matrix<double, 3, kNumCoarseModes>>>
          shares;
      CoarseSystem from_double, from_float;
      from_double.Reset(kNumClusters);
      from_float.Reset(kNumClusters);
      AddPointToCoarseSystem(point.store.data(), point.poses.data(),
                             point.poses.size(), point.pose_columns.data(),
                             v_inv, coarse.data(), &from_double, &shares);
      const std::vector<float> store(point.store.begin(), point.store.end());
      AddPointToCoarseSystem(store.data(), point.poses.data(),
                             point.poses.size(), point.pose_columns.data(),
                             v_inv, coarse.data(), &from_float, &shares);
      EXPECT_GT(reference.norm(), 0);
      EXPECT_LT((from_double.Matrix() - reference).norm(),
                1e-12 * reference.norm())
          << point.poses.size() << " observations, held " << held;
      EXPECT_LT((from_float.Matrix() - reference).norm(),
                1e-5 * reference.norm());
    }
  }
}

}  // namespace
}  // namespace colmap_irav4
