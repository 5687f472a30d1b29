#include "talus/particles/seeding.hpp"

#include <cmath>
#include <vector>

namespace talus {

namespace {
// Crossing-number test with half-open edges, so that a point on an edge shared
// by two bodies' polygons belongs to exactly one of them.
bool inside_polygon(const std::vector<std::array<double, 2>>& polygon, double x, double y) {
  bool inside = false;
  for (std::size_t i = 0, j = polygon.size() - 1; i < polygon.size(); j = i++) {
    const auto& a = polygon[i];
    const auto& b = polygon[j];
    if ((a[1] > y) != (b[1] > y) && x < a[0] + (y - a[1]) * (b[0] - a[0]) / (b[1] - a[1])) inside = !inside;
  }
  return inside;
}
}  // namespace

template <int dim>
std::int64_t seed_box_body(Particles<dim>& particles, const Grid<dim>& grid, const BodyConfig& body,
                           const Material& material, int body_index, std::int64_t first_id,
                           double gravity_magnitude, const std::vector<Obstacle<dim>>* obstacles) {
  const double h = grid.cell_size();
  const int ppc = body.particles_per_cell;
  const double spacing = h / ppc;
  // Sub-cell lattice: point s on axis a sits at lower + (s + 1/2) * spacing.
  std::array<long, dim> first{}, count{};
  std::int64_t total = 1;
  for (int a = 0; a < dim; ++a) {
    const double lo = (body.box_lower[a] - grid.lower()[a]) / spacing - 0.5;
    const double hi = (body.box_upper[a] - grid.lower()[a]) / spacing - 0.5;
    first[a] = static_cast<long>(std::ceil(lo - 1e-9));
    const long last = static_cast<long>(std::floor(hi + 1e-9));
    count[a] = std::max(0L, last - first[a] + 1);
    total *= count[a];
  }
  PetscMPIInt rank;
  MPI_Comm_rank(grid.comm(), &rank);

  std::vector<std::int64_t> mine;
  std::array<long, dim> s{};
  // Top of the body over each lattice column (index of the highest point inside), for geostatic stresses.
  std::int64_t columns = 1;
  for (int a = 0; a + 1 < dim; ++a) columns *= count[a];
  std::vector<long> top(body.geostatic ? columns : 0, -1);
  for (std::int64_t id = 0; id < total; ++id) {
    std::int64_t r = id;
    Vector<dim> x;
    for (int a = 0; a < dim; ++a) {
      s[a] = first[a] + r % count[a];
      r /= count[a];
      x[a] = grid.lower()[a] + (s[a] + 0.5) * spacing;
    }
    if (!body.polygon.empty() && !inside_polygon(body.polygon, x[0], x[dim - 1])) continue;
    if (obstacles) {
      bool buried = false;
      for (const Obstacle<dim>& o : *obstacles) buried |= o.gap(x, 0.0).gap < 0.0;
      if (buried) continue;
    }
    if (body.geostatic) {
      long& t = top[id % columns];
      t = std::max(t, s[dim - 1]);
    }
    if (grid.owner_rank(x) == rank) mine.push_back(id);
  }

  const PetscInt start = particles.add(static_cast<PetscInt>(mine.size()));
  DM sw = particles.swarm();
  FieldView<PetscReal> pos(sw, field::position), vel(sw, field::velocity), aff(sw, field::affine_velocity),
      disp(sw, field::displacement), mass(sw, field::mass), vol0(sw, field::initial_volume),
      defgrad(sw, field::deformation_gradient), stress(sw, field::stress), state(sw, field::material_state),
      plastic(sw, field::cumulative_plastic_strain), separation(sw, field::separation_strain);
  FieldView<PetscInt> mat(sw, field::material_id), bid(sw, field::body_id);
  FieldView<std::int64_t> pid(sw, field::particle_id);
  const double volume = std::pow(spacing, dim);
  for (std::size_t k = 0; k < mine.size(); ++k) {
    const PetscInt p = start + static_cast<PetscInt>(k);
    std::int64_t r = mine[k];
    for (int a = 0; a < dim; ++a) {
      pos[dim * p + a] = grid.lower()[a] + (first[a] + r % count[a] + 0.5) * spacing;
      r /= count[a];
      vel[dim * p + a] = body.velocity[a];
      disp[dim * p + a] = 0.0;
    }
    for (int i = 0; i < dim * dim; ++i) {
      aff[dim * dim * p + i] = 0.0;
      defgrad[dim * dim * p + i] = (i % (dim + 1) == 0) ? 1.0 : 0.0;
    }
    for (int i = 0; i < 6; ++i) stress[6 * p + i] = 0.0;
    if (body.geostatic) {
      // Lithostatic load of the material above, K0 laterally (tension positive).
      const long level = first[dim - 1] + mine[k] / columns;
      // From the upper edge of the column's top particle down to this particle's centre.
      const double depth = (top[mine[k] % columns] - level + 0.5) * spacing;
      const Tangent& C = material.elastic_stiffness();
      const double k0 = body.k0 > 0 ? body.k0 : C(0, 1) / C(0, 0);  // nu / (1 - nu) for isotropic elasticity
      const double vertical = -material.density() * gravity_magnitude * depth;
      for (int i = 0; i < 3; ++i) stress[6 * p + i] = (i == dim - 1 ? 1.0 : k0) * vertical;
    }
    for (int i = 0; i < max_state_size; ++i) state[max_state_size * p + i] = 0.0;
    plastic[p] = 0.0;
    separation[p] = 0.0;
    mass[p] = material.density() * volume;
    vol0[p] = volume;
    mat[p] = body.material;
    bid[p] = body_index;
    pid[p] = first_id + mine[k];
  }
  return total;
}

template std::int64_t seed_box_body<2>(Particles<2>&, const Grid<2>&, const BodyConfig&, const Material&, int,
                                       std::int64_t, double, const std::vector<Obstacle<2>>*);
template std::int64_t seed_box_body<3>(Particles<3>&, const Grid<3>&, const BodyConfig&, const Material&, int,
                                       std::int64_t, double, const std::vector<Obstacle<3>>*);

}  // namespace talus
