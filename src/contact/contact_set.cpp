#include "talus/contact/contact_set.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <petscdmda.h>

#include "talus/core/errors.hpp"

namespace talus {

namespace {

// Per ghosted grid point: min over the particles in its support (all ranks)
// of g(x_p) - l_p / 2; +huge where no particle reaches. The minimum over
// ranks is a maximum of -g.
constexpr double none = 1e300;

// The largest value per ghosted node over all ranks: `value(p, k)` for every
// particle p and stencil entry k with a non-zero weight (-none where no
// particle reaches), one DMDA pass per velocity field.
template <int dim, class Value>
std::vector<double> node_maximum(const Grid<dim>& grid, const std::vector<Stencil<dim>>& stencils,
                                 const GridFields<dim>& fields, const Value& value) {
  const int points = grid.ghosted_count();
  std::vector<double> out(static_cast<std::size_t>(points) * fields.field_count, -none);
  DM da = grid.dm();
  Vec local, global;
  TALUS_PETSC(DMGetLocalVector(da, &local));
  TALUS_PETSC(DMGetGlobalVector(da, &global));
  // DMLocalToGlobal knows only ADD and INSERT; the DMDA's own scatter, run
  // in reverse, takes MAX_VALUES.
  VecScatter global_to_local;
  TALUS_PETSC(DMDAGetScatter(da, &global_to_local, nullptr));
  for (int field = 0; field < fields.field_count; ++field) {
    const int offset = field * points;
    TALUS_PETSC(VecSet(local, -none));
    TALUS_PETSC(VecSet(global, -none));
    PetscScalar* a;
    TALUS_PETSC(VecGetArray(local, &a));
    for (std::size_t p = 0; p < stencils.size(); ++p) {
      const Stencil<dim>& st = stencils[p];
      if (st.local[0] / points != field) continue;
      for (int k = 0; k < st.count; ++k)
        if (st.weight[k] > 0.0) {
          double& m = a[st.local[k] - offset];
          m = std::max(m, value(p, k));
        }
    }
    TALUS_PETSC(VecRestoreArray(local, &a));
    TALUS_PETSC(VecScatterBegin(global_to_local, local, global, MAX_VALUES, SCATTER_REVERSE));
    TALUS_PETSC(VecScatterEnd(global_to_local, local, global, MAX_VALUES, SCATTER_REVERSE));
    TALUS_PETSC(DMGlobalToLocalBegin(da, global, INSERT_VALUES, local));
    TALUS_PETSC(DMGlobalToLocalEnd(da, global, INSERT_VALUES, local));
    const PetscScalar* b;
    TALUS_PETSC(VecGetArrayRead(local, &b));
    std::copy(b, b + points, out.begin() + offset);
    TALUS_PETSC(VecRestoreArrayRead(local, &b));
  }
  TALUS_PETSC(DMRestoreLocalVector(da, &local));
  TALUS_PETSC(DMRestoreGlobalVector(da, &global));
  return out;
}

// Per ghosted node: min over the particles of its field in its support (all
// ranks) of g(x_p) - l_p / 2; +huge where no particle reaches.
//
// A rigid body's point takes only the particles across its own cell strip
// (tangential offset from the point at most half a cell): its gap is then
// the body's surface height under the point, so a rolling body touches at the
// points under its lowest surface, not at every point within the B-splines'
// reach (those would block the rotation, docs/contact.md#rigid-bodies).
template <int dim>
std::vector<double> material_gaps(const Grid<dim>& grid, const Particles<dim>& particles,
                                  const std::vector<Stencil<dim>>& stencils, const GridFields<dim>& fields,
                                  const Obstacle<dim>& obstacle, double time, const std::vector<int>& rigid_of_field,
                                  const std::vector<double>* displacement = nullptr) {
  FieldView<PetscReal> x(particles.swarm(), field::position), v0(particles.swarm(), field::initial_volume);
  std::vector<double> particle_gap(stencils.size());
  std::vector<Vector<dim>> particle_normal(rigid_of_field.empty() ? 0 : stencils.size());
  const int points = grid.ghosted_count();
  for (std::size_t p = 0; p < stencils.size(); ++p) {
    Vector<dim> xp = Eigen::Map<const Vector<dim>>(x.data() + dim * p);
    if (displacement) xp += Eigen::Map<const Vector<dim>>(displacement->data() + dim * p);
    const ObstacleGap<dim> g = obstacle.gap(xp, time);
    particle_gap[p] = g.gap - 0.5 * std::pow(v0[p], 1.0 / dim);
    if (!particle_normal.empty()) particle_normal[p] = g.normal;
  }
  const double strip = 0.5 * grid.cell_size() * (1.0 + 1e-9);
  std::vector<double> gaps = node_maximum(grid, stencils, fields, [&](std::size_t p, int k) {
    const Stencil<dim>& st = stencils[p];
    if (!particle_normal.empty() && rigid_of_field[st.local[k] / points] >= 0) {
      const Vector<dim> d = Eigen::Map<const Vector<dim>>(x.data() + dim * p) - grid.point_position(st.node[k]);
      const Vector<dim>& n = particle_normal[p];
      if ((d - d.dot(n) * n).template lpNorm<Eigen::Infinity>() > strip) return -none;
    }
    return -particle_gap[p];
  });
  for (double& g : gaps) g = -g;
  return gaps;
}

// A rigid body's surface point at each of its nodes: the lowest point
// x_p - (l_p / 2) n of the particle of the node's strip that sets its gap
// (material_gaps), dim per node (ties: the largest coordinates). The
// contact's velocity is the body's there (a rolling body turns about it).
template <int dim>
std::vector<double> rigid_surface_points(const Grid<dim>& grid, const Particles<dim>& particles,
                                         const std::vector<Stencil<dim>>& stencils, const GridFields<dim>& fields,
                                         const Obstacle<dim>& obstacle, double time,
                                         const std::vector<int>& rigid_of_field, const std::vector<double>& gaps) {
  FieldView<PetscReal> x(particles.swarm(), field::position), v0(particles.swarm(), field::initial_volume);
  const int points = grid.ghosted_count();
  const double strip = 0.5 * grid.cell_size() * (1.0 + 1e-9), tie = 1e-9 * grid.cell_size();
  std::vector<double> particle_gap(stencils.size());
  std::vector<Vector<dim>> surface(stencils.size()), normal(stencils.size());
  for (std::size_t p = 0; p < stencils.size(); ++p) {
    const Vector<dim> xp = Eigen::Map<const Vector<dim>>(x.data() + dim * p);
    const ObstacleGap<dim> g = obstacle.gap(xp, time);
    const double extent = 0.5 * std::pow(v0[p], 1.0 / dim);
    particle_gap[p] = g.gap - extent;
    normal[p] = g.normal;
    surface[p] = xp - extent * g.normal;
  }
  std::vector<double> out(gaps.size() * dim, 0.0);
  for (int a = 0; a < dim; ++a) {
    const std::vector<double> component = node_maximum(grid, stencils, fields, [&](std::size_t p, int k) {
      const Stencil<dim>& st = stencils[p];
      const int node = st.local[k];
      if (rigid_of_field[node / points] < 0 || particle_gap[p] > gaps[node] + tie) return -none;
      const Vector<dim> d = Eigen::Map<const Vector<dim>>(x.data() + dim * p) - grid.point_position(st.node[k]);
      if ((d - d.dot(normal[p]) * normal[p]).template lpNorm<Eigen::Infinity>() > strip) return -none;
      return surface[p][a];
    });
    for (std::size_t node = 0; node < gaps.size(); ++node) out[dim * node + a] = component[node];
  }
  return out;
}

}  // namespace

template <int dim>
std::vector<ContactPoint<dim>> find_contact_candidates(const Grid<dim>& grid, const Particles<dim>& particles,
                                                       const std::vector<Stencil<dim>>& stencils,
                                                       const GridFields<dim>& fields, const ActiveSet<dim>& active,
                                                       const std::vector<Obstacle<dim>>& obstacles, double time,
                                                       double h, double gap_prediction,
                                                       const std::vector<int>& rigid_of_field,
                                                       const std::vector<char>* forced,
                                                       const std::vector<double>* displacement) {
  std::vector<ContactPoint<dim>> contacts;
  if (obstacles.empty() && rigid_of_field.empty()) return contacts;
  std::vector<std::vector<double>> gaps;
  std::vector<std::vector<double>> surfaces;
  for (const Obstacle<dim>& o : obstacles) {
    gaps.push_back(material_gaps(grid, particles, stencils, fields, o, time, rigid_of_field, displacement));
    if (!rigid_of_field.empty())
      surfaces.push_back(rigid_surface_points(grid, particles, stencils, fields, o, time, rigid_of_field, gaps.back()));
  }
  // A point on a grid-aligned obstacle face has gap 0 up to round-off.
  const double point_tolerance = 1e-9 * grid.cell_size();
  bool at_face = false;  // a rigid body's active point on a constrained face
  const auto& owned = active.owned_points();
  for (std::size_t k = 0; k < owned.size(); ++k) {
    const int i = owned[k];
    std::array<bool, dim> free;
    int constrained = 0;
    for (int c = 0; c < dim; ++c) {
      free[c] = !active.constrained(i, c);
      constrained += !free[c];
    }
    const int rigid = rigid_of_field.empty() ? -1 : rigid_of_field[fields.field_of(i)];
    if (constrained == dim && rigid < 0) continue;
    const Vector<dim> x = grid.point_position(grid.global_index(fields.point_of(i)));
    const Vector<dim> v = Eigen::Map<const Vector<dim>>(fields.velocity.data() + static_cast<std::size_t>(dim) * i);
    const bool force = forced && (*forced)[i];
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
      if (!compatible && rigid < 0) continue;
      const double un = (v - obstacles[o].velocity()).dot(g.normal);
      // A closed gap is a candidate whatever its velocity (Moreau's sweeping
      // process); an open one when it is predicted to close within the step,
      // or when its material crossed the obstacle in an attempt of the step
      // without it (`forced`). Candidates that separate get r = 0 from the
      // natural map itself; an open gap may close within the step
      // (contact_rows.cpp).
      const double predicted = g.gap + gap_prediction * h * std::min(un, 0.0);
      if ((predicted <= 0.0 || force) && predicted < best) {
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
        cp.rigid = rigid;
        cp.closes_gap = force && rigid < 0 && g.gap > 0.0;
        if (rigid >= 0) cp.surface = Eigen::Map<const Vector<dim>>(surfaces[o].data() + static_cast<std::size_t>(dim) * i);
      }
    }
    if (rigid >= 0 && constrained > 0) at_face = true;
    if (cp.point >= 0) contacts.push_back(cp);
  }
  if (!rigid_of_field.empty()) {
    // A constrained component would hold a rigid body's grid point without
    // the body's equations knowing: the body would pass through the face.
    int any = 0, mine = at_face ? 1 : 0;
    MPI_Allreduce(&mine, &any, 1, MPI_INT, MPI_MAX, grid.comm());
    if (any)
      throw SimulationError("a rigid body reached a fixed or slip face of the grid: rigid bodies are held by "
                            "obstacles only (docs/contact.md#rigid-bodies); keep the grid's faces away from them");
  }
  return contacts;
}

