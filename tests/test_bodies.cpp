// Bodies beyond boxes and polygons: closed polyhedra (3D) seeded by the
// winding number, and particles read from a file. Each test compares with an
// independent answer: the analytic inside test of a rotated cube, the
// extruded-polygon body (crossing number) of the same solid, and a lattice
// body run side by side with the file written from its particles.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <random>
#include <sstream>

#include "talus/io/config.hpp"
#include "talus/particles/body_region.hpp"
#include "talus/simulation.hpp"
#include "test_support.hpp"

using namespace talus;

namespace {

// A cube of side `a` centred at c, rotated by R: 8 vertices, 6 quadrilateral
// faces ordered counter-clockwise seen from outside (or clockwise if `inward`).
struct Cube {
  double a;
  Vector<3> c;
  Eigen::Matrix3d R;
  std::vector<std::array<double, 3>> vertices;
  std::vector<std::vector<int>> faces;
  Cube(double a_, const Vector<3>& c_, bool inward = false) : a(a_), c(c_) {
    R = Eigen::AngleAxisd(0.4, Vector<3>(0, 0, 1)).toRotationMatrix() *
        Eigen::AngleAxisd(0.7, Vector<3>(1, 1, 0).normalized()).toRotationMatrix();
    for (int k = 0; k < 8; ++k) {
      const Vector<3> local((k & 1 ? 0.5 : -0.5) * a, (k & 2 ? 0.5 : -0.5) * a, (k & 4 ? 0.5 : -0.5) * a);
      const Vector<3> x = c + R * local;
      vertices.push_back({x[0], x[1], x[2]});
    }
    // Vertex k has bits (x, y, z); each face listed counter-clockwise from outside.
    faces = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
    if (inward)
      for (auto& f : faces) std::reverse(f.begin(), f.end());
  }
  bool inside(const Vector<3>& x) const { return (R.transpose() * (x - c)).cwiseAbs().maxCoeff() < 0.5 * a; }
  std::vector<std::array<int, 3>> triangles() const {
    std::vector<std::array<int, 3>> t;
    for (const auto& f : faces)
      for (std::size_t k = 1; k + 1 < f.size(); ++k) t.push_back({f[0], f[k], f[k + 1]});
    return t;
  }
  std::string yaml() const {
    std::ostringstream os;
    os << std::setprecision(17) << "{vertices: [";
    for (std::size_t k = 0; k < vertices.size(); ++k)
      os << (k ? ", " : "") << "[" << vertices[k][0] << ", " << vertices[k][1] << ", " << vertices[k][2] << "]";
    os << "], faces: [";
    for (std::size_t f = 0; f < faces.size(); ++f) {
      os << (f ? ", " : "") << "[";
      for (std::size_t k = 0; k < faces[f].size(); ++k) os << (k ? ", " : "") << faces[f][k];
      os << "]";
    }
    os << "]}";
    return os.str();
  }
};

const std::string header_3d =
    "grid: {lower: [0, 0, 0], upper: [2, 1, 1], cell_size: 0.1}\n"
    "time: {end: 1, step: 0.01}\n"
    "output: {enabled: false}\n"
    "gravity: [0, 0, -9.81]\n"
    "materials: [{name: m, model: linear_elastic, density: 2000, youngs_modulus: 1.0e6, poisson_ratio: 0.3}]\n";

// A directory that every rank sees: made by rank 0, its name broadcast.
std::filesystem::path shared_temp_dir() {
  int rank;
  MPI_Comm_rank(PETSC_COMM_WORLD, &rank);
  char name[4096] = {0};
  if (rank == 0) {
    std::string pattern = (std::filesystem::temp_directory_path() / "talus_bodies_XXXXXX").string();
    REQUIRE(mkdtemp(pattern.data()) != nullptr);
    std::snprintf(name, sizeof name, "%s", pattern.c_str());
  }
  MPI_Bcast(name, sizeof name, MPI_CHAR, 0, PETSC_COMM_WORLD);
  return name;
}

void remove_on_rank0(const std::filesystem::path& dir) {
  int rank;
  MPI_Comm_rank(PETSC_COMM_WORLD, &rank);
  MPI_Barrier(PETSC_COMM_WORLD);  // every rank is done reading
  if (rank == 0) std::filesystem::remove_all(dir);
}

void write_on_rank0(const std::filesystem::path& path, const std::string& text) {
  int rank;
  MPI_Comm_rank(PETSC_COMM_WORLD, &rank);
  MPI_Barrier(PETSC_COMM_WORLD);  // every rank has read the file's previous text
  if (rank == 0) {
    std::ofstream out(path);
    out << text;
  }
  MPI_Barrier(PETSC_COMM_WORLD);
}

}  // namespace

