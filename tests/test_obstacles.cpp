// Obstacle geometry (src/contact/obstacle.cpp): the signed gap and the
// outward normal of half-planes, boxes and terrains against closed forms, in
// 2D and 3D, fixed and moving; and a 3D terrain read from an ESRI ASCII grid
// by the case loader (north row first) giving the same closed form. The
// loads on an obstacle over time (src/io/obstacle_loads.cpp): impulses,
// their running total and the window-averaged force against closed forms.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include "talus/contact/obstacle.hpp"
#include "talus/io/config.hpp"
#include "talus/io/obstacle_loads.hpp"

using namespace talus;

namespace {

constexpr double tol = 1e-12;

template <int dim>
void check_gap(const Obstacle<dim>& obstacle, const Vector<dim>& x, double t, double gap, const Vector<dim>& normal) {
  const ObstacleGap<dim> g = obstacle.gap(x, t);
  INFO("x = " << x.transpose() << ", t = " << t << ": gap " << g.gap << " (want " << gap << "), normal "
              << g.normal.transpose() << " (want " << normal.transpose() << ")");
  CHECK(std::abs(g.gap - gap) <= tol);
  CHECK((g.normal - normal).norm() <= tol);
  CHECK(std::abs(g.normal.norm() - 1.0) <= tol);
}

ObstacleConfig half_plane(std::vector<double> point, std::vector<double> normal) {
  ObstacleConfig c;
  c.name = "plane";
  c.shape = ObstacleShape::half_plane;
  c.point = std::move(point);
  c.normal = std::move(normal);
  return c;
}

ObstacleConfig box(std::vector<double> lower, std::vector<double> upper) {
  ObstacleConfig c;
  c.name = "box";
  c.shape = ObstacleShape::box;
  c.lower = std::move(lower);
  c.upper = std::move(upper);
  return c;
}

// A fresh directory under the system's temporary directory (tests may run in parallel).
std::filesystem::path temp_dir() {
  std::string pattern = (std::filesystem::temp_directory_path() / "talus_obstacles_XXXXXX").string();
  REQUIRE(mkdtemp(pattern.data()) != nullptr);
  return pattern;
}

}  // namespace

TEST_CASE("half-plane at an arbitrary angle: gap (x - p).n, normal n", "[obstacle]") {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  SECTION("2D") {
    const double angle = 0.37;  // normal not along an axis, given unnormalised
    const Vector<2> n(std::cos(angle), std::sin(angle)), p(0.3, -1.2);
    const Obstacle<2> plane(half_plane({p[0], p[1]}, {2.5 * n[0], 2.5 * n[1]}));
    for (int k = 0; k < 20; ++k) {
      const Vector<2> x(u(rng), u(rng));
      check_gap<2>(plane, x, 0.0, (x - p).dot(n), n);
    }
  }
  SECTION("3D") {
    const Vector<3> n = Vector<3>(1.0, -2.0, 3.0).normalized(), p(0.5, 0.25, -0.75);
    const Obstacle<3> plane(half_plane({p[0], p[1], p[2]}, {1.0, -2.0, 3.0}));
    for (int k = 0; k < 20; ++k) {
      const Vector<3> x(u(rng), u(rng), u(rng));
      check_gap<3>(plane, x, 0.0, (x - p).dot(n), n);
    }
  }
}

