// Particle-grid sums over tensor-product stencils (tensor_stencil.hpp).
//
// In 3D (tensor_stencil.hpp says why not in 2D). Per particle the same
// multiply-adds as node by node (about 3^dim dim^2
// each for a gather and a scatter), but on rows of 3 dim contiguous values
// and with the gradients formed from 6 dim numbers instead of read (dim 3^dim).
// GCC's own vectorization of the plain loops shuffled lanes and spilled,
// and ran no faster than the scalar code; the AVX2 + FMA kernels hold a
// padded row (3 dim values and one node of zeros: 2 vectors in 2D, 3 in 3D)
// and the accumulators in registers. They are compiled for that target only
// (function attributes) and chosen at run time, so the binary still runs on
// any x86-64 CPU; elsewhere the plain loops run.
#include "talus/solver/tensor_stencil.hpp"

#include "talus/core/types.hpp"  // stress_row

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define TALUS_HAVE_AVX2_KERNEL 1
#endif

namespace talus {

namespace {

constexpr int n1 = 3;  // functions per axis

// One particle's stencil as rows along x: w[r][l], the factor of gradient
// component l from the axes other than x for row r (y index r % 3, z index
// r / 3); start[r], the row's first value; the x axis's values and slopes.
template <int dim>
struct Rows {
  static constexpr int count = dim == 2 ? n1 : n1 * n1;
  static constexpr int length = n1 * dim;           // values in a row
  static constexpr int padded = dim == 2 ? 8 : 12;  // ... read and written
  double w[count][dim];
  long start[count];
  const double* value0;
  const double* slope0;
  // X^(l): the x factor of gradient component l.
  const double* x_factor(int l) const { return l == 0 ? slope0 : value0; }
};

template <int dim>
__attribute__((always_inline)) inline void particle_rows(const TensorStencils<dim>& S, std::size_t p, Rows<dim>& rows) {
  const double* basis = S.basis + p * 2 * dim * n1;
  rows.value0 = basis;
  rows.slope0 = basis + n1;
  const double* value1 = basis + 2 * n1;
  const double* slope1 = basis + 3 * n1;
  for (int r = 0; r < Rows<dim>::count; ++r) {
    const int j = r % n1, k = r / n1;
    rows.start[r] = static_cast<long>(dim) * (S.base[p] + j * S.stride[1] + (dim == 3 ? k * S.stride[dim - 1] : 0));
    for (int l = 0; l < dim; ++l) {
      double f = (l == 1 ? slope1 : value1)[j];
      if constexpr (dim == 3) f *= (l == 2 ? basis + 5 * n1 : basis + 4 * n1)[k];
      rows.w[r][l] = f;
    }
  }
}

// L(k, l) = sum_a X^(l)_a u[l][a dim + k] from the row sums u[l][e] = sum_r w[r][l] x_(r),e.
template <int dim>
__attribute__((always_inline)) inline void contract_x(const Rows<dim>& rows, const double (*u)[Rows<dim>::padded],
                                                      double* L) {
  for (int k = 0; k < dim; ++k)
    for (int l = 0; l < dim; ++l) {
      const double* xl = rows.x_factor(l);
      double sum = 0.0;
      for (int a = 0; a < n1; ++a) sum += xl[a] * u[l][a * dim + k];
      L[k * dim + l] = sum;
    }
}

// q[l][a dim + i] = X^(l)_a T_il (zero on the padding): y_(r),e += sum_l w[r][l] q[l][e].
template <int dim>
__attribute__((always_inline)) inline void expand_x(const Rows<dim>& rows, const double* T,
                                                    double (*q)[Rows<dim>::padded]) {
  for (int l = 0; l < dim; ++l) {
    const double* xl = rows.x_factor(l);
    for (int a = 0; a < n1; ++a)
      for (int i = 0; i < dim; ++i) q[l][a * dim + i] = xl[a] * T[stress_row<dim>(i, l)];
    for (int e = Rows<dim>::length; e < Rows<dim>::padded; ++e) q[l][e] = 0.0;
  }
}

// ---- The plain loops ----

template <int dim>
__attribute__((always_inline)) inline void gather_plain(const Rows<dim>& rows, const double* x, double* L) {
  double u[dim][Rows<dim>::padded] = {};
  for (int r = 0; r < Rows<dim>::count; ++r) {
    const double* xr = x + rows.start[r];
    for (int l = 0; l < dim; ++l)
      for (int e = 0; e < Rows<dim>::length; ++e) u[l][e] += rows.w[r][l] * xr[e];
  }
  contract_x<dim>(rows, u, L);
}

template <int dim>
__attribute__((always_inline)) inline void scatter_plain(const Rows<dim>& rows, const double* T, double* y) {
  double q[dim][Rows<dim>::padded];
  expand_x<dim>(rows, T, q);
  for (int r = 0; r < Rows<dim>::count; ++r) {
    double* yr = y + rows.start[r];
    for (int e = 0; e < Rows<dim>::length; ++e) {
      double sum = 0.0;
      for (int l = 0; l < dim; ++l) sum += rows.w[r][l] * q[l][e];
      yr[e] += sum;
    }
  }
}

template <int dim>
void gather_all_plain(const TensorStencils<dim>& S, const double* x, double* L) {
  Rows<dim> rows;
  for (std::size_t p = 0; p < S.particles; ++p) {
    if (S.base[p] < 0) continue;
    particle_rows(S, p, rows);
    gather_plain(rows, x, L + p * dim * dim);
  }
}

template <int dim>
void scatter_all_plain(const TensorStencils<dim>& S, const double* T, double* y) {
  constexpr int nS = TensorStencils<dim>::stress_components;
  Rows<dim> rows;
  for (std::size_t p = 0; p < S.particles; ++p) {
    if (S.base[p] < 0) continue;
    particle_rows(S, p, rows);
    scatter_plain(rows, T + p * nS, y);
  }
}

template <int dim>
void products_plain(const TensorStencilProduct<dim>& P) {
  constexpr int nS = TensorStencils<dim>::stress_components, nL = dim * dim;
  const TensorStencils<dim>& S = P.stencils;
  Rows<dim> rows;
  for (std::size_t p = 0; p < S.particles; ++p) {
    if (S.base[p] < 0 || !P.stiff[p]) continue;
    particle_rows(S, p, rows);
    double L[nL];
    gather_plain(rows, P.x, L);
    const double* A = P.tangent + p * nS * nL;
    const double factor = P.scale * P.volume[p];
    double t[nS] = {};
    for (int c = 0; c < nL; ++c)
      for (int s = 0; s < nS; ++s) t[s] += A[s + nS * c] * L[c];
    for (int s = 0; s < nS; ++s) t[s] *= factor;
    scatter_plain(rows, t, P.y);
  }
}

// ---- AVX2 + FMA ----

#ifdef TALUS_HAVE_AVX2_KERNEL
#define TALUS_AVX2 __attribute__((target("avx2,fma"), always_inline)) inline

template <int dim>
TALUS_AVX2 void gather_avx2(const Rows<dim>& rows, const double* x, double* L) {
  constexpr int vectors = Rows<dim>::padded / 4;
  __m256d u[dim][vectors];
#pragma GCC unroll 3
  for (int l = 0; l < dim; ++l)
#pragma GCC unroll 3
    for (int v = 0; v < vectors; ++v) u[l][v] = _mm256_setzero_pd();
#pragma GCC unroll 9
  for (int r = 0; r < Rows<dim>::count; ++r) {
    const double* xr = x + rows.start[r];
    __m256d xv[vectors];
#pragma GCC unroll 3
    for (int v = 0; v < vectors; ++v) xv[v] = _mm256_loadu_pd(xr + 4 * v);
#pragma GCC unroll 3
    for (int l = 0; l < dim; ++l) {
      const __m256d wl = _mm256_set1_pd(rows.w[r][l]);
#pragma GCC unroll 3
      for (int v = 0; v < vectors; ++v) u[l][v] = _mm256_fmadd_pd(wl, xv[v], u[l][v]);
    }
  }
  double us[dim][Rows<dim>::padded];
#pragma GCC unroll 3
  for (int l = 0; l < dim; ++l)
#pragma GCC unroll 3
    for (int v = 0; v < vectors; ++v) _mm256_storeu_pd(us[l] + 4 * v, u[l][v]);
  contract_x<dim>(rows, us, L);
}

template <int dim>
TALUS_AVX2 void scatter_avx2(const Rows<dim>& rows, const double* T, double* y) {
  constexpr int vectors = Rows<dim>::padded / 4;
  alignas(32) double q[dim][Rows<dim>::padded];
  expand_x<dim>(rows, T, q);
  __m256d qv[dim][vectors];
#pragma GCC unroll 3
  for (int l = 0; l < dim; ++l)
#pragma GCC unroll 3
    for (int v = 0; v < vectors; ++v) qv[l][v] = _mm256_load_pd(q[l] + 4 * v);
#pragma GCC unroll 9
  for (int r = 0; r < Rows<dim>::count; ++r) {
    double* yr = y + rows.start[r];
#pragma GCC unroll 3
    for (int v = 0; v < vectors; ++v) {
      __m256d sum = _mm256_loadu_pd(yr + 4 * v);
#pragma GCC unroll 3
      for (int l = 0; l < dim; ++l) sum = _mm256_fmadd_pd(_mm256_set1_pd(rows.w[r][l]), qv[l][v], sum);
      _mm256_storeu_pd(yr + 4 * v, sum);
    }
  }
}

// t = factor A L: A's columns are nS contiguous values (4 + 2 in 3D, 3 in 2D).
template <int dim>
TALUS_AVX2 void tangent_product_avx2(const double* A, const double* L, double factor, double* t) {
  constexpr int nS = TensorStencils<dim>::stress_components, nL = dim * dim;
  if constexpr (dim == 3) {
    __m256d t_lo = _mm256_setzero_pd();
    __m128d t_hi = _mm_setzero_pd();
#pragma GCC unroll 9
    for (int c = 0; c < nL; ++c) {
      t_lo = _mm256_fmadd_pd(_mm256_loadu_pd(A + nS * c), _mm256_set1_pd(L[c]), t_lo);
      t_hi = _mm_fmadd_pd(_mm_loadu_pd(A + nS * c + 4), _mm_set1_pd(L[c]), t_hi);
    }
    _mm256_storeu_pd(t, _mm256_mul_pd(t_lo, _mm256_set1_pd(factor)));
    _mm_storeu_pd(t + 4, _mm_mul_pd(t_hi, _mm_set1_pd(factor)));
  } else {
    for (int s = 0; s < nS; ++s) t[s] = 0.0;
    for (int c = 0; c < nL; ++c)
      for (int s = 0; s < nS; ++s) t[s] += A[s + nS * c] * L[c];
    for (int s = 0; s < nS; ++s) t[s] *= factor;
  }
}

// The drivers below repeat the plain ones line for line: GCC does not
// inline a target-specific always_inline function into one compiled for
// the baseline, so each target needs its own loop over the particles.
template <int dim>
TALUS_AVX2 void gather_all_avx2(const TensorStencils<dim>& S, const double* x, double* L) {
  Rows<dim> rows;
  for (std::size_t p = 0; p < S.particles; ++p) {
    if (S.base[p] < 0) continue;
    particle_rows(S, p, rows);
    gather_avx2(rows, x, L + p * dim * dim);
  }
}

template <int dim>
TALUS_AVX2 void scatter_all_avx2(const TensorStencils<dim>& S, const double* T, double* y) {
  constexpr int nS = TensorStencils<dim>::stress_components;
  Rows<dim> rows;
  for (std::size_t p = 0; p < S.particles; ++p) {
    if (S.base[p] < 0) continue;
    particle_rows(S, p, rows);
    scatter_avx2(rows, T + p * nS, y);
  }
}

template <int dim>
TALUS_AVX2 void products_avx2(const TensorStencilProduct<dim>& P) {
  constexpr int nS = TensorStencils<dim>::stress_components, nL = dim * dim;
  const TensorStencils<dim>& S = P.stencils;
  Rows<dim> rows;
  for (std::size_t p = 0; p < S.particles; ++p) {
    if (S.base[p] < 0 || !P.stiff[p]) continue;
    particle_rows(S, p, rows);
    double L[nL];
    gather_avx2(rows, P.x, L);
    double t[nS];
    tangent_product_avx2<dim>(P.tangent + p * nS * nL, L, P.scale * P.volume[p], t);
    scatter_avx2(rows, t, P.y);
  }
}

// The entry points of the AVX2 code (not inlined into code for the baseline).
#define TALUS_AVX2_ENTRY __attribute__((target("avx2,fma"), noinline))
TALUS_AVX2_ENTRY void gather_avx2_3d(const TensorStencils<3>& S, const double* x, double* L) { gather_all_avx2(S, x, L); }
TALUS_AVX2_ENTRY void scatter_avx2_3d(const TensorStencils<3>& S, const double* T, double* y) { scatter_all_avx2(S, T, y); }
TALUS_AVX2_ENTRY void products_avx2_3d(const TensorStencilProduct<3>& P) { products_avx2(P); }

bool cpu_has_avx2_fma() {
  static const bool has = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  return has;
}
#else
bool cpu_has_avx2_fma() { return false; }
#endif

bool vectorized(TensorKernel kernel) { return kernel == TensorKernel::automatic && cpu_has_avx2_fma(); }

}  // namespace

bool tensor_kernel_vectorized() { return cpu_has_avx2_fma(); }

#ifdef TALUS_HAVE_AVX2_KERNEL
#define TALUS_DISPATCH(vector_call) \
  if (vectorized(kernel)) return vector_call
#else
#define TALUS_DISPATCH(vector_call) (void)kernel
#endif

void gather_tensor_gradients(const TensorStencils<3>& S, const double* x, double* L, TensorKernel kernel) {
  TALUS_DISPATCH(gather_avx2_3d(S, x, L));
  gather_all_plain(S, x, L);
}

void scatter_tensor_stresses(const TensorStencils<3>& S, const double* T, double* y, TensorKernel kernel) {
  TALUS_DISPATCH(scatter_avx2_3d(S, T, y));
  scatter_all_plain(S, T, y);
}

void add_tensor_stencil_products(const TensorStencilProduct<3>& product, TensorKernel kernel) {
  TALUS_DISPATCH(products_avx2_3d(product));
  products_plain(product);
}

}  // namespace talus
