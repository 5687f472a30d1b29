#include "talus/io/config.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "talus/io/yaml_section.hpp"

namespace talus {

// ---------------------------------------------------------------- YamlSection

namespace {

std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diag = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diag = up;
    }
  }
  return row[b.size()];
}

std::string scalar_text(const YAML::Node& n) {
  if (n.IsScalar()) return n.Scalar();
  std::ostringstream os;
  os << YAML::Dump(n);
  std::string s = os.str();
  std::replace(s.begin(), s.end(), '\n', ' ');
  return s;
}

// YAML allows a key twice in one map and the first value silently wins:
// a case file must not (the second value would be ignored without a word).
void reject_duplicate_keys(const YAML::Node& map, const std::string& path, const std::string& file) {
  if (!map.IsMap()) return;
  std::map<std::string, int> first_line;
  for (auto it = map.begin(); it != map.end(); ++it) {
    const std::string key = it->first.Scalar();
    const int line = it->first.Mark().line + 1;
    const auto [at, inserted] = first_line.emplace(key, line);
    if (!inserted)
      throw InputError(file + ":" + std::to_string(line) + ": " + (path.empty() ? key : path + "." + key) +
                       ": is given twice (first on line " + std::to_string(at->second) + ")");
  }
}

}  // namespace

YamlSection::YamlSection(YAML::Node node, std::string path, std::string file)
    : node_(std::move(node)), path_(std::move(path)), file_(std::move(file)) {
  reject_duplicate_keys(node_, path_, file_);
}

int YamlSection::line() const { return node_.Mark().line + 1; }

bool YamlSection::has(const std::string& key) const {
  read_.insert(key);  // a key asked for is a known key, for "did you mean"
  return node_.IsMap() && node_[key].IsDefined();
}

int YamlSection::line_of(const std::string& key) const {
  if (node_.IsMap())
    for (auto it = node_.begin(); it != node_.end(); ++it)
      if (it->first.Scalar() == key) return it->first.Mark().line + 1;
  return line();
}

std::string YamlSection::key_path(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }

void YamlSection::fail(const std::string& key, const std::string& message) const {
  throw InputError(file_ + ":" + std::to_string(line_of(key)) + ": " + key_path(key) + ": " + message);
}

void YamlSection::fail_value(const std::string& key, const std::string& value, const std::string& message) const {
  throw InputError(file_ + ":" + std::to_string(line_of(key)) + ": " + key_path(key) + " = " + value + ": " +
                   message);
}

YAML::Node YamlSection::child(const std::string& key, const char* expected) {
  read_.insert(key);
  if (!node_.IsMap()) fail(key, "the enclosing section must be a map");
  YAML::Node c = node_[key];
  if (!c.IsDefined() || c.IsNull()) {
    // A required key that is absent is often a misspelled one that is present.
    for (auto it = node_.begin(); it != node_.end(); ++it) {
      const std::string other = it->first.Scalar();
      if (other != key && edit_distance(other, key) <= 2 && !read_.count(other))
        fail(other, "unknown key (did you mean '" + key + "'?)");
    }
    fail(key, std::string("is required (") + expected + ")");
  }
  return c;
}

double YamlSection::real(const std::string& key) {
  YAML::Node c = child(key, "a number");
  double v = 0;
  if (!c.IsScalar() || !YAML::convert<double>::decode(c, v) || !std::isfinite(v))
    fail_value(key, scalar_text(c), "must be a finite number");
  return v;
}

double YamlSection::real(const std::string& key, double fallback) { return has(key) ? real(key) : fallback; }

int YamlSection::integer(const std::string& key) {
  YAML::Node c = child(key, "an integer");
  int v = 0;
  if (!c.IsScalar() || !YAML::convert<int>::decode(c, v)) fail_value(key, scalar_text(c), "must be an integer");
  return v;
}

int YamlSection::integer(const std::string& key, int fallback) {
  return has(key) ? integer(key) : fallback;
}

bool YamlSection::boolean(const std::string& key, bool fallback) {
  if (!has(key)) return fallback;
  YAML::Node c = child(key, "true or false");
  bool v = false;
  if (!c.IsScalar() || !YAML::convert<bool>::decode(c, v)) fail_value(key, scalar_text(c), "must be true or false");
  return v;
}

