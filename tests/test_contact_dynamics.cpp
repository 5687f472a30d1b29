// Frictional contact in whole runs, against closed forms (docs/contact.md):
// a block sliding or sticking on an incline (grid aligned with the slope, and
// not), a block dropped on a floor with e = 0, a granular column on a
// frictional floor, a layer at rest on a Coulomb floor, and the earth
// pressure on a frictionless wall.
#include <catch2/catch.hpp>
#include <algorithm>
#include <cmath>
#include <map>

#include "talus/simulation.hpp"
#include "test_support.hpp"

using namespace talus;

namespace {

constexpr double g = 9.81;
constexpr double pi = 3.14159265358979323846;

const std::string stiff_block =
    "{name: rock, model: linear_elastic, density: 2000, youngs_modulus: 2.0e7, poisson_ratio: 0.3}";

// Mass-weighted mean of a particle vector field, over all ranks.
template <int dim>
Vector<dim> mean_field(Particles<dim>& particles, const char* name) {
  FieldView<PetscReal> f(particles.swarm(), name), m(particles.swarm(), field::mass);
  double local[dim + 1] = {};
  for (PetscInt p = 0; p < particles.local_count(); ++p) {
    for (int a = 0; a < dim; ++a) local[a] += m[p] * f[dim * p + a];
    local[dim] += m[p];
  }
  double total[dim + 1];
  MPI_Allreduce(local, total, dim + 1, MPI_DOUBLE, MPI_SUM, PETSC_COMM_WORLD);
  Vector<dim> mean;
  for (int a = 0; a < dim; ++a) mean[a] = total[a] / total[dim];
  return mean;
}

template <int dim>
double max_speed(Particles<dim>& particles) {
  FieldView<PetscReal> v(particles.swarm(), field::velocity);
  double local = 0.0, total = 0.0;
  for (PetscInt p = 0; p < particles.local_count(); ++p)
    local = std::max(local, Eigen::Map<const Vector<dim>>(v.data() + dim * p).norm());
  MPI_Allreduce(&local, &total, 1, MPI_DOUBLE, MPI_MAX, PETSC_COMM_WORLD);
  return total;
}

double run_steps(Simulation<2>& sim, double h, double t_end, long* newton = nullptr, long* steps = nullptr) {
  while (sim.time() < t_end - 1e-12) {
    const StepReport r = sim.advance(std::min(h, t_end - sim.time()));
    INFO("t = " << sim.time() << ": " << r.newton.reason << " after " << r.newton.iterations);
    REQUIRE(r.converged);
    if (newton) *newton += r.newton.iterations;
    if (steps) ++*steps;
  }
  return sim.time();
}

// Grid aligned with the slope: gravity tilted by theta, the floor y_min a
// frictional face. Returns the slide distance of the centre of mass at t.
CaseConfig aligned_incline_case(double theta_deg, double mu, bool explicit_steps = false) {
  const double theta = theta_deg * pi / 180.0;
  CaseConfig c = testing::case_from_yaml(
      "grid: {lower: [0, 0], upper: [1.2, 0.4], cell_size: 0.05}\n"
      "time: {end: 1, step: 0.01}\n"
      "output: {enabled: false}\n"
      "gravity: [" + std::to_string(g * std::sin(theta)) + ", " + std::to_string(-g * std::cos(theta)) + "]\n"
      "materials: [" + stiff_block + "]\n"
      "bodies: [{name: block, material: rock, box: {lower: [0.1, 0.0], upper: [0.5, 0.2]}}]\n"
      "boundaries: {x_min: free, x_max: free, y_min: slip, y_max: free}\n");
  c.faces[2] = FaceCondition::frictional;
  c.face_contact[2].friction = mu;
  if (explicit_steps) c.time.integrator = Integrator::explicit_euler;
  return c;
}

double aligned_incline(double theta_deg, double mu, double t, double step, long* newton, long* steps,
                       bool explicit_steps = false) {
  Simulation<2> sim(aligned_incline_case(theta_deg, mu, explicit_steps), PETSC_COMM_WORLD);
  const Vector<2> x0 = mean_field(sim.particles(), field::position);
  run_steps(sim, step, t, newton, steps);
  const Vector<2> x1 = mean_field(sim.particles(), field::position);
  return x1[0] - x0[0];
}

// Vertical gravity, the incline a half-plane through (0.1, 0.1) at theta, the
// block a rotated rectangle resting on it. Returns the slide distance along the slope.
double rotated_incline(double theta_deg, double mu, double t, double step, long* newton, long* steps,
                       bool explicit_steps = false) {
  const double theta = theta_deg * pi / 180.0;
  const double c0 = std::cos(theta), s0 = std::sin(theta);
  // Rectangle 0.4 x 0.2 with its lower edge on the plane from 0.1 along the slope.
  const auto corner = [&](double along, double up) {
    const double x = 0.1 + along * c0 - up * s0, y = 0.1 + along * s0 + up * c0;
    return "[" + std::to_string(x) + ", " + std::to_string(y) + "]";
  };
  CaseConfig c = testing::case_from_yaml(
      "grid: {lower: [0, 0], upper: [1.4, 1.0], cell_size: 0.05}\n"
      "time: {end: 1, step: 0.01}\n"
      "output: {enabled: false}\n"
      "gravity: [0, -9.81]\n"
      "materials: [" + stiff_block + "]\n"
      "bodies: [{name: block, material: rock, polygon: [" + corner(0.5, 0.0) + ", " + corner(0.9, 0.0) + ", " +
      corner(0.9, 0.2) + ", " + corner(0.5, 0.2) + "]}]\n"
      "boundaries: {x_min: free, x_max: free, y_min: free, y_max: free}\n");
  ObstacleConfig plane;
  plane.name = "incline";
  plane.point = {0.1, 0.1};
  plane.normal = {-s0, c0};
  plane.velocity = {0.0, 0.0};
  plane.friction = mu;
  c.obstacles.push_back(plane);
  if (explicit_steps) c.time.integrator = Integrator::explicit_euler;
  Simulation<2> sim(c, PETSC_COMM_WORLD);
  const Vector<2> x0 = mean_field(sim.particles(), field::position);
  run_steps(sim, step, t, newton, steps);
  const Vector<2> d = mean_field(sim.particles(), field::position) - x0;
  return -(d[0] * c0 + d[1] * s0);  // down the slope
}

}  // namespace

