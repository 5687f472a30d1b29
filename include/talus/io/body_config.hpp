#pragma once
// The `bodies` entries of a case file (docs/case_file.md#bodies): the region a
// body fills (box, polygon, extruded polygon, polyhedron) or the file its
// particles are read from, its material, velocity and initial stress.
#include <vector>

#include "talus/io/config.hpp"
#include "talus/io/yaml_section.hpp"

namespace talus {

// Reads and checks one body; c's grid, gravity and materials are read.
BodyConfig parse_body(YamlSection& b, const CaseConfig& c);

// Once the obstacles are read: a body whose particles would all lie inside
// obstacles (seeding leaves those out, so it would silently vanish), or a
// particle of a particle file inside one, stops the run.
void check_bodies_against_obstacles(std::vector<YamlSection>& sections, const CaseConfig& c);

// contact.bodies (`k` the contact section): the pairs of bodies in contact
// and each body's velocity field (docs/contact.md#bodies-in-contact); the
// bodies are read.
void parse_body_pairs(YamlSection& k, CaseConfig& c);
// After contact.bodies: a rigid body (rigid: true) has a velocity field of its own.
void check_rigid_fields(std::vector<YamlSection>& sections, const CaseConfig& c);

}  // namespace talus
