// The Jacobian's product over tensor-product stencils (src/solver/tensor_stencil.cpp):
// both kernels (AVX2 + FMA where the CPU has it, and the plain loops)
// against the product written node by node, with each node's gradient
// formed explicitly, on random bases, tangents and velocities, with
// neighbouring particles sharing grid points (so that the accumulation into
// y is checked, not only one stencil), in 2D and 3D.
#include <catch2/catch.hpp>
#include <array>
#include <cmath>
#include <random>
#include <vector>

#include "talus/solver/tensor_stencil.hpp"

using namespace talus;

namespace {

constexpr int stress_row(int dim, int i, int j) { return dim == 2 ? (i == j ? i : 2) : (i == j ? i : 6 - i - j); }

template <int dim>
struct Case {
  static constexpr int nS = dim == 2 ? 3 : 6, nL = dim * dim, n1 = 3;
  std::array<int, dim> size{};  // ghosted points per axis
  std::vector<double> x;
  std::vector<int> base;
  std::vector<char> stiff;
  std::vector<double> basis, tangent, volume;
  double scale = 0.37;

  Case() {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> uniform(-1.0, 1.0);
    for (int ax = 0; ax < dim; ++ax) size[ax] = 6 + ax;
    int points = 1;
    for (int ax = 0; ax < dim; ++ax) points *= size[ax];
    x.resize(static_cast<std::size_t>(dim) * (points + 1));  // one node of padding (tensor_stencil.hpp)
    for (std::size_t e = 0; e + dim < x.size(); ++e) x[e] = uniform(rng);
    // A particle at every stencil position of the box, twice: many overlaps.
    const int positions = dim == 2 ? (size[0] - 2) * (size[1] - 2) : (size[0] - 2) * (size[1] - 2) * (size[2] - 2);
    for (int copy = 0; copy < 2; ++copy)
      for (int n = 0; n < positions; ++n) {
        int rest = n, index = 0, stride = 1;
        for (int ax = 0; ax < dim; ++ax) {
          index += (rest % (size[ax] - 2)) * stride;
          rest /= size[ax] - 2;
          stride *= size[ax];
        }
        base.push_back(index);
        stiff.push_back(n % 5 != 3);  // some particles add nothing
        for (int k = 0; k < 2 * dim * n1; ++k) basis.push_back(uniform(rng));
        for (int k = 0; k < nS * nL; ++k) tangent.push_back(uniform(rng));
        volume.push_back(0.5 + 0.5 * uniform(rng));
      }
    base[3] = -1;  // a particle off the tensor path
  }

  TensorStencilProduct<dim> product(std::vector<double>& y) const {
    TensorStencilProduct<dim> p;
    p.x = x.data();
    p.y = y.data();
    p.stride[0] = 1;
    for (int ax = 1; ax < dim; ++ax) p.stride[ax] = p.stride[ax - 1] * size[ax - 1];
    p.particles = base.size();
    p.base = base.data();
    p.stiff = stiff.data();
    p.basis = basis.data();
    p.tangent = tangent.data();
    p.volume = volume.data();
    p.scale = scale;
    return p;
  }

  // Node by node: grad N_a = per axis the slope on that axis, the value on the others.
  std::vector<double> reference() const {
    std::vector<double> y(x.size(), 0.0);
    const TensorStencilProduct<dim> p = product(y);
    const int nodes = dim == 2 ? 9 : 27;
    for (std::size_t q = 0; q < base.size(); ++q) {
      if (base[q] < 0 || !stiff[q]) continue;
      const double* b = basis.data() + q * 2 * dim * n1;
      std::vector<int> local(nodes);
      std::vector<std::array<double, dim>> gradient(nodes);
      for (int n = 0; n < nodes; ++n) {
        int rest = n, offset = 0;
        std::array<int, dim> index;
        for (int ax = 0; ax < dim; ++ax, rest /= n1) index[ax] = rest % n1, offset += index[ax] * p.stride[ax];
        local[n] = base[q] + offset;
        for (int l = 0; l < dim; ++l) {
          double g = 1.0;
          for (int ax = 0; ax < dim; ++ax) g *= b[(2 * ax + (ax == l)) * n1 + index[ax]];
          gradient[n][l] = g;
        }
      }
      std::array<double, nL> L{};
      for (int n = 0; n < nodes; ++n)
        for (int k = 0; k < dim; ++k)
          for (int l = 0; l < dim; ++l) L[k * dim + l] += x[dim * local[n] + k] * gradient[n][l];
      std::array<double, nS> t{};
      for (int s = 0; s < nS; ++s)
        for (int c = 0; c < nL; ++c) t[s] += tangent[q * nS * nL + s + nS * c] * L[c];
      for (int n = 0; n < nodes; ++n)
        for (int i = 0; i < dim; ++i)
          for (int j = 0; j < dim; ++j)
            y[dim * local[n] + i] += scale * volume[q] * t[stress_row(dim, i, j)] * gradient[n][j];
    }
    return y;
  }
};

template <int dim>
void check_kernels() {
  const Case<dim> c;
  const std::vector<double> expected = c.reference();
  double norm = 0.0;
  for (const double e : expected) norm = std::max(norm, std::abs(e));
  REQUIRE(norm > 1e-2);  // the products are not trivially zero (inputs of order 1)
  for (const TensorKernel kernel : {TensorKernel::automatic, TensorKernel::baseline}) {
    std::vector<double> y(c.x.size(), 0.0);
    add_tensor_stencil_products(c.product(y), kernel);
    double difference = 0.0;
    for (std::size_t e = 0; e < y.size(); ++e) difference = std::max(difference, std::abs(y[e] - expected[e]));
    INFO(dim << "D, " << (kernel == TensorKernel::baseline ? "baseline" : "automatic") << " kernel ("
              << (tensor_kernel_vectorized() ? "AVX2 + FMA on this CPU" : "baseline on this CPU")
              << "): max |y - y_ref| = " << difference << " of max |y_ref| = " << norm);
    // The same sums in another order: round-off, about 1e-16 times the
    // largest partial sum (a few times |y|).
    CHECK(difference <= 1e-13 * norm);
    // The padding node past the end is written with zeros added only.
    for (int c2 = 0; c2 < dim; ++c2) CHECK(y[y.size() - dim + c2] == 0.0);
  }
}

}  // namespace

TEST_CASE("tensor-product stencils: the Jacobian's product equals the node-by-node product", "[jacobian]") {
  check_kernels<2>();
  check_kernels<3>();
}