TEST_CASE("winding number and enclosed volume of a rotated cube", "[bodies]") {
  for (const bool inward : {false, true}) {
    const Cube cube(0.5, Vector<3>(1.0, 0.5, 0.5), inward);
    const auto t = cube.triangles();
    // Divergence theorem: exact for a closed surface, signed by orientation.
    CHECK(enclosed_volume(cube.vertices, t) == Approx(inward ? -0.125 : 0.125).epsilon(1e-13));
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-0.45, 0.45);  // the cube reaches 0.433 from its centre
    int inside = 0;
    for (int k = 0; k < 3000; ++k) {
      const Vector<3> x = cube.c + Vector<3>(u(rng), u(rng), u(rng));
      const double distance = 0.5 * cube.a - (cube.R.transpose() * (x - cube.c)).cwiseAbs().maxCoeff();
      if (std::abs(distance) < 1e-9) continue;  // on the surface the winding number is 1/2
      const double w = winding_number(cube.vertices, t, x);
      const double expected = cube.inside(x) ? (inward ? -1.0 : 1.0) : 0.0;
      // Sums of 12 atan2 terms: round-off of a few ulps of 2 pi each.
      CHECK(std::abs(w - expected) < 1e-12);
      inside += cube.inside(x);
    }
    CHECK(inside > 300);  // both sides sampled well: 0.125 / 0.9^3, about 1 in 6, lie inside
  }
}

TEST_CASE("the ray casting of the seeding agrees with the winding number at every lattice point", "[bodies]") {
  // A UV sphere of radius 0.3 (24 x 22 bands, 1008 triangles) on a lattice
  // of spacing 0.02: 27 000 points, about half inside. And a box whose
  // fanned faces have their diagonals exactly on lattice columns.
  BodyConfig sphere;
  sphere.shape = BodyShape::polyhedron;
  const int nu = 24, nv = 22;
  const auto vertex_of = [&](int j, int i) { return 2 + (j - 1) * nu + (i % nu); };
  sphere.polyhedron_vertices = {{0.5, 0.5, 0.8}, {0.5, 0.5, 0.2}};
  for (int j = 1; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      const double th = M_PI * j / nv, ph = 2 * M_PI * i / nu;
      sphere.polyhedron_vertices.push_back(
          {0.5 + 0.3 * std::sin(th) * std::cos(ph), 0.5 + 0.3 * std::sin(th) * std::sin(ph), 0.5 + 0.3 * std::cos(th)});
    }
  for (int i = 0; i < nu; ++i) sphere.polyhedron_triangles.push_back({0, vertex_of(1, i), vertex_of(1, i + 1)});
  for (int j = 1; j < nv - 1; ++j)
    for (int i = 0; i < nu; ++i) {
      sphere.polyhedron_triangles.push_back({vertex_of(j, i), vertex_of(j + 1, i), vertex_of(j + 1, i + 1)});
      sphere.polyhedron_triangles.push_back({vertex_of(j, i), vertex_of(j + 1, i + 1), vertex_of(j, i + 1)});
    }
  for (int i = 0; i < nu; ++i) sphere.polyhedron_triangles.push_back({1, vertex_of(nv - 1, i + 1), vertex_of(nv - 1, i)});
  REQUIRE(enclosed_volume(sphere.polyhedron_vertices, sphere.polyhedron_triangles) > 0);
  sphere.box_lower = {0.2, 0.2, 0.2};
  sphere.box_upper = {0.8, 0.8, 0.8};
  sphere.particles_per_cell = 2;
  const BodyLattice<3> lattice(sphere, {0, 0, 0}, 0.04);
  REQUIRE(lattice.size == 30 * 30 * 30);
  const std::vector<bool> seeded = seeded_lattice_points<3>(sphere, lattice);
  long mismatches = 0, inside = 0;
  for (std::int64_t id = 0; id < lattice.size; ++id) {
    const bool wn = std::abs(winding_number(sphere.polyhedron_vertices, sphere.polyhedron_triangles, lattice.point(id))) > 0.5;
    mismatches += wn != seeded[id];
    inside += seeded[id];
  }
  CHECK(mismatches == 0);
  // The seeded volume against the mesh's 0.11124 m^3 (the sphere's 0.11310),
  // within the lattice resolution: a shell of half a spacing over 1.1 m^2.
  CAPTURE(inside);
  CHECK(std::abs(inside * 8e-6 - enclosed_volume(sphere.polyhedron_vertices, sphere.polyhedron_triangles)) <=
        0.5 * 0.02 * 4 * M_PI * 0.09);

  // The box [0.2, 0.6] x [0.2, 0.6] x [0.1, 0.4]: its top and bottom faces
  // are fanned along the diagonal x = y, on which lie lattice columns exactly
  // (x and y the same double). Every column must cross the surface exactly
  // twice, leaving upwards through the top (+1) and entering through the
  // bottom (-1): a diagonal counted by both triangles or by neither would
  // show up here.
  BodyConfig box;
  box.shape = BodyShape::polyhedron;
  box.particles_per_cell = 2;
  for (int k = 0; k < 8; ++k) box.polyhedron_vertices.push_back({k & 1 ? 0.6 : 0.2, k & 2 ? 0.6 : 0.2, k & 4 ? 0.4 : 0.1});
  for (const auto& f : std::vector<std::vector<int>>{{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}})
    for (std::size_t k = 1; k + 1 < f.size(); ++k) box.polyhedron_triangles.push_back({f[0], f[k], f[k + 1]});
  REQUIRE(enclosed_volume(box.polyhedron_vertices, box.polyhedron_triangles) == Approx(0.4 * 0.4 * 0.3).epsilon(1e-14));
  box.box_lower = {0.2, 0.2, 0.1};
  box.box_upper = {0.6, 0.6, 0.4};
  for (const double cell : {0.1, 0.05, 0.025}) {
    const BodyLattice<3> l(box, {0, 0, 0}, cell);
    CAPTURE(cell);
    long diagonal = 0, wrong = 0;
    for (std::int64_t column = 0; column < l.count[0] * l.count[1]; ++column) {
      const Vector<3> x = l.point(column);
      diagonal += x[0] == x[1];
      const auto c = ray_crossings(box.polyhedron_vertices, box.polyhedron_triangles, x[0], x[1]);
      wrong += !(c.size() == 2 && c[0].second == -1 && c[1].second == 1 && c[0].first == Approx(0.1) &&
                 c[1].first == Approx(0.4));
    }
    CHECK(diagonal == l.count[0]);  // the diagonal columns are there
    CHECK(wrong == 0);
    const std::vector<bool> in = seeded_lattice_points<3>(box, l);
    CHECK(std::count(in.begin(), in.end(), true) == l.size);
  }
}

