// Large implicit steps through a collapsing, frictional, plastic column
// (issue 11): a coarse version of the reference column (inputs/
// reference_column_frictional.yaml) at 20 times its explicit step, with
// psi = 0 and with associated flow, converges with few cut-backs, and its
// deposit matches a run at a four times smaller step.
#include <catch2/catch.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "talus/simulation.hpp"
#include "test_support.hpp"

using namespace talus;

namespace {

struct Deposit {
  double runout = 0;       // x below which 99 % of the particles lie (m)
  double wall_height = 0;  // highest particle within one cell of the left wall (m)
  RunSummary summary;
};

// Cell 0.02 m, 2 x 2 particles per cell (800 particles), Mohr-Coulomb
// phi = 30, c = 100 Pa, E = 1 MPa, nu = 0.3, rho = 1800: P-wave speed
// 27.3 m/s, so an explicit code needs h <= 0.02 / 27.3 = 7.3e-4 s and runs
// about 2e-4 s (the reference column's 1e-4 s at half the cell).
Deposit collapse(double psi, double h, double end) {
  char yaml[1400];
  std::snprintf(yaml, sizeof yaml,
                "grid: {lower: [0, 0], upper: [1.0, 0.5], cell_size: 0.02}\n"
                "time: {end: %.17g, step: %.17g}\noutput: {enabled: false}\ngravity: [0, -9.81]\n"
                "materials: [{name: sand, model: mohr_coulomb, density: 1800, youngs_modulus: 1.0e6,"
                " poisson_ratio: 0.3, friction_angle: 30, dilatancy_angle: %g, cohesion: 100}]\n"
                "bodies: [{name: column, material: sand, box: {lower: [0, 0], upper: [0.2, 0.4]},"
                " particles_per_cell: 2}]\n"
                "boundaries: {x_min: slip, x_max: slip, y_min: {condition: frictional, friction: 0.4}, y_max: slip}\n",
                end, h, psi);
  Simulation<2> sim(testing::case_from_yaml(yaml), PETSC_COMM_SELF);
  Deposit d;
  d.summary = sim.run(nullptr);
  const auto x = testing::gather_by_id(sim.particles(), field::position, 2);
  std::vector<double> xs;
  for (std::size_t p = 0; p < x.size() / 2; ++p) {
    xs.push_back(x[2 * p]);
    if (x[2 * p] < 0.02) d.wall_height = std::max(d.wall_height, x[2 * p + 1]);
  }
  std::sort(xs.begin(), xs.end());
  d.runout = xs[static_cast<std::size_t>(0.99 * (xs.size() - 1))];
  return d;
}

void check_large_steps(double psi, const char* name) {
  const double explicit_step = 2e-4, end = 0.6;
  const Deposit large = collapse(psi, 20 * explicit_step, end);
  const Deposit small = collapse(psi, 5 * explicit_step, end);
  std::printf("%s: h = 4e-3 s: %ld steps, %ld cut-backs, %.2f Newton/step, run-out %.4f m, wall height %.4f m; "
              "h = 1e-3 s: %ld steps, %ld cut-backs, %.2f Newton/step, run-out %.4f m, wall height %.4f m\n",
              name, large.summary.steps, large.summary.cutbacks,
              double(large.summary.newton_iterations) / large.summary.steps, large.runout, large.wall_height,
              small.summary.steps, small.summary.cutbacks,
              double(small.summary.newton_iterations) / small.summary.steps, small.runout, small.wall_height);
  // 150 nominal steps. Issue 11 asks for a handful of cut-backs at most;
  // measured on 2026-11-24 with the trust region (newtontr): 5 (psi = 0) and
  // 9 (psi = phi) cut-backs, 157 and 288 steps; since the Coulomb floor is
  // one grid row thick (15207c3), 0 and 7 cut-backs, 150 and 180 steps
  // (8.2 and 10.4 Newton iterations per step). With the default
  // backtracking line search (2026-11-25): 0 and 6 cut-backs, 150 and 159
  // steps, 8.8 and 12.2 Newton iterations per step; with inexact Newton
  // (Eisenstat-Walker on stale LU factors, 2026-11-25): 0 and 8 cut-backs,
  // 150 and 196 steps, 9.2 and 11.2. With the ghost penalty and quadratic
  // backtracking (2026-11-27): 0 and 1 cut-backs, 150 and 151 steps, 4.75
  // and 8.95 Newton iterations per step. These bounds guard that
  // state against regressions; the target itself is still open
  // (docs/solver.md#large-steps).
  CHECK(large.summary.cutbacks <= 12);
  CHECK(large.summary.steps <= 2 * 150);
  // The deposit at 0.6 s: within 2 cells' worth of the small-step run,
  // 0.04 m, about 5 % of a run-out of 0.6-0.9 m, the first-order time
  // error at 4x the step (the same figure in the issue asks 2 % on the
  // finer reference column).
  CHECK(std::abs(large.runout - small.runout) < 0.04);
  CHECK(std::abs(large.wall_height - small.wall_height) < 0.04);
}

}  // namespace