TEST_CASE("box: distance to the closest face, edge or corner outside, minus the nearest face's inside", "[obstacle]") {
  SECTION("2D, box [0, 1] x [0, 2]") {
    const Obstacle<2> b(box({0.0, 0.0}, {1.0, 2.0}));
    // Corner region: Euclidean distance to the corner (1, 2).
    check_gap<2>(b, Vector<2>(1.3, 2.4), 0.0, 0.5, Vector<2>(0.6, 0.8));
    check_gap<2>(b, Vector<2>(-0.3, -0.4), 0.0, 0.5, Vector<2>(-0.6, -0.8));
    // Face regions: distance to the face, its normal.
    check_gap<2>(b, Vector<2>(0.5, 2.25), 0.0, 0.25, Vector<2>(0.0, 1.0));
    check_gap<2>(b, Vector<2>(-0.1, 1.0), 0.0, 0.1, Vector<2>(-1.0, 0.0));
    check_gap<2>(b, Vector<2>(1.7, 0.3), 0.0, 0.7, Vector<2>(1.0, 0.0));
    // Inside: minus the distance to the nearest face, that face's normal.
    check_gap<2>(b, Vector<2>(0.2, 1.0), 0.0, -0.2, Vector<2>(-1.0, 0.0));
    check_gap<2>(b, Vector<2>(0.5, 1.9), 0.0, -0.1, Vector<2>(0.0, 1.0));
    check_gap<2>(b, Vector<2>(0.6, 0.05), 0.0, -0.05, Vector<2>(0.0, -1.0));
    check_gap<2>(b, Vector<2>(0.9, 1.2), 0.0, -0.1, Vector<2>(1.0, 0.0));
  }
  SECTION("3D, unit cube") {
    const Obstacle<3> b(box({0.0, 0.0, 0.0}, {1.0, 1.0, 1.0}));
    // Corner region: beyond three faces.
    check_gap<3>(b, Vector<3>(1.2, 1.3, 1.6), 0.0, 0.7, Vector<3>(0.2, 0.3, 0.6) / 0.7);
    // Edge region: beyond two faces, the distance to the edge.
    check_gap<3>(b, Vector<3>(1.3, 0.5, -0.4), 0.0, 0.5, Vector<3>(0.6, 0.0, -0.8));
    // Face region.
    check_gap<3>(b, Vector<3>(0.25, -0.5, 0.75), 0.0, 0.5, Vector<3>(0.0, -1.0, 0.0));
    // Inside.
    check_gap<3>(b, Vector<3>(0.5, 0.5, 0.9), 0.0, -0.1, Vector<3>(0.0, 0.0, 1.0));
    check_gap<3>(b, Vector<3>(0.3, 0.04, 0.5), 0.0, -0.04, Vector<3>(0.0, -1.0, 0.0));
  }
}

TEST_CASE("2D terrain polyline: segments, a convex kink, below, beyond the ends", "[obstacle]") {
  // A ridge at (1, 1), a valley at (2, 0), then a gentle rise to (4, 0.5).
  ObstacleConfig c;
  c.name = "terrain";
  c.shape = ObstacleShape::terrain;
  c.polyline = {{0.0, 0.0}, {1.0, 1.0}, {2.0, 0.0}, {4.0, 0.5}};
  const Obstacle<2> terrain(c);
  const double r2 = std::sqrt(2.0), r17 = std::sqrt(4.25);  // |(1, 1)|, |(2, 0.5)|

  // Above the segment y = x: the perpendicular distance, the segment's normal.
  check_gap<2>(terrain, Vector<2>(0.3, 0.8), 0.0, 0.5 / r2, Vector<2>(-1.0, 1.0) / r2);
  // Above the ridge, in the vertex's normal cone: the distance to the vertex,
  // the normal along x - vertex.
  const Vector<2> x(1.2, 1.6), ridge(1.0, 1.0);
  check_gap<2>(terrain, x, 0.0, (x - ridge).norm(), (x - ridge).normalized());
  // Below the terrain: negative, the upward normal of the segment above.
  check_gap<2>(terrain, Vector<2>(3.0, 0.0), 0.0, -0.5 / r17, Vector<2>(-0.5, 2.0) / r17);
  // Beyond the last vertex: the last segment extended.
  check_gap<2>(terrain, Vector<2>(5.0, 1.0), 0.0, 0.5 / r17, Vector<2>(-0.5, 2.0) / r17);
  // Before the first vertex: the first segment extended (the line y = x).
  check_gap<2>(terrain, Vector<2>(-1.0, -0.5), 0.0, 0.5 / r2, Vector<2>(-1.0, 1.0) / r2);
  check_gap<2>(terrain, Vector<2>(-1.0, -1.5), 0.0, -0.5 / r2, Vector<2>(-1.0, 1.0) / r2);
}

TEST_CASE("3D height map sampling a plane: gap (z - a x - b y - c) / sqrt(1 + a^2 + b^2)", "[obstacle]") {
  const double a = 0.3, b = -0.2, c0 = 1.0;
  ObstacleConfig c;
  c.name = "terrain";
  c.shape = ObstacleShape::terrain;
  c.map_origin = {-1.0, -2.0};
  c.map_spacing = 0.5;
  c.map_nx = 7;
  c.map_ny = 5;
  for (int j = 0; j < c.map_ny; ++j)
    for (int i = 0; i < c.map_nx; ++i)
      c.heights.push_back(a * (c.map_origin[0] + i * c.map_spacing) + b * (c.map_origin[1] + j * c.map_spacing) + c0);
  const Obstacle<3> terrain(c);
  const double norm = std::sqrt(1.0 + a * a + b * b);
  const Vector<3> n = Vector<3>(-a, -b, 1.0) / norm;
  std::mt19937 rng(11);
  // Inside the map (x in [-1, 2], y in [-2, 0]) and beyond it (border cells extended).
  std::uniform_real_distribution<double> ux(-2.0, 3.0), uy(-3.0, 1.0), uz(-2.0, 3.0);
  for (int k = 0; k < 50; ++k) {
    const Vector<3> x(ux(rng), uy(rng), uz(rng));
    check_gap<3>(terrain, x, 0.0, (x[2] - a * x[0] - b * x[1] - c0) / norm, n);
  }
}

