// Shape functions: partition of unity, zero gradient sum and exact
// reproduction of linear fields at random points (boundary cells included),
// 2D and 3D, linear hats and clamped quadratic B-splines.
#include <catch2/catch.hpp>
#include <random>

#include "talus/shape/shape_functions.hpp"

using namespace talus;

namespace {

// With `domain`, the averages over boxes of random half-widths up to the cap
// h/2 (docs/grid.md#particle-quadrature), clipped at the faces: their first
// moment is the centre of the (clipped) box.
template <int dim>
void check_random_points(ShapeKind kind, bool domain = false) {
  std::mt19937 rng(domain ? 13 : 7);
  const double h = 0.37;
  std::array<int, dim> cells;
  for (int a = 0; a < dim; ++a) cells[a] = 5 + a;  // small grids: most points sit in boundary spans
  Stencil<dim> st;
  for (int trial = 0; trial < 2000; ++trial) {
    Vector<dim> x, r, centre;
    for (int a = 0; a < dim; ++a) {
      x[a] = std::uniform_real_distribution<double>(0.0, cells[a] * h)(rng);
      if (!domain) continue;
      r[a] = std::uniform_real_distribution<double>(0.01 * h, 0.5 * h)(rng);
      centre[a] = 0.5 * (std::max(x[a] - r[a], 0.0) + std::min(x[a] + r[a], cells[a] * h));
    }
    if (!domain) centre = x;
    evaluate_stencil<dim>(kind, x, cells, h, st, domain ? &r : nullptr);
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
    CHECK((x_rep - centre).norm() / h == Approx(0.0).margin(1e-12));  // sum N_i x_i = x
    CHECK((grad_rep - Matrix<dim>::Identity()).norm() == Approx(0.0).margin(1e-12));  // sum x_i grad N_i = I
  }
}

// Gradient against a central difference of the values (catches a wrong slope
// formula that would still sum to zero). With `domain`, grad S_i is the
// derivative of S_i with respect to the particle's position (d/dx of the
// average over [x - r, x + r] is the end-point difference over 2r), away
// from the faces.
template <int dim>
void check_gradient_by_differences(ShapeKind kind, bool domain = false) {
  std::mt19937 rng(domain ? 17 : 11);
  const double h = 0.5, d = 1e-6;
  std::array<int, dim> cells;
  for (int a = 0; a < dim; ++a) cells[a] = 6;
  Stencil<dim> st, sp, sm;
  int compared = 0;
  for (int trial = 0; trial < 500; ++trial) {
    Vector<dim> x, r = Vector<dim>::Zero();
    for (int a = 0; a < dim; ++a) {
      if (domain) r[a] = std::uniform_real_distribution<double>(0.05 * h, 0.5 * h)(rng);
      x[a] = std::uniform_real_distribution<double>(r[a] + 0.01, cells[a] * h - r[a] - 0.01)(rng);
    }
    const Vector<dim>* half_width = domain ? &r : nullptr;
    evaluate_stencil<dim>(kind, x, cells, h, st, half_width);
    for (int a = 0; a < dim; ++a) {
      Vector<dim> xp = x, xm = x;
      xp[a] += d;
      xm[a] -= d;
      evaluate_stencil<dim>(kind, xp, cells, h, sp, half_width);
      evaluate_stencil<dim>(kind, xm, cells, h, sm, half_width);
      if (sp.node[0] != st.node[0] || sm.node[0] != st.node[0] || sp.count != st.count || sm.count != st.count)
        continue;  // crossed a knot: skip
      for (int k = 0; k < st.count; ++k, ++compared) {
        const double fd = (sp.weight[k] - sm.weight[k]) / (2 * d);
        CHECK(st.gradient[k][a] == Approx(fd).margin(1e-7));  // O(d^2) truncation + 1e-16/d round-off
      }
    }
  }
  CHECK(compared > 1000);
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

// Domain quadrature (docs/grid.md#particle-quadrature): weights and
// gradients averaged over a particle's box.
namespace {

// Uniform cubic B-spline (support [-2, 2]) and uniform quadratic B-spline
// (support [-3/2, 3/2]), in cell units.
double cubic_bspline(double t) {
  t = std::abs(t);
  return t <= 1 ? 2.0 / 3.0 - t * t + 0.5 * t * t * t : (t <= 2 ? (2 - t) * (2 - t) * (2 - t) / 6.0 : 0.0);
}
double quadratic_bspline(double t) {
  t = std::abs(t);
  return t <= 0.5 ? 0.75 - t * t : (t <= 1.5 ? 0.5 * (1.5 - t) * (1.5 - t) : 0.0);
}

}  // namespace

TEST_CASE("domain quadrature: partition of unity and linear reproduction", "[shape]") {
  check_random_points<2>(ShapeKind::quadratic_bspline, true);
  check_random_points<3>(ShapeKind::quadratic_bspline, true);
  check_random_points<2>(ShapeKind::linear, true);
  check_random_points<3>(ShapeKind::linear, true);
}

TEST_CASE("domain quadrature: gradients are derivatives of the averaged weights", "[shape]") {
  check_gradient_by_differences<2>(ShapeKind::quadratic_bspline, true);
  check_gradient_by_differences<3>(ShapeKind::quadratic_bspline, true);
  check_gradient_by_differences<2>(ShapeKind::linear, true);
}

TEST_CASE("domain quadrature over a whole cell: the next B-spline degree", "[shape]") {
  // A box one cell long (r = 1/2) convolves the basis with the unit box: the
  // averaged quadratic B-spline is the cubic B-spline, the averaged hat the
  // quadratic B-spline (cpGIMP's known closed form), both centred on the
  // function's point. Interior functions of a 12-cell axis.
  const int n = 12;
  double worst = 0.0;
  for (double u = 3.0; u <= 9.0; u += 0.0137) {
    const Basis1D q = evaluate_domain_basis_1d(ShapeKind::quadratic_bspline, u, 0.5, n, 1.0);
    REQUIRE(q.count <= 4);
    for (int k = 0; k < q.count; ++k) {
      const double t = u - basis_position(ShapeKind::quadratic_bspline, q.first + k, n);
      worst = std::max(worst, std::abs(q.value[k] - cubic_bspline(t)));
      // The derivative of the cubic: central difference of the closed form.
      const double slope = (cubic_bspline(t + 1e-6) - cubic_bspline(t - 1e-6)) / 2e-6;
      CHECK(q.slope[k] == Approx(slope).margin(1e-8));
    }
    const Basis1D l = evaluate_domain_basis_1d(ShapeKind::linear, u, 0.5, n, 1.0);
    REQUIRE(l.count <= 3);
    for (int k = 0; k < l.count; ++k)
      worst = std::max(worst, std::abs(l.value[k] - quadratic_bspline(u - (l.first + k))));
  }
  CHECK(worst < 1e-14);
  // A vanishing box is the point evaluation (to O(r^2) = 1e-14; away from
  // the faces, where the box is clipped to one side).
  for (const ShapeKind kind : {ShapeKind::quadratic_bspline, ShapeKind::linear})
    for (double u = 0.173; u < n; u += 0.173) {
      const Basis1D p = evaluate_basis_1d(kind, u, n, 1.0), d = evaluate_domain_basis_1d(kind, u, 1e-7, n, 1.0);
      for (int k = 0; k < d.count; ++k) {
        const int i = d.first + k - p.first;
        const double point = i >= 0 && i < p.count ? p.value[i] : 0.0;
        CHECK(d.value[k] == Approx(point).margin(1e-12));
      }
    }
}
