#include "talus/solver/newton.hpp"
#include "newton_convergence.hpp"
#include "newton_option_readers.hpp"
#include "talus/solver/petsc_options.hpp"

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <string>
#include <utility>
#include <vector>

namespace talus {

namespace {

template <int dim>
PetscErrorCode form_residual(SNES, Vec v, Vec F, void* ctx) {
  auto* context = static_cast<typename NewtonSolver<dim>::CallbackContext*>(ctx);
  const bool known = v == context->start && F == context->start_residual;
  context->start = context->start_residual = nullptr;  // only SNES's first evaluation
  if (known) return 0;
  return petsc_callback([&] { context->system->residual(v, F); });
}

// The Jacobian, and in reused-factorization mode the choice of whether its
// LU factors are computed: SNES reads its preconditioner lag after this
// callback, so lag -2 factors this Jacobian (and sets the lag to -1), and
// lag -1 keeps the factors of an earlier one for GMRES to precondition with.
//
// With the Jacobian as an operator (docs/solver.md#the-jacobian-as-an-operator)
// the Krylov method multiplies by the particle tangents at v, and the matrix
// P is assembled only when its factors are computed: kept factors
// precondition the exact operator, as they precondition the exact matrix.
template <int dim>
PetscErrorCode form_jacobian(SNES snes, Vec v, Mat J, Mat P, void* ctx) {
  auto* context = static_cast<typename NewtonSolver<dim>::CallbackContext*>(ctx);
  auto& factorization = *context->factorization;
  if (context->adaptive_first_tolerance)
    PetscCall(petsc_callback([&] { choose_first_tolerance(snes, context->system->plastic_particles()); }));
  // The linear solve follows this callback: its time runs from here to
  // record_linear_solve (not a KSP pre-solve hook: SNES's inexact Newton
  // sets its tolerance in that hook, and there is only one).
  struct StampAtReturn {
    typename NewtonSolver<dim>::CallbackContext* context;
    ~StampAtReturn() { context->linear_start = std::chrono::steady_clock::now(); }
  } stamp{context};
  if (!context->jacobian_operator) {
    PetscErrorCode ierr = petsc_callback([&] { context->system->jacobian(v, J); });
    if (ierr) return ierr;
    ++context->assembled;
    if (!factorization.reused_mode) return 0;
    factorization.fresh = false;
    if (factorization.refactor) factorization.factor_now();
    return SNESSetLagPreconditioner(snes, factorization.fresh ? -2 : -1);
  }
  factorization.fresh = false;
  // Point-block Jacobi's blocks cost about one product: fresh at every
  // iterate (kept like factors they saved 2-3 % and cost a cut-back on the
  // 3D landslide, docs/solver.md#point-block-jacobi).
  if (context->block_diagonal) factorization.refactor = true;
  PetscErrorCode ierr = petsc_callback([&] {
    context->system->prepare_operator(v);
    if (factorization.refactor) context->assemble_preconditioner(v, P);
  });
  if (ierr) return ierr;
  PetscCall(MatAssemblyBegin(J, MAT_FINAL_ASSEMBLY));  // the operator changed with v
  PetscCall(MatAssemblyEnd(J, MAT_FINAL_ASSEMBLY));
  if (factorization.refactor) factorization.factor_now(!context->block_diagonal);
  return SNESSetLagPreconditioner(snes, factorization.fresh ? -2 : -1);
}

// y = J x by the particle operator.
template <int dim>
PetscErrorCode operator_mult(Mat J, Vec x, Vec y) {
  void* ctx = nullptr;
  PetscCall(MatShellGetContext(J, &ctx));
  auto* context = static_cast<typename NewtonSolver<dim>::CallbackContext*>(ctx);
  return petsc_callback([&] { context->system->apply_jacobian(x, y); });
}

// After every linear solve: remember a KSP that did not converge. Not every
// SNES type checks (PETSc 3.18's trust region uses the unconverged direction
// as it is), so talus checks for all of them. On stale LU factors (reused-
// factorization mode) a slow solve makes the next Jacobian be factored
// again, and an unfinished one stops the SNES (its direction is not taken:
// a full step along it can land near another solution) and the step is
// solved again with fresh factors at every iterate (NewtonSolver::solve).
template <int dim>
PetscErrorCode record_linear_solve(KSP ksp, Vec, Vec, void* ctx) {
  auto* context = static_cast<typename NewtonSolver<dim>::CallbackContext*>(ctx);
  context->linear_seconds +=
      std::chrono::duration<double>(std::chrono::steady_clock::now() - context->linear_start).count();
  KSPConvergedReason reason;
  PetscErrorCode ierr = KSPGetConvergedReason(ksp, &reason);
  if (ierr) return ierr;
  PetscInt iterations = 0;
  ierr = KSPGetIterationNumber(ksp, &iterations);
  if (ierr) return ierr;
  auto& factorization = *context->factorization;
  if (factorization.reused_mode && !factorization.fresh) {
    if (reason < 0 || iterations > factorization.stale_limit) factorization.refactor = true;
    if (reason < 0) factorization.resolve = true;  // solved again on fresh factors before the line search
    return 0;
  }
  if (reason < 0) ++*context->linear_failures;
  return 0;
}

// Before the line search of a Newton iteration whose solve on stale LU factors
// did not converge: factor the current Jacobian and solve the same system
// again, so the iteration goes on along the fresh-LU direction instead of
// restarting the whole step (docs/solver.md#reused-factorizations). The
// fresh factors are then kept for the following iterations. A fresh solve
// that fails counts as a failed linear solve (the convergence test stops the
// SNES after this iteration; its update is discarded with the step).
template <int dim>
PetscErrorCode resolve_on_fresh_factors(SNESLineSearch line_search, Vec x, Vec direction, PetscBool* changed,
                                        void* ctx) {
  *changed = PETSC_FALSE;
  auto* context = static_cast<typename NewtonSolver<dim>::CallbackContext*>(ctx);
  auto& factorization = *context->factorization;
  if (!factorization.resolve) return 0;
  factorization.resolve = false;
  SNES snes;
  KSP ksp;
  Vec F;
  PetscCall(SNESLineSearchGetSNES(line_search, &snes));
  PetscCall(SNESGetKSP(snes, &ksp));
  PetscCall(SNESGetFunction(snes, &F, nullptr, nullptr));
  if (context->jacobian_operator) {
    // The matrix of the factors, at this iterate (assembled only for factors).
    Mat J, P;
    PetscCall(SNESGetJacobian(snes, &J, &P, nullptr, nullptr));
    PetscCall(petsc_callback([&] { context->assemble_preconditioner(x, P); }));
  }
  // The PC's matrix changed since its factors were computed, so PCSetUp
  // factors it again once reuse is off.
  PetscCall(KSPSetReusePreconditioner(ksp, PETSC_FALSE));
  factorization.factor_now(!context->block_diagonal);
  ++factorization.resolves;
  context->linear_start = std::chrono::steady_clock::now();
  PetscCall(KSPSolve(ksp, F, direction));  // counted in KSPGetTotalIterations
  // Keep these factors for the next Jacobians (SNES sets the flag again at
  // every Jacobian from its lag; -1 means reuse).
  PetscCall(KSPSetReusePreconditioner(ksp, PETSC_TRUE));
  *changed = PETSC_TRUE;
  return 0;
}

}  // namespace

// The report of a step solved again: the retry's outcome, with the work of
// both attempts.
template <int dim>
NewtonReport NewtonSolver<dim>::retried(const NewtonReport& first, NewtonReport retry) {
  retry.iterations += first.iterations;
  retry.linear_iterations += first.linear_iterations;
  retry.factorizations += first.factorizations;
  retry.jacobian_matrices += first.jacobian_matrices;
  retry.block_diagonals += first.block_diagonals;
  retry.linear_seconds += first.linear_seconds;
  retry.structure_built = first.structure_built;
  return retry;
}

template <int dim>
NewtonSolver<dim>::NewtonSolver(MPI_Comm comm, PetscInt direct_limit, double balance_tolerance, int velocity_fields,
                                ParticleQuadrature quadrature)
    : comm_(comm), direct_limit_(direct_limit), velocity_fields_(velocity_fields), quadrature_(quadrature) {
  scale_.tolerance = balance_tolerance;
  // Read once, before the run writes anything.
  factorization_.stale_limit = count_option("refactor_iterations", default_refactor_iterations);
  scale_.stagnation_window = count_option("stagnation_iterations", default_stagnation_iterations);
  scale_.time_fraction = real_option("balance_time_fraction", default_balance_time_fraction, 0.0, 1.0);
  scale_.time_cap = time_tolerance_cap;
  fallback_limit_ = count_option("direct_fallback_limit", default_direct_fallback_limit);
  primal_dual_ = choice_option("newton_tangent", {"primal_dual", "consistent"}) == "primal_dual";
  ilu_fill_limit_ = count_option("ilu_fill_limit", default_ilu_fill_limit);
  predict_last_acceleration_ = choice_option("newton_predictor", {"last", "gravity"}) == "last";
  jacobian_choice_ = choice_option("jacobian", {"auto", "matrix", "operator"});
  multigrid_coarse_unknowns_ = count_option("mg_coarse_unknowns", default_multigrid_coarse_unknowns);
  multigrid_fallback_ = choice_option("multigrid_fallback", {"yes", "no"}) == "yes";
  check_petsc_options(comm);
}

template <int dim>
NewtonSolver<dim>::~NewtonSolver() {
  destroy();
}

template <int dim>
void NewtonSolver<dim>::destroy() {
  SNESDestroy(&snes_);
  MatDestroy(&J_);
  MatDestroy(&J_operator_);
  VecDestroy(&F_);
  unknown_points_.clear();
  unknown_count_ = -1;
}

// Block AIJ (BAIJ, blocks of dim x dim) for PETSc's own (incomplete) LU or
// MUMPS, which factor it with block kernels: 1.3-1.7x faster factorization
// and assembly than AIJ (docs/benchmarks.md). AIJ for everything else: GAMG,
// SuperLU, UMFPACK and KLU do not take BAIJ.
template <int dim>
MatType NewtonSolver<dim>::matrix_type() const {
  PC pc = solving_pc();
  if (!solves_by_factors()) return MATAIJ;
  // Incomplete LU (also in block Jacobi's blocks) is PETSc's own, with block
  // kernels on BAIJ, unless another package is named (SuperLU's ILUTP).
  if (solving_pc_is(PCPBJACOBI) || solving_pc_is(PCJACOBI)) return MATBAIJ;
  MatSolverType package = nullptr;
  if (!solving_pc_is(PCBJACOBI)) TALUS_PETSC(PCFactorGetMatSolverType(pc, &package));
  if (!solves_by_lu()) return package == nullptr || std::strcmp(package, MATSOLVERPETSC) == 0 ? MATBAIJ : MATAIJ;
  // No package named (an LU forced above the direct limit): PETSc picks one
  // when it factors, so stay with AIJ, which every package takes.
  const bool blocks =
      package != nullptr && (std::strcmp(package, MATSOLVERPETSC) == 0 || std::strcmp(package, MATSOLVERMUMPS) == 0);
  return blocks ? MATBAIJ : MATAIJ;
}

template <int dim>
SNES NewtonSolver<dim>::solving_snes() const {
  // With an inner Newton step, its KSP does the linear solves.
  PetscBool has_inner = PETSC_FALSE;
  TALUS_PETSC(SNESHasNPC(snes_, &has_inner));
  if (!has_inner) return snes_;
  SNES inner;
  TALUS_PETSC(SNESGetNPC(snes_, &inner));
  return inner;
}

template <int dim>
PC NewtonSolver<dim>::solving_pc() const {
  KSP ksp;
  PC pc;
  TALUS_PETSC(SNESGetKSP(solving_snes(), &ksp));
  TALUS_PETSC(KSPGetPC(ksp, &pc));
  return pc;
}

template <int dim>
bool NewtonSolver<dim>::solves_by_factors() const {
  // Block Jacobi factors its blocks (ILU by default): kept in the same way,
  // as are (point-block) Jacobi's inverted diagonals.
  PetscBool factors = PETSC_FALSE;
  TALUS_PETSC(
      PetscObjectTypeCompareAny(reinterpret_cast<PetscObject>(solving_pc()), &factors, PCLU, PCILU, PCBJACOBI,
                                                 PCPBJACOBI, PCJACOBI, ""));
  return factors;
}

template <int dim>
bool NewtonSolver<dim>::solves_by_lu() const {
  return solving_pc_is(PCLU);
}

template <int dim>
bool NewtonSolver<dim>::same_unknowns(const MomentumSystem<dim>& system) const {
  // The unknowns, their numbering, their constraints and the sparsity pattern
  // are functions of the active points alone (the pattern couples every pair
  // of active points within the shape functions' reach), so an identical
  // active set on every rank means an identical system structure.
  // Rigid bodies' rows couple with contact points that change with the same
  // active set: their systems are always built anew.
  const PetscInt count = system.active().global_count();
  int same = snes_ && reuse_ && !fallback_structure_ && !stale_structure_ && unknown_count_ == count &&
             unknown_points_ == system.active().owned_points() && system.rigid_bodies().empty() &&
             built_on_multigrid_ == starts_on_multigrid(count * dim) &&
             built_point_block_ == point_block_default(system) &&
             (!solves_by_multigrid() || multigrid_held_ == contact_rows(system));
  int all = 0;
  MPI_Allreduce(&same, &all, 1, MPI_INT, MPI_MIN, comm_);
  return all == 1;
}

template <int dim>
void NewtonSolver<dim>::build(MomentumSystem<dim>& system, PetscInt unknowns, Fallback fallback) {
  destroy();
  ++builds_;
  stale_structure_ = false;
  // A fresh SNES (SNESReset leaves stale sizes inside some preconditioners,
  // e.g. GAMG's coarse solver).
  TALUS_PETSC(SNESCreate(comm_, &snes_));
  fallback_structure_ = fallback != Fallback::none;
  built_on_multigrid_ = starts_on_multigrid(unknowns);
  built_point_block_ = false;
  factorization_.reused_mode = false;
  factorization_.refactor = true;
  if (fallback == Fallback::multigrid) {
    configure_multigrid_fallback(system);
  } else if (fallback == Fallback::direct) {
    // The fallback after a failed linear solve: Newton with the default
    // line search and LU factors, whatever the options say. The factors are
    // kept across the step's Newton iterations under GMRES, like the
    // default's incomplete ones, and computed again only when a solve on
    // them needs more than -talus_refactor_iterations Krylov iterations: a
    // fresh LU at every iterate cost the 12,800-particle column a fifth of
    // its CPU time. Every solve to 1e-8, as the fresh LU's were (not inexact
    // Newton: on a stiff rock sliding down an incline it cut the step back
    // 9 times against 6 with fresh LU and 2 with this; docs/solver.md#failed-linear-solves).
    TALUS_PETSC(SNESSetOptionsPrefix(snes_, "talus_fallback_"));
    set_newton(snes_, 25, SNESLINESEARCHBT);
    KSP ksp;
    TALUS_PETSC(SNESGetKSP(snes_, &ksp));
    configure_direct(ksp);
    set_right_gmres(ksp, 1e-8, 50);
    factorization_.reused_mode = true;
    TALUS_PETSC(SNESSetConvergenceTest(snes_, physical_convergence<dim>, &scale_, nullptr));
  } else {
    built_point_block_ = point_block_default(system);
    configure(unknowns, built_point_block_);
    if (solves_by_multigrid()) build_multigrid(system);
  }
  // The Jacobian as an operator where kept factors precondition a Krylov
  // method: by default (auto) with 27-point stencils (3D quadratic
  // B-splines), whose matrix costs about 25 operator products to assemble,
  // more than the Krylov iterations of a Newton step need; in 2D (9 points)
  // the matrix is cheaper than the products (docs/solver.md#the-jacobian-as-an-operator).
  // Rigid bodies' rows exist only in the assembled matrix.
  context_.jacobian_operator = factorization_.reused_mode && operator_expected(system);
  // Point-block Jacobi of the operator needs the diagonal blocks only
  // (docs/solver.md#point-block-jacobi), not the block rows.
  context_.block_diagonal = context_.jacobian_operator && (solving_pc_is(PCPBJACOBI) || solving_pc_is(PCJACOBI));
  J_ = context_.block_diagonal ? system.create_block_diagonal_matrix() : system.create_matrix(matrix_type());
  if (context_.jacobian_operator) {
    PetscInt rows, columns, global_rows, global_columns;
    TALUS_PETSC(MatGetLocalSize(J_, &rows, &columns));
    TALUS_PETSC(MatGetSize(J_, &global_rows, &global_columns));
    TALUS_PETSC(MatCreateShell(comm_, rows, columns, global_rows, global_columns, &context_, &J_operator_));
    TALUS_PETSC(MatShellSetOperation(J_operator_, MATOP_MULT, reinterpret_cast<void (*)(void)>(operator_mult<dim>)));
  }
  Vec v = system.initial_guess();
  TALUS_PETSC(VecDuplicate(v, &F_));
  TALUS_PETSC(VecDestroy(&v));
  unknown_points_ = system.active().owned_points();
  unknown_count_ = system.active().global_count();
}

// Point-block Jacobi by default where the Jacobian is a 3D operator of one
// velocity field in a step that a P-wave crosses in fewer than
// point_block_wave_cells cells (docs/solver.md#point-block-jacobi): with
// bodies in contact its blocks miss the stiff contact couplings (3D boulders
// in sand: 328 LU fallbacks where ILU(1) needs none), and the more cells a
// step spans, the further the Jacobian is from its mass-dominated diagonal
// (a quasi-static step is an elliptic problem).
template <int dim>
bool NewtonSolver<dim>::point_block_default(const MomentumSystem<dim>& system) const {
  return dim == 3 && velocity_fields_ == 1 && operator_expected(system) && wave_cells_ < point_block_wave_cells;
}

template <int dim>
bool NewtonSolver<dim>::operator_expected(const MomentumSystem<dim>& system) const {
  return system.rigid_bodies().empty() &&
         (jacobian_choice_ == "operator" || (jacobian_choice_ == "auto" && system.stencil_nodes() >= 27));
}

template <int dim>
NewtonReport NewtonSolver<dim>::run_snes(MomentumSystem<dim>& system, Start start) {
  system.set_primal_dual(primal_dual_);
  NewtonReport report;
  Vec v = system.initial_guess(false);
  started_from_last_ = starts_differ_ = false;
  if (start != Start::gravity) {
    // The last step's acceleration continued is the better start where the
    // motion is resolved in time (a collapse decelerating on its floor, a
    // steady flow); where it is not (an elastic block ringing faster than
    // h), it can start Newton far off. Start from whichever of the two
    // predictors is closer to balance (one residual more per step).
    Vec last = system.initial_guess(true);
    PetscBool same = PETSC_FALSE;
    TALUS_PETSC(VecEqual(v, last, &same));
    starts_differ_ = !same;
    if (!same && start == Start::last) {
      std::swap(v, last);
      started_from_last_ = true;
    } else if (!same) {
      PetscReal at_gravity = 0.0, at_last = 0.0;
      system.residual(v, F_);
      TALUS_PETSC(VecNorm(F_, NORM_2, &at_gravity));
      system.residual(last, F_);
      TALUS_PETSC(VecNorm(F_, NORM_2, &at_last));
      if (at_last < at_gravity) {
        std::swap(v, last);
        started_from_last_ = true;
        context_.start = v;  // F_ = F(v), the system's latest evaluation
        context_.start_residual = F_;
      }
    }
    TALUS_PETSC(VecDestroy(&last));
  }
  context_.system = &system;
  context_.factorization = &factorization_;
  context_.linear_failures = &linear_failures_;
  const long factorizations_before = factorization_.factorizations;
  const long assembled_before = context_.assembled;
  const long block_diagonals_before = context_.block_diagonals;
  const double linear_seconds_before = context_.linear_seconds;
  TALUS_PETSC(SNESSetFunction(snes_, F_, form_residual<dim>, &context_));
  TALUS_PETSC(SNESSetJacobian(snes_, context_.jacobian_operator ? J_operator_ : J_, J_, form_jacobian<dim>, &context_));
  std::vector<PetscReal> history(128);
  TALUS_PETSC(SNESSetConvergenceHistory(snes_, history.data(), nullptr, static_cast<PetscInt>(history.size()),
                                        PETSC_TRUE));
  KSP ksp;
  TALUS_PETSC(SNESGetKSP(solving_snes(), &ksp));
  linear_failures_ = 0;
  scale_.stagnated = false;
  scale_.history.clear();
  TALUS_PETSC(KSPSetPostSolve(ksp, record_linear_solve<dim>, &context_));
  scale_.linear_failures = &linear_failures_;
  const long resolves_before = factorization_.resolves;
  if (factorization_.reused_mode) {
    // A solve on stale factors that did not converge is solved again on
    // fresh ones before the line search, so SNES must not stop at it.
    SNESLineSearch line_search;
    TALUS_PETSC(SNESGetLineSearch(snes_, &line_search));
    TALUS_PETSC(SNESLineSearchSetPreCheck(line_search, resolve_on_fresh_factors<dim>, &context_));
    TALUS_PETSC(SNESSetMaxLinearSolveFailures(snes_, PETSC_MAX_INT));
  }
  begin_time_error(scale_, system);
  PetscInt linear_before = 0, linear_after = 0;
  TALUS_PETSC(KSPGetTotalIterations(ksp, &linear_before));
  context_.adaptive_first_tolerance = adaptive_first_tolerance(snes_);
  TALUS_PETSC(SNESSolve(snes_, nullptr, v));
  system.reset_carried_stresses();  // the next solve's first evaluation has none
  context_.start = context_.start_residual = nullptr;
  end_time_error(scale_);
  TALUS_PETSC(KSPGetTotalIterations(ksp, &linear_after));
  PetscInt recorded = 0;
  TALUS_PETSC(SNESGetConvergenceHistory(snes_, nullptr, nullptr, &recorded));
  report.residual_norms.assign(history.begin(), history.begin() + recorded);
  SNESConvergedReason reason;
  TALUS_PETSC(SNESGetConvergedReason(snes_, &reason));
  TALUS_PETSC(SNESGetIterationNumber(snes_, &report.iterations));
  report.linear_iterations = linear_after - linear_before;
  report.converged = reason > 0;
  report.reason = SNESConvergedReasons[reason];
  if (reason == SNES_DIVERGED_INNER) {
    // The inner Newton step failed: report why (a failed linear solve is
    // then retried by LU, like the outer one).
    SNESConvergedReason inner;
    TALUS_PETSC(SNESGetConvergedReason(solving_snes(), &inner));
    if (inner < 0) report.reason = SNESConvergedReasons[inner];
  }
  report.unbalance = scale_.unbalance;
  report.time_error = scale_.time_error;
  report.tolerance = scale_.step_tolerance;
  report.unbalances = scale_.history;
  report.linear_failures = linear_failures_;
  report.factorizations = factorization_.factorizations - factorizations_before;
  report.jacobian_matrices = context_.assembled - assembled_before;
  report.block_diagonals = context_.block_diagonals - block_diagonals_before;
  report.linear_seconds = context_.linear_seconds - linear_seconds_before;
  report.fresh_resolves = factorization_.resolves - resolves_before;
  if (!report.converged && scale_.stagnated) report.reason = "STAGNATED";
  if (!report.converged && linear_failures_ > 0) report.reason = SNESConvergedReasons[SNES_DIVERGED_LINEAR_SOLVE];
  if (report.converged) system.finish(v);
  TALUS_PETSC(VecDestroy(&v));
  return report;
}

template <int dim>
NewtonReport NewtonSolver<dim>::solve(MomentumSystem<dim>& system) {
  scale_.impulse = system.momentum_scale();
  if (!(scale_.impulse > 0.0)) scale_.impulse = 1e-300;
  scale_.unbalance = 0.0;
  const PetscInt unknowns = system.active().global_count() * dim;
  const bool built = !same_unknowns(system);
  if (built) build(system, unknowns, Fallback::none);
  const Start start = predict_last_acceleration_ ? Start::closer : Start::gravity;
  NewtonReport report = run_snes(system, start);
  report.structure_built = built;
  const bool retried_linear =
      !report.converged && report.linear_failures > 0 && retry_linear_failure(system, unknowns, start, report);
  if (!retried_linear && !report.converged && starts_differ_) {
    // Semismooth Newton can stall at a kink of the contact or plastic laws
    // from one start and not from another (a stiff block on a Coulomb
    // incline stalls at |F| = 5e-4 from the last acceleration, converges in
    // 4 iterations from free fall): try the other start before the step is
    // cut back.
    report = retried(report, run_snes(system, started_from_last_ ? Start::gravity : Start::last));
    report.predictor_retry = true;
  }
  if (!report.converged && !system.rigid_bodies().empty()) report = retry_rigid(system, start, report);
  if (report.converged && multigrid_pause_ > 0) --multigrid_pause_;
  return report;
}

template class NewtonSolver<2>;
template class NewtonSolver<3>;

}  // namespace talus
