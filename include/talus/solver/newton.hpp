#pragma once
// Newton's method for one implicit step, by PETSc SNES with the assembled
// Jacobian and a KSP, all under the options prefix "talus_" (docs/solver.md).
//
// Convergence is judged in physical units (docs/solver.md#convergence): the
// step is solved when the total unbalanced impulse is a small fraction of
// the step's impulse scale,
//
//   U = sum_i |F_i|_1 / S <= balance_tolerance,   S = sum_i m_i (|v_i^n| + h |g|),
//
// never on the ratio to the first residual. A linear solve that did not
// converge fails the Newton iteration; the step is then solved again with a
// direct LU factorization before it counts as failed (cut-back). A Newton
// iteration that has stopped reducing U (no new minimum for a few
// iterations: it cycles between branches) fails the step at once.
//
// The SNES, the matrix, its preallocation and the KSP/PC (with a symbolic
// factorization or an ILU/AMG structure) live across steps and are rebuilt
// only when the unknowns (the active set) change.
//
// Below the direct limit the Newton systems are solved by GMRES
// preconditioned with the LU factorization of an earlier Newton iterate
// (docs/solver.md#reused-factorizations): the matrix is factored again only
// when the stale factors no longer solve the system in a few Krylov
// iterations, so most Newton iterations cost triangular solves instead of a
// factorization.
#include <petscsnes.h>

#include <chrono>
#include <string>
#include <map>
#include <vector>

#include "talus/solver/momentum_system.hpp"
#include "talus/solver/multigrid.hpp"

namespace talus {

struct NewtonReport {
  bool converged = false;
  PetscInt iterations = 0;
  PetscInt linear_iterations = 0;
  std::string reason;
  std::vector<double> residual_norms;  // ||F||_2 at every Newton iterate, the initial guess first
  std::vector<double> unbalances;      // U at every Newton iterate of the last attempt, the initial guess first
  double unbalance = 0.0;              // U at the last iterate (docs/solver.md#convergence)
  double time_error = 0.0;             // E at the last iterate (docs/solver.md#the-tolerance-follows-the-time-error)
  double tolerance = 0.0;              // the bound U was held to: max(balance_tolerance, min(fraction E, 1e-4))
  bool structure_built = false;        // matrix and KSP/PC built for this step (active set changed)
  bool direct_fallback = false;        // a linear solve failed and the step was solved again by LU
  bool multigrid_fallback = false;     // ... above the LU's limit: solved again on geometric multigrid
  long linear_failures = 0;            // linear solves that did not converge (the step is judged on U alone)
  long factorizations = 0;             // numeric LU factorizations in this step (reused-factorization mode)
  long jacobian_matrices = 0;          // Jacobian matrices assembled (with the operator: only for factors)
  long block_diagonals = 0;            // the Jacobian's diagonal blocks alone (point-block Jacobi of the operator)
  double linear_seconds = 0.0;         // in KSPSolve (preconditioner set-up, factorizations and products included)
  long fresh_resolves = 0;             // Newton systems solved again on fresh factors after stale ones failed
  bool line_search_retry = false;      // a step with rigid bodies failed with bt and was solved again with l2
  bool regularized_retry = false;      // ... and failed again: solved with the regularized Jacobian
  bool predictor_retry = false;        // Newton failed from one predictor and the step was solved from the other
};

template <int dim>
class NewtonSolver {
 public:
  // direct_limit: largest number of unknowns solved by LU by default; larger
  // systems default to the Krylov solver (docs/solver.md#defaults).
  // balance_tolerance: the bound on U above.
  // velocity_fields: bodies in contact (docs/contact.md#bodies-in-contact)
  // make the 3D incomplete factors one level deeper.
  NewtonSolver(MPI_Comm comm, PetscInt direct_limit, double balance_tolerance, int velocity_fields = 1,
               ParticleQuadrature quadrature = ParticleQuadrature::point);
  ~NewtonSolver();
  NewtonSolver(const NewtonSolver&) = delete;
  NewtonSolver& operator=(const NewtonSolver&) = delete;

