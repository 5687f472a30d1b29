#include "talus/materials/parameters.hpp"

#include <sstream>

#include <string>

#include "talus/io/yaml_section.hpp"

namespace talus {

namespace {
// Bounds far outside any soil, rock or debris, inside which the particle
// masses, volumes and wave speeds of any grid talus accepts stay normal
// double-precision numbers (docs/case_file.md#materials): 4.9e-324 kg/m3
// passes "> 0" but gives particles of zero mass.
double bounded(YamlSection& y, const char* key, double value, double low, double high, const std::string& range) {
  if (!(value >= low && value <= high))
    y.fail_value(key, "must be in " + range + " (far outside it the particle masses or wave speeds under- or overflow)");
  return value;
}
}  // namespace

ElasticParameters read_elastic_parameters(YamlSection& y) {
  ElasticParameters p;
  p.density = bounded(y, "density", y.real("density"), 1e-6, 1e9, "[1e-6, 1e9] kg/m^3");
  p.youngs_modulus = bounded(y, "youngs_modulus", y.real("youngs_modulus"), 1e-6, 1e15, "[1e-6, 1e15] Pa");
  p.poisson_ratio = y.real("poisson_ratio");
  if (!(p.poisson_ratio >= 0.0 && p.poisson_ratio < 0.5))
    y.fail_value("poisson_ratio", "must be in [0, 0.5)");
  return p;
}

FrictionParameters read_friction_parameters(YamlSection& y) {
  FrictionParameters p;
  p.friction_angle = y.real("friction_angle");
  if (!(p.friction_angle > 0.0 && p.friction_angle < 90.0))
    y.fail_value("friction_angle", "must be in (0, 90) degrees");
  p.dilatancy_angle = y.real("dilatancy_angle", 0.0);
  if (!(p.dilatancy_angle >= 0.0 && p.dilatancy_angle <= p.friction_angle))
    y.fail_value("dilatancy_angle", "must be in [0, friction_angle] degrees");
  p.cohesion = y.real("cohesion", 0.0);
  if (!(p.cohesion >= 0.0)) y.fail_value("cohesion", "must be >= 0");
  return p;
}

std::string parameter_text(const char* model, const std::vector<std::pair<const char*, double>>& values) {
  std::ostringstream out;
  out.precision(17);
  out << "model: " << model;
  for (const auto& [key, value] : values) out << ", " << key << ": " << value;
  return out.str();
}

}  // namespace talus