// The backward-Euler velocity update v^{k} = v^{k-1} + h a with x^{k} = x^{k-1} + h v^{k}
// slides 0.5 a t^2 (1 + h / t) in N = t / h steps: the closed form
// 0.5 a t^2 is met to h / t = 1 % with h = 0.005, inside the 2 %;
// the time-discrete value must be met to 0.3 % (the elastic block's own
// vibration under the initial load).
void check_slide(double d, double t, double h, double accel) {
  const double expected = 0.5 * accel * t * t, discrete = expected * (1.0 + h / t);
  INFO("slide " << d << " m, closed form " << expected << " m, time-discrete " << discrete << " m");
  CHECK(std::abs(d - expected) <= 0.02 * expected);
  CHECK(std::abs(d - discrete) <= 0.003 * discrete);
}

TEST_CASE("Block sliding down an incline aligned with the grid: 0.5 g (sin - mu cos) t^2", "[contact][mpi]") {
  const double theta = 30.0, mu = 0.3, t = 0.5, h = 0.005;
  long newton = 0, steps = 0;
  const double d = aligned_incline(theta, mu, t, h, &newton, &steps);
  INFO("Newton/step " << double(newton) / steps);
  check_slide(d, t, h, g * (std::sin(theta * pi / 180) - mu * std::cos(theta * pi / 180)));
}

TEST_CASE("Block sliding down an incline not aligned with the grid", "[contact][mpi]") {
  const double theta = 30.0, mu = 0.3, t = 0.5, h = 0.005;
  long newton = 0, steps = 0;
  const double d = rotated_incline(theta, mu, t, h, &newton, &steps);
  INFO("Newton/step " << double(newton) / steps);
  check_slide(d, t, h, g * (std::sin(theta * pi / 180) - mu * std::cos(theta * pi / 180)));
}

