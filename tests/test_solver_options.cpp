// Solver choices reach PETSc under the talus_ prefix: from the case file's
// solver.petsc_options, with the command line (the options database) winning.
#include <catch2/catch.hpp>

#include "talus/simulation.hpp"
#include "test_support.hpp"

using namespace talus;

namespace {

const std::string base =
    "grid: {lower: [0, 0], upper: [1, 1], cell_size: 0.1}\n"
    "time: {end: 0.01, step: 0.01}\noutput: {enabled: false}\ngravity: [0, -9.81]\n"
    "materials: [{name: m, model: linear_elastic, density: 2000, youngs_modulus: 1.0e6, poisson_ratio: 0.3}]\n"
    "bodies: [{name: b, material: m, box: {lower: [0.2, 0], upper: [0.8, 0.6]}}]\n"
    "boundaries: {y_min: fixed}\n";

StepReport one_step(const std::string& yaml) {
  Simulation<2> sim(testing::case_from_yaml(yaml), PETSC_COMM_SELF);
  return sim.advance(0.01);
}

void clear(const char* name) { TALUS_PETSC(PetscOptionsClearValue(nullptr, name)); }

}  // namespace

TEST_CASE("case-file PETSc options select the solver, the command line wins", "[solver]") {
  // (This test did not run under ctest until 2026-11-25: a ";" in its name
  // split it into two names that matched nothing. Updated then to the
  // present defaults: GMRES on kept incomplete-LU factors.)
  // The case file asks for a direct solve: one linear iteration per Newton iteration.
  const std::string direct_yaml = base + "solver: {petsc_options: {ksp_type: preonly, pc_type: lu}}\n";
  const StepReport direct = one_step(direct_yaml);
  REQUIRE(direct.converged);
  CHECK(direct.newton.linear_iterations == direct.newton.iterations);
  clear("-talus_ksp_type");
  clear("-talus_pc_type");

  // The case file asks for GMRES + Jacobi: many Krylov iterations per Newton iteration.
  const std::string krylov =
      base + "solver: {petsc_options: {ksp_type: gmres, pc_type: jacobi, ksp_rtol: 1e-12}}\n";
  const StepReport jacobi = one_step(krylov);
  REQUIRE(jacobi.converged);
  CHECK(jacobi.newton.linear_iterations > 5 * jacobi.newton.iterations);

  // CG has no right-preconditioned form: it gets its own (left) side instead
  // of the PETSc error it gave with talus's right side for GMRES.
  clear("-talus_ksp_type");
  clear("-talus_pc_type");
  const StepReport cg = one_step(base + "solver: {petsc_options: {ksp_type: cg, pc_type: jacobi, ksp_rtol: 1e-12}}\n");
  REQUIRE(cg.converged);
  CHECK(cg.newton.linear_iterations > 5 * cg.newton.iterations);

  // An option already in the database (as from the command line) is not overridden.
  clear("-talus_ksp_type");
  clear("-talus_pc_type");
  TALUS_PETSC(PetscOptionsSetValue(nullptr, "-talus_ksp_type", "preonly"));
  TALUS_PETSC(PetscOptionsSetValue(nullptr, "-talus_pc_type", "lu"));
  const StepReport overridden = one_step(krylov);
  REQUIRE(overridden.converged);
  CHECK(overridden.newton.linear_iterations == overridden.newton.iterations);
  for (const char* name : {"-talus_ksp_rtol", "-talus_ksp_type", "-talus_pc_type"}) clear(name);
}

TEST_CASE("a failed Newton solve leaves the particles untouched and the run stops after cut-backs", "[solver]") {
  // Zero Newton iterations allowed: every step with a non-zero initial residual fails.
  TALUS_PETSC(PetscOptionsSetValue(nullptr, "-talus_snes_max_it", "0"));
  std::string yaml = base;
  yaml.replace(yaml.find("time: {end: 0.01, step: 0.01}"), 29, "time: {end: 0.01, step: 0.01, min_step_ratio: 0.1}");
  CaseConfig config = testing::case_from_yaml(yaml);
  Simulation<2> sim(config, PETSC_COMM_SELF);
  const auto before = testing::gather_by_id(sim.particles(), field::position, 2);
  const StepReport r = sim.advance(0.01);
  CHECK_FALSE(r.converged);
  CHECK(sim.time() == 0.0);
  CHECK(testing::gather_by_id(sim.particles(), field::position, 2) == before);
  // h = 0.01, 0.005, ..., 0.000625 < 0.1 * 0.01: the run gives up with a clear error.
  CHECK_THROWS_AS(sim.run(nullptr), SimulationError);
  clear("-talus_snes_max_it");
}

TEST_CASE("systems above solver.direct_solver_limit default to GMRES + GAMG", "[solver]") {
  const StepReport small = one_step(base + "solver: {petsc_options: {snes_type: newtonls}}\n");
  const StepReport large = one_step(base + "solver: {direct_solver_limit: 10, petsc_options: {snes_type: newtonls}}\n");
  REQUIRE(small.converged);
  REQUIRE(large.converged);
  CHECK(small.newton.factorizations >= 1);  // below: GMRES on kept (incomplete) LU factors
  CHECK(large.newton.factorizations == 0);  // above: no factors, algebraic multigrid
  CHECK(large.newton.linear_iterations > 3 * large.newton.iterations);  // Krylov iterations
  CHECK(large.newton.iterations <= 2);  // the linear tolerance is below Newton's
  clear("-talus_snes_type");
}
