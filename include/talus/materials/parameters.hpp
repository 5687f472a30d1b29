#pragma once
// Case-file parameters shared by several laws, read and validated in one
// place so that every law gives the same messages (docs/case_file.md).
#include <string>
#include <utility>
#include <vector>

namespace talus {

class YamlSection;

struct ElasticParameters {
  double density, youngs_modulus, poisson_ratio;  // kg/m^3, Pa, -
};

// Frictional strength: angles in degrees as in the case file, cohesion in Pa.
struct FrictionParameters {
  double friction_angle, dilatancy_angle, cohesion;
};

// density > 0, youngs_modulus > 0, poisson_ratio in [0, 0.5).
ElasticParameters read_elastic_parameters(YamlSection& y);
// friction_angle in (0, 90), dilatancy_angle in [0, friction_angle] (default 0), cohesion >= 0 (default 0).
FrictionParameters read_friction_parameters(YamlSection& y);

// "model: <model>, key: value, ..." with every value to 17 digits (Material::parameters).
std::string parameter_text(const char* model, const std::vector<std::pair<const char*, double>>& values);

}  // namespace talus
