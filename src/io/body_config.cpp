#include "talus/io/body_config.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <system_error>
#include <utility>

#include "talus/io/particle_file.hpp"
#include "talus/io/stl_file.hpp"
#include "talus/particles/body_region.hpp"

namespace talus {

namespace {

// The key that defines a body's region, for messages.
const char* region_key(const BodyConfig& body) {
  switch (body.shape) {
    case BodyShape::box: return "box";
    case BodyShape::polygon: return "polygon";
    case BodyShape::polyhedron: return "polyhedron";
    case BodyShape::particle_file: return "particles";
  }
  return "box";
}

void parse_box(YamlSection& b, const CaseConfig& c, BodyConfig& bc) {
  YamlSection box = b.section("box");
  bc.box_lower = box.reals("lower", c.dim);
  bc.box_upper = box.reals("upper", c.dim);
  for (int a = 0; a < c.dim; ++a) {
    if (!(bc.box_upper[a] > bc.box_lower[a])) box.fail("upper", "must be above lower on every axis");
    if (bc.box_lower[a] < c.grid.lower[a]) box.fail("lower", "lies outside the grid box (below grid.lower)");
    if (bc.box_upper[a] > c.grid.upper[a]) box.fail("upper", "lies outside the grid box (above grid.upper)");
  }
  box.finish();
}

// 2D: vertices (x, y). 3D: a vertical section, vertices (x, z), extruded along
// y over `extrusion: [y_from, y_to]` (a landslide cross-section across the slope).
void parse_polygon(YamlSection& b, const CaseConfig& c, BodyConfig& bc) {
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

// A closed polyhedron: vertices and faces (each a list of vertex indices, all
// faces ordered the same way around their outward normals), or the triangles
// of an STL file (scaled, then translated). Each face is split into a fan of
// triangles from its first vertex; "inside" is the winding number, so faces
// need not be convex or exactly planar.
void parse_polyhedron(YamlSection& b, const CaseConfig& c, BodyConfig& bc) {
  YamlSection p = b.section("polyhedron");
  if (c.dim != 3) b.fail("polyhedron", "is only used in 3D (in 2D a body is a box or a polygon)");
  const bool from_file = p.has("file");
  std::vector<std::vector<double>> vertices;
  std::vector<std::vector<int>> faces;
  std::vector<int> facet;  // STL: each face's facet number in the file
  std::string file;
  if (from_file) {
    for (const char* key : {"vertices", "faces"})
      if (p.has(key)) p.fail(key, "give either file or vertices and faces, not both");
    file = p.text("file");
    std::ifstream in = open_case_file(p, "file", file, "STL file", c.source_file);
    TriangleMesh mesh;
    try {
      mesh = read_stl(in);
    } catch (const FileLineError& e) {
      p.fail_value("file", file, file + (e.line > 0 ? ":" + std::to_string(e.line) : "") + ": " + e.message);
    }
    const double scale = p.positive("scale", p.real("scale", 1.0));
    const std::vector<double> shift = p.has("translate") ? p.reals("translate", 3) : std::vector<double>(3, 0.0);
    for (const auto& v : mesh.vertices) vertices.push_back({scale * v[0] + shift[0], scale * v[1] + shift[1], scale * v[2] + shift[2]});
    for (const auto& t : mesh.triangles) faces.push_back({t[0], t[1], t[2]});
    facet = mesh.facet;
  } else {
    for (const char* key : {"scale", "translate"})
      if (p.has(key)) p.fail(key, "is only used with file (an STL file)");
    vertices = p.points("vertices", 3);
    faces = p.index_lists("faces");
  }
  // Messages name the YAML's vertex and face numbers, or an STL's coordinates and facets.
  const auto fail = [&](const char* key, const std::string& message) {
    if (from_file) p.fail_value("file", file, message);
    p.fail(key, message);
  };
  const auto vertex_name = [&](int i) {
    if (!from_file) return "vertex " + std::to_string(i);
    return "(" + number_text(vertices[i][0]) + ", " + number_text(vertices[i][1]) + ", " + number_text(vertices[i][2]) + ")";
  };
  const auto face_name = [&](std::size_t f) {
    return from_file ? "facet " + std::to_string(facet[f]) : "face " + std::to_string(f);
  };
  if (vertices.size() < 4) fail("vertices", "needs at least 4 vertices");
  bc.box_lower = vertices[0];
  bc.box_upper = vertices[0];
  for (std::size_t i = 0; i < vertices.size(); ++i) {
    for (int a = 0; a < 3; ++a) {
      if (vertices[i][a] < c.grid.lower[a] || vertices[i][a] > c.grid.upper[a])
        fail("vertices", vertex_name(static_cast<int>(i)) + " lies outside the grid box");
      bc.box_lower[a] = std::min(bc.box_lower[a], vertices[i][a]);
      bc.box_upper[a] = std::max(bc.box_upper[a], vertices[i][a]);
    }
    bc.polyhedron_vertices.push_back({vertices[i][0], vertices[i][1], vertices[i][2]});
  }
  if (faces.size() < 4) fail("faces", "needs at least 4 faces (a closed surface)");
  const int n = static_cast<int>(vertices.size());
  std::map<std::pair<int, int>, std::size_t> edge_face;  // directed edge -> its face
  for (std::size_t f = 0; f < faces.size(); ++f) {
    const auto& face = faces[f];
    if (face.size() < 3) fail("faces", face_name(f) + " has fewer than 3 vertices");
    for (std::size_t k = 0; k < face.size(); ++k) {
      if (face[k] < 0 || face[k] >= n)
        fail("faces", face_name(f) + " names vertex " + std::to_string(face[k]) + "; the vertices are 0.." +
                          std::to_string(n - 1));
      if (std::count(face.begin(), face.end(), face[k]) > 1)
        fail("faces", face_name(f) + " names vertex " + std::to_string(face[k]) + " twice");
    }
    for (std::size_t k = 0; k < face.size(); ++k) {
      const std::pair<int, int> edge{face[k], face[(k + 1) % face.size()]};
      const auto [at, fresh] = edge_face.emplace(edge, f);
      if (!fresh) {
        const std::string faces_named = from_file ? "facets " + std::to_string(facet[at->second]) + " and " + std::to_string(facet[f])
                                                  : "faces " + std::to_string(at->second) + " and " + std::to_string(f);
        fail("faces", faces_named + " both run from " + vertex_name(edge.first) + " to " +
                          (from_file ? vertex_name(edge.second) : std::to_string(edge.second)) +
                          " (order every face the same way around its outward normal)");
      }
    }
    for (std::size_t k = 1; k + 1 < face.size(); ++k) bc.polyhedron_triangles.push_back({face[0], face[k], face[k + 1]});
  }
  for (const auto& [edge, f] : edge_face)
    if (!edge_face.count({edge.second, edge.first}))
      fail("faces", "the edge from " + vertex_name(edge.first) + " to " +
                        (from_file ? vertex_name(edge.second) : std::to_string(edge.second)) + " of " + face_name(f) +
                        " belongs to no other face (the surface must be closed)");
  // Against the cube of the bounding box's diagonal: a flat box has no volume.
  const double diagonal = std::hypot(bc.box_upper[0] - bc.box_lower[0], bc.box_upper[1] - bc.box_lower[1],
                                     bc.box_upper[2] - bc.box_lower[2]);
  if (!(std::abs(enclosed_volume(bc.polyhedron_vertices, bc.polyhedron_triangles)) > 1e-12 * std::pow(diagonal, 3)))
    fail("faces", "enclose no volume");
  p.finish();
}

void parse_particle_file(YamlSection& b, const CaseConfig& c, BodyConfig& bc) {
  bc.particle_file = b.text("particles");
  std::ifstream in = open_case_file(b, "particles", bc.particle_file, "particle file", c.source_file);
  const auto fail_at = [&](int line, const std::string& message) {
    b.fail_value("particles", bc.particle_file,
                 bc.particle_file + (line > 0 ? ":" + std::to_string(line) : "") + ": " + message);
  };
  ParticleTable table;
  try {
    table = read_particle_table(in, c.dim);
  } catch (const FileLineError& e) {
    fail_at(e.line, e.message);
  }
  static const char* axis_name[3] = {"x", "y", "z"};
  bc.box_lower.assign(c.dim, 0.0);
  bc.box_upper.assign(c.dim, 0.0);
  for (std::size_t k = 0; k < table.volumes.size(); ++k)
    for (int a = 0; a < c.dim; ++a) {
      const double x = table.positions[c.dim * k + a];
      // Strictly inside: a particle on the boundary of the grid box has no owner.
      if (!(x > c.grid.lower[a] && x < c.grid.upper[a]))
        fail_at(table.lines[k], "the particle lies outside the grid box (" + std::string(axis_name[a]) + " = " +
                                    number_text(x) + " is not in (" + number_text(c.grid.lower[a]) + ", " +
                                    number_text(c.grid.upper[a]) + "))");
      bc.box_lower[a] = k == 0 ? x : std::min(bc.box_lower[a], x);
      bc.box_upper[a] = k == 0 ? x : std::max(bc.box_upper[a], x);
    }
  if (!table.velocities.empty() && b.has("velocity"))
    b.fail("velocity", "the particle file " + bc.particle_file + " has velocity columns: give the velocity in one place");
  for (const char* key : {"particles_per_cell", "polygon", "extrusion"})
    if (b.has(key)) b.fail(key, "is not used with a particle file (the file gives each particle's position and volume)");
  bc.file_positions = std::move(table.positions);
  bc.file_volumes = std::move(table.volumes);
  bc.file_velocities = std::move(table.velocities);
  bc.file_lines = std::move(table.lines);
}

// Whether the seeding lattice puts a particle in the body.
template <int dim>
bool body_has_particle(const CaseConfig& c, const BodyConfig& body) {
  const BodyLattice<dim> lattice(body, c.grid.lower, c.grid.cell_size);
  const std::vector<bool> seeded = seeded_lattice_points<dim>(body, lattice);
  return std::find(seeded.begin(), seeded.end(), true) != seeded.end();
}

// "" if some particle of the body lies outside every obstacle at t = 0;
// otherwise the obstacles that bury it, for a message.
template <int dim>
std::string body_buried_by(const CaseConfig& c, const BodyConfig& body, const std::vector<Obstacle<dim>>& obstacles) {
  const BodyLattice<dim> lattice(body, c.grid.lower, c.grid.cell_size);
  const std::vector<bool> seeded = seeded_lattice_points<dim>(body, lattice);
  std::vector<bool> burying(obstacles.size(), false);
  for (std::int64_t id = 0; id < lattice.size; ++id) {
    if (!seeded[id]) continue;
    const Vector<dim> x = lattice.point(id);
    bool buried = false;
    for (std::size_t o = 0; o < obstacles.size(); ++o)
      if (obstacles[o].gap(x, 0.0).gap < 0.0) buried = true, burying[o] = true;
    if (!buried) return "";
  }
  std::string names;
  for (std::size_t o = 0; o < obstacles.size(); ++o)
    if (burying[o]) names += (names.empty() ? "obstacle '" : ", '") + obstacles[o].name() + "'";
  return names;
}

template <int dim>
void check_against_obstacles(std::vector<YamlSection>& sections, const CaseConfig& c) {
  std::vector<Obstacle<dim>> obstacles;
  for (const ObstacleConfig& o : c.obstacles) obstacles.emplace_back(o);
  for (std::size_t b = 0; b < c.bodies.size(); ++b) {
    const BodyConfig& body = c.bodies[b];
    if (body.shape == BodyShape::particle_file) {
      // A particle placed by hand inside an obstacle is a mistake, not something to cut away.
      for (std::size_t k = 0; k < body.file_volumes.size(); ++k) {
        const Vector<dim> x = Eigen::Map<const Vector<dim>>(&body.file_positions[dim * k]);
        for (const Obstacle<dim>& o : obstacles)
          if (o.gap(x, 0.0).gap < 0.0)
            sections[b].fail_value("particles", body.particle_file,
                                   body.particle_file + ":" + std::to_string(body.file_lines[k]) +
                                       ": the particle lies inside obstacle '" + o.name() + "'");
      }
      continue;
    }
    const std::string buried_by = body_buried_by<dim>(c, body, obstacles);
    if (!buried_by.empty())
      sections[b].fail(region_key(body), "holds no particle outside the obstacles (its particles would all lie inside " +
                                             buried_by + ")");
  }
}

}  // namespace

BodyConfig parse_body(YamlSection& b, const CaseConfig& c) {
  BodyConfig bc;
  bc.name = b.text("name");
  const std::string material = b.text("material");
  const auto it = std::find_if(c.materials.begin(), c.materials.end(),
                               [&](const MaterialConfig& m) { return m.name == material; });
  if (it == c.materials.end()) b.fail_value("material", material, "names no material in 'materials'");
  bc.material = static_cast<int>(it - c.materials.begin());

  std::vector<const char*> given;
  for (const char* key : {"box", "polygon", "polyhedron", "particles"})
    if (b.has(key)) given.push_back(key);
  if (given.empty()) b.fail("box", "is required (or polygon, polyhedron, or particles: a particle file)");
  if (given.size() > 1)
    b.fail(given[1], std::string("give one of box, polygon, polyhedron and particles, not both ") + given[0] +
                         " and " + given[1]);
  const std::string shape = given[0];
  if (shape == "box") {
    bc.shape = BodyShape::box;
    parse_box(b, c, bc);
  } else if (shape == "polygon") {
    bc.shape = BodyShape::polygon;
    parse_polygon(b, c, bc);
  } else if (shape == "polyhedron") {
    bc.shape = BodyShape::polyhedron;
    parse_polyhedron(b, c, bc);
  } else {
    bc.shape = BodyShape::particle_file;
    parse_particle_file(b, c, bc);
  }
  if (bc.shape != BodyShape::particle_file) {
    if (b.has("extrusion") && bc.shape != BodyShape::polygon)
      b.fail("extrusion", "is only used with a polygon in 3D (a polygon extruded along y)");
    bc.particles_per_cell = b.integer("particles_per_cell", 2);
    if (bc.particles_per_cell < 1 || bc.particles_per_cell > 8)
      b.fail_value("particles_per_cell", "must be in 1..8 (per axis)");
    const bool has_particle = c.dim == 2 ? body_has_particle<2>(c, bc) : body_has_particle<3>(c, bc);
    if (!has_particle)
      b.fail(region_key(bc), "holds no particle (too thin for the particle spacing cell_size / particles_per_cell = " +
                                 number_text(c.grid.cell_size / bc.particles_per_cell) + " m)");
  }
  bc.velocity = b.has("velocity") ? b.reals("velocity", c.dim) : std::vector<double>(c.dim, 0.0);
  bc.geostatic = b.choice("initial_stress", {"none", "geostatic"}, "none") == "geostatic";
  if (bc.geostatic && bc.shape == BodyShape::particle_file)
    b.fail_value("initial_stress", "geostatic",
                 "needs a body seeded on the lattice (box, polygon or polyhedron): the depth of a particle read "
                 "from a file is not defined");
  if (b.has("k0")) {
    if (!bc.geostatic) b.fail("k0", "is only used with initial_stress: geostatic");
    bc.k0 = b.real("k0");
    if (!(bc.k0 > 0.0 && bc.k0 <= 5.0)) b.fail_value("k0", "must be in (0, 5]");
  }
  bc.rigid = b.boolean("rigid", false);
  if (bc.rigid && bc.geostatic)
    b.fail_value("initial_stress", "geostatic", "a rigid body carries no stress (rigid: true)");
  if (bc.rigid && c.time.integrator == Integrator::explicit_euler)
    b.fail_value("rigid", "true", "rigid bodies need the implicit integrator (time.integrator: implicit)");
  if (bc.geostatic)
    for (int a = 0; a + 1 < c.dim; ++a)
      if (c.gravity[a] != 0.0 || !(c.gravity[c.dim - 1] < 0.0))
        b.fail_value("initial_stress", "geostatic", "needs gravity pointing down the last axis (gravity = [0, -g] or [0, 0, -g])");
  b.finish();
  return bc;
}

void check_bodies_against_obstacles(std::vector<YamlSection>& sections, const CaseConfig& c) {
  if (c.obstacles.empty()) return;
  if (c.dim == 2)
    check_against_obstacles<2>(sections, c);
  else
    check_against_obstacles<3>(sections, c);
}

// contact.bodies: pairs of bodies in frictional contact, each body of a pair
// with its own velocity field (docs/contact.md#bodies-in-contact).
void parse_body_pairs(YamlSection& k, CaseConfig& c) {
  std::vector<YamlSection> pairs = k.list("bodies");
  const auto body_index = [&](YamlSection& p, const std::string& name) {
    for (std::size_t b = 0; b < c.bodies.size(); ++b)
      if (c.bodies[b].name == name) return static_cast<int>(b);
    p.fail_value("pair", "'" + name + "' is not the name of a body");
  };
  for (YamlSection& p : pairs) {
    const std::vector<std::string> names = p.texts("pair", 2);
    BodyContactPair pair;
    pair.body_a = body_index(p, names[0]);
    pair.body_b = body_index(p, names[1]);
    if (pair.body_a == pair.body_b) p.fail_value("pair", "names the same body twice");
    for (const BodyContactPair& q : c.contact.body_pairs)
      if ((q.body_a == pair.body_a && q.body_b == pair.body_b) || (q.body_a == pair.body_b && q.body_b == pair.body_a))
        p.fail_value("pair", "is listed twice");
    if (c.bodies[pair.body_a].rigid && c.bodies[pair.body_b].rigid)
      p.fail_value("pair", "[" + names[0] + ", " + names[1] + "]",
                   "names two rigid bodies: contact between rigid bodies is not supported, they would pass through "
                   "each other (docs/contact.md#rigid-bodies)");
    pair.friction = p.real("friction");
    if (!(pair.friction >= 0.0 && pair.friction <= 10.0)) p.fail_value("friction", "must be in [0, 10]");
    p.finish();
    c.contact.body_pairs.push_back(pair);
  }
  // Field 0 for the bodies in no pair (if any), then one field per named body.
  std::vector<char> named(c.bodies.size(), 0);
  for (const BodyContactPair& q : c.contact.body_pairs) named[q.body_a] = named[q.body_b] = 1;
  const bool common = std::find(named.begin(), named.end(), 0) != named.end();
  c.contact.body_field.assign(c.bodies.size(), 0);
  int next = common ? 1 : 0;
  for (std::size_t b = 0; b < c.bodies.size(); ++b)
    if (named[b]) c.contact.body_field[b] = next++;
  c.contact.field_count = next;
}

// A rigid body's field carries its rigid motion only: no other body may
// share it.
void check_rigid_fields(std::vector<YamlSection>& sections, const CaseConfig& c) {
  const auto field = [&](std::size_t k) { return c.contact.body_field.empty() ? 0 : c.contact.body_field[k]; };
  for (std::size_t b = 0; b < c.bodies.size(); ++b) {
    if (!c.bodies[b].rigid) continue;
    for (std::size_t k = 0; k < c.bodies.size(); ++k)
      if (k != b && field(k) == field(b))
        sections[b].fail_value("rigid", "true",
                               "needs a velocity field of its own, but body '" + c.bodies[b].name +
                                   "' shares one with body '" + c.bodies[k].name +
                                   "': name it in a pair of contact.bodies (docs/contact.md#rigid-bodies)");
  }
}

}  // namespace talus
