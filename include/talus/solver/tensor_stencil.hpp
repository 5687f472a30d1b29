#pragma once
// The Jacobian's product over the particles whose stencils are full tensor
// products of three quadratic B-splines per axis (point quadrature, the
// default), contracted axis by axis (docs/solver.md#the-jacobian-as-an-operator):
//
//   y += h theta^2 V_p sum_a grad N_a (A_p : L_p(x)),  L_p(x) = sum_b x_b (x) grad N_b,
//   grad N_abc = (X'_a Y_b Z_c, X_a Y'_b Z_c, X_a Y_b Z'_c).
//
// Along x a row of a stencil's nodes is 3 dim contiguous values of the
// ghosted arrays, so both the gather of L and the scatter of the stress are
// loops over rows with fixed trip counts. Plain loops over raw arrays, so
// that the one kernel is compiled twice (AVX2 + FMA and the baseline, chosen
// at run time: tensor_stencil.cpp) without sharing an inline function
// between the two.
#include <cstddef>

namespace talus {

template <int dim>
struct TensorStencilProduct {
  static constexpr int stress_components = dim == 2 ? 3 : 6;  // rows of a tangent
  const double* x = nullptr;  // ghosted grid vector, dim values per node
  double* y = nullptr;        // accumulated into
  int stride[dim] = {};       // local index step per axis (stride[0] = 1)
  std::size_t particles = 0;
  const int* base = nullptr;     // per particle: first node's local index; < 0: not on this path
  const char* stiff = nullptr;   // per particle: A_p != 0
  const double* basis = nullptr;  // per particle 6 dim: per axis 3 values, then 3 slopes
  // Per particle stress_components x dim^2, column-major (Eigen's default):
  // d sigma_(row) / d L_(k dim + l), the rows xx, yy, (zz, yz, xz,) xy.
  const double* tangent = nullptr;
  const double* volume = nullptr;  // per particle V_p
  double scale = 0.0;              // h theta^2
};

// y += the product of every particle with base >= 0 and stiff. `kernel`:
// the AVX2 + FMA one where the CPU has it (automatic), or the plain loops
// (baseline; the tests compare the two).
enum class TensorKernel { automatic, baseline };
void add_tensor_stencil_products(const TensorStencilProduct<2>& product, TensorKernel kernel = TensorKernel::automatic);
void add_tensor_stencil_products(const TensorStencilProduct<3>& product, TensorKernel kernel = TensorKernel::automatic);
// Whether `automatic` takes the AVX2 + FMA kernel on this CPU.
bool tensor_kernel_vectorized();

}  // namespace talus
