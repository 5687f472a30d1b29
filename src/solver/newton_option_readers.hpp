#pragma once
// Readers of talus's own solver options (-talus_<name>), read once before
// the run writes anything (defined in newton_options.cpp).
#include <petscsnes.h>

#include <cstddef>
#include <string>
#include <vector>

namespace talus {

// An integer in [0, 1e6]; `fallback` when not given.
PetscInt count_option(const char* name, PetscInt fallback);
// A real number in [lower, upper]; `fallback` when not given.
double real_option(const char* name, double fallback, double lower, double upper);
// One of `choices`, the first when not given.
std::string choice_option(const char* name, const std::vector<std::string>& choices);
// The default of an option of block Jacobi's blocks (-talus_<name>), whose
// PCs exist only after set-up: put in the options database, unless given
// there already or another PC is asked for (it would then stay unused).
void default_block_option(const char* name, const std::string& value);
// SuperLU's incomplete LU (-talus_pc_factor_mat_solver_type superlu under
// ILU) on a PETSc whose SuperLU lacks MC64 (Debian's) aborts the process
// when it permutes rows: default to NOROWPERM, and refuse MC64 by name.
void guard_superlu_ilu(PC pc);
// GMRES preconditioned on the right (its residual is the true one), to
// relative tolerance `rtol` in at most `max_it` iterations.
void set_right_gmres(KSP ksp, PetscReal rtol, PetscInt max_it);
// Inexact Newton (Eisenstat & Walker 1996, choice 2): the first solve of a
// step to 1e-8, so a linear step still takes one Newton iteration; later
// ones only as accurately as Newton is contracting,
//   eta_k = (||F_k|| / ||F_k-1||)^((1 + sqrt 5)/2),  at most 1e-2,
// so a line search that shortens the step to 10-50 % (large steps,
// docs/solver.md#large-steps) does not pay for a direction to 1e-8.
void set_inexact_newton(SNES snes);
// Inexact Newton with a first tolerance the options do not fix: the solver
// then chooses it at each solve's first Jacobian (choose_first_tolerance).
bool adaptive_first_tolerance(SNES snes);
// At a solve's first Jacobian: 1e-4 where a particle is plastic at the
// start (on any rank), 1e-8 where none is. A plastic step is nonlinear, and
// its first direction to 1e-8 only cost Krylov iterations and, through
// them, factorizations: a quarter of the 3D time loop at 128,000 particles.
// A linear step keeps its one Newton iteration (docs/solver.md#inexact-newton).
void choose_first_tolerance(SNES snes, std::size_t plastic_particles_here);
// Newton with a line search of `line_search_type`, at most max_it
// iterations, no PETSc tolerance (talus's own convergence test decides).
void set_newton(SNES snes, PetscInt max_it, SNESLineSearchType line_search_type);

}  // namespace talus
