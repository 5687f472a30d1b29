// Newton judged in physical units, failed linear solves, and a solver
// structure that is kept across steps (docs/solver.md#convergence,
// #failed-linear-solves, #reuse-across-steps).
#include <catch2/catch.hpp>
#include <array>
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

TEST_CASE("quasi-static steps with the Krylov defaults give the LU stresses", "[solver][convergence][mpi]") {
  // Steps of 10 s on a column whose period is ~0.03 s: backward Euler makes
  // each step a static solve, where the first residual (h^2 K (h g)) dwarfs
  // the weight. Only a test on the momentum balance itself stops Newton at
  // equilibrium; a test relative to the first residual stops it far away.
  // direct_solver_limit 0 puts the 2,000-unknown system on GMRES + GAMG (the
  // default above the limit); the 2D default limit keeps it on GMRES with
  // kept factors (incomplete LU on one rank).
  // Two solvers compared: each held to the balance tolerance itself, not to
  // the time-error bound that loosens it (docs/solver.md#the-tolerance-follows-the-time-error).
  const testing::ScopedOption exact_balance("-talus_balance_time_fraction", "0");
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
  const auto lu = [&] {
    const testing::ScopedOption preonly("-talus_ksp_type", "preonly");
    const auto on_lu = testing::lu_on_every_rank();
    return settle("").first;
  }();
  const auto [factors, factors_report] = settle("");
  REQUIRE(factors_report.newton.linear_iterations > factors_report.newton.iterations);  // it was Krylov
  CHECK(max_relative_difference(factors, lu) < 1e-6);  // the same bound as below
  const auto [krylov, krylov_report] = settle("solver: {direct_solver_limit: 0}\n");
  REQUIRE(krylov_report.newton.linear_iterations > krylov_report.newton.iterations);  // it was Krylov
  REQUIRE(krylov_report.newton.factorizations == 0);  // and not on factors
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
      testing::case_from_yaml(column_case(1.0, 0.1, 0.01, "solver: {petsc_options: {snes_type: newtonls, pc_type: lu}}\n")),
      PETSC_COMM_SELF);
  const StepReport lu = reference.advance(0.01);
  clear("-talus_snes_type");  // the case file's options stay in the database
  clear("-talus_pc_type");
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
  SECTION("above -talus_direct_fallback_limit the step is cut back instead") {
    // The same failing solves with the fallback limited to 10 unknowns (the
    // column has ~200): the step is rejected, not re-solved by LU, and the
    // particles are left as they were.
    const testing::ScopedOption limit("-talus_direct_fallback_limit", "10");
    const testing::ScopedOption no_multigrid("-talus_multigrid_fallback", "no");
    const testing::ScopedOption ksp("-talus_ksp_type", "gmres");
    const testing::ScopedOption pc("-talus_pc_type", "none");
    const testing::ScopedOption max_it("-talus_ksp_max_it", "2");
    Simulation<2> sim(testing::case_from_yaml(yaml), PETSC_COMM_SELF);
    const auto before = testing::gather_by_id(sim.particles(), field::position, 2);
    const StepReport r = sim.advance(0.01);
    CHECK_FALSE(r.converged);
    CHECK_FALSE(r.newton.direct_fallback);
    CHECK(r.newton.linear_failures > 0);
    CHECK(testing::gather_by_id(sim.particles(), field::position, 2) == before);
  }
}

