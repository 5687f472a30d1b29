// P2G and G2P conserve total mass and momentum to round-off, in 2D and 3D,
// for APIC, PIC and FLIP, on one rank and across ranks.
#include <catch2/catch.hpp>
#include <cmath>

#include "talus/particles/seeding.hpp"
#include "talus/transfer/transfer.hpp"
#include "test_support.hpp"

using namespace talus;

namespace {

// A smooth pseudo-random number from an integer key, identical on every rank.
double hashed(long key, int salt) { return std::sin(12.9898 * key + 78.233 * salt) * 0.5; }

template <int dim>
struct Totals {
  double mass = 0;
  Vector<dim> momentum = Vector<dim>::Zero();
};

template <int dim>
Totals<dim> particle_totals(Particles<dim>& particles) {
  Totals<dim> t;
  FieldView<PetscReal> m(particles.swarm(), field::mass), v(particles.swarm(), field::velocity);
  for (PetscInt p = 0; p < particles.local_count(); ++p) {
    t.mass += m[p];
    for (int a = 0; a < dim; ++a) t.momentum[a] += m[p] * v[dim * p + a];
  }
  MPI_Comm comm = PetscObjectComm(reinterpret_cast<PetscObject>(particles.swarm()));
  MPI_Allreduce(MPI_IN_PLACE, &t.mass, 1, MPI_DOUBLE, MPI_SUM, comm);
  MPI_Allreduce(MPI_IN_PLACE, t.momentum.data(), dim, MPI_DOUBLE, MPI_SUM, comm);
  return t;
}

// Sum over owned grid points of m_i and m_i v_i for a ghosted velocity array.
template <int dim>
Totals<dim> grid_totals(const Grid<dim>& grid, const std::vector<double>& mass, const std::vector<double>& velocity) {
  Totals<dim> t;
  for (int i = 0; i < grid.ghosted_count(); ++i) {
    if (!grid.is_owned(grid.global_index(i))) continue;
    t.mass += mass[i];
    for (int a = 0; a < dim; ++a) t.momentum[a] += mass[i] * velocity[dim * i + a];
  }
  MPI_Allreduce(MPI_IN_PLACE, &t.mass, 1, MPI_DOUBLE, MPI_SUM, grid.comm());
  MPI_Allreduce(MPI_IN_PLACE, t.momentum.data(), dim, MPI_DOUBLE, MPI_SUM, grid.comm());
  return t;
}

// Seeds the box [lo, hi] (by default the whole grid box [0, hi]) with 2
// particles per cell and axis, at rest.
template <int dim>
void fill_grid_box(const Grid<dim>& grid, const Vector<dim>& hi, Particles<dim>& particles,
                   const Vector<dim>& lo = Vector<dim>::Zero(), int particles_per_cell = 2, int body_index = 0,
                   std::int64_t first_id = 0) {
  BodyConfig bc;
  bc.box_lower.assign(lo.data(), lo.data() + dim);
  bc.box_upper.assign(hi.data(), hi.data() + dim);
  bc.particles_per_cell = particles_per_cell;
  bc.velocity.assign(dim, 0.0);
  // Any material will do: seeding only reads the density.
  struct Dummy : Material {
    const char* model() const override { return "dummy"; }
    double density() const override { return 1500.0; }
    void update(const Voigt&, const Voigt&, const double*, double*, MaterialPointUpdate&) const override {}
    const Tangent& elastic_stiffness() const override { static Tangent t = Tangent::Identity(); return t; }
    std::string parameters() const override { return "model: dummy"; }
  } dummy;
  seed_body<dim>(particles, grid, bc, dummy, body_index, first_id);
}

template <int dim>
void check_conservation(ShapeKind kind, TransferScheme scheme, double flip_blend,
                        ParticleQuadrature quadrature = ParticleQuadrature::point) {
  Vector<dim> lo = Vector<dim>::Zero(), hi;
  if constexpr (dim == 2) hi << 1.0, 0.8; else hi << 0.6, 0.5, 0.4;
  Grid<dim> grid(PETSC_COMM_WORLD, lo, hi, 0.1, kind, quadrature);
  Particles<dim> particles(grid.comm());
  fill_grid_box(grid, hi, particles);
  // Random masses, velocities and affine velocities, keyed by particle id.
  {
    FieldView<PetscReal> m(particles.swarm(), field::mass), v(particles.swarm(), field::velocity),
        c(particles.swarm(), field::affine_velocity), x(particles.swarm(), field::position),
        F(particles.swarm(), field::deformation_gradient), J(particles.swarm(), field::volume_ratio);
    FieldView<std::int64_t> id(particles.swarm(), field::particle_id);
    for (PetscInt p = 0; p < particles.local_count(); ++p) {
      const long k = static_cast<long>(id[p]);
      m[p] *= 1.0 + hashed(k, 1);
      for (int a = 0; a < dim; ++a) {
        v[dim * p + a] = hashed(k, 2 + a);
        x[dim * p + a] += 0.02 * hashed(k, 9 + a);  // off the regular lattice
      }
      for (int a = 0; a < dim * dim; ++a) c[dim * dim * p + a] = 10.0 * hashed(k, 20 + a);
      // Deformed particles: domains of different sizes and shapes.
      for (int a = 0; a < dim * dim; ++a) F[dim * dim * p + a] += 0.4 * hashed(k, 40 + a);
      J[p] = Eigen::Map<const Eigen::Matrix<double, dim, dim, Eigen::RowMajor>>(F.data() + dim * dim * p).determinant();
    }
  }
  particles.migrate(grid);
  std::vector<Stencil<dim>> stencils;
  compute_stencils(grid, particles, stencils);
  GridFields<dim> fields;
  particles_to_grid(grid, particles, stencils, scheme, fields);

  const Totals<dim> before = particle_totals(particles);
  const Totals<dim> on_grid = grid_totals(grid, fields.mass, fields.velocity);
  // Sums of ~1e3 terms of O(1): relative round-off ~1e-14; 1e-12 leaves a margin.
  CHECK(on_grid.mass == Approx(before.mass).epsilon(1e-12));
  CHECK((on_grid.momentum - before.momentum).norm() <= 1e-12 * before.mass);

  // G2P with a new grid velocity field (consistent on ghosts: keyed by global index).
  std::vector<double> v_new(fields.velocity.size());
  for (int i = 0; i < grid.ghosted_count(); ++i) {
    const auto ijk = grid.global_index(i);
    long key = 0;
    for (int a = dim - 1; a >= 0; --a) key = key * 1000 + ijk[a];
    for (int a = 0; a < dim; ++a) v_new[dim * i + a] = fields.mass[i] > 0 ? hashed(key, 40 + a) : 0.0;
  }
  TransferConfig transfer;
  transfer.scheme = scheme;
  transfer.flip_blend = flip_blend;
  grid_to_particles(particles, stencils, v_new, fields.velocity, fields.velocity, 1e-3, 1.0, transfer);
  const Totals<dim> after = particle_totals(particles);
  const Totals<dim> new_grid = grid_totals(grid, fields.mass, v_new);
  // PIC/APIC: sum_p m_p v_p = sum_i m_i v_i^{n+1}. FLIP adds sum_i m_i (v^{n+1} - v^n)
  // to the old particle momentum, which equals the old grid momentum: same total.
  CHECK((after.momentum - new_grid.momentum).norm() <= 1e-12 * before.mass);
  CHECK(after.mass == Approx(before.mass).epsilon(1e-14));
}

}  // namespace

