// An elastic column between frictionless walls on a fixed floor settles under
// gravity to the lithostatic stress sigma_yy = -rho g (H - y), whatever nu
// (equilibrium alone fixes it in this uniaxial-strain column), and
// sigma_xx = nu / (1 - nu) sigma_yy (K0 condition of plane strain).
// Backward Euler (theta = 1) with steps far beyond the column's period damps
// the dynamics by 1 / (1 + (omega h)^2) per step: a quasi-static solve.
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdio>

#include "talus/simulation.hpp"
#include "test_support.hpp"

using namespace talus;

namespace {

constexpr double H = 1.0, rho = 2000.0, g = 9.81, E = 1e7, nu = 0.3;

struct ColumnError {
  double vertical, horizontal;  // RMS over particles, relative to rho g H
};

template <int dim>
ColumnError settle_column(int cells_over_height, const std::string& shape) {
  const double dx = H / cells_over_height;
  const double w = 4 * dx;  // width (and depth in 3D): the column is 1D anyway
  char yaml[1024];
  if constexpr (dim == 2)
    std::snprintf(yaml, sizeof yaml,
                  "grid: {lower: [0, 0], upper: [%.17g, %.17g], cell_size: %.17g, shape_function: %s}\n"
                  "time: {end: 2.0, step: 0.5}\noutput: {enabled: false}\ngravity: [0, %g]\n"
                  "materials: [{name: soil, model: linear_elastic, density: %g, youngs_modulus: %g, poisson_ratio: %g}]\n"
                  "bodies: [{name: column, material: soil, box: {lower: [0, 0], upper: [%.17g, %.17g]}}]\n"
                  "boundaries: {x_min: slip, x_max: slip, y_min: fixed, y_max: free}\n",
                  w, 1.5 * H, dx, shape.c_str(), -g, rho, E, nu, w, H);
  else
    std::snprintf(yaml, sizeof yaml,
                  "grid: {lower: [0, 0, 0], upper: [%.17g, %.17g, %.17g], cell_size: %.17g, shape_function: %s}\n"
                  "time: {end: 2.0, step: 0.5}\noutput: {enabled: false}\ngravity: [0, 0, %g]\n"
                  "materials: [{name: soil, model: linear_elastic, density: %g, youngs_modulus: %g, poisson_ratio: %g}]\n"
                  "bodies: [{name: column, material: soil, box: {lower: [0, 0, 0], upper: [%.17g, %.17g, %.17g]}}]\n"
                  "boundaries: {x_min: slip, x_max: slip, y_min: slip, y_max: slip, z_min: fixed, z_max: free}\n",
                  w, w, 1.5 * H, dx, shape.c_str(), -g, rho, E, nu, w, w, H);
  CaseConfig config = testing::case_from_yaml(yaml);
  Simulation<dim> sim(config, PETSC_COMM_WORLD);
  for (int n = 0; n < 4; ++n) REQUIRE(sim.advance(0.5).converged);
  const auto x = testing::gather_by_id(sim.particles(), field::position, dim);
  const auto u = testing::gather_by_id(sim.particles(), field::displacement, dim);
  const auto tau = testing::gather_by_id(sim.particles(), field::stress, 6);
  const auto F = testing::gather_by_id(sim.particles(), field::deformation_gradient, dim * dim);
  const std::size_t n = tau.size() / 6;
  const int vertical = dim - 1;  // Voigt index of sigma_yy (2D) or sigma_zz (3D)
  double ev = 0, eh = 0;
  for (std::size_t p = 0; p < n; ++p) {
    const double y0 = x[dim * p + vertical] - u[dim * p + vertical];  // initial height of the particle
    const double exact = -rho * g * (H - y0);
    // The stored stress is Kirchhoff's; the lithostatic solution is Cauchy's.
    const Eigen::Map<const Eigen::Matrix<double, dim, dim, Eigen::RowMajor>> Fp(F.data() + dim * dim * p);
    const double J = Fp.determinant();
    ev += std::pow(tau[6 * p + vertical] / J - exact, 2);
    eh += std::pow(tau[6 * p + 0] / J - nu / (1 - nu) * exact, 2);
  }
  const double scale = rho * g * H;
  return {std::sqrt(ev / n) / scale, std::sqrt(eh / n) / scale};
}

}  // namespace

TEST_CASE("elastic column settles to the lithostatic stress", "[column][mpi]") {
  const ColumnError coarse = settle_column<2>(10, "quadratic_bspline");
  const ColumnError fine = settle_column<2>(20, "quadratic_bspline");
  const ColumnError coarse3 = settle_column<3>(10, "quadratic_bspline");
  std::printf("elastic column: RMS error of sigma_v / (rho g H): 2D %.3e (10 cells), %.3e (20 cells), 3D %.3e "
              "(10 cells); sigma_h: %.3e, %.3e, %.3e\n",
              coarse.vertical, fine.vertical, coarse3.vertical, coarse.horizontal, fine.horizontal, coarse3.horizontal);
  // Measured 1.0e-3 and 4.3e-4 at 20 cells: the stated bound is 0.15 % of rho g H.
  CHECK(fine.vertical < 1.5e-3);
  CHECK(fine.horizontal < 1.5e-3);
  // Refinement reduces the error (measured ratio 2.8).
  CHECK(coarse.vertical / fine.vertical > 2.0);
  // The 3D column between slip walls is the same 1D problem: same error to round-off.
  CHECK(coarse3.vertical == Approx(coarse.vertical).epsilon(1e-6));
  CHECK(coarse3.horizontal == Approx(coarse.horizontal).epsilon(1e-6));
}