// The explicit integrator (docs/explicit.md): the same block with the grid
// velocities projected onto the Coulomb cone, at half the stable step of the
// stiff block (c_p = 116 m/s, cell 0.05 m: limit 5.3e-4 s). Symplectic Euler
// slides the same time-discrete 0.5 a t^2 (1 + h / t) as the implicit update.
TEST_CASE("Explicit: a block slides down an incline at g (sin - mu cos), or sticks", "[contact][explicit][mpi]") {
  const double theta = 30.0, mu = 0.3, t = 0.5;
  const CaseConfig c = aligned_incline_case(theta, mu);
  const double speed = std::sqrt(c.materials[0].law->elastic_stiffness()(0, 0) / c.materials[0].law->density());
  const double h = 0.5 * explicit_stable_step(c.grid.shape, c.grid.cell_size, speed, 2);
  const double a = g * (std::sin(theta * pi / 180) - mu * std::cos(theta * pi / 180));
  long newton = 0, steps = 0;
  check_slide(aligned_incline(theta, mu, t, h, &newton, &steps, true), t, h, a);
  CHECK(newton == 0);
  // Sticking (tan 20 deg < 0.5), grid aligned: the bound of the implicit test below.
  CHECK(std::abs(aligned_incline(20.0, 0.5, t, h, &newton, &steps, true)) < 1e-4);
  // The plane across the cells is where the explicit contact is less exact
  // than the implicit one: a point is projected only while it approaches,
  // so the block's elastic rebound under the first load lets some contact
  // points separate and slip. Measured 2026-11-25: slide 0.2958 m against
  // the time-discrete 0.2947 m (+0.37 %, the implicit step: within 0.3 %),
  // and a creep of 3.9e-4 m of the sticking block (2.7e-4 m at h / 2; the
  // implicit step: below 1e-4 m), 0.1 % of the frictionless 0.42 m slide.
  const double rotated = rotated_incline(theta, mu, t, h, &newton, &steps, true);
  const double discrete = 0.5 * a * t * t * (1.0 + h / t);
  CHECK(std::abs(rotated - discrete) <= 0.005 * discrete);
  CHECK(std::abs(rotated_incline(20.0, 0.5, t, h, &newton, &steps, true)) < 5e-4);
}

TEST_CASE("Block on an incline with tan(theta) < mu sticks", "[contact]") {
  const double theta = 20.0, mu = 0.5, t = 0.5;
  long newton = 0, steps = 0;
  const double aligned = aligned_incline(theta, mu, t, 0.01, &newton, &steps);
  const double rotated = rotated_incline(theta, mu, t, 0.01, &newton, &steps);
  const double frictionless = 0.5 * g * std::sin(theta * pi / 180) * t * t;
  INFO("aligned " << aligned << " m, rotated " << rotated << " m (frictionless " << frictionless << " m)");
  // The elastic shear of the block under the tangential load is rho g sin(theta) H^2 / (2 G) = 2e-5 m;
  // the rotated grid adds the cut-cell error of the contact points (6e-5 m measured); a slide would be 0.4 m.
  CHECK(std::abs(aligned) < 1e-4);
  CHECK(std::abs(rotated) < 1e-4);
}

