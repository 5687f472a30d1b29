// The run loop (docs/solver.md#time-step-control, docs/command_line.md):
// steps to time.end with cut-backs and the automatic step, outputs landed
// on exactly, checkpoints, signals, the progress line and the summary.
#include "talus/simulation.hpp"
#include "talus/solver/step_control.hpp"

#include <algorithm>
#include <csignal>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <limits>
#include <ostream>
#include <sstream>

#include "talus/io/yaml_section.hpp"

namespace talus {

namespace {
// What a user can change when the step cannot be cut back any further
// (issue 15: a failure message that says what to do).
std::string failure_advice(const CaseConfig& c, double nominal) {
  std::ostringstream m;
  m << "to get past it: a smaller nominal step (now " << number_text(nominal) << " s";
  if (!c.time.auto_step) m << "; `time.step: auto` chooses one from the cell size and gravity";
  m << ", docs/solver.md#choosing-the-step), a smaller time.min_step_ratio (now " << number_text(c.time.min_step_ratio)
    << ") to allow deeper cut-backs, a finer grid.cell_size where few particles carry the failing region, "
       "or another Newton globalization (-talus_snes_linesearch_type, docs/solver.md#large-steps); "
       "-talus_snes_monitor prints the Newton history";
  return m.str();
}
}  // namespace

template <int dim>
double Simulation<dim>::auto_nominal_step() const {
  double speed = motion_extremes().first;  // collective
  for (const auto& o : obstacles_) speed = std::max(speed, o.velocity().norm());
  const double h = automatic_step(config_.time, grid_->cell_size(), gravity_.norm(), speed);
  return std::isfinite(h) ? h : config_.time.step;
}

namespace {
// Set by SIGINT/SIGTERM; the run loop checks it after every step.
volatile std::sig_atomic_t pending_signal = 0;
extern "C" void remember_signal(int signal) { pending_signal = signal; }
}  // namespace

template <int dim>
RunSummary Simulation<dim>::run(std::ostream* progress, const ProgressOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  try {
    return run_steps(progress, options, start);
  } catch (...) {
    // What the run did until it failed, for its closing lines (summary()).
    summary_.status = RunStatus::failed;
    summary_.time = time_;
    summary_.wall_seconds = seconds_since(start);
    MPI_Comm_size(comm_, &summary_.final_load.ranks);  // not the particles per rank: no collective on this path
    if (std::isfinite(energy_balance_error())) summary_.energy_balance_error = energy_balance_error();
    throw;
  }
}

template <int dim>
std::pair<double, double> Simulation<dim>::motion_extremes() const {
  double local[2] = {0.0, -std::numeric_limits<double>::infinity()}, global[2];
  {
    FieldView<PetscReal> x(particles_->swarm(), field::position), v(particles_->swarm(), field::velocity);
    for (PetscInt p = 0; p < particles_->local_count(); ++p) {
      local[0] = std::max(local[0], Eigen::Map<const Vector<dim>>(v.data() + dim * p).norm());
      local[1] = std::max(local[1], x[dim * p]);
    }
  }
  MPI_Allreduce(local, global, 2, MPI_DOUBLE, MPI_MAX, comm_);
  return {global[0], global[1]};
}

namespace {

// The continued series, from rank 0 to every rank (each numbers the files it writes).
void broadcast_series(ContinuedSeries& series, MPI_Comm comm) {
  int rank;
  MPI_Comm_rank(comm, &rank);
  std::string text;
  if (rank == 0) {
    std::ostringstream out;
    out.precision(17);
    out << series.next_number << '\n';
    for (const auto& [t, file] : series.entries) out << t << ' ' << file << '\n';
    text = out.str();
  }
  unsigned long size = text.size();
  MPI_Bcast(&size, 1, MPI_UNSIGNED_LONG, 0, comm);
  text.resize(size);
  MPI_Bcast(text.data(), static_cast<int>(size), MPI_CHAR, 0, comm);
  if (rank == 0) return;
  std::istringstream in(text);
  in >> series.next_number;
  series.entries.clear();
  double t;
  std::string file;
  while (in >> t >> file) series.entries.emplace_back(t, file);
}

}  // namespace

template <int dim>
RunSummary Simulation<dim>::run_steps(std::ostream* progress, const ProgressOptions& options,
                                      std::chrono::steady_clock::time_point start) {
  RunSummary& summary = summary_;
  summary = RunSummary{};
  summary.start_time = summary.time = time_;
  summary.end_time = config_.time.end;
  int rank;
  MPI_Comm_rank(comm_, &rank);
  ProgressLog log(rank == 0 ? progress : nullptr, options);
  EtaEstimate eta;
  const TimeConfig& tc = config_.time;
  const double eps = 1e-12 * tc.end;
  const double interval = config_.output.interval;
  const long rebalances_at_start = rebalances_;
  double next_output = interval > 0 ? interval : tc.end;
  StepController control(tc.step);
  bool options_checked = false;
  std::unique_ptr<VtkSeries<dim>> vtk;
  if (config_.output.enabled) vtk = std::make_unique<VtkSeries<dim>>(comm_, config_.output.directory);
  // With obstacles: their geometry and the contact points at every output
  // (file numbers those of the particle output), the force on each at every step.
  std::unique_ptr<ObstacleSeries<dim>> obstacle_vtk;
  std::unique_ptr<ContactSeries<dim>> contact_vtk;
  std::unique_ptr<ObstacleForceTable> forces;
  // With output.grid: the grid points of the last step (grid.pvd), same numbers.
  std::unique_ptr<PointCloudSeries> grid_vtk;
  if (vtk && config_.output.grid) grid_vtk = std::make_unique<PointCloudSeries>(comm_, config_.output.directory, "grid");
  const bool obstacle_output = vtk && !obstacles_.empty();
  if (obstacle_output) {
    obstacle_vtk =
        std::make_unique<ObstacleSeries<dim>>(comm_, config_.output.directory, grid_->lower(), grid_->upper());
    contact_vtk = std::make_unique<ContactSeries<dim>>(comm_, config_.output.directory);
  }
  // Every write of results goes through `guarded`: a write that failed on any
  // rank (a full disk, a file-size limit) stops every rank with an
  // OutputError, after the writers have left the files of earlier outputs
  // (and the last checkpoint) as they were.
  const auto guarded = [&](const char* what, const auto& body) {
    int failed = 0;
    std::string message;
    try {
      body();
    } catch (const std::exception& e) {
      failed = 1;
      message = e.what();
    }
    int any = 0;
    MPI_Allreduce(&failed, &any, 1, MPI_INT, MPI_MAX, comm_);
    if (!any) return;
    if (failed && rank != 0) std::cerr << "talus: output failed on rank " << rank << ": " << message << "\n";
    throw OutputError(std::string(what) + " at t = " + number_text(time_) + ": " +
                      (failed ? message : std::string("a file could not be written on another rank")) +
                      "; the results written before and the last checkpoint are intact");
  };
  const auto write_output = [&] {
    guarded("writing the output", [&] {
      const std::size_t number = static_cast<std::size_t>(vtk->next_number());
      vtk->write(*particles_, time_);
      if (obstacle_vtk) obstacle_vtk->write(obstacles_, time_, number);
      if (contact_vtk) contact_vtk->write(contact_samples(), time_, number);
      if (grid_vtk) grid_vtk->write(grid_points_, time_, number);
    });
    ++summary.outputs;
  };
  const std::string forces_path = config_.output.directory + "/obstacle_forces.csv";
  // The energy balance at every step (docs/energy.md).
  std::unique_ptr<ObstacleForceTable> energy_table;
  const std::string energy_path = config_.output.directory + "/energy.csv";
  std::vector<std::string> energy_columns{"kinetic", "gravitational", "elastic"};
  for (const char* name : EnergyTerms::names()) energy_columns.push_back(name);
  energy_columns.push_back("balance_error");
  for (std::string& c : energy_columns) c += dim == 2 ? " [J/m]" : " [J]";  // per m of thickness in 2D
  const auto energy_row = [&] {
    std::vector<double> row{particle_energy_.kinetic, particle_energy_.gravitational, particle_energy_.elastic};
    for (double v : energy_.values()) row.push_back(v);
    row.push_back(energy_balance_error());
    return row;
  };
  // The bodies' rigid-body motion at every step (docs/output.md#bodiescsv).
  std::unique_ptr<ObstacleForceTable> body_table;
  const std::string bodies_path = config_.output.directory + "/bodies.csv";
  if (resume_) {
    summary.steps_before = resume_->steps;
    summary.cutbacks_before = resume_->cutbacks;
    // With `time.step: auto` the nominal step is the one the next step will
    // take (as in the run that wrote the checkpoint), not the first one.
    if (tc.auto_step) control.set_nominal(auto_nominal_step());
    control.restore({resume_->step_size, resume_->patience, resume_->calm, resume_->since_growth});
    next_output = resume_->next_output;
    if (vtk) {
      // The series goes on from the checkpoint's outputs: in the directory
      // of the checkpoint's run as they are, in another (a branch) from hard
      // links to them (docs/checkpoints.md#restart-into-another-directory-a-branch).
      ContinuedSeries series;
      guarded("continuing the output series", [&] {
        if (rank == 0) series = continue_series(resume_->output_directory, config_.output.directory, resume_->outputs);
      });
      broadcast_series(series, comm_);
      vtk->resume(series.entries, series.next_number);
      if (obstacle_vtk) obstacle_vtk->resume(series.entries);
      if (contact_vtk) contact_vtk->resume(series.entries);
      if (grid_vtk) grid_vtk->resume(series.entries);
      if (!series.note.empty()) log.message("  " + series.note);
    }
    // The table keeps its rows up to the checkpoint's time and continues.
    std::string note;
    if (obstacle_output)
      forces = std::make_unique<ObstacleForceTable>(comm_, forces_path, force_columns(), time_, &note);
    if (vtk) {
      std::string energy_note, bodies_note;
      energy_table = std::make_unique<ObstacleForceTable>(comm_, energy_path, energy_columns, time_, &energy_note);
      body_table =
          std::make_unique<ObstacleForceTable>(comm_, bodies_path, body_motion_columns(), time_, &bodies_note);
      if (note.empty()) note = energy_note;
      if (note.empty()) note = bodies_note;
    }
    if (!note.empty()) log.message("  " + note);
  } else {
    // The equilibrium stage runs before anything of the run is written, so
    // that t = 0 is its state (a restart starts after it).
    if (config_.equilibrium.enabled) equilibrate(summary, progress);
    if (obstacle_output) forces = std::make_unique<ObstacleForceTable>(comm_, forces_path, force_columns());
    if (vtk) {
      if (std::isnan(initial_energy_)) {
        particle_energy_ = particle_energy();
        initial_energy_ = particle_energy_.total();
      }
      energy_table = std::make_unique<ObstacleForceTable>(comm_, energy_path, energy_columns);
      guarded("appending to energy.csv", [&] { energy_table->append(time_, energy_row()); });
      body_table = std::make_unique<ObstacleForceTable>(comm_, bodies_path, body_motion_columns());
      const std::vector<double> row = body_motion_row();  // collective
      guarded("appending to bodies.csv", [&] { body_table->append(time_, row); });
    }
    if (grid_vtk) record_initial_grid_points();  // t = 0: the P2G state
    if (vtk) write_output();
  }
  // Steps and cut-backs since t = 0: the checkpoints' numbering and counts.
  const auto steps_since_start = [&] { return summary.steps_before + summary.steps; };
  const auto checkpoint = [&] {
    const StepController::State s = control.state();
    RunState state;
    state.time = time_;
    state.steps = steps_since_start();
    state.cutbacks = summary.cutbacks_before + summary.cutbacks;
    state.step_size = s.step;
    state.patience = s.patience;
    state.calm = s.calm;
    state.since_growth = s.since_growth;
    state.next_output = next_output;
    if (vtk) state.outputs = vtk->entries();
    state.output_directory = config_.output.directory;
    for (const auto& axis : grid_->ownership()) state.grid_ownership.push_back(axis);
    store_last_acceleration(state);
    state.initial_energy = initial_energy_;
    state.energy_terms = energy_.values();
    state.obstacle_loads = loads_.state();
    for (const Obstacle<dim>& o : obstacles_) state.obstacle_names.push_back(o.name());
    state.case_file = std::filesystem::absolute(config_.source_file).lexically_normal().string();
    state.fingerprint = config_.fingerprint;
    std::filesystem::create_directories(config_.checkpoint.directory);
    char name[64];
    std::snprintf(name, sizeof name, "checkpoint_%06ld.h5", state.steps);
    summary.last_checkpoint = config_.checkpoint.directory + "/" + name;
    guarded("writing a checkpoint", [&] { write_checkpoint(summary.last_checkpoint, *particles_, state, comm_); });
    log.note("  checkpoint " + summary.last_checkpoint);
    // A restart from here builds its solver anew (matrix, KSP/PC, LU factors,
    // the inexact-Newton state); so does this run, so that both continue bit
    // for bit (docs/checkpoints.md).
    newton_->rebuild_next_step();
  };
  const auto finish = [&] {
    summary.time = time_;
    summary.wall_seconds = seconds_since(start);
    summary.rebalances = rebalances_ - rebalances_at_start;
    summary.final_load = rank_load(comm_, particles_->local_count());
    summary.energy_balance_error = energy_balance_error();
    summary.peak_window_forces = peak_loads();
    summary.force_window = loads_.window();
    log.finish();
  };
  // The next step: control.step(), shortened to land exactly on the next
  // output time or time.end when it would pass it, or stretched to land on it
  // when it would stop short of it by less than a millionth of a step. When a
  // full step would leave less than a quarter step before the target, the
  // two steps to it are halves of the rest instead (no sliver step: 0.1 s
  // outputs with steps of 7.14e-3 s ended every interval with a 5.1e-5 s
  // step). The controller's step is not changed by any of them.
  const auto next_step = [&] {
    const double target = vtk && interval > 0 ? std::min(next_output, tc.end) : tc.end;
    const double h = control.step();
    const double rest = target - time_;
    if (time_ + h * (1.0 + 1e-6) >= target) return std::pair{rest, target};
    if (rest < 1.25 * h) return std::pair{0.5 * rest, -1.0};
    return std::pair{h, -1.0};
  };
  pending_signal = 0;
  const auto previous_int = std::signal(SIGINT, remember_signal);
  const auto previous_term = std::signal(SIGTERM, remember_signal);
  struct RestoreSignals {
    decltype(previous_int) i, t;
    ~RestoreSignals() {
      std::signal(SIGINT, i);
      std::signal(SIGTERM, t);
    }
  } restore_signals{previous_int, previous_term};
  while (time_ < tc.end - eps) {
    if (tc.auto_step) control.set_nominal(auto_nominal_step());
    const double step_start = time_;
    const auto [h_try, landing] = next_step();
    // Balanced ranks: re-partition the grid when the particles have moved
    // too far out of balance (docs/parallel.md).
    RankLoad load;
    const bool rebalanced = balance_ranks(false, &load);
    summary.worst_imbalance = std::max(summary.worst_imbalance, load.imbalance());
    if (rebalanced) {
      std::ostringstream m;
      m << "  grid re-partitioned at t = " << time_ << ": particles per rank " << load.min << " to " << load.max;
      log.message(m.str());
    }
    StepReport r = advance(h_try);
    if (r.rigid_overlap_points > 0 && !rigid_overlap_warned_) {
      rigid_overlap_warned_ = true;
      std::ostringstream m;
      m << "  warning: two rigid bodies share " << r.rigid_overlap_points << " grid points at t = " << time_
        << ": rigid bodies are not held apart from each other (docs/contact.md#rigid-bodies)";
      log.message(m.str());
    }
    summary.newton_iterations += r.newton.iterations;
    summary.linear_iterations += r.newton.linear_iterations;
    summary.transfer_seconds += r.transfer_seconds;
    summary.solve_seconds += r.solve_seconds;
    summary.contact_seconds += r.contact_seconds;
    summary.material_seconds += r.material_seconds;
    summary.assembly_seconds += r.assembly_seconds;
    summary.linear_seconds += r.linear_seconds;
    summary.operator_seconds += r.operator_seconds;
    summary.structure_builds += r.newton.structure_built;
    summary.direct_fallbacks += r.newton.direct_fallback;
    summary.multigrid_fallbacks += r.newton.multigrid_fallback;
    summary.factorizations += r.newton.factorizations;
    summary.jacobian_matrices += r.newton.jacobian_matrices;
    summary.block_diagonals += r.newton.block_diagonals;
    summary.contact_resolves += r.contact_resolves;
    if (!r.converged) {
      ++summary.cutbacks;
      summary.inverting_cutbacks += r.inverting_particles > 0;
      const double h = control.failed(h_try);
      std::ostringstream m;
      m << "  " << (r.inverting_particles > 0 ? "step rejected" : "Newton failed") << " (" << r.newton.reason
        << ") at t = " << time_ << " with h = " << h_try << "; retrying with h = " << next_step().first;
      log.message(m.str());
      if (h < tc.min_step_ratio * control.nominal())
        throw SimulationError("Newton did not converge at t = " + number_text(time_) +
                              " even with h = " + number_text(h_try) + " (" + r.newton.reason + "); " +
                              failure_advice(config_, control.nominal()));
      continue;
    }
    // On the output time or time.end itself: time_ + h can miss it in the last bit.
    if (landing >= 0) time_ = landing;
    ++summary.steps;
    const double elapsed = seconds_since(start);
    eta.add(elapsed, time_);
    if (!options_checked) {
      // By now the solver has read every option it will read: one that it
      // did not is misspelled or meant for another configuration.
      options_checked = true;
      const std::string unused = unused_solver_options();
      if (!unused.empty() && rank == 0) {
        std::cerr << "talus: warning: PETSc options never read by the solver (misspelled, or for another solver "
                     "configuration): " << unused << "\n";
        log.message("  warning: PETSc options never read by the solver: " + unused);
      }
    }
    summary.contact_points += r.contact_points;
    summary.body_contact_points += r.body_contact_points;
    summary.ghost_cells += r.ghost_cells;
    summary.max_step_newton_iterations = std::max<long>(summary.max_step_newton_iterations, r.newton.iterations);
    summary.max_unbalance = std::max(summary.max_unbalance, r.newton.unbalance);
    control.succeeded(r.newton.iterations);
    if (!obstacles_.empty()) loads_.add_step(step_start, time_, force_row());
    if (forces) guarded("appending to obstacle_forces.csv", [&] { forces->append(time_, force_table_row()); });
    if (energy_table) guarded("appending to energy.csv", [&] { energy_table->append(time_, energy_row()); });
    if (body_table) {
      const std::vector<double> row = body_motion_row();  // collective
      guarded("appending to bodies.csv", [&] { body_table->append(time_, row); });
    }
    const bool last = time_ >= tc.end - eps;
    const bool due = time_ >= next_output - eps || last;
    if (vtk && due) {
      write_output();
      // k x interval, not a running sum: 0.1 + 0.1 + 0.1 is not 0.3.
      while (next_output <= time_ + eps)
        next_output = interval > 0 ? interval * (std::round(next_output / interval) + 1) : next_output + tc.end;
    }
    // Rank 0's clock decides whether this step gets a progress line; the same
    // reduction tells every rank whether a signal arrived on any.
    int flags[2] = {pending_signal,
                    rank == 0 && log.wants_line(steps_since_start(), summary.steps == 1, vtk && due, last, elapsed)};
    int any[2] = {0, 0};
    MPI_Allreduce(flags, any, 2, MPI_INT, MPI_MAX, comm_);
    if (any[1]) {
      const auto [max_speed, front] = motion_extremes();  // collective
      ProgressFigures f;
      f.step = steps_since_start();
      f.time = time_;
      f.end = tc.end;
      f.h = r.h;
      f.explicit_step = tc.integrator == Integrator::explicit_euler;
      f.newton = r.newton.iterations;
      f.linear = r.newton.linear_iterations;
      f.unbalance = r.newton.unbalance;
      f.active = r.active_points;
      f.elapsed = elapsed;
      f.eta = eta.seconds_to(tc.end);
      f.max_speed = max_speed;
      f.kinetic = particle_energy_.kinetic;
      f.front = front;
      f.dim = dim;
      f.output = vtk && due;
      log.line(f);
    }
    // A signal on any rank stops every rank after this step, with a checkpoint.
    if (any[0]) {
      summary.status = RunStatus::interrupted;
      summary.interrupted_by = any[0];
      if (config_.checkpoint.enabled) checkpoint();
      finish();
      return summary;
    }
    if (config_.checkpoint.enabled && config_.checkpoint.interval > 0 &&
        steps_since_start() % config_.checkpoint.interval == 0 && !last)
      checkpoint();
  }
  if (config_.checkpoint.enabled) checkpoint();
  finish();
  return summary;
}

template class Simulation<2>;
template class Simulation<3>;

}  // namespace talus