  // Before anything is written: configures a throwaway solver below and
  // above the direct limit in a copy of the options database and returns
  // the -talus_ options (names without the dash) that no configuration read
  // (misspelled, e.g. talus_snes_monitr); throws InputError naming an option
  // whose value PETSc refused. Options read only at set-up (block and
  // multigrid sub-solvers, viewers, the LU fallback) are left to the warning
  // after the first step (docs/command_line.md#petsc-options).
  // The rehearsal also solves a small system with each configuration that
  // can occur: the one above direct_limit only if max_unknowns (a bound on
  // the case's unknowns) exceeds it. A PETSc error there is an InputError
  // naming the option.
  // `where`: for options from the case file, key (without talus_) -> where
  // the file sets it, named in the error.
  static std::vector<std::string> options_read_by_no_configuration(
      MPI_Comm comm, PetscInt direct_limit, double max_unknowns = 1e300,
      const std::map<std::string, std::string>* where = nullptr);

  // Solves F(v) = 0; on success the system holds v^{n+1} (MomentumSystem::finish).
  NewtonReport solve(MomentumSystem<dim>& system);

  // false: build the SNES, matrix and preconditioner for every step (for tests
  // comparing against reuse).
  void set_structure_reuse(bool reuse) { reuse_ = reuse; }
  long structure_builds() const { return builds_; }  // since construction

  // The convergence test's view of the current step (used by the SNES callback).
  struct Scale {
    double impulse = 1.0;    // S
    double tolerance = 0.0;  // balance_tolerance
    double unbalance = 0.0;  // U of the last tested iterate
    PetscInt stagnation_window = 0;  // > 0: fail when U has had no new minimum for this many iterations
    double stagnation_decrease = 0.05;  // a new minimum is this fraction below the last one
    double best = 0.0;               // smallest U of the current SNESSolve
    PetscInt best_iteration = 0;     // where it was reached
    bool stagnated = false;          // the current step failed by stagnation
    std::vector<double> history;     // U at every iterate of the current SNESSolve
    const long* linear_failures = nullptr;  // failed linear solves of the current SNESSolve: diverged
    // The step's own time error (docs/solver.md#the-tolerance-follows-the-time-error):
    // U may be as large as time_fraction times E = (1/2) sum_k w_k |v_k - p_k| / S,
    // the backward-Euler local error estimated from the distance of the iterate
    // v to the last step's acceleration continued, p, with the points'
    // masses as weights w (zero where there is no last acceleration).
    double time_fraction = 0.0;
    Vec predictor = nullptr, weights = nullptr, work = nullptr;  // set for one SNESSolve
    double time_error = 0.0;  // E at the last tested iterate
    double time_cap = 0.0;        // the largest time_fraction E taken
    double step_tolerance = 0.0;  // max(tolerance, min(time_fraction E, time_cap)) at the last tested iterate
  };

