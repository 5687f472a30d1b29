#pragma once
// The discrete energy balance of a run (docs/energy.md): the energies of the
// particles, K + G + E (kinetic, gravitational, stored elastic), and what the
// steps dissipated or received, summed since t = 0, so that
//
//   K + G + E + D_plastic + D_contact - W_obstacles + D_faces + D_transfer + D_time - W_correction = K0 + G0 + E0
//
// holds to the closing error the run reports. Every term is computed from
// the discrete step itself (the derivation is in docs/energy.md):
//   D_plastic   V0 tau^theta : (d eps_p + d(voids)), the work of the stress on
//               the inelastic strain of the return mapping and on the voids;
//   D_contact   -r . (v^theta - v_obstacle) at contact points (Coulomb friction
//               and inelastic impact), W_obstacles = r . v_obstacle;
//   D_faces     (1/2) m v^2 of the velocity components fixed and slip faces
//               remove at the start of a step;
//   D_transfer  kinetic energy lost between the particles and the grid by P2G
//               and G2P (and on grid points below the active-mass threshold);
//   D_time      the time integrator's own dissipation, (theta_v - 1/2) |dv|^2_M
//               + (theta_s - 1/2) V0 d tau : C^-1 : d tau (theta_v, theta_s: the
//               weights of v^{n+1} in the power and of sigma^{n+1} in the force;
//               theta for the implicit step, 1 and 0 for the explicit one);
//   W_correction the gravitational energy added when a particle carried past a
//               slip or fixed face is put back inside the grid.
// Energies in J (J per metre of thickness in 2D).
#include <array>
#include <string>
#include <vector>

namespace talus {

struct EnergyTerms {
  double plastic = 0.0, contact = 0.0, obstacle_work = 0.0, faces = 0.0, transfer = 0.0, time_integration = 0.0;
  double correction_work = 0.0;
  static constexpr int count = 7;
  std::array<double, count> values() const {
    return {plastic, contact, obstacle_work, faces, transfer, time_integration, correction_work};
  }
  static std::array<const char*, count> names() {
    return {"plastic_dissipation", "contact_dissipation", "obstacle_work", "face_dissipation", "transfer_dissipation",
            "time_dissipation", "correction_work"};
  }
  // values() with the received terms (obstacle and correction work) negated:
  // their sum with K + G + E is conserved.
  double dissipated() const {
    return plastic + contact - obstacle_work + faces + transfer + time_integration - correction_work;
  }
  EnergyTerms& operator+=(const EnergyTerms& o) {
    plastic += o.plastic, contact += o.contact, obstacle_work += o.obstacle_work, faces += o.faces;
    transfer += o.transfer, time_integration += o.time_integration, correction_work += o.correction_work;
    return *this;
  }
};

// The state energies of the particles at one instant.
struct ParticleEnergy {
  double kinetic = 0.0, gravitational = 0.0, elastic = 0.0;
  double total() const { return kinetic + gravitational + elastic; }
};

// The grid side of one step, from MomentumSystem::step_energy (this rank's
// owned points and particles; the caller sums over ranks).
struct StepEnergy {
  double grid_kinetic_start = 0.0;  // (1/2) m |v^n|^2 on the free components of the unknowns
  double grid_kinetic_end = 0.0;    // (1/2) m |v^{n+1}|^2 on the same
  EnergyTerms terms;                // plastic, contact, obstacle_work, faces, time_integration
};

}  // namespace talus