TEST_CASE("a polyhedron body is filled with exactly the lattice points inside it", "[bodies][mpi]") {
  // A cube of side 0.5 rotated about two axes: the seeded particles are
  // exactly the lattice points (spacing 0.05) of the analytic cube, whichever
  // way its faces are ordered.
  for (const bool inward : {false, true}) {
    const Cube cube(0.5, Vector<3>(1.0, 0.5, 0.5), inward);
    const CaseConfig config =
        testing::case_from_yaml(header_3d + "bodies: [{name: rock, material: m, polyhedron: " + cube.yaml() + "}]\n");
    REQUIRE(config.bodies[0].shape == BodyShape::polyhedron);
    REQUIRE(config.bodies[0].polyhedron_triangles.size() == 12);
    Simulation<3> sim(config, PETSC_COMM_WORLD);
    const std::vector<double> x = testing::gather_by_id(sim.particles(), field::position, 3);
    const std::vector<double> mass = testing::gather_by_id(sim.particles(), field::mass, 1);
    long expected = 0;
    for (int i = 0; i < 40; ++i)
      for (int j = 0; j < 20; ++j)
        for (int k = 0; k < 20; ++k) expected += cube.inside(Vector<3>(0.025 + 0.05 * i, 0.025 + 0.05 * j, 0.025 + 0.05 * k));
    CHECK(static_cast<long>(mass.size()) == expected);
    for (std::size_t p = 0; p < mass.size(); ++p) {
      CHECK(cube.inside(Vector<3>(x[3 * p], x[3 * p + 1], x[3 * p + 2])));
      CHECK(mass[p] == Approx(2000 * 0.05 * 0.05 * 0.05).epsilon(1e-14));
    }
    // The seeded volume approaches 0.125 m^3 to within the lattice resolution
    // over the surface (6 faces of 0.25 m^2, half a spacing each way).
    CHECK(std::abs(mass.size() * 0.05 * 0.05 * 0.05 - 0.125) <= 0.5 * 6 * 0.25 * 0.05);
  }
}

namespace {

// The cube's triangles as an STL file, in millimetres, binary (float32) or ASCII.
std::string cube_stl(const Cube& cube, bool binary, double unit) {
  std::ostringstream os;
  const auto t = cube.triangles();
  if (binary) {
    std::string header(80, ' ');
    header.replace(0, 14, "talus cube mm ");
    os << header;
    const std::uint32_t count = static_cast<std::uint32_t>(t.size());
    os.write(reinterpret_cast<const char*>(&count), 4);
    for (const auto& tri : t) {
      float record[12] = {0, 0, 0};  // the normal is ignored: left zero
      for (int k = 0; k < 3; ++k)
        for (int a = 0; a < 3; ++a) record[3 + 3 * k + a] = static_cast<float>(cube.vertices[tri[k]][a] / unit);
      os.write(reinterpret_cast<const char*>(record), sizeof record);
      const std::uint16_t attribute = 0;
      os.write(reinterpret_cast<const char*>(&attribute), 2);
    }
  } else {
    os << std::setprecision(17) << "solid cube\n";
    for (const auto& tri : t) {
      os << "  facet normal 0 0 0\n    outer loop\n";
      for (int k = 0; k < 3; ++k)
        os << "      vertex " << cube.vertices[tri[k]][0] / unit << " " << cube.vertices[tri[k]][1] / unit << " "
           << cube.vertices[tri[k]][2] / unit << "\n";
      os << "    endloop\n  endfacet\n";
    }
    os << "endsolid cube\n";
  }
  return os.str();
}

}  // namespace