TEST_CASE("a moving obstacle: the gap at time t is the gap at x - velocity t", "[obstacle]") {
  SECTION("half-plane") {
    ObstacleConfig c = half_plane({0.0, 0.0}, {0.6, 0.8});
    c.velocity = {1.5, -0.5};
    const Obstacle<2> plane(c);
    const Vector<2> n(0.6, 0.8), v(1.5, -0.5), x(0.7, 0.4);
    CHECK(plane.velocity() == v);
    for (double t : {0.0, 0.1, 0.75, 2.0}) check_gap<2>(plane, x, t, x.dot(n) - t * v.dot(n), n);
  }
  SECTION("box (3D)") {
    ObstacleConfig c = box({0.0, 0.0, 0.0}, {1.0, 1.0, 1.0});
    c.velocity = {0.0, 0.0, -2.0};  // a falling block
    const Obstacle<3> b(c);
    // Above the top face at z = 1 - 2 t.
    for (double t : {0.0, 0.1, 0.25})
      check_gap<3>(b, Vector<3>(0.5, 0.5, 1.5), t, 0.5 + 2.0 * t, Vector<3>(0.0, 0.0, 1.0));
    // At t = 0.5 the top face is at z = 0 and the corner region lies above-right.
    check_gap<3>(b, Vector<3>(1.3, 0.5, 0.4), 0.5, 0.5, Vector<3>(0.6, 0.0, 0.8));
  }
  SECTION("terrain (2D)") {
    ObstacleConfig c;
    c.shape = ObstacleShape::terrain;
    c.polyline = {{0.0, 0.0}, {10.0, 0.0}};
    c.velocity = {3.0, 0.25};  // a rising conveyor belt
    const Obstacle<2> floor(c);
    for (double t : {0.0, 0.4, 1.0})
      check_gap<2>(floor, Vector<2>(2.0, 0.5), t, 0.5 - 0.25 * t, Vector<2>(0.0, 1.0));
  }
}

TEST_CASE("a 3D terrain from an ESRI ASCII grid (north row first) gives the plane it samples", "[obstacle][config]") {
  // z = a x + b y + c on 5 x 4 samples, spacing 0.5, the south-west sample
  // centre at (0.25, 0.25): the header gives the corner (0, 0).
  const double a = 0.2, b = 0.1, c0 = 0.05, s = 0.5;
  const int nx = 5, ny = 4;
  const std::filesystem::path dir = temp_dir();
  {
    std::ofstream asc(dir / "plane.asc");
    asc << "ncols " << nx << "\nnrows " << ny << "\nxllcorner 0.0\nyllcorner 0.0\ncellsize " << s
        << "\nNODATA_value -9999\n";
    asc.precision(17);
    for (int row = 0; row < ny; ++row) {  // north (largest y) first
      const double y = 0.25 + (ny - 1 - row) * s;
      for (int i = 0; i < nx; ++i) asc << (i ? " " : "") << a * (0.25 + i * s) + b * y + c0;
      asc << "\n";
    }
  }
  const std::string yaml =
      "grid: {lower: [0, 0, 0], upper: [2.5, 2, 1.5], cell_size: 0.5}\n"
      "time: {end: 1, step: 0.1}\n"
      "materials: [{name: m, model: linear_elastic, density: 1000, youngs_modulus: 1e6, poisson_ratio: 0.2}]\n"
      "bodies: [{name: b, material: m, box: {lower: [1, 1, 0.5], upper: [1.5, 1.5, 1]}}]\n"
      "obstacles:\n"
      "  - {name: ground, type: terrain, file: plane.asc, friction: 0.6}\n";
  const CaseConfig config = parse_case(yaml, (dir / "case.yaml").string());
  REQUIRE(config.obstacles.size() == 1);
  const ObstacleConfig& o = config.obstacles[0];
  CHECK(o.map_nx == nx);
  CHECK(o.map_ny == ny);
  const Obstacle<3> terrain(o);
  const double norm = std::sqrt(1.0 + a * a + b * b);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> ux(0.0, 2.5), uy(0.0, 2.0), uz(-0.5, 1.5);
  for (int k = 0; k < 30; ++k) {
    const Vector<3> x(ux(rng), uy(rng), uz(rng));
    check_gap<3>(terrain, x, 0.0, (x[2] - a * x[0] - b * x[1] - c0) / norm, Vector<3>(-a, -b, 1.0) / norm);
  }
  std::filesystem::remove_all(dir);
}

