#pragma once
// The Newton solver's convergence test in physical units (NewtonSolver's
// SNES convergence test, docs/solver.md#convergence-the-momentum-balance-in-physical-units).
#include <petscsnes.h>

#include <algorithm>
#include <cmath>

#include "talus/solver/newton.hpp"

namespace talus {

// The physical test (newton.hpp): U = ||F||_1 / S <= tolerance. F is in
// impulse units on every row (momentum rows, m_i v_i = 0 on constrained
// components, the natural map on contact rows), so ||F||_1 is the total
// unbalanced impulse of the step. Divergence: NaN, the iteration limit, or
// stagnation: no new smallest U for stagnation_window iterations. Full
// semismooth Newton steps that have stopped reducing U are cycling between
// branches of the return map or the cone (docs/solver.md#stagnation); they
// did not recover in our runs, so the step is cut back at once instead of
// after the iteration limit.
// The time-error estimate's vectors for one SNESSolve (Scale::predictor,
// weights, work), where the step has a last acceleration to continue.
template <int dim>
void begin_time_error(typename NewtonSolver<dim>::Scale& scale, const MomentumSystem<dim>& system) {
  scale.time_error = 0.0;
  if (!(scale.time_fraction > 0.0 && system.has_time_error_reference())) return;
  scale.predictor = system.time_error_predictor();
  scale.weights = system.time_error_weights();
  TALUS_PETSC(VecDuplicate(scale.predictor, &scale.work));
}

template <typename Scale>
void end_time_error(Scale& scale) {
  TALUS_PETSC(VecDestroy(&scale.predictor));
  TALUS_PETSC(VecDestroy(&scale.weights));
  TALUS_PETSC(VecDestroy(&scale.work));
}

template <int dim>
PetscErrorCode physical_convergence(SNES snes, PetscInt it, PetscReal, PetscReal, PetscReal fnorm,
                                    SNESConvergedReason* reason, void* ctx) {
  auto* scale = static_cast<typename NewtonSolver<dim>::Scale*>(ctx);
  *reason = SNES_CONVERGED_ITERATING;
  if (std::isnan(fnorm) || std::isinf(fnorm)) {
    *reason = SNES_DIVERGED_FNORM_NAN;
    return 0;
  }
  Vec F;
  PetscErrorCode ierr = SNESGetFunction(snes, &F, nullptr, nullptr);
  if (ierr) return ierr;
  PetscReal total = 0.0;
  ierr = VecNorm(F, NORM_1, &total);
  if (ierr) return ierr;
  scale->unbalance = total / scale->impulse;
  scale->step_tolerance = scale->tolerance;
  if (scale->predictor) {
    Vec v;
    ierr = SNESGetSolution(snes, &v);
    if (ierr) return ierr;
    ierr = VecWAXPY(scale->work, -1.0, scale->predictor, v);
    if (ierr) return ierr;
    ierr = VecPointwiseMult(scale->work, scale->work, scale->weights);
    if (ierr) return ierr;
    PetscReal distance = 0.0;
    ierr = VecNorm(scale->work, NORM_1, &distance);
    if (ierr) return ierr;
    scale->time_error = 0.5 * distance / scale->impulse;
    scale->step_tolerance =
        std::max(scale->tolerance, std::min(scale->time_fraction * scale->time_error, scale->time_cap));
  }
  PetscInt max_it = 0;
  ierr = SNESGetTolerances(snes, nullptr, nullptr, nullptr, &max_it, nullptr);
  if (ierr) return ierr;
  scale->history.push_back(scale->unbalance);
  // A new minimum must be a real one: U at least stagnation_decrease below
  // the last minimum. Semismooth Newton steps stalled at a kink creep down by
  // 1e-8-1e-2 per iteration under a line search that cuts them to 1e-6-1e-9
  // (3D landslide: four such steps ran 25 iterations each).
  if (it == 0 || scale->unbalance < (1.0 - scale->stagnation_decrease) * scale->best) {
    scale->best = scale->unbalance;
    scale->best_iteration = it;
  }
  if (scale->linear_failures && *scale->linear_failures > 0)
    *reason = SNES_DIVERGED_LINEAR_SOLVE;  // the iterate followed an unsolved system
  else if (scale->unbalance <= scale->step_tolerance)
    *reason = SNES_CONVERGED_FNORM_ABS;
  else if (it >= max_it)
    *reason = SNES_DIVERGED_MAX_IT;
  else if (scale->stagnation_window > 0 && it - scale->best_iteration >= scale->stagnation_window) {
    *reason = SNES_DIVERGED_DTOL;  // reported as "stagnated" (NewtonSolver::run_snes)
    scale->stagnated = true;
  }
  return 0;
}

}  // namespace talus
