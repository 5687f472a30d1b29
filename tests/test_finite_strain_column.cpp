// Issue 13, item 1 (docs/formulation.md#finite-strain-the-settling-column):
// an elastic column (nu = 0, slip walls and floor) settles under its own
// weight with a strain of 4.9 % at its base. Whatever the constitutive law,
// the exact Cauchy stress is sigma_yy(Y) = -rho0 g (l0 - Y) in terms of a
// particle's original height Y. With classic point quadrature the error
// does not fall under refinement (the particles cross knots as they
// settle); with domain quadrature (docs/grid.md#particle-quadrature) the
// interior error converges. The rows next to the floor and the free
// surface keep a boundary layer (documented), so the interior is measured.
#include <catch2/catch.hpp>
#include <string>
#include <cmath>
#include <cstdio>

#include "talus/simulation.hpp"
#include "test_support.hpp"

using namespace talus;

namespace {

constexpr double rho0 = 1000.0, g = 9.81, l0 = 1.0;

struct ColumnError {
  double interior;  // the largest |sigma_yy - exact| / (rho0 g l0) for 0.2 l0 < Y < 0.8 l0
  double l2;        // the root mean square of (sigma_yy - exact) / (rho0 g l0) over all particles
  double floor_row; // the mean of (sigma_yy - exact) / (rho0 g l0) over the row of particles at the floor
};

// The column after 10 quasi-static backward-Euler steps of 0.5 s; E = 2e5 Pa
// gives a base strain rho0 g l0 / E of 4.9 %.
// ghost_penalty < 0: the case file's default (solver.ghost_penalty 0.03).
ColumnError column_error(double cell, const char* quadrature, double E = 2e5, int particles_per_cell = 2,
                         double ghost_penalty = -1.0) {
  char yaml[1024];
  std::snprintf(yaml, sizeof yaml,
                "grid: {lower: [0, 0], upper: [%.17g, %.17g], cell_size: %.17g, quadrature: %s}\n"
                "time: {end: 5.0, step: 0.5, theta: 1.0}\n"
                "output: {enabled: false}\ngravity: [0, %g]\n"
                "materials: [{name: soil, model: linear_elastic, density: %g, youngs_modulus: %g, poisson_ratio: 0}]\n"
                "bodies: [{name: column, material: soil, box: {lower: [0, 0], upper: [%.17g, %.17g]}, "
                "particles_per_cell: %d}]\n"
                "boundaries: {x_min: slip, x_max: slip, y_min: slip, y_max: slip}\n",
                4 * cell, 1.2 * l0, cell, quadrature, -g, rho0, E, 4 * cell, l0, particles_per_cell);
  std::string text = yaml;
  if (ghost_penalty >= 0.0) text += "solver: {ghost_penalty: " + std::to_string(ghost_penalty) + "}\n";
  CaseConfig config = testing::case_from_yaml(text);
  Simulation<2> sim(config, PETSC_COMM_SELF);
  for (int n = 0; n < 10; ++n) REQUIRE(sim.advance(0.5).converged);
  Particles<2>& particles = sim.particles();
  FieldView<PetscReal> x(particles.swarm(), field::position), u(particles.swarm(), field::displacement),
      tau(particles.swarm(), field::stress), volume_ratio(particles.swarm(), field::volume_ratio);
  double worst = 0.0, squares = 0.0, floor_sum = 0.0;
  int floor_count = 0;
  const double spacing = cell / particles_per_cell;
  for (PetscInt p = 0; p < particles.local_count(); ++p) {
    const double Y = x[2 * p + 1] - u[2 * p + 1];
    const double J = volume_ratio[p];
    const double sigma_yy = tau[6 * p + 1] / J;  // Kirchhoff to Cauchy
    const double error = (sigma_yy + rho0 * g * (l0 - Y)) / (rho0 * g * l0);
    squares += error * error;
    if (Y > 0.2 * l0 && Y < 0.8 * l0) worst = std::max(worst, std::abs(error));
    if (Y < spacing) floor_sum += error, ++floor_count;  // seeded at spacing / 2
  }
  const ColumnError result{worst, std::sqrt(squares / static_cast<double>(particles.local_count())),
                           floor_sum / std::max(1, floor_count)};
  std::printf("settling column, %s quadrature, cell %g m, E %g Pa: interior stress error %.3e, L2 %.3e of rho0 g l0\n",
              quadrature, cell, E, result.interior, result.l2);
  return result;
}

}  // namespace

