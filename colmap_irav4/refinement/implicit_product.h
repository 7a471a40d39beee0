#pragma once

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "colmap_irav4/refinement/coarse_space.h"

namespace colmap_irav4 {

// The implicit Schur complement's product, point by point
// (SchurBundleAdjuster's iterative solver without the reduced system
// formed): y += sum_k A_k^T (u_k - B_k s), u_k = A_k x, s = V^-1 sum_k
// B_k^T u_k over a point's observations k, from their linearisations kept
// in the Jacobian store.
//
// The store's record of an observation: r (2), B (2 x 3 column-major), A's
// two rows (row-major, its reduced columns), in T (double, or float for
// the single-precision store).

// The reduced system's columns of an observation of a pose (its blocks'
// scalar offsets and sizes), one per pose.
struct ProductColumns {
  int count = 0;  // blocks
  int offset[2] = {0, 0};
  int size[2] = {0, 0};
  int num_cols = 0;  // A's
};

// One point's share of the product over its `count` observations of poses
// `poses`, records from `at`. v_inv null: a held point (s = 0). `x_in_t`: x
// in T (an observation whose A is one block of 6-10 columns, the photo
// collections' pose with its own camera, multiplies in T). `ax`: scratch.
// T: double, or float (the single-precision store).
template <typename T>
void MultiplyPoint(const T* at, const uint32_t* poses, size_t count,
                   const ProductColumns* pose_columns,
                   const Eigen::Matrix3d* v_inv, const double* x,
                   const T* x_in_t, double* y,
                   std::vector<Eigen::Vector2d>* ax);

// The same for the single-precision store with AVX2 and FMA (eight float
// lanes; the build targets plain x86-64, so the kernel is compiled for
// those instructions alone and chosen at run time) when all the point's
// observations have one block of the same 6-10 columns (records of one
// stride: the photo collections' poses with their own cameras of one
// model); other points as MultiplyPoint. The same sums in another order,
// with fused multiply-adds: equal to MultiplyPoint's to float rounding.
// Only when Avx2ProductAvailable().
void MultiplyPointAvx2(const float* at, const uint32_t* poses, size_t count,
                       const ProductColumns* pose_columns,
                       const Eigen::Matrix3d* v_inv, const double* x,
                       const float* x_float, double* y,
                       std::vector<Eigen::Vector2d>* ax);

// A pose's place in the coarse space (coarse_space.h): its cluster (-1:
// none) and the motion of its free tangent coordinates (the first
// num_free rows of `motion`; A's first num_free columns).
struct CoarsePose {
  int cluster = -1;
  int num_free = 0;
  CoarseMotion motion = CoarseMotion::Zero();
};

// One point's share of the coarse system P^T S P from the same records:
// sum_k E_k^T E_k - F^T V^-1 F with E_k = A_k M_k (M_k: the motion of
// observation k's pose) and F the sums of B_k^T E_k by cluster. `shares`:
// scratch.
template <typename T>
void AddPointToCoarseSystem(
    const T* at, const uint32_t* poses, size_t count,
    const ProductColumns* pose_columns, const Eigen::Matrix3d* v_inv,
    const CoarsePose* coarse_poses, CoarseSystem* system,
    std::vector<std::pair<int, Eigen::Matrix<double, 3, kNumCoarseModes>>>*
        shares);

// True when this build has the AVX2 kernel and this processor runs it.
bool Avx2ProductAvailable();

}  // namespace colmap_irav4