std::string YamlSection::text(const std::string& key) {
  YAML::Node c = child(key, "a text");
  if (!c.IsScalar()) fail_value(key, scalar_text(c), "must be a text");
  return c.Scalar();
}

std::string YamlSection::text(const std::string& key, const std::string& fallback) {
  return has(key) ? text(key) : fallback;
}

std::string YamlSection::choice(const std::string& key, const std::vector<std::string>& choices,
                                const std::string& fallback) {
  const std::string v = text(key, fallback);
  if (std::find(choices.begin(), choices.end(), v) == choices.end()) {
    std::string list;
    for (const auto& c : choices) list += (list.empty() ? "" : ", ") + c;
    fail_value(key, v, "must be one of: " + list);
  }
  return v;
}

std::vector<double> YamlSection::reals(const std::string& key, int length) {
  YAML::Node c = child(key, "a list of numbers");
  if (!c.IsSequence()) fail_value(key, scalar_text(c), "must be a list of numbers");
  if ((length >= 0 && static_cast<int>(c.size()) != length) || c.size() == 0)
    fail_value(key, scalar_text(c), "must have " + std::to_string(length) + " entries");
  std::vector<double> out;
  for (const auto& e : c) {
    double v = 0;
    if (!e.IsScalar() || !YAML::convert<double>::decode(e, v) || !std::isfinite(v))
      fail_value(key, scalar_text(c), "entry '" + scalar_text(e) + "' is not a finite number");
    out.push_back(v);
  }
  return out;
}

std::vector<std::vector<double>> YamlSection::points(const std::string& key, int dim) {
  YAML::Node c = child(key, "a list of points");
  if (!c.IsSequence() || c.size() == 0) fail_value(key, scalar_text(c), "must be a non-empty list of points");
  std::vector<std::vector<double>> out;
  for (std::size_t i = 0; i < c.size(); ++i) {
    const YAML::Node& point = c[i];
    const std::string where = key_path(key) + "[" + std::to_string(i) + "]";
    const auto bad = [&](const std::string& message) {
      throw InputError(file_ + ":" + std::to_string(point.Mark().line + 1) + ": " + where + " = " +
                       scalar_text(point) + ": " + message);
    };
    if (!point.IsSequence() || static_cast<int>(point.size()) != dim)
      bad("must be a point of " + std::to_string(dim) + " numbers");
    std::vector<double> x;
    for (const auto& e : point) {
      double v = 0;
      if (!e.IsScalar() || !YAML::convert<double>::decode(e, v) || !std::isfinite(v))
        bad("entry '" + scalar_text(e) + "' is not a finite number");
      x.push_back(v);
    }
    out.push_back(x);
  }
  return out;
}

YamlSection YamlSection::section(const std::string& key) {
  YAML::Node c = child(key, "a map");
  if (!c.IsMap()) fail_value(key, scalar_text(c), "must be a map of keys");
  return YamlSection(c, key_path(key), file_);
}

std::vector<YamlSection> YamlSection::list(const std::string& key) {
  YAML::Node c = child(key, "a list");
  if (!c.IsSequence() || c.size() == 0) fail_value(key, scalar_text(c), "must be a non-empty list");
  std::vector<YamlSection> out;
  for (std::size_t i = 0; i < c.size(); ++i) {
    const std::string p = key_path(key) + "[" + std::to_string(i) + "]";
    if (!c[i].IsMap()) throw InputError(file_ + ":" + std::to_string(c[i].Mark().line + 1) + ": " + p + ": must be a map");
    out.emplace_back(c[i], p, file_);
  }
  return out;
}

