#pragma once
// Particle <-> grid transfers (P2G, G2P) on the rank's ghosted grid arrays.
//
// P2G accumulates into a ghosted DMDA local vector and sums the ranks'
// contributions with DMLocalToGlobal(ADD_VALUES), then brings the sums back to
// the ghost points with DMGlobalToLocal: particles near a rank boundary are
// handled exactly (docs/transfers.md).
#include <vector>

#include "talus/io/config.hpp"
#include "talus/particles/particles.hpp"

namespace talus {

// Grid fields on the rank's ghosted points: values are complete (summed over
// all ranks) on owned and ghost points alike.
//
// Bodies in contact (docs/contact.md#bodies-in-contact) move with separate
// velocity fields: the grid then carries `field_count` nodes per point, node
// f * points + i being field f at ghosted point i, and every array below is
// indexed by node. With one field a node is a point.
template <int dim>
struct GridFields {
  int field_count = 1;
  int points = 0;                // ghosted grid points per field
  int point_of(int node) const { return points > 0 ? node % points : node; }
  int field_of(int node) const { return points > 0 ? node / points : 0; }
  std::vector<double> mass;      // m_i
  std::vector<double> velocity;  // v_i^n = (m v)_i / m_i, dim per point; 0 where m_i = 0
  // The grid acceleration of the last accepted step, (v_i^n - v_i^{n-1}) / h
  // of that step's solve, dim per point; NaN where the point was not active
  // then. Not set by P2G (the run keeps it between steps); empty: unknown.
  // The predictor of the Newton iteration (MomentumSystem::initial_guess).
  std::vector<double> last_acceleration;
  // Where the step has no last acceleration (its first step, after a
  // re-partition): the acceleration of the stresses at t^n,
  // stress_acceleration(), the time-error estimate's reference only; empty:
  // none (quasi-static steps, a geostatic stage).
  std::vector<double> start_acceleration;
  // A geostatic stage's step (docs/equilibrium.md): its time is a pseudo-time,
  // so Newton's tolerance does not follow a time error (NewtonSolver::Scale).
  bool pseudo_time = false;
};

// Shape-function stencils of all local particles at their current positions.
// With `body_field` (the velocity field of each body, more than one field)
// a particle's stencil indexes the nodes of its body's field:
// Stencil::local holds f * ghosted points + the ghosted point.
// The half-widths of a particle's domain for domain quadrature
// (docs/grid.md#particle-quadrature): a box of the particle's volume J V0
// whose extents follow its stretch along the axes; zero if F is degenerate.
template <int dim>
Vector<dim> domain_half_width(double initial_volume, const Matrix<dim>& F, double volume_ratio);

template <int dim>
void compute_stencils(const Grid<dim>& grid, const Particles<dim>& particles, std::vector<Stencil<dim>>& stencils,
                      const std::vector<int>& body_field = {});

// P2G of mass and momentum. APIC adds m_p N_ip C_p (x_i - x_p); FLIP/PIC
// uses v_p. Each particle goes to the field of its stencil (field_count
// fields, the same on every rank).
template <int dim>
void particles_to_grid(const Grid<dim>& grid, const Particles<dim>& particles,
                       const std::vector<Stencil<dim>>& stencils, TransferScheme scheme, GridFields<dim>& out,
                       int field_count = 1);

// The grid acceleration of the particles' stresses at t^n, dim per node:
// a_i = g - f_i / m_i with f_i = sum_p V0_p tau_p grad N_i(x_p) (the stored
// Kirchhoff stress, as in the momentum rows), summed over the ranks like P2G;
// NaN where m_i = 0. It leaves out the reactions of walls, obstacles and
// contacts. The time-error estimate's reference where a step has no last
// acceleration (docs/solver.md#the-tolerance-follows-the-time-error).
template <int dim>
std::vector<double> stress_acceleration(const Grid<dim>& grid, const Particles<dim>& particles,
                                        const std::vector<Stencil<dim>>& stencils, const GridFields<dim>& fields,
                                        const Vector<dim>& gravity);

// G2P after the implicit solve. v_new: end-of-step grid velocity v^{n+1};
// v_old: start-of-step v^n as used by the solve (zero on constrained
// components); v_p2g: v^n as transferred (the FLIP reference, so that a wall's
// removal of the normal velocity reaches the particles). All ghosted, dim per
// point. Positions and the deformation gradient advance with
// v_theta = theta v^{n+1} + (1-theta) v_old (Moreau-Jean q_{k+1} = q_k + h v_{k+theta});
// particle velocities take v^{n+1} by APIC (v_p, C_p = sum v_i grad N_i^T)
// or the FLIP/PIC blend v_p <- a (v_p + sum N (v^{n+1} - v_p2g)) + (1 - a) sum N v^{n+1}.
// Positions are not clamped here (Simulation keeps particles inside the box).
// Particles with `skip[p]` (those of rigid bodies, moved by
// move_rigid_particles) are left as they are.
template <int dim>
void grid_to_particles(Particles<dim>& particles, const std::vector<Stencil<dim>>& stencils,
                       const std::vector<double>& v_new, const std::vector<double>& v_old,
                       const std::vector<double>& v_p2g, double h, double theta, const TransferConfig& transfer,
                       const std::vector<char>* skip = nullptr);

// The particles' packing against their own volumes, per ghosted grid point
// (docs/transfers.md#packing): P_i = sum_p min(J_p, 2) V0_p N_ip / int N_i dV,
// with the integral over the grid. lattice[b]: the particles per cell (per
// axis) of body b's seeding lattice, 0 for particles read from a file; with
// point quadrature a body's weights are divided by its lattice's rule on the
// integrals (lattice_rule_ratio), so that a body as seeded reads 1 at the
// faces too. At an open face (open_faces: x_min, x_max, y_min, ...) the
// functions that end there read 0. 1 inside a body whose particles fill the space
// their volumes claim, below 1 at its surface, above 1 where the positions
// have crowded together while the volumes J_p V0_p have not shrunk. Per node
// of the stencils' `field_count` velocity fields (bodies in contact each read
// their own packing), complete on owned and ghost points (summed over the
// ranks).
template <int dim>
std::vector<double> particle_packing(const Grid<dim>& grid, const Particles<dim>& particles,
                                     const std::vector<Stencil<dim>>& stencils, const std::vector<int>& lattice = {},
                                     const std::array<bool, 2 * dim>& open_faces = {}, int field_count = 1);

// The packing correction (docs/transfers.md#packing): moves every particle by
//   dx_p = -rate h^2 sum_i max(P_i - 1.05, 0) grad N_ip
// (h the cell size), down the gradient of the crowding, with the stencils and
// packing of the step's start; a particle whose stencil reaches the
// functions that end at a contact face (`contact_faces`: x_min, x_max,
// y_min, ...) moves along that face only, and one whose stencil reaches a
// node with a contact normal (`contact_normals`: dim values per node of the
// stencils' fields, a unit normal where an obstacle or another body is in
// contact, 0 elsewhere) loses the shift's component along that normal.
// Positions and displacements only: mass, velocity, F, J and the stress stay
// with the particle. Particles with `skip[p]` stay. Returns this rank's work
// of gravity on the shift, -sum_p m_p g . dx_p (the energy balance's
// correction_work), and sets `largest_shift` to this rank's largest |dx_p|.
template <int dim>
double correct_packing(Particles<dim>& particles, const std::vector<Stencil<dim>>& stencils,
                       const std::vector<double>& packing, const Grid<dim>& grid, double rate,
                       const Vector<dim>& gravity, double& largest_shift, const std::vector<char>* skip = nullptr,
                       const std::array<bool, 2 * dim>& contact_faces = {},
                       const std::vector<double>* contact_normals = nullptr);

// The particles whose neighbourhood the step would invert: those where
// det(I + h grad v_theta) <= 0 (or is not a number), v_theta = theta v_new +
// (1 - theta) v_old as in grid_to_particles. Such a step moves material
// across the grid faster than the grid can follow (a layer driven through a
// no-slip floor in one step); F^{n+1} = (I + h grad v_theta) F^n would lose
// det F > 0, so the step is cut back (docs/solver.md#inverting-steps).
// Particles with `skip[p]` are not counted. Local count.
template <int dim>
long count_inverting_particles(const std::vector<Stencil<dim>>& stencils, const std::vector<double>& v_new,
                               const std::vector<double>& v_old, double h, double theta,
                               const std::vector<char>* skip = nullptr);

}  // namespace talus