TEST_CASE("P2G/G2P conserve mass and momentum, quadratic B-splines", "[transfer][mpi]") {
  check_conservation<2>(ShapeKind::quadratic_bspline, TransferScheme::apic, 0.0);
  check_conservation<2>(ShapeKind::quadratic_bspline, TransferScheme::flip, 0.0);
  check_conservation<2>(ShapeKind::quadratic_bspline, TransferScheme::flip, 0.95);
  check_conservation<3>(ShapeKind::quadratic_bspline, TransferScheme::apic, 0.0);
  check_conservation<3>(ShapeKind::quadratic_bspline, TransferScheme::flip, 0.95);
}

TEST_CASE("P2G/G2P conserve mass and momentum, domain quadrature", "[transfer][mpi]") {
  check_conservation<2>(ShapeKind::quadratic_bspline, TransferScheme::apic, 0.0, ParticleQuadrature::domain);
  check_conservation<2>(ShapeKind::quadratic_bspline, TransferScheme::flip, 0.95, ParticleQuadrature::domain);
  check_conservation<3>(ShapeKind::quadratic_bspline, TransferScheme::apic, 0.0, ParticleQuadrature::domain);
  check_conservation<2>(ShapeKind::linear, TransferScheme::apic, 0.0, ParticleQuadrature::domain);
}