TEST_CASE("A block dropped on a floor with e = 0 lands without bouncing and comes to rest", "[contact][mpi]") {
  // Floor: a half-plane at y = 0.13, between grid lines (cell 0.05), so the
  // contact points are grid points inside the floor and just above it.
  const double floor = 0.13, drop = 0.2, cell = 0.05;
  CaseConfig c = testing::case_from_yaml(
      "grid: {lower: [0, 0], upper: [1.0, 0.8], cell_size: 0.05}\n"
      "time: {end: 1, step: 0.005}\n"
      "output: {enabled: false}\n"
      "gravity: [0, -9.81]\n"
      "materials: [{name: rock, model: linear_elastic, density: 2000, youngs_modulus: 5.0e6, poisson_ratio: 0.3}]\n"
      "bodies: [{name: block, material: rock, box: {lower: [0.35, 0.33], upper: [0.65, 0.53]}}]\n"
      "boundaries: {x_min: free, x_max: free, y_min: free, y_max: free}\n");
  ObstacleConfig plane;
  plane.name = "floor";
  plane.point = {0.0, floor};
  plane.normal = {0.0, 1.0};
  plane.velocity = {0.0, 0.0};
  plane.friction = 0.3;
  plane.restitution = 0.0;
  c.obstacles.push_back(plane);
  Simulation<2> sim(c, PETSC_COMM_WORLD);
  const double impact_speed = std::sqrt(2 * g * drop);
  double lowest = 1e9, max_rebound = 0.0, first_contact = -1.0, lift = -1e9;
  bool landed = false;
  long newton = 0, steps = 0;
  while (sim.time() < 1.0 - 1e-12) {
    const StepReport r = sim.advance(0.005);
    REQUIRE(r.converged);
    newton += r.newton.iterations;
    ++steps;
    if (first_contact < 0 && r.contact_points > 0) first_contact = sim.time();
    const Vector<2> v = mean_field(sim.particles(), field::velocity);
    if (first_contact > 0) max_rebound = std::max(max_rebound, v[1]);
    FieldView<PetscReal> x(sim.particles().swarm(), field::position);
    double local = 1e9;
    for (PetscInt p = 0; p < sim.particles().local_count(); ++p) local = std::min(local, x[2 * p + 1]);
    double global;
    MPI_Allreduce(&local, &global, 1, MPI_DOUBLE, MPI_MIN, PETSC_COMM_WORLD);
    lowest = std::min(lowest, global);
    // Touchdown: the lowest particle has reached its resting height.
    if (!landed) landed = global <= floor + 0.25 * cell;
    if (landed) lift = std::max(lift, global - (floor + 0.25 * cell));
  }
  // The lowest particle centre sits half a particle spacing (cell / 4) above
  // the floor when the block rests on it.
  const double penetration = floor + 0.25 * cell - lowest;
  const double final_speed = max_speed(sim.particles());
  const double weight = 0.3 * 0.2 * 2000 * g;
  INFO("first contact at t = " << first_contact << " s (free fall: " << std::sqrt(2 * drop / g) - 0.0
                               << " s), max rebound velocity " << max_rebound << " m/s (impact " << impact_speed
                               << "), penetration " << penetration / cell << " cell, lift-off after impact "
                               << lift / cell << " cell, final max speed "
                               << final_speed << " m/s, floor force " << sim.obstacle_forces()[0].transpose()
                               << " N/m (weight " << weight << "), Newton/step " << double(newton) / steps);
  CHECK(first_contact > 0.0);
  // e = 0: after the impact the block never leaves the floor: its lowest
  // particle never rises above its resting height (-7e-4 cell measured; the
  // former contact rule, which held grid points up to 1.5 cells inside the
  // block, let it lift 0.037 cell). The centre of mass still moves up while
  // the block's elastic compression springs back (2.3 % of the impact speed
  // for one step, then damped): that is the block, not a bounce.
  CHECK(landed);
  CHECK(lift <= 0.01 * cell);
  CHECK(penetration <= 0.05 * cell);  // 0.003 cell measured: contact closes on the particles' gap
  // At rest, and carried by the floor: contact force = weight.
  CHECK(final_speed < 1e-2);
  CHECK(std::abs(sim.obstacle_forces()[0][1] - weight) <= 1e-3 * weight);
  CHECK(std::abs(sim.obstacle_forces()[0][0]) <= 1e-6 * weight);
}

