#include "talus/simulation.hpp"
#include "talus/solver/step_control.hpp"

#include <algorithm>
#include <cstdio>
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

template <int dim>
Simulation<dim>::Simulation(const CaseConfig& config, MPI_Comm comm) : config_(config), comm_(comm) {
  if (config.dim != dim) throw InputError(config.source_file + ": the case is " + std::to_string(config.dim) + "D");
  Vector<dim> lo, hi;
  for (int a = 0; a < dim; ++a) {
    lo[a] = config.grid.lower[a];
    hi[a] = config.grid.upper[a];
    gravity_[a] = config.gravity[a];
  }
  grid_ = std::make_unique<Grid<dim>>(comm, lo, hi, config.grid.cell_size, config.grid.shape, config.grid.quadrature);
  particles_ = std::make_unique<Particles<dim>>(comm);
  for (const auto& m : config.materials) materials_.push_back(m.law.get());
  // C^-1 of each material, for the energy balance's elastic energy (docs/energy.md).
  for (const Material* m : materials_) compliance_.push_back(m->elastic_stiffness().inverse());
  for (const Material* m : materials_) p_wave_speed_ = std::max(p_wave_speed_, p_wave_speed(*m));
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
  // Per body, the particles per cell of its lattice, for the packing's rule at
  // the faces; for particles read from a file, those of a lattice of their
  // mean volume (docs/transfers.md#packing).
  for (const BodyConfig& b : config.bodies) {
    double mean = 0.0;
    for (const double v : b.file_volumes) mean += v / static_cast<double>(b.file_volumes.size());
    const double per_cell = mean > 0 ? config.grid.cell_size / std::pow(mean, 1.0 / dim) : 0.0;
    packing_lattice_.push_back(b.particle_file.empty() ? b.particles_per_cell
                                                       : static_cast<int>(std::clamp(std::round(per_cell), 1.0, 64.0)));
  }
  apply_case_petsc_options(config);
  check_solver_options<dim>(config, comm);
  newton_ = std::make_unique<NewtonSolver<dim>>(comm, config.solver.direct_solver_limit,
                                                config.solver.balance_tolerance, config.contact.field_count,
                                                config.grid.quadrature);
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
                                          grid_->quadrature(), &ownership);
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

  // 1. Locate particles: shape-function stencils at x_p^n (in their body's
  // velocity field when bodies are in contact with each other).
  const ContactConfig& contact = config_.contact;
  std::vector<Stencil<dim>>& stencils = stencils_;
  compute_stencils(*grid_, *particles_, stencils, contact.field_count > 1 ? contact.body_field : std::vector<int>());
  // 2. P2G: nodal mass and momentum (and v^n).
  GridFields<dim> fields;
  particles_to_grid(*grid_, *particles_, stencils, config_.transfer.scheme, fields, contact.field_count);
  report.transfer_seconds = seconds_since(t0);

  const auto t1 = std::chrono::steady_clock::now();
  // Rigid bodies (docs/contact.md#rigid-bodies): mass, inertia and motion
  // q^n from their particles.
  std::vector<char> rigid_flags(config_.bodies.size(), 0);
  for (std::size_t b = 0; b < config_.bodies.size(); ++b) rigid_flags[b] = config_.bodies[b].rigid;
  std::vector<RigidBody<dim>> rigid = rigid_bodies(*particles_, rigid_flags, contact.body_field, comm_);
  std::vector<int> rigid_of_field;
  if (!rigid.empty()) {
    rigid_of_field.assign(contact.field_count, -1);
    for (std::size_t k = 0; k < rigid.size(); ++k) rigid_of_field[rigid[k].field] = static_cast<int>(k);
  }
  // 3. Unknowns: velocities of the active grid points (and the rigid
  // bodies' motions, two blocks each).
  ActiveSet<dim> active;
  active.build(*grid_, fields, mass_threshold_, config_.faces, 2 * static_cast<int>(rigid.size()));
  for (std::size_t k = 0; k < rigid.size(); ++k) rigid[k].block = active.extra_first() + 2 * static_cast<PetscInt>(k);
  if (rigid.size() > 1) {
    // Two rigid bodies on one grid point are not held apart (contact.md#rigid-bodies): counted for a warning.
    PetscInt overlap = 0;
    const int points = grid_->ghosted_count();
    for (const int node : active.owned_points()) {
      if (rigid_of_field[node / points] < 0) continue;
      for (int f = node / points + 1; f < contact.field_count; ++f)
        overlap += rigid_of_field[f] >= 0 && active.compact_index(f * points + node % points) >= 0;
    }
    MPI_Allreduce(&overlap, &report.rigid_overlap_points, 1, MPIU_INT, MPI_SUM, comm_);
  }
  report.active_points = active.global_count();
  last_system_size_ = active.global_count() * dim;
  // 4. Contact candidates: active points whose predicted gap to an obstacle
  // is closed, and points where two bodies are predicted to touch.
  const auto tc = std::chrono::steady_clock::now();
  std::vector<ContactPoint<dim>> contacts =
      find_contact_candidates(*grid_, *particles_, stencils, fields, active, obstacles_, time_, h, contact.gap_prediction,
                              rigid_of_field, forced_contacts_.empty() ? nullptr : &forced_contacts_);
  std::vector<BodyContactPoint<dim>> body_contacts =
      find_body_contacts(*grid_, *particles_, stencils, fields, active, contact, contacts, h, rigid_of_field);
  report.contact_seconds = seconds_since(tc);
  if (equilibrium_stage_ && config_.equilibrium.stick) {
    // `contact: stick`: the bodies are held where they touch an obstacle or a
    // frictional face, as on the fixed base of a gravity-loading step.
    // A rigid body's contact points stay contacts (its equations hold it).
    std::vector<ContactPoint<dim>> kept;
    for (const ContactPoint<dim>& cp : contacts)
      if (cp.rigid >= 0)
        kept.push_back(cp);
      else
        active.constrain(cp.point);
    contacts = std::move(kept);
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
  fields.pseudo_time = equilibrium_stage_;
  // Without a last acceleration (the first step, after a re-partition) the
  // time-error estimate starts from the stresses' acceleration at t^n; not in
  // a quasi-static step, whose user asks for its equilibrium rather than its
  // dynamics (docs/solver.md#the-tolerance-follows-the-time-error).
  const double wave_cells = h * p_wave_speed_ / grid_->cell_size();  // cells a P-wave crosses in the step
  if (!equilibrium_stage_ && last_acceleration_.empty() && wave_cells < NewtonSolver<dim>::quasi_static_wave_cells)
    fields.start_acceleration = stress_acceleration(*grid_, *particles_, stencils, fields, gravity_);
  {
    PetscInt local = static_cast<PetscInt>(body_contacts.size());
    MPI_Allreduce(&local, &report.body_contact_points, 1, MPIU_INT, MPI_SUM, comm_);
  }
  MomentumSystem<dim> system(*grid_, *particles_, stencils, fields, active, materials_, gravity_, h, theta,
                             std::move(contacts), std::move(body_contacts), std::move(rigid));
  system.set_strain_increment(config_.time.strain_increment);
  system.use_workspace(momentum_workspace_);
  // The ghost penalty (docs/solver.md#ghost-penalty): the grid functions
  // that particles barely touch at a body's edge get a stiffness tied to
  // their neighbours. Not in the equilibrium stage (its accumulated form
  // carries load that the run then releases; docs/equilibrium.md).
  std::unique_ptr<GhostPenalty<dim>> ghost;
  if (!equilibrium_stage_ && config_.solver.ghost_penalty > 0) {
    const double t = time_;
    auto inside_obstacle = [this, t](const Vector<dim>& x) {
      for (const Obstacle<dim>& o : obstacles_)
        if (o.gap(x, t).gap <= 0.0) return true;
      return false;
    };
    // Contact points (with obstacles, faces, other bodies) are held by
    // their contact condition.
    std::vector<char> held(fields.mass.size(), 0);
    for (const auto& cp : system.contacts()) held[cp.point] = 1;
    for (const auto& cp : system.body_contacts()) held[cp.node_a] = held[cp.node_b] = 1;
    // A rigid body's points are held by its rigid motion.
    for (std::size_t node = 0; node < held.size() && !rigid_of_field.empty(); ++node)
      if (rigid_of_field[fields.field_of(static_cast<int>(node))] >= 0) held[node] = 1;
    ghost = std::make_unique<GhostPenalty<dim>>(*grid_, *particles_, stencils, fields, active, materials_,
                                                config_.solver.ghost_penalty, inside_obstacle, &held);
    system.set_ghost_penalty(ghost.get());
    report.ghost_cells = ghost->global_cells();
  }
  if (active.global_count() > 0) {
    // How static the step is for the linear solver: the cells a P-wave
    // crosses in it (docs/solver.md#geometric-multigrid).
    newton_->set_wave_cells(wave_cells);
    report.newton = newton_->solve(system);
  } else {
    report.newton.converged = true;
    report.newton.reason = "no active grid points";
  }
  report.solve_seconds = seconds_since(t1);
  report.contact_seconds += system.contact_seconds();
  report.material_seconds = system.material_seconds();
  report.assembly_seconds = system.assembly_seconds();
  report.operator_seconds = system.operator_seconds();
  report.linear_seconds = report.newton.linear_seconds;
  if (!report.newton.converged) return report;
  if (!equilibrium_stage_ && !obstacles_.empty()) {
    // The contact set must hold at the end of the step. A point whose
    // material's gap was open at t^n and not predicted to close (a body at
    // rest a hair away from a wall, whose stress then pushes it across)
    // is missed: the material moves into the obstacle within the step, and
    // the velocity-level condition of the next steps only stops it there,
    // relieved. Such points become contact points and the step is solved
    // again (at most twice), as an active-set iteration
    // (docs/contact.md#which-grid-points-are-contact-points).
    const auto tm = std::chrono::steady_clock::now();
    const long local =
        flag_missed_contacts(*grid_, *particles_, stencils, fields, active, obstacles_, time_, h, theta,
                             system.end_velocity(), system.start_velocity(), system.contacts(), forced_contacts_,
                             rigid_of_field);
    long missed = 0;
    MPI_Allreduce(&local, &missed, 1, MPI_LONG, MPI_SUM, comm_);
    const double check_seconds = seconds_since(tm);
    report.contact_seconds += check_seconds;
    report.solve_seconds += check_seconds;
    if (missed > 0 && contact_resolve_depth_ < 2) {
      ++contact_resolve_depth_;
      StepReport again = advance(h);
      if (--contact_resolve_depth_ == 0) forced_contacts_.clear();
      again.contact_resolves += 1;
      again.newton.iterations += report.newton.iterations;
      again.newton.linear_iterations += report.newton.linear_iterations;
      again.newton.factorizations += report.newton.factorizations;
      again.newton.jacobian_matrices += report.newton.jacobian_matrices;
      again.newton.block_diagonals += report.newton.block_diagonals;
      again.solve_seconds += report.solve_seconds;
      again.transfer_seconds += report.transfer_seconds;
      return again;
    }
    if (contact_resolve_depth_ == 0) forced_contacts_.clear();
  }
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
    // The step's motion must not invert a particle's neighbourhood:
    // det(I + h grad v_theta) > 0, or F^{n+1} loses det F > 0. A step longer
    // than the material's motion allows (a layer driven through a no-slip
    // floor within one step) is cut back like one that Newton could not
    // solve (docs/solver.md#inverting-steps).
    const std::vector<char> rigid = rigid_particles(system);
    const long local = count_inverting_particles(stencils, system.end_velocity(), system.start_velocity(), h, theta,
                                                 rigid.empty() ? nullptr : &rigid);
    MPI_Allreduce(&local, &report.inverting_particles, 1, MPI_LONG, MPI_SUM, comm_);
    if (report.inverting_particles > 0) {
      report.newton.reason = "the step inverts " + std::to_string(report.inverting_particles) +
                             " particles, det(I + h grad v) <= 0";
      return report;
    }
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
  // A rigid body's particles move with the body's motion, rotated exactly.
  const std::vector<char> rigid_particle = rigid_particles(system);
  const std::vector<char>* skip = rigid_particle.empty() ? nullptr : &rigid_particle;
  // The packing of the step's start, before G2P changes the volumes.
  const double packing_rate = config_.transfer.packing_correction;
  const auto faces_that_are = [&](FaceCondition condition) {
    std::array<bool, 2 * dim> faces;
    for (int f = 0; f < 2 * dim; ++f) faces[f] = config_.faces[f] == condition;
    return faces;
  };
  std::vector<double> packing =
      packing_rate > 0
          ? particle_packing(*grid_, *particles_, stencils, packing_lattice_, faces_that_are(FaceCondition::free),
                             fields.field_count)
          : std::vector<double>();
  if (packing_rate > 0) leave_out_sticking_contacts(system, fields.field_count, packing);
  grid_to_particles(*particles_, stencils, system.end_velocity(), system.start_velocity(), fields.velocity, h,
                    theta, config_.transfer, skip);
  move_rigid_particles(*particles_, system.rigid_bodies(), system.rigid_motion(), h);
  if (packing_rate > 0) {
    // Particles crowded beyond their volumes move apart (docs/transfers.md#packing);
    // gravity's work on the shift enters the energy balance as correction work.
    double largest = 0.0;
    const std::vector<double> normals = contact_normals(system, fields.field_count);
    correction_work_ += correct_packing(*particles_, stencils, packing, *grid_, packing_rate, gravity_, largest, skip,
                                        faces_that_are(FaceCondition::frictional),
                                        normals.empty() ? nullptr : &normals);
  }
  commit_material_state(system);
  check_finite();
  keep_particles_inside();
  particles_->migrate(*grid_);
  time_ += h;
  return seconds_since(t2);
}

