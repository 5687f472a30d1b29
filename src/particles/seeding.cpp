#include "talus/particles/seeding.hpp"

#include <cmath>
#include <vector>

#include "talus/particles/body_region.hpp"

namespace talus {

template <int dim>
std::int64_t seed_body(Particles<dim>& particles, const Grid<dim>& grid, const BodyConfig& body,
                           const Material& material, int body_index, std::int64_t first_id,
                           double gravity_magnitude, const std::vector<Obstacle<dim>>* obstacles) {
  PetscMPIInt rank;
  MPI_Comm_rank(grid.comm(), &rank);
  const bool from_file = body.shape == BodyShape::particle_file;
  std::vector<double> lower(dim);
  for (int a = 0; a < dim; ++a) lower[a] = grid.lower()[a];
  const BodyLattice<dim> lattice(body, lower, grid.cell_size());
  const auto& count = lattice.count;
  const std::int64_t total = from_file ? static_cast<std::int64_t>(body.file_volumes.size()) : lattice.size;

  // The particles this rank owns, as lattice ids or file indices.
  std::vector<std::int64_t> mine;
  // Top of the body over each lattice column (index of the highest point inside), for geostatic stresses.
  std::int64_t columns = 1;
  for (int a = 0; a + 1 < dim; ++a) columns *= count[a];
  std::vector<long> top(body.geostatic ? columns : 0, -1);
  const std::vector<bool> in_body = from_file ? std::vector<bool>() : seeded_lattice_points<dim>(body, lattice);
  for (std::int64_t id = 0; id < total; ++id) {
    // File particles were checked against the grid and the obstacles when the case was read.
    const Vector<dim> x = from_file ? Vector<dim>(Eigen::Map<const Vector<dim>>(&body.file_positions[dim * id]))
                                    : lattice.point(id);
    if (!from_file) {
      if (!in_body[id]) continue;
      if (obstacles) {
        bool buried = false;
        for (const Obstacle<dim>& o : *obstacles) buried |= o.gap(x, 0.0).gap < 0.0;
        if (buried) continue;
      }
      if (body.geostatic) {
        long& t = top[id % columns];
        t = std::max(t, lattice.index(id)[dim - 1]);
      }
    }
    if (grid.owner_rank(x) == rank) mine.push_back(id);
  }

  const PetscInt start = particles.add(static_cast<PetscInt>(mine.size()));
  DM sw = particles.swarm();
  FieldView<PetscReal> pos(sw, field::position), vel(sw, field::velocity), aff(sw, field::affine_velocity),
      disp(sw, field::displacement), mass(sw, field::mass), vol0(sw, field::initial_volume),
      defgrad(sw, field::deformation_gradient), ratio(sw, field::volume_ratio), stress(sw, field::stress), state(sw, field::material_state),
      plastic(sw, field::cumulative_plastic_strain), separation(sw, field::separation_strain);
  FieldView<PetscInt> mat(sw, field::material_id), bid(sw, field::body_id);
  FieldView<std::int64_t> pid(sw, field::particle_id);
  const double lattice_volume = std::pow(lattice.spacing, dim);
  for (std::size_t k = 0; k < mine.size(); ++k) {
    const PetscInt p = start + static_cast<PetscInt>(k);
    const std::int64_t id = mine[k];
    const Vector<dim> x = from_file ? Vector<dim>(Eigen::Map<const Vector<dim>>(&body.file_positions[dim * id]))
                                    : lattice.point(id);
    for (int a = 0; a < dim; ++a) {
      pos[dim * p + a] = x[a];
      vel[dim * p + a] = body.file_velocities.empty() ? body.velocity[a] : body.file_velocities[dim * id + a];
      disp[dim * p + a] = 0.0;
    }
    const double volume = from_file ? body.file_volumes[id] : lattice_volume;
    for (int i = 0; i < dim * dim; ++i) {
      aff[dim * dim * p + i] = 0.0;
      defgrad[dim * dim * p + i] = (i % (dim + 1) == 0) ? 1.0 : 0.0;
    }
    ratio[p] = 1.0;
    for (int i = 0; i < 6; ++i) stress[6 * p + i] = 0.0;
    if (body.geostatic) {
      // Lithostatic load of the material above, K0 laterally (tension positive).
      const long level = lattice.index(id)[dim - 1];
      // From the upper edge of the column's top particle down to this particle's centre.
      const double depth = (top[id % columns] - level + 0.5) * lattice.spacing;
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
    pid[p] = first_id + id;
  }
  return total;
}

template std::int64_t seed_body<2>(Particles<2>&, const Grid<2>&, const BodyConfig&, const Material&, int,
                                       std::int64_t, double, const std::vector<Obstacle<2>>*);
template std::int64_t seed_body<3>(Particles<3>&, const Grid<3>&, const BodyConfig&, const Material&, int,
                                       std::int64_t, double, const std::vector<Obstacle<3>>*);

}  // namespace talus
