// The one list of built-in materials: the case file's `model:` key -> factory.
#include <functional>
#include <map>

#include "talus/io/yaml_section.hpp"
#include "talus/materials/drucker_prager.hpp"
#include "talus/materials/linear_elastic.hpp"
#include "talus/materials/mohr_coulomb.hpp"

namespace talus {

namespace {
using Factory = std::function<std::unique_ptr<Material>(YamlSection&)>;
const std::map<std::string, Factory>& registry() {
  static const std::map<std::string, Factory> models = {
      {"linear_elastic", &LinearElastic::from_yaml},
      {"drucker_prager", &DruckerPrager::from_yaml},
      {"mohr_coulomb", &MohrCoulomb::from_yaml},
  };
  return models;
}
}  // namespace

std::vector<std::string> material_models() {
  std::vector<std::string> names;
  for (const auto& [name, factory] : registry()) names.push_back(name);
  return names;
}

std::unique_ptr<Material> make_material(const std::string& model, YamlSection& parameters) {
  const auto it = registry().find(model);
  if (it == registry().end()) {
    std::string known;
    for (const auto& name : material_models()) known += (known.empty() ? "" : ", ") + name;
    parameters.fail_value("model", model, "is not a known material model (known: " + known + ")");
  }
  return it->second(parameters);
}

}  // namespace talus