namespace {

// inputs/column_collapse_frictional_floor.yaml on a coarser time span: a = 2, H0 = 1 m.
void collapse_on_frictional_floor(double packing_correction) {
  CaseConfig c = testing::case_from_yaml(
      "grid: {lower: [0, 0], upper: [3.0, 1.2], cell_size: 0.05}\n"
      "time: {end: 2.0, step: 0.0025}\n"
      "output: {enabled: false}\n"
      "gravity: [0, -9.81]\n"
      "materials: [{name: sand, model: drucker_prager, density: 2000, youngs_modulus: 1.0e6, poisson_ratio: 0.3,"
      " friction_angle: 30, dilatancy_angle: 0, cohesion: 0, mohr_coulomb_match: plane_strain}]\n"
      "bodies: [{name: column, material: sand, box: {lower: [0, 0], upper: [0.5, 1.0]}}]\n"
      "boundaries: {x_min: slip, x_max: slip, y_min: slip, y_max: slip}\n");
  c.faces[2] = FaceCondition::frictional;
  c.face_contact[2].friction = 0.4;
  c.transfer.packing_correction = packing_correction;
  Simulation<2> sim(c, PETSC_COMM_WORLD);
  const double bound = std::sqrt(2 * g * 1.0);
  double fastest = 0.0;
  long newton = 0, steps = 0, max_newton = 0;
  // A step that fails is retried at half the step, as run() does; at most
  // 1 % of the 800 steps may cut back (2 measured, in the resting deposit at
  // t = 1.4 s; none with the former contact rule, whose 1.5-cell-thick floor
  // held the bottom of the deposit).
  int cutbacks = 0;
  // The particles of the bottom cell once the deposit is at rest (t = 1.5 s),
  // by their ids: how far they move in the last 0.5 s.
  const double cell = 0.05;
  std::map<std::int64_t, Vector<2>> bottom_at_rest;
  while (sim.time() < 2.0 - 1e-12) {
    if (bottom_at_rest.empty() && sim.time() >= 1.5 - 1e-12) {
      FieldView<PetscReal> x(sim.particles().swarm(), field::position);
      FieldView<std::int64_t> id(sim.particles().swarm(), field::particle_id);
      for (PetscInt p = 0; p < sim.particles().local_count(); ++p)
        if (x[2 * p + 1] < cell) bottom_at_rest[id[p]] = Vector<2>(x[2 * p], x[2 * p + 1]);
    }
    double h = 0.0025;
    StepReport r = sim.advance(h);
    while (!r.converged && h > 0.0025 / 8) {
      ++cutbacks;
      r = sim.advance(h *= 0.5);
    }
    REQUIRE(r.converged);
    newton += r.newton.iterations;
    max_newton = std::max<long>(max_newton, r.newton.iterations);
    ++steps;
    fastest = std::max(fastest, max_speed(sim.particles()));
  }
  const double final_speed = max_speed(sim.particles());
  double creep = 0.0;
  {
    FieldView<PetscReal> x(sim.particles().swarm(), field::position);
    FieldView<std::int64_t> id(sim.particles().swarm(), field::particle_id);
    for (PetscInt p = 0; p < sim.particles().local_count(); ++p)
      if (const auto it = bottom_at_rest.find(id[p]); it != bottom_at_rest.end())
        creep = std::max(creep, (Vector<2>(x[2 * p], x[2 * p + 1]) - it->second).norm());
  }
  FieldView<PetscReal> x(sim.particles().swarm(), field::position);
  double front = 0.0;
  for (PetscInt p = 0; p < sim.particles().local_count(); ++p) front = std::max(front, x[2 * p]);
  INFO("fastest particle " << fastest << " m/s (bound " << bound << "), final max speed " << final_speed
                           << " m/s, front " << front << " m, Newton/step " << double(newton) / steps << " (max "
                           << max_newton << "), cut-backs " << cutbacks << ", bottom cell's particles moved up to "
                           << creep << " m from t = 1.5 to 2 s (" << bottom_at_rest.size() << " particles)");
  CHECK(fastest < bound);
  CHECK(final_speed < 0.05);
  CHECK(cutbacks <= 8);
  // The deposit at rest does not creep along the floor. Measured: 1.1e-3 m
  // without the correction (the deposit's last settling), 4.2e-4 m with it;
  // 8.0e-3 m (a sixth of a cell) when the correction still shifted the
  // particles away from the crowding of the floor's sticking contact points
  // (Simulation::leave_out_sticking_contacts). The bound: twice the
  // settling without the correction.
  REQUIRE(!bottom_at_rest.empty());
  CHECK(creep <= 0.04 * cell);
}

}  // namespace

TEST_CASE("Granular column on a frictional floor (mu = 0.4): below the free-fall speed, deposit at rest",
          "[contact]") {
  collapse_on_frictional_floor(0.0);
}

// The packing correction must leave the deposit at rest too: particles next
// to the frictional face move along it only (docs/transfers.md#packing).
// Without that rule the shift lifted the particles that crowd the face, they
// fell back, and the tip still slid at 0.09 m/s at t = 2 s (0.003 with it).
TEST_CASE("Granular column on a frictional floor with the packing correction: deposit at rest", "[contact]") {
  collapse_on_frictional_floor(0.25);
}