std::vector<std::pair<std::string, std::string>> YamlSection::free_map(const std::string& key) {
  std::vector<std::pair<std::string, std::string>> out;
  if (!has(key)) return out;
  YAML::Node c = child(key, "a map");
  if (!c.IsMap()) fail_value(key, scalar_text(c), "must be a map of option: value");
  reject_duplicate_keys(c, key_path(key), file_);
  for (auto it = c.begin(); it != c.end(); ++it) {
    if (!it->second.IsScalar() && !it->second.IsNull())
      fail_value(key + "." + it->first.Scalar(), scalar_text(it->second), "must be a single value");
    out.emplace_back(it->first.Scalar(), it->second.IsNull() ? "" : it->second.Scalar());
  }
  return out;
}

double YamlSection::positive(const std::string& key, double value) const {
  if (!(value > 0)) fail_value(key, scalar_text(YAML::Node(value)), "must be > 0");
  return value;
}

void YamlSection::finish() const {
  if (!node_.IsMap()) return;
  for (auto it = node_.begin(); it != node_.end(); ++it) {
    const std::string key = it->first.Scalar();
    if (read_.count(key)) continue;
    std::string best;
    std::size_t best_d = 4;
    for (const auto& known : read_) {
      const std::size_t d = edit_distance(key, known);
      if (d < best_d) best_d = d, best = known;
    }
    std::string msg = "unknown key";
    if (!best.empty()) msg += " (did you mean '" + best + "'?)";
    fail(key, msg);
  }
}

// ---------------------------------------------------------------- case file

