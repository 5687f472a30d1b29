#include "talus/solver/newton.hpp"

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

void set_if_absent(const char* name, const char* value) {
  PetscBool set = PETSC_FALSE;
  TALUS_PETSC(PetscOptionsHasName(nullptr, nullptr, name, &set));
  if (!set) TALUS_PETSC(PetscOptionsSetValue(nullptr, name, value));
}

}  // namespace

void set_default_solver_options(MPI_Comm comm) {
  set_if_absent("-talus_snes_type", "newtonls");
  set_if_absent("-talus_snes_linesearch_type", "basic");
  set_if_absent("-talus_snes_rtol", "1e-10");
  set_if_absent("-talus_snes_stol", "0");
  set_if_absent("-talus_snes_max_it", "25");
  set_if_absent("-talus_ksp_type", "preonly");
  set_if_absent("-talus_pc_type", "lu");
  // PETSc's own LU is the fastest for small serial systems; MUMPS factors in parallel.
  int size = 1;
  MPI_Comm_size(comm, &size);
  set_if_absent("-talus_pc_factor_mat_solver_type", size > 1 ? "mumps" : "petsc");
}

template <int dim>
NewtonSolver<dim>::NewtonSolver(MPI_Comm comm) {
  set_default_solver_options(comm);
  PetscBool set = PETSC_FALSE;
  TALUS_PETSC(PetscOptionsHasName(nullptr, nullptr, "-talus_snes_atol", &set));
  user_atol_ = set;
  comm_ = comm;
}

template <int dim>
NewtonSolver<dim>::~NewtonSolver() {
  SNESDestroy(&snes_);
}

template <int dim>
NewtonReport NewtonSolver<dim>::solve(MomentumSystem<dim>& system) {
  NewtonReport report;
  Vec v = system.initial_guess();
  Vec F;
  TALUS_PETSC(VecDuplicate(v, &F));
  Mat J = system.create_matrix();
  // The unknowns change every step, so each step gets a fresh SNES (SNESReset
  // leaves stale sizes inside some preconditioners, e.g. GAMG's coarse solver).
  TALUS_PETSC(SNESDestroy(&snes_));
  TALUS_PETSC(SNESCreate(comm_, &snes_));
  TALUS_PETSC(SNESSetOptionsPrefix(snes_, "talus_"));
  TALUS_PETSC(SNESSetFromOptions(snes_));
  TALUS_PETSC(SNESSetFunction(snes_, F, form_residual<dim>, &system));
  TALUS_PETSC(SNESSetJacobian(snes_, J, J, form_jacobian<dim>, &system));
  if (!user_atol_) {
    // Absolute tolerance in momentum units: 1e-12 of the step's momentum scale.
    TALUS_PETSC(SNESSetTolerances(snes_, 1e-12 * system.momentum_scale() + 1e-300, PETSC_DEFAULT, PETSC_DEFAULT,
                                  PETSC_DEFAULT, PETSC_DEFAULT));
  }
  TALUS_PETSC(SNESSolve(snes_, nullptr, v));
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