TEST_CASE("A layer at rest on a frictional floor carries its weight down to the bottom row, as on a slip floor",
          "[contact][mpi]") {
  // An elastic layer filling the box between slip side walls, in its
  // geostatic state: nothing moves sideways, so friction has no work to do
  // and a Coulomb floor (contact at the grid points of the face) must give
  // the stresses of a slip face (those points constrained) to the Newton
  // tolerance. A floor that also held the grid points inside the layer
  // (the former rule: every point in the support of a particle touching the
  // floor, 0.5 and 1.5 cells up) unloads the two bottom rows of particles.
  const double H = 0.4, rho = 2000;
  const auto layer = [&](const std::string& floor) {
    CaseConfig c = testing::case_from_yaml(
        "grid: {lower: [0, 0], upper: [0.4, 0.5], cell_size: 0.05}\n"
        "time: {end: 1, step: 0.01}\n"
        "output: {enabled: false}\n"
        "gravity: [0, -9.81]\n"
        "materials: [{name: soil, model: linear_elastic, density: 2000, youngs_modulus: 1.0e7, poisson_ratio: 0.3}]\n"
        "bodies: [{name: layer, material: soil, box: {lower: [0, 0], upper: [0.4, 0.4]}, initial_stress: geostatic}]\n"
        "boundaries: {x_min: slip, x_max: slip, y_min: " + floor + ", y_max: free}\n");
    Simulation<2> sim(c, PETSC_COMM_WORLD);
    for (int k = 0; k < 10; ++k) REQUIRE(sim.advance(0.01).converged);
    return std::make_pair(testing::gather_by_id(sim.particles(), field::stress, 6),
                          testing::gather_by_id(sim.particles(), field::position, 2));
  };
  const auto [slip, x] = layer("slip");
  const std::vector<double> frictional = layer("{condition: frictional, friction: 0.4}").first;
  REQUIRE(slip.size() == frictional.size());
  const double scale = rho * g * H;
  double difference = 0.0, bottom_error = 0.0;
  for (std::size_t p = 0; p < slip.size() / 6; ++p) {
    for (int k = 0; k < 6; ++k) difference = std::max(difference, std::abs(frictional[6 * p + k] - slip[6 * p + k]));
    // The bottom row (y = cell / 4): the lithostatic sigma_yy (the Kirchhoff
    // stress differs from Cauchy's by the strain, 1e-4 here).
    if (x[2 * p + 1] < 0.0125 + 1e-3)
      bottom_error = std::max(bottom_error, std::abs(frictional[6 * p + 1] + rho * g * (H - x[2 * p + 1])));
  }
  INFO("largest stress difference, Coulomb floor against slip face: " << difference / scale
                                                                      << " rho g H; bottom row sigma_yy error "
                                                                      << bottom_error / scale << " rho g H");
  CHECK(difference <= 1e-6 * scale);
  // The discrete equilibrium of the bottom row, the same on the slip face:
  // 1.04 % of rho g H measured; unloaded rows would be ~97 % off.
  CHECK(bottom_error <= 0.02 * scale);
}

namespace {

// A rigid frictionless wall at x = x_wall holding material on its left.
ObstacleConfig frictionless_wall(double x_wall) {
  ObstacleConfig wall;
  wall.name = "wall";
  wall.point = {x_wall, 0.0};
  wall.normal = {-1.0, 0.0};
  wall.velocity = {0.0, 0.0};
  wall.friction = 0.0;
  return wall;
}

}  // namespace

TEST_CASE("Earth pressure on a frictionless wall: K0 rho g H^2 / 2, first order in the cell", "[contact][mpi]") {
  // An elastic soil layer in uniaxial strain between a slip face (x = 0), a
  // slip floor and a frictionless wall half a cell beyond a grid line (x =
  // 0.825 with cell 0.05, 0.8375 with cell 0.025), starting from its
  // geostatic state with k0 = nu / (1 - nu): at rest, the wall carries
  // K0 rho g H^2 / 2. The wall holds the grid points inside it, so its
  // grid position is up to half a cell off: the force converges at first
  // order (1.02 % and 0.51 % low measured, 0.25 % with cell 0.0125). The
  // former rule, which also held points inside the layer, gave the closed
  // form to 1e-8 on these two grids but 1.9 % low with cell 0.0125.
  const double H = 1.0, rho = 2000, nu = 0.3, K0 = nu / (1 - nu);
  const double expected = K0 * rho * g * H * H / 2;
  const auto wall_force = [&](double cell, double x_wall) {
    CaseConfig c = testing::case_from_yaml(
        "grid: {lower: [0, 0], upper: [1.2, 1.2], cell_size: " + std::to_string(cell) + "}\n"
        "time: {end: 1, step: 0.01}\n"
        "output: {enabled: false}\n"
        "gravity: [0, -9.81]\n"
        "materials: [{name: soil, model: linear_elastic, density: 2000, youngs_modulus: 1.0e7, poisson_ratio: 0.3}]\n"
        "bodies: [{name: layer, material: soil, box: {lower: [0, 0], upper: [" + std::to_string(x_wall) +
        ", 1.0]}, initial_stress: geostatic}]\n"
        "boundaries: {x_min: slip, x_max: free, y_min: slip, y_max: free}\n");
    c.obstacles.push_back(frictionless_wall(x_wall));
    Simulation<2> sim(c, PETSC_COMM_WORLD);
    for (int k = 0; k < 20; ++k) REQUIRE(sim.advance(0.01).converged);
    const Vector<2> f = sim.obstacle_forces()[0];
    CHECK(std::abs(f[1]) <= 1e-9 * expected);  // frictionless
    return -f[0];
  };
  const double coarse = wall_force(0.05, 0.825), fine = wall_force(0.025, 0.8375);
  const double e_coarse = std::abs(coarse - expected) / expected, e_fine = std::abs(fine - expected) / expected;
  INFO("wall force " << coarse << " and " << fine << " N/m, closed form " << expected << ": relative errors "
                     << e_coarse << ", " << e_fine << ", order " << std::log2(e_coarse / e_fine));
  CHECK(e_coarse <= 0.011);
  CHECK(std::log2(e_coarse / e_fine) >= 0.9);
}

