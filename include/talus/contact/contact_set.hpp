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
  // A rigid body's contact point (docs/contact.md#rigid-bodies): the index of
  // the body in the step's rigid bodies (-1: a deformable body's), and the
  // body's surface point at the contact, where its velocity is taken: the
  // lowest point (along the normal) of the particle that sets the gap.
  int rigid = -1;
  Vector<dim> surface = Vector<dim>::Zero();
  // A point added because its material crossed the obstacle in an attempt
  // of the step without it (find_contact_candidates' `forced`): its open gap
  // may close within the step, u_N >= -g / h, so the material reaches the
  // obstacle instead of stopping where the step began.
  bool closes_gap = false;
};

// A grid point where two velocity fields meet (docs/contact.md#bodies-in-contact):
// bodies in contact with each other. The impulse r that field b gives field a
// (and -r that a gives b) obeys the same Coulomb cone as an obstacle's, with
// the axis -normal (pushing a away from b) and the relative velocity
// u = v_a - v_b. r is condensed as for obstacles: r = R_a(v), the momentum
// imbalance of a's node; a's row becomes the natural map and b's the
// point's total balance R_a + R_b = 0.
template <int dim>
struct BodyContactPoint {
  int node_a = -1, node_b = -1;   // ghosted nodes (owned) at the point: a field, and the point's heaviest (hub)
  PetscInt row_a = 0, row_b = 0;  // local offsets of their first components in the compact vector
  double gap = 0.0;               // the bodies' gap along the normal at t^n
  Vector<dim> normal;             // outward normal of body a: from a into b
  double friction = 0.0;
  double start_normal_velocity = 0.0;  // u_N^n = (v_a^n - v_b^n) . (-normal), > 0 separating
  double rho = 0.0;               // natural-map parameter: the reduced mass m_a m_b / (m_a + m_b)
};

// Active points on or inside an obstacle whose material's gap is closed or
// predicted to close within the step: g + gap_prediction h min(u_N, 0) <= 0
// (docs/contact.md#which-grid-points-are-contact-points). `forced` (per
// ghosted node of `fields`, optional): points that are candidates whatever
// their predicted gap (the material crossed the obstacle in an attempt of
// the step without them). `displacement` (optional, dim per particle): the
// material's gaps are taken at x_p + displacement_p (the end of a step).
template <int dim>
std::vector<ContactPoint<dim>> find_contact_candidates(const Grid<dim>& grid, const Particles<dim>& particles,
                                                       const std::vector<Stencil<dim>>& stencils,
                                                       const GridFields<dim>& fields, const ActiveSet<dim>& active,
                                                       const std::vector<Obstacle<dim>>& obstacles, double time,
                                                       double h, double gap_prediction,
                                                       const std::vector<int>& rigid_of_field = {},
                                                       const std::vector<char>* forced = nullptr,
                                                       const std::vector<double>* displacement = nullptr);

// The step's missed contact points (docs/contact.md#which-grid-points-are-contact-points):
// points on or inside an obstacle at t^n, not among `contacts`, whose
// material would end the step (particles moved by h v_theta, v_theta from
// the grid velocities v_end and v_start) more than 1e-4 cell inside the
// obstacle where it is at t^n + h. Sets `forced` (per ghosted node of
// `fields`, sized here if empty) at them and returns how many this rank
// has; collective.
template <int dim>
long flag_missed_contacts(const Grid<dim>& grid, const Particles<dim>& particles,
                          const std::vector<Stencil<dim>>& stencils, const GridFields<dim>& fields,
                          const ActiveSet<dim>& active, const std::vector<Obstacle<dim>>& obstacles, double time,
                          double h, double theta, const std::vector<double>& v_end, const std::vector<double>& v_start,
                          const std::vector<ContactPoint<dim>>& contacts, std::vector<char>& forced,
                          const std::vector<int>& rigid_of_field = {});

// Points where two fields are predicted to touch within the step:
// g + gap_prediction h min(u_N^n, 0) <= 0, with g the gap between the two
// bodies' particles along the normal. The normal comes from the fields'
// volume gradients g_f = sum over f's particles of V_p grad N_i(x_p), each
// along its body's outward normal (Bardenhagen et al. 2001): a point is a
// contact point only where the two oppose each other within 30 degrees (not
// at a block's corner, where they are 45 degrees apart), and the normal is
// that of the larger body of the two (by volume), whose surface is the
// flatter one at the contact. The gap comes from
// the particles around the point: min over b's particles of x_q . n - e_q
// less max over a's of x_p . n + e_p (e half the extent of the particle's
// initial cube along n), so contact closes when the bodies' surfaces meet,
// not one or two cells early as with shared nodal mass alone. At a point
// the heaviest field is the hub and every other field there is paired with
// it (a = that field, b = the hub): any number of fields can meet. Points
// that are obstacle contacts or carry a constrained component are left out.
// A rigid body's field (rigid_of_field[f] >= 0) is always the hub: its row is
// its rigid constraint and the impulse goes to the body's equations; where two
// rigid bodies meet, nothing holds them apart (not a contact point).
template <int dim>
std::vector<BodyContactPoint<dim>> find_body_contacts(const Grid<dim>& grid, const Particles<dim>& particles,
                                                      const std::vector<Stencil<dim>>& stencils,
                                                      const GridFields<dim>& fields, const ActiveSet<dim>& active,
                                                      const ContactConfig& config,
                                                      const std::vector<ContactPoint<dim>>& obstacle_contacts,
                                                      double h, const std::vector<int>& rigid_of_field = {});

}  // namespace talus
