// The geometric multigrid's interpolations (talus/solver/multigrid.hpp) are
// exact: a coarse spline's fine coefficients give the same function
// everywhere (1D, both shape functions, even and odd cell counts), and
// through every level of an active set a linear velocity field, whose
// B-spline coefficients are its values at the Greville points, is carried
// to the fine level exactly, with constrained components left alone, on one
// rank and on two.
#include <catch2/catch.hpp>

#include <random>

#include "talus/solver/multigrid.hpp"

using namespace talus;

namespace {

double spline_value(ShapeKind kind, const std::vector<double>& coefficients, double u, int cells) {
  const Basis1D b = evaluate_basis_1d(kind, u, cells, 1.0);
  double s = 0.0;
  for (int k = 0; k < b.count; ++k) s += coefficients[b.first + k] * b.value[k];
  return s;
}

// A linear field per component, in fine cell units.
template <int dim>
double linear_field(const double* x, int component) {
  double f = 0.3 + 0.7 * component;
  for (int a = 0; a < dim; ++a) f += (1.0 + a + 2.0 * component) * x[a] * (a % 2 ? -0.25 : 0.5);
  return f;
}

template <int dim>
void check_levels(ShapeKind kind) {
  const double h = 0.05;
  Vector<dim> lower = Vector<dim>::Zero(), upper;
  upper[0] = 1.55;  // 31 cells: odd counts on the way down
  upper[1] = 0.8;
  if constexpr (dim == 3) upper[2] = 0.6;
  Grid<dim> grid(PETSC_COMM_WORLD, lower, upper, h, kind);
  GridFields<dim> fields;
  fields.points = grid.ghosted_count();
  fields.mass.assign(fields.points, 0.0);
  // Mass on the points inside a slanted region touching the x_min and y_min faces.
  for (int i = 0; i < fields.points; ++i) {
    const auto ijk = grid.global_index(i);
    const double x = basis_position(kind, ijk[0], grid.cells()[0]) * h;
    const double y = basis_position(kind, ijk[1], grid.cells()[1]) * h;
    if (y < 0.6 - 0.5 * x) fields.mass[i] = 1.0;
  }
  std::array<FaceCondition, 6> faces;
  faces.fill(FaceCondition::free);
  faces[0] = FaceCondition::fixed;
  faces[2] = FaceCondition::slip;
  ActiveSet<dim> active;
  active.build(grid, fields, 0.5, faces);
  GeometricMultigrid<dim> mg;
  mg.build(grid, active, 1, 60, 10);
  REQUIRE(mg.levels() >= 3);
  for (int l = 0; l + 1 < mg.levels(); ++l) CHECK(mg.unknowns(l + 1) < mg.unknowns(l));

  // The coarsest level's coefficients of the linear field, interpolated down.
  const int last = mg.levels() - 1;
  Vec coarse;
  TALUS_PETSC(MatCreateVecs(mg.interpolation(last - 1), &coarse, nullptr));
  {
    PetscScalar* c;
    TALUS_PETSC(VecGetArray(coarse, &c));
    const auto& x = mg.positions(last);
    const auto& comp = mg.components(last);
    for (std::size_t u = 0; u < comp.size(); ++u) c[u] = linear_field<dim>(&x[dim * u], comp[u]);
    TALUS_PETSC(VecRestoreArray(coarse, &c));
  }
  for (int l = last - 1; l >= 0; --l) {
    Vec fine;
    TALUS_PETSC(MatCreateVecs(mg.interpolation(l), nullptr, &fine));
    TALUS_PETSC(MatMult(mg.interpolation(l), coarse, fine));
    TALUS_PETSC(VecDestroy(&coarse));
    coarse = fine;
  }
  const PetscScalar* v;
  TALUS_PETSC(VecGetArrayRead(coarse, &v));
  const auto& x = mg.positions(0);
  const auto& comp = mg.components(0);
  double worst = 0.0;
  int held = 0;
  for (std::size_t u = 0; u < comp.size(); ++u) {
    const double expected = comp[u] < 0 ? 0.0 : linear_field<dim>(&x[dim * u], comp[u]);
    worst = std::max(worst, std::abs(v[u] - expected));
    held += comp[u] < 0;
  }
  TALUS_PETSC(VecRestoreArrayRead(coarse, &v));
  TALUS_PETSC(VecDestroy(&coarse));
  int held_all = 0;
  MPI_Allreduce(&held, &held_all, 1, MPI_INT, MPI_SUM, PETSC_COMM_WORLD);
  CHECK(held_all > 0);  // the fixed and slip faces are in the active set
  // Values of order 10-100; the products of weights (multiples of 1/4) sum
  // them with round-off only.
  CHECK(worst < 1e-11);
}

}  // namespace

TEST_CASE("a coarse spline's fine coefficients give the same function", "[multigrid]") {
  std::mt19937 random(7);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  for (ShapeKind kind : {ShapeKind::quadratic_bspline, ShapeKind::linear})
    for (int fine_cells : {2, 7, 8, 13}) {
      const int coarse_cells = (fine_cells + 1) / 2;
      const AxisRefinement r = refine_axis(kind, fine_cells);
      std::vector<double> c(basis_count(kind, coarse_cells));
      for (double& x : c) x = uniform(random);
      std::vector<double> f(basis_count(kind, fine_cells), 0.0);
      REQUIRE(r.parents.size() == f.size());
      for (std::size_t i = 0; i < f.size(); ++i)
        for (auto& [I, w] : r.parents[i]) f[i] += w * c[I];
      double worst = 0.0;
      for (int k = 0; k <= 200; ++k) {
        const double u = fine_cells * k / 200.0;
        worst = std::max(worst, std::abs(spline_value(kind, f, u, fine_cells) -
                                         spline_value(kind, c, 0.5 * u, coarse_cells)));
      }
      CHECK(worst < 1e-14);
    }
}

TEST_CASE("a linear field passes every level exactly, 2D", "[multigrid][mpi]") {
  check_levels<2>(ShapeKind::quadratic_bspline);
  check_levels<2>(ShapeKind::linear);
}

TEST_CASE("a linear field passes every level exactly, 3D", "[multigrid][mpi]") {
  check_levels<3>(ShapeKind::quadratic_bspline);
  check_levels<3>(ShapeKind::linear);
}