TEST_CASE("a particle's domain keeps its volume and follows its stretch", "[transfer]") {
  // Stretches along the axes: r_a = R F_aa (the domains of a lattice stay a
  // tiling); a rotation leaves the reference half-width R; any F: a box of
  // volume J V0; a degenerate F: no domain.
  const double V0 = 0.008, R = 0.1;  // a cube of side 0.2
  Matrix<3> F = Matrix<3>::Zero();
  F.diagonal() << 0.95, 1.2, 0.7;
  const Vector<3> stretched = domain_half_width<3>(V0, F, F.determinant());
  for (int a = 0; a < 3; ++a) CHECK(stretched[a] == Approx(R * F(a, a)).epsilon(1e-14));
  const double c = std::cos(0.7), s = std::sin(0.7);
  Matrix<2> Q;
  Q << c, -s, s, c;
  const Vector<2> rotated = domain_half_width<2>(0.04, Q, Q.determinant());
  CHECK(rotated[0] == Approx(R).epsilon(1e-14));
  CHECK(rotated[1] == Approx(R).epsilon(1e-14));
  Matrix<3> G;
  G << 1.1, 0.3, -0.2, 0.05, 0.9, 0.4, 0.1, -0.3, 1.3;
  const Vector<3> r = domain_half_width<3>(V0, G, G.determinant());
  CHECK(8 * r.prod() == Approx(G.determinant() * V0).epsilon(1e-14));
  // The extents keep the ratios of the rows' lengths (the image of a ball's extents).
  CHECK(r[0] / r[2] == Approx(G.row(0).norm() / G.row(2).norm()).epsilon(1e-14));
  Matrix<2> flat;
  flat << 1.0, 2.0, 0.5, 1.0;
  CHECK(domain_half_width<2>(0.04, flat, flat.determinant()).norm() == 0.0);
}

TEST_CASE("P2G/G2P conserve mass and momentum, linear hats", "[transfer][mpi]") {
  check_conservation<2>(ShapeKind::linear, TransferScheme::apic, 0.0);
  check_conservation<2>(ShapeKind::linear, TransferScheme::flip, 0.95);
  check_conservation<3>(ShapeKind::linear, TransferScheme::apic, 0.0);
}

namespace {

// A step inverts a particle where det(I + h grad v_theta) <= 0. On a linear
// grid velocity field v = G x (coefficients at the Greville points, which
// both bases reproduce exactly) the gradient is G at every particle, so the
// count is all particles or none, switching at the closed-form step where
// det(I + h G) = 0, and G2P's F^{n+1} = (I + h G) F^n has det F <= 0 exactly
// at the particles counted (and so has the volume ratio J it carries).
template <int dim>
void check_inverting_count(ShapeKind kind) {
  Vector<dim> lo = Vector<dim>::Zero(), hi;
  if constexpr (dim == 2) hi << 1.0, 0.8; else hi << 0.6, 0.5, 0.4;
  Grid<dim> grid(PETSC_COMM_WORLD, lo, hi, 0.1, kind, ParticleQuadrature::point);
  Particles<dim> particles(grid.comm());
  fill_grid_box(grid, hi, particles);
  particles.migrate(grid);
  std::vector<Stencil<dim>> stencils;
  compute_stencils(grid, particles, stencils);
  // G: a compression along the last axis (rate -100 1/s) with a shear; the
  // start-of-step field v_old = G_old x stretches along the first axis.
  Matrix<dim> G = Matrix<dim>::Zero(), G_old = Matrix<dim>::Zero();
  G(dim - 1, dim - 1) = -100.0;
  G(0, dim - 1) = 30.0;
  G_old(0, 0) = 20.0;
  std::vector<double> v_new(dim * grid.ghosted_count()), v_old(v_new.size());
  for (int i = 0; i < grid.ghosted_count(); ++i) {
    const Vector<dim> x = grid.point_position(grid.global_index(i));
    Eigen::Map<Vector<dim>>(v_new.data() + dim * i) = G * x;
    Eigen::Map<Vector<dim>>(v_old.data() + dim * i) = G_old * x;
  }
  const long n = particles.local_count();
  long total = 0, local = n;
  MPI_Allreduce(&local, &total, 1, MPI_LONG, MPI_SUM, grid.comm());
  auto count = [&](double h, double theta, const std::vector<char>* skip = nullptr) {
    long mine = count_inverting_particles(stencils, v_new, v_old, h, theta, skip), all = 0;
    MPI_Allreduce(&mine, &all, 1, MPI_LONG, MPI_SUM, grid.comm());
    return all;
  };
  // theta = 1: det(I + h G) = 1 - 100 h; zero at h = 0.01.
  CHECK(count(0.0099, 1.0) == 0);
  CHECK(count(0.0101, 1.0) == total);
  // theta = 1/2: grad v_theta = (G + G_old)/2, det = (1 + 10 h)(1 - 50 h); zero at h = 0.02.
  CHECK(count(0.0199, 0.5) == 0);
  CHECK(count(0.0201, 0.5) == total);
  // Skipped particles (a rigid body's) are not counted.
  std::vector<char> skip(n, 0);
  long skipped = 0;
  for (long p = 0; p < n; p += 3) skip[p] = 1, ++skipped;
  MPI_Allreduce(MPI_IN_PLACE, &skipped, 1, MPI_LONG, MPI_SUM, grid.comm());
  CHECK(count(0.0101, 1.0, &skip) == total - skipped);
  // G2P at h = 0.0101 leaves det F = 1 - 100 h = -0.01 at every particle.
  TransferConfig transfer;
  grid_to_particles(particles, stencils, v_new, v_old, v_old, 0.0101, 1.0, transfer);
  // The volume ratio J, carried as the product of the steps' determinants, too.
  FieldView<PetscReal> F(particles.swarm(), field::deformation_gradient), J(particles.swarm(), field::volume_ratio);
  double worst = 0.0;
  for (long p = 0; p < n; ++p) {
    const double det = Eigen::Map<const Eigen::Matrix<double, dim, dim, Eigen::RowMajor>>(F.data() + dim * dim * p)
                           .determinant();
    worst = std::max({worst, std::abs(det - (1.0 - 100.0 * 0.0101)), std::abs(J[p] - (1.0 - 100.0 * 0.0101))});
  }
  // Gradients of O(100) summed over 9-27 functions: round-off ~1e-13 relative to h G.
  CHECK(worst < 1e-12);
}

}  // namespace