TEST_CASE("a polyhedron read from an STL file, binary or ASCII, in millimetres", "[bodies][mpi]") {
  // The rotated cube written in mm, its corners welded back from the 12
  // triangles' 36 corners; scale 0.001 and a translation of 0.1 m along x.
  // The particles must be those of the same cube given in the case file.
  const Cube cube(0.5, Vector<3>(0.9, 0.5, 0.5));
  const Cube shifted(0.5, Vector<3>(1.0, 0.5, 0.5));
  const std::filesystem::path dir = shared_temp_dir();
  write_on_rank0(dir / "cube_ascii.stl", cube_stl(cube, false, 1e-3));
  write_on_rank0(dir / "cube_binary.stl", cube_stl(cube, true, 1e-3));
  const CaseConfig reference =
      testing::case_from_yaml(header_3d + "bodies: [{name: rock, material: m, polyhedron: " + shifted.yaml() + "}]\n");
  Simulation<3> a(reference, PETSC_COMM_WORLD);
  const std::vector<double> xa = testing::gather_by_id(a.particles(), field::position, 3);
  for (const char* name : {"cube_ascii.stl", "cube_binary.stl"}) {
    CAPTURE(name);
    const CaseConfig config = testing::case_from_yaml(header_3d + "bodies: [{name: rock, material: m, polyhedron: {file: " +
                                                      (dir / name).string() + ", scale: 0.001, translate: [0.1, 0, 0]}}]\n");
    const BodyConfig& body = config.bodies[0];
    CHECK(body.polyhedron_vertices.size() == 8);  // 36 corners welded to the cube's 8
    CHECK(body.polyhedron_triangles.size() == 12);
    // float32 in the binary file: 6e-8 relative per coordinate.
    CHECK(enclosed_volume(body.polyhedron_vertices, body.polyhedron_triangles) == Approx(0.125).epsilon(1e-6));
    Simulation<3> b(config, PETSC_COMM_WORLD);
    const std::vector<double> xb = testing::gather_by_id(b.particles(), field::position, 3);
    CHECK(xa == xb);
  }

  // Broken STL files name the file, the line (ASCII) or the facet, and the problem.
  const std::string good = cube_stl(cube, false, 1e-3);
  const auto without_facet = [&](int k) {  // the ASCII file without its k-th facet (7 lines each)
    std::istringstream in(good);
    std::string line, out;
    for (int number = 0; std::getline(in, line); ++number)
      if (number < 1 + 7 * k || number >= 1 + 7 * (k + 1)) out += line + "\n";
    return out;
  };
  std::string binary = cube_stl(cube, true, 1e-3);
  const std::vector<std::pair<std::string, std::string>> broken = {
      {"", "is neither a binary STL"},
      {"solid empty\nendsolid empty\n", "is an ASCII STL without facets"},
      {binary.substr(0, binary.size() - 1), "is neither a binary STL"},
      {without_facet(3), "belongs to no other face (the surface must be closed)"},
      {"solid x\n facet normal 0 0 1\n  outer loop\n   vertex 1 2\n", "x.stl:4: 'vertex' needs 3 coordinates, found 2"},
      {"solid x\n facet normal 0 0 1\n  outer loop\n   vertex 1 2 z\n", "x.stl:4: coordinate 'z' is not a number"},
      {"solid x\n facet normal 0 0 1\n  outer loop\n   vertex 1 2 3\n   vertex 1 2 4\n  endloop\n",
       "x.stl:6: the facet has 2 vertices (STL facets are triangles)"},
      {"solid x\n facet normal 0 0 1\n  outer loop\n   vertex 1 2 3\n", "x.stl:3: the loop that starts here has no 'endloop'"},
      {"solid x\n facet normal 0 0 1\n  inner loop\n", "x.stl:3: unexpected 'inner'"},
  };
  for (const auto& [text, message] : broken) {
    write_on_rank0(dir / "x.stl", text);
    CAPTURE(text);
    CHECK_THROWS_WITH(testing::case_from_yaml(header_3d + "bodies: [{name: rock, material: m, polyhedron: {file: " +
                                              (dir / "x.stl").string() + ", scale: 0.001}}]\n"),
                      Catch::Contains(message));
  }
  // A facet turned over (two of its vertex lines swapped): it then runs along
  // each of its edges in the same direction as its neighbour.
  {
    std::istringstream in(good);
    std::vector<std::string> lines;
    for (std::string line; std::getline(in, line);) lines.push_back(line);
    std::swap(lines[1 + 7 * 5 + 2], lines[1 + 7 * 5 + 3]);  // facet 6: "facet", "outer loop", then its vertices
    std::string flipped;
    for (const auto& line : lines) flipped += line + "\n";
    write_on_rank0(dir / "x.stl", flipped);
    CHECK_THROWS_WITH(testing::case_from_yaml(header_3d + "bodies: [{name: rock, material: m, polyhedron: {file: " +
                                              (dir / "x.stl").string() + ", scale: 0.001}}]\n"),
                      Catch::Contains("(order every face the same way around its outward normal)"));
  }
  // Units forgotten: the cube in mm lies far outside the grid box.
  write_on_rank0(dir / "x.stl", good);
  CHECK_THROWS_WITH(testing::case_from_yaml(header_3d + "bodies: [{name: rock, material: m, polyhedron: {file: " +
                                            (dir / "x.stl").string() + "}}]\n"),
                    Catch::Contains("lies outside the grid box"));
  CHECK_THROWS_WITH(testing::case_from_yaml(header_3d + "bodies: [{name: rock, material: m, polyhedron: {file: " +
                                            (dir / "x.stl").string() + ", faces: [[0, 1, 2]]}}]\n"),
                    Catch::Contains("polyhedron.faces: give either file or vertices and faces, not both"));
  CHECK_THROWS_WITH(testing::case_from_yaml(header_3d + "bodies: [{name: rock, material: m, polyhedron: " +
                                            shifted.yaml().substr(0, shifted.yaml().size() - 1) + ", scale: 2}}]\n"),
                    Catch::Contains("polyhedron.scale: is only used with file"));
  CHECK_THROWS_WITH(testing::case_from_yaml(header_3d + "bodies: [{name: rock, material: m, polyhedron: {file: " +
                                            (dir / "x.stl").string() + ", scale: -1}}]\n"),
                    Catch::Contains("polyhedron.scale = -1: must be > 0"));
  remove_on_rank0(dir);
}