namespace {

// sum over field f's particles of V_p grad N_i(x_p) at every ghosted node
// (all ranks), dim per node: along the body's outward normal at its surface.
template <int dim>
std::vector<double> volume_gradients(const Grid<dim>& grid, const Particles<dim>& particles,
                                   const std::vector<Stencil<dim>>& stencils, const GridFields<dim>& fields) {
  std::vector<double> mine(static_cast<std::size_t>(grid.ghosted_count()) * fields.field_count * dim, 0.0);
  // The particle's current volume V0 J.
  FieldView<PetscReal> v0(particles.swarm(), field::initial_volume), J(particles.swarm(), field::volume_ratio);
  for (std::size_t p = 0; p < stencils.size(); ++p) {
    const Stencil<dim>& st = stencils[p];
    const double m = v0[p] * J[p];
    for (int k = 0; k < st.count; ++k)
      for (int c = 0; c < dim; ++c) mine[static_cast<std::size_t>(dim) * st.local[k] + c] += m * st.gradient[k][c];
  }
  return grid.sum_over_ranks(mine, fields.field_count, dim);
}

}  // namespace

// The largest angle between one body's outward direction and the other's
// inward one at a contact point (find_body_contacts).
constexpr double opposed_angle = 30.0 * 3.14159265358979323846 / 180.0;