TEST_CASE("2D terrain polyline: the local search gives the full scan's gap and normal", "[obstacle]") {
  // A rough terrain of 2000 vertices (random steps and slopes, some steep),
  // queried at random points above, below and beyond its ends: the bisection
  // search (src/contact/obstacle.cpp) must return exactly what scanning every
  // segment returns.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> step(0.001, 0.05), slope(-3.0, 3.0), unit(0.0, 1.0);
  ObstacleConfig c;
  c.name = "rough";
  c.shape = ObstacleShape::terrain;
  double x = 0.0, y = 0.0;
  for (int k = 0; k < 2000; ++k) {
    c.polyline.push_back({x, y});
    const double dx = step(rng);
    x += dx;
    y += slope(rng) * dx;
  }
  const Obstacle<2> terrain(c);
  const auto& v = c.polyline;
  const std::size_t segments = v.size() - 1;
  int checked = 0;
  for (int q = 0; q < 3000; ++q) {
    const Vector<2> p(-1.0 + (x + 2.0) * unit(rng), -3.0 + 6.0 * unit(rng));
    // The full scan, as the code did before the local search.
    double best = std::numeric_limits<double>::infinity();
    Vector<2> closest = Vector<2>::Zero();
    for (std::size_t s = 0; s < segments; ++s) {
      const Vector<2> a(v[s][0], v[s][1]), b(v[s + 1][0], v[s + 1][1]), d = b - a;
      double t = (p - a).dot(d) / d.squaredNorm();
      t = std::clamp(t, s == 0 ? -1e300 : 0.0, s + 1 == segments ? 1e300 : 1.0);
      const double distance = (p - (a + t * d)).norm();
      if (distance < best) best = distance, closest = a + t * d;
    }
    const ObstacleGap<2> g = terrain.gap(p, 0.0);
    REQUIRE(std::abs(g.gap) == best);
    if (best > 1e-9) CHECK((g.normal - std::copysign(1.0, g.gap) * (p - closest) / best).norm() < 1e-14);
    ++checked;
  }
  CHECK(checked == 3000);
}

TEST_CASE("obstacle loads: a constant force gives impulse F h, total F t, window force F", "[obstacle][loads]") {
  // Steps of uneven size (a cut-back and regrowth); the window T = 0.05 s is
  // no multiple of them, so steps straddle its start. Every quantity is a
  // closed form of F and t; the tolerance is round-off of sums of ~20 terms.
  const std::vector<double> force{300.0, -400.0};  // |F| = 500
  ObstacleLoads loads(1, 2, 0.05);
  double t = 0.0;
  for (double h : {0.01, 0.01, 0.005, 0.0025, 0.0025, 0.005, 0.01, 0.02, 0.02, 0.01, 0.01, 0.01}) {
    loads.add_step(t, t + h, force);
    const double hk = (t + h) - t;
    t += h;
    for (int a = 0; a < 2; ++a) {
      CHECK(loads.step_impulse()[a] == force[a] * hk);
      CHECK(std::abs(loads.total_impulse()[a] - force[a] * t) <= 1e-14 * 500.0 * t);
      CHECK(std::abs(loads.window_force()[a] - force[a]) <= 1e-13 * 500.0);
    }
    CHECK(std::abs(loads.peak_force()[0] - 500.0) <= 1e-13 * 500.0);
  }
}