  // The reused LU factorization (used by the Jacobian and KSP callbacks).
  struct Factorization {
    bool reused_mode = false;  // LU preconditioning a Krylov method: factors may be kept
    bool refactor = true;      // factor the matrix at the next Jacobian
    bool fresh = false;        // the factors in use were computed from the current Jacobian
    bool resolve = false;      // the last solve on stale factors did not converge: solve it again, fresh
    long resolves = 0;         // since construction
    PetscInt stale_limit = 0;  // more Krylov iterations than this on stale factors: factor again
    long factorizations = 0;   // since construction
    // The current Jacobian is factored now: its factors are fresh and kept.
    // `counted`: factors (LU, ILU), not a Jacobi preconditioner's inverted
    // diagonal blocks.
    void factor_now(bool counted = true) {
      fresh = true;
      refactor = false;
      factorizations += counted;
    }
  };
  // Krylov iterations on stale LU factors above which the next Newton
  // iteration factors the matrix again (docs/solver.md#reused-factorizations).
  static constexpr PetscInt default_refactor_iterations = 30;
  // Newton iterations without a new smallest unbalance U (5 % below the last)
  // after which the step
  // fails (-talus_stagnation_iterations, 0: only the iteration limit;
  // docs/solver.md#stagnation).
  static constexpr PetscInt default_stagnation_iterations = 6;
  // U may reach this fraction of the step's estimated time error E, but no
  // more than time_tolerance_cap (-talus_balance_time_fraction; 0:
  // balance_tolerance only): the algebraic error a hundredth of the time
  // error (docs/solver.md#the-tolerance-follows-the-time-error).
  static constexpr double default_balance_time_fraction = 1e-2;
  static constexpr double time_tolerance_cap = 1e-4;
  // 2D (point quadrature, one velocity field): ILU(1) up to this many
  // unknowns, ILU(0) above (-talus_ilu_fill_limit). On large systems the
  // triangular solves are half of a Newton iteration, and ILU(0)'s cheaper
  // ones pay for its extra Krylov iterations (docs/solver.md#what-a-newton-iteration-costs);
  // the same size as the LU fallback's limit, below which ILU(1)'s robustness at
  // kinks (a fresh factor that fails costs an LU) is worth its fill.
  static constexpr PetscInt default_ilu_fill_limit = 20000;
  // Largest system (unknowns) whose step is solved again by LU after a failed
  // linear solve (-talus_direct_fallback_limit); larger ones are cut back.
  // In 2D an LU of 20,000 unknowns costs about a second, one of 51,000 (the
  // 1e5-particle column) several, and a fallback step takes up to 25 of
  // them; in 3D the fill makes 5,000 the affordable size.
  static constexpr PetscInt default_direct_fallback_limit = dim == 2 ? 20000 : 5000;
  // Coarsest level of the geometric multigrid, at most (-talus_mg_coarse_unknowns):
  // its LU costs about what one smoothing sweep of the fine level does.
  static constexpr PetscInt default_multigrid_coarse_unknowns = dim == 2 ? 4000 : 3000;
  long factorizations() const { return factorization_.factorizations; }  // since construction
  // The next step builds its structure anew (and factors its first
  // Jacobian): the grid was re-partitioned, or a checkpoint was written, from
  // which a restarted run starts with a new solver.
  void rebuild_next_step() { stale_structure_ = true; }
  // The cells a P-wave crosses in the coming step, h c_p / cell. Above
  // quasi_static_wave_cells the step is static for the linear solver: a
  // failed linear solve above the LU fallback's limit is solved again on
  // geometric multigrid (docs/solver.md#geometric-multigrid).
  // Such a step above that limit starts on the multigrid (the static
  // systems defeat the incomplete factors; -talus_multigrid_fallback no: it
  // does not, and is cut back when they fail).
  void set_wave_cells(double cells) { wave_cells_ = cells; }
  static constexpr double quasi_static_wave_cells = 100.0;
  // Point-block Jacobi is the 3D default below this many cells per step
  // (docs/solver.md#point-block-jacobi): measured better or equal to ILU(0)
  // up to 27 cells, worse from 41.
  static constexpr double point_block_wave_cells = 30.0;
  bool starts_on_multigrid(PetscInt unknowns) const {
    return multigrid_fallback_ && wave_cells_ >= quasi_static_wave_cells && unknowns > fallback_limit_;
  }

  // What the SNES callbacks see.
  struct CallbackContext {
    MomentumSystem<dim>* system = nullptr;
    Factorization* factorization = nullptr;
    long* linear_failures = nullptr;
    // The Krylov method multiplies by the particle operator
    // (MomentumSystem::apply_jacobian) and the matrix is assembled only when
    // its factors are computed (docs/solver.md#the-jacobian-as-an-operator).
    bool jacobian_operator = false;
    // With the operator, the preconditioner's matrix holds the Jacobian's
    // diagonal blocks only (point-block Jacobi).
    bool block_diagonal = false;
    void assemble_preconditioner(Vec v, Mat P) {
      if (block_diagonal) {
        system->jacobian_block_diagonal(v, P);
        ++block_diagonals;
      } else {
        system->jacobian(v, P);
        ++assembled;
      }
    }
    long assembled = 0;  // Jacobian matrices assembled (since construction)
    long block_diagonals = 0;  // block diagonals assembled instead (since construction)
    double linear_seconds = 0.0;  // in KSPSolve, since construction
    std::chrono::steady_clock::time_point linear_start;
    // The choice of the start left F(start) in `start_residual` (the SNES's
    // function vector) as the system's latest evaluation: SNES's first
    // residual, at `start` itself, is that one (one residual less per step).
    Vec start = nullptr, start_residual = nullptr;
    // Inexact Newton's first tolerance is chosen at the first Jacobian of a
    // solve: loose where a particle is plastic, tight where the step is linear.
    bool adaptive_first_tolerance = false;
  };

