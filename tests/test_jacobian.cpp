// The assembled Jacobian agrees with central finite differences of the
// residual, on a deformed state (non-zero stress, so the Jaumann rotation
// terms matter), 2D and 3D, theta = 1 and 1/2, serial and across ranks.
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>

#include "talus/simulation.hpp"
#include "talus/solver/momentum_system.hpp"
#include "test_support.hpp"

using namespace talus;

namespace {

double hashed(long key, int salt) { return std::sin(12.9898 * key + 78.233 * salt) * 0.5; }

const std::string elastic = "{name: m, model: linear_elastic, density: 2000, youngs_modulus: 1.0e6, poisson_ratio: 0.3}";
// Nonassociated (psi = 0) with hardening: every return-mapping branch has a non-trivial tangent.
const std::string plastic =
    "{name: m, model: drucker_prager, density: 2000, youngs_modulus: 1.0e6, poisson_ratio: 0.3, friction_angle: 30, "
    "dilatancy_angle: 0, cohesion: 5.0e3, hardening_modulus: 1.0e5}";

// One box of `material` in a grid from the origin to `hi`, cells of 0.1.
std::string block_case(const std::string& shape, const std::string& hi, const std::string& blo,
                       const std::string& bhi, const std::string& gravity, const std::string& faces,
                       const std::string& material) {
  const std::string lo = std::count(hi.begin(), hi.end(), ',') == 1 ? "[0, 0]" : "[0, 0, 0]";
  return "grid: {lower: " + lo + ", upper: " + hi + ", cell_size: 0.1, shape_function: " + shape +
         "}\n"
         "time: {end: 1, step: 0.01}\n"
         "output: {enabled: false}\n"
         "gravity: " + gravity + "\n"
         "materials: [" + material + "]\n"
         "bodies: [{name: b, material: m, box: {lower: " + blo + ", upper: " + bhi + "}}]\n" + faces;
}

template <int dim>
std::string jacobian_case(const std::string& shape, const std::string& faces, const std::string& material) {
  return block_case(shape, dim == 2 ? "[1.0, 0.8]" : "[0.6, 0.5, 0.4]", dim == 2 ? "[0.0, 0.0]" : "[0.0, 0.0, 0.0]",
                    dim == 2 ? "[0.63, 0.52]" : "[0.45, 0.3, 0.25]", dim == 2 ? "[0, -9.81]" : "[0, 0, -9.81]",
                    faces, material);
}

template <int dim>
void check_jacobian(const std::string& shape, double theta, const std::string& material = elastic,
                    bool separated = false, double ghost_penalty = 0.0,
                    StrainIncrement increment = StrainIncrement::linear) {
  const std::string faces = dim == 2 ? "boundaries: {x_min: fixed, x_max: free, y_min: slip, y_max: free}\n"
                                     : "boundaries: {x_min: fixed, y_min: slip, z_min: slip}\n";
  CaseConfig config = testing::case_from_yaml(jacobian_case<dim>(shape, faces, material));
  // The residual is linear in v for elasticity with the linear increment only.
  const bool linear = material == elastic && increment == StrainIncrement::linear;
  config.time.theta = theta;
  Simulation<dim> sim(config, PETSC_COMM_WORLD);
  Particles<dim>& particles = sim.particles();
  // A deformed state: stresses of order 1e-2 E, velocities, distorted F.
  {
    FieldView<PetscReal> s(particles.swarm(), field::stress), v(particles.swarm(), field::velocity),
        F(particles.swarm(), field::deformation_gradient);
    FieldView<PetscReal> separation(particles.swarm(), field::separation_strain);
    FieldView<std::int64_t> id(particles.swarm(), field::particle_id);
    for (PetscInt p = 0; p < particles.local_count(); ++p) {
      const long k = static_cast<long>(id[p]);
      // Half the particles carry voids of up to 5 % volumetric strain, of the
      // order of this step's strain increments: some close partly, some fully.
      if (separated && k % 2 == 0) separation[p] = 0.05 * (hashed(k, 30) + 0.5);
      for (int i = 0; i < 6; ++i) s[6 * p + i] = 2e4 * hashed(k, i);
      for (int a = 0; a < dim; ++a) v[dim * p + a] = hashed(k, 10 + a);
      for (int a = 0; a < dim * dim; ++a) F[dim * dim * p + a] += 0.05 * hashed(k, 20 + a);
    }
  }
  const Grid<dim>& grid = sim.grid();
  testing::GridStep<dim> step(grid, particles, config);
  auto& [stencils, fields, active] = step;
  std::vector<const Material*> materials{config.materials[0].law.get()};
  Vector<dim> g = Vector<dim>::Zero();
  g[dim - 1] = -9.81;
  const double h = 0.02;
  MomentumSystem<dim> system(grid, particles, stencils, fields, active, materials, g, h, theta);
  system.set_strain_increment(increment);
  std::unique_ptr<GhostPenalty<dim>> ghost;
  if (ghost_penalty > 0) {
    ghost = std::make_unique<GhostPenalty<dim>>(grid, particles, stencils, fields, active, materials, ghost_penalty);
    // The block's free faces cut the cells they pass through.
    INFO("cut cells " << ghost->global_cells());
    CHECK(ghost->global_cells() >= (dim == 2 ? 10 : 20));
    system.set_ghost_penalty(ghost.get());
  }

  Vec v = system.initial_guess(), w, vp, vm, Fp, Fm, Jw;
  TALUS_PETSC(VecDuplicate(v, &w));
  PetscInt first, last;
  TALUS_PETSC(VecGetOwnershipRange(v, &first, &last));
  for (PetscInt r = first; r < last; ++r) {
    TALUS_PETSC(VecSetValue(v, r, hashed(r, 50), ADD_VALUES));
    TALUS_PETSC(VecSetValue(w, r, hashed(r, 60), INSERT_VALUES));
  }
  TALUS_PETSC(VecAssemblyBegin(v));
  TALUS_PETSC(VecAssemblyEnd(v));
  TALUS_PETSC(VecAssemblyBegin(w));
  TALUS_PETSC(VecAssemblyEnd(w));
  for (Vec* x : {&vp, &vm, &Fp, &Fm, &Jw}) TALUS_PETSC(VecDuplicate(v, x));
  // The elastic residual is linear in v; the plastic one is piecewise smooth,
  // so its difference step is small enough not to cross a branch boundary.
  const double eps = linear ? 1e-4 : 1e-7;
  TALUS_PETSC(VecWAXPY(vp, eps, w, v));
  TALUS_PETSC(VecWAXPY(vm, -eps, w, v));
  system.residual(vp, Fp);
  system.residual(vm, Fm);
  TALUS_PETSC(VecAXPY(Fp, -1.0, Fm));
  TALUS_PETSC(VecScale(Fp, 0.5 / eps));  // central difference of F along w

  Vec F0;
  TALUS_PETSC(VecDuplicate(v, &F0));
  system.residual(v, F0);
  if (material != elastic) {  // the state must actually be plastic for the test to mean anything
    long yielding = 0;
    for (const Voigt& e : system.plastic_strain_increment()) yielding += e.norm() > 0;
    MPI_Allreduce(MPI_IN_PLACE, &yielding, 1, MPI_LONG, MPI_SUM, PETSC_COMM_WORLD);
    INFO("particles yielding: " << yielding);
    CHECK(yielding > 10);
  }
  if (separated) {  // both closing branches must be hit, or the test means nothing
    long partly = 0, fully = 0;
    FieldView<PetscReal> separation(particles.swarm(), field::separation_strain);
    const auto& end = system.end_separation();
    for (std::size_t p = 0; p < end.size(); ++p) {
      partly += separation[p] > 0.0 && end[p] > 0.0 && end[p] < separation[p];
      fully += separation[p] > 0.0 && end[p] == 0.0;
    }
    MPI_Allreduce(MPI_IN_PLACE, &partly, 1, MPI_LONG, MPI_SUM, PETSC_COMM_WORLD);
    MPI_Allreduce(MPI_IN_PLACE, &fully, 1, MPI_LONG, MPI_SUM, PETSC_COMM_WORLD);
    INFO("voids closing partly: " << partly << ", fully: " << fully);
    CHECK(partly >= 3);
    CHECK(fully >= 3);
  }
  Mat J = system.create_matrix();
  system.jacobian(v, J);
  TALUS_PETSC(MatMult(J, w, Jw));
  double norm_jw, norm_diff;
  TALUS_PETSC(VecNorm(Jw, NORM_2, &norm_jw));
  TALUS_PETSC(VecAXPY(Fp, -1.0, Jw));
  TALUS_PETSC(VecNorm(Fp, NORM_2, &norm_diff));
  INFO(dim << "D " << shape << " theta " << theta << " ghost penalty " << ghost_penalty
            << (material == elastic ? " elastic" : " Drucker-Prager")
            << (increment == StrainIncrement::logarithmic ? " logarithmic increment" : "") << ": |J w| = " << norm_jw
            << ", |J w - FD| = " << norm_diff);
  // The elastic residual is linear in v, so the central difference is exact up
  // to round-off (~1e-16 |F| / eps = 1e-12 relative); any missing or wrong
  // term (rotation, theta, constraints) shows at >= 1e-3.
  CHECK(norm_diff <= (linear ? 1e-9 : 1e-6) * norm_jw);
  // The block matrix of the direct solvers holds the same Jacobian: the same
  // sums, only stored by dim x dim blocks (round-off at most).
  CHECK(testing::block_matrix_difference(system, v, J) <= 1e-14);
  // The Jacobian as an operator, without the matrix (3D's default with kept
  // factors): the same products, summed in another order (round-off).
  CHECK(testing::operator_difference(system, v, w, Jw) <= 1e-13);
  // Point-block Jacobi's matrix (3D's default preconditioner of the
  // operator): the Jacobian's diagonal blocks, summed without the block rows.
  CHECK(testing::block_diagonal_difference(system, v, J) <= 1e-13);
  // ... in 3D through the tensor-product kernels for every particle of
  // quadratic B-splines at points (tensor_stencil.cpp), node by node for
  // hats and in 2D, and both in one product with quadratic B-splines
  // averaged over domains (a domain that spans one knot span more on an
  // axis has 4 functions there).
  const std::size_t local_particles = static_cast<std::size_t>(particles.local_count());
  const std::size_t tensor_particles = system.tensor_stencil_particles();
  INFO("particles on the tensor-product path: " << tensor_particles << " of " << local_particles);
  if (shape == "quadratic_bspline")
    CHECK(tensor_particles == (dim == 3 ? local_particles : 0u));
  else if (shape == "linear" || dim == 2)
    CHECK(tensor_particles == 0u);
  else if (shape == "quadratic_bspline, quadrature: domain" && local_particles > 0)
    CHECK((tensor_particles > 0u && tensor_particles < local_particles));
  // Constrained rows are m_i e_i: the Jacobian is non-singular and the diagonal is positive.
  Vec diag;
  TALUS_PETSC(VecDuplicate(v, &diag));
  TALUS_PETSC(MatGetDiagonal(J, diag));
  double min_diag;
  TALUS_PETSC(VecMin(diag, nullptr, &min_diag));
  CHECK(min_diag > 0.0);
  PetscInt rows, cols;
  TALUS_PETSC(MatGetSize(J, &rows, &cols));
  CHECK(rows == active.global_count() * dim);
  for (Vec* x : {&v, &w, &vp, &vm, &Fp, &Fm, &Jw, &F0, &diag}) TALUS_PETSC(VecDestroy(x));
  TALUS_PETSC(MatDestroy(&J));
}

}  // namespace