// The unit normal of the step's contact points per ghosted node (dim values
// each, 0 where there is none), complete on every rank; empty in a scene
// without obstacles or bodies in contact. The packing correction moves the
// particles next to them along the contact only: the contact closes on the
// particles' gap, so they crowd its nodes, and a shift across it would be
// undone by the next step's contact, turning the shift into motion
// (docs/transfers.md#packing).
template <int dim>
std::vector<double> Simulation<dim>::contact_normals(const MomentumSystem<dim>& system, int field_count) const {
  if (obstacles_.empty() && field_count == 1) return {};
  std::vector<double> normals(static_cast<std::size_t>(field_count) * grid_->ghosted_count() * dim, 0.0);
  const auto set = [&](int node, const Vector<dim>& n) {
    Eigen::Map<Vector<dim>> slot(normals.data() + static_cast<std::size_t>(dim) * node);
    if (slot.isZero()) slot = n.normalized();  // a hub paired with several bodies keeps the first
  };
  for (const ContactPoint<dim>& cp : system.contacts()) set(cp.point, cp.normal);
  for (const BodyContactPoint<dim>& cp : system.body_contacts()) {
    set(cp.node_a, cp.normal);
    set(cp.node_b, cp.normal);
  }
  return grid_->sum_over_ranks(normals, field_count, dim);
}