TEST_CASE("a non-convex polyhedron equals the extruded polygon of the same solid", "[bodies][mpi]") {
  // An L-shaped section in (x, z), extruded over y in [0.1, 0.4]: once as
  // `polygon` + `extrusion` (crossing number in the section) and once as a
  // polyhedron with two non-convex L faces (fanned into triangles that stick
  // out of the L, which the winding number cancels) and six rectangles.
  const std::vector<std::array<double, 2>> L = {{0.2, 0.1}, {1.7, 0.1}, {1.7, 0.35}, {0.75, 0.35}, {0.75, 0.8}, {0.2, 0.8}};
  std::ostringstream polygon, vertices, faces;
  polygon << "[";
  vertices << "[";
  for (std::size_t k = 0; k < L.size(); ++k) {
    polygon << (k ? ", " : "") << "[" << L[k][0] << ", " << L[k][1] << "]";
    vertices << (k ? ", " : "") << "[" << L[k][0] << ", 0.1, " << L[k][1] << "], [" << L[k][0] << ", 0.4, " << L[k][1] << "]";
  }
  polygon << "]";
  vertices << "]";
  // Vertex 2k at y = 0.1, 2k + 1 at y = 0.4. The L runs counter-clockwise in
  // (x, z), i.e. clockwise seen from -y: the y = 0.1 face (outward -y) takes
  // it as it is, the y = 0.4 face reversed, the sides (a, b) at y = 0.1 to y = 0.4.
  const int n = static_cast<int>(L.size());
  faces << "[[";
  for (int k = 0; k < n; ++k) faces << (k ? ", " : "") << 2 * k;
  faces << "], [";
  for (int k = n - 1; k >= 0; --k) faces << (k < n - 1 ? ", " : "") << 2 * k + 1;
  faces << "]";
  for (int k = 0; k < n; ++k) {
    const int a = k, b = (k + 1) % n;
    faces << ", [" << 2 * b << ", " << 2 * a << ", " << 2 * a + 1 << ", " << 2 * b + 1 << "]";
  }
  faces << "]";
  const CaseConfig extruded = testing::case_from_yaml(
      header_3d + "bodies: [{name: l, material: m, polygon: " + polygon.str() + ", extrusion: [0.1, 0.4]}]\n");
  const CaseConfig polyhedron = testing::case_from_yaml(header_3d + "bodies: [{name: l, material: m, polyhedron: {vertices: " +
                                                        vertices.str() + ", faces: " + faces.str() + "}}]\n");
  // Volume of the L: (1.5 x 0.25 + 0.55 x 0.45) x 0.3.
  CHECK(enclosed_volume(polyhedron.bodies[0].polyhedron_vertices, polyhedron.bodies[0].polyhedron_triangles) ==
        Approx((1.5 * 0.25 + 0.55 * 0.45) * 0.3).epsilon(1e-13));
  Simulation<3> a(extruded, PETSC_COMM_WORLD), b(polyhedron, PETSC_COMM_WORLD);
  const std::vector<double> xa = testing::gather_by_id(a.particles(), field::position, 3);
  const std::vector<double> xb = testing::gather_by_id(b.particles(), field::position, 3);
  REQUIRE(xa.size() == xb.size());
  CHECK(xa == xb);  // the same lattice points, with the same ids
  CHECK(xa.size() / 3 == static_cast<std::size_t>(std::round((1.5 * 0.25 + 0.55 * 0.45) * 0.3 / std::pow(0.05, 3))));
}

