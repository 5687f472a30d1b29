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
                  "time: {end: 2.0, step: 0.5}\noutput: {enabled: false}\nsolver: {ghost_penalty: 0}\ngravity: [0, %g]\n"
                  "materials: [{name: soil, model: linear_elastic, density: %g, youngs_modulus: %g, poisson_ratio: %g}]\n"
                  "bodies: [{name: column, material: soil, box: {lower: [0, 0], upper: [%.17g, %.17g]}}]\n"
                  "boundaries: {x_min: slip, x_max: slip, y_min: fixed, y_max: free}\n",
                  w, 1.5 * H, dx, shape.c_str(), -g, rho, E, nu, w, H);
  else
    std::snprintf(yaml, sizeof yaml,
                  "grid: {lower: [0, 0, 0], upper: [%.17g, %.17g, %.17g], cell_size: %.17g, shape_function: %s}\n"
                  "time: {end: 2.0, step: 0.5}\noutput: {enabled: false}\nsolver: {ghost_penalty: 0}\ngravity: [0, 0, %g]\n"
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
  // (These columns run without the ghost penalty: its cell integrals are exact where
  // the particles' quadrature is not, at the functions next to the walls, so
  // with it the 3D column differs from the 2D one by 2e-5 of rho g H.)
  CHECK(coarse3.vertical == Approx(coarse.vertical).epsilon(1e-6));
  CHECK(coarse3.horizontal == Approx(coarse.horizontal).epsilon(1e-6));
}

TEST_CASE("a geostatic initial stress starts the column in equilibrium", "[column][mpi]") {
  // The column of the test above, once with initial_stress: geostatic and
  // once without. Without, the first step of h = 0.01 s lets the column fall
  // freely (v ~ g h ~ 0.1 m/s); with it, only the discretisation error of the
  // equilibrium moves it. The seeded stress must be the lithostatic one.
  const auto first_step = [](bool geostatic) {
    char yaml[1200];
    std::snprintf(yaml, sizeof yaml,
                  "grid: {lower: [0, 0], upper: [0.4, 1.5], cell_size: 0.1}\n"
                  "time: {end: 1.0, step: 0.01}\noutput: {enabled: false}\ngravity: [0, %g]\n"
                  "materials: [{name: soil, model: linear_elastic, density: %g, youngs_modulus: %g, poisson_ratio: %g}]\n"
                  "bodies: [{name: column, material: soil, box: {lower: [0, 0], upper: [0.4, %g]}%s}]\n"
                  "boundaries: {x_min: slip, x_max: slip, y_min: fixed, y_max: free}\n",
                  -g, rho, E, nu, H, geostatic ? ", initial_stress: geostatic" : "");
    Simulation<2> sim(testing::case_from_yaml(yaml), PETSC_COMM_WORLD);
    const auto x = testing::gather_by_id(sim.particles(), field::position, 2);
    const auto s = testing::gather_by_id(sim.particles(), field::stress, 6);
    double seeded_error = 0;
    for (std::size_t p = 0; p < s.size() / 6; ++p) {
      const double exact = -rho * g * (H - x[2 * p + 1]);
      if (geostatic) {
        seeded_error = std::max(seeded_error, std::abs(s[6 * p + 1] - exact));
        seeded_error = std::max(seeded_error, std::abs(s[6 * p + 0] - nu / (1 - nu) * exact));
        seeded_error = std::max(seeded_error, std::abs(s[6 * p + 2] - nu / (1 - nu) * exact));
      }
    }
    REQUIRE(sim.advance(0.01).converged);
    const auto v = testing::gather_by_id(sim.particles(), field::velocity, 2);
    double vmax = 0;
    for (double vi : v) vmax = std::max(vmax, std::abs(vi));
    return std::pair{vmax, seeded_error};
  };
  const auto [v_free, e_free] = first_step(false);
  const auto [v_geo, e_geo] = first_step(true);
  std::printf("first step: max |v| without initial stress %.3e m/s, geostatic %.3e m/s; seeded stress error %.1e Pa\n",
              v_free, v_geo, e_geo);
  CHECK(e_geo <= 1e-9 * rho * g * H);          // the closed form, to round-off
  CHECK(v_free > 0.25 * g * 0.01);            // falls: of order g h (measured 0.46 g h)
  CHECK(v_geo < 0.01 * v_free);               // at rest to the discretisation error (measured 1.4e-3)
}
