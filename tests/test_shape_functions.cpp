// Shape functions: partition of unity, zero gradient sum and exact
// reproduction of linear fields at random points (boundary cells included),
// 2D and 3D, linear hats and clamped quadratic B-splines.
#include <catch2/catch.hpp>
#include <random>

#include "talus/shape/shape_functions.hpp"

using namespace talus;

namespace {

template <int dim>
void check_random_points(ShapeKind kind) {
  std::mt19937 rng(7);
  const double h = 0.37;
  std::array<int, dim> cells;
  for (int a = 0; a < dim; ++a) cells[a] = 5 + a;  // small grids: most points sit in boundary spans
  Stencil<dim> st;
  for (int trial = 0; trial < 2000; ++trial) {
    Vector<dim> x;
    for (int a = 0; a < dim; ++a) x[a] = std::uniform_real_distribution<double>(0.0, cells[a] * h)(rng);
    evaluate_stencil<dim>(kind, x, cells, h, st);
    double sum = 0.0;
    Vector<dim> grad_sum = Vector<dim>::Zero(), x_rep = Vector<dim>::Zero();
    Matrix<dim> grad_rep = Matrix<dim>::Zero();
    for (int k = 0; k < st.count; ++k) {
      REQUIRE(st.weight[k] >= -1e-15);
      Vector<dim> xi;
      for (int a = 0; a < dim; ++a) xi[a] = h * basis_position(kind, st.node[k][a], cells[a]);
      sum += st.weight[k];
      grad_sum += st.gradient[k];
      x_rep += st.weight[k] * xi;
      grad_rep += xi * st.gradient[k].transpose();
    }
    // Round-off of a few dozen products of O(1) numbers: 1e-13 is ~500 ulp.
    CHECK(sum == Approx(1.0).margin(1e-13));
    CHECK(grad_sum.norm() * h == Approx(0.0).margin(1e-12));
    CHECK((x_rep - x).norm() / h == Approx(0.0).margin(1e-12));  // sum N_i x_i = x
    CHECK((grad_rep - Matrix<dim>::Identity()).norm() == Approx(0.0).margin(1e-12));  // sum x_i grad N_i = I
  }
}

// Gradient against a central difference of the values (catches a wrong slope
// formula that would still sum to zero).
template <int dim>
void check_gradient_by_differences(ShapeKind kind) {
  std::mt19937 rng(11);
  const double h = 0.5, d = 1e-6;
  std::array<int, dim> cells;
  for (int a = 0; a < dim; ++a) cells[a] = 6;
  Stencil<dim> st, sp, sm;
  for (int trial = 0; trial < 500; ++trial) {
    Vector<dim> x;
    for (int a = 0; a < dim; ++a) x[a] = std::uniform_real_distribution<double>(0.01, cells[a] * h - 0.01)(rng);
    evaluate_stencil<dim>(kind, x, cells, h, st);
    for (int a = 0; a < dim; ++a) {
      Vector<dim> xp = x, xm = x;
      xp[a] += d;
      xm[a] -= d;
      evaluate_stencil<dim>(kind, xp, cells, h, sp);
      evaluate_stencil<dim>(kind, xm, cells, h, sm);
      if (sp.node[0] != st.node[0] || sm.node[0] != st.node[0]) continue;  // crossed a knot: skip
      for (int k = 0; k < st.count; ++k) {
        const double fd = (sp.weight[k] - sm.weight[k]) / (2 * d);
        CHECK(st.gradient[k][a] == Approx(fd).margin(1e-7));  // O(d^2) truncation + 1e-16/d round-off
      }
    }
  }
}

}  // namespace

TEST_CASE("quadratic B-splines: partition of unity and linear reproduction", "[shape]") {
  check_random_points<2>(ShapeKind::quadratic_bspline);
  check_random_points<3>(ShapeKind::quadratic_bspline);
}

TEST_CASE("linear hats: partition of unity and linear reproduction", "[shape]") {
  check_random_points<2>(ShapeKind::linear);
  check_random_points<3>(ShapeKind::linear);
}

TEST_CASE("shape-function gradients match finite differences", "[shape]") {
  check_gradient_by_differences<2>(ShapeKind::quadratic_bspline);
  check_gradient_by_differences<3>(ShapeKind::quadratic_bspline);
  check_gradient_by_differences<2>(ShapeKind::linear);
}

TEST_CASE("clamped quadratic B-spline is interpolatory on the faces", "[shape]") {
  // Only the outermost basis is non-zero on a face, where it equals one: this
  // is what makes fixing one coefficient an exact Dirichlet condition.
  const int n = 6;
  for (double u : {0.0, double(n)}) {
    const Basis1D b = evaluate_basis_1d(ShapeKind::quadratic_bspline, u, n, 1.0);
    const int face = u == 0.0 ? 0 : n + 1;
    for (int k = 0; k < b.count; ++k) CHECK(b.value[k] == Approx(b.first + k == face ? 1.0 : 0.0).margin(1e-15));
  }
  // Interior spans are the uniform quadratic B-spline: values 1/8, 3/4, 1/8 at a cell centre.
  const Basis1D mid = evaluate_basis_1d(ShapeKind::quadratic_bspline, 3.5, n, 1.0);
  CHECK(mid.value[0] == Approx(0.125));
  CHECK(mid.value[1] == Approx(0.75));
  CHECK(mid.value[2] == Approx(0.125));
}