template <int dim>
std::vector<BodyContactPoint<dim>> find_body_contacts(const Grid<dim>& grid, const Particles<dim>& particles,
                                                      const std::vector<Stencil<dim>>& stencils,
                                                      const GridFields<dim>& fields, const ActiveSet<dim>& active,
                                                      const ContactConfig& config,
                                                      const std::vector<ContactPoint<dim>>& obstacle_contacts,
                                                      double h, const std::vector<int>& rigid_of_field) {
  std::vector<BodyContactPoint<dim>> contacts;
  const int F = fields.field_count;
  if (F < 2) return contacts;
  const int points = grid.ghosted_count();
  // The hub of every ghosted point (ghost points too: the gaps below need
  // the normals wherever a particle's support reaches): its heaviest active
  // field. Every other active field x there is paired with the hub (x's row
  // takes the natural map, the hub's the point's total balance), so any
  // number of fields can meet at a point.
  // A rigid body's field is the hub wherever it is active.
  const auto rigid = [&](int f) { return !rigid_of_field.empty() && rigid_of_field[f] >= 0; };
  std::vector<int> hub(points, -1), count(points, 0);
  for (int i = 0; i < points; ++i)
    for (int f = 0; f < F; ++f) {
      const int node = f * points + i;
      if (active.compact_index(node) < 0) continue;
      ++count[i];
      if (hub[i] < 0 || (rigid(f) && !rigid(hub[i])) ||
          (rigid(f) == rigid(hub[i]) && fields.mass[node] > fields.mass[hub[i] * points + i]))
        hub[i] = f;
    }
  const std::vector<double> gradient = volume_gradients(grid, particles, stencils, fields);
  // Each field's volume, all ranks: which body of a pair is the larger.
  std::vector<double> volume(F, 0.0);
  {
    std::vector<double> local(F, 0.0);
    FieldView<PetscReal> v0(particles.swarm(), field::initial_volume);
    for (std::size_t p = 0; p < stencils.size(); ++p) local[stencils[p].local[0] / points] += v0[p];
    MPI_Allreduce(local.data(), volume.data(), F, MPI_DOUBLE, MPI_SUM, grid.comm());
  }
  // The normal of the pair (x, hub) at point i, out of x's body, on x's
  // node (zero: not a contact point).
  std::vector<Vector<dim>> normal(static_cast<std::size_t>(points) * F, Vector<dim>::Zero());
  for (int i = 0; i < points; ++i) {
    if (count[i] < 2) continue;
    const int b = hub[i] * points + i;
    const Eigen::Map<const Vector<dim>> gb(gradient.data() + static_cast<std::size_t>(dim) * b);
    for (int f = 0; f < F; ++f) {
      const int a = f * points + i;
      if (f == hub[i] || active.compact_index(a) < 0) continue;
      const Eigen::Map<const Vector<dim>> ga(gradient.data() + static_cast<std::size_t>(dim) * a);
      // sum_p V_p grad N_i(x_p) points out of a body at its surface (N_i grows
      // as a particle moves towards the point). Two bodies touch where their
      // outward directions oppose each other; at a block's corner on a flat
      // base they are 45 degrees apart (the block's is the corner's diagonal):
      // such points are not contact points (the next row, where the surfaces
      // oppose, holds the bodies apart). The normal is that of the larger body
      // of the two, whose surface is the flatter one at the contact (the base
      // under a block, the slope under a boulder, the debris around a rock):
      // the smaller body's, or an average, tilts near its edges, and a tilted
      // normal is a ramp that stops a sliding block or launches it.
        if (!(ga.norm() > 0.0 && gb.norm() > 0.0)) continue;
      if (-ga.normalized().dot(gb.normalized()) < std::cos(opposed_angle)) continue;
      normal[a] = volume[f] >= volume[hub[i]] ? Vector<dim>(ga.normalized()) : Vector<dim>(-gb.normalized());
    }
  }
  // The bodies' surfaces along each pair's normal: x's front (the largest
  // x_p . n + e_p of its particles) on x's node, and the hub's back (the
  // smallest x_q . n - e_q of its particles), one pass per paired field x,
  // stored on x's node too; both as maxima over the particles around the point.
  FieldView<PetscReal> x(particles.swarm(), field::position), v0(particles.swarm(), field::initial_volume);
  const auto extent = [&](std::size_t p, const Vector<dim>& n, double sign) {
    // Along n, plus or minus half the extent of the particle's cube (side l_p).
    return Eigen::Map<const Vector<dim>>(x.data() + dim * p).dot(n) +
           sign * 0.5 * std::pow(v0[p], 1.0 / dim) * n.template lpNorm<1>();
  };
  const std::vector<double> front = node_maximum(grid, stencils, fields, [&](std::size_t p, int k) {
    const Vector<dim>& n = normal[stencils[p].local[k]];
    return n.isZero(0.0) ? -none : extent(p, n, 1.0);
  });
  std::vector<double> back(static_cast<std::size_t>(points) * F, none);
  for (int f = 0; f < F; ++f) {
    const std::vector<double> hub_back = node_maximum(grid, stencils, fields, [&](std::size_t p, int k) {
      const int node = stencils[p].local[k], i = node % points;
      const Vector<dim>& n = normal[f * points + i];
      if (node / points != hub[i] || f == hub[i] || n.isZero(0.0)) return -none;
      return -extent(p, n, -1.0);
    });
    for (int i = 0; i < points; ++i)
      if (hub[i] >= 0 && f != hub[i]) back[f * points + i] = -hub_back[hub[i] * points + i];
  }

  std::vector<char> obstacle_node(static_cast<std::size_t>(points) * F, 0);
  for (const ContactPoint<dim>& cp : obstacle_contacts) obstacle_node[cp.point] = 1;
  PetscInt first = 0;
  {
    Vec v = active.create_vector();
    TALUS_PETSC(VecGetOwnershipRange(v, &first, nullptr));
    TALUS_PETSC(VecDestroy(&v));
  }
  for (const int node : active.owned_points()) {
    const int i = node % points;
    if (normal[node].isZero(0.0)) continue;  // the hub, or not a contact point
    const int a = node, b = hub[i] * points + i;
    if (obstacle_node[a] || obstacle_node[b]) continue;
    if (rigid(a / points)) continue;  // two rigid bodies
    bool constrained = false;
    for (int c = 0; c < dim; ++c) constrained |= active.constrained(a, c);
    if (constrained) continue;
    BodyContactPoint<dim> cp;
    cp.node_a = a;
    cp.node_b = b;
    cp.row_a = dim * (active.compact_index(a) - first / dim);
    cp.row_b = dim * (active.compact_index(b) - first / dim);
    cp.normal = normal[a];
    cp.gap = back[a] - front[a];
    const Eigen::Map<const Vector<dim>> va(fields.velocity.data() + static_cast<std::size_t>(dim) * a),
        vb(fields.velocity.data() + static_cast<std::size_t>(dim) * b);
    cp.start_normal_velocity = -(va - vb).dot(cp.normal);
    // Touching bodies have gap 0 up to round-off.
    const double tolerance = 1e-9 * grid.cell_size();
    if (cp.gap + config.gap_prediction * h * std::min(cp.start_normal_velocity, 0.0) > tolerance) continue;
    cp.friction = config.field_friction(a / points, hub[i]);
    cp.rho = fields.mass[a] * fields.mass[b] / (fields.mass[a] + fields.mass[b]);
    contacts.push_back(cp);
  }
  return contacts;
}

