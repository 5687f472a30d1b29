#include "talus/contact/contact_set.hpp"

#include <algorithm>
#include <limits>

namespace talus {

template <int dim>
std::vector<ContactPoint<dim>> find_contact_candidates(const Grid<dim>& grid, const GridFields<dim>& fields,
                                                       const ActiveSet<dim>& active,
                                                       const std::vector<Obstacle<dim>>& obstacles, double time,
                                                       double h, double gap_prediction) {
  std::vector<ContactPoint<dim>> contacts;
  if (obstacles.empty()) return contacts;
  const auto& owned = active.owned_points();
  for (std::size_t k = 0; k < owned.size(); ++k) {
    const int i = owned[k];
    bool constrained = false;
    for (int c = 0; c < dim; ++c) constrained |= active.constrained(i, c);
    if (constrained) continue;
    const Vector<dim> x = grid.point_position(grid.global_index(i));
    const Vector<dim> v = Eigen::Map<const Vector<dim>>(fields.velocity.data() + static_cast<std::size_t>(dim) * i);
    double best = std::numeric_limits<double>::infinity();
    ContactPoint<dim> cp;
    for (std::size_t o = 0; o < obstacles.size(); ++o) {
      const ObstacleGap<dim> g = obstacles[o].gap(x, time);
      const double un = (v - obstacles[o].velocity()).dot(g.normal);
      // A closed gap is a candidate whatever its velocity (Moreau's sweeping
      // process); an open one when it is predicted to close within the step.
      const double predicted = g.gap + gap_prediction * h * std::min(un, 0.0);
      if (predicted <= 0.0 && predicted < best) {
        best = predicted;
        cp.point = i;
        cp.row = static_cast<PetscInt>(dim * k);
        cp.obstacle = static_cast<int>(o);
        cp.gap = g.gap;
        cp.normal = g.normal;
        cp.obstacle_velocity = obstacles[o].velocity();
        cp.friction = obstacles[o].friction();
        cp.restitution = obstacles[o].restitution();
        cp.start_normal_velocity = un;
        cp.rho = fields.mass[i];
      }
    }
    if (cp.point >= 0) contacts.push_back(cp);
  }
  return contacts;
}

template std::vector<ContactPoint<2>> find_contact_candidates(const Grid<2>&, const GridFields<2>&,
                                                              const ActiveSet<2>&, const std::vector<Obstacle<2>>&,
                                                              double, double, double);
template std::vector<ContactPoint<3>> find_contact_candidates(const Grid<3>&, const GridFields<3>&,
                                                              const ActiveSet<3>&, const std::vector<Obstacle<3>>&,
                                                              double, double, double);

}  // namespace talus