 private:
  // Default solver, then the options database under the prefix talus_.
  void configure(PetscInt unknowns, bool point_block = false);
  // Kept preconditioners would work on the particle operator (no rigid
  // bodies; -talus_jacobian, by default 27-point stencils).
  bool operator_expected(const MomentumSystem<dim>& system) const;
  bool point_block_default(const MomentumSystem<dim>& system) const;
  bool built_point_block_ = false;  // the structure was built with point_block_default()
  void configure_direct(KSP ksp);  // preonly + LU (PETSc's LU in serial, MUMPS in parallel)
  MatType matrix_type() const;     // for the preconditioner configure() set up
  SNES solving_snes() const;       // the SNES whose KSP solves the linear systems (inner Newton, if any)
  PC solving_pc() const;           // its preconditioner
  bool solving_pc_is(PCType type) const;
  bool solves_by_lu() const;
  bool solves_by_factors() const;  // LU or incomplete LU: factors that can be kept (reused mode)
  bool solves_by_multigrid() const;  // PCMG on the active set's levels, kept like factors
  void build_multigrid(const MomentumSystem<dim>& system);  // its levels, on the PCMG
  static std::vector<PetscInt> contact_rows(const MomentumSystem<dim>& system);  // held out of the coarse levels
  // The structure for the configured solver, or for a step solved again
  // after a failed linear solve (docs/solver.md#failed-linear-solves).
  enum class Fallback { none, direct, multigrid };
  void build(MomentumSystem<dim>& system, PetscInt unknowns, Fallback fallback);
  void configure_multigrid_fallback(const MomentumSystem<dim>& system);
  void destroy();
  bool same_unknowns(const MomentumSystem<dim>& system) const;
  // Newton's start (docs/solver.md#the-predictor): v^n + h g, v^n + h a_last,
  // or whichever of the two has the smaller residual.
  enum class Start { gravity, last, closer };
  NewtonReport run_snes(MomentumSystem<dim>& system, Start start);
  // The retry's outcome with the work of both attempts.
  static NewtonReport retried(const NewtonReport& first, NewtonReport retry);
  // A failed step with rigid bodies solved again: with the l2 line search,
  // then with a regularized Jacobian (newton_rigid_retry.cpp).
  NewtonReport retry_rigid(MomentumSystem<dim>& system, Start start, NewtonReport report);
  // A step whose linear solves failed, solved again by LU or on geometric
  // multigrid (newton_fallbacks.cpp, docs/solver.md#failed-linear-solves);
  // false if neither was tried.
  bool retry_linear_failure(MomentumSystem<dim>& system, PetscInt unknowns, Start start, NewtonReport& report);

  MPI_Comm comm_;
  PetscInt direct_limit_;
  int velocity_fields_ = 1;
  ParticleQuadrature quadrature_ = ParticleQuadrature::point;  // sets the default ILU fill (configure)
  PetscInt fallback_limit_ = 0;  // -talus_direct_fallback_limit
  PetscInt ilu_fill_limit_ = 0;  // -talus_ilu_fill_limit
  // Newton starts from v^n + h a with a the grid point's acceleration of the
  // last step (-talus_newton_predictor last, the default) or a = g (gravity).
  bool predict_last_acceleration_ = true;
  bool started_from_last_ = false;   // the last run_snes started from v^n + h a_last
  bool starts_differ_ = false;       // and that differs from v^n + h g
  bool reuse_ = true;
  bool stale_structure_ = false;
  long builds_ = 0;
  Scale scale_;
  bool primal_dual_ = true;  // -talus_newton_tangent (primal_dual_tangent.hpp)
  SNES snes_ = nullptr;
  Mat J_ = nullptr;
  Mat J_operator_ = nullptr;  // MATSHELL over MomentumSystem::apply_jacobian, or none
  std::string jacobian_choice_;  // -talus_jacobian: auto, matrix or operator
  Vec F_ = nullptr;
  bool fallback_structure_ = false;     // the current structure was built for a retry (LU or multigrid)
  bool multigrid_fallback_ = true;      // -talus_multigrid_fallback
  int multigrid_pause_ = 0;             // converged steps before the multigrid retry is tried again
  double wave_cells_ = 1e300;           // set_wave_cells (unknown: static)
  bool built_on_multigrid_ = false;     // the structure was built for starts_on_multigrid
  std::vector<int> unknown_points_;     // the active set the structure was built for (this rank)
  PetscInt unknown_count_ = -1;         // global
  long linear_failures_ = 0;            // of the current SNESSolve
  Factorization factorization_;
  CallbackContext context_;
  // -talus_pc_type mg: the levels of the active set (docs/solver.md#geometric-multigrid).
  GeometricMultigrid<dim> multigrid_;
  PetscInt multigrid_coarse_unknowns_ = 0;  // -talus_mg_coarse_unknowns
  std::vector<PetscInt> multigrid_held_;     // the contact rows its levels were built for
};

}  // namespace talus