TEST_CASE("large steps: a frictional psi = 0 column at 20x the explicit step", "[solver][large_steps]") {
  check_large_steps(0.0, "psi = 0");
}

TEST_CASE("large steps: a frictional associated column at 20x the explicit step", "[solver][large_steps]") {
  check_large_steps(30.0, "psi = phi");
}

// The line search backtracks by quadratic fits (docs/solver.md#the-backtracking-order):
// a crawling step's merit rises steeply past one plastic particle's kink and
// then flattens, and PETSc's default cubic fit through that plateau takes
// steps of lambda ~ 0.02. Measured on this column (2026-11-27): 1,352 Newton
// iterations and 1 cut-back with quadratic fits against 1,421 and 5 with
// cubic ones (reference column, mu = 0.4: 1,753 against 1,858;
// boulders_onto_wall.yaml: 7,296 and 19 cut-backs against 12,438 and 45).
// With the same fits both runs would be identical, so the strict inequality
// fails if the default goes back to cubic fits.
TEST_CASE("large steps: quadratic backtracking crawls less than cubic", "[solver][large_steps]") {
  // With every first linear solve to 1e-8 and every step held to U <= 1e-8:
  // the looser first solve of plastic steps (docs/solver.md#inexact-newton)
  // and the time-error tolerance, since 2026-11-28 also at the first step
  // (docs/solver.md#the-tolerance-follows-the-time-error), move this
  // column's path (1,535 Newton iterations and 3 cut-backs quadratic, 1,412
  // and 2 cubic; then 1,448 and 4 against 1,498 and 0), and the comparison is
  // of the fits alone. Measured so (2026-11-28): 1,831 and 3 against 1,949
  // and 4.
  const testing::ScopedOption first("-talus_snes_ksp_ew_rtol0", "1e-8");
  const testing::ScopedOption exact("-talus_balance_time_fraction", "0");
  const Deposit quadratic = collapse(30.0, 4e-3, 0.6);
  TALUS_PETSC(PetscOptionsSetValue(nullptr, "-talus_snes_linesearch_order", "3"));
  const Deposit cubic = collapse(30.0, 4e-3, 0.6);
  TALUS_PETSC(PetscOptionsClearValue(nullptr, "-talus_snes_linesearch_order"));
  std::printf("psi = phi, h = 4e-3 s: quadratic fits %ld Newton iterations, %ld cut-backs; cubic fits %ld, %ld\n",
              quadratic.summary.newton_iterations, quadratic.summary.cutbacks, cubic.summary.newton_iterations,
              cubic.summary.cutbacks);
  CHECK(quadratic.summary.newton_iterations < cubic.summary.newton_iterations);
  CHECK(quadratic.summary.cutbacks <= cubic.summary.cutbacks);
}

