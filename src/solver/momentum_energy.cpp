// The energy terms of one implicit step (docs/energy.md), from the step's
// own velocities, stresses, contact impulses and ghost penalty.
#include "talus/solver/momentum_system.hpp"

namespace talus {

template <int dim>
StepEnergy MomentumSystem<dim>::step_energy(double stress_weight, double velocity_weight,
                                            const std::vector<Tangent>& compliance,
                                            const std::vector<ContactPoint<dim>>& contacts,
                                            const std::vector<Vector<dim>>& impulses,
                                            const std::vector<BodyContactPoint<dim>>* body_contacts,
                                            const std::vector<Vector<dim>>* body_impulses) const {
  StepEnergy e;
  // Grid: m (v^{n+1} - v^n) . v^w = (1/2) m (|v^{n+1}|^2 - |v^n|^2) + (w - 1/2) m |dv|^2
  // on every free component; a constrained component loses (1/2) m (v^n)^2
  // of the P2G velocity at once (its row is m v = 0).
  for (const int i : active_.owned_points()) {
    if (rigid_node(i)) continue;  // a rigid body's energy is its motion q's (below)
    const double m = fields_.mass[i];
    for (int c = 0; c < dim; ++c) {
      const std::size_t k = static_cast<std::size_t>(dim) * i + c;
      if (active_.constrained(i, c)) {
        e.terms.faces += 0.5 * m * fields_.velocity[k] * fields_.velocity[k];
        continue;
      }
      const double v0 = velocity_old_[k], v1 = velocity_[k];
      e.grid_kinetic_start += 0.5 * m * v0 * v0;
      e.grid_kinetic_end += 0.5 * m * v1 * v1;
      e.terms.time_integration += (velocity_weight - 0.5) * m * (v1 - v0) * (v1 - v0);
    }
  }
  // Particles: V0 tau^w : d eps = dE + (w - 1/2) V0 d tau : C^-1 : d tau
  // + V0 tau^w : (d eps_p + d(closed voids) I / 3) - V0 tau^w : C^-1 : (sigma* - sigma^n)
  // (the last: the Jaumann rotation, work-free to first order only).
  for (std::size_t p = 0; p < stress_end_.size(); ++p) {
    const Voigt dtau = stress_end_[p] - stress_old_[p];
    const Voigt tau_w = (1.0 - stress_weight) * stress_old_[p] + stress_weight * stress_end_[p];
    const double V0 = reference_volume_[p];
    const Tangent& S = compliance[material_[p]];
    // The Jaumann rotation sigma* - sigma^n is work-free only to first
    // order: its second-order work counts with the time integration.
    e.terms.time_integration += (stress_weight - 0.5) * V0 * dtau.dot(S * dtau) +
                                V0 * tau_w.dot(S * (stress_old_[p] - rotated_stress_[p]));
    // The return mapping's inelastic strain C^-1 (trial - sigma) includes the
    // voids it opens; the voids closed before the material saw the strain
    // are the strain's other inelastic part.
    e.terms.plastic += V0 * (tau_w.dot(plastic_increment_[p]) + tau_w.head<3>().sum() / 3.0 * closed_voids_[p]);
  }
  if (ghost_) {
    // The ghost penalty's impulse h K (h v_theta) works on v^w: numerical
    // dissipation, counted with the time integration's (docs/energy.md).
    std::vector<double> u, Ku(velocity_.size(), 0.0);
    step_displacement(u);
    ghost_->add_product(u, Ku, h_);
    for (std::size_t k = 0; k < u.size(); ++k)
      e.terms.time_integration += Ku[k] * ((1.0 - velocity_weight) * velocity_old_[k] + velocity_weight * velocity_[k]);
  }
  // Rigid bodies: G (q - q^n) = h (M g, 0) + sum T^T r times q is
  // (1/2) q G q - (1/2) q^n G q^n + (1/2) dq G dq = h M g . V + sum r . T q:
  // the kinetic energy of q, the backward-Euler dissipation of its rows,
  // and the contact work at the surface points T q (below). Counted once,
  // by the rank that owns q.
  int rank = 0, size = 1;
  MPI_Comm_rank(grid_.comm(), &rank);
  MPI_Comm_size(grid_.comm(), &size);
  for (std::size_t b = 0; b < rigid_.size() && rank == size - 1; ++b) {
    const typename RigidBody<dim>::Inertia G = rigid_[b].generalized_mass();
    const typename RigidBody<dim>::Motion dq = motion_[b] - rigid_[b].start;
    e.grid_kinetic_start += 0.5 * rigid_[b].start.dot(G * rigid_[b].start);
    e.grid_kinetic_end += 0.5 * motion_[b].dot(G * motion_[b]);
    e.terms.time_integration += 0.5 * dq.dot(G * dq);
  }
  // Contact points: the impulse r the obstacle gives works on v^w (a rigid
  // body's: on its velocity at the surface point, T(x_s) q).
  for (std::size_t c = 0; c < contacts.size(); ++c) {
    const int i = contacts[c].point;
    Vector<dim> v;
    for (int a = 0; a < dim; ++a)
      v[a] = (1.0 - velocity_weight) * velocity_old_[dim * i + a] + velocity_weight * velocity_[dim * i + a];
    if (contacts[c].rigid >= 0) v = rigid_[contacts[c].rigid].velocity_map(contacts[c].surface) * motion_[contacts[c].rigid];
    e.terms.contact -= impulses[c].dot(v - contacts[c].obstacle_velocity);
    e.terms.obstacle_work += impulses[c].dot(contacts[c].obstacle_velocity);
  }
  // Bodies in contact: r on a, -r on b, work r . (v_a - v_b)^w (<= 0: friction).
  const auto& bodies = body_contacts ? *body_contacts : body_contacts_;
  const auto& body_r = body_impulses ? *body_impulses : body_impulse_;
  for (std::size_t c = 0; c < bodies.size(); ++c) {
    const BodyContactPoint<dim>& cp = bodies[c];
    Vector<dim> u;
    for (int a = 0; a < dim; ++a) {
      const std::size_t ka = static_cast<std::size_t>(dim) * cp.node_a + a, kb = static_cast<std::size_t>(dim) * cp.node_b + a;
      u[a] = (1.0 - velocity_weight) * (velocity_old_[ka] - velocity_old_[kb]) +
             velocity_weight * (velocity_[ka] - velocity_[kb]);
    }
    e.terms.contact -= body_r[c].dot(u);
  }
  return e;
}

template StepEnergy MomentumSystem<2>::step_energy(double, double, const std::vector<Tangent>&,
                                                   const std::vector<ContactPoint<2>>&, const std::vector<Vector<2>>&,
                                                   const std::vector<BodyContactPoint<2>>*,
                                                   const std::vector<Vector<2>>*) const;
template StepEnergy MomentumSystem<3>::step_energy(double, double, const std::vector<Tangent>&,
                                                   const std::vector<ContactPoint<3>>&, const std::vector<Vector<3>>&,
                                                   const std::vector<BodyContactPoint<3>>*,
                                                   const std::vector<Vector<3>>*) const;

}  // namespace talus
