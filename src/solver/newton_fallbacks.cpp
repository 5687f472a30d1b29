// Geometric multigrid as the Newton systems' preconditioner
// (-talus_pc_type mg, docs/solver.md#geometric-multigrid): PETSc's PCMG on the
// levels of the active set (talus/solver/multigrid.hpp), set up again with
// the structure and kept across Newton iterations like factors; and the
// retries of a step whose linear solves failed, by LU or on the multigrid.
#include "talus/solver/newton.hpp"
#include "newton_convergence.hpp"
#include "newton_option_readers.hpp"

#include <algorithm>

namespace talus {

template <int dim>
bool NewtonSolver<dim>::solving_pc_is(PCType type) const {
  PetscBool same = PETSC_FALSE;
  TALUS_PETSC(PetscObjectTypeCompare(reinterpret_cast<PetscObject>(solving_pc()), type, &same));
  return same;
}

template <int dim>
bool NewtonSolver<dim>::solves_by_multigrid() const {
  return solving_pc_is(PCMG);
}

template <int dim>
std::vector<PetscInt> NewtonSolver<dim>::contact_rows(const MomentumSystem<dim>& system) {
  std::vector<PetscInt> rows;
  for (const auto& cp : system.contacts())
    for (int a = 0; a < dim; ++a) rows.push_back(cp.row + a);
  for (const auto& cp : system.body_contacts())
    for (int a = 0; a < dim; ++a) rows.push_back(cp.row_a + a);
  std::sort(rows.begin(), rows.end());
  return rows;
}

template <int dim>
void NewtonSolver<dim>::build_multigrid(const MomentumSystem<dim>& system) {
  // -talus_pc_mg_levels caps the levels; by default they go down to
  // -talus_mg_coarse_unknowns.
  const PetscInt max_levels = count_option("pc_mg_levels", 30);
  multigrid_held_ = contact_rows(system);
  multigrid_.build(system.grid(), system.active(), system.field_count(), multigrid_coarse_unknowns_,
                   static_cast<int>(std::max<PetscInt>(max_levels, 1)), multigrid_held_);
  multigrid_.configure(solving_pc());
}

// The retry of a step whose linear solves failed above the LU fallback's
// limit: the default Newton (backtracking line search, inexact solves) with
// GMRES on the multigrid of the active set, kept across the step's
// iterations like factors. Like the LU fallback, not read from the options
// database (prefix talus_fallback_).
template <int dim>
void NewtonSolver<dim>::configure_multigrid_fallback(const MomentumSystem<dim>& system) {
  TALUS_PETSC(SNESSetOptionsPrefix(snes_, "talus_fallback_"));
  set_newton(snes_, 25, SNESLINESEARCHBT);
  KSP ksp;
  PC pc;
  TALUS_PETSC(SNESGetKSP(snes_, &ksp));
  TALUS_PETSC(KSPGetPC(ksp, &pc));
  set_right_gmres(ksp, 1e-8, 50);
  set_inexact_newton(snes_);
  TALUS_PETSC(PCSetType(pc, PCMG));
  TALUS_PETSC(SNESSetConvergenceTest(snes_, physical_convergence<dim>, &scale_, nullptr));
  factorization_.reused_mode = true;
  build_multigrid(system);
}

// A step whose linear solves failed (docs/solver.md#failed-linear-solves):
// solved again from the same start by Newton with LU up to
// -talus_direct_fallback_limit unknowns, whose LU costs less than the
// cut-back that follows a failed step; above it, in a quasi-static step (a
// P-wave crosses at least quasi_static_wave_cells cells), on the geometric
// multigrid, which solves the static systems the incomplete factors cannot.
// In dynamic steps the failures are the yielding systems, which neither
// preconditioner solves: there the retries cost 8-15 % more CPU on the
// 51,200-particle column (24 cells per step) and 12 % on the 3D landslide at
// cell 0.075 m (7 cells). Where a retry fails it is not tried again for
// `pause` converged steps.
template <int dim>
bool NewtonSolver<dim>::retry_linear_failure(MomentumSystem<dim>& system, PetscInt unknowns, Start start,
                                             NewtonReport& report) {
  constexpr int pause = 25;
  if (solves_by_lu()) return false;
  if (unknowns <= fallback_limit_) {
    build(system, unknowns, Fallback::direct);
    report = retried(report, run_snes(system, start));
    report.structure_built = true;
    report.direct_fallback = true;
  } else if (multigrid_fallback_ && multigrid_pause_ == 0 && wave_cells_ >= quasi_static_wave_cells &&
             !solves_by_multigrid()) {
    build(system, unknowns, Fallback::multigrid);
    report = retried(report, run_snes(system, start));
    report.structure_built = true;
    report.multigrid_fallback = true;
    if (!report.converged) multigrid_pause_ = pause;
  } else {
    return false;
  }
  return true;
}

template class NewtonSolver<2>;
template class NewtonSolver<3>;

}  // namespace talus