// The Newton predictor (docs/solver.md#the-predictor): a block sliding at the
// constant acceleration g (sin - mu cos) has, once its first steps have
// passed, nearly the same grid acceleration at every step, so v^n + h a_last
// starts Newton close to the solution, while free fall v^n + h g misses it
// by m_i h |g - a| at every point. The problem is linear once the contact
// points' states are right, so both take one iteration per step; what the
// predictor changes is the start.
TEST_CASE("the last-acceleration predictor starts a steadily sliding block near balance", "[contact][solver]") {
  const double mu = 0.3, h = 0.005;
  const auto start_residuals = [&](const char* predictor) {
    const testing::ScopedOption start("-talus_newton_predictor", predictor);
    const CaseConfig c = aligned_incline_case(30.0, mu);
    Simulation<2> sim(c, PETSC_COMM_WORLD);
    std::vector<double> norms;
    for (int n = 0; n < 40; ++n) {
      const StepReport r = sim.advance(h);
      REQUIRE(r.converged);
      REQUIRE(!r.newton.residual_norms.empty());
      if (n >= 10) norms.push_back(r.newton.residual_norms.front());
    }
    std::sort(norms.begin(), norms.end());
    return norms[norms.size() / 2];
  };
  const double last = start_residuals("last"), gravity = start_residuals("gravity");
  INFO("median initial |F| of steps 11-40: " << last << " (last acceleration), " << gravity << " (free fall)");
  // Measured 2026-11-25: 2.4e-3 against 1.10 (a few steps where the block's
  // leading edge activates a grid point, which starts from free fall, reach
  // 0.3); a hundredth is asserted.
  CHECK(last < 1e-2 * gravity);
}

// Issue 13, item 2: a wall holding a layer at rest must not depend on the
// step size. With quasi-static steps of 1 s (100 times the dynamic
// step above) the contact set stays the same at every step and the wall
// force is the closed form to the grid's first-order error (0.51 % on this
// grid at 0.01 s).
TEST_CASE("a wall holding a layer at rest with steps of 1 s: the same contact points and force", "[contact]") {
  const double H = 1.0, rho = 2000, nu = 0.3, K0 = nu / (1 - nu);
  const double expected = K0 * rho * g * H * H / 2;
  // Two step sizes compared point by point: both held to the balance
  // tolerance (1e-8 of the weight), not to the time-error bound that
  // loosens it up to 1e-4 at steps of 1 s, where a contact point can keep a
  // force of 1e-6 of the wall's (docs/solver.md#the-tolerance-follows-the-time-error).
  const testing::ScopedOption exact_balance("-talus_balance_time_fraction", "0");
  struct Step {
    double force;
    long loaded;  // contact points that carry force
  };
  const auto run = [&](double h) {
    CaseConfig c = testing::case_from_yaml(
        "grid: {lower: [0, 0], upper: [1.2, 1.2], cell_size: 0.025}\n"
        "time: {end: 100, step: 1}\n"
        "output: {enabled: false}\n"
        "gravity: [0, -9.81]\n"
        "materials: [{name: soil, model: linear_elastic, density: 2000, youngs_modulus: 1.0e7, poisson_ratio: 0.3}]\n"
        "bodies: [{name: layer, material: soil, box: {lower: [0, 0], upper: [0.8375, 1.0]}, initial_stress: geostatic}]\n"
        "boundaries: {x_min: slip, x_max: free, y_min: slip, y_max: free}\n");
    c.obstacles.push_back(frictionless_wall(0.8375));
    Simulation<2> sim(c, PETSC_COMM_SELF);
    std::vector<Step> steps;
    for (int k = 0; k < 20; ++k) {
      REQUIRE(sim.advance(h).converged);
      long loaded = 0;
      for (const auto& n : sim.nodal_contacts()) loaded += n.force.norm() > 1e-6 * expected;
      steps.push_back({-sim.obstacle_forces()[0][0], loaded});
    }
    return steps;
  };
  const std::vector<Step> dynamic = run(0.01), quasi_static = run(1.0);
  // Measured 2026-11-25: at 1 s, 84 loaded points in the first step (the
  // geostatic start) and 82 in every later one, as the 0.01 s run ends
  // with; the force 4182.958 N/m from the first step on, 0.51 % below the
  // closed form (the wall's first-order grid position), equal to the 0.01 s
  // run's final force to 7 digits (the first step to 1.3e-6). The issue measured 2-49 % low with
  // points dropping out one at a time (before the one-row contact rule of
  // 15207c3 and the later solver work).
  const long settled = dynamic.back().loaded;
  for (int k = 0; k < 20; ++k) {
    INFO("step " << k << " of 1 s: " << quasi_static[k].loaded << " loaded contact points, force "
                 << quasi_static[k].force << " N/m (0.01 s run: " << settled << ", " << dynamic.back().force << ")");
    CHECK(std::abs(quasi_static[k].force - expected) <= 0.01 * expected);
    // The first step of 1 s also equilibrates the seeded geostatic state
    // (1.3e-6 relative off the final force, measured); later ones 0.
    CHECK(std::abs(quasi_static[k].force - dynamic.back().force) <= 1e-5 * expected);
    CHECK(quasi_static[k].loaded >= settled);
    if (k > 0) CHECK(quasi_static[k].loaded == settled);
  }
}

