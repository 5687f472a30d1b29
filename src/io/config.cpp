#include "talus/io/config.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <system_error>

#include "talus/io/terrain_file.hpp"
#include "talus/io/yaml_section.hpp"

namespace talus {

// ---------------------------------------------------------------- case file

namespace {

const std::vector<std::string> face_conditions = {"free", "slip", "fixed", "frictional"};
const char* const face_names[6] = {"x_min", "x_max", "y_min", "y_max", "z_min", "z_max"};
const char* const axis_names[3] = {"x", "y", "z"};

std::string list_text(const std::vector<double>& v) {
  std::string s = "[";
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + number_text(v[i]);
  return s + "]";
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
    if (covers) o.fail("lower", "the whole grid box lies inside the obstacle");
    const std::string problem = outside_grid(c, ob.lower, ob.upper, ob.velocity);
    if (!problem.empty())
      o.fail(problem[0] == 'b' ? "upper" : "lower", "the box lies outside the grid box (" + problem + during + ")");
  } else {
    ob.shape = ObstacleShape::terrain;
    ob.file = o.text("file");
    // Relative to the case file's directory (so a case and its terrain move together).
    std::filesystem::path path(ob.file);
    if (path.is_relative()) path = std::filesystem::path(c.source_file).parent_path() / path;
    std::error_code ec;
    if (std::filesystem::is_directory(path, ec))
      o.fail_value("file", ob.file, "is a directory, not a terrain file (" + path.string() + ")");
    std::ifstream in(path);
    if (!in)
      o.fail_value("file", ob.file,
                   "cannot open the terrain file " + path.string() + " (relative paths start at the case file's directory)");
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

// Whether the seeding lattice (src/particles/seeding.cpp: points at
// grid.lower + (s + 1/2) * cell_size / particles_per_cell, box edges included
// to 1e-9, polygons by the crossing-number test) puts a particle in the body.
bool body_has_particle(const CaseConfig& c, const BodyConfig& body) {
  const double spacing = c.grid.cell_size / body.particles_per_cell;
  std::vector<long> first(c.dim), last(c.dim);
  for (int a = 0; a < c.dim; ++a) {
    first[a] = static_cast<long>(std::ceil((body.box_lower[a] - c.grid.lower[a]) / spacing - 0.5 - 1e-9));
    last[a] = static_cast<long>(std::floor((body.box_upper[a] - c.grid.lower[a]) / spacing - 0.5 + 1e-9));
    if (last[a] < first[a]) return false;
  }
  if (body.polygon.empty()) return true;
  // The polygon lies in the (x, last axis) plane; in 3D it is extruded along y.
  const auto& poly = body.polygon;
  const int v = c.dim - 1;
  for (long i = first[0]; i <= last[0]; ++i)
    for (long j = first[v]; j <= last[v]; ++j) {
      const double x = c.grid.lower[0] + (i + 0.5) * spacing, y = c.grid.lower[v] + (j + 0.5) * spacing;
      bool inside = false;
      for (std::size_t k = 0, l = poly.size() - 1; k < poly.size(); l = k++)
        if ((poly[k][1] > y) != (poly[l][1] > y) &&
            x < poly[k][0] + (y - poly[k][1]) * (poly[l][0] - poly[k][0]) / (poly[l][1] - poly[k][1]))
          inside = !inside;
      if (inside) return true;
    }
  return false;
}

// "" if some lattice point of the body (as in body_has_particle) lies outside
// every obstacle at t = 0; otherwise the obstacles that bury it, for a message.
template <int dim>
std::string body_buried_by(const CaseConfig& c, const BodyConfig& body) {
  std::vector<Obstacle<dim>> obstacles;
  for (const ObstacleConfig& o : c.obstacles) obstacles.emplace_back(o);
  const double spacing = c.grid.cell_size / body.particles_per_cell;
  std::array<long, dim> first{}, last{}, s{};
  for (int a = 0; a < dim; ++a) {
    first[a] = static_cast<long>(std::ceil((body.box_lower[a] - c.grid.lower[a]) / spacing - 0.5 - 1e-9));
    last[a] = static_cast<long>(std::floor((body.box_upper[a] - c.grid.lower[a]) / spacing - 0.5 + 1e-9));
    if (last[a] < first[a]) return "";  // no lattice point at all: reported before
  }
  std::vector<bool> burying(obstacles.size(), false);
  for (s = first;;) {
    Vector<dim> x;
    for (int a = 0; a < dim; ++a) x[a] = c.grid.lower[a] + (s[a] + 0.5) * spacing;
    bool inside_body = true;
    if (!body.polygon.empty()) {
      inside_body = false;
      const auto& poly = body.polygon;
      for (std::size_t k = 0, l = poly.size() - 1; k < poly.size(); l = k++)
        if ((poly[k][1] > x[dim - 1]) != (poly[l][1] > x[dim - 1]) &&
            x[0] < poly[k][0] + (x[dim - 1] - poly[k][1]) * (poly[l][0] - poly[k][0]) / (poly[l][1] - poly[k][1]))
          inside_body = !inside_body;
    }
    if (inside_body) {
      bool buried = false;
      for (std::size_t o = 0; o < obstacles.size(); ++o)
        if (obstacles[o].gap(x, 0.0).gap < 0.0) buried = true, burying[o] = true;
      if (!buried) return "";
    }
    int a = 0;
    while (a < dim && s[a] == last[a]) s[a] = first[a], ++a;
    if (a == dim) break;
    ++s[a];
  }
  std::string names;
  for (std::size_t o = 0; o < obstacles.size(); ++o)
    if (burying[o]) names += (names.empty() ? "obstacle '" : ", '") + obstacles[o].name() + "'";
  return names;
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
    c.grid.cell_size = g.positive("cell_size", g.real("cell_size"));
    for (int a = 0; a < c.dim; ++a) {
      const double n = (c.grid.upper[a] - c.grid.lower[a]) / c.grid.cell_size;
      if (std::abs(n - std::round(n)) > 1e-9 * n || std::round(n) < 3)
        g.fail("cell_size", "the box length on axis " + std::to_string(a) +
                                " must be a whole number (at least 3) of cells; it is " + std::to_string(n));
    }
    c.grid.shape = g.choice("shape_function", {"quadratic_bspline", "linear"}, "quadratic_bspline") == "linear"
                       ? ShapeKind::linear
                       : ShapeKind::quadratic_bspline;
    g.finish();
  }
  {
    YamlSection t = root.section("time");
    c.time.end = t.positive("end", t.real("end"));
    c.time.step = t.positive("step", t.real("step"));
    c.time.theta = t.real("theta", 1.0);
    if (!(c.time.theta >= 0.5 && c.time.theta <= 1.0))
      t.fail_value("theta", "must be in [0.5, 1]");
    c.time.min_step_ratio = t.real("min_step_ratio", 1e-3);
    if (!(c.time.min_step_ratio > 0 && c.time.min_step_ratio <= 1))
      t.fail_value("min_step_ratio", "must be in (0, 1]");
    t.finish();
  }
  if (root.has("output")) {
    YamlSection o = root.section("output");
    c.output.directory = o.text("directory", "output");
    c.output.interval = o.real("interval", 0.0);
    if (c.output.interval < 0) o.fail_value("interval", "must be >= 0");
    c.output.enabled = o.boolean("enabled", true);
    c.output.grid = o.boolean("grid", false);
    o.finish();
  }
  c.checkpoint.directory = c.output.directory;
  c.checkpoint.enabled = c.output.enabled;
  if (root.has("checkpoint")) {
    YamlSection k = root.section("checkpoint");
    c.checkpoint.enabled = k.boolean("enabled", c.output.enabled);
    c.checkpoint.interval = k.integer("interval", 0);
    if (c.checkpoint.interval < 0)
      k.fail_value("interval", "must be >= 0 (steps; 0: only at the end)");
    c.checkpoint.directory = k.text("directory", c.output.directory);
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

  std::vector<YamlSection> body_sections = root.list("bodies");
  for (YamlSection& b : body_sections) {
    BodyConfig bc;
    bc.name = b.text("name");
    const std::string material = b.text("material");
    const auto it = std::find_if(c.materials.begin(), c.materials.end(),
                                 [&](const MaterialConfig& m) { return m.name == material; });
    if (it == c.materials.end()) b.fail_value("material", material, "names no material in 'materials'");
    bc.material = static_cast<int>(it - c.materials.begin());
    if (b.has("box") == b.has("polygon"))
      b.fail("box", b.has("box") ? "give either box or polygon, not both" : "is required (or polygon)");
    if (b.has("box")) {
      YamlSection box = b.section("box");
      bc.box_lower = box.reals("lower", c.dim);
      bc.box_upper = box.reals("upper", c.dim);
      for (int a = 0; a < c.dim; ++a) {
        if (!(bc.box_upper[a] > bc.box_lower[a])) box.fail("upper", "must be above lower on every axis");
        if (bc.box_lower[a] < c.grid.lower[a]) box.fail("lower", "lies outside the grid box (below grid.lower)");
        if (bc.box_upper[a] > c.grid.upper[a]) box.fail("upper", "lies outside the grid box (above grid.upper)");
      }
      box.finish();
    } else {
      // 2D: vertices (x, y). 3D: a vertical section, vertices (x, z), extruded
      // along y over `extrusion: [y_from, y_to]` (a landslide cross-section
      // across the slope).
      const auto vertices = b.points("polygon", 2);
      if (vertices.size() < 3) b.fail("polygon", "needs at least 3 vertices");
      double area2 = 0.0;
      const int v = c.dim - 1;  // the grid axis of the vertices' second coordinate
      std::vector<double> lo = vertices[0], hi = vertices[0];
      for (std::size_t i = 0; i < vertices.size(); ++i) {
        const auto& p = vertices[i];
        const auto& q = vertices[(i + 1) % vertices.size()];
        area2 += p[0] * q[1] - q[0] * p[1];
        for (int a = 0; a < 2; ++a) {
          const int axis = a == 0 ? 0 : v;
          if (p[a] < c.grid.lower[axis] || p[a] > c.grid.upper[axis])
            b.fail("polygon", "vertex " + std::to_string(i) + " lies outside the grid box");
          lo[a] = std::min(lo[a], p[a]);
          hi[a] = std::max(hi[a], p[a]);
        }
        bc.polygon.push_back({p[0], p[1]});
      }
      bc.box_lower.assign(c.dim, 0.0);
      bc.box_upper.assign(c.dim, 0.0);
      bc.box_lower[0] = lo[0], bc.box_upper[0] = hi[0];
      bc.box_lower[v] = lo[1], bc.box_upper[v] = hi[1];
      if (c.dim == 3) {
        if (!b.has("extrusion")) b.fail("extrusion", "is required with a polygon in 3D: [y_from, y_to], the extent across the section");
        const auto e = b.reals("extrusion", 2);
        if (!(e[1] > e[0])) b.fail("extrusion", "must be [y_from, y_to] with y_to > y_from");
        if (e[0] < c.grid.lower[1] || e[1] > c.grid.upper[1]) b.fail("extrusion", "lies outside the grid box along y");
        bc.box_lower[1] = e[0], bc.box_upper[1] = e[1];
      } else if (b.has("extrusion")) {
        b.fail("extrusion", "is only used in 3D (a polygon extruded along y)");
      }
      // Edges that cross would make "inside" ambiguous.
      const std::size_t n = vertices.size();
      for (std::size_t i = 0; i < n; ++i)
        for (std::size_t j = i + 2; j < n; ++j) {
          if (i == 0 && j == n - 1) continue;  // adjacent through the closing edge
          const auto& a0 = bc.polygon[i];
          const auto& a1 = bc.polygon[(i + 1) % n];
          const auto& b0 = bc.polygon[j];
          const auto& b1 = bc.polygon[(j + 1) % n];
          const auto cross = [](const std::array<double, 2>& o, const std::array<double, 2>& p,
                                const std::array<double, 2>& q) {
            return (p[0] - o[0]) * (q[1] - o[1]) - (p[1] - o[1]) * (q[0] - o[0]);
          };
          if (cross(a0, a1, b0) * cross(a0, a1, b1) < 0 && cross(b0, b1, a0) * cross(b0, b1, a1) < 0)
            b.fail("polygon", "edges " + std::to_string(i) + " and " + std::to_string(j) +
                                  " cross (the polygon must be simple)");
        }
      if (std::abs(area2) <= 1e-12 * (hi[0] - lo[0]) * (hi[1] - lo[1]) || !(hi[0] > lo[0] && hi[1] > lo[1]))
        b.fail("polygon", "has zero area");
    }
    bc.particles_per_cell = b.integer("particles_per_cell", 2);
    if (bc.particles_per_cell < 1 || bc.particles_per_cell > 8)
      b.fail_value("particles_per_cell", "must be in 1..8 (per axis)");
    if (!body_has_particle(c, bc)) {
      b.fail(bc.polygon.empty() ? "box" : "polygon",
             "holds no particle (too thin for the particle spacing cell_size / particles_per_cell = " +
                 number_text(c.grid.cell_size / bc.particles_per_cell) + " m)");
    }
    bc.velocity = b.has("velocity") ? b.reals("velocity", c.dim) : std::vector<double>(c.dim, 0.0);
    bc.geostatic = b.choice("initial_stress", {"none", "geostatic"}, "none") == "geostatic";
    if (b.has("k0")) {
      if (!bc.geostatic) b.fail("k0", "is only used with initial_stress: geostatic");
      bc.k0 = b.real("k0");
      if (!(bc.k0 > 0.0 && bc.k0 <= 5.0)) b.fail_value("k0", "must be in (0, 5]");
    }
    if (bc.geostatic)
      for (int a = 0; a + 1 < c.dim; ++a)
        if (c.gravity[a] != 0.0 || !(c.gravity[c.dim - 1] < 0.0))
          b.fail_value("initial_stress", "geostatic", "needs gravity pointing down the last axis (gravity = [0, -g] or [0, 0, -g])");
    b.finish();
    c.bodies.push_back(std::move(bc));
  }

  if (root.has("boundaries")) {
    YamlSection f = root.section("boundaries");
    const YAML::Node raw = doc["boundaries"];
    for (int i = 0; i < 2 * c.dim; ++i) parse_face(f, raw, face_names[i], c.faces[i], c.face_contact[i]);
    f.finish();
  }

  if (root.has("obstacles"))
    for (YamlSection& o : root.list("obstacles")) c.obstacles.push_back(parse_obstacle(o, c));
  // Seeding leaves out the lattice points inside obstacles: a body buried
  // entirely would silently vanish.
  if (!c.obstacles.empty())
    for (std::size_t b = 0; b < c.bodies.size(); ++b) {
      const std::string buried_by =
          c.dim == 2 ? body_buried_by<2>(c, c.bodies[b]) : body_buried_by<3>(c, c.bodies[b]);
      if (!buried_by.empty())
        body_sections[b].fail(c.bodies[b].polygon.empty() ? "box" : "polygon",
                              "holds no particle outside the obstacles (its particles would all lie inside " +
                                  buried_by + ")");
    }

  if (root.has("contact")) {
    YamlSection k = root.section("contact");
    c.contact.gap_prediction = k.real("gap_prediction", 0.5);
    if (!(c.contact.gap_prediction >= 0 && c.contact.gap_prediction <= 1))
      k.fail_value("gap_prediction", "must be in [0, 1]");
    k.finish();
  }

  if (root.has("transfer")) {
    YamlSection t = root.section("transfer");
    c.transfer.scheme = t.choice("scheme", {"apic", "flip"}, "apic") == "apic" ? TransferScheme::apic
                                                                                  : TransferScheme::flip;
    c.transfer.flip_blend = t.real("flip_blend", 0.99);
    if (!(c.transfer.flip_blend >= 0 && c.transfer.flip_blend <= 1))
      t.fail_value("flip_blend", "must be in [0, 1]");
    t.finish();
  }

  if (root.has("solver")) {
    YamlSection s = root.section("solver");
    c.solver.active_mass_ratio = s.real("active_mass_ratio", 1e-12);
    if (!(c.solver.active_mass_ratio >= 0 && c.solver.active_mass_ratio < 1))
      s.fail_value("active_mass_ratio", "must be in [0, 1)");
    c.solver.direct_solver_limit = s.integer("direct_solver_limit", 5000);
    if (c.solver.direct_solver_limit < 0)
      s.fail_value("direct_solver_limit", "must be >= 0");
    for (auto& [k, v] : s.free_map("petsc_options")) {
      std::string key = k;
      if (!key.empty() && key[0] == '-') key.erase(0, 1);
      c.solver.petsc_options.emplace_back(key, v);
    }
    s.finish();
  }
  root.finish();
  return c;
}

}  // namespace

CaseConfig parse_case(const std::string& yaml_text, const std::string& name) {
  YAML::Node doc;
  try {
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
  YamlSection root(doc, "", name);
  return parse_root(root, doc);
}

CaseConfig load_case(const std::string& file) {
  std::error_code ec;
  if (std::filesystem::is_directory(file, ec)) throw InputError(file + ": is a directory, not a case file");
  std::ifstream in(file);
  if (!in) throw InputError(file + ": cannot open the case file");
  std::stringstream buffer;
  buffer << in.rdbuf();
  if (in.bad()) throw InputError(file + ": cannot read the case file");
  return parse_case(buffer.str(), file);
}

}  // namespace talus
