#pragma once
// Newton's method for one implicit step, by PETSc SNES with the assembled
// Jacobian and a KSP, all under the options prefix "talus_" (docs/solver.md).
#include <petscsnes.h>

#include <string>
#include <vector>

#include "talus/solver/momentum_system.hpp"

namespace talus {

struct NewtonReport {
  bool converged = false;
  PetscInt iterations = 0;
  PetscInt linear_iterations = 0;
  std::string reason;
  std::vector<double> residual_norms;  // ||F|| at every Newton iterate, the initial guess first
};

template <int dim>
class NewtonSolver {
 public:
  // direct_limit: largest number of unknowns solved by LU by default; larger
  // systems default to GMRES + GAMG.
  NewtonSolver(MPI_Comm comm, PetscInt direct_limit);
  ~NewtonSolver();
  NewtonSolver(const NewtonSolver&) = delete;
  NewtonSolver& operator=(const NewtonSolver&) = delete;

  // Solves F(v) = 0; on success the system holds v^{n+1} (MomentumSystem::finish).
  NewtonReport solve(MomentumSystem<dim>& system);

 private:
  // Default solver (newtonls with full steps, rtol 1e-10, stol 0, 25
  // iterations; direct LU, PETSc's on one rank, MUMPS on several, or
  // GMRES + GAMG above direct_limit unknowns), then the options database
  // under the prefix talus_.
  void configure(double absolute_tolerance, PetscInt unknowns);
  MatType matrix_type() const;  // for the preconditioner configure() set up

  MPI_Comm comm_;
  PetscInt direct_limit_;
  SNES snes_ = nullptr;
};

}  // namespace talus
