// Only grid points that carry mass are unknowns: a body filling a tenth of the
// grid box gives a system of (active points) x dim, where the active points
// are exactly the shape functions whose support meets the body.
#include <catch2/catch.hpp>

#include "talus/simulation.hpp"
#include "test_support.hpp"

using namespace talus;

namespace {

// One step of a body that fills a tenth of the grid box; the active points are
// counted independently from the body's cell range.
template <int dim>
void check_active_size(const std::string& shape) {
  const bool quad = shape == "quadratic_bspline";
  const std::string grid = dim == 2 ? "{lower: [0, 0], upper: [2.0, 1.0], cell_size: 0.05, shape_function: " + shape + "}"
                                    : "{lower: [0, 0, 0], upper: [1.0, 0.5, 0.5], cell_size: 0.05, shape_function: " + shape + "}";
  // A tenth of the box: 2D 0.4 x 0.5 of 2 x 1; 3D 0.2 x 0.25 x 0.5 of 1 x 0.5 x 0.5.
  const std::string body = dim == 2 ? "{lower: [0.8, 0.0], upper: [1.2, 0.5]}" : "{lower: [0.4, 0.0, 0.0], upper: [0.6, 0.25, 0.5]}";
  const std::string g = dim == 2 ? "[0, -9.81]" : "[0, 0, -9.81]";
  CaseConfig config = testing::case_from_yaml(
      "grid: " + grid + "\ntime: {end: 0.01, step: 0.01}\noutput: {enabled: false}\ngravity: " + g +
      "\nmaterials: [{name: m, model: linear_elastic, density: 2000, youngs_modulus: 1.0e6, poisson_ratio: 0.3}]\n"
      "bodies: [{name: b, material: m, box: " + body + "}]\n");
  Simulation<dim> sim(config, PETSC_COMM_WORLD);
  const StepReport r = sim.advance(0.01);
  REQUIRE(r.converged);
  // Body cells per axis: 8, 10 (2D); 4, 5, 10 (3D). A quadratic B-spline body
  // spanning c cells touches c + 2 functions per axis, linear hats c + 1.
  const std::array<int, 3> body_cells = dim == 2 ? std::array<int, 3>{8, 10, 1} : std::array<int, 3>{4, 5, 10};
  long expected = 1, box_points = 1;
  for (int a = 0; a < dim; ++a) {
    expected *= body_cells[a] + (quad ? 2 : 1);
    box_points *= sim.grid().points()[a];
  }
  CHECK(r.active_points == expected);
  CHECK(sim.last_system_size() == expected * dim);
  CHECK(sim.last_system_size() < box_points * dim / 5);  // not the whole box
}

}  // namespace

TEST_CASE("system size is active points x dim, 2D", "[active][mpi]") {
  check_active_size<2>("quadratic_bspline");
  check_active_size<2>("linear");
}

TEST_CASE("system size is active points x dim, 3D", "[active][mpi]") {
  check_active_size<3>("quadratic_bspline");
  check_active_size<3>("linear");
}
