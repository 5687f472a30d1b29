// What a step leaves for the output (docs/output.md): the contact forces per
// obstacle and per point, the grid points of output.grid, the rows of
// obstacle_forces.csv and the peak loads of the run summary.
#include "talus/simulation.hpp"

namespace talus {

template <int dim>
void Simulation<dim>::record_contact_forces(const std::vector<ContactPoint<dim>>& contacts,
                                           const std::vector<Vector<dim>>& impulses,
                                           const std::vector<NaturalMap<dim>>& maps, double h) {
  nodal_contacts_.clear();
  // Per obstacle, then (several velocity fields) per obstacle and field.
  const int fields = config_.contact.field_count, points = grid_->ghosted_count();
  const std::size_t by_field = fields > 1 ? obstacles_.size() * fields * dim : 0;
  std::vector<double> local(obstacles_.size() * dim + by_field, 0.0), total(local.size(), 0.0);
  for (std::size_t c = 0; c < contacts.size(); ++c) {
    const Vector<dim> force = impulses[c] / h;
    const int o = contacts[c].obstacle, point = contacts[c].point % points, field = contacts[c].point / points;
    for (int a = 0; a < dim; ++a) local[o * dim + a] += force[a];
    if (by_field)
      for (int a = 0; a < dim; ++a) local[obstacles_.size() * dim + (o * fields + field) * dim + a] += force[a];
    // A rigid body's impulse acts at its surface point (docs/contact.md#rigid-bodies).
    const Vector<dim> at = contacts[c].rigid >= 0 ? contacts[c].surface : grid_->point_position(grid_->global_index(point));
    nodal_contacts_.push_back({at, force, o, maps[c].region});
  }
  if (!obstacles_.empty())
    MPI_Allreduce(local.data(), total.data(), static_cast<int>(local.size()), MPI_DOUBLE, MPI_SUM, comm_);
  for (std::size_t o = 0; o < obstacles_.size(); ++o)
    obstacle_force_[o] = Eigen::Map<const Vector<dim>>(total.data() + dim * o);
  obstacle_field_force_.assign(by_field / dim, Vector<dim>::Zero());
  for (std::size_t k = 0; k < obstacle_field_force_.size(); ++k)
    obstacle_field_force_[k] = Eigen::Map<const Vector<dim>>(total.data() + obstacles_.size() * dim + dim * k);
}

template <int dim>
void Simulation<dim>::record_grid_points(const GridFields<dim>& fields, const std::vector<double>& velocity,
                                         const MomentumSystem<dim>* system, double h) {
  PointCloud& cloud = grid_points_;
  cloud = PointCloud{};
  cloud.arrays = {{"mass", 1, false, {}},
                  {"velocity", 3, false, {}},
                  {"contact_force", 3, false, {}},
                  {"active", 1, true, {}}};
  cloud.vectors = "velocity";
  auto& mass = cloud.arrays[0].values;
  auto& v = cloud.arrays[1].values;
  auto& force = cloud.arrays[2].values;
  auto& active = cloud.arrays[3].values;
  // One cloud point per node: with bodies in contact, one per velocity field at a grid point.
  const int points = grid_->ghosted_count(), n = static_cast<int>(fields.mass.size());
  std::vector<int> slot(static_cast<std::size_t>(n), -1);  // ghosted node -> point of the cloud
  for (int i = 0; i < n; ++i) {
    const auto ijk = grid_->global_index(i % points);
    if (!(fields.mass[i] > 0.0) || !grid_->is_owned(ijk)) continue;
    slot[i] = static_cast<int>(cloud.points.size());
    const Vector<dim> x = grid_->point_position(ijk);
    std::array<double, 3> p{0.0, 0.0, 0.0};
    for (int a = 0; a < dim; ++a) p[a] = x[a];
    cloud.points.push_back(p);
    mass.push_back(fields.mass[i]);
    for (int a = 0; a < 3; ++a) v.push_back(a < dim ? velocity[dim * i + a] : 0.0);
    force.insert(force.end(), 3, 0.0);
    // The unknowns of the step: the points above the active-mass threshold (ActiveSet::build).
    active.push_back(fields.mass[i] > mass_threshold_ ? 1.0 : 0.0);
  }
  if (!system) return;
  const auto& contacts = system->contacts();
  for (std::size_t c = 0; c < contacts.size(); ++c) {
    const int k = slot[contacts[c].point];
    if (k < 0) continue;  // a contact point always carries mass: not reached
    // As in contacts.pvd: the force on the obstacle, -r_i / h.
    const Vector<dim> f = system->contact_impulses()[c] / h;
    for (int a = 0; a < dim; ++a) force[3 * static_cast<std::size_t>(k) + a] = 0.0 - f[a];
  }
}

template <int dim>
void Simulation<dim>::record_initial_grid_points() {
  std::vector<Stencil<dim>> stencils;
  compute_stencils(*grid_, *particles_, stencils);
  GridFields<dim> fields;
  particles_to_grid(*grid_, *particles_, stencils, config_.transfer.scheme, fields);
  record_grid_points(fields, fields.velocity, nullptr, 0.0);
}

template <int dim>
std::vector<ContactSample<dim>> Simulation<dim>::contact_samples() const {
  std::vector<ContactSample<dim>> samples;
  samples.reserve(nodal_contacts_.size());
  for (const NodalContact& c : nodal_contacts_) {
    // 0 sticking (inside the cone), 1 separating (polar cone: r = 0), 2 sliding (on its boundary).
    const int state = c.region == ConeRegion::inside ? 0 : c.region == ConeRegion::polar ? 1 : 2;
    samples.push_back({c.position, Vector<dim>(Vector<dim>::Zero() - c.force), c.obstacle, state});
  }
  return samples;
}

template <int dim>
std::vector<std::string> Simulation<dim>::force_columns() const {
  // Four blocks of one column per obstacle and axis, the force first (as the
  // table had before, so that its columns keep their places); N and N s in
  // 3D, per m of thickness in 2D.
  const std::string force = dim == 2 ? " [N/m]" : " [N]", impulse = dim == 2 ? " [N s/m]" : " [N s]";
  const std::pair<const char*, std::string> blocks[4] = {
      {"_f", force}, {"_impulse_", impulse}, {"_cumulative_impulse_", impulse}, {"_window_f", force}};
  std::vector<std::string> columns;
  for (const auto& [stem, unit] : blocks)
    for (const Obstacle<dim>& o : obstacles_)
      for (int a = 0; a < dim; ++a) columns.push_back(o.name() + stem + "xyz"[a] + unit);
  // With bodies in contact, a fifth block: the force of each velocity
  // field's bodies (named by the field's body, `unpaired` for the bodies in
  // no pair), so that a boulder's load on a wall is told from the debris's.
  const ContactConfig& contact = config_.contact;
  if (contact.field_count > 1)
    for (const Obstacle<dim>& o : obstacles_)
      for (int f = 0; f < contact.field_count; ++f) {
        std::string name = "unpaired";
        for (const BodyContactPair& p : contact.body_pairs)
          for (const int b : {p.body_a, p.body_b})
            if (contact.body_field[b] == f) name = config_.bodies[b].name;
        for (int a = 0; a < dim; ++a) columns.push_back(o.name() + "_f_by_" + name + "_" + "xyz"[a] + force);
      }
  return columns;
}

template <int dim>
std::vector<double> Simulation<dim>::force_table_row() const {
  std::vector<double> row = force_row();
  for (const auto* block : {&loads_.step_impulse(), &loads_.total_impulse(), &loads_.window_force()})
    row.insert(row.end(), block->begin(), block->end());
  for (const Vector<dim>& f : obstacle_field_force_)
    for (int a = 0; a < dim; ++a) row.push_back(0.0 - f[a]);  // on the obstacle, as force_row()
  return row;
}

template <int dim>
std::vector<RunSummary::PeakLoad> Simulation<dim>::peak_loads() const {
  std::vector<RunSummary::PeakLoad> peaks;
  for (std::size_t o = 0; o < obstacles_.size(); ++o)
    peaks.push_back({obstacles_[o].name(), loads_.peak_force()[o], loads_.peak_time()[o]});
  return peaks;
}

template <int dim>
std::vector<double> Simulation<dim>::force_row() const {
  std::vector<double> row;
  for (const Vector<dim>& f : obstacle_force_)
    // On the obstacle: minus the force on the body (0.0 - f: +0, not -0, where nothing touches).
    for (int a = 0; a < dim; ++a) row.push_back(0.0 - f[a]);
  return row;
}

template <int dim>
std::vector<typename Simulation<dim>::BodyMotion> Simulation<dim>::body_motion() const {
  const std::size_t bodies = config_.bodies.size();
  // Two passes of sums over all ranks: mass and momentum moments, then the
  // angular momentum and inertia about the centres.
  std::vector<double> first(bodies * (1 + 2 * dim), 0.0), first_all(first.size());
  DM sw = particles_->swarm();
  FieldView<PetscReal> x(sw, field::position), v(sw, field::velocity), m(sw, field::mass);
  FieldView<PetscInt> body(sw, field::body_id);
  const PetscInt n = particles_->local_count();
  for (PetscInt p = 0; p < n; ++p) {
    double* s = first.data() + body[p] * (1 + 2 * dim);
    s[0] += m[p];
    for (int a = 0; a < dim; ++a) s[1 + a] += m[p] * x[dim * p + a], s[1 + dim + a] += m[p] * v[dim * p + a];
  }
  MPI_Allreduce(first.data(), first_all.data(), static_cast<int>(first.size()), MPI_DOUBLE, MPI_SUM, comm_);
  std::vector<BodyMotion> motion(bodies);
  for (std::size_t b = 0; b < bodies; ++b) {
    const double* s = first_all.data() + b * (1 + 2 * dim);
    const double mass = s[0] > 0 ? s[0] : 1.0;
    for (int a = 0; a < dim; ++a) motion[b].centre[a] = s[1 + a] / mass, motion[b].velocity[a] = s[1 + dim + a] / mass;
  }
  // Angular momentum L (3) and inertia tensor (9) per body, in 3D
  // components (2D: in the plane, L and I about z).
  std::vector<double> second(bodies * 12, 0.0), second_all(second.size());
  for (PetscInt p = 0; p < n; ++p) {
    Eigen::Vector3d r = Eigen::Vector3d::Zero(), u = Eigen::Vector3d::Zero();
    for (int a = 0; a < dim; ++a)
      r[a] = x[dim * p + a] - motion[body[p]].centre[a], u[a] = v[dim * p + a] - motion[body[p]].velocity[a];
    double* s = second.data() + body[p] * 12;
    Eigen::Map<Eigen::Vector3d>(s) += m[p] * r.cross(u);
    Eigen::Map<Eigen::Matrix3d>(s + 3) += m[p] * (r.squaredNorm() * Eigen::Matrix3d::Identity() - r * r.transpose());
  }
  MPI_Allreduce(second.data(), second_all.data(), static_cast<int>(second.size()), MPI_DOUBLE, MPI_SUM, comm_);
  for (std::size_t b = 0; b < bodies; ++b) {
    const Eigen::Map<const Eigen::Vector3d> L(second_all.data() + b * 12);
    const Eigen::Map<const Eigen::Matrix3d> I(second_all.data() + b * 12 + 3);
    motion[b].angular_velocity.setZero();
    if constexpr (dim == 2) {
      if (I(2, 2) > 0) motion[b].angular_velocity[2] = L[2] / I(2, 2);
    } else {
      // A body of one particle (or collinear ones) has a singular inertia:
      // the least-squares rotation.
      motion[b].angular_velocity = I.completeOrthogonalDecomposition().solve(L);
    }
  }
  return motion;
}

template <int dim>
std::vector<std::string> Simulation<dim>::body_motion_columns() const {
  std::vector<std::string> columns;
  for (const BodyConfig& b : config_.bodies) {
    for (int a = 0; a < dim; ++a) columns.push_back(b.name + "_" + "xyz"[a] + " [m]");
    for (int a = 0; a < dim; ++a) columns.push_back(b.name + "_v" + "xyz"[a] + " [m/s]");
    if (dim == 2)
      columns.push_back(b.name + "_omega [rad/s]");
    else
      for (int a = 0; a < 3; ++a) columns.push_back(b.name + "_omega_" + "xyz"[a] + " [rad/s]");
  }
  return columns;
}

template <int dim>
std::vector<double> Simulation<dim>::body_motion_row() const {
  std::vector<double> row;
  for (const BodyMotion& m : body_motion()) {
    for (int a = 0; a < dim; ++a) row.push_back(m.centre[a]);
    for (int a = 0; a < dim; ++a) row.push_back(m.velocity[a]);
    if (dim == 2)
      row.push_back(m.angular_velocity[2]);
    else
      for (int a = 0; a < 3; ++a) row.push_back(m.angular_velocity[a]);
  }
  return row;
}

template std::vector<Simulation<2>::BodyMotion> Simulation<2>::body_motion() const;
template std::vector<Simulation<3>::BodyMotion> Simulation<3>::body_motion() const;
template std::vector<std::string> Simulation<2>::body_motion_columns() const;
template std::vector<std::string> Simulation<3>::body_motion_columns() const;
template std::vector<double> Simulation<2>::body_motion_row() const;
template std::vector<double> Simulation<3>::body_motion_row() const;

template void Simulation<2>::record_contact_forces(const std::vector<ContactPoint<2>>&, const std::vector<Vector<2>>&,
                                                  const std::vector<NaturalMap<2>>&, double);
template void Simulation<3>::record_contact_forces(const std::vector<ContactPoint<3>>&, const std::vector<Vector<3>>&,
                                                  const std::vector<NaturalMap<3>>&, double);
template void Simulation<2>::record_grid_points(const GridFields<2>&, const std::vector<double>&,
                                               const MomentumSystem<2>*, double);
template void Simulation<3>::record_grid_points(const GridFields<3>&, const std::vector<double>&,
                                               const MomentumSystem<3>*, double);
template void Simulation<2>::record_initial_grid_points();
template void Simulation<3>::record_initial_grid_points();
template std::vector<ContactSample<2>> Simulation<2>::contact_samples() const;
template std::vector<ContactSample<3>> Simulation<3>::contact_samples() const;
template std::vector<std::string> Simulation<2>::force_columns() const;
template std::vector<std::string> Simulation<3>::force_columns() const;
template std::vector<double> Simulation<2>::force_row() const;
template std::vector<double> Simulation<3>::force_row() const;
template std::vector<double> Simulation<2>::force_table_row() const;
template std::vector<double> Simulation<3>::force_table_row() const;
template std::vector<RunSummary::PeakLoad> Simulation<2>::peak_loads() const;
template std::vector<RunSummary::PeakLoad> Simulation<3>::peak_loads() const;

}  // namespace talus
