#pragma once
// The contact candidates of one step (docs/contact.md): owned active grid
// points x_i whose gap to an obstacle, predicted over the step,
//
//   g + gamma h min(u_N^n, 0) <= 0      (Moreau-Jean's g_bar; u = v^n - v_obstacle)
//
// is closed. Points with a fixed or slip component keep that constraint and
// are not candidates; a point near several obstacles takes the one with the
// smallest predicted gap. A case without obstacles never builds one.
#include <vector>

#include "talus/contact/obstacle.hpp"
#include "talus/solver/active_set.hpp"

namespace talus {

template <int dim>
struct ContactPoint {
  int point = -1;        // ghosted grid index (owned by this rank)
  PetscInt row = 0;      // local offset of its first velocity component in the compact vector
  int obstacle = -1;     // index into the step's obstacle list
  double gap = 0.0;      // g at t^n
  Vector<dim> normal;    // outward normal of the obstacle
  Vector<dim> obstacle_velocity;
  double friction = 0.0, restitution = 0.0;
  double start_normal_velocity = 0.0;  // u_N^n
  double rho = 0.0;      // natural-map parameter: the point's mass m_i
};

template <int dim>
std::vector<ContactPoint<dim>> find_contact_candidates(const Grid<dim>& grid, const GridFields<dim>& fields,
                                                       const ActiveSet<dim>& active,
                                                       const std::vector<Obstacle<dim>>& obstacles, double time,
                                                       double h, double gap_prediction);

}  // namespace talus
