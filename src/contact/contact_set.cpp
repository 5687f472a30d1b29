#include "talus/contact/contact_set.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <petscdmda.h>

namespace talus {

namespace {

// Per ghosted grid point: min over the particles in its support (all ranks)
// of g(x_p) - l_p / 2; +huge where no particle reaches. The minimum over
// ranks is a maximum of -g.
template <int dim>
std::vector<double> material_gaps(const Grid<dim>& grid, const Particles<dim>& particles,
                                  const std::vector<Stencil<dim>>& stencils, const Obstacle<dim>& obstacle,
                                  double time) {
  constexpr double none = 1e300;
  DM da = grid.dm();
  Vec local, global;
  TALUS_PETSC(DMGetLocalVector(da, &local));
  TALUS_PETSC(DMGetGlobalVector(da, &global));
  TALUS_PETSC(VecSet(local, -none));
  TALUS_PETSC(VecSet(global, -none));
  {
    PetscScalar* a;
    TALUS_PETSC(VecGetArray(local, &a));
    FieldView<PetscReal> x(particles.swarm(), field::position), v0(particles.swarm(), field::initial_volume);
    for (std::size_t p = 0; p < stencils.size(); ++p) {
      const double size = std::pow(v0[p], 1.0 / dim);
      const double g = obstacle.gap(Eigen::Map<const Vector<dim>>(x.data() + dim * p), time).gap - 0.5 * size;
      const Stencil<dim>& st = stencils[p];
      for (int k = 0; k < st.count; ++k)
        if (st.weight[k] > 0.0) a[st.local[k]] = std::max(a[st.local[k]], -g);
    }
    TALUS_PETSC(VecRestoreArray(local, &a));
  }
  // DMLocalToGlobal knows only ADD and INSERT; the DMDA's own scatter, run
  // in reverse, takes MAX_VALUES.
  VecScatter global_to_local;
  TALUS_PETSC(DMDAGetScatter(da, &global_to_local, nullptr));
  TALUS_PETSC(VecScatterBegin(global_to_local, local, global, MAX_VALUES, SCATTER_REVERSE));
  TALUS_PETSC(VecScatterEnd(global_to_local, local, global, MAX_VALUES, SCATTER_REVERSE));
  TALUS_PETSC(DMGlobalToLocalBegin(da, global, INSERT_VALUES, local));
  TALUS_PETSC(DMGlobalToLocalEnd(da, global, INSERT_VALUES, local));
  std::vector<double> gaps(grid.ghosted_count());
  const PetscScalar* a;
  TALUS_PETSC(VecGetArrayRead(local, &a));
  for (std::size_t i = 0; i < gaps.size(); ++i) gaps[i] = -a[i];
  TALUS_PETSC(VecRestoreArrayRead(local, &a));
  TALUS_PETSC(DMRestoreLocalVector(da, &local));
  TALUS_PETSC(DMRestoreGlobalVector(da, &global));
  return gaps;
}

}  // namespace

template <int dim>
std::vector<ContactPoint<dim>> find_contact_candidates(const Grid<dim>& grid, const Particles<dim>& particles,
                                                       const std::vector<Stencil<dim>>& stencils,
                                                       const GridFields<dim>& fields, const ActiveSet<dim>& active,
                                                       const std::vector<Obstacle<dim>>& obstacles, double time,
                                                       double h, double gap_prediction) {
  std::vector<ContactPoint<dim>> contacts;
  if (obstacles.empty()) return contacts;
  std::vector<std::vector<double>> gaps;
  for (const Obstacle<dim>& o : obstacles) gaps.push_back(material_gaps(grid, particles, stencils, o, time));
  // A point on a grid-aligned obstacle face has gap 0 up to round-off.
  const double point_tolerance = 1e-9 * grid.cell_size();
  const auto& owned = active.owned_points();
  for (std::size_t k = 0; k < owned.size(); ++k) {
    const int i = owned[k];
    std::array<bool, dim> free;
    int constrained = 0;
    for (int c = 0; c < dim; ++c) {
      free[c] = !active.constrained(i, c);
      constrained += !free[c];
    }
    if (constrained == dim) continue;
    const Vector<dim> x = grid.point_position(grid.global_index(i));
    const Vector<dim> v = Eigen::Map<const Vector<dim>>(fields.velocity.data() + static_cast<std::size_t>(dim) * i);
    double best = std::numeric_limits<double>::infinity();
    ContactPoint<dim> cp;
    for (std::size_t o = 0; o < obstacles.size(); ++o) {
      // The normal from the obstacle's surface next to the point; the gap of the material around it.
      ObstacleGap<dim> g = obstacles[o].gap(x, time);
      // Only a point on or inside the obstacle carries its condition. The
      // material's gap below says when contact closes; a point inside the
      // material above a floor (quadratic B-splines: up to 1.5 cells up)
      // would otherwise be held as if the floor were that thick, leaving the
      // bottom rows of particles unloaded (docs/contact.md).
      if (g.gap > point_tolerance) continue;
      g.gap = gaps[o][i];
      bool compatible = true;
      for (int c = 0; c < dim; ++c) compatible &= free[c] || std::abs(g.normal[c]) < 1e-12;
      if (!compatible) continue;
      const double un = (v - obstacles[o].velocity()).dot(g.normal);
      // A closed gap is a candidate whatever its velocity (Moreau's sweeping
      // process); an open one when it is predicted to close within the step.
      // Candidates that separate get r = 0 from the natural map itself.
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
        cp.free = free;
      }
    }
    if (cp.point >= 0) contacts.push_back(cp);
  }
  return contacts;
}

template std::vector<ContactPoint<2>> find_contact_candidates(const Grid<2>&, const Particles<2>&,
                                                              const std::vector<Stencil<2>>&, const GridFields<2>&,
                                                              const ActiveSet<2>&, const std::vector<Obstacle<2>>&,
                                                              double, double, double);
template std::vector<ContactPoint<3>> find_contact_candidates(const Grid<3>&, const Particles<3>&,
                                                              const std::vector<Stencil<3>>&, const GridFields<3>&,
                                                              const ActiveSet<3>&, const std::vector<Obstacle<3>>&,
                                                              double, double, double);

}  // namespace talus
