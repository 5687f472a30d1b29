// The grid acceleration of the particles' stresses (stress_acceleration),
// the time-error estimate's reference for a step without a last
// acceleration (docs/solver.md#the-tolerance-follows-the-time-error):
// a_i = g - f_i / m_i, f_i = sum_p V0_p tau_p grad N_i(x_p).
#include <catch2/catch.hpp>
#include <cmath>

#include "talus/particles/seeding.hpp"
#include "talus/transfer/transfer.hpp"
#include "test_support.hpp"

using namespace talus;

namespace {

double hashed(long key, int salt) { return std::sin(12.9898 * key + 78.233 * salt) * 0.5; }

struct Dummy : Material {
  const char* model() const override { return "dummy"; }
  double density() const override { return 1500.0; }
  void update(const Voigt&, const Voigt&, const double*, double*, MaterialPointUpdate&) const override {}
  const Tangent& elastic_stiffness() const override {
    static Tangent t = Tangent::Identity();
    return t;
  }
  std::string parameters() const override { return "model: dummy"; }
};

// A body filling [0, hi] with 2 particles per cell and axis; with `jitter`
// the particles leave the lattice and every stress is random (keyed by id,
// the same on any number of ranks), without it every particle carries the
// hydrostatic Kirchhoff stress -p I.
template <int dim>
void check(bool jitter) {
  Vector<dim> lo = Vector<dim>::Zero(), hi, g;
  if constexpr (dim == 2) hi << 1.0, 0.8, g << 0.3, -9.81;
  else hi << 0.6, 0.5, 0.4, g << 0.3, -0.2, -9.81;
  const double dx = 0.1, p_hydro = 2.0e3;
  Grid<dim> grid(PETSC_COMM_WORLD, lo, hi, dx, ShapeKind::quadratic_bspline, ParticleQuadrature::point);
  Particles<dim> particles(grid.comm());
  BodyConfig bc;
  bc.box_lower.assign(lo.data(), lo.data() + dim);
  bc.box_upper.assign(hi.data(), hi.data() + dim);
  bc.particles_per_cell = 2;
  bc.velocity.assign(dim, 0.0);
  const Dummy dummy;
  seed_body<dim>(particles, grid, bc, dummy, 0, 0);
  {
    FieldView<PetscReal> x(particles.swarm(), field::position), s(particles.swarm(), field::stress);
    FieldView<std::int64_t> id(particles.swarm(), field::particle_id);
    for (PetscInt p = 0; p < particles.local_count(); ++p) {
      const long k = static_cast<long>(id[p]);
      for (int c = 0; c < 6; ++c)
        s[6 * p + c] = jitter ? 1.0e3 * hashed(k, 3 + c) : (c < 3 ? -p_hydro : 0.0);
      if (jitter)
        for (int a = 0; a < dim; ++a) x[dim * p + a] += 0.02 * hashed(k, 11 + a);
    }
  }
  particles.migrate(grid);
  std::vector<Stencil<dim>> stencils;
  compute_stencils(grid, particles, stencils);
  GridFields<dim> fields;
  particles_to_grid(grid, particles, stencils, TransferScheme::apic, fields);
  const std::vector<double> a = stress_acceleration(grid, particles, stencils, fields, g);
  REQUIRE(a.size() == fields.mass.size() * dim);

  // sum_i grad N_i = 0 (partition of unity), so the internal forces sum to
  // zero and sum_i m_i a_i = M g for any stresses: a conservation law.
  Vector<dim> momentum_rate = Vector<dim>::Zero();
  double mass = 0.0, force_scale = 0.0;
  for (int i = 0; i < grid.ghosted_count(); ++i) {
    if (!grid.is_owned(grid.global_index(i))) continue;
    const double m = fields.mass[i];
    if (!(m > 0.0)) {
      CHECK(std::isnan(a[dim * i]));  // no mass, no acceleration
      continue;
    }
    const Eigen::Map<const Vector<dim>> ai(a.data() + dim * i);
    REQUIRE(ai.allFinite());
    momentum_rate += m * ai;
    mass += m;
    force_scale += m * (g - ai).norm();
  }
  MPI_Allreduce(MPI_IN_PLACE, momentum_rate.data(), dim, MPI_DOUBLE, MPI_SUM, grid.comm());
  MPI_Allreduce(MPI_IN_PLACE, &mass, 1, MPI_DOUBLE, MPI_SUM, grid.comm());
  MPI_Allreduce(MPI_IN_PLACE, &force_scale, 1, MPI_DOUBLE, MPI_SUM, grid.comm());
  INFO(dim << "D, " << (jitter ? "random stresses" : "hydrostatic") << ": sum |f_i| " << force_scale);
  REQUIRE(force_scale > 1e-3 * mass * g.norm());  // the stresses do act
  // Sums of ~1e3 forces: round-off ~1e-14 of their sizes; 1e-12 leaves room.
  CHECK((momentum_rate - mass * g).norm() <= 1e-12 * (force_scale + mass * g.norm()));

  if (jitter) return;
  // A uniform stress has no divergence: a uniform quadratic B-spline (not
  // the clamped ones at the faces) is centred on a cell, the lattice's
  // quarter points are symmetric about that centre, the gradients cancel
  // pairwise, and a_i = g to round-off; at the faces the surface traction
  // -p n acts, pushing the face points outwards.
  // The face's traction in closed form: the two clamped functions at x_min
  // sum to 1 - N_2, whose x-derivative integrates to -1 along x; it is
  // linear on each cell, so the particles (the midpoints of half-cells)
  // integrate it exactly, and their forces sum to p times the face's area A.
  double face_force = 0.0, area = 1.0;
  for (int ax = 1; ax < dim; ++ax) area *= hi[ax];
  for (int i = 0; i < grid.ghosted_count(); ++i) {
    const auto ijk = grid.global_index(i);
    if (!grid.is_owned(ijk) || !(fields.mass[i] > 0.0)) continue;
    const Eigen::Map<const Vector<dim>> ai(a.data() + dim * i);
    bool interior = true;
    for (int ax = 0; ax < dim; ++ax) interior = interior && ijk[ax] >= 2 && ijk[ax] <= grid.points()[ax] - 3;
    if (interior) CHECK((ai - g).norm() <= 1e-9 * p_hydro / (1500.0 * dx));
    if (ijk[0] == 0) CHECK(ai[0] < g[0]);  // the x_min face is pushed to -x
    if (ijk[0] <= 1) face_force += fields.mass[i] * (g[0] - ai[0]);
  }
  MPI_Allreduce(MPI_IN_PLACE, &face_force, 1, MPI_DOUBLE, MPI_SUM, grid.comm());
  CHECK(face_force == Approx(p_hydro * area).epsilon(1e-12));
}

}  // namespace

TEST_CASE("the stresses' grid acceleration: momentum rate M g, uniform stress in equilibrium", "[transfer][mpi]") {
  check<2>(true);
  check<2>(false);
  check<3>(true);
  check<3>(false);
}
