#include "talus/materials/parameters.hpp"

#include <string>

#include "talus/io/yaml_section.hpp"

namespace talus {

ElasticParameters read_elastic_parameters(YamlSection& y) {
  ElasticParameters p;
  p.density = y.positive("density", y.real("density"));
  p.youngs_modulus = y.positive("youngs_modulus", y.real("youngs_modulus"));
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

}  // namespace talus
