// Case-file validation: each malformed case stops with an InputError whose
// message names the file line, the key path and (where there is one) the value.
#include <catch2/catch.hpp>

#include "talus/io/config.hpp"
#include "talus/simulation.hpp"
#include "test_support.hpp"

using namespace talus;

namespace {

const std::string valid =
    "grid:\n"                                                       // 1
    "  lower: [0, 0]\n"                                              // 2
    "  upper: [2, 1]\n"                                              // 3
    "  cell_size: 0.1\n"                                             // 4
    "time: {end: 1.0, step: 0.01}\n"                                 // 5
    "gravity: [0, -9.81]\n"                                          // 6
    "materials:\n"                                                   // 7
    "  - name: soil\n"                                               // 8
    "    model: linear_elastic\n"                                    // 9
    "    density: 2000\n"                                            // 10
    "    youngs_modulus: 1.0e7\n"                                    // 11
    "    poisson_ratio: 0.3\n"                                       // 12
    "bodies:\n"                                                      // 13
    "  - name: block\n"                                              // 14
    "    material: soil\n"                                           // 15
    "    box: {lower: [0.5, 0], upper: [1.0, 0.5]}\n"                // 16
    "boundaries: {y_min: fixed}\n";                                  // 17

std::string replace(std::string s, const std::string& from, const std::string& to) {
  const auto at = s.find(from);
  REQUIRE(at != std::string::npos);
  return s.replace(at, from.size(), to);
}

// The message of the InputError thrown by parsing `yaml`.
std::string error_of(const std::string& yaml) {
  try {
    parse_case(yaml, "case.yaml");
  } catch (const InputError& e) {
    return e.what();
  }
  FAIL("no InputError for:\n" << yaml);
  return "";
}

}  // namespace

TEST_CASE("a valid case parses into the expected values", "[config]") {
  const CaseConfig c = parse_case(valid, "case.yaml");
  CHECK(c.dim == 2);
  CHECK(c.grid.cell_size == 0.1);
  CHECK(c.grid.shape == ShapeKind::quadratic_bspline);
  CHECK(c.time.theta == 1.0);
  CHECK(c.materials.size() == 1);
  CHECK(c.materials[0].law->density() == 2000.0);
  CHECK(c.bodies[0].particles_per_cell == 2);
  CHECK(c.faces[2] == FaceCondition::fixed);
  CHECK(c.faces[0] == FaceCondition::slip);  // default
}