TEST_CASE("a step that would invert particles is counted", "[transfer][mpi]") {
  check_inverting_count<2>(ShapeKind::quadratic_bspline);
  check_inverting_count<3>(ShapeKind::quadratic_bspline);
  check_inverting_count<2>(ShapeKind::linear);
}

namespace {

// Per axis, the packing of a lattice of 2 particles per cell on the whole
// axis: the quarter-point rule integrates every function whose knots are
// uniform exactly (the quadratic B-spline's errors on its three spans, in
// proportion to its second derivative's jumps 1, -2, 1, cancel), but not the
// two clamped functions at a face: int (1 - u)^2 over [0, 1] is 1/3 and the
// rule gives ((3/4)^2 + (1/4)^2)/2 = 5/16, so the face function reads
// (5/16)/(1/3) = 15/16 and its neighbour, which takes up the rest of the cell
// (partition of unity), (1 - 5/16)/(2/3) = 33/32. Hats are linear: exact.
double axis_packing(ShapeKind kind, int i, int cells) {
  if (kind == ShapeKind::linear) return 1.0;
  if (i == 0 || i == cells + 1) return 15.0 / 16.0;
  if (i == 1 || i == cells) return 33.0 / 32.0;
  return 1.0;
}

template <int dim>
double owned_max(const Grid<dim>& grid, const std::vector<double>& values) {
  double largest = -1e300;
  for (int i = 0; i < grid.ghosted_count(); ++i)
    if (grid.is_owned(grid.global_index(i))) largest = std::max(largest, values[i]);
  MPI_Allreduce(MPI_IN_PLACE, &largest, 1, MPI_DOUBLE, MPI_MAX, grid.comm());
  return largest;
}

// The packing of a lattice that fills the grid box is the product of the
// axes' closed forms above, times the particles' volume ratio (capped at 2),
// when particle_packing is not told the lattice; told it (n = 2 or 3 per
// cell), it divides by the lattice's rule and reads min(J, 2) everywhere but
// at an open face, whose functions read 0.
template <int dim>
void check_packing_closed_form(ShapeKind kind) {
  Vector<dim> hi;
  if constexpr (dim == 2) hi << 1.0, 0.8; else hi << 0.6, 0.5, 0.4;
  Grid<dim> grid(PETSC_COMM_WORLD, Vector<dim>::Zero(), hi, 0.1, kind, ParticleQuadrature::point);
  for (const int n : {2, 3}) {
    Particles<dim> particles(grid.comm());
    fill_grid_box(grid, hi, particles, Vector<dim>(Vector<dim>::Zero()), n);
    particles.migrate(grid);
    std::vector<Stencil<dim>> stencils;
    compute_stencils(grid, particles, stencils);
    for (const double J : {1.0, 1.5, 3.0}) {
      {
        FieldView<PetscReal> ratio(particles.swarm(), field::volume_ratio);
        for (PetscInt p = 0; p < particles.local_count(); ++p) ratio[p] = J;
      }
      const std::vector<double> packing = particle_packing(grid, particles, stencils);
      const std::vector<double> on_lattice = particle_packing(grid, particles, stencils, {n});
      double worst = 0.0, worst_on_lattice = 0.0;
      for (int i = 0; i < grid.ghosted_count(); ++i) {
        const auto ijk = grid.global_index(i);
        double expected = std::min(J, 2.0);
        if (n == 2)
          for (int a = 0; a < dim; ++a) expected *= axis_packing(kind, ijk[a], grid.cells()[a]);
        if (n == 2) worst = std::max(worst, std::abs(packing[i] - expected));
        worst_on_lattice = std::max(worst_on_lattice, std::abs(on_lattice[i] - std::min(J, 2.0)));
      }
      // An open x_max face: its functions read 0, the others as before.
      std::array<bool, 2 * dim> open{};
      open[1] = true;
      const std::vector<double> open_x = particle_packing(grid, particles, stencils, {n}, open);
      const int at_face = kind == ShapeKind::linear ? 1 : 2;
      for (int i = 0; i < grid.ghosted_count(); ++i) {
        const bool ends_there = grid.global_index(i)[0] >= grid.points()[0] - at_face;
        worst_on_lattice = std::max(worst_on_lattice, std::abs(open_x[i] - (ends_there ? 0.0 : on_lattice[i])));
      }
      MPI_Allreduce(MPI_IN_PLACE, &worst, 1, MPI_DOUBLE, MPI_MAX, grid.comm());
      MPI_Allreduce(MPI_IN_PLACE, &worst_on_lattice, 1, MPI_DOUBLE, MPI_MAX, grid.comm());
      // Sums of 4-27 weights per particle over up to 216 particles: round-off ~1e-15.
      CHECK(worst < 1e-12);
      CHECK(worst_on_lattice < 1e-12);
    }
  }
}

// The lattice's rule on one axis against its closed form: the midpoint rule
// with n points per cell on int_0^1 (1 - u)^2 du = 1/3 gives
// (1/n^3) sum_m (m + 1/2)^2 = 1/3 - 1/(12 n^2), so 1 - 1/(4 n^2) of it; the
// face's second function takes up the rest of the first cell (partition of
// unity; the third function's share there, u^2/2, is short by as much as
// (1 - u)^2 / 2 is) and is exact on its other spans: 1 + 1/(8 n^2).
template <int dim>
void check_lattice_rule() {
  for (const int n : {1, 2, 3, 5})
    for (const int cells : {3, 4, 9}) {
      const std::vector<double> r = lattice_rule_ratio(ShapeKind::quadratic_bspline, cells, n);
      REQUIRE(static_cast<int>(r.size()) == cells + 2);
      for (int i = 0; i < cells + 2; ++i) {
        const int from_face = std::min(i, cells + 1 - i);
        const double expected = from_face == 0 ? 1.0 - 0.25 / (n * n) : from_face == 1 ? 1.0 + 0.125 / (n * n) : 1.0;
        CHECK(r[i] == Approx(expected).epsilon(1e-13));
      }
      for (const double x : lattice_rule_ratio(ShapeKind::linear, cells, n)) CHECK(x == Approx(1.0).epsilon(1e-13));
    }
}

// The shift moves a particle down the gradient of the crowding. On a
// synthetic packing P_i = 1.05 + c + a . x_i (x_i the Greville points) the
// crowding is the linear field c + a . x, which both bases reproduce, so
// sum_i (P_i - 1.05) grad N_ip = a and every particle moves by exactly
// -rate h^2 a; gravity's work on the shift is -sum_p m_p g . dx_p.
template <int dim>
void check_shift_closed_form(ShapeKind kind) {
  Vector<dim> hi;
  if constexpr (dim == 2) hi << 1.0, 0.8; else hi << 0.6, 0.5, 0.4;
  const double h = 0.1, rate = 0.25;
  Grid<dim> grid(PETSC_COMM_WORLD, Vector<dim>::Zero(), hi, h, kind, ParticleQuadrature::point);
  Particles<dim> particles(grid.comm());
  fill_grid_box(grid, hi, particles);
  particles.migrate(grid);
  std::vector<Stencil<dim>> stencils;
  compute_stencils(grid, particles, stencils);
  Vector<dim> a = Vector<dim>::LinSpaced(0.3, 0.7), g = Vector<dim>::Zero();
  g[dim - 1] = -9.81;
  std::vector<double> packing(grid.ghosted_count());
  for (int i = 0; i < grid.ghosted_count(); ++i)
    packing[i] = 1.05 + 0.2 + a.dot(grid.point_position(grid.global_index(i)));
  const PetscInt n = particles.local_count();
  std::vector<double> x0(dim * n), u0(dim * n);
  double mass = 0.0;
  {
    FieldView<PetscReal> x(particles.swarm(), field::position), u(particles.swarm(), field::displacement),
        m(particles.swarm(), field::mass);
    std::copy(x.data(), x.data() + dim * n, x0.begin());
    std::copy(u.data(), u.data() + dim * n, u0.begin());
    for (PetscInt p = 0; p < n; ++p) mass += m[p];
  }
  double largest = 0.0;
  double work = correct_packing(particles, stencils, packing, grid, rate, g, largest);
  MPI_Allreduce(MPI_IN_PLACE, &work, 1, MPI_DOUBLE, MPI_SUM, grid.comm());
  MPI_Allreduce(MPI_IN_PLACE, &mass, 1, MPI_DOUBLE, MPI_SUM, grid.comm());
  const Vector<dim> expected = -rate * h * h * a;
  double worst = 0.0;
  {
    FieldView<PetscReal> x(particles.swarm(), field::position), u(particles.swarm(), field::displacement);
    for (PetscInt p = 0; p < n; ++p)
      for (int k = 0; k < dim; ++k) {
        worst = std::max(worst, std::abs(x[dim * p + k] - x0[dim * p + k] - expected[k]));
        worst = std::max(worst, std::abs(u[dim * p + k] - u0[dim * p + k] - expected[k]));
      }
  }
  MPI_Allreduce(MPI_IN_PLACE, &worst, 1, MPI_DOUBLE, MPI_MAX, grid.comm());
  // Shifts of 1e-3 m from gradients of O(10) 1/m summed over 9-27 functions.
  CHECK(worst < 1e-15 * 1e3);
  CHECK(largest == Approx(expected.norm()).epsilon(1e-10));
  CHECK(work == Approx(-mass * g.dot(expected)).epsilon(1e-10));

  // After a restricted shift, the particles whose stencil reaches a node
  // with `reaches` moved by `restricted(expected)`, the others as before.
  const auto reset = [&]() {
    FieldView<PetscReal> x(particles.swarm(), field::position), u(particles.swarm(), field::displacement);
    std::copy(x0.begin(), x0.end(), x.data());
    std::copy(u0.begin(), u0.end(), u.data());
  };
  const auto check_restricted = [&](auto reaches_node, auto restricted) {
    double off = 0.0;
    long along = 0, free = 0;
    {
      FieldView<PetscReal> x(particles.swarm(), field::position);
      for (PetscInt p = 0; p < n; ++p) {
        bool reaches = false;
        for (int k = 0; k < stencils[p].count; ++k) reaches = reaches || reaches_node(stencils[p].node[k]);
        ++(reaches ? along : free);
        const Vector<dim> e = reaches ? restricted(expected) : expected;
        for (int k = 0; k < dim; ++k) off = std::max(off, std::abs(x[dim * p + k] - x0[dim * p + k] - e[k]));
      }
    }
    MPI_Allreduce(MPI_IN_PLACE, &off, 1, MPI_DOUBLE, MPI_MAX, grid.comm());
    MPI_Allreduce(MPI_IN_PLACE, &along, 1, MPI_LONG, MPI_SUM, grid.comm());
    MPI_Allreduce(MPI_IN_PLACE, &free, 1, MPI_LONG, MPI_SUM, grid.comm());
    CHECK(off < 1e-15 * 1e3);
    CHECK(along > 0);
    CHECK(free > 0);
  };

  // With a contact floor (y_min, or z_min in 3D), the particles whose
  // stencils reach its functions (the first cell and a half above it for
  // the B-splines, the first cell for the hats) move along it only: the same
  // shift without its vertical component; the others as before.
  reset();
  std::array<bool, 2 * dim> contact{};
  contact[2 * (dim - 1)] = true;
  correct_packing(particles, stencils, packing, grid, rate, g, largest, nullptr, contact);
  const int at_face = kind == ShapeKind::linear ? 1 : 2;
  check_restricted([&](const auto& node) { return node[dim - 1] < at_face; },
                   [](Vector<dim> e) {
                     e[dim - 1] = 0.0;
                     return e;
                   });

  // With contact points of an obstacle or another body (a slanted normal n
  // at the nodes of the first four columns), the particles whose stencils
  // reach one move without the shift's component along n; the others as
  // before.
  reset();
  const Vector<dim> normal = Vector<dim>::LinSpaced(1.0, 2.0).normalized();
  std::vector<double> normals(static_cast<std::size_t>(dim) * grid.ghosted_count(), 0.0);
  for (int i = 0; i < grid.ghosted_count(); ++i)
    if (grid.global_index(i)[0] < 4) Eigen::Map<Vector<dim>>(normals.data() + dim * i) = normal;
  correct_packing(particles, stencils, packing, grid, rate, g, largest, nullptr, {}, &normals);
  check_restricted([](const auto& node) { return node[0] < 4; },
                   [&](const Vector<dim>& e) { return Vector<dim>(e - e.dot(normal) * normal); });
}

// A block whose particles were crowded into 0.8 of their space per axis
// (2D: packing 1.56) inside a larger empty box: repeated shifts spread it
// until no point is crowded beyond the 5 % tolerance, the block's extent
// grows by the factor its volume asks, and a body that is not crowded (the
// lattice as seeded, packing at most 33/32) does not move at all.
// Bodies in contact each read their own packing: a second lattice seeded on
// the lower half of the first reads 2 there on one field (the space holds
// twice its volume) and at most 1 on each of two fields, so the correction
// never pushes two bodies apart across their contact (which closes on their
// particles' gap); on one field it would (the crowding's gradient at the
// second lattice's top moves its particles by about rate h (P - 1.05) = 0.02).
template <int dim>
void check_packing_per_field() {
  Vector<dim> hi, half;
  if constexpr (dim == 2) hi << 1.0, 0.8; else hi << 0.6, 0.5, 0.4;
  half = hi;
  half[dim - 1] *= 0.5;
  Grid<dim> grid(PETSC_COMM_WORLD, Vector<dim>::Zero(), hi, 0.1, ShapeKind::quadratic_bspline,
                 ParticleQuadrature::point);
  Particles<dim> particles(grid.comm());
  fill_grid_box(grid, hi, particles, Vector<dim>(Vector<dim>::Zero()), 2, 0, 0);
  fill_grid_box(grid, half, particles, Vector<dim>(Vector<dim>::Zero()), 2, 1, 1000000);
  particles.migrate(grid);
  std::vector<Stencil<dim>> together, apart;
  compute_stencils(grid, particles, together);
  compute_stencils(grid, particles, apart, {0, 1});
  const std::vector<double> one_field = particle_packing(grid, particles, together, {2, 2});
  const std::vector<double> two_fields = particle_packing(grid, particles, apart, {2, 2}, {}, 2);
  const int points = grid.ghosted_count();
  REQUIRE(static_cast<int>(two_fields.size()) == 2 * points);
  double first = 0.0, second = 0.0;
  for (int i = 0; i < points; ++i) {
    first = std::max(first, std::abs(two_fields[i] - 1.0));
    second = std::max(second, two_fields[points + i]);
  }
  MPI_Allreduce(MPI_IN_PLACE, &first, 1, MPI_DOUBLE, MPI_MAX, grid.comm());
  MPI_Allreduce(MPI_IN_PLACE, &second, 1, MPI_DOUBLE, MPI_MAX, grid.comm());
  CHECK(first < 1e-12);
  CHECK(second < 1.0 + 1e-12);
  CHECK(std::abs(owned_max(grid, one_field) - 2.0) < 1e-12);
  double largest = 0.0;
  correct_packing<dim>(particles, apart, two_fields, grid, 0.25, Vector<dim>::Zero(), largest);
  MPI_Allreduce(MPI_IN_PLACE, &largest, 1, MPI_DOUBLE, MPI_MAX, grid.comm());
  CHECK(largest == 0.0);
  correct_packing<dim>(particles, together, one_field, grid, 0.25, Vector<dim>::Zero(), largest);
  MPI_Allreduce(MPI_IN_PLACE, &largest, 1, MPI_DOUBLE, MPI_MAX, grid.comm());
  CHECK(largest > 0.01);
}

template <int dim>
void check_crowded_block_relaxes(double rate) {
  Vector<dim> hi, lo, top;
  if constexpr (dim == 2) hi << 2.0, 2.0; else hi << 1.2, 1.2, 1.2;
  const double h = 0.1;
  lo.setConstant(0.5 * hi[0] - 0.3);
  top.setConstant(0.5 * hi[0] + 0.3);
  Grid<dim> grid(PETSC_COMM_WORLD, Vector<dim>::Zero(), hi, h, ShapeKind::quadratic_bspline,
                 ParticleQuadrature::point);
  Particles<dim> particles(grid.comm());
  fill_grid_box(grid, top, particles, lo);
  const Vector<dim> centre = 0.5 * (lo + top);
  std::vector<Stencil<dim>> stencils;
  auto extent = [&]() {
    FieldView<PetscReal> x(particles.swarm(), field::position);
    double reach = 0.0;
    for (PetscInt p = 0; p < particles.local_count(); ++p)
      reach = std::max(reach, (Eigen::Map<const Vector<dim>>(x.data() + dim * p) - centre).cwiseAbs().maxCoeff());
    MPI_Allreduce(MPI_IN_PLACE, &reach, 1, MPI_DOUBLE, MPI_MAX, grid.comm());
    return reach;
  };
  auto shift_once = [&]() {
    compute_stencils(grid, particles, stencils);
    const std::vector<double> packing = particle_packing(grid, particles, stencils);
    double largest = 0.0;
    correct_packing<dim>(particles, stencils, packing, grid, rate, Vector<dim>::Zero(), largest);
    MPI_Allreduce(MPI_IN_PLACE, &largest, 1, MPI_DOUBLE, MPI_MAX, grid.comm());
    particles.migrate(grid);
    return std::pair<double, double>(owned_max(grid, packing), largest);
  };
  particles.migrate(grid);
  // As seeded: nothing moves.
  const double seeded = extent();
  CHECK(shift_once().second == 0.0);
  CHECK(extent() == seeded);
  // Crowd it: positions 0.8 of the way from the centre, volumes unchanged.
  {
    FieldView<PetscReal> x(particles.swarm(), field::position);
    for (PetscInt p = 0; p < particles.local_count(); ++p) {
      Eigen::Map<Vector<dim>> xp(x.data() + dim * p);
      xp = centre + 0.8 * (xp - centre);
    }
  }
  particles.migrate(grid);
  const double crowded = extent();
  double first = 0.0, last = 0.0;
  for (int k = 0; k < 400; ++k) {
    const auto [most, largest] = shift_once();
    if (k == 0) first = most;
    last = most;
    // Stable: no particle jumps half a cell in one application (the first
    // ones move the block's edge by 0.2-0.4 h at rate 1).
    CHECK(largest < 0.5 * h);
  }
  INFO("rate " << rate << ": largest packing " << first << " -> " << last << ", extent " << crowded << " -> "
               << extent() << " (seeded " << seeded << ")");
  CHECK(first > 1.4);
  CHECK(last < 1.05 + 0.03);
  // The block spreads back towards the extent of its volume.
  CHECK(extent() > crowded + 0.5 * (seeded - crowded));
}

}  // namespace