TEST_CASE("Jacobian equals finite differences of the residual, 2D", "[jacobian][mpi]") {
  check_jacobian<2>("quadratic_bspline", 1.0);
  check_jacobian<2>("quadratic_bspline", 0.5);
  check_jacobian<2>("linear", 1.0);
}

TEST_CASE("Jacobian equals finite differences of the residual, 3D", "[jacobian][mpi]") {
  check_jacobian<3>("quadratic_bspline", 1.0);
  check_jacobian<3>("linear", 0.5);
}

TEST_CASE("Jacobian equals finite differences with nonassociated Drucker-Prager", "[jacobian][plasticity][mpi]") {
  check_jacobian<2>("quadratic_bspline", 1.0, plastic);
  check_jacobian<2>("quadratic_bspline", 0.5, plastic);
  check_jacobian<3>("quadratic_bspline", 1.0, plastic);
}

TEST_CASE("Jacobian equals finite differences while voids close", "[jacobian][plasticity][mpi]") {
  check_jacobian<2>("quadratic_bspline", 1.0, plastic, true);
  check_jacobian<3>("quadratic_bspline", 0.5, plastic, true);
}

// The ghost penalty (docs/solver.md#ghost-penalty) adds h^2 theta K to the
// Jacobian, in the matrix and in the operator; gamma = 1 makes its share of
// J w large enough that a missing or wrong term shows.
TEST_CASE("Jacobian with the ghost penalty equals finite differences", "[jacobian][ghost][mpi]") {
  check_jacobian<2>("quadratic_bspline", 1.0, elastic, false, 1.0);
  check_jacobian<2>("quadratic_bspline", 0.5, plastic, false, 1.0);
  check_jacobian<3>("quadratic_bspline", 1.0, elastic, false, 1.0);
  check_jacobian<3>("quadratic_bspline", 0.5, plastic, false, 1.0);
}