TEST_CASE("finite-strain settling column: the interior stress converges with domain quadrature", "[verification]") {
  const double coarse = column_error(0.05, "domain").interior, fine = column_error(0.025, "domain").interior,
               finest = column_error(0.0125, "domain").interior;
  // Measured 2026-11-26: 9.02e-5, 8.98e-6, 4.32e-6 (order 3.3, then 1.1 as
  // it nears a floor of a few 1e-6 at this strain). Issue 13 asks order >= 1.5
  // (a factor 2^1.5 = 2.83 per halving) down to <= 1e-5 of rho0 g l0.
  CHECK(coarse / fine > std::pow(2.0, 1.5));
  CHECK(finest < 1e-5);
  // Point quadrature on the same grid: 6.70e-3, the knot-crossing error that
  // domain quadrature removes (more than a hundredfold smaller).
  const double point = column_error(0.025, "point").interior;
  CHECK(point > 100 * fine);
}

TEST_CASE("finite-strain settling column: the whole column's L2 reaches 1e-5 on a fine grid", "[verification]") {
  // 3.3 % strain (E = 294,300 Pa); cell 0.0015625 m, 10,240 particles. The
  // boundary rows set the L2 (docs/formulation.md#finite-strain-the-settling-column):
  // measured 2026-11-26 4.64e-6, with the settled top 0.56 of a cell past a
  // grid line (7.7e-6 at half the cell, where it is 0.12 past one). Issue 13
  // asks <= 1e-5 of rho0 g l0 at fine grids.
  const ColumnError fine = column_error(0.0015625, "domain", 294300.0);
  CHECK(fine.l2 < 1e-5);
  // Point quadrature on the same grid does not converge: about 1e-3.
  CHECK(column_error(0.0015625, "point", 294300.0).l2 > 20 * fine.l2);
}

TEST_CASE("finite-strain settling column: the ghost penalty trades the sliver's error for its own",
          "[verification]") {
  // Cell 0.0125 m (1,280 particles), domain quadrature. At E = 2e5 Pa the
  // settled top lies 0.10 of a cell past a grid line: a function that only a
  // sliver of material enters (docs/formulation.md, the sliver). At
  // E = 294,300 Pa it lies 0.70 past one: no sliver. Measured 2026-11-27:
  // sliver 5.36e-4 at the default gamma = 0.03, 2.99e-4 at gamma = 3 (0.56
  // of it); no sliver 9.03e-5 and 3.79e-4 (4.2 times). The bounds say what
  // docs/formulation.md says: the penalty roughly halves the sliver's error
  // and costs several times the error where there is none.
  const double sliver = column_error(0.0125, "domain", 2e5, 2, 0.03).l2;
  const double sliver_penalized = column_error(0.0125, "domain", 2e5, 2, 3.0).l2;
  const double clean = column_error(0.0125, "domain", 294300.0, 2, 0.03).l2;
  const double clean_penalized = column_error(0.0125, "domain", 294300.0, 2, 3.0).l2;
  CHECK(sliver_penalized < 0.7 * sliver);
  CHECK(clean_penalized > 2.0 * clean);
  // The sliver's error is the larger one by far at the default (5.9 times).
  CHECK(sliver > 3.0 * clean);
}

// Why both ends keep a first-order row with domain quadrature
// (docs/formulation.md#finite-strain-the-settling-column): the
// domain-constant stresses integrate the internal force exactly up to the
// trapezoidal rule's end terms (rho0 g d^2 / 12) [N_i'], d = cell / ppc, so
// the row at the floor carries an error of about rho0 g d^2 / h: first order
// in the cell at a fixed ppc, and a quarter of it with twice the particles
// per cell. Measured at 3.3 % strain: -2.59e-3, -1.30e-3 (ppc 2), -7.39e-4,
// -3.68e-4 (ppc 4) at cells 0.05 and 0.025 m.
TEST_CASE("finite-strain settling column: the floor row's error is first order in the cell and falls as 1/ppc^2",
          "[verification]") {
  const double E = 294300.0;  // 3.3 % strain at the base
  const double coarse2 = column_error(0.05, "domain", E, 2).floor_row, fine2 = column_error(0.025, "domain", E, 2).floor_row;
  const double coarse4 = column_error(0.05, "domain", E, 4).floor_row, fine4 = column_error(0.025, "domain", E, 4).floor_row;
  INFO("floor row: ppc 2 " << coarse2 << ", " << fine2 << "; ppc 4 " << coarse4 << ", " << fine4);
  // The sign: the floor row is too compressive (the end term pulls it down).
  CHECK(coarse2 < 0.0);
  // First order: halving the cell halves it, up to the next-order terms of
  // the decaying layer (measured 0.502).
  CHECK(fine2 / coarse2 == Approx(0.5).margin(0.05));
  // d^2: twice the particles per cell, a quarter (measured 0.285 and 0.283,
  // the layer's next rows adding O(d / h) to the 1/4 of the end term alone).
  CHECK(coarse4 / coarse2 == Approx(0.25).margin(0.06));
  CHECK(fine4 / fine2 == Approx(0.25).margin(0.06));
}
