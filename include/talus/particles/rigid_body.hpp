#pragma once
// Rigid bodies (docs/contact.md#rigid-bodies): a body marked `rigid: true`
// moves as a rigid body. Its velocity field on the grid is constrained to
// the rigid motion v(x) = V + omega x (x - X) of the body's centre of mass X,
// and the body's generalized velocity q = (V, w), w = r_g omega (r_g the
// radius of gyration, so that every entry of q is a velocity and every row
// of its equations an impulse), is an unknown of the step's monolithic
// system. Its equations are the Newton-Euler equations of the body
// (backward Euler, as the momentum rows):
//
//   M (V - V^n) - h M g - sum_k r_k = 0,
//   (I / r_g^2) (w - w^n) - sum_k S(x_k - X)^T r_k = 0,
//
// the sums over the impulses r_k the body receives at its contact points
// (obstacles, and bodies in contact through the grid), S(r) = the map from
// w to the velocity of the point r, omega x r = S(r) w.
#include <petscsys.h>

#include <vector>

#include "talus/core/types.hpp"
#include "talus/particles/particles.hpp"

namespace talus {

template <int dim>
struct RigidBody {
  static constexpr int rotations = dim == 2 ? 1 : 3;
  // q takes two blocks of dim unknowns: (V) and (w) in 3D, (V) and (w, 0) in 2D.
  static constexpr int unknowns = 2 * dim;
  using Motion = Eigen::Matrix<double, unknowns, 1>;
  using Map = Eigen::Matrix<double, dim, unknowns>;  // T(x): q -> the velocity at x
  using Inertia = Eigen::Matrix<double, unknowns, unknowns>;

  int body = -1;   // index into CaseConfig::bodies
  int field = -1;  // its velocity field
  double mass = 0.0;
  Vector<dim> centre = Vector<dim>::Zero();
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();  // about the centre, 3D components (2D: about z)
  double gyration = 1.0;                            // r_g = sqrt(trace I / (rotations M)), m
  Motion start = Motion::Zero();                    // q^n: V^n and w^n = r_g omega^n
  PetscInt block = -1;                              // global block index of q's first block

  // T(x) q = V + omega x (x - X).
  Map velocity_map(const Vector<dim>& x) const;
  // The inertia in the unknowns' units: M on V, I / r_g^2 on w (2D: M on the
  // padding entry, whose equation is M q_3 = 0).
  Inertia generalized_mass() const;
  // The angular velocity (3D components) of q.
  Eigen::Vector3d angular_velocity(const Motion& q) const;
};

// The rigid bodies of the case at the particles' present state: mass, centre,
// inertia (each particle a cube of its initial volume: own inertia m l^2 / 6)
// and the motion q^n (the momentum and angular momentum of the particles,
// their APIC affine velocities' spin included), all ranks. `rigid` per body,
// `body_field` the field of each body. Empty when no body is rigid.
template <int dim>
std::vector<RigidBody<dim>> rigid_bodies(const Particles<dim>& particles, const std::vector<char>& rigid,
                                         const std::vector<int>& body_field, MPI_Comm comm);

// G2P of a rigid body: each particle of a rigid body is moved by the body's
// motion q^{n+1} over the step, x^{n+1} = X^n + h V + R(h omega) (x^n - X^n),
// takes the rigid velocity V + omega x (x^{n+1} - X^{n+1}) and affine velocity
// skew(omega), and its deformation gradient is rotated, F <- R F (the body
// neither strains nor changes volume).
template <int dim>
void move_rigid_particles(Particles<dim>& particles, const std::vector<RigidBody<dim>>& bodies,
                          const std::vector<typename RigidBody<dim>::Motion>& motion, double h);

}  // namespace talus
