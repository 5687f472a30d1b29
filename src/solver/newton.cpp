#include "talus/solver/newton.hpp"

#include <cstring>

namespace talus {

namespace {

template <int dim>
PetscErrorCode form_residual(SNES, Vec v, Vec F, void* ctx) {
  return petsc_callback([&] { static_cast<MomentumSystem<dim>*>(ctx)->residual(v, F); });
}

template <int dim>
PetscErrorCode form_jacobian(SNES, Vec v, Mat J, Mat, void* ctx) {
  return petsc_callback([&] { static_cast<MomentumSystem<dim>*>(ctx)->jacobian(v, J); });
}

}  // namespace

template <int dim>
NewtonSolver<dim>::NewtonSolver(MPI_Comm comm, PetscInt direct_limit) : comm_(comm), direct_limit_(direct_limit) {}

template <int dim>
NewtonSolver<dim>::~NewtonSolver() {
  SNESDestroy(&snes_);
}

template <int dim>
void NewtonSolver<dim>::configure(double absolute_tolerance, PetscInt unknowns) {
  // Defaults are set on the objects, then SNESSetFromOptions lets the options
  // database (command line, case file) override any of them.
  TALUS_PETSC(SNESSetOptionsPrefix(snes_, "talus_"));
  TALUS_PETSC(SNESSetType(snes_, SNESNEWTONLS));
  SNESLineSearch line_search;
  TALUS_PETSC(SNESGetLineSearch(snes_, &line_search));
  TALUS_PETSC(SNESLineSearchSetType(line_search, SNESLINESEARCHBASIC));
  TALUS_PETSC(SNESSetTolerances(snes_, absolute_tolerance, 1e-10, 0.0, 25, PETSC_DEFAULT));
  KSP ksp;
  PC pc;
  TALUS_PETSC(SNESGetKSP(snes_, &ksp));
  TALUS_PETSC(KSPGetPC(ksp, &pc));
  if (unknowns <= direct_limit_) {
    TALUS_PETSC(KSPSetType(ksp, KSPPREONLY));
    TALUS_PETSC(PCSetType(pc, PCLU));
    // PETSc's own LU is the fastest for small serial systems; MUMPS factors in parallel.
    int size = 1;
    MPI_Comm_size(comm_, &size);
    TALUS_PETSC(PCFactorSetMatSolverType(pc, size > 1 ? MATSOLVERMUMPS : MATSOLVERPETSC));
  } else {
    // Large systems: GMRES (the Jacobian is non-symmetric) with algebraic
    // multigrid; the linear tolerance sits below Newton's so that a linear
    // problem still converges in one Newton iteration.
    TALUS_PETSC(KSPSetType(ksp, KSPGMRES));
    TALUS_PETSC(KSPSetTolerances(ksp, 1e-11, PETSC_DEFAULT, PETSC_DEFAULT, 500));
    TALUS_PETSC(PCSetType(pc, PCGAMG));
  }
  TALUS_PETSC(SNESSetFromOptions(snes_));
}

// Block AIJ (BAIJ, blocks of dim x dim) for a direct solve by PETSc's own LU
// or MUMPS, which factor it with block kernels: 1.3-1.7x faster factorization
// and assembly than AIJ (docs/benchmarks.md). AIJ for everything else: GAMG,
// SuperLU, UMFPACK and KLU do not take BAIJ.
template <int dim>
MatType NewtonSolver<dim>::matrix_type() const {
  KSP ksp;
  PC pc;
  TALUS_PETSC(SNESGetKSP(snes_, &ksp));
  TALUS_PETSC(KSPGetPC(ksp, &pc));
  PetscBool lu = PETSC_FALSE;
  TALUS_PETSC(PetscObjectTypeCompare(reinterpret_cast<PetscObject>(pc), PCLU, &lu));
  if (!lu) return MATAIJ;
  MatSolverType package = nullptr;
  TALUS_PETSC(PCFactorGetMatSolverType(pc, &package));
  // No package named (an LU forced above the direct limit): PETSc picks one
  // when it factors, so stay with AIJ, which every package takes.
  const bool blocks =
      package != nullptr && (std::strcmp(package, MATSOLVERPETSC) == 0 || std::strcmp(package, MATSOLVERMUMPS) == 0);
  return blocks ? MATBAIJ : MATAIJ;
}

template <int dim>
NewtonReport NewtonSolver<dim>::solve(MomentumSystem<dim>& system) {
  NewtonReport report;
  Vec v = system.initial_guess();
  Vec F;
  TALUS_PETSC(VecDuplicate(v, &F));
  // The unknowns change every step, so each step gets a fresh SNES (SNESReset
  // leaves stale sizes inside some preconditioners, e.g. GAMG's coarse solver).
  TALUS_PETSC(SNESDestroy(&snes_));
  TALUS_PETSC(SNESCreate(comm_, &snes_));
  // Absolute tolerance in momentum units: 1e-12 of the step's momentum scale.
  PetscInt unknowns;
  TALUS_PETSC(VecGetSize(v, &unknowns));
  configure(1e-12 * system.momentum_scale() + 1e-300, unknowns);
  Mat J = system.create_matrix(matrix_type());
  TALUS_PETSC(SNESSetFunction(snes_, F, form_residual<dim>, &system));
  TALUS_PETSC(SNESSetJacobian(snes_, J, J, form_jacobian<dim>, &system));
  std::vector<PetscReal> history(64);
  TALUS_PETSC(SNESSetConvergenceHistory(snes_, history.data(), nullptr, static_cast<PetscInt>(history.size()),
                                        PETSC_TRUE));
  TALUS_PETSC(SNESSolve(snes_, nullptr, v));
  PetscInt recorded = 0;
  TALUS_PETSC(SNESGetConvergenceHistory(snes_, nullptr, nullptr, &recorded));
  report.residual_norms.assign(history.begin(), history.begin() + recorded);
  SNESConvergedReason reason;
  TALUS_PETSC(SNESGetConvergedReason(snes_, &reason));
  TALUS_PETSC(SNESGetIterationNumber(snes_, &report.iterations));
  TALUS_PETSC(SNESGetLinearSolveIterations(snes_, &report.linear_iterations));
  report.converged = reason > 0;
  report.reason = SNESConvergedReasons[reason];
  if (report.converged) system.finish(v);
  TALUS_PETSC(MatDestroy(&J));
  TALUS_PETSC(VecDestroy(&F));
  TALUS_PETSC(VecDestroy(&v));
  return report;
}

template class NewtonSolver<2>;
template class NewtonSolver<3>;

}  // namespace talus