namespace {

// The coarse psi = 0 column on the Coulomb floor, advanced with full Newton
// steps (-talus_snes_linesearch_type basic) at 20x its explicit step for `steps` steps, or until a
// step fails; the reports of all steps taken.
std::vector<StepReport> column_steps(const char* stagnation_iterations, long steps) {
  TALUS_PETSC(PetscOptionsSetValue(nullptr, "-talus_stagnation_iterations", stagnation_iterations));
  TALUS_PETSC(PetscOptionsSetValue(nullptr, "-talus_snes_linesearch_type", "basic"));
  const char* yaml =
      "grid: {lower: [0, 0], upper: [1.0, 0.5], cell_size: 0.02}\n"
      "time: {end: 1.0, step: 4e-3}\noutput: {enabled: false}\ngravity: [0, -9.81]\n"
      "materials: [{name: sand, model: mohr_coulomb, density: 1800, youngs_modulus: 1.0e6,"
      " poisson_ratio: 0.3, friction_angle: 30, dilatancy_angle: 0, cohesion: 100}]\n"
      "bodies: [{name: column, material: sand, box: {lower: [0, 0], upper: [0.2, 0.4]},"
      " particles_per_cell: 2}]\n"
      "boundaries: {x_min: slip, x_max: slip, y_min: {condition: frictional, friction: 0.4}, y_max: slip}\n";
  std::vector<StepReport> reports;
  {
    Simulation<2> sim(testing::case_from_yaml(yaml), PETSC_COMM_SELF);
    while (static_cast<long>(reports.size()) < steps) {
      reports.push_back(sim.advance(4e-3));
      if (!reports.back().converged) break;
    }
  }
  TALUS_PETSC(PetscOptionsClearValue(nullptr, "-talus_stagnation_iterations"));
  TALUS_PETSC(PetscOptionsClearValue(nullptr, "-talus_snes_linesearch_type"));
  return reports;
}

}  // namespace

// Full semismooth Newton steps that stop reducing the unbalance U are
// cycling between branches of the return map (docs/solver.md#stagnation):
// the step fails as soon as U has had no new minimum (5 % below the last) for 6 iterations, not
// after the 25 of the iteration limit, and nothing else changes: the
// iterates are those of the run without the test, bit for bit.
TEST_CASE("a cycling Newton step fails by stagnation, not at the iteration limit", "[solver][large_steps]") {
  // One Newton attempt per step: from free fall only, so that a failed step
  // is not tried again from the other predictor (docs/solver.md#the-predictor).
  const testing::ScopedOption start("-talus_newton_predictor", "gravity");
  const std::vector<StepReport> stagnating = column_steps("6", 60);
  REQUIRE_FALSE(stagnating.back().converged);
  const std::size_t failed = stagnating.size() - 1;
  const std::vector<StepReport> limited = column_steps("0", static_cast<long>(failed + 1));
  REQUIRE(limited.size() == failed + 1);
  // The steps before converge identically (they never stagnate).
  for (std::size_t n = 0; n < failed; ++n) CHECK(limited[n].newton.unbalances == stagnating[n].newton.unbalances);
  const NewtonReport& s = stagnating[failed].newton;
  const NewtonReport& l = limited[failed].newton;
  CHECK(s.reason == "STAGNATED");
  const std::vector<double>& u = s.unbalances;
  // The last new minimum: U at least 5 % below the minimum before it.
  std::size_t best = 0;
  for (std::size_t k = 1; k < u.size(); ++k)
    if (u[k] < 0.95 * u[best]) best = k;
  std::printf("step %zu: U %.2e at iteration %ld, then no new minimum: stopped after %ld iterations; without the "
              "test: %s after %ld\n",
              failed, u[best], static_cast<long>(best), static_cast<long>(s.iterations), l.reason.c_str(),
              static_cast<long>(l.iterations));
  // Stopped exactly 6 iterations after the last new minimum, on the same
  // iterates as the run without the test.
  CHECK(u.size() - 1 == best + 6);
  CHECK(s.iterations == static_cast<PetscInt>(best) + 6);
  REQUIRE(l.unbalances.size() >= u.size());
  for (std::size_t k = 0; k < u.size(); ++k) CHECK(u[k] == l.unbalances[k]);
}

