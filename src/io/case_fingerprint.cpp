// The case fingerprint a checkpoint records (docs/checkpoints.md#restart-with-a-changed-case).
#include <charconv>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "talus/io/config.hpp"
#include "talus/io/yaml_section.hpp"

namespace talus {

namespace {

// FNV-1a (64 bit) of a data file's bytes: a data file that changes under a
// checkpoint changes its case fingerprint.
std::string file_hash(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return "unreadable";
  std::uint64_t h = 1469598103934665603ULL;
  char buffer[65536];
  while (in) {
    in.read(buffer, sizeof buffer);
    for (std::streamsize i = 0; i < in.gcount(); ++i) {
      h ^= static_cast<unsigned char>(buffer[i]);
      h *= 1099511628211ULL;
    }
  }
  char text[24];
  std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(h));
  return text;
}

// A canonical text of a YAML node: the same for the same content however it
// is written (key order, flow or block style, 1e3 or 1000).
std::string canonical(const YAML::Node& node, const std::filesystem::path& base, const std::string& key) {
  switch (node.Type()) {
    case YAML::NodeType::Scalar: {
      const std::string& s = node.Scalar();
      double value = 0.0;
      const auto [end, error] = std::from_chars(s.data(), s.data() + s.size(), value);
      if (error == std::errc() && end == s.data() + s.size() && !s.empty()) return number_text(value);
      std::string text = "'" + s + "'";
      if (key == "file" || key == "particles") {
        std::filesystem::path path(s);
        if (path.is_relative()) path = base / path;
        text += " (contents " + file_hash(path) + ")";
      }
      return text;
    }
    case YAML::NodeType::Sequence: {
      std::string text = "[";
      for (std::size_t i = 0; i < node.size(); ++i) text += (i ? ", " : "") + canonical(node[i], base, key);
      return text + "]";
    }
    case YAML::NodeType::Map: {
      std::map<std::string, std::string> entries;
      for (auto it = node.begin(); it != node.end(); ++it)
        entries[it->first.Scalar()] = canonical(it->second, base, it->first.Scalar());
      std::string text = "{";
      for (const auto& [k, v] : entries) text += (text.size() > 1 ? ", " : "") + k + ": " + v;
      return text + "}";
    }
    default:
      return "~";
  }
}

// The canonical text of a list of bodies or obstacles, each without the
// keys whose value is the default the parser gives (`defaults`: key and the
// canonical text of its default; a zero vector stands for any dimension), so
// that writing a default out (particles_per_cell: 2, restitution: 0,
// velocity: [0, 0]) is no change (issue 14).
std::string canonical_list(const YAML::Node& list, const std::filesystem::path& base, const std::string& key,
                           const std::map<std::string, std::string>& defaults) {
  if (!list || !list.IsSequence()) return canonical(list, base, key);
  std::string text = "[";
  for (std::size_t i = 0; i < list.size(); ++i) {
    const YAML::Node item = list[i];
    std::string entry;
    if (item.IsMap()) {
      std::map<std::string, std::string> entries;
      for (auto it = item.begin(); it != item.end(); ++it) {
        const std::string name = it->first.Scalar();
        const std::string value = canonical(it->second, base, name);
        const auto d = defaults.find(name);
        const bool zero_vector = d != defaults.end() && d->second == "zeros" && it->second.IsSequence() &&
                                 value == (it->second.size() == 3 ? "[0, 0, 0]" : "[0, 0]");
        if (d != defaults.end() && (value == d->second || zero_vector)) continue;
        entries[name] = value;
      }
      entry = "{";
      for (const auto& [k, v] : entries) entry += (entry.size() > 1 ? ", " : "") + k + ": " + v;
      entry += "}";
    } else {
      entry = canonical(item, base, key);
    }
    text += (i ? ", " : "") + entry;
  }
  return text + "]";
}

}  // namespace

CaseFingerprint case_fingerprint(const YAML::Node& doc, const CaseConfig& c) {
  const std::filesystem::path base = std::filesystem::path(c.source_file).parent_path();
  // The sections with few keys and the materials from their parsed values,
  // defaults included, so that writing a default out (shape_function:
  // quadratic_bspline, transfer: {scheme: apic}, cohesion: 0) is not a
  // change; bodies and obstacles from their canonical YAML text without the
  // keys that hold their default.
  const char* const shapes[2] = {"quadratic_bspline", "linear"};
  std::string grid = "lower: " + list_text(c.grid.lower) + ", upper: " + list_text(c.grid.upper) +
                     ", cell_size: " + number_text(c.grid.cell_size) +
                     ", shape_function: " + shapes[c.grid.shape == ShapeKind::linear];
  // Named only when not the default, so that earlier checkpoints still match.
  if (c.grid.quadrature == ParticleQuadrature::domain) grid += ", quadrature: domain";
  std::string boundaries;
  for (int i = 0; i < 2 * c.dim; ++i) {
    boundaries += (i ? ", " : "") + std::string(face_names[i]) + ": " + face_conditions[static_cast<int>(c.faces[i])];
    if (c.faces[i] == FaceCondition::frictional)
      boundaries += " (friction " + number_text(c.face_contact[i].friction) + ", restitution " +
                    number_text(c.face_contact[i].restitution) + ")";
  }
  CaseFingerprint f;
  f.emplace_back("grid", grid);
  f.emplace_back("gravity", list_text(c.gravity));
  // Materials from their parsed parameters (Material::parameters), defaults
  // included: `cohesion: 0` written out is no change.
  std::string materials;
  for (const MaterialConfig& m : c.materials)
    materials += (materials.empty() ? "" : "; ") + ("name: " + m.name + ", " + m.law->parameters());
  f.emplace_back("materials", materials);
  f.emplace_back("bodies", canonical_list(doc["bodies"], base, "bodies",
                                          {{"particles_per_cell", "2"}, {"initial_stress", "'none'"},
                                           {"velocity", "zeros"}}));
  f.emplace_back("boundaries", boundaries);
  f.emplace_back("obstacles", doc["obstacles"] ? canonical_list(doc["obstacles"], base, "obstacles",
                                                                {{"restitution", "0"}, {"velocity", "zeros"}})
                                              : "none");
  std::string contact = "gap_prediction: " + number_text(c.contact.gap_prediction);
  for (const BodyContactPair& p : c.contact.body_pairs)
    contact += "; bodies " + c.bodies[p.body_a].name + ", " + c.bodies[p.body_b].name + ": friction " +
               number_text(p.friction);
  f.emplace_back("contact", contact);
  f.emplace_back("transfer", std::string("scheme: ") + (c.transfer.scheme == TransferScheme::apic ? "apic" : "flip") +
                                 ", flip_blend: " + number_text(c.transfer.flip_blend) +
                                 // Only when set: checkpoints of runs without it keep their fingerprint.
                                 (c.transfer.packing_correction > 0
                                      ? ", packing_correction: " + number_text(c.transfer.packing_correction)
                                      : std::string()));
  return f;
}

}  // namespace talus