TEST_CASE("particles read from a file run exactly like the lattice body they were written from", "[bodies][mpi]") {
  // A 2D elastic block slides at 0.5 m/s along a slip floor and is thrown
  // down onto it at 0.25 m/s, so stresses develop.
  // Run A seeds it as a box; run B reads the same particles from a file (in
  // a different column order, with the velocity columns). Same ids, same
  // order on every rank, same arithmetic: the states agree to round-off.
  const std::string header =
      "grid: {lower: [0, 0], upper: [2, 1], cell_size: 0.1}\n"
      "time: {end: 1, step: 0.01}\n"
      "output: {enabled: false}\n"
      "gravity: [0, -9.81]\n"
      "materials: [{name: m, model: linear_elastic, density: 2000, youngs_modulus: 1.0e6, poisson_ratio: 0.3}]\n";
  const CaseConfig lattice_case = testing::case_from_yaml(
      header + "bodies: [{name: b, material: m, box: {lower: [0.5, 0.0], upper: [1.2, 0.4]}, velocity: [0.5, -0.25]}]\n");
  Simulation<2> a(lattice_case, PETSC_COMM_WORLD);
  const std::vector<double> x0 = testing::gather_by_id(a.particles(), field::position, 2);
  const std::size_t n = x0.size() / 2;
  REQUIRE(n == 14 * 8);

  const std::filesystem::path dir = shared_temp_dir();
  std::ostringstream file;
  file << std::setprecision(17) << "# written from the lattice of a box body\nvolume, vy, y, x, vx\n";
  for (std::size_t p = 0; p < n; ++p) file << 0.05 * 0.05 << ", -0.25, " << x0[2 * p + 1] << ", " << x0[2 * p] << ", 0.5\n";
  write_on_rank0(dir / "block.csv", file.str());
  const CaseConfig file_case = testing::case_from_yaml(
      header + "bodies: [{name: b, material: m, particles: " + (dir / "block.csv").string() + "}]\n");
  REQUIRE(file_case.bodies[0].shape == BodyShape::particle_file);
  REQUIRE(file_case.bodies[0].file_lines.front() == 3);
  Simulation<2> b(file_case, PETSC_COMM_WORLD);

  for (const auto& [name, block] : std::vector<std::pair<const char*, int>>{
           {field::position, 2}, {field::velocity, 2}, {field::mass, 1}, {field::initial_volume, 1}})
    CHECK(testing::gather_by_id(a.particles(), name, block) == testing::gather_by_id(b.particles(), name, block));
  for (int step = 0; step < 5; ++step) {
    REQUIRE(a.advance(0.01).converged);
    REQUIRE(b.advance(0.01).converged);
  }
  const auto compare = [&](const char* name, int block, double scale) {
    const std::vector<double> va = testing::gather_by_id(a.particles(), name, block);
    const std::vector<double> vb = testing::gather_by_id(b.particles(), name, block);
    REQUIRE(va.size() == vb.size());
    double worst = 0.0;
    for (std::size_t k = 0; k < va.size(); ++k) worst = std::max(worst, std::abs(va[k] - vb[k]));
    CAPTURE(name, worst);
    // The same sums in the same order; 1e-13 of the field's scale leaves room
    // only for a different summation order, never for a different particle.
    CHECK(worst <= 1e-13 * scale);
  };
  compare(field::position, 2, 1.0);
  compare(field::velocity, 2, 1.0);
  compare(field::stress, 6, 2000 * 9.81 * 0.4);
  // The block moved: the comparison is not between two resting states.
  const std::vector<double> x5 = testing::gather_by_id(b.particles(), field::position, 2);
  double moved = 0.0;
  for (std::size_t k = 0; k < x5.size(); ++k) moved = std::max(moved, std::abs(x5[k] - x0[k]));
  CHECK(moved > 0.02);  // 5 steps at 0.5 m/s along the frictionless floor: 0.025 m
  remove_on_rank0(dir);
}