// The Newton predictor (docs/solver.md#the-predictor): starting from the
// last step's grid acceleration saves Newton iterations on the collapsing
// column, where the velocity field changes smoothly from step to step.
TEST_CASE("the last-acceleration predictor saves Newton iterations on the collapsing column", "[solver][large_steps]") {
  // With the consistent tangent: the primal-dual tangent (the default, test
  // below) removes most of the iterations the predictor saved on this
  // coarse column (2026-11-28: 662 from the last acceleration against 656
  // from free fall; on the reference column 1,407 against 1,639).
  const testing::ScopedOption tangent("-talus_newton_tangent", "consistent");
  const auto newton = [](const char* predictor) {
    const testing::ScopedOption start("-talus_newton_predictor", predictor);
    return collapse(0.0, 4e-3, 0.6).summary;
  };
  const RunSummary last = newton("last"), gravity = newton("gravity");
  std::printf("predictor last: %ld steps, %ld cut-backs, %ld Newton; gravity: %ld steps, %ld cut-backs, %ld Newton\n",
              last.steps, last.cutbacks, last.newton_iterations, gravity.steps, gravity.cutbacks,
              gravity.newton_iterations);
  // Measured 2026-11-25: 1,238 against 1,404 (12 % fewer), both 150 steps
  // without cut-backs; at least 5 % fewer is asserted.
  CHECK(last.newton_iterations < 0.95 * gravity.newton_iterations);
  CHECK(last.cutbacks <= gravity.cutbacks);
}

namespace {
// A soft elastic block (E = 1e4 Pa: P-wave speed 2.7 m/s) thrown at 4 m/s
// onto a no-slip floor, cell 0.02 m. It lands at about t = 0.02 s at
// 4.2 m/s: a step of 0.01 s would carry it 2.1 cells, through the floor's
// grid row, faster than the wave it sends up can stop it.
RunSummary soft_block_landing(double h, double& smallest_det) {
  char yaml[1200];
  std::snprintf(yaml, sizeof yaml,
                "grid: {lower: [0, 0], upper: [1.0, 0.5], cell_size: 0.02}\n"
                "time: {end: 0.1, step: %.17g}\noutput: {enabled: false}\ngravity: [0, -9.81]\n"
                "materials: [{name: gel, model: linear_elastic, density: 1800, youngs_modulus: 1.0e4,"
                " poisson_ratio: 0.3}]\n"
                "bodies: [{name: block, material: gel, box: {lower: [0.3, 0.1], upper: [0.7, 0.3]},"
                " particles_per_cell: 2, velocity: [0, -4]}]\n"
                "boundaries: {x_min: slip, x_max: slip, y_min: fixed, y_max: slip}\n",
                h);
  Simulation<2> sim(testing::case_from_yaml(yaml), PETSC_COMM_SELF);
  const RunSummary s = sim.run(nullptr);
  const auto F = testing::gather_by_id(sim.particles(), field::deformation_gradient, 4);
  const auto J = testing::gather_by_id(sim.particles(), field::volume_ratio, 1);
  smallest_det = 1e300;
  for (std::size_t p = 0; p < J.size(); ++p)
    smallest_det = std::min({smallest_det, F[4 * p] * F[4 * p + 3] - F[4 * p + 1] * F[4 * p + 2], J[p]});
  return s;
}
}  // namespace

TEST_CASE("a converged step that would invert particles is cut back", "[solver][large_steps]") {
  double det_large = 0, det_small = 0;
  const RunSummary large = soft_block_landing(0.01, det_large);
  const RunSummary small = soft_block_landing(0.0025, det_small);
  std::printf("soft block: h = 0.01 s: %ld steps, %ld cut-backs (%ld inverting), smallest det F %.3f; "
              "h = 0.0025 s: %ld steps, %ld cut-backs (%ld inverting), smallest det F %.3f\n",
              large.steps, large.cutbacks, large.inverting_cutbacks, det_large, small.steps, small.cutbacks,
              small.inverting_cutbacks, det_small);
  // Measured 2026-11-27: at 0.01 s the landing step converges but inverts
  // 40 particles; it is cut back once and the run ends at 0.1 s (without
  // the check G2P left det F < 0 there). A quarter of the step (0.5 cell per
  // step) needs no such cut-back.
  CHECK(large.status == RunStatus::completed);
  CHECK(large.inverting_cutbacks >= 1);
  CHECK(large.inverting_cutbacks <= large.cutbacks);
  CHECK(det_large > 0.0);
  CHECK(small.status == RunStatus::completed);
  CHECK(small.inverting_cutbacks == 0);
  CHECK(det_small > 0.0);
}

