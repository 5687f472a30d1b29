#pragma once
// One run of a case: the particles, the grid, and the implicit time step.
#include <chrono>
#include <iosfwd>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "talus/grid/partition.hpp"
#include "talus/io/checkpoint.hpp"
#include "talus/io/config.hpp"
#include "talus/io/run_directory.hpp"
#include "talus/io/vtk_output.hpp"
#include "talus/run_progress.hpp"
#include "talus/solver/newton.hpp"

namespace talus {

struct StepReport {
  bool converged = false;
  double h = 0;
  NewtonReport newton;
  PetscInt active_points = 0;     // global
  double transfer_seconds = 0;    // stencils + P2G + G2P
  double solve_seconds = 0;       // active set + Newton
  PetscInt contact_points = 0;    // global number of contact candidates
  PetscInt body_contact_points = 0;  // global number of points where two bodies touch
  PetscInt rigid_overlap_points = 0;  // global number of grid points where two rigid bodies are both active
  long ghost_cells = 0;           // global number of cells under the ghost penalty (docs/solver.md#ghost-penalty)
  double contact_seconds = 0;     // detection + natural-map rows (part of solve_seconds)
  // Parts of solve_seconds: the particles' stress updates and internal
  // forces, the Jacobian matrices' assembly, the linear solves (with their
  // factorizations and, in 3D, the operator products, also given alone).
  double material_seconds = 0, assembly_seconds = 0, linear_seconds = 0, operator_seconds = 0;
  // Global number of particles the converged step would invert, det(I + h grad v) <= 0
  // (the step is then not accepted; docs/solver.md#inverting-steps).
  long inverting_particles = 0;
  // Times the step was solved again because its material crossed an
  // obstacle at grid points that were not contact points
  // (docs/contact.md#which-grid-points-are-contact-points).
  long contact_resolves = 0;
};

// How a run ended: at time.end, on SIGINT/SIGTERM (after a step, with a
// checkpoint), or on an exception (Simulation::summary() then holds what it did).
enum class RunStatus { completed, interrupted, failed };

struct RunSummary {
  RunStatus status = RunStatus::completed;
  // The counts are of this run, from its start (t = 0, or the checkpoint it
  // restarted from); steps_before and cutbacks_before are those of the run up
  // to that checkpoint (0 from t = 0), so steps_before + steps counts the
  // accepted steps since t = 0, as checkpoint_<steps>.h5 and the progress line do.
  long steps = 0, cutbacks = 0, newton_iterations = 0, linear_iterations = 0, outputs = 0;
  long steps_before = 0, cutbacks_before = 0;
  double start_time = 0, time = 0, end_time = 0;  // s: the run's first and last time, and time.end
  int interrupted_by = 0;        // SIGINT or SIGTERM if the run stopped on a signal
  std::string last_checkpoint;   // empty if none was written
  long max_step_newton_iterations = 0;  // over the accepted steps (totals include failed attempts)
  double wall_seconds = 0, transfer_seconds = 0, solve_seconds = 0;
  double contact_seconds = 0;     // part of solve_seconds: candidates + contact rows
  double material_seconds = 0, assembly_seconds = 0, linear_seconds = 0, operator_seconds = 0;  // StepReport
  long contact_points = 0;        // summed over the accepted steps
  long body_contact_points = 0;   // summed over the accepted steps
  long ghost_cells = 0;           // summed over the accepted steps
  double max_unbalance = 0;       // largest U of an accepted step (docs/solver.md#convergence)
  double energy_balance_error = 0;  // J: K + G + E + the dissipated terms - (K0 + G0 + E0) (docs/energy.md)
  long structure_builds = 0;      // steps whose matrix and preconditioner structure was built anew
  long direct_fallbacks = 0;      // steps solved again by LU after a failed linear solve
  long multigrid_fallbacks = 0;   // ... above the LU's limit, solved again on geometric multigrid
  long inverting_cutbacks = 0;    // cut-backs of converged steps that would invert a particle (docs/solver.md#inverting-steps)
  long contact_resolves = 0;      // steps solved again with the contact points their material crossed (docs/contact.md)
  long factorizations = 0;        // numeric LU factorizations with reused factors (docs/solver.md#reused-factorizations)
  long jacobian_matrices = 0;     // Jacobian matrices assembled (docs/solver.md#the-jacobian-as-an-operator)
  long block_diagonals = 0;       // the Jacobian's diagonal blocks alone (docs/solver.md#point-block-jacobi)
  // Balanced ranks (docs/parallel.md): grid re-partitions during the run, the
  // largest max/mean particles per rank at the start of a step, and the
  // particles per rank at the end.
  long rebalances = 0;
  double worst_imbalance = 1.0;
  RankLoad final_load;
  // Per obstacle (docs/output.md#obstacle_forcescsv-the-force-on-each-obstacle):
  // the largest magnitude of the force averaged over output.force_window
  // since t = 0 (N/m in 2D, N in 3D) and the time it was reached.
  struct PeakLoad {
    std::string obstacle;
    double force = 0, time = 0;
  };
  std::vector<PeakLoad> peak_window_forces;
  double force_window = 0;  // s
  // The equilibrium stage before the run (docs/equilibrium.md), if any: its
  // steps and Newton iterations, the largest stress change of its last step
  // relative to the largest stress, and the work of gravity over the stage
  // (J, J/m in 2D).
  long equilibrium_steps = 0, equilibrium_newton_iterations = 0;
  double equilibrium_last_stress_change = 0, equilibrium_gravity_work = 0;
  double equilibrium_unbalance = 0;  // U at rest at the start of the stage's last step (docs/equilibrium.md)
};

template <int dim>
class Simulation {
 public:
  Simulation(const CaseConfig& config, MPI_Comm comm);