TEST_CASE("obstacle loads: one impact's impulse I spread over the window, I/T, then partly, then gone",
          "[obstacle][loads]") {
  // Steps of 0.01 s, one impact in the step (0.10, 0.11] of impulse 2 N s/m
  // (force 200 N/m), nothing else; window T = 0.025 s. The window (t - T, t]
  // holds the whole impact at t = 0.11 and 0.12 (force I/T = 80 N/m), half
  // of its step at t = 0.13 (window from 0.105: 40 N/m), none from 0.14 on.
  // The step force peaks at 200 N/m; the window force at 80 N/m, first at
  // t = 0.11. The running total stays I after the impact.
  ObstacleLoads loads(2, 2, 0.025);
  std::vector<std::pair<double, double>> window;  // (t, window force x of obstacle 1)
  for (int k = 0; k < 20; ++k) {
    const double start = 0.01 * k, end = 0.01 * (k + 1);
    std::vector<double> force{0.0, 0.0, k == 10 ? 200.0 : 0.0, 0.0};  // obstacle 0 untouched
    loads.add_step(start, end, force);
    window.emplace_back(end, loads.window_force()[2]);
    CHECK(loads.window_force()[0] == 0.0);
    CHECK(loads.total_impulse()[2] == Approx(k >= 10 ? 2.0 : 0.0).margin(1e-13));  // 200 N/m x (0.11 - 0.10)
  }
  const double tol = 1e-12 * 80.0;  // round-off of t - T and of the fraction
  for (const auto& [t, f] : window) {
    INFO("t = " << t << ": window force " << f);
    const double want = t < 0.105 ? 0.0 : t < 0.125 ? 80.0 : t < 0.135 ? 40.0 : 0.0;
    CHECK(std::abs(f - want) <= tol);
  }
  CHECK(std::abs(loads.peak_force()[1] - 80.0) <= tol);  // per obstacle: obstacle 1
  CHECK(std::abs(loads.peak_time()[1] - 0.11) <= 1e-15);
  CHECK(loads.peak_force()[0] == 0.0);
}

TEST_CASE("obstacle loads: before a full window the mean since t = 0, with a window 0 or shorter than a step the step force",
          "[obstacle][loads]") {
  ObstacleLoads long_window(1, 3, 1.0), none(1, 3, 0.0);
  // 1 N for 0.1 s, then 3 N for 0.1 s: the mean since 0 at t = 0.2 is 2 N.
  long_window.add_step(0.0, 0.1, {1.0, 0.0, 0.0});
  long_window.add_step(0.1, 0.2, {3.0, 0.0, 0.0});
  CHECK(std::abs(long_window.window_force()[0] - 2.0) <= 1e-15 * 2.0 / 0.2);
  none.add_step(0.0, 0.1, {1.0, 2.0, 3.0});
  none.add_step(0.1, 0.2, {3.0, -2.0, 1.0});
  CHECK(none.window_force() == std::vector<double>{3.0, -2.0, 1.0});
  CHECK(none.peak_force()[0] == Approx(std::sqrt(14.0)).epsilon(1e-15));
  CHECK(none.peak_time()[0] == 0.1);  // both steps reach sqrt(14): the first counts
  // A window shorter than the step lies within it: the step's force, also
  // for a window below the resolution of the time.
  for (double window : {0.001, 4.9e-324}) {
    ObstacleLoads short_window(1, 3, window);
    short_window.add_step(0.0, 0.1, {1.0, 2.0, 3.0});
    short_window.add_step(0.1, 0.2, {3.0, -2.0, 1.0});
    CHECK(short_window.window_force() == std::vector<double>{3.0, -2.0, 1.0});
  }
}

TEST_CASE("obstacle loads: restored from their state, they continue bit for bit", "[obstacle][loads]") {
  // What a checkpoint stores (ObstacleLoads::State) is all a restart needs:
  // 30 steps straight through against 17, a copy through the state, 13 more.
  const auto force = [](int k) {
    return std::vector<double>{std::sin(0.7 * k) * 1e3, std::cos(0.3 * k) * 5e2, k % 7 == 0 ? 4e4 : 0.0, 1.0};
  };
  const auto step = [](int k) { return 0.003 * k + 0.0001 * (k % 3); };  // uneven steps
  ObstacleLoads whole(2, 2, 0.02), first(2, 2, 0.02);
  for (int k = 0; k < 30; ++k) whole.add_step(step(k), step(k + 1), force(k));
  for (int k = 0; k < 17; ++k) first.add_step(step(k), step(k + 1), force(k));
  ObstacleLoads second(2, 2, 0.02);
  second.restore(first.state());
  for (int k = 17; k < 30; ++k) second.add_step(step(k), step(k + 1), force(k));
  CHECK(second.total_impulse() == whole.total_impulse());
  CHECK(second.window_force() == whole.window_force());
  CHECK(second.peak_force() == whole.peak_force());
  CHECK(second.peak_time() == whole.peak_time());
  ObstacleLoads other_window(2, 2, 0.03);
  CHECK_THROWS_AS(other_window.restore(first.state()), std::invalid_argument);
}