TEST_CASE("the packing of a lattice filling the grid has its closed form", "[transfer][packing][mpi]") {
  check_packing_closed_form<2>(ShapeKind::quadratic_bspline);
  check_packing_closed_form<3>(ShapeKind::quadratic_bspline);
  check_packing_closed_form<2>(ShapeKind::linear);
  check_packing_closed_form<3>(ShapeKind::linear);
}

TEST_CASE("bodies in contact each read their own packing", "[transfer][packing][mpi]") {
  check_packing_per_field<2>();
  check_packing_per_field<3>();
}

TEST_CASE("a lattice's rule on the grid functions' integrals has its closed form", "[transfer][packing]") {
  check_lattice_rule<2>();
}

TEST_CASE("the packing correction moves particles down the crowding's gradient", "[transfer][packing][mpi]") {
  check_shift_closed_form<2>(ShapeKind::quadratic_bspline);
  check_shift_closed_form<3>(ShapeKind::quadratic_bspline);
  check_shift_closed_form<2>(ShapeKind::linear);
}

TEST_CASE("a crowded block spreads until its packing is within the tolerance", "[transfer][packing][mpi]") {
  check_crowded_block_relaxes<2>(0.25);
  check_crowded_block_relaxes<2>(1.0);
  check_crowded_block_relaxes<3>(0.25);
}
