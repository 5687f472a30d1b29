#pragma once
// Filling bodies with material points.
#include <cstdint>

#include <vector>

#include "talus/contact/obstacle.hpp"
#include "talus/io/config.hpp"
#include "talus/particles/particles.hpp"

namespace talus {

// Puts the body's particles: those of its particle file, or
// particles_per_cell^dim particles per grid cell at sub-cell centres
// inside the body's box or polygon (in 3D: the (x, z) section extruded over y), each with volume (h / ppc)^dim (per unit thickness in
// 2D), density from the material, the body's initial velocity and zero stress.
// Every rank creates the particles it owns, so no particle crosses the network.
// Particle ids are the lattice order offset by `first_id`, identical for any
// number of ranks. Returns the number of lattice points of the body (all ranks).
// With body.geostatic, the particles start with sigma_v = -rho g (top - y),
// top being the upper edge of the body's topmost particle in the same lattice
// column, and sigma_h = k0 sigma_v on the other normal components.
// Lattice points inside an obstacle (negative gap at t = 0) are left out, so
// a box body placed on a terrain is cut by it (docs/contact.md).
template <int dim>
std::int64_t seed_body(Particles<dim>& particles, const Grid<dim>& grid, const BodyConfig& body,
                           const Material& material, int body_index, std::int64_t first_id,
                           double gravity_magnitude = 0.0, const std::vector<Obstacle<dim>>* obstacles = nullptr);

}  // namespace talus