// The primal-dual tangent (docs/solver.md#the-primal-dual-tangent): the
// stress carried from the last Newton iterate in the tangent of the return
// removes the crawls of the psi = 0 column (a plastic particle's stress far
// outside the cone turning through a kink of the return), and the deposit is
// that of the consistent tangent's run to solver tolerance.
TEST_CASE("the primal-dual tangent saves Newton iterations on the collapsing psi = 0 column", "[solver][large_steps]") {
  const auto run = [](const char* tangent) {
    const testing::ScopedOption choice("-talus_newton_tangent", tangent);
    const testing::ScopedOption start("-talus_newton_predictor", "gravity");
    return collapse(0.0, 4e-3, 0.6);
  };
  const Deposit primal_dual = run("primal_dual"), consistent = run("consistent");
  std::printf("tangent primal_dual: %ld steps, %ld cut-backs, %ld Newton, run-out %.4f m, wall %.4f m; "
              "consistent: %ld steps, %ld cut-backs, %ld Newton, run-out %.4f m, wall %.4f m\n",
              primal_dual.summary.steps, primal_dual.summary.cutbacks, primal_dual.summary.newton_iterations,
              primal_dual.runout, primal_dual.wall_height, consistent.summary.steps, consistent.summary.cutbacks,
              consistent.summary.newton_iterations, consistent.runout, consistent.wall_height);
  // Measured 2026-11-28 (from free fall, where the predictor does not hide
  // the difference): 656 against 820 Newton iterations (20 % fewer), both
  // 150 steps without cut-backs; at least 10 % fewer is asserted.
  CHECK(primal_dual.summary.newton_iterations < 0.9 * consistent.summary.newton_iterations);
  CHECK(primal_dual.summary.cutbacks <= consistent.summary.cutbacks);
  // Both solve every step to the same balance tolerance: the deposits
  // agree to far less than a cell (0.02 m); 2 mm is asserted.
  CHECK(std::abs(primal_dual.runout - consistent.runout) < 2e-3);
  CHECK(std::abs(primal_dual.wall_height - consistent.wall_height) < 2e-3);
}

// Inexact Newton's first tolerance (docs/solver.md#inexact-newton): 1e-4
// where a particle is plastic at the start of the step, 1e-8 where none is.
// The collapsing column's steps are plastic: fewer Krylov iterations, the
// same deposit to solver tolerance; an elastic step keeps its single Newton
// iteration (tests/test_energy_balance.cpp, test_elastic_column.cpp).
TEST_CASE("the first linear solve of a plastic step is loose", "[solver][large_steps]") {
  const auto run = [](const char* first) {
    if (!first) return collapse(0.0, 4e-3, 0.6);
    const testing::ScopedOption pinned("-talus_snes_ksp_ew_rtol0", first);
    return collapse(0.0, 4e-3, 0.6);
  };
  const Deposit adaptive = run(nullptr), tight = run("1e-8");
  std::printf("first solve adaptive: %ld Newton, %ld Krylov, run-out %.4f m, wall %.4f m; to 1e-8: %ld Newton, "
              "%ld Krylov, run-out %.4f m, wall %.4f m\n",
              adaptive.summary.newton_iterations, adaptive.summary.linear_iterations, adaptive.runout,
              adaptive.wall_height, tight.summary.newton_iterations, tight.summary.linear_iterations, tight.runout,
              tight.wall_height);
  // Measured 2026-11-28: 4,637 against 5,160 Krylov iterations (10 % fewer),
  // 646 against 645 Newton iterations, the same deposit. Without the rule
  // both runs are identical; at least 5 % fewer Krylov iterations and at
  // most 5 % more Newton iterations are asserted.
  CHECK(adaptive.summary.linear_iterations < 0.95 * tight.summary.linear_iterations);
  CHECK(adaptive.summary.newton_iterations <= 1.05 * tight.summary.newton_iterations);
  CHECK(std::abs(adaptive.runout - tight.runout) < 2e-3);
  CHECK(std::abs(adaptive.wall_height - tight.wall_height) < 2e-3);
}