// The packing correction leaves out the crowding at the step's sticking
// contact points of obstacles and rigid bodies (inside the Coulomb cone: the
// contact holds the material there). The contact closes on the particles'
// gap, so its points read crowded however the deposit lies; shifted away
// from that crowding along the contact, the particles next to a floor that
// holds them crept along it at rest: 0.7 mm in 0.2 s on the reference
// column's deposit, at a cost of Newton iterations for every shift
// (docs/transfers.md#packing). Not at points where two deformable bodies
// stick: there it moved boulders_onto_wall's wall impulse by 79 %, further
// from the runs with 4 x 4 particles per cell.
template <int dim>
void Simulation<dim>::leave_out_sticking_contacts(const MomentumSystem<dim>& system, int field_count,
                                                  std::vector<double>& packing) const {
  if (obstacles_.empty() && field_count == 1) return;  // the same on every rank (sum_over_ranks)
  std::vector<double> sticking(packing.size(), 0.0);
  const auto& maps = system.contact_maps();
  for (std::size_t c = 0; c < system.contacts().size() && c < maps.size(); ++c)
    if (maps[c].region == ConeRegion::inside) sticking[system.contacts()[c].point] = 1.0;
  sticking = grid_->sum_over_ranks(sticking, field_count, 1);
  for (std::size_t i = 0; i < packing.size(); ++i)
    if (sticking[i] > 0.0) packing[i] = 0.0;
}

