#pragma once
// Particle-grid sums over 3D stencils that are full tensor products of three
// functions per axis (quadratic B-splines at a point, the default), taken
// axis by axis (docs/solver.md#the-jacobian-as-an-operator). In 2D (9 nodes)
// the node-by-node loops are as fast (measured), so the kernels exist for 3D
// only; the templates keep the dimension where it costs nothing:
//
//   gather   L_p = sum_b x_b (x) grad N_b(x_p)            (a velocity gradient)
//   scatter  y_a += sum_p T_p grad N_a(x_p)                (T_p symmetric: a stress)
//   product  y += sum_p grad N_a h theta^2 V_p (A_p : L_p(x))   (the Jacobian's, both at once)
//
//   grad N_abc = (X'_a Y_b Z_c, X_a Y'_b Z_c, X_a Y_b Z'_c).
//
// Along x a row of a stencil's nodes is 3 dim contiguous values of the
// ghosted arrays, so every pass is a loop over such rows with fixed trip
// counts. Plain loops over raw arrays, so that the kernels are compiled
// twice (AVX2 + FMA and the baseline, chosen at run time: tensor_stencil.cpp)
// without sharing an inline function between the two. The ghosted arrays
// must carry dim values of padding past their end (rows are read and
// written 4 values at a time; the padding's weights are zero).
#include <cstddef>

namespace talus {

template <int dim>
struct TensorStencils {
  static constexpr int stress_components = dim == 2 ? 3 : 6;  // xx, yy, (zz, yz, xz,) xy
  int stride[dim] = {};          // local index step per axis (stride[0] = 1)
  std::size_t particles = 0;
  const int* base = nullptr;     // per particle: first node's local index; < 0: not a tensor stencil
  const double* basis = nullptr;  // per particle 6 dim: per axis 3 values, then 3 slopes
};

template <int dim>
struct TensorStencilProduct {
  TensorStencils<dim> stencils;
  const double* x = nullptr;  // ghosted grid vector, dim values per node
  double* y = nullptr;        // accumulated into
  const char* stiff = nullptr;  // per particle: A_p != 0
  // Per particle stress_components x dim^2, column-major (Eigen's default):
  // d sigma_(row) / d L_(k dim + l).
  const double* tangent = nullptr;
  const double* volume = nullptr;  // per particle V_p
  double scale = 0.0;              // h theta^2
};

// `kernel`: the AVX2 + FMA one where the CPU has it (automatic), or the plain
// loops (baseline; the tests compare the two).
enum class TensorKernel { automatic, baseline };

// L (dim^2 per particle, row-major k dim + l) of every tensor stencil; the
// other particles' entries are left as they are.
void gather_tensor_gradients(const TensorStencils<3>& stencils, const double* x, double* L,
                             TensorKernel kernel = TensorKernel::automatic);
// y += sum_p T_p grad N_a for every tensor stencil (T: stress_components per particle).
void scatter_tensor_stresses(const TensorStencils<3>& stencils, const double* T, double* y,
                             TensorKernel kernel = TensorKernel::automatic);
// y += the product of every tensor stencil's particle that is stiff.
void add_tensor_stencil_products(const TensorStencilProduct<3>& product, TensorKernel kernel = TensorKernel::automatic);
// Whether `automatic` takes the AVX2 + FMA kernels on this CPU.
bool tensor_kernel_vectorized();

}  // namespace talus