template std::vector<BodyContactPoint<2>> find_body_contacts(const Grid<2>&, const Particles<2>&,
                                                             const std::vector<Stencil<2>>&, const GridFields<2>&,
                                                             const ActiveSet<2>&, const ContactConfig&,
                                                             const std::vector<ContactPoint<2>>&, double,
                                                             const std::vector<int>&);
template std::vector<BodyContactPoint<3>> find_body_contacts(const Grid<3>&, const Particles<3>&,
                                                             const std::vector<Stencil<3>>&, const GridFields<3>&,
                                                             const ActiveSet<3>&, const ContactConfig&,
                                                             const std::vector<ContactPoint<3>>&, double,
                                                             const std::vector<int>&);

template <int dim>
long flag_missed_contacts(const Grid<dim>& grid, const Particles<dim>& particles,
                          const std::vector<Stencil<dim>>& stencils, const GridFields<dim>& fields,
                          const ActiveSet<dim>& active, const std::vector<Obstacle<dim>>& obstacles, double time,
                          double h, double theta, const std::vector<double>& v_end, const std::vector<double>& v_start,
                          const std::vector<ContactPoint<dim>>& contacts, std::vector<char>& forced,
                          const std::vector<int>& rigid_of_field) {
  // Crossings below 1e-4 of a cell are not a missed contact: the particles
  // move with the velocity interpolated from all their grid points, a
  // contact point holds only its own, and at rest against a wall that leaves
  // crossings of about 2e-5 cell at every step.
  const double tolerance = 1e-4 * grid.cell_size();
  std::vector<char> held(fields.mass.size(), 0);
  for (const ContactPoint<dim>& cp : contacts) held[cp.point] = 1;
  // A point can be flagged only if its material is at rest against an
  // obstacle it lies on or in at t^n, and it is not a contact point. Most
  // steps have none (a flowing body moves; a body at rest on an obstacle
  // holds its points there), and then the gaps at the end of the step,
  // one evaluation per particle and obstacle, are not needed. Decided on
  // all ranks together: find_contact_candidates is collective with rigid
  // bodies.
  const auto could_be_missed = [&](int node, const Obstacle<dim>& obstacle) {
    if (held[node] || fields.mass[node] <= 0.0) return false;
    const Vector<dim> v = Eigen::Map<const Vector<dim>>(fields.velocity.data() + static_cast<std::size_t>(dim) * node);
    if ((v - obstacle.velocity()).norm() * h > tolerance) return false;
    const Vector<dim> x = grid.point_position(grid.global_index(fields.point_of(node)));
    return obstacle.gap(x, time).gap <= 1e-9 * grid.cell_size();
  };
  int mine = 0, any = 0;
  for (std::size_t node = 0; node < fields.mass.size() && !mine; ++node) {
    if (active.compact_index(static_cast<int>(node)) < 0) continue;
    for (const Obstacle<dim>& obstacle : obstacles)
      if (could_be_missed(static_cast<int>(node), obstacle)) {
        mine = 1;
        break;
      }
  }
  MPI_Allreduce(&mine, &any, 1, MPI_INT, MPI_MAX, grid.comm());
  if (!any) return 0;
  // Where the material would be at the end of the step: x_p + h v_theta,
  // as G2P moves it.
  std::vector<double> displacement(static_cast<std::size_t>(dim) * stencils.size(), 0.0);
  for (std::size_t p = 0; p < stencils.size(); ++p)
    for (int k = 0; k < stencils[p].count; ++k)
      for (int a = 0; a < dim; ++a) {
        const std::size_t o = static_cast<std::size_t>(dim) * stencils[p].local[k] + a;
        displacement[dim * p + a] += h * stencils[p].weight[k] * (theta * v_end[o] + (1.0 - theta) * v_start[o]);
      }
  // The material's gaps at the end of the step, to the obstacles where they are then.
  const std::vector<ContactPoint<dim>> closing = find_contact_candidates(
      grid, particles, stencils, fields, active, obstacles, time + h, h, 0.0, rigid_of_field, nullptr, &displacement);
  long missed = 0;
  for (const ContactPoint<dim>& cp : closing) {
    if (cp.rigid >= 0 || cp.gap >= -tolerance) continue;
    // Only material at rest at t^n (moving less than the tolerance in a
    // step), which the prediction cannot see. Moving material is the
    // prediction's (gap_prediction): solving impacts and slides along
    // curved terrain again moved the boulder cases' peak forces by 5-27 %,
    // cost up to 15 % more Newton iterations and left their energy balances
    // 7-100 times less closed (docs/contact.md).
    // A candidate of the next attempt must lie on or inside its obstacle at
    // the step's start (a moving one's points that enter it within the step
    // are not).
    if (!could_be_missed(cp.point, obstacles[cp.obstacle])) continue;
    if (forced.empty()) forced.assign(fields.mass.size(), 0);
    forced[cp.point] = 1;
    ++missed;
  }
  return missed;
}