TEST_CASE("geometric multigrid: quasi-static steps give the LU stresses, in as many Krylov iterations on a finer grid",
          "[solver][multigrid][mpi]") {
  // Steps of 10 s on the elastic column (docs/solver.md#geometric-multigrid):
  // static elasticity, whose smooth modes incomplete factors do not reach
  // (on the finer grid here kept ILU fails every solve) and the coarse
  // levels do.
  const double H = 2.0, h = 10.0;
  std::array<double, 2> per_newton{};
  for (int k = 0; k < 2; ++k) {
    const double dx = k == 0 ? 0.025 : 0.0125;
    const auto settle = [&](const char* pc) {
      const testing::ScopedOption option("-talus_pc_type", pc);
      const testing::ScopedOption preonly("-talus_ksp_type", std::string(pc) == "lu" ? "preonly" : "gmres");
      Simulation<2> sim(testing::case_from_yaml(column_case(H, dx, h, "")), PETSC_COMM_WORLD);
      StepReport r;
      double iterations = 0.0, linear = 0.0;
      for (int n = 0; n < 3; ++n) {
        r = sim.advance(h);
        REQUIRE(r.converged);
        iterations += r.newton.iterations;
        linear += r.newton.linear_iterations;
      }
      return std::pair{testing::gather_by_id(sim.particles(), field::stress, 6), linear / iterations};
    };
    const auto lu = settle("lu").first;
    const auto [stress, krylov_per_newton] = settle("mg");
    per_newton[k] = krylov_per_newton;
    std::printf("multigrid, cell %g: %.1f Krylov iterations per Newton iteration, max |sigma - sigma_LU| / max "
                "|sigma_LU| = %.2e\n",
                dx, krylov_per_newton, max_relative_difference(stress, lu));
    CHECK(max_relative_difference(stress, lu) < 1e-6);  // the bound of the Krylov defaults' test above
  }
  // Measured 3.8 and 3.8: a V-cycle's contraction does not depend on the
  // cell; ILU(0) needs 17 and then fails (docs/solver.md#geometric-multigrid).
  CHECK(per_newton[1] <= 1.25 * per_newton[0]);
  CHECK(per_newton[1] < 8.0);
}

TEST_CASE("quasi-static steps above the LU fallback's limit start on the multigrid", "[solver][multigrid]") {
  // The column at cell 0.0125 m (26,568 unknowns, above the 20,000 of the
  // LU fallback in 2D), steps of 10 s: a P-wave crosses 16,000 cells. The
  // default starts on the multigrid and solves the step in a few Krylov
  // iterations per Newton iteration; the incomplete factors alone
  // (-talus_multigrid_fallback no) fail it.
  const std::string yaml = column_case(2.0, 0.0125, 10.0, "");
  {
    Simulation<2> sim(testing::case_from_yaml(yaml), PETSC_COMM_SELF);
    const StepReport r = sim.advance(10.0);
    REQUIRE(r.converged);
    CHECK_FALSE(r.newton.multigrid_fallback);
    CHECK_FALSE(r.newton.direct_fallback);
    // Measured 11 Krylov iterations over 4 Newton iterations.
    CHECK(r.newton.linear_iterations < 8 * r.newton.iterations);
  }
  const testing::ScopedOption off("-talus_multigrid_fallback", "no");
  Simulation<2> sim(testing::case_from_yaml(yaml), PETSC_COMM_SELF);
  const StepReport r = sim.advance(10.0);
  CHECK_FALSE(r.converged);
  CHECK(r.newton.linear_failures > 0);
}

TEST_CASE("above the LU fallback's limit a failed linear solve is solved again on multigrid", "[solver][multigrid]") {
  // Unpreconditioned GMRES limited to 2 iterations fails the quasi-static
  // column's solves; with the LU fallback limited to 10 unknowns the step is
  // solved again on the geometric multigrid (not read from the options), to
  // the LU answer within the balance tolerance, instead of being cut back.
  const std::string yaml = column_case(2.0, 0.05, 10.0, "");
  const auto lu = [&] {
    const testing::ScopedOption preonly("-talus_ksp_type", "preonly");
    const testing::ScopedOption pc("-talus_pc_type", "lu");
    Simulation<2> sim(testing::case_from_yaml(yaml), PETSC_COMM_SELF);
    REQUIRE(sim.advance(10.0).converged);
    return testing::gather_by_id(sim.particles(), field::stress, 6);
  }();
  const testing::ScopedOption limit("-talus_direct_fallback_limit", "10");
  const testing::ScopedOption ksp("-talus_ksp_type", "gmres");
  const testing::ScopedOption pc("-talus_pc_type", "none");
  const testing::ScopedOption max_it("-talus_ksp_max_it", "2");
  Simulation<2> sim(testing::case_from_yaml(yaml), PETSC_COMM_SELF);
  const StepReport r = sim.advance(10.0);
  REQUIRE(r.converged);
  CHECK(r.newton.multigrid_fallback);
  CHECK_FALSE(r.newton.direct_fallback);
  CHECK(r.newton.linear_failures == 0);  // the retry's own solves all converged
  CHECK(max_relative_difference(testing::gather_by_id(sim.particles(), field::stress, 6), lu) < 1e-6);
  // A dynamic step (1 ms: a P-wave, 82 m/s, crosses 1.6 cells of 0.05 m,
  // below NewtonSolver::quasi_static_wave_cells) is cut back instead: there
  // the failures are not the static modes the multigrid reaches.
  Simulation<2> dynamic(testing::case_from_yaml(column_case(2.0, 0.05, 1e-3, "")), PETSC_COMM_SELF);
  const StepReport d = dynamic.advance(1e-3);
  CHECK_FALSE(d.converged);
  CHECK_FALSE(d.newton.multigrid_fallback);
  CHECK(d.newton.linear_failures > 0);
}

