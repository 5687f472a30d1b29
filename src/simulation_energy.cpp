// The energy balance of a run (docs/energy.md, energy_balance.hpp): the
// particles' kinetic, gravitational and stored elastic energies, and the
// terms each step adds to the balance.
#include "talus/simulation.hpp"

#include <cmath>

namespace talus {

template <int dim>
double Simulation<dim>::local_particle_kinetic() const {
  DM sw = particles_->swarm();
  FieldView<PetscReal> m(sw, field::mass), v(sw, field::velocity);
  double kinetic = 0.0;
  for (PetscInt p = 0; p < particles_->local_count(); ++p)
    kinetic += 0.5 * m[p] * Eigen::Map<const Vector<dim>>(v.data() + dim * p).squaredNorm();
  return kinetic;
}

template <int dim>
ParticleEnergy Simulation<dim>::local_particle_energy() const {
  DM sw = particles_->swarm();
  FieldView<PetscReal> m(sw, field::mass), x(sw, field::position), v(sw, field::velocity), tau(sw, field::stress),
      volume(sw, field::initial_volume);
  FieldView<PetscInt> material(sw, field::material_id);
  ParticleEnergy e;
  for (PetscInt p = 0; p < particles_->local_count(); ++p) {
    e.kinetic += 0.5 * m[p] * Eigen::Map<const Vector<dim>>(v.data() + dim * p).squaredNorm();
    // G = -m g . x (zero at the origin); E = (1/2) V0 tau : C^-1 : tau, the
    // elastic part of the Kirchhoff stress (engineering shears in C^-1 tau).
    e.gravitational -= m[p] * gravity_.dot(Eigen::Map<const Vector<dim>>(x.data() + dim * p));
    const Eigen::Map<const Voigt> t(tau.data() + 6 * p);
    e.elastic += 0.5 * volume[p] * t.dot(compliance_[material[p]] * t);
  }
  return e;
}

template <int dim>
ParticleEnergy Simulation<dim>::particle_energy() const {
  const ParticleEnergy e = local_particle_energy();
  double local[3] = {e.kinetic, e.gravitational, e.elastic}, total[3];
  MPI_Allreduce(local, total, 3, MPI_DOUBLE, MPI_SUM, comm_);
  return {total[0], total[1], total[2]};
}

template <int dim>
void Simulation<dim>::account_energy(const StepEnergy& step, double kinetic_start) {
  // One reduction: the step's terms, the grid's kinetic energies, and the
  // particles' energies after G2P.
  const ParticleEnergy after = local_particle_energy();
  EnergyTerms step_terms = step.terms;
  step_terms.correction_work = correction_work_;  // from keep_particles_inside, this step
  correction_work_ = 0.0;
  const auto terms = step_terms.values();
  constexpr int n = EnergyTerms::count + 6;
  double local[n], total[n];
  for (int k = 0; k < EnergyTerms::count; ++k) local[k] = terms[k];
  const double extra[6] = {kinetic_start, step.grid_kinetic_start, step.grid_kinetic_end,
                           after.kinetic, after.gravitational, after.elastic};
  for (int k = 0; k < 6; ++k) local[EnergyTerms::count + k] = extra[k];
  MPI_Allreduce(local, total, n, MPI_DOUBLE, MPI_SUM, comm_);
  EnergyTerms added;
  added.plastic = total[0];
  added.contact = total[1];
  added.obstacle_work = total[2];
  added.faces = total[3];
  added.time_integration = total[5];
  added.correction_work = total[6];
  const double* k = total + EnergyTerms::count;
  // P2G keeps (grid start + faces) of the particles' kinetic energy; G2P
  // turns the grid's end energy into the particles' (docs/energy.md).
  added.transfer = (k[0] - k[1] - added.faces) + (k[2] - k[3]);
  energy_ += added;
  particle_energy_ = {k[3], k[4], k[5]};
}

template <int dim>
double Simulation<dim>::energy_balance_error() const {
  // Obstacle and correction work are done on the body: they enter with a minus sign.
  return particle_energy_.total() + energy_.dissipated() - initial_energy_;
}

template double Simulation<2>::local_particle_kinetic() const;
template double Simulation<3>::local_particle_kinetic() const;
template ParticleEnergy Simulation<2>::local_particle_energy() const;
template ParticleEnergy Simulation<3>::local_particle_energy() const;
template ParticleEnergy Simulation<2>::particle_energy() const;
template ParticleEnergy Simulation<3>::particle_energy() const;
template void Simulation<2>::account_energy(const StepEnergy&, double);
template void Simulation<3>::account_energy(const StepEnergy&, double);
template double Simulation<2>::energy_balance_error() const;
template double Simulation<3>::energy_balance_error() const;

}  // namespace talus