TEST_CASE("a particle file: columns in any order, comments, volumes, velocities, ids in file order", "[bodies]") {
  const std::filesystem::path dir = shared_temp_dir();
  write_on_rank0(dir / "points.txt",
                 "# three grains\n"
                 "z y  x volume\n"
                 "0.5 0.25 1.5 1e-4   # first\n"
                 "\n"
                 "0.25 0.75 0.5 2e-4\n"
                 "0.75,0.5,1.0,+3e-4\r\n");
  const CaseConfig config = testing::case_from_yaml(
      header_3d + "bodies: [{name: g, material: m, particles: " + (dir / "points.txt").string() + ", velocity: [1, 2, 3]}]\n");
  const BodyConfig& body = config.bodies[0];
  CHECK(body.file_positions == std::vector<double>{1.5, 0.25, 0.5, 0.5, 0.75, 0.25, 1.0, 0.5, 0.75});
  CHECK(body.file_volumes == std::vector<double>{1e-4, 2e-4, 3e-4});
  CHECK(body.file_lines == std::vector<int>{3, 5, 6});
  CHECK(body.file_velocities.empty());
  Simulation<3> sim(config, PETSC_COMM_WORLD);
  const std::vector<double> mass = testing::gather_by_id(sim.particles(), field::mass, 1);
  const std::vector<double> v = testing::gather_by_id(sim.particles(), field::velocity, 3);
  REQUIRE(mass.size() == 3);
  for (int p = 0; p < 3; ++p) {
    CHECK(mass[p] == Approx(2000 * body.file_volumes[p]).epsilon(1e-15));
    CHECK(v[3 * p] == 1.0);
    CHECK(v[3 * p + 2] == 3.0);
  }
  remove_on_rank0(dir);
}