TEST_CASE("the matrix and preconditioner are built once while the active set holds", "[solver][reuse][mpi]") {
  // A column resting on its floor: its particles move by micrometres, so the
  // active grid points never change. One build for 6 steps, and the same
  // answer as building everything at every step.
  const std::string yaml = column_case(1.0, 0.1, 0.005, "");
  // A fresh LU at every iterate (preonly), so that both runs factor the
  // same matrices (reused factors are tested below).
  const auto run = [&](bool reuse) {
    TALUS_PETSC(PetscOptionsSetValue(nullptr, "-talus_ksp_type", "preonly"));
    TALUS_PETSC(PetscOptionsSetValue(nullptr, "-talus_pc_type", "lu"));
    Simulation<2> sim(testing::case_from_yaml(yaml), PETSC_COMM_WORLD);
    sim.newton().set_structure_reuse(reuse);
    for (int n = 0; n < 6; ++n) REQUIRE(sim.advance(0.005).converged);
    clear("-talus_ksp_type");
    clear("-talus_pc_type");
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

namespace {

// A coarse collapsing Mohr-Coulomb column (test_large_steps.cpp's, cell
// 0.02 m, 800 particles) with associated flow on a slip floor: plastic
// branches change between Newton iterates, so the Jacobian does too. With
// associated flow the step is a convex minimization, so its solution is
// unique and two solvers must find the same one. (With psi = 0 on a Coulomb
// floor they need not: docs/solver.md#non-unique-steps.)
std::string collapsing_column(double h) {
  char yaml[1200];
  std::snprintf(yaml, sizeof yaml,
                "grid: {lower: [0, 0], upper: [1.0, 0.5], cell_size: 0.02}\n"
                "time: {end: 1.0, step: %.17g}\noutput: {enabled: false}\ngravity: [0, -9.81]\n"
                "materials: [{name: sand, model: mohr_coulomb, density: 1800, youngs_modulus: 1.0e6,"
                " poisson_ratio: 0.3, friction_angle: 30, dilatancy_angle: 30, cohesion: 100}]\n"
                "bodies: [{name: column, material: sand, box: {lower: [0, 0], upper: [0.2, 0.4]},"
                " particles_per_cell: 2}]\n"
                "boundaries: {x_min: slip, x_max: slip, y_min: slip, y_max: slip}\n",
                h);
  return yaml;
}

struct ColumnRun {
  std::vector<double> stress;
  long newton = 0, factorizations = 0, linear_failures = 0, fallbacks = 0, resolves = 0, matrices = 0, krylov = 0;
  std::vector<NewtonReport> steps;  // each step's Newton report
};

// `steps` steps of h with the PETSc options `options` (name, value) set for
// the run only.
ColumnRun run_column(const std::string& yaml, double h, int steps,
                     const std::vector<std::pair<std::string, std::string>>& options, MPI_Comm comm) {
  for (const auto& [name, value] : options) TALUS_PETSC(PetscOptionsSetValue(nullptr, name.c_str(), value.c_str()));
  ColumnRun run;
  {
    Simulation<2> sim(testing::case_from_yaml(yaml), comm);
    for (int n = 0; n < steps; ++n) {
      const StepReport r = sim.advance(h);
      REQUIRE(r.converged);
      run.newton += r.newton.iterations;
      run.factorizations += r.newton.factorizations;
      run.linear_failures += r.newton.linear_failures;
      run.fallbacks += r.newton.direct_fallback;
      run.resolves += r.newton.fresh_resolves;
      run.matrices += r.newton.jacobian_matrices;
      run.krylov += r.newton.linear_iterations;
      run.steps.push_back(r.newton);
    }
    run.stress = testing::gather_by_id(sim.particles(), field::stress, 6);
  }
  for (const auto& option : options) clear(option.first.c_str());
  return run;
}

}  // namespace

// The default below the direct limit is GMRES preconditioned by the factors
// (incomplete LU on one rank, LU on several) of an earlier Newton iterate,
// factored again only when a solve needs more than
// -talus_refactor_iterations Krylov iterations. The reference is Newton with
// a fresh LU solve at every iterate (preonly).
const std::vector<std::pair<std::string, std::string>> fresh_lu{{"-talus_ksp_type", "preonly"},
                                                                {"-talus_pc_type", "lu"}};

TEST_CASE("Factors are kept across steps while the Jacobian holds", "[solver][reuse][mpi]") {
  for (const char* pc : {"", "lu"}) {
    // Elastic, at rest: every Jacobian equals the first, so its factors
    // serve every later system (in one Krylov iteration for LU).
    INFO("-talus_pc_type " << (*pc ? pc : "(default)"));
    const std::string yaml = column_case(1.0, 0.1, 0.005, "");
    std::vector<std::pair<std::string, std::string>> options;
    if (*pc) options.emplace_back("-talus_pc_type", pc);
    const ColumnRun reused = run_column(yaml, 0.005, 6, options, PETSC_COMM_WORLD);
    const ColumnRun fresh = run_column(yaml, 0.005, 6, fresh_lu, PETSC_COMM_WORLD);
    CHECK(reused.factorizations == 1);
    CHECK(fresh.factorizations == 0);  // preonly: no reuse, nothing counted
    // Both Newton runs stop at U <= 1e-8 on a linear problem: one Newton
    // iteration each, solved to GMRES's 1e-8 or exactly.
    CHECK(max_relative_difference(reused.stress, fresh.stress) < 1e-7);
  }
}

TEST_CASE("Factors are refreshed when they no longer precondition well", "[solver][reuse]") {
  // The two runs agree to the balance tolerance: the unbalance
  // is held to balance_tolerance itself, not to the step's time error
  // (docs/solver.md#the-tolerance-follows-the-time-error).
  const testing::ScopedOption exact_balance("-talus_balance_time_fraction", "0");
  SECTION("a collapsing plastic column, LU and the default incomplete LU") {
    // 16 steps of 2e-3 s (10 explicit steps): branches of the return map
    // change between iterates, the stale factors precondition less well and
    // are refreshed when a solve needs more than 30 Krylov iterations.
    for (const char* pc : {"lu", ""}) {
    INFO("-talus_pc_type " << (*pc ? pc : "(default)"));
    const std::string yaml = collapsing_column(2e-3);
    std::vector<std::pair<std::string, std::string>> options;
    if (*pc) options.emplace_back("-talus_pc_type", pc);
    const ColumnRun reused = run_column(yaml, 2e-3, 16, options, PETSC_COMM_SELF);
    const ColumnRun fresh = run_column(yaml, 2e-3, 16, fresh_lu, PETSC_COMM_SELF);
    std::printf("collapsing column, 16 steps: reused factors: %ld Newton iterations, %ld factorizations; "
                "fresh LU: %ld Newton iterations\n",
                reused.newton, reused.factorizations, fresh.newton);
    CHECK(reused.factorizations >= 1);
    CHECK(4 * reused.factorizations <= reused.newton);  // measured: 4 factorizations, 59 iterations
    CHECK(reused.linear_failures == 0);
    // Each step ends at U <= 1e-8 on a problem with a unique solution: the
    // stresses agree to the solver tolerance times the stiffness ratio
    // (c_p h / dx)^2 ~ 10 (measured: 7e-13).
    CHECK(max_relative_difference(reused.stress, fresh.stress) < 1e-6);
    CHECK(reused.fallbacks == 0);
    }
  }
  SECTION("a stale solve that does not converge is solved again on fresh factors") {
    // One GMRES iteration allowed: every solve on stale factors stops
    // unconverged. Its direction is not taken; the same Newton system is
    // solved again on fresh factors of its own Jacobian (where one GMRES
    // iteration is an exact solve), so every iterate follows the fresh-LU
    // direction. No linear failure, no LU fallback, and the fresh-LU answer
    // to round-off.
    const std::string yaml = collapsing_column(2e-3);
    // Inexact Newton off: with its looser tolerances (up to 1e-2) one
    // iteration on stale factors can converge, and this section is about
    // the solves that do not.
    const ColumnRun capped = run_column(
        yaml, 2e-3, 8, {{"-talus_pc_type", "lu"}, {"-talus_ksp_max_it", "1"}, {"-talus_snes_ksp_ew", "false"}},
        PETSC_COMM_SELF);
    const ColumnRun fresh = run_column(yaml, 2e-3, 8, fresh_lu, PETSC_COMM_SELF);
    CHECK(capped.resolves >= 1);
    CHECK(capped.linear_failures == 0);
    CHECK(capped.fallbacks == 0);
    CHECK(max_relative_difference(capped.stress, fresh.stress) < 1e-10);
  }
}

TEST_CASE("The LU fallback keeps its factors across the step's Newton iterations", "[solver][reuse][convergence]") {
  // Unpreconditioned GMRES limited to 2 iterations fails the first solve of
  // every step, so every step of the collapsing column is solved again by
  // the LU fallback: Newton with GMRES on LU factors kept while a solve on
  // them needs at most 30 Krylov iterations (docs/solver.md#failed-linear-solves),
  // every solve to 1e-8. Against Newton with a fresh LU at every iterate:
  // the same answer to the solver tolerance times the stiffness ratio, as
  // for the default's kept factors above, with far fewer factorizations.
  const testing::ScopedOption exact_balance("-talus_balance_time_fraction", "0");
  const std::string yaml = collapsing_column(2e-3);
  const ColumnRun fallback = run_column(
      yaml, 2e-3, 16, {{"-talus_ksp_type", "gmres"}, {"-talus_pc_type", "none"}, {"-talus_ksp_max_it", "2"}},
      PETSC_COMM_SELF);
  const ColumnRun fresh = run_column(yaml, 2e-3, 16, fresh_lu, PETSC_COMM_SELF);
  std::printf("collapsing column, 16 steps by the LU fallback: %ld Newton iterations (with the failed starts), "
              "%ld factorizations; fresh LU: %ld Newton iterations\n",
              fallback.newton, fallback.factorizations, fresh.newton);
  CHECK(fallback.fallbacks == 16);
  CHECK(fallback.factorizations >= 16);  // at least one per step: each fallback builds its own structure
  CHECK(2 * fallback.factorizations <= fresh.newton);
  CHECK(max_relative_difference(fallback.stress, fresh.stress) < 1e-6);
}

TEST_CASE("The Jacobian as an operator: the matrix's steps, assembled only for its factors", "[solver][reuse]") {
  // -talus_jacobian operator: GMRES multiplies by the particle tangents
  // (MomentumSystem::apply_jacobian) and the matrix is assembled only when
  // the kept factors are refreshed (3D's default, forced here in 2D, where
  // the same templated code runs). The Newton iterates are those of the
  // assembled matrix up to round-off in the products: the same iteration
  // counts, the stresses to the solver tolerance, far fewer matrices.
  const std::string yaml = collapsing_column(2e-3);
  const ColumnRun matrix = run_column(yaml, 2e-3, 16, {{"-talus_jacobian", "matrix"}}, PETSC_COMM_SELF);
  const ColumnRun op = run_column(yaml, 2e-3, 16, {{"-talus_jacobian", "operator"}}, PETSC_COMM_SELF);
  std::printf("collapsing column, 16 steps: matrix: %ld Newton, %ld matrices; operator: %ld Newton, %ld matrices, "
              "%ld factorizations\n", matrix.newton, matrix.matrices, op.newton, op.matrices, op.factorizations);
  CHECK(matrix.matrices == matrix.newton);
  CHECK(op.newton == matrix.newton);
  CHECK(op.matrices == op.factorizations);  // one matrix per factorization, fresh re-solves included
  CHECK(4 * op.matrices <= op.newton);      // measured: 4 factorizations, 59 iterations
  CHECK(max_relative_difference(op.stress, matrix.stress) < 1e-6);
  SECTION("a stale solve that does not converge is solved again on the fresh matrix at the iterate") {
    const ColumnRun capped = run_column(yaml, 2e-3, 8,
                                        {{"-talus_jacobian", "operator"}, {"-talus_pc_type", "lu"},
                                         {"-talus_ksp_max_it", "1"}, {"-talus_snes_ksp_ew", "false"}},
                                        PETSC_COMM_SELF);
    const ColumnRun fresh = run_column(yaml, 2e-3, 8, fresh_lu, PETSC_COMM_SELF);
    CHECK(capped.resolves >= 1);
    CHECK(capped.linear_failures == 0);
    CHECK(max_relative_difference(capped.stress, fresh.stress) < 1e-10);
  }
}

TEST_CASE("The balance tolerance follows the step's time error", "[solver][convergence]") {
  // docs/solver.md#the-tolerance-follows-the-time-error: U may reach
  // min(1e-2 E, 1e-4) (E the backward-Euler local error estimated from the
  // distance to the last acceleration continued), never less than
  // balance_tolerance = 1e-8. The collapsing column (16 steps of 2e-3 s, 10
  // explicit steps) against the same run held to 1e-8 at every step.
  const std::string yaml = collapsing_column(2e-3);
  const ColumnRun loose = run_column(yaml, 2e-3, 16, {}, PETSC_COMM_SELF);
  const ColumnRun exact = run_column(yaml, 2e-3, 16, {{"-talus_balance_time_fraction", "0"}}, PETSC_COMM_SELF);
  int loosened = 0;
  for (std::size_t n = 0; n < loose.steps.size(); ++n) {
    const NewtonReport& r = loose.steps[n];
    INFO("step " << n + 1 << ": E " << r.time_error << ", tolerance " << r.tolerance << ", U " << r.unbalance);
    CHECK(r.tolerance == std::max(1e-8, std::min(1e-2 * r.time_error, 1e-4)));
    CHECK(r.unbalance <= r.tolerance);
    loosened += r.tolerance > 1e-8;
    CHECK(exact.steps[n].tolerance == 1e-8);
  }
  // The first step has no last acceleration: its estimate starts from the
  // stresses' acceleration at t = 0 (GridFields::start_acceleration; free
  // fall here, the column starts stress free), so it is loosened too.
  CHECK(loose.steps.front().time_error > 1e-3);
  CHECK(loose.steps.front().tolerance > 1e-8);
  {
    // A quasi-static first step (h c_p / dx >= 100: 10 s on a column whose
    // period is ~0.03 s) keeps the floor: its user asks for its equilibrium.
    Simulation<2> sim(testing::case_from_yaml(column_case(2.0, 0.05, 10.0, "")), PETSC_COMM_SELF);
    const StepReport r = sim.advance(10.0);
    REQUIRE(r.converged);
    CHECK(r.newton.time_error == 0.0);
    CHECK(r.newton.tolerance == 1e-8);
    CHECK(r.newton.unbalance <= 1e-8);
  }
  std::printf("collapsing column, 16 steps: %d steps loosened; Newton %ld against %ld at 1e-8; stresses differ by "
              "%.2e (max relative)\n",
              loosened, loose.newton, exact.newton, max_relative_difference(loose.stress, exact.stress));
  // Measured 2026-11-26: 15 steps loosened, 29 Newton iterations against 57,
  // stresses 6.0e-5 apart; 2026-11-28, with the first step's estimate: 16.
  CHECK(loosened >= 8);
  CHECK(4 * loose.newton <= 3 * exact.newton);
  // The stresses differ by the algebraic error left, a hundredth of a step's
  // time error (E of 1e-3-1e-2 here), accumulated over the 16 steps.
  CHECK(max_relative_difference(loose.stress, exact.stress) < 5e-4);
}

TEST_CASE("Inexact Newton loosens the linear solves of later iterations", "[solver][inexact]") {
  // The two runs agree to the balance tolerance: the unbalance
  // is held to balance_tolerance itself, not to the step's time error
  // (docs/solver.md#the-tolerance-follows-the-time-error).
  const testing::ScopedOption exact_balance("-talus_balance_time_fraction", "0");
  // Eisenstat-Walker (docs/solver.md#inexact-newton) sets each KSP's
  // tolerance in SNES's pre-solve hook of the KSP; a hook of talus's own
  // there once replaced it silently and doubled the Krylov iterations (3D
  // landslide: 11,192 -> 23,833). Guard: the default needs clearly fewer
  // Krylov iterations than the same run with every solve to 1e-8.
  const std::string yaml = collapsing_column(2e-3);
  const ColumnRun inexact = run_column(yaml, 2e-3, 16, {}, PETSC_COMM_SELF);
  const ColumnRun exact = run_column(yaml, 2e-3, 16, {{"-talus_snes_ksp_ew", "false"}}, PETSC_COMM_SELF);
  std::printf("collapsing column, 16 steps: Krylov iterations %ld with inexact Newton, %ld without\n",
              inexact.krylov, exact.krylov);
  CHECK(inexact.krylov < 0.8 * exact.krylov);
  CHECK(max_relative_difference(inexact.stress, exact.stress) < 1e-6);
  SECTION("also with the Jacobian as an operator") {
    const ColumnRun op = run_column(yaml, 2e-3, 16, {{"-talus_jacobian", "operator"}}, PETSC_COMM_SELF);
    // The same solves up to round-off in the products (measured: equal).
    CHECK(std::abs(op.krylov - inexact.krylov) <= 0.05 * inexact.krylov);
  }
}
