#include "colmap_irav4/refinement/implicit_product.h"

#include <algorithm>
#include <cmath>
#include <iterator>

#include <glog/logging.h>

#include "colmap_irav4/refinement/reprojection_cost.h"

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define COLMAP_IRAV4_AVX2_PRODUCT 1
#include <immintrin.h>
#endif

namespace colmap_irav4 {
namespace {

// An observation's two halves of the product when A is one block of N
// columns (row-major 2 x N at `a`), at a width known at compile time: u = A
// x (Eigen's vectorised sums; a scalar loop cannot reorder them), and y +=
// A^T z. In T: the single-precision store multiplies in floats, x given in
// floats; the sums over the observations stay in double.
template <int N, typename T>
void MultiplyRows(const T* a, const T* x, double u[2]) {
  const Eigen::Matrix<T, 2, 1> product =
      Eigen::Map<const Eigen::Matrix<T, 2, N, Eigen::RowMajor>>(a) *
      Eigen::Map<const Eigen::Matrix<T, N, 1>>(x);
  u[0] = static_cast<double>(product[0]);
  u[1] = static_cast<double>(product[1]);
}

template <int N, typename T>
void AddTransposedRows(const T* a, const double z[2], double* y) {
  const Eigen::Matrix<T, N, 1> product =
      Eigen::Map<const Eigen::Matrix<T, 2, N, Eigen::RowMajor>>(a).transpose() *
      Eigen::Matrix<T, 2, 1>(static_cast<T>(z[0]), static_cast<T>(z[1]));
  Eigen::Map<Eigen::Matrix<double, N, 1>>(y) += product.template cast<double>();
}

// An observation's record from `at`: B, A's two rows, the next record.
template <typename T>
struct Record {
  const T *b, *row0, *row1, *next;
  Record(const T* at, int num_cols)
      : b(at + 2),
        row0(b + 6),
        row1(row0 + num_cols),
        next(row0 + 2 * num_cols) {}
  double B(int i) const { return static_cast<double>(b[i]); }
};

// The store streams in once per product, point by point, each point's
// records read twice: the first pass asks for the lines this far ahead
// (the hardware's prefetcher alone left the product waiting on them: a
// conjugate gradient iteration 1.15x cheaper on a 4,907-image photo model,
// docs/notes/2026-12-06-implicit-schur.md).
constexpr size_t kPrefetchBytes = 2048;

inline void PrefetchAhead(const void* record) {
#if defined(__GNUC__) || defined(__clang__)
  __builtin_prefetch(static_cast<const char*>(record) + kPrefetchBytes, 0, 3);
#else
  (void)record;
#endif
}

// The single blocks the fixed-width code takes (the photo collections'
// pose with its own camera: 6 pose columns and 0-4 camera ones).
constexpr int kMinFixedCols = 6;
constexpr int kMaxFixedCols = 10;

bool FixedWidth(const ProductColumns& columns) {
  return columns.count == 1 && columns.num_cols >= kMinFixedCols &&
         columns.num_cols <= kMaxFixedCols;
}

// u = A x for an observation of any blocks (x in double).
template <typename T>
void MultiplyBlocks(const Record<T>& r, const ProductColumns& columns,
                    const double* x, double u[2]) {
  u[0] = u[1] = 0;
  int col = 0;
  for (int i = 0; i < columns.count; ++i) {
    const double* xs = x + columns.offset[i];
    for (int j = 0; j < columns.size[i]; ++j, ++col) {
      u[0] += static_cast<double>(r.row0[col]) * xs[j];
      u[1] += static_cast<double>(r.row1[col]) * xs[j];
    }
  }
}

// y += A^T z for an observation of any blocks.
template <typename T>
void AddTransposedBlocks(const Record<T>& r, const ProductColumns& columns,
                         const double z[2], double* y) {
  int col = 0;
  for (int i = 0; i < columns.count; ++i) {
    double* ys = y + columns.offset[i];
    for (int j = 0; j < columns.size[i]; ++j, ++col) {
      ys[j] += static_cast<double>(r.row0[col]) * z[0] +
               static_cast<double>(r.row1[col]) * z[1];
    }
  }
}

#ifdef COLMAP_IRAV4_AVX2_PRODUCT

#define COLMAP_IRAV4_AVX2 __attribute__((target("avx2,fma")))

// The first min(N, 8) floats from p (masked below 8: no read past them).
template <int N>
COLMAP_IRAV4_AVX2 inline __m256 LoadHead(const float* p) {
  if constexpr (N >= 8) {
    return _mm256_loadu_ps(p);
  } else {
    const __m256i lanes = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    return _mm256_maskload_ps(p,
                              _mm256_cmpgt_epi32(_mm256_set1_epi32(N), lanes));
  }
}

// u = A x for A's rows at `row0` (N columns), x in floats.
template <int N>
COLMAP_IRAV4_AVX2 inline void MultiplyRowsAvx2(const float* row0,
                                               const float* x, double u[2]) {
  const float* row1 = row0 + N;
  const __m256 xv = LoadHead<N>(x);
  const __m256 p0 = _mm256_mul_ps(LoadHead<N>(row0), xv);
  const __m256 p1 = _mm256_mul_ps(LoadHead<N>(row1), xv);
  // Lanes: (p0 0+1, 2+3, p1 0+1, 2+3 | p0 4+5, 6+7, p1 4+5, 6+7).
  const __m256 pairs = _mm256_hadd_ps(p0, p1);
  __m128 sums = _mm_add_ps(_mm256_castps256_ps128(pairs),
                           _mm256_extractf128_ps(pairs, 1));
  sums = _mm_hadd_ps(sums, sums);  // (u0, u1, u0, u1)
  float u0 = _mm_cvtss_f32(sums);
  float u1 = _mm_cvtss_f32(_mm_movehdup_ps(sums));
  for (int j = 8; j < N; ++j) {
    u0 += row0[j] * x[j];
    u1 += row1[j] * x[j];
  }
  u[0] = u0;
  u[1] = u1;
}

// y += A^T z: A^T z in floats, added to y in double.
template <int N>
COLMAP_IRAV4_AVX2 inline void AddTransposedRowsAvx2(const float* row0,
                                                    const double z[2],
                                                    double* y) {
  const float* row1 = row0 + N;
  const float z0 = static_cast<float>(z[0]);
  const float z1 = static_cast<float>(z[1]);
  const __m256 v =
      _mm256_fmadd_ps(LoadHead<N>(row0), _mm256_set1_ps(z0),
                      _mm256_mul_ps(LoadHead<N>(row1), _mm256_set1_ps(z1)));
  const __m256d low = _mm256_cvtps_pd(_mm256_castps256_ps128(v));
  const __m256d high = _mm256_cvtps_pd(_mm256_extractf128_ps(v, 1));
  _mm256_storeu_pd(y, _mm256_add_pd(_mm256_loadu_pd(y), low));
  if constexpr (N >= 8) {
    _mm256_storeu_pd(y + 4, _mm256_add_pd(_mm256_loadu_pd(y + 4), high));
  } else {
    const __m256i mask = _mm256_cmpgt_epi64(_mm256_set1_epi64x(N - 4),
                                            _mm256_setr_epi64x(0, 1, 2, 3));
    _mm256_maskstore_pd(y + 4, mask,
                        _mm256_add_pd(_mm256_maskload_pd(y + 4, mask), high));
  }
  for (int j = 8; j < N; ++j) {
    y[j] += static_cast<double>(std::fma(row0[j], z0, row1[j] * z1));
  }
}

// A point whose observations all have one block of N columns: records of
// one stride, no dispatch per observation.
template <int N>
COLMAP_IRAV4_AVX2 void MultiplyPointAvx2Uniform(
    const float* at, const uint32_t* poses, size_t count,
    const ProductColumns* pose_columns, const Eigen::Matrix3d* v_inv,
    const float* x_float, double* y, std::vector<Eigen::Vector2d>* ax) {
  constexpr int kStride = 8 + 2 * N;
  ax->resize(count);
  Eigen::Vector2d* const u_all = ax->data();
  double t0 = 0, t1 = 0, t2 = 0;
  for (size_t o = 0; o < count; ++o) {
    const float* record = at + o * kStride;
    PrefetchAhead(record);
    double u[2];
    MultiplyRowsAvx2<N>(record + 8, x_float + pose_columns[poses[o]].offset[0],
                        u);
    const float* b = record + 2;
    t0 += static_cast<double>(b[0]) * u[0] + static_cast<double>(b[1]) * u[1];
    t1 += static_cast<double>(b[2]) * u[0] + static_cast<double>(b[3]) * u[1];
    t2 += static_cast<double>(b[4]) * u[0] + static_cast<double>(b[5]) * u[1];
    u_all[o] = Eigen::Vector2d(u[0], u[1]);
  }
  double s[3] = {0, 0, 0};
  if (v_inv != nullptr) {
    const Eigen::Matrix3d& v = *v_inv;
    for (int i = 0; i < 3; ++i)
      s[i] = v(i, 0) * t0 + v(i, 1) * t1 + v(i, 2) * t2;
  }
  for (size_t o = 0; o < count; ++o) {
    const float* record = at + o * kStride;
    const float* b = record + 2;
    const double z[2] = {u_all[o][0] - (static_cast<double>(b[0]) * s[0] +
                                        static_cast<double>(b[2]) * s[1] +
                                        static_cast<double>(b[4]) * s[2]),
                         u_all[o][1] - (static_cast<double>(b[1]) * s[0] +
                                        static_cast<double>(b[3]) * s[1] +
                                        static_cast<double>(b[5]) * s[2])};
    AddTransposedRowsAvx2<N>(record + 8, z,
                             y + pose_columns[poses[o]].offset[0]);
  }
}

#endif  // COLMAP_IRAV4_AVX2_PRODUCT

}  // namespace

template <typename T>
void MultiplyPoint(const T* at, const uint32_t* poses, size_t count,
                   const ProductColumns* pose_columns,
                   const Eigen::Matrix3d* v_inv, const double* x,
                   const T* x_in_t, double* y,
                   std::vector<Eigen::Vector2d>* ax) {
  ax->resize(count);
  const T* const point_begin = at;
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  for (size_t o = 0; o < count; ++o) {
    const ProductColumns& columns = pose_columns[poses[o]];
    PrefetchAhead(at);
    const Record<T> r(at, columns.num_cols);
    at = r.next;
    double u[2];
    if (!FixedWidth(columns) ||
        !WithConstant<6, 7, 8, 9, 10>(columns.num_cols, [&](auto width) {
          MultiplyRows<width()>(r.row0, x_in_t + columns.offset[0], u);
        })) {
      MultiplyBlocks(r, columns, x, u);
    }
    t[0] += r.B(0) * u[0] + r.B(1) * u[1];
    t[1] += r.B(2) * u[0] + r.B(3) * u[1];
    t[2] += r.B(4) * u[0] + r.B(5) * u[1];
    (*ax)[o] = Eigen::Vector2d(u[0], u[1]);
  }
  const Eigen::Vector3d s =
      v_inv != nullptr ? Eigen::Vector3d(*v_inv * t) : Eigen::Vector3d::Zero();
  at = point_begin;
  for (size_t o = 0; o < count; ++o) {
    const ProductColumns& columns = pose_columns[poses[o]];
    const Record<T> r(at, columns.num_cols);
    at = r.next;
    const double z[2] = {
        (*ax)[o][0] - (r.B(0) * s[0] + r.B(2) * s[1] + r.B(4) * s[2]),
        (*ax)[o][1] - (r.B(1) * s[0] + r.B(3) * s[1] + r.B(5) * s[2])};
    if (!FixedWidth(columns) ||
        !WithConstant<6, 7, 8, 9, 10>(columns.num_cols, [&](auto width) {
          AddTransposedRows<width()>(r.row0, z, y + columns.offset[0]);
        })) {
      AddTransposedBlocks(r, columns, z, y);
    }
  }
}

template void MultiplyPoint(const double*, const uint32_t*, size_t,
                            const ProductColumns*, const Eigen::Matrix3d*,
                            const double*, const double*, double*,
                            std::vector<Eigen::Vector2d>*);
template void MultiplyPoint(const float*, const uint32_t*, size_t,
                            const ProductColumns*, const Eigen::Matrix3d*,
                            const double*, const float*, double*,
                            std::vector<Eigen::Vector2d>*);

template <typename T>
void AddPointToCoarseSystem(
    const T* at, const uint32_t* poses, size_t count,
    const ProductColumns* pose_columns, const Eigen::Matrix3d* v_inv,
    const CoarsePose* coarse_poses, CoarseSystem* system,
    std::vector<std::pair<int, Eigen::Matrix<double, 3, kNumCoarseModes>>>*
        shares) {
  using Share = Eigen::Matrix<double, 3, kNumCoarseModes>;
  shares->clear();
  for (size_t o = 0; o < count; ++o) {
    const ProductColumns& columns = pose_columns[poses[o]];
    const Record<T> r(at, columns.num_cols);
    at = r.next;
    const CoarsePose& pose = coarse_poses[poses[o]];
    if (pose.cluster < 0) continue;
    Eigen::Matrix<double, 2, kNumCoarseModes> e =
        Eigen::Matrix<double, 2, kNumCoarseModes>::Zero();
    for (int j = 0; j < pose.num_free; ++j) {
      e.row(0) += static_cast<double>(r.row0[j]) * pose.motion.row(j);
      e.row(1) += static_cast<double>(r.row1[j]) * pose.motion.row(j);
    }
    system->AddDiagonal(pose.cluster, e.transpose() * e);
    if (v_inv == nullptr) continue;
    Eigen::Matrix<double, 2, 3> b;
    for (int i = 0; i < 6; ++i) b(i % 2, i / 2) = r.B(i);
    auto share = std::find_if(shares->begin(), shares->end(),
                              [&](auto& s) { return s.first == pose.cluster; });
    if (share == shares->end()) {
      shares->push_back({pose.cluster, Share::Zero()});
      share = shares->end() - 1;
    }
    share->second.noalias() += b.transpose() * e;
  }
  if (v_inv == nullptr) return;
  // By cluster, so that the updates of a block row walk forward.
  std::sort(shares->begin(), shares->end(),
            [](const auto& x, const auto& y) { return x.first < y.first; });
  for (size_t i = 0; i < shares->size(); ++i) {
    const auto& [a, f_a] = (*shares)[i];
    const Share g_a = *v_inv * f_a;
    system->AddDiagonal(a, -g_a.transpose() * f_a);
    for (size_t j = i + 1; j < shares->size(); ++j) {
      const auto& [b, f_b] = (*shares)[j];
      system->AddPair(a, b, -g_a.transpose() * f_b);
    }
  }
}

template void AddPointToCoarseSystem(
    const double*, const uint32_t*, size_t, const ProductColumns*,
    const Eigen::Matrix3d*, const CoarsePose*, CoarseSystem*,
    std::vector<std::pair<int, Eigen::Matrix<double, 3, kNumCoarseModes>>>*);
template void AddPointToCoarseSystem(
    const float*, const uint32_t*, size_t, const ProductColumns*,
    const Eigen::Matrix3d*, const CoarsePose*, CoarseSystem*,
    std::vector<std::pair<int, Eigen::Matrix<double, 3, kNumCoarseModes>>>*);

bool Avx2ProductAvailable() {
#ifdef COLMAP_IRAV4_AVX2_PRODUCT
  static const bool available =
      __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  return available;
#else
  return false;
#endif
}

void MultiplyPointAvx2(const float* at, const uint32_t* poses, size_t count,
                       const ProductColumns* pose_columns,
                       const Eigen::Matrix3d* v_inv, const double* x,
                       const float* x_float, double* y,
                       std::vector<Eigen::Vector2d>* ax) {
  CHECK(Avx2ProductAvailable());
  if (count == 0) return;
#ifdef COLMAP_IRAV4_AVX2_PRODUCT
  const int width = pose_columns[poses[0]].num_cols;
  bool uniform = pose_columns[poses[0]].count == 1;
  for (size_t o = 1; o < count && uniform; ++o) {
    const ProductColumns& columns = pose_columns[poses[o]];
    uniform = columns.count == 1 && columns.num_cols == width;
  }
  // The kernels by width, from kMinFixedCols.
  static constexpr decltype(&MultiplyPointAvx2Uniform<6>) kUniform[] = {
      MultiplyPointAvx2Uniform<6>, MultiplyPointAvx2Uniform<7>,
      MultiplyPointAvx2Uniform<8>, MultiplyPointAvx2Uniform<9>,
      MultiplyPointAvx2Uniform<10>};
  static_assert(std::size(kUniform) == kMaxFixedCols - kMinFixedCols + 1);
  if (uniform && width >= kMinFixedCols && width <= kMaxFixedCols) {
    kUniform[width - kMinFixedCols](at, poses, count, pose_columns, v_inv,
                                    x_float, y, ax);
    return;
  }
  // Mixed widths, a held pose or a shared camera's two blocks.
  MultiplyPoint(at, poses, count, pose_columns, v_inv, x, x_float, y, ax);
#else
  (void)at, (void)poses, (void)count, (void)pose_columns, (void)v_inv;
  (void)x, (void)x_float, (void)y, (void)ax;
#endif
}

}  // namespace colmap_irav4
