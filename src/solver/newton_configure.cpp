// The default solver of an implicit step, set on the PETSc objects before
// the options database (prefix talus_) may override any of it
// (docs/solver.md#defaults): Newton with a backtracking line search, GMRES
// on kept preconditioners (point-block Jacobi of the 3D operator, incomplete
// LU otherwise), LU for the fallback.
#include "talus/solver/newton.hpp"
#include "newton_convergence.hpp"
#include "newton_option_readers.hpp"
#include "talus/solver/petsc_options.hpp"

#include <string>

namespace talus {

template <int dim>
void NewtonSolver<dim>::configure_direct(KSP ksp) {
  PC pc;
  TALUS_PETSC(KSPGetPC(ksp, &pc));
  TALUS_PETSC(KSPSetType(ksp, KSPPREONLY));
  TALUS_PETSC(PCSetType(pc, PCLU));
  // PETSc's own LU is the fastest for small serial systems; MUMPS factors in parallel.
  int size = 1;
  MPI_Comm_size(comm_, &size);
  TALUS_PETSC(PCFactorSetMatSolverType(pc, size > 1 ? MATSOLVERMUMPS : MATSOLVERPETSC));
}

template <int dim>
void NewtonSolver<dim>::configure(PetscInt unknowns, bool point_block) {
  // Defaults are set on the objects, then SNESSetFromOptions lets the options
  // database (command line, case file) override any of them.
  //
  // Default: Newton with a backtracking line search, LU below the direct
  // limit, GMRES + GAMG above it. At large steps full steps cycle between
  // branches of the return map and cut the step back tens of times per
  // second of flow (docs/solver.md#large-steps); the line search removes
  // nearly all of those cut-backs. A trust region (-talus_snes_type newtontr)
  // does too, but a 2-rank contact test failed a step with it in CI.
  // Nonlinear GMRES over an inexact Newton step (-talus_snes_type ngmres,
  // configured below) is faster, but its serial and parallel runs of a
  // contact case differ by more than the solver tolerance.
  TALUS_PETSC(SNESSetOptionsPrefix(snes_, "talus_"));
  // Backtracking on the merit ||F||^2 (Armijo): the full Newton step when it
  // reduces the residual enough, a shorter one when it would cross a kink
  // of the return map or the cone and land far beyond (docs/solver.md#large-steps).
  set_newton(snes_, 25, SNESLINESEARCHBT);
  KSP ksp;
  PC pc;
  TALUS_PETSC(SNESGetKSP(snes_, &ksp));
  TALUS_PETSC(KSPGetPC(ksp, &pc));
  if (unknowns <= direct_limit_) {
    // GMRES preconditioned by factors that are kept while they work
    // (docs/solver.md#reused-factorizations). Right preconditioning: the
    // Krylov residual is the true one. On one rank the factors are an
    // incomplete LU, ILU(1) in 2D and ILU(0) in 3D, where the Jacobian has
    // 125 block neighbours per row and the full LU costs 5 times an ILU(0):
    // measured on plastic and contact cases, 1.5-1.8x less CPU than kept LU
    // factors (docs/solver.md#defaults). A fresh ILU that cannot solve a
    // Newton system sends the step to the LU fallback or a cut-back
    // (NewtonSolver::solve). On several ranks:
    // block Jacobi with the same incomplete LU on each rank's block (PETSc's
    // ILU is serial), kept in the same way.
    configure_direct(ksp);
    int size = 1;
    MPI_Comm_size(comm_, &size);
    // With bodies in contact, ILU(1) in 3D too: ILU(0) of the contact rows
    // between a stiff boulder and sand could not solve 40 of 52 steps of a
    // 3D landslide (each then solved by LU at every iterate: 17 s), ILU(1)
    // solved them all (5 s; kept LU: 8.4 s; docs/contact.md#bodies-in-contact).
    // With domain quadrature in 2D, ILU(0): its 7 x 7 block rows hold the
    // coupling ILU(1) adds to the 5 x 5 rows of point quadrature (measured on
    // the reference column: 2,108 Newton iterations against 2,079, no LU
    // fallback, a third less time in the linear solves;
    // docs/grid.md#particle-quadrature). ILU(0) in 2D above
    // -talus_ilu_fill_limit unknowns too (default_ilu_fill_limit).
    const bool point_2d = dim == 2 && quadrature_ == ParticleQuadrature::point && unknowns <= ilu_fill_limit_;
    const PetscInt levels = point_2d || velocity_fields_ > 1 ? 1 : 0;
    if (starts_on_multigrid(unknowns)) {  // quasi-static, above the LU fallback (docs/solver.md#geometric-multigrid)
      TALUS_PETSC(PCSetType(pc, PCMG));
    } else if (point_block) {
      // The 3D operator of one velocity field: point-block Jacobi, from the
      // Jacobian's diagonal blocks alone (docs/solver.md#point-block-jacobi).
      // It needs 2-3 times the Krylov iterations of ILU(0), but neither the
      // 125-block rows nor their factors, which cost 20-25 products each: on
      // 3D landslides 2.3-2.5 times less CPU, on the 128,000-particle column
      // 1.3 times. Its solves take more iterations: up to 500 (below).
      TALUS_PETSC(PCSetType(pc, PCPBJACOBI));
    } else if (size == 1) {
      TALUS_PETSC(PCSetType(pc, PCILU));
      TALUS_PETSC(PCFactorSetLevels(pc, levels));
    } else {
      TALUS_PETSC(PCSetType(pc, PCBJACOBI));
      default_block_option("sub_pc_factor_levels", std::to_string(levels));
    }
    set_right_gmres(ksp, 1e-8, 50);
    set_inexact_newton(snes_);
  } else {
    set_right_gmres(ksp, 1e-11, 500);
    TALUS_PETSC(PCSetType(pc, PCGAMG));
  }
  TALUS_PETSC(SNESSetFromOptions(snes_));
  guard_superlu_ilu(pc);
  {
    // (Point-block) Jacobi, by default or by option, needs 2-3 times the
    // Krylov iterations of factors: its solves fail after 500, not 50
    // (docs/solver.md#point-block-jacobi), unless the limit is an option.
    PetscBool diagonal = PETSC_FALSE, limit_given = PETSC_FALSE;
    TALUS_PETSC(PetscObjectTypeCompareAny(reinterpret_cast<PetscObject>(pc), &diagonal, PCPBJACOBI, PCJACOBI, ""));
    TALUS_PETSC(PetscOptionsHasName(nullptr, "talus_", "-ksp_max_it", &limit_given));
    if (diagonal && !limit_given && unknowns <= direct_limit_)
      TALUS_PETSC(KSPSetTolerances(ksp, PETSC_DEFAULT, PETSC_DEFAULT, PETSC_DEFAULT, 500));
  }
  {
    // Right preconditioning is talus's choice for GMRES; a Krylov method
    // asked for by option that has no right-preconditioned form (CG, MINRES,
    // ...) gets its own default side instead of a PETSc error at the first
    // solve, unless the side is an option too.
    PetscBool gmres = PETSC_FALSE, side_given = PETSC_FALSE;
    TALUS_PETSC(PetscObjectTypeCompareAny(reinterpret_cast<PetscObject>(ksp), &gmres, KSPGMRES, KSPFGMRES,
                                          KSPLGMRES, KSPDGMRES, KSPPGMRES, KSPBCGS, KSPIBCGS, KSPFBCGS, KSPFBCGSR,
                                          KSPBCGSL, KSPPREONLY, ""));
    TALUS_PETSC(PetscOptionsHasName(nullptr, "talus_", "-ksp_pc_side", &side_given));
    if (!gmres && !side_given) TALUS_PETSC(KSPSetPCSide(ksp, PC_SIDE_DEFAULT));
  }
  PetscBool accelerated = PETSC_FALSE;
  TALUS_PETSC(PetscObjectTypeCompareAny(reinterpret_cast<PetscObject>(snes_), &accelerated, SNESNGMRES,
                                        SNESANDERSON, ""));
  if (accelerated) {
    // The inner Newton step (prefix talus_npc_): one iteration, full step,
    // an inexact right-preconditioned GMRES solve (relative 1e-5: the outer
    // iteration corrects it) with ILU, or GAMG above the direct limit.
    SNES newton;
    TALUS_PETSC(SNESGetNPC(snes_, &newton));
    set_newton(newton, 1, SNESLINESEARCHBASIC);
    KSP inner;
    PC inner_pc;
    TALUS_PETSC(SNESGetKSP(newton, &inner));
    TALUS_PETSC(KSPGetPC(inner, &inner_pc));
    set_right_gmres(inner, 1e-5, 200);
    int size = 1;
    MPI_Comm_size(comm_, &size);
    TALUS_PETSC(PCSetType(inner_pc, unknowns <= direct_limit_ ? (size > 1 ? PCBJACOBI : PCILU) : PCGAMG));
    TALUS_PETSC(SNESSetFromOptions(newton));
  }
  // After the options: nobody replaces the physical test.
  TALUS_PETSC(SNESSetConvergenceTest(snes_, physical_convergence<dim>, &scale_, nullptr));
  // Reused factorizations wherever an LU preconditions a Krylov method of the
  // outer line-search Newton (not under preonly, where stale factors would
  // change the Newton direction, nor inside a nonlinear preconditioner).
  // Line-search Newton only: the trust region takes the stale solve's
  // direction as it is and stalls on it.
  PetscBool preonly = PETSC_FALSE, line_search = PETSC_FALSE;
  TALUS_PETSC(PetscObjectTypeCompare(reinterpret_cast<PetscObject>(ksp), KSPPREONLY, &preonly));
  TALUS_PETSC(PetscObjectTypeCompare(reinterpret_cast<PetscObject>(snes_), SNESNEWTONLS, &line_search));
  factorization_.reused_mode = line_search && !preonly && (solves_by_factors() || solves_by_multigrid());
  PetscBool ksp_chosen = PETSC_FALSE;
  TALUS_PETSC(PetscOptionsHasName(nullptr, "talus_", "-ksp_type", &ksp_chosen));
  // Without reuse the factors are always fresh and GMRES over them is one
  // iteration of overhead: a plain LU solve, unless GMRES was asked for.
  if (!factorization_.reused_mode && !accelerated && solves_by_lu() && !ksp_chosen)
    TALUS_PETSC(KSPSetType(ksp, KSPPREONLY));
}

template void NewtonSolver<2>::configure_direct(KSP);
template void NewtonSolver<3>::configure_direct(KSP);
template void NewtonSolver<2>::configure(PetscInt, bool);
template void NewtonSolver<3>::configure(PetscInt, bool);

}  // namespace talus