  // One step of size h, implicit or explicit (time.integrator). If Newton
  // does not converge the particles are left exactly as they were and
  // report.converged is false.
  StepReport advance(double h);

  // Runs to config.time.end with cut-backs; writes VTK output if enabled, and
  // HDF5 checkpoints (docs/checkpoints.md). A SIGINT or SIGTERM received
  // during the run ends it after the current step, with a checkpoint.
  // `progress` (rank 0's is used): the progress line as `options` say, and
  // the run's messages (cut-backs, warnings, checkpoints); nullptr: silent.
  RunSummary run(std::ostream* progress, const ProgressOptions& options = {});
  // The summary of the last run(), also when it threw (status failed).
  const RunSummary& summary() const { return summary_; }
  // After restart(): the output directory of the checkpoint's run.
  std::string continued_directory() const { return resume_ ? resume_->output_directory : std::string(); }

  // Continue from a checkpoint: particles, time, step control and output
  // series come from the file; run() then goes on to config.time.end.
  void restart(const std::string& checkpoint_path);

  // Re-partitions the grid on the particles (docs/parallel.md) if
  // parallel.balance is on, there are several ranks, and either `always` or
  // max/mean particles per rank exceeds parallel.imbalance_limit; only if that
  // lowers the largest rank's count by at least 5 %. Collective; returns
  // whether it re-partitioned. The constructor and restart() call it with
  // `always`, run() before every step. With `load`, stores there the
  // particles per rank after the call.
  bool balance_ranks(bool always, RankLoad* load = nullptr);
  long rebalances() const { return rebalances_; }
  // The energy balance (docs/energy.md): the terms summed since t = 0, the
  // particles' energies after the last step, K0 + G0 + E0, and the closing
  // error K + G + E + sum of the terms - (K0 + G0 + E0).
  const EnergyTerms& energy_terms() const { return energy_; }
  const ParticleEnergy& energies() const { return particle_energy_; }
  double initial_energy() const { return initial_energy_; }
  double energy_balance_error() const;

  double time() const { return time_; }
  const Grid<dim>& grid() const { return *grid_; }
  Particles<dim>& particles() { return *particles_; }

  // Introspection of the last step's system (tests and benchmarks).
  PetscInt last_system_size() const { return last_system_size_; }
  NewtonSolver<dim>& newton() { return *newton_; }

