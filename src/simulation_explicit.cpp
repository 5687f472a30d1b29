// The explicit baseline (docs/explicit.md): symplectic Euler with the stress
// updated last (USL), on the same grid, transfers, return mappings, faces and
// obstacles as the implicit step.
//
//   m_i v_i^{n+1} = m_i v_i^n + h m_i g - h sum_p V0_p tau_p^n grad N_i(x_p^n)
//
// then faces and obstacles act on v^{n+1} (the grid-velocity projection onto
// the Coulomb cone), and sigma^{n+1} follows from L_p = sum_i v_i^{n+1} grad N_i
// by the same objective update and return mapping as the implicit step with
// theta = 1 (MomentumSystem, evaluated once, no Newton). The step is bounded
// by the CFL condition (time.step, time.cfl; checked when the case is read).
#include "talus/simulation.hpp"

#include <chrono>

namespace talus {

namespace {

// The Coulomb cone acting on a grid point's velocity relative to the
// obstacle, u = v - v_obstacle, in one explicit step: an approaching normal
// velocity u_N < -e u_N^n (e the restitution, u_N^n the normal velocity at
// the start of the step) is raised to -e u_N^n by a normal impulse p_N, and
// the tangential velocity is reduced by mu p_N / m, to zero if it is smaller
// (sticking). A separating point is left free. Returns the impulse the
// obstacle gives, m (u_new - u), and its region of the cone.
template <int dim>
Vector<dim> project_velocity(Vector<dim>& u, double mass, const ContactPoint<dim>& cp, ConeRegion& region) {
  const Vector<dim>& n = cp.normal;
  const double target = cp.start_normal_velocity < 0.0 ? -cp.restitution * cp.start_normal_velocity : 0.0;
  const double un = u.dot(n);
  if (un >= target) {
    region = ConeRegion::polar;
    return Vector<dim>::Zero();
  }
  const Vector<dim> before = u;
  const double dn = target - un;  // normal velocity change, p_N / m
  Vector<dim> ut = u - un * n;
  const double slip = ut.norm();
  if (slip <= cp.friction * dn) {
    ut.setZero();
    region = ConeRegion::inside;
  } else {
    ut *= 1.0 - cp.friction * dn / slip;
    region = ConeRegion::boundary;
  }
  u = ut + target * n;
  return mass * (u - before);
}

}  // namespace

template <int dim>
StepReport Simulation<dim>::advance_explicit(double h) {
  StepReport report;
  report.h = h;
  const double kinetic_start = local_particle_kinetic();
  const auto t0 = std::chrono::steady_clock::now();
  // 1. Stencils at x^n and 2. P2G: m_i and v_i^n (per velocity field with
  // bodies in contact).
  const ContactConfig& contact = config_.contact;
  std::vector<Stencil<dim>>& stencils = stencils_;
  compute_stencils(*grid_, *particles_, stencils, contact.field_count > 1 ? contact.body_field : std::vector<int>());
  GridFields<dim> fields;
  particles_to_grid(*grid_, *particles_, stencils, config_.transfer.scheme, fields, contact.field_count);
  report.transfer_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  const auto t1 = std::chrono::steady_clock::now();
  // 3. The grid points that carry the momentum equation (same threshold and
  // faces as the implicit step) and the contact candidates.
  ActiveSet<dim> active;
  active.build(*grid_, fields, mass_threshold_, config_.faces);
  report.active_points = active.global_count();
  std::vector<ContactPoint<dim>> contacts = find_contact_candidates(
      *grid_, *particles_, stencils, fields, active, obstacles_, time_, h, config_.contact.gap_prediction);
  std::vector<BodyContactPoint<dim>> body_contacts =
      find_body_contacts(*grid_, *particles_, stencils, fields, active, contact, contacts, h);
  {
    PetscInt local[2] = {static_cast<PetscInt>(contacts.size()), static_cast<PetscInt>(body_contacts.size())};
    PetscInt global[2];
    MPI_Allreduce(local, global, 2, MPIU_INT, MPI_SUM, comm_);
    report.contact_points = global[0];
    report.body_contact_points = global[1];
  }
  // theta = 1: the stress of the end of the step from L(v^{n+1}) (USL).
  MomentumSystem<dim> system(*grid_, *particles_, stencils, fields, active, materials_, gravity_, h, 1.0);
  system.set_strain_increment(config_.time.strain_increment);
  system.skip_tangents();

  // 4. The internal force of the stresses at t^n, summed over ranks on the
  // owners: f_i = -sum_p V0_p tau_p^n grad N_i (the stored stress is
  // Kirchhoff's, so the initial volume; docs/formulation.md).
  std::vector<double> force(fields.mass.size() * dim, 0.0);
  {
    DM sw = particles_->swarm();
    FieldView<PetscReal> stress(sw, field::stress), volume(sw, field::initial_volume);
    for (std::size_t p = 0; p < stencils.size(); ++p) {
      const Matrix<dim> tau =
          voigt_to_tensor(Eigen::Map<const Voigt>(stress.data() + 6 * p)).template topLeftCorner<dim, dim>();
      const Stencil<dim>& st = stencils[p];
      for (int k = 0; k < st.count; ++k)
        Eigen::Map<Vector<dim>>(force.data() + static_cast<std::size_t>(dim) * st.local[k]) -=
            volume[p] * (tau * st.gradient[k]);
    }
  }
  Vec v = active.create_vector();
  TALUS_PETSC(VecZeroEntries(v));
  active.add_to_compact(force, v);

  // 5. v^{n+1} = v^n + h (g + f / m) on the free components; faces hold
  // theirs at zero, obstacles project theirs onto the Coulomb cone.
  std::vector<Vector<dim>> impulses(contacts.size(), Vector<dim>::Zero());
  std::vector<Vector<dim>> body_impulses(body_contacts.size(), Vector<dim>::Zero());
  std::vector<NaturalMap<dim>> regions(contacts.size());
  {
    PetscScalar* x;
    TALUS_PETSC(VecGetArray(v, &x));
    const auto& owned = active.owned_points();
    const std::vector<double>& v_start = system.start_velocity();
    for (std::size_t k = 0; k < owned.size(); ++k) {
      const int i = owned[k];
      const double m = fields.mass[i];
      for (int c = 0; c < dim; ++c) {
        double& vc = x[dim * k + c];
        vc = active.constrained(i, c) ? 0.0 : v_start[dim * i + c] + h * (gravity_[c] + vc / m);
      }
    }
    for (std::size_t c = 0; c < contacts.size(); ++c) {
      const ContactPoint<dim>& cp = contacts[c];
      Vector<dim> u = Eigen::Map<const Vector<dim>>(x + cp.row) - cp.obstacle_velocity;
      for (int a = 0; a < dim; ++a)
        if (!cp.free[a]) u[a] = 0.0;
      const Vector<dim> impulse = project_velocity<dim>(u, fields.mass[cp.point], cp, regions[c].region);
      for (int a = 0; a < dim; ++a)
        if (cp.free[a]) {
          x[cp.row + a] = u[a] + cp.obstacle_velocity[a];
          impulses[c][a] = impulse[a];
        }
    }
    // Bodies in contact (docs/contact.md#bodies-in-contact): the relative
    // velocity u = v_a - v_b of a pair, when approaching, projected onto
    // the Coulomb cone with the reduced mass (Bardenhagen et al. 2001), the
    // impulse p given to a and -p to b: momentum is conserved. Pairs that
    // share a hub are projected one after the other.
    for (std::size_t c = 0; c < body_contacts.size(); ++c) {
      const BodyContactPoint<dim>& bc = body_contacts[c];
      ContactPoint<dim> cone;  // the cone seen from a: axis -n, no restitution
      cone.normal = -bc.normal;
      cone.friction = bc.friction;
      cone.start_normal_velocity = bc.start_normal_velocity;
      const double ma = fields.mass[bc.node_a], mb = fields.mass[bc.node_b];
      Eigen::Map<Vector<dim>> va(x + bc.row_a), vb(x + bc.row_b);
      Vector<dim> u = va - vb;
      ConeRegion region;
      const Vector<dim> p = project_velocity<dim>(u, ma * mb / (ma + mb), cone, region);
      va += p / ma;
      vb -= p / mb;
      body_impulses[c] = p;
    }
    TALUS_PETSC(VecRestoreArray(v, &x));
  }
  // 6. The stresses at the end of the step (one evaluation at v^{n+1}).
  system.finish(v);
  TALUS_PETSC(VecDestroy(&v));
  report.solve_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
  report.material_seconds = system.material_seconds();
  report.newton.converged = true;
  report.newton.reason = "explicit";

  record_contact_forces(contacts, impulses, regions, h);
  if (grid_output()) record_grid_points(fields, system.end_velocity(), nullptr, h);
  // 7. G2P with theta = 1 (x^{n+1} = x^n + h v^{n+1}: symplectic Euler) and
  // 8. the commit of sigma^{n+1}.
  report.transfer_seconds += complete_step(system, stencils, fields, h, 1.0);
  // The force used sigma^n (weight 0 of sigma^{n+1}), the strain and the
  // motion v^{n+1} (weight 1): docs/energy.md.
  account_energy(system.step_energy(0.0, 1.0, compliance_, contacts, impulses, &body_contacts, &body_impulses),
                 kinetic_start);
  report.converged = true;
  return report;
}

template StepReport Simulation<2>::advance_explicit(double);
template StepReport Simulation<3>::advance_explicit(double);

}  // namespace talus
