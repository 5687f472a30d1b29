// Newton judged in physical units, failed linear solves, and a solver
// structure that is kept across steps (docs/solver.md#convergence,
// #failed-linear-solves, #reuse-across-steps).
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdio>

#include "talus/simulation.hpp"
#include "test_support.hpp"

using namespace talus;

namespace {

constexpr double rho = 2000.0, g = 9.81, E = 1e7, nu = 0.3;

// An elastic column of height H (m) on a fixed floor between slip walls;
// `solver` is appended to the case (a `solver:` section or nothing).
std::string column_case(double H, double dx, double step, const std::string& solver) {
  char yaml[1500];
  std::snprintf(yaml, sizeof yaml,
                "grid: {lower: [0, 0], upper: [%.17g, %.17g], cell_size: %.17g}\n"
                "time: {end: 100.0, step: %.17g}\noutput: {enabled: false}\ngravity: [0, %g]\n"
                "materials: [{name: soil, model: linear_elastic, density: %g, youngs_modulus: %g, poisson_ratio: %g}]\n"
                "bodies: [{name: column, material: soil, box: {lower: [0, 0], upper: [%.17g, %.17g]}}]\n"
                "boundaries: {x_min: slip, x_max: slip, y_min: fixed, y_max: free}\n%s",
                0.5 * H, 1.5 * H, dx, step, -g, rho, E, nu, 0.5 * H, H, solver.c_str());
  return yaml;
}

void clear(const char* name) { TALUS_PETSC(PetscOptionsClearValue(nullptr, name)); }

using testing::max_relative_difference;

}  // namespace

TEST_CASE("quasi-static steps with the Krylov default give the LU stresses", "[solver][convergence][mpi]") {
  // Steps of 10 s on a column whose period is ~0.03 s: backward Euler makes
  // each step a static solve, where the first residual (h^2 K (h g)) dwarfs
  // the weight. Only a test on the momentum balance itself stops Newton at
  // equilibrium; a test relative to the first residual stops it far away.
  // direct_solver_limit 0 puts the 2,000-unknown system on the Krylov default.
  const double H = 2.0, dx = 0.05, h = 10.0;
  const auto settle = [&](const std::string& solver) {
    Simulation<2> sim(testing::case_from_yaml(column_case(H, dx, h, solver)), PETSC_COMM_WORLD);
    StepReport r;
    for (int n = 0; n < 3; ++n) {
      r = sim.advance(h);
      REQUIRE(r.converged);
      CHECK(r.newton.unbalance <= 1e-8);  // the default balance_tolerance
    }
    return std::pair{testing::gather_by_id(sim.particles(), field::stress, 6), r};
  };
  const auto [lu, lu_report] = settle("solver: {direct_solver_limit: 1000000}\n");
  const auto [krylov, krylov_report] = settle("solver: {direct_solver_limit: 0}\n");
  REQUIRE(krylov_report.newton.linear_iterations > krylov_report.newton.iterations);  // it was Krylov
  const double difference = max_relative_difference(krylov, lu);
  std::printf("quasi-static column, %d unknowns: max |sigma_krylov - sigma_LU| / max |sigma_LU| = %.2e "
              "(Newton %d, KSP %d)\n",
              static_cast<int>(2 * (H / dx + 3) * (0.5 * H / dx + 3)), difference,
              static_cast<int>(krylov_report.newton.iterations),
              static_cast<int>(krylov_report.newton.linear_iterations));
  // U <= 1e-8 of the weight impulse bounds the nodal force error by 1e-8 W;
  // spread over the ~40-cell column that is ~1e-7 of the stress scale.
  CHECK(difference < 1e-6);
}

