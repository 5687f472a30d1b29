// The same case run on one rank and on all ranks of the MPI run gives the
// same particle positions and stresses to within solver tolerance, while
// particles cross the rank boundary.
#include <catch2/catch.hpp>
#include <cmath>

#include "talus/simulation.hpp"
#include "test_support.hpp"

using namespace talus;

namespace {

template <int dim>
std::string moving_block_case() {
  // An elastic block thrown sideways and sliding on a frictionless (slip) floor; it
  // crosses the middle of the box, where two ranks split the grid.
  if constexpr (dim == 2)
    return "grid: {lower: [0, 0], upper: [1.2, 0.8], cell_size: 0.05}\n"
           "time: {end: 0.3, step: 0.01}\noutput: {enabled: false}\ngravity: [0, -9.81]\n"
           "materials: [{name: m, model: linear_elastic, density: 1000, youngs_modulus: 2.0e5, poisson_ratio: 0.25}]\n"
           "bodies: [{name: b, material: m, box: {lower: [0.2, 0.0], upper: [0.5, 0.3]}, velocity: [1.5, 0.5]}]\n"
           "boundaries: {y_min: slip}\n";
  else
    return "grid: {lower: [0, 0, 0], upper: [0.8, 0.4, 0.4], cell_size: 0.05}\n"
           "time: {end: 0.15, step: 0.01}\noutput: {enabled: false}\ngravity: [0, 0, -9.81]\n"
           "materials: [{name: m, model: linear_elastic, density: 1000, youngs_modulus: 2.0e5, poisson_ratio: 0.25}]\n"
           "bodies: [{name: b, material: m, box: {lower: [0.15, 0.1, 0.0], upper: [0.35, 0.3, 0.2]}, velocity: [1.5, 0, 0.5]}]\n"
           "boundaries: {z_min: slip}\n";
}

template <int dim>
void compare_serial_and_parallel(const std::string& transfer, bool explicit_steps = false,
                                 ParticleQuadrature quadrature = ParticleQuadrature::point) {
  const auto lu = testing::lu_on_every_rank();
  std::string text = moving_block_case<dim>() + "transfer: {scheme: " + transfer + "}\n";
  if (quadrature == ParticleQuadrature::domain) text.replace(text.find("cell_size: 0.05}"), 16, "cell_size: 0.05, quadrature: domain}");
  CaseConfig config = testing::case_from_yaml(text);
  if (explicit_steps) {
    // docs/explicit.md: half the stability limit (no solver: the runs differ
    // by the order of the ranks' sums only).
    config.time.integrator = Integrator::explicit_euler;
    const Material& m = *config.materials[0].law;
    config.time.step = 0.5 * explicit_stable_step(config.grid.shape, config.grid.cell_size,
                                                  std::sqrt(m.elastic_stiffness()(0, 0) / m.density()), dim);
  }
  Simulation<dim> parallel(config, PETSC_COMM_WORLD);
  Simulation<dim> serial(config, PETSC_COMM_SELF);
  const PetscInt local_at_start = parallel.particles().local_count();
  int steps = 0;
  while (parallel.time() < config.time.end - 1e-12) {
    INFO(dim << "D" << (explicit_steps ? " explicit" : "") << ", step " << steps);
    REQUIRE(parallel.advance(config.time.step).converged);
    REQUIRE(serial.advance(config.time.step).converged);
    ++steps;
  }
  const auto xp = testing::gather_by_id(parallel.particles(), field::position, dim);
  const auto xs = testing::gather_by_id(serial.particles(), field::position, dim);
  const auto sp = testing::gather_by_id(parallel.particles(), field::stress, 6);
  const auto ss = testing::gather_by_id(serial.particles(), field::stress, 6);
  REQUIRE(xp.size() == xs.size());
  double dx = 0, ds = 0, smax = 0, travel = 0;
  const auto x0 = testing::gather_by_id(parallel.particles(), field::displacement, dim);
  for (std::size_t i = 0; i < xp.size(); ++i) dx = std::max(dx, std::abs(xp[i] - xs[i]));
  for (std::size_t i = 0; i < x0.size(); ++i) travel = std::max(travel, std::abs(x0[i]));
  for (std::size_t i = 0; i < sp.size(); ++i) {
    ds = std::max(ds, std::abs(sp[i] - ss[i]));
    smax = std::max(smax, std::abs(ss[i]));
  }
  INFO(dim << "D " << transfer << (explicit_steps ? " explicit" : "")
           << (quadrature == ParticleQuadrature::domain ? " domain quadrature" : "") << ", " << steps << " steps: max |x_parallel - x_serial| = " << dx
           << " m, max stress difference " << ds << " Pa of " << smax << " Pa, largest displacement " << travel);
  // With LU factors on both sides (lu_on_every_rank) the two runs differ by
  // round-off only. 1e-9 m over 30 steps of ~1 cm motion
  // is far below any modelling error and far above round-off.
  CHECK(dx < 1e-9);
  CHECK(ds < 1e-8 * smax);
  CHECK(travel > 0.1);  // the body did move a lot
  if (testing::comm_size(PETSC_COMM_WORLD) > 1) {
    // Particles changed rank during the run (migration was exercised).
    const PetscInt local_at_end = parallel.particles().local_count();
    PetscInt changed = local_at_end != local_at_start, any = 0;
    MPI_Allreduce(&changed, &any, 1, MPIU_INT, MPI_MAX, PETSC_COMM_WORLD);
    CHECK(any == 1);
  }
}

}  // namespace

TEST_CASE("serial and parallel runs agree, 2D", "[parallel][mpi]") {
  compare_serial_and_parallel<2>("apic");
  compare_serial_and_parallel<2>("flip");
}

TEST_CASE("serial and parallel runs agree, 3D", "[parallel][mpi]") { compare_serial_and_parallel<3>("apic"); }

TEST_CASE("serial and parallel runs agree, explicit integrator", "[parallel][mpi][explicit]") {
  compare_serial_and_parallel<2>("apic", true);
  compare_serial_and_parallel<3>("apic", true);
}

// Domain quadrature widens the stencils and the ghost width to 3 points
// (docs/grid.md#particle-quadrature): the same equality.
TEST_CASE("serial and parallel runs agree, domain quadrature", "[parallel][mpi]") {
  compare_serial_and_parallel<2>("apic", false, ParticleQuadrature::domain);
  compare_serial_and_parallel<3>("apic", false, ParticleQuadrature::domain);
  compare_serial_and_parallel<2>("apic", true, ParticleQuadrature::domain);
}
