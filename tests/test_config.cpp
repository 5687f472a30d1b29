// Case-file validation: each malformed case stops with an InputError whose
// message names the file line, the key path and (where there is one) the value.
#include <catch2/catch.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "talus/io/config.hpp"
#include "talus/io/yaml_section.hpp"
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
      {replace(valid, "y_min: fixed", "y_min: glued"), "boundaries.y_min = glued: must be one of: free, slip, fixed, frictional"},
      {replace(valid, "upper: [2, 1]", "upper: [2, 1, 1]"), "grid.upper"},
      {replace(valid, "time: {end: 1.0, step: 0.01}", "time: {end: 1.0, step: 0.01, theta: 0.3}"), "time.theta = 0.3"},
      {replace(valid, "model: linear_elastic", "model: drucker_prager\n    friction_angle: 30\n    dilatancy_angle: 40"),
       "case.yaml:11: materials[0].dilatancy_angle = 40"},
      {replace(valid, "model: linear_elastic", "model: drucker_prager\n    friction_angle: 95"),
       "case.yaml:10: materials[0].friction_angle = 95"},
      {replace(valid, "model: linear_elastic", "model: drucker_prager\n    friction_angle: 30\n    cohesion: -5"),
       "materials[0].cohesion = -5"},
      {replace(valid, "box: {lower: [0.5, 0], upper: [1.0, 0.5]}", "polygon: [[0.5, 0], [1.0, 0], [1.0, 0.5], [0.5, 0.5]]\n    box: {lower: [0.5, 0], upper: [1.0, 0.5]}"),
       "bodies[0].polygon: give one of box, polygon, polyhedron and particles, not both box and polygon"},
      {replace(valid, "    box: {lower: [0.5, 0], upper: [1.0, 0.5]}\n", ""), "case.yaml:14: bodies[0].box: is required (or polygon, polyhedron, or particles: a particle file)"},
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

