// The Jacobian's product over tensor-product stencils (tensor_stencil.hpp).
//
// Per particle the same multiply-adds as the node-by-node product (about
// 2 x 3^dim x dim^2 for the gather and the scatter, nS dim^2 for the
// tangent), but on rows of 3 dim contiguous values and with the gradients
// formed from 6 dim numbers instead of read (dim 3^dim): loops the compiler
// vectorizes. The build's baseline (x86-64: SSE2) gains little from that;
// on x86-64 GCC also compiles an AVX2 + FMA clone, picked at run time
// (target_clones), so the binary still runs on any x86-64 CPU.
#include "talus/solver/tensor_stencil.hpp"

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#endif

namespace talus {

namespace {

constexpr int n1 = 3;  // quadratic B-splines: three per axis at a point

// Row of sigma_ij in a tangent: xx, yy, xy in 2D; Voigt (xx, yy, zz, yz, xz, xy) in 3D.
template <int dim>
constexpr int stress_row(int i, int j) {
  return dim == 2 ? (i == j ? i : 2) : (i == j ? i : 6 - i - j);
}

template <int dim>
__attribute__((always_inline)) inline void add_products(const TensorStencilProduct<dim>& P) {
  constexpr int nS = TensorStencilProduct<dim>::stress_components, nL = dim * dim;
  constexpr int row = n1 * dim;                    // values in a row of nodes along x
  // Rows are read and written padded to a multiple of 4 values (one more
  // node along x, weighted zero; the ghosted arrays carry dim values of
  // padding): whole AVX2 vectors, no shuffles.
  constexpr int padded = dim == 2 ? 8 : 12;
  constexpr int rows = dim == 2 ? n1 : n1 * n1;    // rows of a stencil
  constexpr int per_particle = 2 * dim * n1;       // basis numbers
  for (std::size_t p = 0; p < P.particles; ++p) {
    if (P.base[p] < 0 || !P.stiff[p]) continue;
    const double* basis = P.basis + p * per_particle;
    const double* value[dim];
    const double* slope[dim];
    for (int ax = 0; ax < dim; ++ax) value[ax] = basis + 2 * ax * n1, slope[ax] = basis + (2 * ax + 1) * n1;
    // w[r][l]: the factor of gradient component l from the axes other than
    // x, for row r (y index r % 3, z index r / 3); start: the row's first value.
    double w[rows][dim];
    long start[rows];
    for (int r = 0; r < rows; ++r) {
      const int j = r % n1, k = r / n1;
      start[r] = static_cast<long>(dim) * (P.base[p] + j * P.stride[1] + (dim == 3 ? k * P.stride[dim - 1] : 0));
      for (int l = 0; l < dim; ++l) {
        double f = (l == 1 ? slope[1] : value[1])[j];
        if (dim == 3) f *= (l == 2 ? slope[dim - 1] : value[dim - 1])[k];
        w[r][l] = f;
      }
    }
    // Gather: u[l][a dim + k] = sum_r w[r][l] x_(a, r),k, then
    // L(k, l) = sum_a X^(l)_a u[l][a dim + k] with X^(0) = X', X^(l > 0) = X.
    double u[dim][padded] = {};
    for (int r = 0; r < rows; ++r) {
      const double* xr = P.x + start[r];
      for (int l = 0; l < dim; ++l)
        for (int e = 0; e < padded; ++e) u[l][e] += w[r][l] * xr[e];
    }
    double L[nL];
    for (int k = 0; k < dim; ++k)
      for (int l = 0; l < dim; ++l) {
        const double* xl = l == 0 ? slope[0] : value[0];
        double sum = 0.0;
        for (int a = 0; a < n1; ++a) sum += xl[a] * u[l][a * dim + k];
        L[k * dim + l] = sum;
      }
    // The stress's change, times h theta^2 V_p.
    const double* A = P.tangent + p * nS * nL;
    double t[nS] = {};
    for (int c = 0; c < nL; ++c)
      for (int s = 0; s < nS; ++s) t[s] += A[s + nS * c] * L[c];
    const double factor = P.scale * P.volume[p];
    // Scatter: y_(a, r),i += sum_l w[r][l] q[l][a dim + i], q[l][a dim + i] = X^(l)_a T_il.
    double q[dim][padded] = {};
    for (int l = 0; l < dim; ++l) {
      const double* xl = l == 0 ? slope[0] : value[0];
      for (int a = 0; a < n1; ++a)
        for (int i = 0; i < dim; ++i) q[l][a * dim + i] = factor * xl[a] * t[stress_row<dim>(i, l)];
    }
    for (int r = 0; r < rows; ++r) {
      double* yr = P.y + start[r];
      for (int e = 0; e < padded; ++e) {
        double sum = 0.0;
        for (int l = 0; l < dim; ++l) sum += w[r][l] * q[l][e];
        yr[e] += sum;
      }
    }
  }
}

#if defined(__x86_64__) && defined(__GNUC__)
// The same products with AVX2 + FMA intrinsics: a padded row is dim / 4 * 3
// whole vectors (3 in 3D, 2 in 2D), the accumulators u and the weights q
// stay in registers, each row costs dim (dim / 4 * 3) fused multiply-adds
// per pass. GCC's own vectorization of the loops above shuffled lanes and
// spilled, and ran no faster than the scalar code.
template <int dim>
__attribute__((target("avx2,fma"), always_inline)) inline void add_products_avx2(const TensorStencilProduct<dim>& P) {
  constexpr int nS = TensorStencilProduct<dim>::stress_components, nL = dim * dim;
  constexpr int vectors = dim == 2 ? 2 : 3;  // per padded row
  constexpr int rows = dim == 2 ? n1 : n1 * n1;
  constexpr int per_particle = 2 * dim * n1;
  for (std::size_t p = 0; p < P.particles; ++p) {
    if (P.base[p] < 0 || !P.stiff[p]) continue;
    const double* basis = P.basis + p * per_particle;
    const double* value[dim];
    const double* slope[dim];
    for (int ax = 0; ax < dim; ++ax) value[ax] = basis + 2 * ax * n1, slope[ax] = basis + (2 * ax + 1) * n1;
    double w[rows][dim];
    long start[rows];
#pragma GCC unroll 9
    for (int r = 0; r < rows; ++r) {
      const int j = r % n1, k = r / n1;
      start[r] = static_cast<long>(dim) * (P.base[p] + j * P.stride[1] + (dim == 3 ? k * P.stride[dim - 1] : 0));
      for (int l = 0; l < dim; ++l) {
        double f = (l == 1 ? slope[1] : value[1])[j];
        if (dim == 3) f *= (l == 2 ? slope[dim - 1] : value[dim - 1])[k];
        w[r][l] = f;
      }
    }
    __m256d u[dim][vectors];
#pragma GCC unroll 3
    for (int l = 0; l < dim; ++l)
#pragma GCC unroll 3
      for (int v = 0; v < vectors; ++v) u[l][v] = _mm256_setzero_pd();
#pragma GCC unroll 9
    for (int r = 0; r < rows; ++r) {
      const double* xr = P.x + start[r];
      __m256d xv[vectors];
#pragma GCC unroll 3
      for (int v = 0; v < vectors; ++v) xv[v] = _mm256_loadu_pd(xr + 4 * v);
#pragma GCC unroll 3
      for (int l = 0; l < dim; ++l) {
        const __m256d wl = _mm256_set1_pd(w[r][l]);
#pragma GCC unroll 3
        for (int v = 0; v < vectors; ++v) u[l][v] = _mm256_fmadd_pd(wl, xv[v], u[l][v]);
      }
    }
    double us[dim][4 * vectors];
#pragma GCC unroll 3
    for (int l = 0; l < dim; ++l)
#pragma GCC unroll 3
      for (int v = 0; v < vectors; ++v) _mm256_storeu_pd(us[l] + 4 * v, u[l][v]);
    double L[nL];
    for (int k = 0; k < dim; ++k)
      for (int l = 0; l < dim; ++l) {
        const double* xl = l == 0 ? slope[0] : value[0];
        L[k * dim + l] = xl[0] * us[l][k] + xl[1] * us[l][dim + k] + xl[2] * us[l][2 * dim + k];
      }
    // t = V_p h theta^2 A L: A's columns are nS contiguous values (4 + 2 in 3D, 3 in 2D).
    const double* A = P.tangent + p * nS * nL;
    alignas(32) double t[8];
    if constexpr (dim == 3) {
      __m256d t_lo = _mm256_setzero_pd();
      __m128d t_hi = _mm_setzero_pd();
#pragma GCC unroll 9
      for (int c = 0; c < nL; ++c) {
        t_lo = _mm256_fmadd_pd(_mm256_loadu_pd(A + nS * c), _mm256_set1_pd(L[c]), t_lo);
        t_hi = _mm_fmadd_pd(_mm_loadu_pd(A + nS * c + 4), _mm_set1_pd(L[c]), t_hi);
      }
      _mm256_store_pd(t, t_lo);
      _mm_store_pd(t + 4, t_hi);
    } else {
      for (int s = 0; s < nS; ++s) t[s] = 0.0;
      for (int c = 0; c < nL; ++c)
        for (int s = 0; s < nS; ++s) t[s] += A[s + nS * c] * L[c];
    }
    const double factor = P.scale * P.volume[p];
    alignas(32) double q[dim][4 * vectors];
    for (int l = 0; l < dim; ++l) {
      const double* xl = l == 0 ? slope[0] : value[0];
      for (int a = 0; a < n1; ++a) {
        const double xa = factor * xl[a];
        for (int i = 0; i < dim; ++i) q[l][a * dim + i] = xa * t[stress_row<dim>(i, l)];
      }
      for (int e = n1 * dim; e < 4 * vectors; ++e) q[l][e] = 0.0;
    }
    __m256d qv[dim][vectors];
#pragma GCC unroll 3
    for (int l = 0; l < dim; ++l)
#pragma GCC unroll 3
      for (int v = 0; v < vectors; ++v) qv[l][v] = _mm256_load_pd(q[l] + 4 * v);
#pragma GCC unroll 9
    for (int r = 0; r < rows; ++r) {
      double* yr = P.y + start[r];
#pragma GCC unroll 3
      for (int v = 0; v < vectors; ++v) {
        __m256d sum = _mm256_loadu_pd(yr + 4 * v);
#pragma GCC unroll 3
        for (int l = 0; l < dim; ++l) sum = _mm256_fmadd_pd(_mm256_set1_pd(w[r][l]), qv[l][v], sum);
        _mm256_storeu_pd(yr + 4 * v, sum);
      }
    }
  }
}

__attribute__((target("avx2,fma"))) void add_products_avx2_2d(const TensorStencilProduct<2>& P) { add_products_avx2<2>(P); }
__attribute__((target("avx2,fma"))) void add_products_avx2_3d(const TensorStencilProduct<3>& P) { add_products_avx2<3>(P); }

bool cpu_has_avx2_fma() {
  static const bool has = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  return has;
}
#define TALUS_HAVE_AVX2_KERNEL 1
#endif

}  // namespace

bool tensor_kernel_vectorized() {
#ifdef TALUS_HAVE_AVX2_KERNEL
  return cpu_has_avx2_fma();
#else
  return false;
#endif
}

void add_tensor_stencil_products(const TensorStencilProduct<2>& product, TensorKernel kernel) {
#ifdef TALUS_HAVE_AVX2_KERNEL
  if (kernel == TensorKernel::automatic && cpu_has_avx2_fma()) return add_products_avx2_2d(product);
#endif
  add_products<2>(product);
}

void add_tensor_stencil_products(const TensorStencilProduct<3>& product, TensorKernel kernel) {
#ifdef TALUS_HAVE_AVX2_KERNEL
  if (kernel == TensorKernel::automatic && cpu_has_avx2_fma()) return add_products_avx2_3d(product);
#endif
  add_products<3>(product);
}

}  // namespace talus