namespace {

FaceCondition parse_face(YamlSection& s, const std::string& key) {
  const std::string v = s.choice(key, {"free", "slip", "fixed"}, "slip");
  return v == "free" ? FaceCondition::free : v == "slip" ? FaceCondition::slip : FaceCondition::fixed;
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
  const auto& poly = body.polygon;
  for (long i = first[0]; i <= last[0]; ++i)
    for (long j = first[1]; j <= last[1]; ++j) {
      const double x = c.grid.lower[0] + (i + 0.5) * spacing, y = c.grid.lower[1] + (j + 0.5) * spacing;
      bool inside = false;
      for (std::size_t k = 0, l = poly.size() - 1; k < poly.size(); l = k++)
        if ((poly[k][1] > y) != (poly[l][1] > y) &&
            x < poly[k][0] + (y - poly[k][1]) * (poly[l][0] - poly[k][0]) / (poly[l][1] - poly[k][1]))
          inside = !inside;
      if (inside) return true;
    }
  return false;
}

CaseConfig parse_root(YamlSection& root) {
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
      t.fail_value("theta", std::to_string(c.time.theta), "must be in [0.5, 1]");
    c.time.min_step_ratio = t.real("min_step_ratio", 1e-3);
    if (!(c.time.min_step_ratio > 0 && c.time.min_step_ratio <= 1))
      t.fail_value("min_step_ratio", std::to_string(c.time.min_step_ratio), "must be in (0, 1]");
    t.finish();
  }
  if (root.has("output")) {
    YamlSection o = root.section("output");
    c.output.directory = o.text("directory", "output");
    c.output.interval = o.real("interval", 0.0);
    if (c.output.interval < 0) o.fail_value("interval", std::to_string(c.output.interval), "must be >= 0");
    c.output.enabled = o.boolean("enabled", true);
    o.finish();
  }
  c.checkpoint.directory = c.output.directory;
  c.checkpoint.enabled = c.output.enabled;
  if (root.has("checkpoint")) {
    YamlSection k = root.section("checkpoint");
    c.checkpoint.enabled = k.boolean("enabled", c.output.enabled);
    c.checkpoint.interval = k.integer("interval", 0);
    if (c.checkpoint.interval < 0)
      k.fail_value("interval", std::to_string(c.checkpoint.interval), "must be >= 0 (steps; 0: only at the end)");
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

  for (YamlSection& b : root.list("bodies")) {
    BodyConfig bc;
    bc.name = b.text("name");
    const std::string material = b.text("material");
    const auto it = std::find_if(c.materials.begin(), c.materials.end(),
                                 [&](const MaterialConfig& m) { return m.name == material; });
    if (it == c.materials.end()) b.fail_value("material", material, "names no material in 'materials'");
    bc.material = static_cast<int>(it - c.materials.begin());
    if (b.has("box") == b.has("polygon"))
      b.fail("box", b.has("box") ? "give either box or polygon, not both" : "is required (or polygon, in 2D)");
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
      if (c.dim != 2) b.fail("polygon", "is a 2D body shape (the grid is 3D)");
      const auto vertices = b.points("polygon", 2);
      if (vertices.size() < 3) b.fail("polygon", "needs at least 3 vertices");
      double area2 = 0.0;
      bc.box_lower = vertices[0];
      bc.box_upper = vertices[0];
      for (std::size_t i = 0; i < vertices.size(); ++i) {
        const auto& p = vertices[i];
        const auto& q = vertices[(i + 1) % vertices.size()];
        area2 += p[0] * q[1] - q[0] * p[1];
        for (int a = 0; a < 2; ++a) {
          if (p[a] < c.grid.lower[a] || p[a] > c.grid.upper[a])
            b.fail("polygon", "vertex " + std::to_string(i) + " lies outside the grid box");
          bc.box_lower[a] = std::min(bc.box_lower[a], p[a]);
          bc.box_upper[a] = std::max(bc.box_upper[a], p[a]);
        }
        bc.polygon.push_back({p[0], p[1]});
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
      if (std::abs(area2) <= 1e-12 * (bc.box_upper[0] - bc.box_lower[0]) * (bc.box_upper[1] - bc.box_lower[1]) ||
          !(bc.box_upper[0] > bc.box_lower[0] && bc.box_upper[1] > bc.box_lower[1]))
        b.fail("polygon", "has zero area");
    }
    bc.particles_per_cell = b.integer("particles_per_cell", 2);
    if (bc.particles_per_cell < 1 || bc.particles_per_cell > 8)
      b.fail_value("particles_per_cell", std::to_string(bc.particles_per_cell), "must be in 1..8 (per axis)");
    if (!body_has_particle(c, bc)) {
      std::ostringstream spacing;
      spacing << c.grid.cell_size / bc.particles_per_cell;
      b.fail(bc.polygon.empty() ? "box" : "polygon",
             "holds no particle (too thin for the particle spacing cell_size / particles_per_cell = " +
                 spacing.str() + " m)");
    }
    bc.velocity = b.has("velocity") ? b.reals("velocity", c.dim) : std::vector<double>(c.dim, 0.0);
    bc.geostatic = b.choice("initial_stress", {"none", "geostatic"}, "none") == "geostatic";
    if (b.has("k0")) {
      if (!bc.geostatic) b.fail("k0", "is only used with initial_stress: geostatic");
      bc.k0 = b.real("k0");
      if (!(bc.k0 > 0.0 && bc.k0 <= 5.0)) b.fail_value("k0", std::to_string(bc.k0), "must be in (0, 5]");
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
    const char* names[6] = {"x_min", "x_max", "y_min", "y_max", "z_min", "z_max"};
    for (int i = 0; i < 2 * c.dim; ++i) c.faces[i] = parse_face(f, names[i]);
    f.finish();
  }

  if (root.has("transfer")) {
    YamlSection t = root.section("transfer");
    c.transfer.scheme = t.choice("scheme", {"apic", "flip"}, "apic") == "apic" ? TransferScheme::apic
                                                                                  : TransferScheme::flip;
    c.transfer.flip_blend = t.real("flip_blend", 0.99);
    if (!(c.transfer.flip_blend >= 0 && c.transfer.flip_blend <= 1))
      t.fail_value("flip_blend", std::to_string(c.transfer.flip_blend), "must be in [0, 1]");
    t.finish();
  }

  if (root.has("solver")) {
    YamlSection s = root.section("solver");
    c.solver.active_mass_ratio = s.real("active_mass_ratio", 1e-12);
    if (!(c.solver.active_mass_ratio >= 0 && c.solver.active_mass_ratio < 1))
      s.fail_value("active_mass_ratio", std::to_string(c.solver.active_mass_ratio), "must be in [0, 1)");
    c.solver.direct_solver_limit = s.integer("direct_solver_limit", 5000);
    if (c.solver.direct_solver_limit < 0)
      s.fail_value("direct_solver_limit", std::to_string(c.solver.direct_solver_limit), "must be >= 0");
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
  return parse_root(root);
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
