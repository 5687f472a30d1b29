#include "talus/io/config.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <limits>
#include <map>
#include <sstream>
#include <system_error>

#include <petscsys.h>
#include <unistd.h>

#include "talus/io/body_config.hpp"
#include "talus/io/case_memory.hpp"
#include "talus/io/run_config.hpp"
#include "talus/io/terrain_file.hpp"
#include "talus/io/yaml_section.hpp"
#include "talus/solver/petsc_options.hpp"

namespace talus {

// ---------------------------------------------------------------- case file

const std::vector<std::string> face_conditions = {"free", "slip", "fixed", "frictional"};
const char* const face_names[6] = {"x_min", "x_max", "y_min", "y_max", "z_min", "z_max"};

namespace {

const char* const axis_names[3] = {"x", "y", "z"};

// time.end / time.step must stay below time.max_steps (an overridable guard
// against runs that would never end).
void check_step_count(YamlSection& t, const TimeConfig& time) {
  const double nominal_steps = time.end / time.step;
  if (!(nominal_steps <= static_cast<double>(time.max_steps))) {
    std::ostringstream m;
    m << "gives end / step = " << nominal_steps << " steps, more than time.max_steps = " << time.max_steps
      << "; raise time.max_steps to run that many";
    t.fail_value("step", m.str());
  }
}

// The first step of `time.step: auto` (docs/solver.md#choosing-the-step):
// min(gravity_number sqrt(cell / |g|), courant cell / v0, end), v0 the fastest
// initial body or obstacle velocity; infinite when nothing sets a time scale.
double first_auto_step(const CaseConfig& c) {
  const auto norm = [](const double* v, int n) {
    double s = 0.0;
    for (int i = 0; i < n; ++i) s += v[i] * v[i];
    return std::sqrt(s);
  };
  const double g = norm(c.gravity.data(), c.dim);
  double speed = 0.0;
  for (const BodyConfig& b : c.bodies) {
    if (!b.velocity.empty()) speed = std::max(speed, norm(b.velocity.data(), c.dim));
    for (std::size_t p = 0; p + c.dim <= b.file_velocities.size(); p += c.dim)
      speed = std::max(speed, norm(b.file_velocities.data() + p, c.dim));
  }
  for (const ObstacleConfig& o : c.obstacles)
    if (!o.velocity.empty()) speed = std::max(speed, norm(o.velocity.data(), c.dim));
  const double h = automatic_step(c.time, c.grid.cell_size, g, speed);
  return std::isfinite(h) ? std::min(h, c.time.end) : h;
}

// A required text that must be one of `choices`.
std::string required_choice(YamlSection& s, const std::string& key, const std::vector<std::string>& choices) {
  const std::string v = s.text(key);
  if (std::find(choices.begin(), choices.end(), v) == choices.end()) {
    std::string list;
    for (const auto& c : choices) list += (list.empty() ? "" : ", ") + c;
    s.fail_value(key, v, "must be one of: " + list);
  }
  return v;
}

// Coulomb's mu (required, >= 0) and Newton's restitution e (default 0, in [0, 1]).
void parse_friction(YamlSection& s, double& friction, double& restitution) {
  friction = s.real("friction");
  if (!(friction >= 0)) s.fail_value("friction", "must be >= 0 (the Coulomb coefficient mu)");
  restitution = s.real("restitution", 0.0);
  if (!(restitution >= 0 && restitution <= 1))
    s.fail_value("restitution", "must be in [0, 1]");
}

FaceCondition face_condition(const std::string& v) {
  return v == "free"    ? FaceCondition::free
         : v == "slip"  ? FaceCondition::slip
         : v == "fixed" ? FaceCondition::fixed
                        : FaceCondition::frictional;
}

// One face of the grid box: a text (free, slip, fixed), or a map
// {condition: ..., friction: ..., restitution: ...}, which a frictional face
// needs for its friction coefficient. `raw` is the boundaries map itself, only
// looked at to tell the two forms apart.
void parse_face(YamlSection& f, const YAML::Node& raw, const std::string& key, FaceCondition& condition,
                FaceContact& contact) {
  const YAML::Node value = raw[key];
  if (value.IsDefined() && value.IsMap()) {
    YamlSection m = f.section(key);
    condition = face_condition(required_choice(m, "condition", face_conditions));
    if (condition == FaceCondition::frictional) {
      parse_friction(m, contact.friction, contact.restitution);
    } else {
      for (const char* k : {"friction", "restitution"})
        if (m.has(k)) m.fail(k, "is only used with condition: frictional");
    }
    m.finish();
    return;
  }
  const std::string v = f.choice(key, face_conditions, "slip");
  if (v == "frictional")
    f.fail_value(key, v,
                 "needs its friction coefficient: write " + key + ": {condition: frictional, friction: MU}");
  condition = face_condition(v);
}

// ------------------------------------------------------------ obstacles

// Where the box [lo, up], translated by velocity * t for t in [0, end],
// misses the grid box on some axis ("" if it touches it at some time).
std::string outside_grid(const CaseConfig& c, const std::vector<double>& lo, const std::vector<double>& up,
                         const std::vector<double>& velocity) {
  for (int a = 0; a < c.dim; ++a) {
    const double d = velocity[a] * c.time.end;
    if (up[a] + std::max(0.0, d) < c.grid.lower[a]) return std::string("below grid.lower on the ") + axis_names[a] + " axis";
    if (lo[a] + std::min(0.0, d) > c.grid.upper[a]) return std::string("above grid.upper on the ") + axis_names[a] + " axis";
  }
  return "";
}

ObstacleConfig parse_obstacle(YamlSection& o, const CaseConfig& c) {
  ObstacleConfig ob;
  ob.name = o.text("name");
  const bool plain = !ob.name.empty() && std::all_of(ob.name.begin(), ob.name.end(), [](char ch) {
    return std::isalnum(static_cast<unsigned char>(ch)) || ch == '_' || ch == '-' || ch == '.';
  });
  if (!plain)
    o.fail_value("name", ob.name, "must be a non-empty name of letters, digits, '_', '-' and '.' (it names the obstacle in the output)");
  for (const char* face : face_names)
    if (ob.name == face)
      o.fail_value("name", ob.name, "is the name of a face of the grid box (x_min ... z_max); choose another");
  for (const auto& other : c.obstacles)
    if (other.name == ob.name) o.fail_value("name", ob.name, "is used by two obstacles");

  const std::string type = required_choice(o, "type", {"half_plane", "box", "terrain"});
  // Another type's geometry key is a mistake worth naming as such.
  static const std::vector<std::pair<std::string, std::string>> geometry = {
      {"point", "half_plane"}, {"normal", "half_plane"}, {"lower", "box"}, {"upper", "box"}, {"file", "terrain"}};
  for (const auto& [key, owner] : geometry)
    if (owner != type && o.has(key)) o.fail(key, "is a key of " + owner + " obstacles, not of " + type + " ones");

  parse_friction(o, ob.friction, ob.restitution);
  ob.velocity = o.has("velocity") ? o.reals("velocity", c.dim) : std::vector<double>(c.dim, 0.0);
  const bool moving = std::any_of(ob.velocity.begin(), ob.velocity.end(), [](double v) { return v != 0.0; });
  const std::string during = moving ? ", for the whole run" : "";

  if (type == "half_plane") {
    ob.shape = ObstacleShape::half_plane;
    ob.point = o.reals("point", c.dim);
    ob.normal = o.reals("normal", c.dim);
    double norm = 0.0;
    for (double v : ob.normal) norm += v * v;
    norm = std::sqrt(norm);
    if (!(norm > 0) || !std::isfinite(norm))
      o.fail_value("normal", list_text(ob.normal), "must not be zero (it points out of the solid, into the free side)");
    for (double& v : ob.normal) v /= norm;
    // Signed distances of the grid corners at t = 0 and their drift until time.end.
    double lowest = std::numeric_limits<double>::infinity(), highest = -lowest, drift = 0.0;
    for (int corner = 0; corner < (1 << c.dim); ++corner) {
      double g = 0.0;
      for (int a = 0; a < c.dim; ++a)
        g += ((corner >> a & 1 ? c.grid.upper[a] : c.grid.lower[a]) - ob.point[a]) * ob.normal[a];
      lowest = std::min(lowest, g);
      highest = std::max(highest, g);
    }
    for (int a = 0; a < c.dim; ++a) drift += ob.velocity[a] * ob.normal[a] * c.time.end;
    if (highest <= 0)
      o.fail("point", "the whole grid box lies inside the obstacle (on the solid side of the plane; the normal "
                      "points out of the solid)");
    if (lowest > 0 && lowest - drift > 0)
      o.fail("point", "the half-plane lies outside the grid box (every grid corner is on its free side" + during + ")");
  } else if (type == "box") {
    ob.shape = ObstacleShape::box;
    ob.lower = o.reals("lower", c.dim);
    ob.upper = o.reals("upper", c.dim);
    bool covers = true;
    for (int a = 0; a < c.dim; ++a) {
      if (!(ob.upper[a] > ob.lower[a])) o.fail("upper", "must be above lower on every axis");
      covers = covers && ob.lower[a] <= c.grid.lower[a] && ob.upper[a] >= c.grid.upper[a];
    }
    for (int a = 0; a < c.dim; ++a) {
      // A grid point inside a box takes the normal of its nearest face; in a
      // box thinner than two cells that can be the far face, which then lets
      // material through (measured: a 1-cell wall in landslide_3d_terrain
      // let 24 of 588 particles pass at its foot and took a quarter of the
      // 2-cell wall's peak force; docs/contact.md#limits).
      if (ob.upper[a] - ob.lower[a] < 2.0 * c.grid.cell_size * (1.0 - 1e-9)) {
        std::ostringstream m;
        m << std::setprecision(4) << "gives a box " << ob.upper[a] - ob.lower[a] << " m thick along " << "xyz"[a]
          << ", less than two cells (2 x grid.cell_size = " << number_text(2.0 * c.grid.cell_size)
          << " m): grid points inside a thinner box can take its far face's normal and let material through; "
             "make it at least two cells thick";
        o.fail_value("upper", m.str());
      }
    }
    if (covers) o.fail("lower", "the whole grid box lies inside the obstacle");
    const std::string problem = outside_grid(c, ob.lower, ob.upper, ob.velocity);
    if (!problem.empty())
      o.fail(problem[0] == 'b' ? "upper" : "lower", "the box lies outside the grid box (" + problem + during + ")");
  } else {
    ob.shape = ObstacleShape::terrain;
    ob.file = o.text("file");
    std::ifstream in = open_case_file(o, "file", ob.file, "terrain file", c.source_file);
    std::vector<double> lo(c.dim), up(c.dim);
    try {
      if (c.dim == 2) {
        ob.polyline = read_polyline(in);
        lo = {ob.polyline.front()[0], ob.polyline.front()[1]};
        up = {ob.polyline.back()[0], ob.polyline.front()[1]};
        for (const auto& v : ob.polyline) lo[1] = std::min(lo[1], v[1]), up[1] = std::max(up[1], v[1]);
      } else {
        read_height_map(in, ob);
        lo = {ob.map_origin[0], ob.map_origin[1], ob.heights[0]};
        up = {ob.map_origin[0] + (ob.map_nx - 1) * ob.map_spacing, ob.map_origin[1] + (ob.map_ny - 1) * ob.map_spacing,
              ob.heights[0]};
        for (double z : ob.heights) lo[2] = std::min(lo[2], z), up[2] = std::max(up[2], z);
      }
    } catch (const TerrainError& e) {
      o.fail_value("file", ob.file, ob.file + (e.line > 0 ? ":" + std::to_string(e.line) : "") + ": " + e.message);
    }
    const std::string problem = outside_grid(c, lo, up, ob.velocity);
    if (!problem.empty())
      o.fail_value("file", ob.file, "the terrain lies outside the grid box (" + problem + during + ")");
  }
  o.finish();
  return ob;
}

// Why the run could not write into `directory` ("" if it can): checked
// before anything runs, without creating anything (talus check has no side
// effects); the run creates the directory later.
std::string directory_problem(const std::string& directory) {
  if (directory.empty()) return "is empty";
  if (directory.size() > 4000) return "is longer than 4000 characters";
  namespace fs = std::filesystem;
  const fs::path path(directory);
  for (const auto& part : path)
    if (part.string().size() > 255) return "has a name longer than 255 characters";
  std::error_code ec;
  fs::path existing = path;
  while (!existing.empty() && !fs::exists(existing, ec)) existing = existing.parent_path();
  if (existing.empty()) existing = ".";
  if (!fs::is_directory(existing, ec))
    return existing == path ? "is not a directory" : "cannot be created: " + existing.string() + " is not a directory";
  if (access(existing.c_str(), W_OK | X_OK) != 0)
    return (existing == path ? std::string("is not writable: ") : "cannot be created in " + existing.string() + ": ") +
           std::strerror(errno);
  return "";
}

CaseConfig parse_root(YamlSection& root, const YAML::Node& doc) {
  CaseConfig c;
  c.source_file = root.file();

  {
    YamlSection g = root.section("grid");
    c.grid.lower = g.reals("lower");
    c.dim = static_cast<int>(c.grid.lower.size());
    if (c.dim != 2 && c.dim != 3)
      g.fail("lower", "must have 2 entries (2D plane strain) or 3 entries (3D)");
    c.grid.upper = g.reals("upper", c.dim);
    for (int a = 0; a < c.dim; ++a)
      if (!(c.grid.upper[a] > c.grid.lower[a])) g.fail("upper", "must be above lower on every axis");
    c.grid.cell_size = g.real("cell_size");
    // Cells from a micrometre to a thousand kilometres: beyond, particle
    // volumes and masses under- or overflow.
    if (!(c.grid.cell_size >= 1e-6 && c.grid.cell_size <= 1e6))
      g.fail_value("cell_size", "must be in [1e-6, 1e6] m");
    for (int a = 0; a < c.dim; ++a) {
      const double n = (c.grid.upper[a] - c.grid.lower[a]) / c.grid.cell_size;
      if (std::abs(n - std::round(n)) > 1e-9 * n || std::round(n) < 3)
        g.fail("cell_size", "the box length on axis " + std::to_string(a) +
                                " must be a whole number (at least 3) of cells; it is " + std::to_string(n));
    }
    c.grid.shape = g.choice("shape_function", {"quadratic_bspline", "linear"}, "quadratic_bspline") == "linear"
                       ? ShapeKind::linear
                       : ShapeKind::quadratic_bspline;
    c.grid.quadrature = g.choice("quadrature", {"point", "domain"}, "point") == "domain" ? ParticleQuadrature::domain
                                                                                      : ParticleQuadrature::point;
    // PETSc indexes its vectors with PetscInt: the grid's (m, m v) vector,
    // dim + 1 values per point, must have fewer than 2^31 entries with the
    // Debian PETSc's 32-bit indices.
    const double entries = grid_points(c) * (c.dim + 1);
    if (entries > static_cast<double>(std::numeric_limits<PetscInt>::max()))
      g.fail_value("cell_size", "gives " + number_text(grid_points(c)) + " grid points, more than PETSc's " +
                                    std::to_string(8 * sizeof(PetscInt)) + "-bit indices can number (" +
                                    number_text(std::floor(std::numeric_limits<PetscInt>::max() / (c.dim + 1.0))) +
                                    " in " + std::to_string(c.dim) + "D)");
    c.grid.memory_limit_gb = g.real("memory_limit_gb", physical_memory_gb());
    if (!(c.grid.memory_limit_gb > 0)) g.fail_value("memory_limit_gb", "must be > 0");
    g.finish();
  }
  {
    YamlSection t = root.section("time");
    c.time.end = t.positive("end", t.real("end"));
    c.time.integrator =
        t.choice("integrator", {"implicit", "explicit"}, "implicit") == "explicit" ? Integrator::explicit_euler
                                                                                     : Integrator::implicit;
    const bool explicit_steps = c.time.integrator == Integrator::explicit_euler;
    if (t.has("cfl") && !explicit_steps) t.fail_value("cfl", "is a key of `integrator: explicit` only");
    if (t.has("theta") && explicit_steps) t.fail_value("theta", "is a key of the implicit integrator only");
    c.time.cfl = t.real("cfl", c.time.cfl);
    if (!(c.time.cfl > 0.0 && c.time.cfl <= 1.0)) t.fail_value("cfl", "must be in (0, 1]");
    // The explicit step may be left out (or `auto`): it is then chosen from
    // the CFL condition once the materials are known (explicit_step below).
    // An implicit `step: auto` is chosen once the bodies and obstacles are
    // known (auto_step below).
    const bool auto_step = t.has("step") && t.written("step") == "auto";
    if (auto_step) t.text("step");
    if (t.has("step") && !auto_step) {
      const std::string written = t.written("step");
      char* end = nullptr;
      std::strtod(written.c_str(), &end);
      if (written.empty() || *end != '\0') t.fail_value("step", "must be a number of seconds, or auto");
    }
    c.time.auto_step = auto_step && !explicit_steps;
    for (const char* key : {"gravity_number", "courant"})
      if (t.has(key) && !c.time.auto_step) t.fail_value(key, "is a key of the implicit `step: auto` only");
    c.time.gravity_number = t.real("gravity_number", c.time.gravity_number);
    if (!(c.time.gravity_number > 0.0 && c.time.gravity_number <= 1.0))
      t.fail_value("gravity_number", "must be in (0, 1]");
    c.time.courant = t.real("courant", c.time.courant);
    if (!(c.time.courant > 0.0 && c.time.courant <= 1.0)) t.fail_value("courant", "must be in (0, 1]");
    c.time.step = auto_step || (explicit_steps && !t.has("step")) ? 0.0 : t.positive("step", t.real("step"));
    c.time.strain_increment = t.choice("strain_increment", {"linear", "logarithmic"}, "linear") == "logarithmic"
                                  ? StrainIncrement::logarithmic
                                  : StrainIncrement::linear;
    c.time.theta = t.real("theta", 1.0);
    if (!(c.time.theta >= 0.5 && c.time.theta <= 1.0))
      t.fail_value("theta", "must be in [0.5, 1]");
    c.time.min_step_ratio = t.real("min_step_ratio", 1e-3);
    // Above 1e-6 the smallest step is still far above the round-off of the
    // time (end / step is bounded below), so t + h > t always.
    if (!(c.time.min_step_ratio >= 1e-6 && c.time.min_step_ratio <= 1))
      t.fail_value("min_step_ratio", "must be in [1e-6, 1]");
    c.time.max_steps = t.integer("max_steps", TimeConfig::default_max_steps);
    if (c.time.max_steps < 1 || c.time.max_steps > 1000000000L)
      t.fail_value("max_steps", "must be in [1, 1e9]");
    if (c.time.step > 0) check_step_count(t, c.time);
    t.finish();
  }
  if (root.has("output")) {
    YamlSection o = root.section("output");
    c.output.directory = o.text("directory", "output");
    c.output.directory_key = o.where("directory");
    c.output.interval = o.real("interval", 0.0);
    if (!(c.output.interval >= 0)) o.fail_value("interval", "must be >= 0");
    c.output.max_outputs = o.integer("max_outputs", OutputConfig::default_max_outputs);
    if (c.output.max_outputs < 1 || c.output.max_outputs > 100000000L)
      o.fail_value("max_outputs", "must be in [1, 1e8]");
    if (c.output.interval > 0 && !(c.time.end / c.output.interval <= static_cast<double>(c.output.max_outputs))) {
      std::ostringstream m;
      m << "gives time.end / interval = " << c.time.end / c.output.interval << " outputs, more than output.max_outputs = "
        << c.output.max_outputs << "; raise output.max_outputs to write that many";
      o.fail_value("interval", m.str());
    }
    c.output.enabled = o.boolean("enabled", true);
    c.output.grid = o.boolean("grid", false);
    c.output.force_window = o.real("force_window", 0.05);
    if (!(c.output.force_window >= 0))
      o.fail_value("force_window", "must be >= 0 (s; 0: no averaging, the window force is the step's force)");
    if (c.output.enabled) {
      const std::string problem = directory_problem(c.output.directory);
      if (!problem.empty()) o.fail_value("directory", c.output.directory, problem);
    }
    o.finish();
  } else {
    const std::string problem = directory_problem(c.output.directory);
    if (!problem.empty())
      throw InputError(c.source_file + ": output.directory = output (the default, no output section): " + problem);
    c.output.directory_key = c.source_file + ": output.directory (the default, no output section)";
  }
  c.checkpoint.directory = c.output.directory;
  c.checkpoint.directory_key = c.output.directory_key;
  c.checkpoint.enabled = c.output.enabled;
  if (root.has("checkpoint")) {
    YamlSection k = root.section("checkpoint");
    c.checkpoint.enabled = k.boolean("enabled", c.output.enabled);
    c.checkpoint.interval = k.integer("interval", 0);
    if (c.checkpoint.interval < 0)
      k.fail_value("interval", "must be >= 0 (steps; 0: only at the end)");
    c.checkpoint.directory = k.text("directory", c.output.directory);
    if (k.has("directory")) c.checkpoint.directory_key = k.where("directory");
    if (c.checkpoint.enabled && k.has("directory")) {
      const std::string problem = directory_problem(c.checkpoint.directory);
      if (!problem.empty()) k.fail_value("directory", c.checkpoint.directory, problem);
    }
    k.finish();
  }
  c.gravity = root.has("gravity") ? root.reals("gravity", c.dim) : std::vector<double>(c.dim, 0.0);

  for (YamlSection& m : root.list("materials")) {
    MaterialConfig mc;
    mc.name = m.text("name");
    for (const auto& other : c.materials)
      if (other.name == mc.name) m.fail_value("name", mc.name, "is used by two materials");
    const std::string model = m.text("model");
    mc.law = make_material(model, m);
    m.finish();
    c.materials.push_back(std::move(mc));
  }

  if (c.time.integrator == Integrator::explicit_euler) {
    // The explicit step: at most the stability limit of the shape functions
    // for the fastest P-wave of the case (docs/explicit.md#the-step).
    YamlSection t = root.section("time");
    double speed = 0.0;
    for (const MaterialConfig& m : c.materials)
      speed = std::max(speed, p_wave_speed(*m.law));
    const double limit = explicit_stable_step(c.grid.shape, c.grid.cell_size, speed, c.dim);
    if (c.time.step == 0.0) {
      c.time.step = c.time.cfl * limit;
      check_step_count(t, c.time);
    } else if (c.time.step > limit) {
      std::ostringstream m;
      m << std::setprecision(3) << "is above the explicit stability limit " << limit << " s (cell "
        << c.grid.cell_size << " m, P-wave speed " << speed
        << " m/s); use a smaller step, or leave time.step out to get time.cfl x the limit";
      t.fail_value("step", m.str());
    }
  }

  std::vector<YamlSection> body_sections = root.list("bodies");
  for (YamlSection& b : body_sections) {
    c.bodies.push_back(parse_body(b, c));
    // The output names bodies by index (body_id), but messages and users by name.
    for (std::size_t k = 0; k + 1 < c.bodies.size(); ++k)
      if (c.bodies[k].name == c.bodies.back().name) b.fail_value("name", c.bodies.back().name, "is used by two bodies");
  }

  if (root.has("boundaries")) {
    YamlSection f = root.section("boundaries");
    const YAML::Node raw = doc["boundaries"];
    for (int i = 0; i < 2 * c.dim; ++i) parse_face(f, raw, face_names[i], c.faces[i], c.face_contact[i]);
    f.finish();
  }

  if (root.has("obstacles"))
    for (YamlSection& o : root.list("obstacles")) c.obstacles.push_back(parse_obstacle(o, c));
  check_bodies_against_obstacles(body_sections, c);
  if (c.time.auto_step) {
    YamlSection t = root.section("time");
    c.time.step = first_auto_step(c);
    if (!std::isfinite(c.time.step))
      t.fail_value("step", "auto needs a time scale: gravity, a body's velocity or a moving obstacle; give "
                           "time.step in seconds");
    check_step_count(t, c.time);
  }

  if (root.has("contact")) {
    YamlSection k = root.section("contact");
    c.contact.gap_prediction = k.real("gap_prediction", 0.5);
    if (!(c.contact.gap_prediction >= 0 && c.contact.gap_prediction <= 1))
      k.fail_value("gap_prediction", "must be in [0, 1]");
    if (k.has("bodies")) parse_body_pairs(k, c);
    k.finish();
  }
  check_rigid_fields(body_sections, c);

  if (root.has("equilibrium")) {
    YamlSection e = root.section("equilibrium");
    parse_equilibrium(e, c);
  }

  if (root.has("transfer")) {
    YamlSection t = root.section("transfer");
    parse_transfer(t, c);
  }

  // The ghost penalty is defined for quadratic B-splines only
  // (docs/solver.md#ghost-penalty).
  if (c.grid.shape == ShapeKind::linear) c.solver.ghost_penalty = 0.0;
  // Domain quadrature gives a function the body barely enters (by delta) a
  // mass of order delta^3 per axis instead of delta^2: points of 1e-12 of a
  // particle's mass then make singular pivots (docs/grid.md#particle-quadrature).
  if (c.grid.quadrature == ParticleQuadrature::domain) c.solver.active_mass_ratio = 1e-9;
  if (root.has("solver")) {
    YamlSection s = root.section("solver");
    parse_solver(s, c);
  }
  if (root.has("parallel")) {
    YamlSection q = root.section("parallel");
    parse_parallel(q, c);
  }
  // The memory a run needs, estimated before anything is allocated: a case
  // that cannot fit stops here instead of growing past the machine's memory.
  check_case_memory(root, c);
  root.finish();
  c.fingerprint = case_fingerprint(doc, c);
  return c;
}

}  // namespace

// What yaml-cpp accepts but a case file must not hold: merge keys `<<`
// (yaml-cpp keeps them as an ordinary key named "<<", so the merged keys
// would silently be missing) and NUL characters (which end the text in every
// message and file name).
void check_yaml_node(const YAML::Node& node, const std::string& name) {
  const auto at = [&](const YAML::Node& n) { return name + ":" + std::to_string(n.Mark().line + 1) + ": "; };
  if (node.IsScalar() && node.Scalar().find('\0') != std::string::npos)
    throw InputError(at(node) + "a value holds a NUL character");
  if (node.IsSequence())
    for (const auto& item : node) check_yaml_node(item, name);
  if (node.IsMap())
    for (auto it = node.begin(); it != node.end(); ++it) {
      if (it->first.IsScalar() && it->first.Scalar() == "<<")
        throw InputError(at(it->first) + "YAML merge keys (<<) are not supported: write the keys out");
      if (it->first.IsScalar() && it->first.Scalar().find('\0') != std::string::npos)
        throw InputError(at(it->first) + "a key holds a NUL character");
      check_yaml_node(it->second, name);
    }
}

CaseConfig parse_case(const std::string& raw_text, const std::string& name) {
  // Old Mac line ends (CR alone) would make the whole file one line, which
  // the first comment swallows: read them as line ends.
  std::string yaml_text;
  yaml_text.reserve(raw_text.size());
  for (std::size_t i = 0; i < raw_text.size(); ++i) {
    if (raw_text[i] == '\r') {
      yaml_text += '\n';
      if (i + 1 < raw_text.size() && raw_text[i + 1] == '\n') ++i;
    } else {
      yaml_text += raw_text[i];
    }
  }
  YAML::Node doc;
  try {
    const std::vector<YAML::Node> documents = YAML::LoadAll(yaml_text);
    if (documents.size() > 1)
      throw InputError(name + ": holds " + std::to_string(documents.size()) +
                       " YAML documents (separated by ---); a case file is one");
    doc = YAML::Load(yaml_text);
  } catch (const YAML::ParserException& e) {
    if (e.mark.is_null()) throw InputError(name + ": YAML syntax error: " + e.msg);
    // yaml-cpp's messages for a tab in the indentation do not say so.
    std::string hint;
    std::istringstream lines(yaml_text);
    std::string line;
    for (int i = 0; i <= e.mark.line && std::getline(lines, line); ++i) {
    }
    const std::size_t indent_end = line.find_first_not_of(" \t");
    if (line.substr(0, indent_end).find('\t') != std::string::npos)
      hint = " (a tab character in the indentation: YAML indents with spaces only)";
    throw InputError(name + ":" + std::to_string(e.mark.line + 1) + ": YAML syntax error: " + e.msg + hint);
  }
  if (!doc.IsMap()) {
    const std::string what = doc.IsNull() ? "it is empty" : doc.IsSequence() ? "it is a list" : "it is a single value";
    throw InputError(name + ": the case file must be a YAML map (grid, time, materials, bodies, ...); " + what);
  }
  check_yaml_node(doc, name);
  YamlSection root(doc, "", name);
  return parse_root(root, doc);
}

CaseConfig load_case(const std::string& file) {
  std::error_code ec;
  if (std::filesystem::is_directory(file, ec)) throw InputError(file + ": is a directory, not a case file");
  // /dev/zero or a FIFO would be read without end.
  if (std::filesystem::exists(file, ec) && !std::filesystem::is_regular_file(file, ec))
    throw InputError(file + ": is not a regular file, not a case file");
  if (std::filesystem::exists(file, ec) && std::filesystem::file_size(file, ec) > max_case_file_bytes)
    throw InputError(file + ": is larger than 64 MiB, not a case file");
  std::ifstream in(file);
  if (!in) throw InputError(file + ": cannot open the case file");
  std::stringstream buffer;
  buffer << in.rdbuf();
  if (in.bad()) throw InputError(file + ": cannot read the case file");
  return parse_case(buffer.str(), file);
}

}  // namespace talus
