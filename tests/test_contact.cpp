// The Coulomb cone, De Saxce's modified velocity and the natural map
// (include/talus/contact/coulomb_cone.hpp) against their definitions, and the
// Jacobian of the momentum system with contact rows against finite differences.
#include <catch2/catch.hpp>
#include <cmath>
#include <random>

#include "talus/contact/coulomb_cone.hpp"
#include "talus/simulation.hpp"
#include "talus/solver/momentum_system.hpp"
#include "test_support.hpp"

using namespace talus;

namespace {

template <int dim>
Vector<dim> random_unit(std::mt19937& rng) {
  std::normal_distribution<double> g;
  Vector<dim> n;
  for (int a = 0; a < dim; ++a) n[a] = g(rng);
  return n.normalized();
}

template <int dim>
Vector<dim> random_vector(std::mt19937& rng, double scale = 1.0) {
  std::normal_distribution<double> g(0.0, scale);
  Vector<dim> x;
  for (int a = 0; a < dim; ++a) x[a] = g(rng);
  return x;
}

// A unit vector orthogonal to n (any, in 3D).
template <int dim>
Vector<dim> tangent_of(const Vector<dim>& n, std::mt19937& rng) {
  Vector<dim> t = random_vector<dim>(rng);
  t -= t.dot(n) * n;
  return t.normalized();
}

template <int dim>
bool in_cone(const Vector<dim>& r, const Vector<dim>& n, double mu, double tol) {
  const double rn = r.dot(n);
  return (r - rn * n).norm() <= mu * rn + tol;
}
template <int dim>
bool in_dual_cone(const Vector<dim>& y, const Vector<dim>& n, double mu, double tol) {
  const double yn = y.dot(n);
  return mu * (y - yn * n).norm() <= yn + tol;
}

template <int dim>
void check_projection() {
  std::mt19937 rng(7 + dim);
  std::uniform_real_distribution<double> mus(0.0, 1.5);
  int counts[3] = {0, 0, 0};
  for (int k = 0; k < 3000; ++k) {
    const Vector<dim> n = random_unit<dim>(rng);
    const double mu = k % 10 == 0 ? 0.0 : mus(rng);
    const Vector<dim> x = random_vector<dim>(rng);
    const ConeProjection<dim> p = project_onto_coulomb_cone<dim>(x, n, mu);
    ++counts[static_cast<int>(p.region)];
    // Idempotent, in K, and Moreau's decomposition: x - P(x) lies in the polar
    // cone -K* and is orthogonal to P(x).
    const ConeProjection<dim> pp = project_onto_coulomb_cone<dim>(p.value, n, mu);
    REQUIRE((pp.value - p.value).norm() <= 1e-14 * (1.0 + x.norm()));
    REQUIRE(in_cone<dim>(p.value, n, mu, 1e-13));
    REQUIRE(in_dual_cone<dim>(p.value - x, n, mu, 1e-13));
    REQUIRE(std::abs((x - p.value).dot(p.value)) <= 1e-13 * x.squaredNorm());
    // The three cases, exact.
    const double xn = x.dot(n), xt = (x - xn * n).norm();
    if (xt <= mu * xn) {
      REQUIRE(p.region == ConeRegion::inside);
      REQUIRE(p.value == x);
    } else if (mu * xt <= -xn) {
      REQUIRE(p.region == ConeRegion::polar);
      REQUIRE(p.value.norm() == 0.0);
    } else {
      REQUIRE(p.region == ConeRegion::boundary);
      const double pn = p.value.dot(n), pt = (p.value - pn * n).norm();
      REQUIRE(std::abs(pt - mu * pn) <= 1e-14 * x.norm());
      // Projection of a point onto a ray: distance to the cone's generator
      // through x's tangential direction, closed form sqrt of the polar part.
      const double expected_pn = (xn + mu * xt) / (1.0 + mu * mu);
      REQUIRE(std::abs(pn - expected_pn) <= 1e-14 * x.norm());
    }
  }
  INFO("inside " << counts[0] << ", polar " << counts[1] << ", boundary " << counts[2]);
  CHECK(counts[0] > 100);
  CHECK(counts[1] > 300);
  CHECK(counts[2] > 300);
}

TEST_CASE("Coulomb cone projection: idempotent, Moreau decomposition, three cases exact", "[contact]") {
  check_projection<2>();
  check_projection<3>();
}

// Complementary pairs built from the three cases give Phi = 0 for any rho;
// random pairs give Phi = 0 only if they happen to be complementary.
template <int dim>
void check_natural_map_complementarity() {
  std::mt19937 rng(11 + dim);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  for (int k = 0; k < 2000; ++k) {
    const Vector<dim> n = random_unit<dim>(rng);
    const Vector<dim> t = tangent_of<dim>(n, rng);
    const double mu = 1.2 * uni(rng), e = k % 3 == 0 ? uni(rng) : 0.0, un0 = -uni(rng), rho = 0.1 + 10 * uni(rng);
    Vector<dim> r, u;
    switch (k % 3) {
      case 0:  // sticking: r strictly inside K, u_hat = 0 (u_N = -e u_N^n, u_T = 0)
        r = (1.0 + uni(rng)) * (n + 0.9 * mu * uni(rng) * t);
        u = -e * un0 * n;
        break;
      case 1: {  // sliding: r on the boundary, opposing u_T; u_N = -e u_N^n
        const double s = 0.1 + uni(rng);
        r = (0.5 + uni(rng)) * (n - mu * t);
        u = s * t - e * un0 * n;
        break;
      }
      default:  // separating: r = 0, u_hat anywhere in K*
        r.setZero();
        u = (uni(rng) + 0.01) * n + 0.5 * uni(rng) * t;
        break;
    }
    const NaturalMap<dim> m = natural_map<dim>(r, u, n, mu, e, un0, rho);
    REQUIRE(m.value.norm() <= 1e-13 * (1.0 + r.norm() + rho * u.norm()));
  }
  // Random pairs: Phi = 0  <=>  r in K, u_hat in K*, r . u_hat = 0.
  int zero = 0;
  for (int k = 0; k < 5000; ++k) {
    const Vector<dim> n = random_unit<dim>(rng);
    const double mu = 1.2 * uni(rng), rho = 0.1 + 10 * uni(rng);
    Vector<dim> r = random_vector<dim>(rng), u = random_vector<dim>(rng);
    if (k % 2 == 0) r = project_onto_coulomb_cone<dim>(r, n, mu).value;  // some admissible impulses
    if (k % 4 == 0) u.setZero();                                          // some sticking velocities
    const Vector<dim> u_hat = modified_velocity<dim>(u, n, mu, 0.0, 0.0);
    const bool complementary = in_cone<dim>(r, n, mu, 1e-12) && in_dual_cone<dim>(u_hat, n, mu, 1e-12) &&
                               std::abs(r.dot(u_hat)) <= 1e-12 * (1.0 + r.norm() * u_hat.norm());
    const NaturalMap<dim> m = natural_map<dim>(r, u, n, mu, 0.0, 0.0, rho);
    const bool vanishes = m.value.norm() <= 1e-12 * (1.0 + r.norm() + rho * u.norm());
    zero += vanishes;
    REQUIRE(vanishes == complementary);
  }
  CHECK(zero > 100);  // the random set holds complementary pairs (u = 0 with r in K)
}

TEST_CASE("Natural map is zero exactly at complementary pairs", "[contact]") {
  check_natural_map_complementarity<2>();
  check_natural_map_complementarity<3>();
}

// dPhi/dr and dPhi/du against central differences, away from the kinks of
// the projection and of ||u_T||.
template <int dim>
void check_natural_map_derivative() {
  std::mt19937 rng(23 + dim);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  int regions[3] = {0, 0, 0};
  double worst = 0.0;
  for (int k = 0; k < 3000; ++k) {
    const Vector<dim> n = random_unit<dim>(rng);
    const double mu = 0.05 + uni(rng), e = uni(rng), un0 = -uni(rng), rho = 0.5 + 2 * uni(rng);
    const Vector<dim> r = random_vector<dim>(rng), u = random_vector<dim>(rng);
    const NaturalMap<dim> m = natural_map<dim>(r, u, n, mu, e, un0, rho);
    // Distance to the kinks: the cone boundary and its polar, and u_T = 0.
    const Vector<dim> x = r - rho * modified_velocity<dim>(u, n, mu, e, un0);
    const double xn = x.dot(n), xt = (x - xn * n).norm();
    const double margin = std::min({std::abs(xt - mu * xn), std::abs(mu * xt + xn), (u - u.dot(n) * n).norm()});
    if (margin < 1e-3) continue;
    ++regions[static_cast<int>(m.region)];
    const double eps = 1e-6;
    Matrix<dim> dr, du;
    for (int b = 0; b < dim; ++b) {
      Vector<dim> d = Vector<dim>::Zero();
      d[b] = eps;
      dr.col(b) = (natural_map<dim>(r + d, u, n, mu, e, un0, rho).value -
                   natural_map<dim>(r - d, u, n, mu, e, un0, rho).value) / (2 * eps);
      du.col(b) = (natural_map<dim>(r, u + d, n, mu, e, un0, rho).value -
                   natural_map<dim>(r, u - d, n, mu, e, un0, rho).value) / (2 * eps);
    }
    const double error = std::max((dr - m.d_impulse).norm(), (du - m.d_velocity).norm() / rho);
    worst = std::max(worst, error);
  }
  INFO(dim << "D: inside " << regions[0] << ", polar " << regions[1] << ", boundary " << regions[2]
           << ", worst |J - FD| " << worst);
  // Central differences of a smooth map with eps = 1e-6: error ~ eps^2 |Phi'''| + 1e-16 / eps ~ 1e-9.
  CHECK(worst < 1e-7);
  CHECK(regions[0] > 100);
  CHECK(regions[1] > 100);
  CHECK(regions[2] > 100);
}

TEST_CASE("Generalized Jacobian of the natural map equals finite differences away from kinks", "[contact]") {
  check_natural_map_derivative<2>();
  check_natural_map_derivative<3>();
}

double hashed(long key, int salt) { return std::sin(12.9898 * key + 78.233 * salt) * 0.5; }

// The whole step's residual with contact rows: J w against central
// differences of F, a Drucker-Prager body pressed on an inclined frictional
// half-plane, with points sticking, sliding and separating.
template <int dim>
void check_system_jacobian(bool slip_floor_and_wall) {
  const std::string lo = dim == 2 ? "[0, 0]" : "[0, 0, 0]";
  const std::string hi = dim == 2 ? "[1.0, 0.8]" : "[0.6, 0.5, 0.5]";
  const std::string floor = slip_floor_and_wall ? "0.0" : "0.1";
  const std::string blo = dim == 2 ? "[0.1, " + floor + "]" : "[0.1, 0.1, " + floor + "]";
  const std::string bhi = dim == 2 ? "[0.73, 0.52]" : "[0.45, 0.3, 0.35]";
  const std::string g = dim == 2 ? "[0, -9.81]" : "[0, 0, -9.81]";
  CaseConfig config = testing::case_from_yaml(
      "grid: {lower: " + lo + ", upper: " + hi + ", cell_size: 0.1}\n"
      "time: {end: 1, step: 0.01}\n"
      "output: {enabled: false}\n"
      "gravity: " + g + "\n"
      "materials: [{name: m, model: drucker_prager, density: 2000, youngs_modulus: 1.0e6, poisson_ratio: 0.3, "
      "friction_angle: 30, dilatancy_angle: 0, cohesion: 5.0e3}]\n"
      "bodies: [{name: b, material: m, box: {lower: " + blo + ", upper: " + bhi + "}}]\n"
      "boundaries: {x_min: free, x_max: free, " + (dim == 2 ? std::string(slip_floor_and_wall ? "y_min: slip" : "y_min: free") + ", y_max: free" : std::string("y_min: free, y_max: free, z_min: ") + (slip_floor_and_wall ? "slip" : "free") + ", z_max: free") + "}\n");
  Simulation<dim> sim(config, PETSC_COMM_WORLD);
  Particles<dim>& particles = sim.particles();
  {
    FieldView<PetscReal> s(particles.swarm(), field::stress), v(particles.swarm(), field::velocity);
    FieldView<std::int64_t> id(particles.swarm(), field::particle_id);
    for (PetscInt p = 0; p < particles.local_count(); ++p) {
      const long k = static_cast<long>(id[p]);
      for (int i = 0; i < 6; ++i) s[6 * p + i] = 2e4 * hashed(k, i);
      for (int a = 0; a < dim; ++a) v[dim * p + a] = hashed(k, 10 + a);
    }
  }
  const Grid<dim>& grid = sim.grid();
  testing::GridStep<dim> step(grid, particles, config);
  auto& [stencils, fields, active] = step;
  // An inclined plane through the body's lower part, moving, with restitution.
  ObstacleConfig plane;
  plane.name = "incline";
  plane.point.assign(dim, 0.2);
  plane.normal.assign(dim, 0.0);
  plane.normal[0] = 0.3;
  plane.normal[dim - 1] = 1.0;
  plane.velocity.assign(dim, 0.0);
  plane.velocity[0] = 0.05;
  plane.friction = 0.4;
  plane.restitution = 0.3;
  if (slip_floor_and_wall) {  // a vertical wall through the body on a slip floor: contact at slip points
    plane.point.assign(dim, 0.0);
    plane.point[0] = 0.23;
    plane.normal.assign(dim, 0.0);
    plane.normal[0] = 1.0;
    plane.velocity.assign(dim, 0.0);
  }
  std::vector<Obstacle<dim>> obstacles{Obstacle<dim>(plane)};
  const double h = 0.02;
  auto contacts = find_contact_candidates(grid, particles, stencils, fields, active, obstacles, 0.0, h, 0.5);
  long candidates = static_cast<long>(contacts.size());
  MPI_Allreduce(MPI_IN_PLACE, &candidates, 1, MPI_LONG, MPI_SUM, PETSC_COMM_WORLD);
  REQUIRE(candidates >= 6);
  long on_slip_face = 0;
  for (const auto& cp : contacts) on_slip_face += !cp.free[dim - 1];
  MPI_Allreduce(MPI_IN_PLACE, &on_slip_face, 1, MPI_LONG, MPI_SUM, PETSC_COMM_WORLD);
  if (slip_floor_and_wall) REQUIRE(on_slip_face >= 1);
  std::vector<const Material*> materials{config.materials[0].law.get()};
  Vector<dim> gravity = Vector<dim>::Zero();
  gravity[dim - 1] = -9.81;
  MomentumSystem<dim> system(grid, particles, stencils, fields, active, materials, gravity, h, 1.0, contacts);

  Vec v = system.initial_guess(), w, vp, vm, Fp, Fm, Jw, F0;
  TALUS_PETSC(VecDuplicate(v, &w));
  PetscInt first, last;
  TALUS_PETSC(VecGetOwnershipRange(v, &first, &last));
  for (PetscInt r = first; r < last; ++r) {
    TALUS_PETSC(VecSetValue(v, r, 0.3 * hashed(r, 50), ADD_VALUES));
    TALUS_PETSC(VecSetValue(w, r, hashed(r, 60), INSERT_VALUES));
  }
  for (Vec x : {v, w}) {
    TALUS_PETSC(VecAssemblyBegin(x));
    TALUS_PETSC(VecAssemblyEnd(x));
  }
  for (Vec* x : {&vp, &vm, &Fp, &Fm, &Jw, &F0}) TALUS_PETSC(VecDuplicate(v, x));
  system.residual(v, F0);
  long regions[3] = {0, 0, 0};
  for (const auto& m : system.contact_maps()) ++regions[static_cast<int>(m.region)];
  MPI_Allreduce(MPI_IN_PLACE, regions, 3, MPI_LONG, MPI_SUM, PETSC_COMM_WORLD);
  INFO("contact candidates " << candidates << ": sticking " << regions[0] << ", separating " << regions[1]
                             << ", sliding " << regions[2]);
  CHECK(regions[1] + regions[0] >= 1);
  CHECK(regions[2] >= 1);
  const double eps = 1e-7;
  TALUS_PETSC(VecWAXPY(vp, eps, w, v));
  TALUS_PETSC(VecWAXPY(vm, -eps, w, v));
  system.residual(vp, Fp);
  system.residual(vm, Fm);
  // The difference must not straddle a kink: same regions at v +- eps w.
  TALUS_PETSC(VecAXPY(Fp, -1.0, Fm));
  TALUS_PETSC(VecScale(Fp, 0.5 / eps));
  Mat J = system.create_matrix();
  system.jacobian(v, J);
  TALUS_PETSC(MatMult(J, w, Jw));
  double norm_jw, norm_diff;
  TALUS_PETSC(VecNorm(Jw, NORM_2, &norm_jw));
  TALUS_PETSC(VecAXPY(Fp, -1.0, Jw));
  TALUS_PETSC(VecNorm(Fp, NORM_2, &norm_diff));
  INFO(dim << "D" << (slip_floor_and_wall ? " wall on a slip floor" : "") << ": |J w| = " << norm_jw << ", |J w - FD| = " << norm_diff);
  // Same bound as the plastic Jacobian test (tests/test_jacobian.cpp): round-off
  // 1e-16 |F| / eps and curvature eps |F''| are both below 1e-8 relative.
  CHECK(norm_diff <= 1e-6 * norm_jw);
  // The block matrix of the direct solvers holds the same Jacobian: the same
  // sums, only stored by dim x dim blocks (round-off at most).
  CHECK(testing::block_matrix_difference(system, v, J) <= 1e-14);
  // The Jacobian as an operator, without the matrix (3D's default with kept
  // factors): the same products, summed in another order (round-off).
  CHECK(testing::operator_difference(system, v, w, Jw) <= 1e-13);
  // Point-block Jacobi's matrix (3D's default preconditioner of the
  // operator): the Jacobian's diagonal blocks, summed without the block rows.
  CHECK(testing::block_diagonal_difference(system, v, J) <= 1e-13);
  PetscInt rows;
  TALUS_PETSC(MatGetSize(J, &rows, nullptr));
  CHECK(rows == active.global_count() * dim);  // contact adds no unknowns
  for (Vec* x : {&v, &w, &vp, &vm, &Fp, &Fm, &Jw, &F0}) TALUS_PETSC(VecDestroy(x));
  TALUS_PETSC(MatDestroy(&J));
}

}  // namespace

TEST_CASE("Jacobian with frictional contact rows equals finite differences (2D)", "[contact][mpi]") {
  check_system_jacobian<2>(false);
  check_system_jacobian<2>(true);
}

TEST_CASE("Jacobian with frictional contact rows equals finite differences (3D)", "[contact][mpi]") {
  check_system_jacobian<3>(false);
  check_system_jacobian<3>(true);
}