template std::vector<ContactPoint<2>> find_contact_candidates(const Grid<2>&, const Particles<2>&,
                                                              const std::vector<Stencil<2>>&, const GridFields<2>&,
                                                              const ActiveSet<2>&, const std::vector<Obstacle<2>>&,
                                                              double, double, double, const std::vector<int>&,
                                                              const std::vector<char>*, const std::vector<double>*);
template std::vector<ContactPoint<3>> find_contact_candidates(const Grid<3>&, const Particles<3>&,
                                                              const std::vector<Stencil<3>>&, const GridFields<3>&,
                                                              const ActiveSet<3>&, const std::vector<Obstacle<3>>&,
                                                              double, double, double, const std::vector<int>&,
                                                              const std::vector<char>*, const std::vector<double>*);

template long flag_missed_contacts<2>(const Grid<2>&, const Particles<2>&, const std::vector<Stencil<2>>&,
                                      const GridFields<2>&, const ActiveSet<2>&, const std::vector<Obstacle<2>>&,
                                      double, double, double, const std::vector<double>&, const std::vector<double>&,
                                      const std::vector<ContactPoint<2>>&, std::vector<char>&, const std::vector<int>&);
template long flag_missed_contacts<3>(const Grid<3>&, const Particles<3>&, const std::vector<Stencil<3>>&,
                                      const GridFields<3>&, const ActiveSet<3>&, const std::vector<Obstacle<3>>&,
                                      double, double, double, const std::vector<double>&, const std::vector<double>&,
                                      const std::vector<ContactPoint<3>>&, std::vector<char>&, const std::vector<int>&);

}  // namespace talus