TEST_CASE("malformed cases name the key, the value and the line", "[config]") {
  struct Case {
    std::string yaml, expected;
  };
  const std::vector<Case> cases = {
      {replace(valid, "poisson_ratio: 0.3", "poisson_ratio: 0.5"), "case.yaml:12: materials[0].poisson_ratio = 0.5"},
      {replace(valid, "density: 2000", "density: -2000"), "case.yaml:10: materials[0].density"},
      {replace(valid, "youngs_modulus: 1.0e7", "youngs_modulus: 0"), "materials[0].youngs_modulus"},
      {replace(valid, "cell_size: 0.1", "cell_size: 0.3"), "case.yaml:4: grid.cell_size"},
      {replace(valid, "step: 0.01", "step: -0.01"), "time.step"},
      {replace(valid, "poisson_ratio: 0.3", "poisson_ratio: abc"), "materials[0].poisson_ratio = abc"},
      {replace(valid, "    density: 2000\n", "    densty: 2000\n    density: 2000\n"),
       "case.yaml:10: materials[0].densty: unknown key (did you mean 'density'?)"},
      {replace(valid, "gravity", "gravty"), "case.yaml:6: gravty: unknown key (did you mean 'gravity'?)"},
      {replace(valid, "material: soil", "material: rock"), "case.yaml:15: bodies[0].material = rock"},
      {replace(valid, "upper: [1.0, 0.5]", "upper: [2.5, 0.5]"), "case.yaml:16: bodies[0].box.upper: lies outside"},
      {replace(valid, "lower: [0.5, 0]", "lower: [-0.5, 0]"), "case.yaml:16: bodies[0].box.lower: lies outside"},
      {replace(valid, "cell_size: 0.1", "cel_size: 0.1"), "case.yaml:4: grid.cel_size: unknown key (did you mean 'cell_size'?)"},
      {replace(valid, "    model: linear_elastic\n", ""), "materials[0].model: is required"},
      {replace(valid, "model: linear_elastic", "model: elastoplastic"), "materials[0].model = elastoplastic"},
      {replace(valid, "y_min: fixed", "y_min: glued"), "boundaries.y_min = glued: must be one of: free, slip, fixed"},
      {replace(valid, "upper: [2, 1]", "upper: [2, 1, 1]"), "grid.upper"},
      {replace(valid, "time: {end: 1.0, step: 0.01}", "time: {end: 1.0, step: 0.01, theta: 0.3}"), "time.theta = 0.3"},
      {replace(valid, "model: linear_elastic", "model: drucker_prager\n    friction_angle: 30\n    dilatancy_angle: 40"),
       "case.yaml:11: materials[0].dilatancy_angle = 40"},
      {replace(valid, "model: linear_elastic", "model: drucker_prager\n    friction_angle: 95"),
       "case.yaml:10: materials[0].friction_angle = 95"},
      {replace(valid, "model: linear_elastic", "model: drucker_prager\n    friction_angle: 30\n    cohesion: -5"),
       "materials[0].cohesion = -5"},
      {replace(valid, "box: {lower: [0.5, 0], upper: [1.0, 0.5]}", "polygon: [[0.5, 0], [1.0, 0], [1.0, 0.5], [0.5, 0.5]]\n    box: {lower: [0.5, 0], upper: [1.0, 0.5]}"),
       "bodies[0].box: give either box or polygon, not both"},
      {replace(valid, "    box: {lower: [0.5, 0], upper: [1.0, 0.5]}\n", ""), "case.yaml:14: bodies[0].box: is required (or polygon, in 2D)"},
      {replace(valid, "box: {lower: [0.5, 0], upper: [1.0, 0.5]}", "polygon: [[0.5, 0], [1.0, 0]]"),
       "case.yaml:16: bodies[0].polygon: needs at least 3 vertices"},
      {replace(valid, "box: {lower: [0.5, 0], upper: [1.0, 0.5]}", "polygon: [[0.5, 0], [1.0, 0], [0.5, 0.5], [1.0, 0.5]]"),
       "bodies[0].polygon: edges 1 and 3 cross"},
      {replace(valid, "box: {lower: [0.5, 0], upper: [1.0, 0.5]}", "polygon: [[0.5, 0], [2.5, 0], [1.0, 0.5]]"),
       "bodies[0].polygon: vertex 1 lies outside the grid box"},
      {replace(valid, "box: {lower: [0.5, 0], upper: [1.0, 0.5]}", "polygon: [[0.5, 0], [1.0, 0], [1.5, 0]]"),
       "bodies[0].polygon: has zero area"},
      {replace(valid, "box: {lower: [0.5, 0], upper: [1.0, 0.5]}", "polygon: [[0.5, 0], [1.0, x], [1.0, 0.5]]"),
       "case.yaml:16: bodies[0].polygon[1] = [1.0, x]: entry 'x' is not a finite number"},
      {replace(valid, "box: {lower: [0.5, 0], upper: [1.0, 0.5]}", "box: {lower: [0.5, 0], upper: [1.0, 0.5]}\n    k0: 0.5"),
       "bodies[0].k0: is only used with initial_stress: geostatic"},
      {replace(valid, "box: {lower: [0.5, 0], upper: [1.0, 0.5]}", "box: {lower: [0.5, 0], upper: [1.0, 0.5]}\n    initial_stress: lithostatic"),
       "bodies[0].initial_stress = lithostatic: must be one of: none, geostatic"},
      {replace(replace(valid, "gravity: [0, -9.81]", "gravity: [-9.81, 0]"), "box: {lower: [0.5, 0], upper: [1.0, 0.5]}",
               "box: {lower: [0.5, 0], upper: [1.0, 0.5]}\n    initial_stress: geostatic"),
       "bodies[0].initial_stress = geostatic: needs gravity pointing down the last axis"},
      {"grid: [1, 2\n", "case.yaml:2: YAML syntax error"},
      {"", "the case file must be a YAML map"},
      // A key given twice: YAML would keep the first value without a word.
      {replace(valid, "    poisson_ratio: 0.3\n", "    poisson_ratio: 0.3\n    poisson_ratio: 0.45\n"),
       "case.yaml:13: materials[0].poisson_ratio: is given twice (first on line 12)"},
      {replace(valid, "boundaries: {y_min: fixed}", "boundaries: {y_min: fixed, y_min: free}"),
       "case.yaml:17: boundaries.y_min: is given twice"},
      {valid + "solver: {petsc_options: {ksp_type: cg, ksp_type: gmres}}\n",
       "case.yaml:18: solver.petsc_options.ksp_type: is given twice"},
      // Bodies that the seeding lattice (spacing 0.05 here) would leave empty.
      {replace(valid, "upper: [1.0, 0.5]", "upper: [1.0, 0.02]"), "case.yaml:16: bodies[0].box: holds no particle"},
      {replace(valid, "box: {lower: [0.5, 0], upper: [1.0, 0.5]}", "polygon: [[0.5, 0.01], [0.98, 0.49], [0.97, 0.49]]"),
       "case.yaml:16: bodies[0].polygon: holds no particle"},
      {"grid:\n\tlower: [0, 0]\n", "case.yaml:2: YAML syntax error"},
      {"grid:\n\tlower: [0, 0]\n", "(a tab character in the indentation"},
      {"# only a comment\n", "the case file must be a YAML map (grid, time, materials, bodies, ...); it is empty"},
      {"- grid: 1\n- time: 2\n", "the case file must be a YAML map (grid, time, materials, bodies, ...); it is a list"},
  };
  for (const Case& c : cases) {
    const std::string message = error_of(c.yaml);
    INFO("message: " << message);
    CHECK(message.find(c.expected) != std::string::npos);
  }
}

