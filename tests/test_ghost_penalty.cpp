// The ghost penalty (include/talus/solver/ghost_penalty.hpp,
// docs/solver.md#ghost-penalty) against closed forms: it vanishes on every
// linear velocity field (rigid motions and uniform strain rates are not
// resisted), and on the field u = x^2 e_y, whose second derivative is 2 in
// every cell, its energy u^T K u is gamma M h^2 (2^2) h^d per cut cell
// exactly. The clamped quadratic B-splines reproduce both fields exactly:
// x = sum_i x*_i B_i (Greville points) and x^2 = sum_i t_{i+1} t_{i+2} B_i
// (Marsden's identity on the knots t). Serial and on 2 ranks (each cell on
// one rank: the sums over ranks are the same).
#include <catch2/catch.hpp>
#include <cmath>

#include "talus/simulation.hpp"
#include "talus/solver/ghost_penalty.hpp"
#include "test_support.hpp"

using namespace talus;

namespace {

constexpr double E = 1.0e6, nu = 0.3, gamma_ = 0.7;

template <int dim>
void check_closed_forms() {
  const std::string box = dim == 2 ? "lower: [0.05, 0.0], upper: [0.63, 0.52]" : "lower: [0.05, 0.0, 0.0], upper: [0.43, 0.3, 0.27]";
  const std::string yaml =
      std::string("grid: {lower: ") + (dim == 2 ? "[0, 0]" : "[0, 0, 0]") + ", upper: " +
      (dim == 2 ? "[1.0, 0.8]" : "[0.6, 0.5, 0.4]") +
      ", cell_size: 0.1}\n"
      "time: {end: 1, step: 0.01}\n"
      "output: {enabled: false}\n"
      "materials: [{name: m, model: linear_elastic, density: 2000, youngs_modulus: 1.0e6, poisson_ratio: 0.3}]\n"
      "bodies: [{name: b, material: m, box: {" + box + "}}]\n";
  CaseConfig config = testing::case_from_yaml(yaml);
  Simulation<dim> sim(config, PETSC_COMM_WORLD);
  const Grid<dim>& grid = sim.grid();
  testing::GridStep<dim> step(grid, sim.particles(), config);
  auto& [stencils, fields, active] = step;
  std::vector<const Material*> materials{config.materials[0].law.get()};
  const GhostPenalty<dim> ghost(grid, sim.particles(), stencils, fields, active, materials, gamma_);
  // The block's free faces (x = 0.05, 0.63; top) cut the cells they cross;
  // the floor (the grid's face) does not.
  INFO("cut cells: " << ghost.global_cells());
  CHECK(ghost.global_cells() >= (dim == 2 ? 10 : 25));

  const double h = grid.cell_size();
  const int nodes = static_cast<int>(fields.mass.size());
  auto knot = [&](int k, int axis) { return clamped_knot(k, grid.cells()[axis]) * h; };
  std::vector<double> linear(static_cast<std::size_t>(nodes) * dim), square(linear.size(), 0.0);
  for (int i = 0; i < nodes; ++i) {
    const auto ijk = grid.global_index(i);
    const Vector<dim> x = grid.point_position(ijk);  // the Greville point
    for (int c = 0; c < dim; ++c) {
      // A uniform strain rate plus a rotation and a translation, per component.
      double value = 0.3 * (c + 1);
      for (int a = 0; a < dim; ++a) value += (0.7 * (a + 1) - 0.4 * c + (a == c ? 1.1 : 0.0)) * x[a];
      linear[static_cast<std::size_t>(dim) * i + c] = value;
    }
    square[static_cast<std::size_t>(dim) * i + 1] = knot(ijk[0] + 1, 0) * knot(ijk[0] + 2, 0);
  }
  std::vector<double> Ku(linear.size(), 0.0), Kx(linear.size(), 0.0);
  ghost.add_product(linear, Ku, 1.0);
  ghost.add_product(square, Kx, 1.0);
  double largest = 0.0, energy = 0.0;
  for (std::size_t k = 0; k < Ku.size(); ++k) {
    largest = std::max(largest, std::abs(Ku[k]));
    energy += square[k] * Kx[k];
  }
  MPI_Allreduce(MPI_IN_PLACE, &largest, 1, MPI_DOUBLE, MPI_MAX, PETSC_COMM_WORLD);
  MPI_Allreduce(MPI_IN_PLACE, &energy, 1, MPI_DOUBLE, MPI_SUM, PETSC_COMM_WORLD);
  const double M = E * (1 - nu) / ((1 + nu) * (1 - 2 * nu));
  const double expected = ghost.global_cells() * gamma_ * M * h * h * 4.0 * std::pow(h, dim);
  // Scale of one coupling times the field (|u| ~ 1): gamma M h^(d-2) ~ 1e6.
  const double scale = gamma_ * M * std::pow(h, dim - 2);
  INFO(dim << "D: largest |K u| on a linear field " << largest << " (scale " << scale << "); energy of x^2 " << energy
           << " against " << expected);
  CHECK(largest <= 1e-12 * scale);
  CHECK(energy == Approx(expected).epsilon(1e-12));
}

}  // namespace

TEST_CASE("the ghost penalty is zero on linear fields and exact on x^2", "[ghost][mpi]") {
  check_closed_forms<2>();
  check_closed_forms<3>();
}