namespace {

// A rigid spin v = omega x x carries no strain, so an elastic particle's
// stress after the step is exactly its Jaumann-rotated start stress,
// s + h (W s - s W) with W = grad v (skew), computed here by 3 x 3 products
// (MomentumSystem writes the spin term out in Voigt form).
template <int dim>
void check_spin() {
  // The block away from the grid's faces, so every stencil reproduces the
  // linear field exactly; no gravity, no constrained faces.
  CaseConfig config = testing::case_from_yaml(block_case(
      "quadratic_bspline", dim == 2 ? "[1.2, 1.2]" : "[1.0, 1.0, 1.0]", dim == 2 ? "[0.3, 0.3]" : "[0.3, 0.3, 0.3]",
      dim == 2 ? "[0.8, 0.7]" : "[0.7, 0.6, 0.65]", dim == 2 ? "[0, 0]" : "[0, 0, 0]", "boundaries: {}\n", elastic));
  Simulation<dim> sim(config, PETSC_COMM_WORLD);
  Particles<dim>& particles = sim.particles();
  std::vector<Voigt> start;
  {
    FieldView<PetscReal> s(particles.swarm(), field::stress);
    FieldView<std::int64_t> id(particles.swarm(), field::particle_id);
    for (PetscInt p = 0; p < particles.local_count(); ++p) {
      for (int i = 0; i < 6; ++i) s[6 * p + i] = 2e4 * hashed(static_cast<long>(id[p]), i);
      if (dim == 2) s[6 * p + 3] = s[6 * p + 4] = 0.0;  // plane strain
      start.push_back(Eigen::Map<const Voigt>(s.data() + 6 * p));
    }
  }
  const Grid<dim>& grid = sim.grid();
  testing::GridStep<dim> step(grid, particles, config);
  auto& [stencils, fields, active] = step;
  std::vector<const Material*> materials{config.materials[0].law.get()};
  const double h = 0.02;
  MomentumSystem<dim> system(grid, particles, stencils, fields, active, materials, Vector<dim>::Zero(), h, 1.0);
  // omega about z in 2D; a general axis in 3D (all three spin components).
  const Eigen::Vector3d omega = dim == 2 ? Eigen::Vector3d(0, 0, 0.7) : Eigen::Vector3d(0.4, -0.5, 0.7);
  Vec v = system.initial_guess();
  {
    PetscScalar* x;
    TALUS_PETSC(VecGetArray(v, &x));
    const auto& owned = active.owned_points();
    for (std::size_t k = 0; k < owned.size(); ++k) {
      const auto ijk = grid.global_index(owned[k]);
      Eigen::Vector3d position = Eigen::Vector3d::Zero();
      for (int a = 0; a < dim; ++a) position[a] = grid.lower()[a] + ijk[a] * grid.cell_size();
      const Eigen::Vector3d velocity = omega.cross(position);
      for (int a = 0; a < dim; ++a) x[dim * k + a] = velocity[a];
    }
    TALUS_PETSC(VecRestoreArray(v, &x));
  }
  Vec F;
  TALUS_PETSC(VecDuplicate(v, &F));
  system.residual(v, F);
  Eigen::Matrix3d W;  // grad (omega x x)
  W << 0, -omega[2], omega[1], omega[2], 0, -omega[0], -omega[1], omega[0], 0;
  double worst = 0.0;
  const auto& end = system.end_stress();
  REQUIRE(end.size() == start.size());
  for (std::size_t p = 0; p < start.size(); ++p) {
    const Eigen::Matrix3d s = voigt_to_tensor(start[p]);
    const Voigt expected = tensor_to_voigt(s + h * (W * s - s * W));
    worst = std::max(worst, (end[p] - expected).norm() / start[p].norm());
  }
  MPI_Allreduce(MPI_IN_PLACE, &worst, 1, MPI_DOUBLE, MPI_MAX, PETSC_COMM_WORLD);
  std::printf("%dD rigid spin: stress after the step against s + h (W s - s W), worst relative %.2e\n", dim, worst);
  // Round-off of the gradient sums (coordinates of order 1, 9 or 27 terms);
  // a wrong sign or a missing spin component gives h |omega| ~ 1e-2.
  CHECK(worst <= 1e-12);
  VecDestroy(&F);
  VecDestroy(&v);
}

}  // namespace