// Per local particle: 1 if it belongs to a rigid body; empty without rigid bodies.
template <int dim>
std::vector<char> Simulation<dim>::rigid_particles(const MomentumSystem<dim>& system) const {
  std::vector<char> rigid;
  if (system.rigid_bodies().empty()) return rigid;
  FieldView<PetscInt> body(particles_->swarm(), field::body_id);
  rigid.resize(particles_->local_count());
  for (std::size_t p = 0; p < rigid.size(); ++p) rigid[p] = config_.bodies[body[p]].rigid;
  return rigid;
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
    FieldView<PetscReal> x(sw, field::position), v(sw, field::velocity), s(sw, field::stress),
        F(sw, field::deformation_gradient), J(sw, field::volume_ratio);
    for (PetscInt p = 0; p < n && !bad; ++p) {
      for (int a = 0; a < dim; ++a) bad |= !std::isfinite(x[dim * p + a]) || !std::isfinite(v[dim * p + a]);
      for (int i = 0; i < 6; ++i) bad |= !std::isfinite(s[6 * p + i]);
      for (int i = 0; i < dim * dim; ++i) bad |= !std::isfinite(F[dim * dim * p + i]);
      // An inverted particle (J <= 0): the implicit step cuts back before it
      // happens; an explicit step that inverts one stops here.
      if (!bad && !(J[p] > 0.0 && std::isfinite(J[p]))) bad = 2;
    }
  }
  int any = 0;
  MPI_Allreduce(&bad, &any, 1, MPI_INT, MPI_MAX, comm_);
  if (any == 1)
    throw SimulationError("a particle position, velocity, stress or deformation gradient is not finite after the step "
                          "ending at t = " +
                          number_text(time_) + "; the run stops (the last output is the last good state)");
  if (any == 2)
    throw SimulationError("a particle is inverted (volume ratio J <= 0) after the step ending at t = " +
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

template class Simulation<2>;
template class Simulation<3>;

}  // namespace talus