TEST_CASE("malformed particle files and polyhedra name the case line, the file line and the problem", "[bodies]") {
  const std::filesystem::path dir = shared_temp_dir();
  // (particle file text, case text after the body, expected message); the
  // file is written just before its case is read.
  const std::string body =
      header_3d + "bodies:\n  - name: g\n    material: m\n    particles: " + (dir / "p.csv").string() + "\n";
  const std::string at = "<test case>:9: bodies[0].particles = " + (dir / "p.csv").string() + ": " + (dir / "p.csv").string();
  const std::vector<std::array<std::string, 3>> cases = {
      {"", "", at + ": is empty"},
      {"x y z volume\n", "", at + ": holds no particle"},
      {"x y z\n1 0.5 0.5\n", "", at + ":1: the header has no column 'volume'"},
      {"x y z volume mass\n", "", at + ":1: unknown column 'mass' (known in 3D: x, y, z, volume, vx, vy, vz)"},
      {"1 0.5 0.5 1e-3\n", "", at + ":1: the first line must name the columns"},
      {"x y z volume x\n", "", at + ":1: column 'x' is named twice"},
      {"x y z volume vx\n", "", at + ":1: give all velocity columns (vx, vy, vz) or none"},
      {"x y z volume\n1 0.5 0.5 1e-3\n1 0.5 0.5\n", "", at + ":3: expected 4 fields (one per column), found 3"},
      {"x y z volume\n1 0.5 0.5 -1e-3\n", "", at + ":2: volume '-1e-3' must be in [1e-30, 1e30] m^3"},
      {"x y z volume\n1 0.5 nan 1e-3\n", "", at + ":2: z 'nan' is not a finite number"},
      {"x y z volume\n1 0.5 1.0 1e-3\n", "", at + ":2: the particle lies outside the grid box (z = 1 is not in (0, 1))"},
      {"x y z volume vx vy vz\n1 0.5 0.5 1e-3 0 0 0\n", "    velocity: [1, 0, 0]\n",
       "<test case>:10: bodies[0].velocity: the particle file"},
      {"x y z volume\n1 0.5 0.5 1e-3\n", "    particles_per_cell: 3\n",
       "<test case>:10: bodies[0].particles_per_cell: is not used with a particle file"},
      {"x y z volume\n1 0.5 0.5 1e-3\n", "    initial_stress: geostatic\n",
       "<test case>:10: bodies[0].initial_stress = geostatic: needs a body seeded on the lattice"},
      {"x y z volume\n1 0.5 0.5 1e-3\n", "obstacles: [{name: floor, type: half_plane, point: [0, 0, 0.6], normal: [0, 0, 1], friction: 0}]\n",
       at + ":2: the particle lies inside obstacle 'floor'"},
  };
  for (const auto& [file_text, extra, message] : cases) {
    write_on_rank0(dir / "p.csv", file_text);
    CAPTURE(file_text, extra);
    CHECK_THROWS_WITH(testing::case_from_yaml(body + extra), Catch::Contains(message));
  }
  const std::vector<std::pair<std::string, std::string>> paths = {
      {dir.string(), "is a directory, not a particle file"},
      {"no_such.csv", "cannot open the particle file"}};
  for (const auto& [path, message] : paths)
    CHECK_THROWS_WITH(testing::case_from_yaml(header_3d + "bodies: [{name: g, material: m, particles: " + path + "}]\n"),
                      Catch::Contains(message));
  CHECK_THROWS_WITH(
      testing::case_from_yaml(header_3d +
                              "bodies: [{name: g, material: m, box: {lower: [0, 0, 0], upper: [1, 1, 1]}, particles: p.csv}]\n"),
      Catch::Contains("bodies[0].particles: give one of box, polygon, polyhedron and particles, not both box and particles"));

  // Polyhedra: a tetrahedron, then broken copies of it.
  const std::string v = "vertices: [[0.5, 0.2, 0.2], [1.5, 0.2, 0.2], [0.5, 0.8, 0.2], [0.5, 0.2, 0.8]]";
  const auto tet = [&](const std::string& faces, const std::string& vertices = "") {
    return header_3d + "bodies: [{name: t, material: m, polyhedron: {" + (vertices.empty() ? v : vertices) +
           ", faces: " + faces + "}}]\n";
  };
  const std::string good = "[[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]";
  const CaseConfig config = testing::case_from_yaml(tet(good));
  CHECK(enclosed_volume(config.bodies[0].polyhedron_vertices, config.bodies[0].polyhedron_triangles) ==
        Approx(1.0 * 0.6 * 0.6 / 6).epsilon(1e-14));
  const std::vector<std::pair<std::string, std::string>> polyhedra = {
      {tet("[[0, 2, 1], [0, 1, 3], [0, 3, 2]]"), "polyhedron.faces: needs at least 4 faces"},
      {tet("[[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 3, 2]]"),
       "polyhedron.faces: faces 1 and 3 both run from vertex 1 to 3 (order every face the same way"},
      {tet("[[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 4]]"), "polyhedron.faces: face 3 names vertex 4; the vertices are 0..3"},
      {tet("[[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 2]]"), "polyhedron.faces: face 3 names vertex 2 twice"},
      {tet("[[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2]]"), "polyhedron.faces: face 3 has fewer than 3 vertices"},
      {tet("[[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, x]]"), "polyhedron.faces[3] = [1, 2, x]: entry 'x' is not an integer"},
      {tet("[[0, 2, 1], [0, 1, 3], [0, 3, 2], [0, 2, 3]]"), "faces 0 and 3 both run from vertex 0 to 2"},
      {tet("[[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3, 0]]"), "faces 1 and 3 both run from vertex 3 to 0"},
      {tet(good, "vertices: [[0.5, 0.2, 0.2], [1.5, 0.2, 0.2], [0.5, 0.8, 0.2], [0.5, 0.2, 1.8]]"),
       "polyhedron.vertices: vertex 3 lies outside the grid box"},
      {tet(good, "vertices: [[0.5, 0.2, 0.2], [1.5, 0.2, 0.2], [0.5, 0.8, 0.2], [0.9, 0.4, 0.2]]"),
       "polyhedron.faces: enclose no volume"},
      {tet("[[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]", "vertices: [[0.5, 0.2, 0.2], [0.51, 0.2, 0.2], [0.5, 0.21, 0.2], [0.5, 0.2, 0.21]]"),
       "bodies[0].polyhedron: holds no particle (too thin for the particle spacing"},
  };
  for (const auto& [yaml, message] : polyhedra) {
    CAPTURE(yaml);
    CHECK_THROWS_WITH(testing::case_from_yaml(yaml), Catch::Contains(message));
  }
  // An open surface: the tetrahedron without face 3 and a fourth vertex unused elsewhere.
  CHECK_THROWS_WITH(testing::case_from_yaml(header_3d + "bodies: [{name: t, material: m, polyhedron: {vertices: "
                                                        "[[0.5, 0.2, 0.2], [1.5, 0.2, 0.2], [0.5, 0.8, 0.2], [0.5, 0.2, 0.8], [1, 1, 1]], "
                                                        "faces: [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 4]]}}]\n"),
                    Catch::Contains("belongs to no other face (the surface must be closed)"));
  // Two bodies with one name.
  CHECK_THROWS_WITH(testing::case_from_yaml(header_3d + "bodies:\n"
                                                        "  - {name: rock, material: m, box: {lower: [0, 0, 0], upper: [0.5, 0.5, 0.5]}}\n"
                                                        "  - {name: rock, material: m, box: {lower: [1, 0, 0], upper: [1.5, 0.5, 0.5]}}\n"),
                    Catch::Contains("<test case>:8: bodies[1].name = rock: is used by two bodies"));
  // 2D has no polyhedra.
  CHECK_THROWS_WITH(testing::case_from_yaml(
                        "grid: {lower: [0, 0], upper: [2, 1], cell_size: 0.1}\ntime: {end: 1, step: 0.01}\n"
                        "materials: [{name: m, model: linear_elastic, density: 2000, youngs_modulus: 1.0e6, poisson_ratio: 0.3}]\n"
                        "bodies: [{name: t, material: m, polyhedron: {vertices: [[0, 0]], faces: [[0]]}}]\n"),
                    Catch::Contains("bodies[0].polyhedron: is only used in 3D"));
  remove_on_rank0(dir);
}