TEST_CASE("a missing case file is an input error", "[config]") {
  CHECK_THROWS_AS(load_case("/nonexistent/case.yaml"), InputError);
  CHECK_THROWS_WITH(load_case("."), Catch::Contains(".: is a directory, not a case file"));
}

TEST_CASE("a polygon body is filled with exactly the lattice points inside it", "[config][seeding]") {
  // A slope profile: toe at x = 0.2, crest at (1.0, 0.6), 0.6 m high. The
  // lattice spacing is 0.05 (cell 0.1, 2 per cell), so no lattice point lies
  // on an edge and "inside" is unambiguous.
  const std::string yaml = replace(valid, "box: {lower: [0.5, 0], upper: [1.0, 0.5]}",
                                   "polygon: [[0.2, 0], [1.9, 0], [1.9, 0.6], [1.0, 0.6]]");
  const CaseConfig config = testing::case_from_yaml(yaml);
  REQUIRE(config.bodies[0].polygon.size() == 4);
  CHECK(config.bodies[0].box_lower == std::vector<double>{0.2, 0.0});
  CHECK(config.bodies[0].box_upper == std::vector<double>{1.9, 0.6});
  Simulation<2> sim(config, PETSC_COMM_WORLD);
  const std::vector<double> x = testing::gather_by_id(sim.particles(), field::position, 2);
  const std::vector<double> mass = testing::gather_by_id(sim.particles(), field::mass, 1);
  // Brute force over the lattice: the trapezoid is y >= 0, y <= 0.6, x <= 1.9
  // and left of the slope line through (0.2, 0) and (1.0, 0.6).
  long expected = 0;
  for (int i = 0; i < 40; ++i)
    for (int j = 0; j < 20; ++j) {
      const double px = 0.025 + 0.05 * i, py = 0.025 + 0.05 * j;
      expected += py < 0.6 && px < 1.9 && py < 0.75 * (px - 0.2);
    }
  CHECK(static_cast<long>(mass.size()) == expected);
  for (std::size_t p = 0; p < mass.size(); ++p) {
    CHECK(x[2 * p + 1] < 0.75 * (x[2 * p] - 0.2));
    CHECK(mass[p] == Approx(2000 * 0.05 * 0.05).epsilon(1e-14));
  }
  // The seeded area approaches the trapezoid's, 0.78 m^2, to within the
  // lattice resolution along the inclined edge (1 m long, spacing 0.05).
  const double area = 0.5 * (1.7 + 0.9) * 0.6;
  CHECK(std::abs(mass.size() * 0.05 * 0.05 - area) <= 0.5 * 1.0 * 0.05);
}