  // The rigid obstacles: the case's `obstacles`, then one half-plane per
  // frictional domain face (named x_min, ..., z_max).
  const std::vector<Obstacle<dim>>& obstacles() const { return obstacles_; }
  // Mean contact force on each obstacle over the last accepted step,
  // sum_i r_i / h (N, per unit thickness in 2D), summed over all ranks; the
  // force the body exerts on the obstacle is its negative.
  const std::vector<Vector<dim>>& obstacle_forces() const { return obstacle_force_; }
  // With bodies in contact (several velocity fields): the force of field f's
  // bodies on obstacle o at the last step, [o * fields + f], on the body as
  // obstacle_forces() (docs/output.md#obstacle_forcescsv-the-force-on-each-obstacle).
  const std::vector<Vector<dim>>& obstacle_forces_by_field() const { return obstacle_field_force_; }
  // The rigid-body motion of each body (all ranks; docs/output.md#bodiescsv):
  // centre of mass, its velocity (the mean velocity) and the angular velocity
  // omega = I^-1 sum_p m_p (x_p - X) x v_p about it (in 2D the scalar about
  // the out-of-plane axis), exact for a rigid motion.
  struct BodyMotion {
    Vector<dim> centre, velocity;
    Eigen::Vector3d angular_velocity;  // (0, 0, omega) in 2D
  };
  std::vector<BodyMotion> body_motion() const;
  std::vector<std::string> body_motion_columns() const;  // bodies.csv's columns after time
  std::vector<double> body_motion_row() const;           // collective
  // The loads on the obstacles since t = 0, on the obstacles (-obstacle_forces()):
  // impulses, their running totals, the window-averaged force and its peak.
  const ObstacleLoads& obstacle_loads() const { return loads_; }
  // Contact points of the last accepted step on this rank: position, force r_i / h.
  struct NodalContact {
    Vector<dim> position, force;
    int obstacle;
    ConeRegion region;
  };
  const std::vector<NodalContact>& nodal_contacts() const { return nodal_contacts_; }
  // With output.grid (docs/output.md#grid-points): the grid points carrying
  // mass that this rank owns, of the last accepted step (before the first
  // step of a run: the P2G state at t = 0), as written to grid.pvd. Empty
  // without output.grid.
  const PointCloud& grid_points() const { return grid_points_; }

 private:
  RunSummary run_steps(std::ostream* progress, const ProgressOptions& options,
                       std::chrono::steady_clock::time_point start);
  // The largest particle speed |v_p| and the largest particle coordinate
  // along x (the run-out front), over all ranks; collective.
  std::pair<double, double> motion_extremes() const;
  void check_finite() const;
  std::vector<char> rigid_particles(const MomentumSystem<dim>& system) const;
  std::vector<double> contact_normals(const MomentumSystem<dim>& system, int field_count) const;
  void leave_out_sticking_contacts(const MomentumSystem<dim>& system, int field_count,
                                   std::vector<double>& packing) const;
  void repartition(const Ownership<dim>& ownership);
  // last_acceleration_ to and from a checkpoint's rows (RunState).
  void store_last_acceleration(RunState& state) const;
  void restore_last_acceleration(const RunState& state);
  // The contact forces r_i / h of the step's contact points, per obstacle
  // (obstacle_force_) and per point (nodal_contacts_).
  void record_contact_forces(const std::vector<ContactPoint<dim>>& contacts, const std::vector<Vector<dim>>& impulses,
                             const std::vector<NaturalMap<dim>>& maps, double h);
  // This rank's (1/2) sum m_p |v_p|^2, and the particles' K, G, E summed over ranks.
  double local_particle_kinetic() const;
  ParticleEnergy local_particle_energy() const;  // this rank's K, G, E
  ParticleEnergy particle_energy() const;
  // Adds a finished step's energy terms (this rank's share, with the
  // particles' kinetic energy before P2G) to energy_; collective.
  void account_energy(const StepEnergy& step, double kinetic_start);
  // One explicit step (time.integrator: explicit; src/simulation_explicit.cpp).
  StepReport advance_explicit(double h);
  // G2P, the commit of the stresses and state of `system`, NaN check and
  // migration; advances the time. Returns its seconds.
  double complete_step(const MomentumSystem<dim>& system, const std::vector<Stencil<dim>>& stencils,
                       const GridFields<dim>& fields, double h, double theta);
  void keep_particles_inside();
  // The equilibrium stage (src/simulation_equilibrium.cpp): quasi-static
  // steps in the initial configuration until the bodies carry their weight;
  // fills summary's equilibrium_* fields. Throws SimulationError if a stage
  // step does not converge.
  void equilibrate(RunSummary& summary, std::ostream* progress);
  // 8. Commit sigma^{n+1} and the material state of `system` to the particles.
  void commit_material_state(const MomentumSystem<dim>& system);
  // `time.step: auto`: min(gravity_number sqrt(cell / |g|), courant cell /
  // v_max) with v_max the fastest particle or obstacle now (collective); the
  // first step when nothing moves and there is no gravity.
  double auto_nominal_step() const;
  bool grid_output() const { return config_.output.enabled && config_.output.grid; }
  // Stores grid_points_: mass, the velocity `velocity` (ghosted, dim per
  // point) and, with `system`, the contact forces -r_i / h of its contact points.
  void record_grid_points(const GridFields<dim>& fields, const std::vector<double>& velocity,
                          const MomentumSystem<dim>* system, double h);
  void record_initial_grid_points();  // P2G at the current particle state, v^n
  // Output of the obstacles (docs/output.md#obstacles-and-contacts): the
  // contact points of the last step as written, the force on each obstacle
  // (-obstacle_forces()), and the columns of obstacle_forces.csv and its row
  // (that force, then the impulses, their totals and the window force of loads_).
  std::vector<ContactSample<dim>> contact_samples() const;
  std::vector<double> force_row() const;
  std::vector<std::string> force_columns() const;
  std::vector<double> force_table_row() const;
  // The peaks of loads_, by obstacle name.
  std::vector<RunSummary::PeakLoad> peak_loads() const;

