#include "talus/simulation.hpp"
#include "talus/solver/step_control.hpp"

#include <algorithm>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <limits>
#include <ostream>
#include <sstream>

#include "talus/io/yaml_section.hpp"
#include "talus/particles/seeding.hpp"

namespace talus {

namespace {
double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
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
  DM sw = particles_->swarm();
  FieldView<PetscReal> v(sw, field::velocity);
  double speed = 0.0;
  for (PetscInt p = 0; p < particles_->local_count(); ++p)
    speed = std::max(speed, Eigen::Map<const Vector<dim>>(v.data() + dim * p).norm());
  for (const auto& o : obstacles_) speed = std::max(speed, o.velocity().norm());
  MPI_Allreduce(MPI_IN_PLACE, &speed, 1, MPI_DOUBLE, MPI_MAX, comm_);
  const TimeConfig& tc = config_.time;
  const double inf = std::numeric_limits<double>::infinity();
  const double g = gravity_.norm();
  const double by_gravity = g > 0 ? tc.gravity_number * std::sqrt(grid_->cell_size() / g) : inf;
  const double by_speed = speed > 0 ? tc.courant * grid_->cell_size() / speed : inf;
  const double h = std::min(by_gravity, by_speed);
  return std::isfinite(h) ? h : tc.step;
}

void apply_case_petsc_options(const CaseConfig& config) {
  for (const auto& [key, value] : config.solver.petsc_options) {
    const std::string name = "-talus_" + key;
    PetscBool set = PETSC_FALSE;
    TALUS_PETSC(PetscOptionsHasName(nullptr, nullptr, name.c_str(), &set));
    if (!set) TALUS_PETSC(PetscOptionsSetValue(nullptr, name.c_str(), value.empty() ? nullptr : value.c_str()));
  }
}

std::string unused_solver_options() {
  PetscInt count = 0;
  char** names = nullptr;
  char** values = nullptr;
  TALUS_PETSC(PetscOptionsLeftGet(nullptr, &count, &names, &values));
  std::string list;
  for (PetscInt k = 0; k < count; ++k) {
    const std::string name = names[k];
    // Read only when they are needed: the LU retry after a failed linear
    // solve, the inner solver of a nonlinear preconditioner.
    if (name.rfind("talus_", 0) != 0 || name.rfind("talus_fallback_", 0) == 0) continue;
    list += (list.empty() ? "-" : ", -") + name;
  }
  TALUS_PETSC(PetscOptionsLeftRestore(nullptr, &count, &names, &values));
  return list;
}

template <int dim>
Simulation<dim>::Simulation(const CaseConfig& config, MPI_Comm comm) : config_(config), comm_(comm) {
  if (config.dim != dim) throw InputError(config.source_file + ": the case is " + std::to_string(config.dim) + "D");
  Vector<dim> lo, hi;
  for (int a = 0; a < dim; ++a) {
    lo[a] = config.grid.lower[a];
    hi[a] = config.grid.upper[a];
    gravity_[a] = config.gravity[a];
  }
  grid_ = std::make_unique<Grid<dim>>(comm, lo, hi, config.grid.cell_size, config.grid.shape);
  particles_ = std::make_unique<Particles<dim>>(comm);
  for (const auto& m : config.materials) materials_.push_back(m.law.get());
  // C^-1 of each material, for the energy balance's elastic energy (docs/energy.md).
  for (const Material* m : materials_) compliance_.push_back(m->elastic_stiffness().inverse());
  for (const ObstacleConfig& o : config.obstacles) obstacles_.emplace_back(o);
  // A frictional face is a rigid half-plane on the face, its solid outside the grid.
  for (int f = 0; f < 2 * dim; ++f)
    if (config.faces[f] == FaceCondition::frictional) {
      ObstacleConfig face;
      face.name = face_names[f];
      face.shape = ObstacleShape::half_plane;
      const int axis = f / 2;
      face.point = f % 2 == 0 ? config.grid.lower : config.grid.upper;
      face.normal.assign(dim, 0.0);
      face.normal[axis] = f % 2 == 0 ? 1.0 : -1.0;
      face.velocity.assign(dim, 0.0);
      face.friction = config.face_contact[f].friction;
      face.restitution = config.face_contact[f].restitution;
      obstacles_.emplace_back(face);
    }
  obstacle_force_.assign(obstacles_.size(), Vector<dim>::Zero());
  loads_ = ObstacleLoads(static_cast<int>(obstacles_.size()), dim, config.output.force_window);
  std::int64_t next_id = 0;
  for (std::size_t b = 0; b < config.bodies.size(); ++b) {
    const BodyConfig& body = config.bodies[b];
    next_id += seed_body<dim>(*particles_, *grid_, body, *materials_[body.material], static_cast<int>(b), next_id,
                                  -config.gravity[dim - 1], obstacles_.empty() ? nullptr : &obstacles_);
  }
  double local_max = 0.0;
  {
    FieldView<PetscReal> m(particles_->swarm(), field::mass);
    for (PetscInt p = 0; p < particles_->local_count(); ++p) local_max = std::max(local_max, m[p]);
  }
  double max_mass = 0.0;
  MPI_Allreduce(&local_max, &max_mass, 1, MPI_DOUBLE, MPI_MAX, comm);
  mass_threshold_ = config.solver.active_mass_ratio * max_mass;
  apply_case_petsc_options(config);
  newton_ = std::make_unique<NewtonSolver<dim>>(comm, config.solver.direct_solver_limit,
                                                config.solver.balance_tolerance);
  // Seeded on PETSc's even split of the box; now follow the particles.
  balance_ranks(true);
  rebalances_ = 0;  // the initial partition is not a re-partition during the run
}

template <int dim>
bool Simulation<dim>::balance_ranks(bool always, RankLoad* load) {
  const RankLoad now = rank_load(comm_, particles_->local_count());
  if (load) *load = now;
  if (now.ranks == 1 || !config_.parallel.balance) return false;
  if (!always && now.imbalance() <= config_.parallel.imbalance_limit) return false;
  BalancedPartition<dim> best;
  {
    FieldView<PetscReal> x(particles_->swarm(), field::position);
    best = balanced_partition(*grid_, x.data(), particles_->local_count());
  }
  // Only for a real gain, so that a distribution that no DMDA split can
  // balance better is not re-partitioned at every step.
  if (best.ownership[0].empty() || best.ownership == grid_->ownership() ||
      static_cast<double>(best.load.max) > 0.95 * static_cast<double>(now.max))
    return false;
  repartition(best.ownership);
  if (load) *load = best.load;  // the exact counts of the new split
  ++rebalances_;
  return true;
}

template <int dim>
void Simulation<dim>::repartition(const Ownership<dim>& ownership) {
  auto grid = std::make_unique<Grid<dim>>(comm_, grid_->lower(), grid_->upper(), grid_->cell_size(), grid_->shape(),
                                          &ownership);
  particles_->migrate(*grid);
  grid_ = std::move(grid);
  last_acceleration_.clear();  // the next step predicts gravity
  // The Newton system's rows live on the grid's ranks: build it anew.
  newton_->rebuild_next_step();
}

template <int dim>
StepReport Simulation<dim>::advance(double h) {
  if (std::isnan(initial_energy_)) {
    // The energy balance starts from the particles as they are now (t = 0,
    // or a state set by a test); a restart brings its own.
    particle_energy_ = particle_energy();
    initial_energy_ = particle_energy_.total();
  }
  if (config_.time.integrator == Integrator::explicit_euler && !equilibrium_stage_) return advance_explicit(h);
  const double kinetic_start = local_particle_kinetic();
  // The equilibrium stage is backward Euler from rest (docs/equilibrium.md).
  const double theta = equilibrium_stage_ ? 1.0 : config_.time.theta;
  StepReport report;
  report.h = h;
  const auto t0 = std::chrono::steady_clock::now();

  // 1. Locate particles: shape-function stencils at x_p^n.
  std::vector<Stencil<dim>> stencils;
  compute_stencils(*grid_, *particles_, stencils);
  // 2. P2G: nodal mass and momentum (and v^n).
  GridFields<dim> fields;
  particles_to_grid(*grid_, *particles_, stencils, config_.transfer.scheme, fields);
  report.transfer_seconds = seconds_since(t0);

  const auto t1 = std::chrono::steady_clock::now();
  // 3. Unknowns: velocities of the active grid points.
  ActiveSet<dim> active;
  active.build(*grid_, fields, mass_threshold_, config_.faces);
  report.active_points = active.global_count();
  last_system_size_ = active.global_count() * dim;
  // 4. Contact candidates: active points whose predicted gap to an obstacle is closed.
  const auto tc = std::chrono::steady_clock::now();
  std::vector<ContactPoint<dim>> contacts =
      find_contact_candidates(*grid_, *particles_, stencils, fields, active, obstacles_, time_, h, config_.contact.gap_prediction);
  report.contact_seconds = seconds_since(tc);
  if (equilibrium_stage_ && config_.equilibrium.stick) {
    // `contact: stick`: the bodies are held where they touch an obstacle or a
    // frictional face, as on the fixed base of a gravity-loading step.
    for (const ContactPoint<dim>& cp : contacts) active.constrain(cp.point);
    contacts.clear();
  }
  {
    PetscInt local = static_cast<PetscInt>(contacts.size());
    MPI_Allreduce(&local, &report.contact_points, 1, MPIU_INT, MPI_SUM, comm_);
  }
  // 5. Freeze the committed particle state and 6. solve momentum, plasticity
  // and contact, F(v) = 0, by one semismooth Newton.
  // The predictor; kept for a retry after a cut-back. A stage step starts
  // from rest (zero acceleration), not from free fall over its long step.
  fields.last_acceleration =
      equilibrium_stage_ ? std::vector<double>(fields.velocity.size(), 0.0) : last_acceleration_;
  MomentumSystem<dim> system(*grid_, *particles_, stencils, fields, active, materials_, gravity_, h, theta,
                             std::move(contacts));
  if (active.global_count() > 0) {
    report.newton = newton_->solve(system);
  } else {
    report.newton.converged = true;
    report.newton.reason = "no active grid points";
  }
  report.solve_seconds = seconds_since(t1);
  report.contact_seconds += system.contact_seconds();
  if (!report.newton.converged) return report;
  if (equilibrium_stage_) {
    // No motion: the particles keep their places, deformation gradients and
    // velocities (zero); only sigma and the material state are committed.
    const auto& v = system.end_velocity();
    double largest = 0.0, work = 0.0;
    for (int i : active.owned_points()) {
      const Eigen::Map<const Vector<dim>> vi(v.data() + dim * i);
      largest = std::max(largest, h * vi.norm());
      work += fields.mass[i] * gravity_.dot(h * vi);
    }
    MPI_Allreduce(&largest, &stage_displacement_, 1, MPI_DOUBLE, MPI_MAX, comm_);
    MPI_Allreduce(&work, &stage_gravity_work_, 1, MPI_DOUBLE, MPI_SUM, comm_);
    // The stage's convergence: the largest stress change of the step against
    // the largest stress. Not the displacement: a grid point whose particles
    // all sit where its B-spline has zero gradient has no stiffness, only the
    // vanishing inertia of the long step, and falls freely without straining
    // anything (seen in landslide_3d_from_dem).
    double change[2] = {0.0, 0.0}, any[2];
    {
      FieldView<PetscReal> start(particles_->swarm(), field::stress);
      const auto& end = system.end_stress();
      for (std::size_t p = 0; p < end.size(); ++p) {
        change[0] = std::max(change[0], (end[p] - Eigen::Map<const Voigt>(start.data() + 6 * p)).norm());
        change[1] = std::max(change[1], end[p].norm());
      }
    }
    MPI_Allreduce(change, any, 2, MPI_DOUBLE, MPI_MAX, comm_);
    stage_stress_change_ = any[1] > 0 ? any[0] / any[1] : 0.0;
    commit_material_state(system);
    check_finite();
    report.converged = true;
    return report;
  }
  {
    // The next step's predictor: this step's grid acceleration.
    const auto& v_end = system.end_velocity();
    const auto& v_start = system.start_velocity();
    last_acceleration_.assign(v_end.size(), std::numeric_limits<double>::quiet_NaN());
    for (int i : active.owned_points())
      for (int a = 0; a < dim; ++a)
        last_acceleration_[dim * i + a] = (v_end[dim * i + a] - v_start[dim * i + a]) / h;
  }
  record_contact_forces(system.contacts(), system.contact_impulses(), system.contact_maps(), h);
  if (grid_output()) record_grid_points(fields, system.end_velocity(), &system, h);
  report.transfer_seconds += complete_step(system, stencils, fields, h, theta);
  account_energy(system.step_energy(theta, theta, compliance_, system.contacts(),
                                   system.contact_impulses()),
                 kinetic_start);
  report.converged = true;
  return report;
}

// 7. G2P and 8. the commit of the material state, the same for both
// integrators; returns its seconds.
template <int dim>
double Simulation<dim>::complete_step(const MomentumSystem<dim>& system, const std::vector<Stencil<dim>>& stencils,
                                      const GridFields<dim>& fields, double h, double theta) {
  // 7. G2P: velocities, affine velocities, positions, deformation gradients.
  const auto t2 = std::chrono::steady_clock::now();
  grid_to_particles(*particles_, stencils, system.end_velocity(), system.start_velocity(), fields.velocity, h,
                    theta, config_.transfer);
  commit_material_state(system);
  check_finite();
  keep_particles_inside();
  particles_->migrate(*grid_);
  time_ += h;
  return seconds_since(t2);
}

// 8. Commit the material state: sigma^{n+1} at the converged velocities.
template <int dim>
void Simulation<dim>::commit_material_state(const MomentumSystem<dim>& system) {
  {
    DM sw = particles_->swarm();
    FieldView<PetscReal> s(sw, field::stress), state(sw, field::material_state),
        plastic(sw, field::cumulative_plastic_strain), separation(sw, field::separation_strain);
    const auto& end = system.end_stress();
    const auto& dep = system.plastic_strain_increment();
    std::copy(system.end_state().begin(), system.end_state().end(), state.data());
    std::copy(system.end_separation().begin(), system.end_separation().end(), separation.data());
    for (std::size_t p = 0; p < end.size(); ++p) {
      Eigen::Map<Voigt>(s.data() + 6 * p) = end[p];
      // Equivalent plastic strain increment sqrt(2/3 d_eps_p : d_eps_p) (engineering shears halved).
      const Voigt& e = dep[p];
      const double norm2 = e.head<3>().squaredNorm() + 0.5 * e.tail<3>().squaredNorm();
      plastic[p] += std::sqrt(2.0 / 3.0 * norm2);
    }
  }
}

template <int dim>
void Simulation<dim>::check_finite() const {
  const PetscInt n = particles_->local_count();
  int bad = 0;
  {
    DM sw = particles_->swarm();
    FieldView<PetscReal> x(sw, field::position), v(sw, field::velocity), s(sw, field::stress);
    for (PetscInt p = 0; p < n && !bad; ++p) {
      for (int a = 0; a < dim; ++a) bad |= !std::isfinite(x[dim * p + a]) || !std::isfinite(v[dim * p + a]);
      for (int i = 0; i < 6; ++i) bad |= !std::isfinite(s[6 * p + i]);
    }
  }
  int any = 0;
  MPI_Allreduce(&bad, &any, 1, MPI_INT, MPI_MAX, comm_);
  if (any)
    throw SimulationError("a particle position, velocity or stress is not finite after the step ending at t = " +
                          number_text(time_) + "; the run stops (the last output is the last good state)");
}

template <int dim>
void Simulation<dim>::keep_particles_inside() {
  // Slip and fixed faces have zero normal velocity on the face itself, but
  // the time integration can carry a particle past it by a small amount: put
  // it back just inside (the DMDA locates points strictly inside its box). A
  // particle beyond a free face has left the computational domain: stop.
  const double margin = 1e-9 * grid_->cell_size();
  long escaped = 0;
  {
    FieldView<PetscReal> x(particles_->swarm(), field::position), m(particles_->swarm(), field::mass);
    for (PetscInt p = 0; p < particles_->local_count(); ++p)
      for (int a = 0; a < dim; ++a) {
        double& xa = x[dim * p + a];
        const double before = xa;
        const double lo = grid_->lower()[a] + margin, hi = grid_->upper()[a] - margin;
        if (xa < lo) {
          if (config_.faces[2 * a] == FaceCondition::free && xa < grid_->lower()[a]) ++escaped;
          xa = lo;
        } else if (xa > hi) {
          if (config_.faces[2 * a + 1] == FaceCondition::free && xa > grid_->upper()[a]) ++escaped;
          xa = hi;
        }
        // The energy balance: the gravitational energy the correction adds
        // (docs/energy.md, correction_work).
        correction_work_ -= m[p] * gravity_[a] * (xa - before);
      }
  }
  long total = 0;
  MPI_Allreduce(&escaped, &total, 1, MPI_LONG, MPI_SUM, comm_);
  if (total > 0)
    throw SimulationError(std::to_string(total) + " particles left the grid through a free face at t = " +
                          number_text(time_) + "; enlarge the grid box or make that face slip or fixed");
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
      std::string energy_note;
      energy_table = std::make_unique<ObstacleForceTable>(comm_, energy_path, energy_columns, time_, &energy_note);
      if (note.empty()) note = energy_note;
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
    summary.newton_iterations += r.newton.iterations;
    summary.linear_iterations += r.newton.linear_iterations;
    summary.transfer_seconds += r.transfer_seconds;
    summary.solve_seconds += r.solve_seconds;
    summary.contact_seconds += r.contact_seconds;
    summary.structure_builds += r.newton.structure_built;
    summary.direct_fallbacks += r.newton.direct_fallback;
    summary.factorizations += r.newton.factorizations;
    if (!r.converged) {
      ++summary.cutbacks;
      const double h = control.failed(h_try);
      std::ostringstream m;
      m << "  Newton failed (" << r.newton.reason << ") at t = " << time_ << " with h = " << h_try
        << "; retrying with h = " << next_step().first;
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
    summary.max_step_newton_iterations = std::max<long>(summary.max_step_newton_iterations, r.newton.iterations);
    summary.max_unbalance = std::max(summary.max_unbalance, r.newton.unbalance);
    control.succeeded(r.newton.iterations);
    if (!obstacles_.empty()) loads_.add_step(step_start, time_, force_row());
    if (forces) guarded("appending to obstacle_forces.csv", [&] { forces->append(time_, force_table_row()); });
    if (energy_table) guarded("appending to energy.csv", [&] { energy_table->append(time_, energy_row()); });
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