TEST_CASE("error messages print a value as the file writes it, a computed number in shortest form", "[config]") {
  // Not std::to_string's six decimals ("0.500000", "-0.000000").
  CHECK(number_text(0.5) == "0.5");
  CHECK(number_text(1e-12) == "1e-12");
  CHECK(number_text(2.0) == "2");
  CHECK(number_text(0.1 + 0.2) == "0.30000000000000004");
  const std::string geostatic = "box: {lower: [0.5, 0], upper: [1.0, 0.5]}\n    initial_stress: geostatic";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {replace(valid, "poisson_ratio: 0.3", "poisson_ratio: 0.5"), "materials[0].poisson_ratio = 0.5: must be in [0, 0.5)"},
      {replace(valid, "density: 2000", "density: -2e3"), "materials[0].density = -2e3: must be in [1e-6, 1e9] kg/m^3"},
      {replace(valid, "youngs_modulus: 1.0e7", "youngs_modulus: 0"), "materials[0].youngs_modulus = 0: must be in [1e-6, 1e15] Pa"},
      {replace(valid, "step: 0.01", "step: -1e-12"), "time.step = -1e-12: must be > 0"},
      {replace(valid, "time: {end: 1.0, step: 0.01}", "time: {end: 1.0, step: 0.01, theta: 0.3}"),
       "time.theta = 0.3: must be in [0.5, 1]"},
      {replace(valid, "time: {end: 1.0, step: 0.01}", "time: {end: 1.0, step: 0.01, min_step_ratio: -1e-12}"),
       "time.min_step_ratio = -1e-12: must be in [1e-6, 1]"},
      {valid + "output: {interval: -0.25}\n", "output.interval = -0.25: must be >= 0"},
      {valid + "checkpoint: {interval: -3}\n", "checkpoint.interval = -3: must be >= 0"},
      {valid + "transfer: {flip_blend: 1.0000001}\n", "transfer.flip_blend = 1.0000001: must be in [0, 1]"},
      {valid + "solver: {active_mass_ratio: 1}\n", "solver.active_mass_ratio = 1: must be in [0, 1)"},
      {valid + "solver: {direct_solver_limit: -1}\n", "solver.direct_solver_limit = -1: must be >= 0"},
      {valid + "contact: {gap_prediction: 1.5}\n", "contact.gap_prediction = 1.5: must be in [0, 1]"},
      {replace(valid, "box: {lower: [0.5, 0], upper: [1.0, 0.5]}", geostatic + "\n    k0: 5.5"),
       "bodies[0].k0 = 5.5: must be in (0, 5]"},
      {replace(valid, "material: soil", "material: soil\n    particles_per_cell: 9"),
       "bodies[0].particles_per_cell = 9: must be in 1..8"},
      {replace(valid, "model: linear_elastic", "model: drucker_prager\n    friction_angle: 30\n    cohesion: -0.5"),
       "materials[0].cohesion = -0.5: must be >= 0"},
      {replace(valid, "model: linear_elastic", "model: drucker_prager\n    friction_angle: 30\n    tension_cutoff: -2.5e-1"),
       "materials[0].tension_cutoff = -2.5e-1: must be >= 0"},
      // A computed number: cell_size / particles_per_cell.
      {replace(replace(valid, "upper: [1.0, 0.5]", "upper: [1.0, 0.01]"), "material: soil",
               "material: soil\n    particles_per_cell: 3"),
       "particle spacing cell_size / particles_per_cell = 0.03333333333333333 m)"},
  };
  for (const auto& [yaml, expected] : cases) {
    const std::string message = error_of(yaml);
    INFO("message: " << message);
    CHECK(message.find(expected) != std::string::npos);
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

TEST_CASE("a 3D polygon body is its vertical section extruded along y", "[config][seeding]") {
  // The 2D slope profile of the test above, as an (x, z) section extruded
  // over y in [0.1, 0.4]: every lattice layer across y holds the 2D lattice
  // points of the section, so the count is the 2D count times 6 layers
  // (spacing 0.05), and every particle lies in the section and the y range.
  const std::string yaml =
      "grid: {lower: [0, 0, 0], upper: [2.0, 0.5, 1.0], cell_size: 0.1}\n"
      "time: {end: 1, step: 0.01}\n"
      "output: {enabled: false}\n"
      "gravity: [0, 0, -9.81]\n"
      "materials: [{name: m, model: linear_elastic, density: 2000, youngs_modulus: 1.0e6, poisson_ratio: 0.3}]\n"
      "bodies: [{name: slope, material: m, polygon: [[0.2, 0], [1.9, 0], [1.9, 0.6], [1.0, 0.6]], "
      "extrusion: [0.1, 0.4]}]\n";
  const CaseConfig config = testing::case_from_yaml(yaml);
  CHECK(config.bodies[0].box_lower == std::vector<double>{0.2, 0.1, 0.0});
  CHECK(config.bodies[0].box_upper == std::vector<double>{1.9, 0.4, 0.6});
  Simulation<3> sim(config, PETSC_COMM_WORLD);
  const std::vector<double> x = testing::gather_by_id(sim.particles(), field::position, 3);
  long section = 0;
  for (int i = 0; i < 40; ++i)
    for (int j = 0; j < 20; ++j) {
      const double px = 0.025 + 0.05 * i, pz = 0.025 + 0.05 * j;
      section += pz < 0.6 && px < 1.9 && pz < 0.75 * (px - 0.2);
    }
  CHECK(static_cast<long>(x.size() / 3) == 6 * section);
  for (std::size_t p = 0; p < x.size() / 3; ++p) {
    CHECK(x[3 * p + 2] < 0.75 * (x[3 * p] - 0.2));
    CHECK(x[3 * p + 1] > 0.1);
    CHECK(x[3 * p + 1] < 0.4);
  }
  // The extrusion belongs to 3D polygons only.
  CHECK_THROWS_WITH(testing::case_from_yaml(replace(valid, "box: {lower: [0.5, 0], upper: [1.0, 0.5]}",
                                                    "polygon: [[0.2, 0], [1.9, 0], [1.9, 0.6]]\n    extrusion: [0, 1]")),
                    Catch::Contains("extrusion: is only used in 3D"));
}

// ------------------------------------------------------------ contact keys

namespace {

// A fresh directory under the system's temporary directory (tests may run in parallel).
std::filesystem::path temp_dir() {
  std::string pattern = (std::filesystem::temp_directory_path() / "talus_config_XXXXXX").string();
  REQUIRE(mkdtemp(pattern.data()) != nullptr);
  return pattern;
}

void write_file(const std::filesystem::path& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
}

const std::string valid_3d =
    "grid: {lower: [0, 0, 0], upper: [2, 1, 1], cell_size: 0.25}\n"                                        // 1
    "time: {end: 1, step: 0.1}\n"                                                                           // 2
    "materials: [{name: m, model: linear_elastic, density: 1000, youngs_modulus: 1e6, poisson_ratio: 0.2}]\n"  // 3
    "bodies: [{name: b, material: m, box: {lower: [0.5, 0.25, 0.5], upper: [1, 0.75, 1]}}]\n"             // 4
    "obstacles:\n"                                                                                          // 5
    "  - name: ground\n"                                                                                    // 6
    "    type: terrain\n"                                                                                   // 7
    "    file: ground.asc\n"                                                                                // 8
    "    friction: 0.6\n";                                                                                  // 9

}  // namespace

TEST_CASE("obstacles, frictional faces and contact options parse into the expected values", "[config][obstacle]") {
  const std::filesystem::path dir = temp_dir();
  // Comments, blank lines, commas, Windows line ends and a '+' sign are all fine.
  write_file(dir / "profile.txt", "# x  height\n\n0.0 0.4   # left\n1.0, 0.2\r\n  2.0\t+0.125\n");
  const std::string yaml = replace(valid, "boundaries: {y_min: fixed}\n",
                                   "boundaries:\n"
                                   "  x_min: free\n"
                                   "  x_max: {condition: fixed}\n"
                                   "  y_min: {condition: frictional, friction: 0.4, restitution: 0.1}\n"
                                   "  y_max: {condition: frictional, friction: 0}\n"
                                   "obstacles:\n"
                                   "  - name: floor\n"
                                   "    type: half_plane\n"
                                   "    point: [0, 0.1]\n"
                                   "    normal: [3, 4]\n"
                                   "    friction: 0.3\n"
                                   "  - name: wall\n"
                                   "    type: box\n"
                                   "    lower: [1.75, 0]\n"
                                   "    upper: [1.95, 0.8]\n"
                                   "    friction: 0.5\n"
                                   "    restitution: 0.2\n"
                                   "    velocity: [-0.1, 0]\n"
                                   "  - {name: slope, type: terrain, file: profile.txt, friction: 0.7}\n"
                                   "contact: {gap_prediction: 0.25}\n");
  const CaseConfig c = parse_case(yaml, (dir / "case.yaml").string());
  CHECK(c.faces[0] == FaceCondition::free);
  CHECK(c.faces[1] == FaceCondition::fixed);
  CHECK(c.faces[2] == FaceCondition::frictional);
  CHECK(c.face_contact[2].friction == 0.4);
  CHECK(c.face_contact[2].restitution == 0.1);
  CHECK(c.faces[3] == FaceCondition::frictional);
  CHECK(c.face_contact[3].friction == 0.0);
  CHECK(c.face_contact[3].restitution == 0.0);
  CHECK(c.contact.gap_prediction == 0.25);
  REQUIRE(c.obstacles.size() == 3);

  const ObstacleConfig& floor = c.obstacles[0];
  CHECK(floor.name == "floor");
  CHECK(floor.shape == ObstacleShape::half_plane);
  CHECK(floor.point == std::vector<double>{0.0, 0.1});
  CHECK(floor.normal[0] == Approx(0.6).epsilon(1e-15));  // normalised on load
  CHECK(floor.normal[1] == Approx(0.8).epsilon(1e-15));
  CHECK(floor.friction == 0.3);
  CHECK(floor.restitution == 0.0);                         // default
  CHECK(floor.velocity == std::vector<double>{0.0, 0.0});  // default

  const ObstacleConfig& wall = c.obstacles[1];
  CHECK(wall.shape == ObstacleShape::box);
  CHECK(wall.lower == std::vector<double>{1.75, 0.0});
  CHECK(wall.upper == std::vector<double>{1.95, 0.8});
  CHECK(wall.friction == 0.5);
  CHECK(wall.restitution == 0.2);
  CHECK(wall.velocity == std::vector<double>{-0.1, 0.0});

  const ObstacleConfig& slope = c.obstacles[2];
  CHECK(slope.shape == ObstacleShape::terrain);
  CHECK(slope.file == "profile.txt");
  CHECK(slope.friction == 0.7);
  REQUIRE(slope.polyline.size() == 3);
  CHECK(slope.polyline[0] == std::array<double, 2>{0.0, 0.4});
  CHECK(slope.polyline[1] == std::array<double, 2>{1.0, 0.2});
  CHECK(slope.polyline[2] == std::array<double, 2>{2.0, 0.125});

  // A body partly inside an obstacle is fine (seeding leaves those points out).
  CHECK_NOTHROW(parse_case(valid + "obstacles: [{name: f, type: half_plane, point: [0, 0.25], normal: [0, 1], "
                                   "friction: 0.5}]\n",
                           "case.yaml"));
  // Without a contact section: the default gap prediction, no obstacles.
  const CaseConfig plain = parse_case(valid, "case.yaml");
  CHECK(plain.contact.gap_prediction == 0.5);
  CHECK(plain.obstacles.empty());
  std::filesystem::remove_all(dir);
}

TEST_CASE("the ESRI ASCII grid reader: corner and centre headers, the north row first", "[config][obstacle]") {
  const std::filesystem::path dir = temp_dir();
  const std::string heights = "0.9 0.8 0.7\n"   // north row: j = 1
                              "0.3 0.2 0.1\n";  // south row: j = 0
  SECTION("corner header: samples at corner + cellsize / 2") {
    write_file(dir / "ground.asc", "ncols 3\nnrows 2\nxllcorner 0.5\nyllcorner 0.25\ncellsize 0.5\nNODATA_value -9999\n" +
                                       heights);
    const ObstacleConfig o = parse_case(valid_3d, (dir / "case.yaml").string()).obstacles.at(0);
    CHECK(o.map_origin == std::array<double, 2>{0.75, 0.5});
    CHECK(o.map_spacing == 0.5);
    CHECK(o.map_nx == 3);
    CHECK(o.map_ny == 2);
    CHECK(o.heights == std::vector<double>{0.3, 0.2, 0.1, 0.9, 0.8, 0.7});
  }
  SECTION("centre header in capitals, no NODATA_value, blank lines") {
    write_file(dir / "ground.asc", "NCOLS 3\nNROWS 2\nXLLCENTER 0.5\nYLLCENTER 0.25\nCELLSIZE 0.5\n\n" + heights + "\n");
    const ObstacleConfig o = parse_case(valid_3d, (dir / "case.yaml").string()).obstacles.at(0);
    CHECK(o.map_origin == std::array<double, 2>{0.5, 0.25});
    CHECK(o.heights == std::vector<double>{0.3, 0.2, 0.1, 0.9, 0.8, 0.7});
  }
  std::filesystem::remove_all(dir);
}

TEST_CASE("contact keys: malformed values and terrain files name the case line and the file line", "[config][obstacle]") {
  const std::filesystem::path dir = temp_dir();
  const std::string name = (dir / "case.yaml").string();
  const auto error_in = [&](const std::string& yaml) -> std::string {
    try {
      parse_case(yaml, name);
    } catch (const InputError& e) {
      return e.what();
    }
    FAIL("no InputError for:\n" << yaml);
    return "";
  };
  // 2D: the valid case plus one obstacle on line 18.
  const auto with_obstacle = [&](const std::string& obstacle) { return valid + "obstacles:\n  - " + obstacle + "\n"; };
  const std::string terrain_2d = "{name: t, type: terrain, file: t.txt, friction: 0.5}";
  struct Case {
    std::string file_text, yaml, expected;
  };
  const std::vector<Case> cases = {
      {"0 0.5\n1 0.4 0.3\n", with_obstacle(terrain_2d),
       "case.yaml:19: obstacles[0].file = t.txt: t.txt:2: expected one vertex 'x height' (2 numbers), found 3 fields"},
      {"# one vertex\n0 0.5\n", with_obstacle(terrain_2d), "obstacles[0].file = t.txt: t.txt: needs at least 2 vertices"},
      {"0 0.5\n1 nan\n", with_obstacle(terrain_2d), "t.txt:2: height 'nan' is not a finite number"},
      {"0 0.5\n1 1e999\n", with_obstacle(terrain_2d), "t.txt:2: height '1e999' is not a finite number"},
      {"0 0.5\n1 0.4\n1 0.3\n", with_obstacle(terrain_2d), "t.txt:3: x must increase (1 after 1)"},
      {"0 5\n2 6\n", with_obstacle(terrain_2d),
       "obstacles[0].file = t.txt: the terrain lies outside the grid box (above grid.upper on the y axis)"},
      {"5 0.5\n6 0.5\n", with_obstacle(terrain_2d), "the terrain lies outside the grid box (above grid.upper on the x axis)"},
      {"", with_obstacle("{name: w, type: box, lower: [2.5, 0], upper: [3, 1], friction: 0.5}"),
       "obstacles[0].lower: the box lies outside the grid box (above grid.upper on the x axis)"},
      {"", with_obstacle("{name: w, type: box, lower: [2.5, 0], upper: [3, 1], friction: 0.5, velocity: [-0.1, 0]}"),
       "the box lies outside the grid box (above grid.upper on the x axis, for the whole run)"},
      {"", with_obstacle("{name: w, type: box, lower: [-1, -1], upper: [3, 2], friction: 0.5}"),
       "obstacles[0].lower: the whole grid box lies inside the obstacle"},
      {"", with_obstacle("{name: f, type: half_plane, point: [0, -0.5], normal: [0, 1], friction: 0.5}"),
       "obstacles[0].point: the half-plane lies outside the grid box (every grid corner is on its free side)"},
      // Thinner than two cells (0.1 m): its far face can let material through.
      {"", with_obstacle("{name: w, type: box, lower: [1.5, 0], upper: [1.65, 1], friction: 0.5}"),
       "obstacles[0].upper = [1.65, 1]: gives a box 0.15 m thick along x, less than two cells (2 x grid.cell_size = "
       "0.2 m)"},
      {"", with_obstacle("{name: 'a wall', type: box, lower: [1.5, 0], upper: [2, 1], friction: 0.5}"),
       "obstacles[0].name = a wall: must be a non-empty name of letters"},
      {"", with_obstacle("{name: w, type: box, lower: [1.5, 0], upper: [2, 1], friction: 0.5, velocity: [1]}"),
       "obstacles[0].velocity"},
      {"", with_obstacle("{name: w, type: box, lower: [1.5, 0], upper: [2, 1], friction: inf}"),
       "obstacles[0].friction = inf: must be a finite number"},
      {"", with_obstacle("{name: w, type: box, file: x.txt, lower: [1.5, 0], upper: [2, 1], friction: 0.5}"),
       "obstacles[0].file: is a key of terrain obstacles, not of box ones"},
      {"", with_obstacle("{name: w, type: box, lower: [0.4, 0], upper: [1.1, 0.6], friction: 0.5}"),
       "case.yaml:16: bodies[0].box: holds no particle outside the obstacles (its particles would all lie inside "
       "obstacle 'w')"},
      {"", with_obstacle("{name: w, type: box, lower: [0.4, 0], upper: [0.76, 0.6], friction: 0.5}\n"
                         "  - {name: f, type: half_plane, point: [0.75, 0], normal: [-1, 0], friction: 0.5}"),
       "bodies[0].box: holds no particle outside the obstacles (its particles would all lie inside obstacle 'w', 'f')"},
      {"", valid + "obstacles: []\n", "case.yaml:18: obstacles = []: must be a non-empty list"},
      {"", valid + "contact: {gap_predicton: 0.5}\n", "contact.gap_predicton: unknown key (did you mean 'gap_prediction'?)"},
      {"", valid + "contact: {gap_prediction: -0.1}\n", "case.yaml:18: contact.gap_prediction = -0.1: must be in [0, 1]"},
      {"", replace(valid, "y_min: fixed", "y_min: {condition: slip, friction: 0.3}"),
       "case.yaml:17: boundaries.y_min.friction: is only used with condition: frictional"},
      {"", replace(valid, "y_min: fixed", "y_min: {condition: rough, friction: 0.3}"),
       "boundaries.y_min.condition = rough: must be one of: free, slip, fixed, frictional"},
      {"", replace(valid, "y_min: fixed", "y_min: {condition: frictional, friction: 0.3, restitution: -1}"),
       "boundaries.y_min.restitution = -1: must be in [0, 1]"},
  };
  for (const Case& c : cases) {
    write_file(dir / "t.txt", c.file_text);
    const std::string message = error_in(c.yaml);
    INFO("message: " << message);
    CHECK(message.find(c.expected) != std::string::npos);
  }

  // 3D height maps (valid_3d: the file key on line 8).
  const std::vector<std::pair<std::string, std::string>> maps = {
      {"ncols 1\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 1\n0\n0\n", "ground.asc: ncols = 1 must be a whole number from 2 to 1e8"},
      {"ncols 2.5\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 1\n", "ncols = 2.5 must be a whole number from 2 to 1e8"},
      {"ncols 2\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 0\n0 0\n0 0\n", "cellsize = 0 must be > 0"},
      {"ncols 2\nnrows 2\nxllcorner 0\nyllcorner 0\n0 0\n0 0\n", "the header has no cellsize"},
      {"ncols 2\nnrows 2\nxllcorner 0\nxllcenter 0\nyllcorner 0\ncellsize 1\n0 0\n0 0\n",
       "the header gives both xllcorner and xllcenter"},
      {"ncols 2\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 1\ncellsize 1\n0 0\n0 0\n",
       "ground.asc:6: header key 'cellsize' is given twice"},
      {"ncols 2\nnrows 2\nxllcorner 0\nyllcorner 0\ncelsize 1\n0 0\n0 0\n",
       "ground.asc:5: unknown ESRI ASCII grid header key 'celsize'"},
      {"ncols 3\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 0.5\n0.5 0.5 0.5\n0.5 0.5\n",
       "case.yaml:8: obstacles[0].file = ground.asc: ground.asc:7: row 2 has 2 heights, ncols = 3"},
      {"ncols 2\nnrows 3\nxllcorner 0\nyllcorner 0\ncellsize 0.5\n0.5 0.5\n0.5 0.5\n", "ground.asc: 2 rows of heights, but nrows = 3"},
      {"ncols 2\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 0.5\n0.5 0.5\n0.5 0.5\n0.5 0.5\n",
       "ground.asc:8: more than nrows = 2 rows of heights"},
      {"ncols 2\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 0.5\nNODATA_value -1\n0.5 0.5\n-1 0.5\n",
       "ground.asc:8: the height in row 2, column 1 is the NODATA_value -1"},
      {"ncols 2\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 0.5\n0.5 inf\n0.5 0.5\n",
       "ground.asc:6: height in row 1, column 2 'inf' is not a finite number"},
      {"0 0.5\n1 0.5\n", "ground.asc: the header has no xllcorner (or xllcenter)"},
      {"ncols 2\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 0.5\n-2 -2\n-2 -3\n",
       "the terrain lies outside the grid box (below grid.lower on the z axis)"},
  };
  for (const auto& [text, expected] : maps) {
    write_file(dir / "ground.asc", text);
    const std::string message = error_in(valid_3d);
    INFO("file:\n" << text << "message: " << message);
    CHECK(message.find(expected) != std::string::npos);
  }

  // A missing file and a directory name the path looked for (relative to the case file).
  std::filesystem::remove(dir / "ground.asc");
  CHECK_THAT(error_in(valid_3d), Catch::Contains("case.yaml:8: obstacles[0].file = ground.asc: cannot open the terrain file " +
                                                 (dir / "ground.asc").string()));
  std::filesystem::create_directory(dir / "ground.asc");
  CHECK_THAT(error_in(valid_3d), Catch::Contains("obstacles[0].file = ground.asc: is a directory, not a terrain file"));
  std::filesystem::remove_all(dir);
}

TEST_CASE("step and output counts are bounded, and the bounds can be raised explicitly", "[config]") {
  // 1 s in steps of 1e-8 s: 1e8 steps, above the default 1e7.
  const std::string many_steps = replace(valid, "time: {end: 1.0, step: 0.01}", "time: {end: 1.0, step: 1.0e-8}");
  CHECK_THROWS_WITH(parse_case(many_steps, "c.yaml"),
                    Catch::Contains("c.yaml:5: time.step = 1.0e-8: gives end / step = 1e+08 steps, more than "
                                    "time.max_steps = 10000000"));
  const CaseConfig raised = parse_case(
      replace(valid, "time: {end: 1.0, step: 0.01}", "time: {end: 1.0, step: 1.0e-8, max_steps: 100000000}"), "c.yaml");
  CHECK(raised.time.max_steps == 100000000);
  // One output per microsecond of a 1 s run: 1e6 outputs, above the default 1e5.
  const std::string many_outputs = valid + "output: {interval: 1.0e-6}\n";
  CHECK_THROWS_WITH(parse_case(many_outputs, "c.yaml"),
                    Catch::Contains("c.yaml:18: output.interval = 1.0e-6: gives time.end / interval = 1e+06 outputs, "
                                    "more than output.max_outputs = 100000"));
  CHECK(parse_case(valid + "output: {interval: 1.0e-6, max_outputs: 1000000}\n", "c.yaml").output.max_outputs ==
        1000000);
}

TEST_CASE("CR line ends read as line ends, NUL characters are refused", "[config]") {
  // Old Mac line ends: the first comment swallowed the whole file ("it is empty").
  std::string cr = "# a comment\n" + valid;
  for (char& ch : cr)
    if (ch == '\n') ch = '\r';
  CHECK(parse_case(cr, "c.yaml").materials.size() == 1);
  // The YAML escape \0 in a double-quoted text gives a NUL character (a raw
  // NUL byte is already a YAML syntax error).
  const std::string nul = replace(valid, "name: block", "name: \"blo\\0ck\"");
  CHECK_THROWS_WITH(parse_case(nul, "c.yaml"), Catch::Contains("c.yaml:14: a value holds a NUL character"));
}