TEST_CASE("a rigid spin rotates the stress by the Jaumann rate, 2D and 3D", "[jacobian][mpi]") {
  check_spin<2>();
  check_spin<3>();
}

// Domain quadrature (docs/grid.md#particle-quadrature): stencils of 4 (3)
// functions per axis, block rows of 7^d (5^d) neighbours, ghost width 3 (2).
TEST_CASE("Jacobian equals finite differences with domain quadrature", "[jacobian][mpi]") {
  check_jacobian<2>("quadratic_bspline, quadrature: domain", 1.0);
  check_jacobian<2>("linear, quadrature: domain", 0.5);
  check_jacobian<3>("quadratic_bspline, quadrature: domain", 1.0, plastic);
  check_jacobian<2>("quadratic_bspline, quadrature: domain", 0.5, plastic, false, 1.0);
}

// The logarithmic strain increment (docs/formulation.md#the-strain-increment)
// changes A_p = D d(de)/dL + S d sigma*/dL; its residual is nonlinear in v
// even for elasticity (the finite-difference settings of plasticity).
TEST_CASE("Jacobian equals finite differences with the logarithmic strain increment", "[jacobian][mpi]") {
  check_jacobian<2>("quadratic_bspline", 1.0, elastic, false, 0.0, StrainIncrement::logarithmic);
  check_jacobian<2>("quadratic_bspline", 0.5, plastic, false, 0.0, StrainIncrement::logarithmic);
  check_jacobian<3>("quadratic_bspline", 1.0, elastic, false, 0.0, StrainIncrement::logarithmic);
  check_jacobian<3>("quadratic_bspline", 0.5, plastic, true, 0.0, StrainIncrement::logarithmic);
}