  CaseConfig config_;
  MPI_Comm comm_;
  std::unique_ptr<Grid<dim>> grid_;
  std::unique_ptr<Particles<dim>> particles_;
  std::unique_ptr<NewtonSolver<dim>> newton_;
  std::vector<const Material*> materials_;
  std::vector<Tangent> compliance_;  // C^-1 per material (the energy balance)
  std::vector<Obstacle<dim>> obstacles_;
  std::vector<Vector<dim>> obstacle_force_;
  std::vector<Vector<dim>> obstacle_field_force_;  // [obstacle * fields + field], several fields only
  ObstacleLoads loads_{0, dim, 0.0};  // set for the obstacles in the constructor
  std::vector<NodalContact> nodal_contacts_;
  PointCloud grid_points_;
  Vector<dim> gravity_;
  double mass_threshold_ = 0;
  double p_wave_speed_ = 0;  // the fastest of the materials' (p_wave_speed)
  double time_ = 0;
  std::unique_ptr<RunState> resume_;  // set by restart()
  // The Newton predictor (GridFields::last_acceleration): the last accepted
  // step's acceleration at this rank's owned active points (ghosted layout,
  // NaN elsewhere; empty before the first step and after a re-partition).
  std::vector<double> last_acceleration_;
  // Grid points (of the step's fields) whose material crossed an obstacle
  // in the last attempt of the step: contact points of the next attempt
  // whatever their predicted gap; and how many attempts are under way.
  std::vector<char> forced_contacts_;
  int contact_resolve_depth_ = 0;
  // True during the equilibrium stage: advance() then takes theta = 1, starts
  // Newton from rest, and commits only the stresses (no motion, no energy).
  bool equilibrium_stage_ = false;
  // The grid displacement h v of the last stage step: largest |u| (m) and the
  // work of gravity sum m_i g . u_i (collective).
  double stage_displacement_ = 0.0, stage_gravity_work_ = 0.0;
  // ... and its largest stress change over the largest stress (collective).
  double stage_stress_change_ = 0.0;
  // The energy balance (docs/energy.md): K0 + G0 + E0 (NaN until the first
  // step or a restart sets it), the terms summed since t = 0, and the
  // particles' energies after the last step.
  double initial_energy_ = std::numeric_limits<double>::quiet_NaN();
  EnergyTerms energy_;
  // The step's shape-function stencils, kept from step to step: a Stencil
  // reserves room for 4 functions per axis (3 kB in 3D), so a fresh vector
  // every step zeroed and page-faulted 400 MB at 128,000 3D particles.
  std::vector<Stencil<dim>> stencils_;
  MomentumWorkspace momentum_workspace_;  // the step's system's large buffers, kept
  std::vector<int> packing_lattice_;  // per body: particles per cell of its lattice (particle_packing)
  double correction_work_ = 0.0;  // this rank's, of the current step (keep_particles_inside)
  ParticleEnergy particle_energy_;
  PetscInt last_system_size_ = 0;
  long rebalances_ = 0;
  bool rigid_overlap_warned_ = false;  // the warning of two rigid bodies on one grid point, once per run
  RunSummary summary_;
};

// Applies the case file's solver.petsc_options under the talus_ prefix,
// leaving any option already given on the command line untouched.
void apply_case_petsc_options(const CaseConfig& config);

// Before anything is written: throws InputError naming the -talus_ options
// (with the case file line of those from solver.petsc_options) that no
// configuration of the solver reads (NewtonSolver::options_read_by_no_configuration).
template <int dim>
void check_solver_options(const CaseConfig& config, MPI_Comm comm);

// The -talus_ PETSc options that nothing has read so far, as "-a, -b" (""
// if none): after the first step, a misspelled or misplaced option.
std::string unused_solver_options();

}  // namespace talus
