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
#include <cmath>
#include <cstdio>

#include "talus/simulation.hpp"
#include "test_support.hpp"

using namespace talus;

namespace {

constexpr double rho0 = 1000.0, g = 9.81, l0 = 1.0, E = 2e5;  // base strain rho0 g l0 / E = 4.9 %

// The largest |sigma_yy - exact| / (rho0 g l0) over the particles with
// 0.2 l0 < Y < 0.8 l0, after 10 quasi-static backward-Euler steps of 0.5 s.
double interior_error(double cell, const char* quadrature) {
  char yaml[1024];
  std::snprintf(yaml, sizeof yaml,
                "grid: {lower: [0, 0], upper: [%.17g, %.17g], cell_size: %.17g, quadrature: %s}\n"
                "time: {end: 5.0, step: 0.5, theta: 1.0}\n"
                "output: {enabled: false}\ngravity: [0, %g]\n"
                "materials: [{name: soil, model: linear_elastic, density: %g, youngs_modulus: %g, poisson_ratio: 0}]\n"
                "bodies: [{name: column, material: soil, box: {lower: [0, 0], upper: [%.17g, %.17g]}}]\n"
                "boundaries: {x_min: slip, x_max: slip, y_min: slip, y_max: slip}\n",
                4 * cell, 1.2 * l0, cell, quadrature, -g, rho0, E, 4 * cell, l0);
  CaseConfig config = testing::case_from_yaml(yaml);
  Simulation<2> sim(config, PETSC_COMM_SELF);
  for (int n = 0; n < 10; ++n) REQUIRE(sim.advance(0.5).converged);
  Particles<2>& particles = sim.particles();
  FieldView<PetscReal> x(particles.swarm(), field::position), u(particles.swarm(), field::displacement),
      tau(particles.swarm(), field::stress), F(particles.swarm(), field::deformation_gradient);
  double worst = 0.0;
  for (PetscInt p = 0; p < particles.local_count(); ++p) {
    const double Y = x[2 * p + 1] - u[2 * p + 1];
    if (Y < 0.2 * l0 || Y > 0.8 * l0) continue;
    const double J = F[4 * p] * F[4 * p + 3] - F[4 * p + 1] * F[4 * p + 2];
    const double sigma_yy = tau[6 * p + 1] / J;  // Kirchhoff to Cauchy
    worst = std::max(worst, std::abs(sigma_yy + rho0 * g * (l0 - Y)) / (rho0 * g * l0));
  }
  std::printf("settling column, %s quadrature, cell %g m: interior stress error %.3e of rho0 g l0\n", quadrature, cell,
              worst);
  return worst;
}

}  // namespace

TEST_CASE("finite-strain settling column: the interior stress converges with domain quadrature", "[verification]") {
  const double coarse = interior_error(0.05, "domain"), fine = interior_error(0.025, "domain"),
               finest = interior_error(0.0125, "domain");
  // Measured 2026-11-26: 9.02e-5, 8.98e-6, 4.32e-6 (order 3.3, then 1.1 as
  // it nears a floor of a few 1e-6 at this strain). Issue 13 asks order >= 1.5
  // (a factor 2^1.5 = 2.83 per halving) down to <= 1e-5 of rho0 g l0.
  CHECK(coarse / fine > std::pow(2.0, 1.5));
  CHECK(finest < 1e-5);
  // Point quadrature on the same grid: 6.70e-3, the knot-crossing error that
  // domain quadrature removes (more than a hundredfold smaller).
  const double point = interior_error(0.025, "point");
  CHECK(point > 100 * fine);
}
