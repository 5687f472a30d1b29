#pragma once
// The contact candidates of one step (docs/contact.md): owned active grid
// points i whose material is predicted to touch an obstacle within the step,
//
//   g_i + gamma h min(u_N,i^n, 0) <= 0      (Moreau-Jean's g_bar; u = v^n - v_obstacle)
//
// where g_i is the gap of the material around the point: the smallest
// g(x_p) - l_p / 2 over the particles p in its support (l_p the particle's
// initial size V0^(1/dim)). So contact closes when the body's surface
// reaches the obstacle, not when a grid point carrying some of its mass
// does (a one-cell early stop with nodal gaps). A point with a slip
// component (on a slip face) is a candidate only when the obstacle's normal
// is orthogonal to that axis: the face then takes the reaction along its axis
// and the obstacle the rest (a wall standing on a slip floor). Fixed points
// are never candidates. A point near several obstacles takes the one with the
// smallest predicted gap. A case without obstacles never builds one.
#include <array>
#include <vector>

#include "talus/contact/obstacle.hpp"
#include "talus/solver/active_set.hpp"

namespace talus {

template <int dim>
struct ContactPoint {
  int point = -1;        // ghosted grid index (owned by this rank)
  PetscInt row = 0;      // local offset of its first velocity component in the compact vector
  int obstacle = -1;     // index into the step's obstacle list
  double gap = 0.0;      // g_i at t^n (the material's gap)
  Vector<dim> normal;    // outward normal of the obstacle
  Vector<dim> obstacle_velocity;
  double friction = 0.0, restitution = 0.0;
  double start_normal_velocity = 0.0;  // u_N^n
  double rho = 0.0;      // natural-map parameter: the point's mass m_i
  std::array<bool, dim> free;  // components not constrained by a slip face
};

template <int dim>
std::vector<ContactPoint<dim>> find_contact_candidates(const Grid<dim>& grid, const Particles<dim>& particles,
                                                       const std::vector<Stencil<dim>>& stencils,
                                                       const GridFields<dim>& fields, const ActiveSet<dim>& active,
                                                       const std::vector<Obstacle<dim>>& obstacles, double time,
                                                       double h, double gap_prediction);

}  // namespace talus