// The same wall a round-off away from the layer (x = 0.8 + 0.025 in floating
// point, 1e-16 m beyond the layer's face): the layer's gap is open at t = 0,
// so no contact point is predicted; its stress pushes it 5e-4 m across the
// wall within the first step of 1 s. Before the missed contact points were
// solved again, the velocity-level condition then held it there, relieved,
// and the wall carried 0.03 N/m for good (100 % low). Now the first step is
// solved again with the crossed points as contact points, whose open gap
// closes within the step, and the wall carries the earth pressure at every
// step.
TEST_CASE("a wall a round-off away from a layer at rest with steps of 1 s carries the earth pressure from the first step", "[contact][mpi]") {
  const double H = 1.0, rho = 2000, nu = 0.3, K0 = nu / (1 - nu);
  const double expected = K0 * rho * g * H * H / 2;
  const double x_wall = 0.8 + 0.025;  // 0.8250000000000001
  REQUIRE(x_wall > 0.825);
  std::ostringstream yaml;
  yaml.precision(17);
  yaml << "grid: {lower: [0, 0], upper: [1.2, 1.2], cell_size: 0.05}\n"
          "time: {end: 20, step: 1}\n"
          "output: {enabled: false}\n"
          "gravity: [0, -9.81]\n"
          "materials: [{name: soil, model: linear_elastic, density: 2000, youngs_modulus: 1.0e7, poisson_ratio: 0.3}]\n"
          "bodies: [{name: layer, material: soil, box: {lower: [0, 0], upper: [0.825, 1.0]}, initial_stress: geostatic}]\n"
          "boundaries: {x_min: slip, x_max: free, y_min: slip, y_max: free}\n";
  CaseConfig c = testing::case_from_yaml(yaml.str());
  c.obstacles.push_back(frictionless_wall(x_wall));
  Simulation<2> sim(c, PETSC_COMM_WORLD);
  for (int k = 0; k < 20; ++k) {
    const StepReport r = sim.advance(1.0);
    REQUIRE(r.converged);
    const double force = -sim.obstacle_forces()[0][0];
    INFO("step " << k << ": wall force " << force << " N/m (closed form " << expected << "), solved again "
                 << r.contact_resolves << " times");
    // Measured: 4161.18 N/m at every step, the touching wall's force on this
    // grid (1.02 % below the closed form, first order in the cell, as in the
    // earth-pressure test above) to 1e-8; one re-solve in the first step.
    CHECK(std::abs(force - expected) <= 0.011 * expected);
    CHECK(r.contact_resolves == (k == 0 ? 1 : 0));
  }
}