TEST_CASE("a Newton system the linear solver did not solve is never accepted", "[solver][convergence]") {
  // Unpreconditioned GMRES limited to 2 iterations cannot solve an elastic
  // step: the linear solve fails, and the step is solved again by Newton
  // with LU (never committed on the failed solve), giving the plain
  // Newton-LU answer. Checked for the default trust-region Newton and for
  // nonlinear GMRES, whose inner Newton step (prefix talus_npc_) fails.
  const std::string yaml = column_case(1.0, 0.1, 0.01, "");
  Simulation<2> reference(
      testing::case_from_yaml(column_case(1.0, 0.1, 0.01, "solver: {petsc_options: {snes_type: newtonls}}\n")),
      PETSC_COMM_SELF);
  const StepReport lu = reference.advance(0.01);
  clear("-talus_snes_type");  // the case file's option stays in the database
  REQUIRE(lu.converged);
  REQUIRE_FALSE(lu.newton.direct_fallback);

  const auto x_lu = testing::gather_by_id(reference.particles(), field::velocity, 2);
  for (const char* prefix : {"-talus_", "-talus_npc_"}) {
    const std::string p = prefix;
    if (p == "-talus_npc_") TALUS_PETSC(PetscOptionsSetValue(nullptr, "-talus_snes_type", "ngmres"));
    TALUS_PETSC(PetscOptionsSetValue(nullptr, (p + "ksp_type").c_str(), "gmres"));
    TALUS_PETSC(PetscOptionsSetValue(nullptr, (p + "pc_type").c_str(), "none"));
    TALUS_PETSC(PetscOptionsSetValue(nullptr, (p + "ksp_max_it").c_str(), "2"));
    Simulation<2> sim(testing::case_from_yaml(yaml), PETSC_COMM_SELF);
    const StepReport r = sim.advance(0.01);
    for (const char* o : {"ksp_type", "pc_type", "ksp_max_it"}) clear((p + o).c_str());
    clear("-talus_snes_type");
    INFO(prefix);
    REQUIRE(r.converged);
    CHECK(r.newton.direct_fallback);
    const auto x = testing::gather_by_id(sim.particles(), field::velocity, 2);
    // Both end on an LU Newton iteration from the same guess: equal to round-off.
    CHECK(max_relative_difference(x, x_lu) < 1e-10);
  }
}

TEST_CASE("the matrix and preconditioner are built once while the active set holds", "[solver][reuse][mpi]") {
  // A column resting on its floor: its particles move by micrometres, so the
  // active grid points never change. One build for 6 steps, and the same
  // answer as building everything at every step.
  const std::string yaml = column_case(1.0, 0.1, 0.005, "");
  const auto run = [&](bool reuse) {
    Simulation<2> sim(testing::case_from_yaml(yaml), PETSC_COMM_WORLD);
    sim.newton().set_structure_reuse(reuse);
    for (int n = 0; n < 6; ++n) REQUIRE(sim.advance(0.005).converged);
    return std::pair{testing::gather_by_id(sim.particles(), field::stress, 6), sim.newton().structure_builds()};
  };
  const auto [kept, kept_builds] = run(true);
  const auto [rebuilt, rebuilt_builds] = run(false);
  CHECK(kept_builds == 1);
  CHECK(rebuilt_builds == 6);
  // The same factorization of the same matrices: equal to round-off.
  CHECK(max_relative_difference(kept, rebuilt) < 1e-12);
}

TEST_CASE("the structure is rebuilt when the active set changes", "[solver][reuse]") {
  // A block in free fall through an empty box: its support moves to new grid
  // points, and each new active set gets a new matrix.
  const std::string yaml =
      "grid: {lower: [0, 0], upper: [1, 2], cell_size: 0.1}\n"
      "time: {end: 1.0, step: 0.05}\noutput: {enabled: false}\ngravity: [0, -9.81]\n"
      "materials: [{name: m, model: linear_elastic, density: 2000, youngs_modulus: 1.0e6, poisson_ratio: 0.3}]\n"
      "bodies: [{name: b, material: m, box: {lower: [0.3, 1.2], upper: [0.7, 1.6]}}]\n";
  Simulation<2> sim(testing::case_from_yaml(yaml), PETSC_COMM_SELF);
  int built = 0;
  for (int n = 0; n < 8; ++n) {
    const StepReport r = sim.advance(0.05);
    REQUIRE(r.converged);
    built += r.newton.structure_built;
  }
  CHECK(sim.newton().structure_builds() == built);
  CHECK(built > 1);  // the block falls ~0.8 m: its support moves over several cells
}
