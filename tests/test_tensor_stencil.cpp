// Sums over tensor-product stencils (src/solver/tensor_stencil.cpp): the
// gather of a velocity gradient, the scatter of a stress and the Jacobian's
// product, both kernels (AVX2 + FMA where the CPU has it, and the plain
// loops), against the same sums written node by node, with each node's gradient
// formed explicitly, on random bases, tangents and velocities, with
// neighbouring particles sharing grid points (so that the accumulation into
// y is checked, not only one stencil), in 3D (the kernels' dimension).
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

  TensorStencils<dim> stencils() const {
    TensorStencils<dim> s;
    s.stride[0] = 1;
    for (int ax = 1; ax < dim; ++ax) s.stride[ax] = s.stride[ax - 1] * size[ax - 1];
    s.particles = base.size();
    s.base = base.data();
    s.basis = basis.data();
    return s;
  }

  TensorStencilProduct<dim> product(std::vector<double>& y) const {
    TensorStencilProduct<dim> p;
    p.stencils = stencils();
    p.x = x.data();
    p.y = y.data();
    p.stiff = stiff.data();
    p.tangent = tangent.data();
    p.volume = volume.data();
    p.scale = scale;
    return p;
  }

  // Node by node: particle q's local indices and gradients, grad N_a = per
  // axis the slope on that axis and the value on the others.
  void nodes(std::size_t q, std::vector<int>& local, std::vector<std::array<double, dim>>& gradient) const {
    const int count = dim == 2 ? 9 : 27;
    const TensorStencils<dim> s = stencils();
    const double* b = basis.data() + q * 2 * dim * n1;
    local.resize(count);
    gradient.resize(count);
    for (int n = 0; n < count; ++n) {
      int rest = n, offset = 0;
      std::array<int, dim> index;
      for (int ax = 0; ax < dim; ++ax, rest /= n1) index[ax] = rest % n1, offset += index[ax] * s.stride[ax];
      local[n] = base[q] + offset;
      for (int l = 0; l < dim; ++l) {
        double g = 1.0;
        for (int ax = 0; ax < dim; ++ax) g *= b[(2 * ax + (ax == l)) * n1 + index[ax]];
        gradient[n][l] = g;
      }
    }
  }
  std::array<double, nL> gradient_of(std::size_t q) const {
    std::vector<int> local;
    std::vector<std::array<double, dim>> gradient;
    nodes(q, local, gradient);
    std::array<double, nL> L{};
    for (std::size_t n = 0; n < local.size(); ++n)
      for (int k = 0; k < dim; ++k)
        for (int l = 0; l < dim; ++l) L[k * dim + l] += x[dim * local[n] + k] * gradient[n][l];
    return L;
  }
  void scatter(std::size_t q, const double* T, std::vector<double>& y) const {
    std::vector<int> local;
    std::vector<std::array<double, dim>> gradient;
    nodes(q, local, gradient);
    for (std::size_t n = 0; n < local.size(); ++n)
      for (int i = 0; i < dim; ++i)
        for (int j = 0; j < dim; ++j) y[dim * local[n] + i] += T[stress_row(dim, i, j)] * gradient[n][j];
  }
  std::vector<double> reference_product() const {
    std::vector<double> y(x.size(), 0.0);
    for (std::size_t q = 0; q < base.size(); ++q) {
      if (base[q] < 0 || !stiff[q]) continue;
      const std::array<double, nL> L = gradient_of(q);
      std::array<double, nS> t{};
      for (int s = 0; s < nS; ++s)
        for (int c = 0; c < nL; ++c) t[s] += scale * volume[q] * tangent[q * nS * nL + s + nS * c] * L[c];
      scatter(q, t.data(), y);
    }
    return y;
  }
};

double max_abs(const std::vector<double>& v) {
  double m = 0.0;
  for (const double e : v) m = std::max(m, std::abs(e));
  return m;
}

template <int dim>
void check_kernels() {
  constexpr int nS = Case<dim>::nS, nL = Case<dim>::nL;
  const Case<dim> c;
  const std::size_t particles = c.base.size();
  // A stress per particle for the scatter.
  std::vector<double> T(particles * nS);
  for (std::size_t e = 0; e < T.size(); ++e) T[e] = std::sin(1.0 + 0.7 * e);
  const std::vector<double> expected_product = c.reference_product();
  std::vector<double> expected_scatter(c.x.size(), 0.0);
  for (std::size_t q = 0; q < particles; ++q)
    if (c.base[q] >= 0) c.scatter(q, T.data() + q * nS, expected_scatter);
  // The sums are of order 1 (inputs in [-1, 1]), not trivially zero.
  REQUIRE(max_abs(expected_product) > 1e-2);
  REQUIRE(max_abs(expected_scatter) > 1e-2);
  for (const TensorKernel kernel : {TensorKernel::automatic, TensorKernel::baseline}) {
    INFO(dim << "D, " << (kernel == TensorKernel::baseline ? "baseline" : "automatic") << " kernel ("
              << (tensor_kernel_vectorized() ? "AVX2 + FMA on this CPU" : "baseline on this CPU") << ")");
    // The same sums in another order: round-off, about 1e-16 times the
    // largest partial sum (a few times the largest result).
    std::vector<double> y(c.x.size(), 0.0);
    add_tensor_stencil_products(c.product(y), kernel);
    double difference = 0.0;
    for (std::size_t e = 0; e < y.size(); ++e) difference = std::max(difference, std::abs(y[e] - expected_product[e]));
    INFO("product: max |y - y_ref| = " << difference << " of max |y_ref| = " << max_abs(expected_product));
    CHECK(difference <= 1e-13 * max_abs(expected_product));
    // The padding node past the end gets zeros added only.
    for (int k = 0; k < dim; ++k) CHECK(y[y.size() - dim + k] == 0.0);

    std::vector<double> L(particles * nL, 7.0);
    gather_tensor_gradients(c.stencils(), c.x.data(), L.data(), kernel);
    double worst = 0.0;
    for (std::size_t q = 0; q < particles; ++q) {
      if (c.base[q] < 0) {
        for (int k = 0; k < nL; ++k) CHECK(L[q * nL + k] == 7.0);  // not a tensor stencil: untouched
        continue;
      }
      const std::array<double, nL> expected = c.gradient_of(q);
      for (int k = 0; k < nL; ++k) worst = std::max(worst, std::abs(L[q * nL + k] - expected[k]));
    }
    INFO("gather: max |L - L_ref| = " << worst);
    CHECK(worst <= 1e-14 * 27);

    std::vector<double> scattered(c.x.size(), 0.0);
    scatter_tensor_stresses(c.stencils(), T.data(), scattered.data(), kernel);
    difference = 0.0;
    for (std::size_t e = 0; e < y.size(); ++e)
      difference = std::max(difference, std::abs(scattered[e] - expected_scatter[e]));
    INFO("scatter: max |y - y_ref| = " << difference << " of max |y_ref| = " << max_abs(expected_scatter));
    CHECK(difference <= 1e-13 * max_abs(expected_scatter));
  }
}

}  // namespace

TEST_CASE("tensor-product stencils: gather, scatter and the Jacobian's product equal the node-by-node sums", "[jacobian]") {
  check_kernels<3>();
}
