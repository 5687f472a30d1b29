#include "talus/transfer/transfer.hpp"

#include <limits>

namespace talus {

namespace {

// The ranks' sums on a ghosted DMDA vector: every rank's contributions added
// into the owned points, then copied back to the ghost points.
void sum_over_ranks(DM da, Vec local, Vec global) {
  TALUS_PETSC(DMLocalToGlobalBegin(da, local, ADD_VALUES, global));
  TALUS_PETSC(DMLocalToGlobalEnd(da, local, ADD_VALUES, global));
  TALUS_PETSC(DMGlobalToLocalBegin(da, global, INSERT_VALUES, local));
  TALUS_PETSC(DMGlobalToLocalEnd(da, global, INSERT_VALUES, local));
}

}  // namespace

template <int dim>
Vector<dim> domain_half_width(double initial_volume, const Matrix<dim>& F, double J) {
  // The reference domain is a cube of the particle's initial volume. Its
  // current extent along axis a is taken as that of the image of a ball,
  // R |F^T e_a| (exact under stretches along the axes, unchanged by a
  // rotation), scaled so that the box keeps the particle's volume J V0.
  const double R = 0.5 * std::pow(initial_volume, 1.0 / dim);
  Vector<dim> r;
  double product = 1.0;
  for (int a = 0; a < dim; ++a) {
    r[a] = F.row(a).norm();
    product *= r[a];
  }
  if (!(J > 0.0) || !(product > 0.0)) return Vector<dim>::Zero();  // a degenerate particle: point quadrature
  return R * std::pow(J / product, 1.0 / dim) * r;
}

template <int dim>
void compute_stencils(const Grid<dim>& grid, const Particles<dim>& particles, std::vector<Stencil<dim>>& stencils,
                      const std::vector<int>& body_field) {
  const PetscInt n = particles.local_count();
  stencils.resize(n);
  FieldView<PetscReal> x(particles.swarm(), field::position);
  if (grid.quadrature() == ParticleQuadrature::domain) {
    FieldView<PetscReal> F(particles.swarm(), field::deformation_gradient), V0(particles.swarm(), field::initial_volume),
        J(particles.swarm(), field::volume_ratio);
    for (PetscInt p = 0; p < n; ++p) {
      const Vector<dim> r = domain_half_width<dim>(
          V0[p], Eigen::Map<const Eigen::Matrix<double, dim, dim, Eigen::RowMajor>>(F.data() + dim * dim * p), J[p]);
      grid.stencil(Eigen::Map<const Vector<dim>>(x.data() + dim * p), stencils[p], &r);
    }
  } else {
    for (PetscInt p = 0; p < n; ++p) grid.stencil(Eigen::Map<const Vector<dim>>(x.data() + dim * p), stencils[p]);
  }
  if (body_field.empty()) return;
  FieldView<PetscInt> body(particles.swarm(), field::body_id);
  const int points = grid.ghosted_count();
  for (PetscInt p = 0; p < n; ++p) {
    const int offset = body_field[body[p]] * points;
    Stencil<dim>& st = stencils[p];
    for (int k = 0; k < st.count; ++k) st.local[k] += offset;
  }
}

template <int dim>
void particles_to_grid(const Grid<dim>& grid, const Particles<dim>& particles,
                       const std::vector<Stencil<dim>>& stencils, TransferScheme scheme, GridFields<dim>& out,
                       int field_count) {
  constexpr int bs = dim + 1;  // (m, m v) per grid point
  DM da = grid.mass_momentum_dm();
  const int n = grid.ghosted_count();
  out.field_count = field_count;
  out.points = n;
  out.mass.assign(static_cast<std::size_t>(n) * field_count, 0.0);
  out.velocity.assign(static_cast<std::size_t>(n) * field_count * dim, 0.0);
  Vec local, global;
  TALUS_PETSC(DMGetLocalVector(da, &local));
  TALUS_PETSC(DMGetGlobalVector(da, &global));
  // One pass over the DMDA per field: its particles' sums (the stencil's
  // node index less the field's offset is the ghosted point).
  for (int field = 0; field < field_count; ++field) {
    TALUS_PETSC(VecZeroEntries(local));
    TALUS_PETSC(VecZeroEntries(global));
    const int offset = field * n;
    {
      PetscScalar* g;
      TALUS_PETSC(VecGetArray(local, &g));
      DM sw = particles.swarm();
      FieldView<PetscReal> x(sw, field::position), v(sw, field::velocity), c(sw, field::affine_velocity),
          m(sw, field::mass);
      const PetscInt np = particles.local_count();
      const bool apic = scheme == TransferScheme::apic;
      const bool domain = grid.quadrature() == ParticleQuadrature::domain;
      for (PetscInt p = 0; p < np; ++p) {
        const Stencil<dim>& st = stencils[p];
        if (field_count > 1 && st.local[0] / n != field) continue;
        const Eigen::Map<const Vector<dim>> vp(v.data() + dim * p);
        const Eigen::Map<const Eigen::Matrix<double, dim, dim, Eigen::RowMajor>> cp(c.data() + dim * dim * p);
        // The affine velocity is taken about the stencil's centre sum_i S_i x_i,
        // so that it adds no momentum: the particle's position with point
        // quadrature; with domain quadrature the centre of its domain, which
        // differs where the domain is clipped at the grid's faces.
        Vector<dim> centre = Eigen::Map<const Vector<dim>>(x.data() + dim * p);
        if (apic && domain) {
          centre.setZero();
          for (int k = 0; k < st.count; ++k) centre += st.weight[k] * grid.point_position(st.node[k]);
        }
        for (int k = 0; k < st.count; ++k) {
          const double w = m[p] * st.weight[k];
          PetscScalar* node = g + bs * (st.local[k] - offset);
          node[0] += w;
          Vector<dim> momentum = w * vp;
          if (apic) momentum += w * (cp * (grid.point_position(st.node[k]) - centre));
          for (int a = 0; a < dim; ++a) node[1 + a] += momentum[a];
        }
      }
      TALUS_PETSC(VecRestoreArray(local, &g));
    }
    sum_over_ranks(da, local, global);
    {
      const PetscScalar* g;
      TALUS_PETSC(VecGetArrayRead(local, &g));
      for (int i = 0; i < n; ++i) {
        const double mi = g[bs * i];
        const std::size_t node = static_cast<std::size_t>(offset + i);
        out.mass[node] = mi;
        if (mi > 0)
          for (int a = 0; a < dim; ++a) out.velocity[dim * node + a] = g[bs * i + 1 + a] / mi;
      }
      TALUS_PETSC(VecRestoreArrayRead(local, &g));
    }
  }
  TALUS_PETSC(DMRestoreGlobalVector(da, &global));
  TALUS_PETSC(DMRestoreLocalVector(da, &local));
}

template <int dim>
std::vector<double> stress_acceleration(const Grid<dim>& grid, const Particles<dim>& particles,
                                        const std::vector<Stencil<dim>>& stencils, const GridFields<dim>& fields,
                                        const Vector<dim>& gravity) {
  constexpr int bs = dim + 1;  // the P2G layout (m, m v); the force in the last dim slots
  DM da = grid.mass_momentum_dm();
  const int n = grid.ghosted_count();
  std::vector<double> acceleration(fields.mass.size() * dim, std::numeric_limits<double>::quiet_NaN());
  Vec local, global;
  TALUS_PETSC(DMGetLocalVector(da, &local));
  TALUS_PETSC(DMGetGlobalVector(da, &global));
  DM sw = particles.swarm();
  FieldView<PetscReal> s(sw, field::stress), v0(sw, field::initial_volume);
  for (int field = 0; field < fields.field_count; ++field) {
    TALUS_PETSC(VecZeroEntries(local));
    TALUS_PETSC(VecZeroEntries(global));
    const int offset = field * n;
    PetscScalar* g;
    TALUS_PETSC(VecGetArray(local, &g));
    for (std::size_t p = 0; p < stencils.size(); ++p) {
      const Stencil<dim>& st = stencils[p];
      if (st.count == 0 || (fields.field_count > 1 && st.local[0] / n != field)) continue;
      const Matrix<dim> tau =
          voigt_to_tensor(Eigen::Map<const Voigt>(s.data() + 6 * p)).template topLeftCorner<dim, dim>();
      for (int k = 0; k < st.count; ++k) {
        const Vector<dim> f = v0[p] * (tau * st.gradient[k]);
        for (int a = 0; a < dim; ++a) g[bs * (st.local[k] - offset) + 1 + a] += f[a];
      }
    }
    TALUS_PETSC(VecRestoreArray(local, &g));
    sum_over_ranks(da, local, global);
    const PetscScalar* sums;
    TALUS_PETSC(VecGetArrayRead(local, &sums));
    for (int i = 0; i < n; ++i) {
      const std::size_t node = static_cast<std::size_t>(offset + i);
      const double m = fields.mass[node];
      if (m > 0)
        for (int a = 0; a < dim; ++a) acceleration[dim * node + a] = gravity[a] - sums[bs * i + 1 + a] / m;
    }
    TALUS_PETSC(VecRestoreArrayRead(local, &sums));
  }
  TALUS_PETSC(DMRestoreGlobalVector(da, &global));
  TALUS_PETSC(DMRestoreLocalVector(da, &local));
  return acceleration;
}

template <int dim>
void grid_to_particles(Particles<dim>& particles, const std::vector<Stencil<dim>>& stencils,
                       const std::vector<double>& v_new, const std::vector<double>& v_old,
                       const std::vector<double>& v_p2g, double h, double theta, const TransferConfig& transfer,
                       const std::vector<char>* skip) {
  using RowMat = Eigen::Matrix<double, dim, dim, Eigen::RowMajor>;
  DM sw = particles.swarm();
  FieldView<PetscReal> x(sw, field::position), v(sw, field::velocity), c(sw, field::affine_velocity),
      u(sw, field::displacement), F(sw, field::deformation_gradient), J(sw, field::volume_ratio);
  const PetscInt np = particles.local_count();
  const bool apic = transfer.scheme == TransferScheme::apic;
  const double blend = transfer.flip_blend;
  for (PetscInt p = 0; p < np; ++p) {
    if (skip && (*skip)[p]) continue;
    const Stencil<dim>& st = stencils[p];
    Vector<dim> v_end = Vector<dim>::Zero(), v_theta = Vector<dim>::Zero(), dv = Vector<dim>::Zero();
    Matrix<dim> grad_end = Matrix<dim>::Zero(), grad_theta = Matrix<dim>::Zero();
    for (int k = 0; k < st.count; ++k) {
      const std::size_t o = static_cast<std::size_t>(dim) * st.local[k];
      const Eigen::Map<const Vector<dim>> vn(v_new.data() + o), vo(v_old.data() + o), vg(v_p2g.data() + o);
      const Vector<dim> vt = theta * vn + (1.0 - theta) * vo;
      v_end += st.weight[k] * vn;
      v_theta += st.weight[k] * vt;
      dv += st.weight[k] * (vn - vg);
      grad_end += vn * st.gradient[k].transpose();
      grad_theta += vt * st.gradient[k].transpose();
    }
    Eigen::Map<Vector<dim>> xp(x.data() + dim * p), vp(v.data() + dim * p), up(u.data() + dim * p);
    Eigen::Map<RowMat> cp(c.data() + dim * dim * p), Fp(F.data() + dim * dim * p);
    xp += h * v_theta;
    up += h * v_theta;
    if (apic) {
      vp = v_end;
      cp = grad_end;
    } else {
      vp = blend * (vp + dv) + (1.0 - blend) * v_end;
    }
    const Matrix<dim> dF = Matrix<dim>::Identity() + h * grad_theta;
    Fp = dF * Fp;
    J[p] *= dF.determinant();
  }
}

template <int dim>
long count_inverting_particles(const std::vector<Stencil<dim>>& stencils, const std::vector<double>& v_new,
                               const std::vector<double>& v_old, double h, double theta,
                               const std::vector<char>* skip) {
  long inverting = 0;
  for (std::size_t p = 0; p < stencils.size(); ++p) {
    if (skip && (*skip)[p]) continue;
    const Stencil<dim>& st = stencils[p];
    Matrix<dim> grad_theta = Matrix<dim>::Zero();
    for (int k = 0; k < st.count; ++k) {
      const std::size_t o = static_cast<std::size_t>(dim) * st.local[k];
      const Vector<dim> vt = theta * Eigen::Map<const Vector<dim>>(v_new.data() + o) +
                             (1.0 - theta) * Eigen::Map<const Vector<dim>>(v_old.data() + o);
      grad_theta += vt * st.gradient[k].transpose();
    }
    inverting += !((Matrix<dim>::Identity() + h * grad_theta).determinant() > 0.0);
  }
  return inverting;
}

// The largest volume ratio the packing counts (docs/transfers.md#packing).
constexpr double kPackingVolumeRatioCap = 2.0;

namespace {

// Whether grid function `index` of `axis` ends at one of the listed faces
// (x_min, x_max, y_min, ...): the two clamped B-splines or the hat there.
template <int dim>
bool ends_at_face(const Grid<dim>& grid, const std::array<bool, 2 * dim>& faces, int axis, int index) {
  const int at_face = grid.shape() == ShapeKind::linear ? 1 : 2;
  return (faces[2 * axis] && index < at_face) || (faces[2 * axis + 1] && index >= grid.points()[axis] - at_face);
}

}  // namespace

template <int dim>
std::vector<double> particle_packing(const Grid<dim>& grid, const Particles<dim>& particles,
                                     const std::vector<Stencil<dim>>& stencils, const std::vector<int>& lattice,
                                     const std::array<bool, 2 * dim>& open_faces, int field_count) {
  const int points = grid.ghosted_count();
  std::vector<double> packing(static_cast<std::size_t>(field_count) * points, 0.0);
  // Per body seeded on a lattice, per axis: its rule's ratio to the exact
  // integrals, by which its particles' weights are divided, so that a body as
  // seeded reads 1 at a face too (15/16 and 33/32 per axis there otherwise,
  // 33/32 squared = 1.063 at a corner: above the tolerance). Domain
  // quadrature integrates exactly.
  std::vector<std::array<std::vector<double>, dim>> rule(lattice.size());
  if (grid.quadrature() == ParticleQuadrature::point)
    for (std::size_t b = 0; b < lattice.size(); ++b)
      if (lattice[b] > 0)
        for (int a = 0; a < dim; ++a) rule[b][a] = lattice_rule_ratio(grid.shape(), grid.cells()[a], lattice[b]);
  {
    FieldView<PetscReal> V0(particles.swarm(), field::initial_volume), J(particles.swarm(), field::volume_ratio);
    FieldView<PetscInt> body(particles.swarm(), field::body_id);
    for (std::size_t p = 0; p < stencils.size(); ++p) {
      const Stencil<dim>& st = stencils[p];
      // The volume, but at most twice the reference volume: a particle flung
      // clear of the body keeps the affine velocity C_p of APIC, whose trace
      // expands it at every step (J of 1e19 and more in the a = 8 column,
      // docs/transfers.md#packing); its volume would push its neighbours away.
      const double volume = V0[p] * std::min(J[p], kPackingVolumeRatioCap);
      const std::size_t b = static_cast<std::size_t>(body[p]);
      const bool on_lattice = b < rule.size() && !rule[b][0].empty();
      // With bodies in contact the stencil indexes its body's field: each
      // body reads its own packing, so that two bodies pressed together by
      // their contact (which closes on their particles' gap) are not read as
      // crowding and pushed apart across it.
      for (int k = 0; k < st.count; ++k) {
        double weight = st.weight[k];
        if (on_lattice)
          for (int a = 0; a < dim; ++a) weight /= rule[b][a][st.node[k][a]];
        packing[st.local[k]] += volume * weight;
      }
    }
  }
  packing = grid.sum_over_ranks(packing, field_count, 1);
  const double cell_volume = std::pow(grid.cell_size(), dim);
  // The functions that end at an open face (two B-splines, one hat) see the
  // material leaving through it as crowding: it is not counted, so the
  // correction never holds a body back from an open face.
  for (int i = 0; i < points; ++i) {
    const std::array<int, dim> ijk = grid.global_index(i);
    bool leaving = false;
    for (int a = 0; a < dim; ++a) leaving = leaving || ends_at_face(grid, open_faces, a, ijk[a]);
    double capacity = cell_volume;
    for (int a = 0; a < dim; ++a) capacity *= basis_integral(grid.shape(), ijk[a], grid.cells()[a]);
    for (int f = 0; f < field_count; ++f) {
      double& node = packing[static_cast<std::size_t>(f) * points + i];
      node = leaving ? 0.0 : node / capacity;
    }
  }
  return packing;
}

// Crowding below 5 % is left alone: particles that the flow has disordered
// read a few per cent either way, and particles not seeded on a lattice (read
// from a file) up to 1/32 per axis more at a face's second B-spline.
constexpr double kPackingTolerance = 0.05;

template <int dim>
double correct_packing(Particles<dim>& particles, const std::vector<Stencil<dim>>& stencils,
                       const std::vector<double>& packing, const Grid<dim>& grid, double rate,
                       const Vector<dim>& gravity, double& largest_shift, const std::vector<char>* skip,
                       const std::array<bool, 2 * dim>& contact_faces, const std::vector<double>* contact_normals) {
  DM sw = particles.swarm();
  FieldView<PetscReal> x(sw, field::position), u(sw, field::displacement), m(sw, field::mass);
  const double scale = rate * grid.cell_size() * grid.cell_size();
  // A particle whose stencil reaches the functions that end at a contact
  // face (two B-splines, one hat), or a contact point of an obstacle or of
  // another body, moves along the face only: the particles
  // sit almost on such a face (the contact closes on their gap) and crowd
  // its functions; lifted off it, they fall back, and the lift's potential
  // energy becomes motion at every step (docs/transfers.md#packing).
  double work = 0.0;
  largest_shift = 0.0;
  for (std::size_t p = 0; p < stencils.size(); ++p) {
    if (skip && (*skip)[p]) continue;
    const Stencil<dim>& st = stencils[p];
    Vector<dim> shift = Vector<dim>::Zero();
    std::array<bool, dim> along_face{};
    for (int k = 0; k < st.count; ++k) {
      for (int a = 0; a < dim; ++a) along_face[a] = along_face[a] || ends_at_face(grid, contact_faces, a, st.node[k][a]);
      const double crowding = packing[st.local[k]] - (1.0 + kPackingTolerance);
      if (crowding > 0.0) shift -= scale * crowding * st.gradient[k];
    }
    for (int a = 0; a < dim; ++a)
      if (along_face[a]) shift[a] = 0.0;
    // The same along an obstacle or another body: the shift loses its
    // component along the normal of every contact point in the stencil.
    if (contact_normals)
      for (int k = 0; k < st.count; ++k) {
        const Eigen::Map<const Vector<dim>> normal(contact_normals->data() + dim * st.local[k]);
        if (normal.squaredNorm() > 0.5) shift -= shift.dot(normal) * normal;
      }
    Eigen::Map<Vector<dim>>(x.data() + dim * p) += shift;
    Eigen::Map<Vector<dim>>(u.data() + dim * p) += shift;
    work -= m[p] * gravity.dot(shift);
    largest_shift = std::max(largest_shift, shift.norm());
  }
  return work;
}

template Vector<2> domain_half_width<2>(double, const Matrix<2>&, double);
template Vector<3> domain_half_width<3>(double, const Matrix<3>&, double);
template void compute_stencils<2>(const Grid<2>&, const Particles<2>&, std::vector<Stencil<2>>&,
                                  const std::vector<int>&);
template void compute_stencils<3>(const Grid<3>&, const Particles<3>&, std::vector<Stencil<3>>&,
                                  const std::vector<int>&);
template void particles_to_grid<2>(const Grid<2>&, const Particles<2>&, const std::vector<Stencil<2>>&,
                                   TransferScheme, GridFields<2>&, int);
template void particles_to_grid<3>(const Grid<3>&, const Particles<3>&, const std::vector<Stencil<3>>&,
                                   TransferScheme, GridFields<3>&, int);
template std::vector<double> stress_acceleration<2>(const Grid<2>&, const Particles<2>&,
                                                    const std::vector<Stencil<2>>&, const GridFields<2>&,
                                                    const Vector<2>&);
template std::vector<double> stress_acceleration<3>(const Grid<3>&, const Particles<3>&,
                                                    const std::vector<Stencil<3>>&, const GridFields<3>&,
                                                    const Vector<3>&);
template void grid_to_particles<2>(Particles<2>&, const std::vector<Stencil<2>>&,
                                   const std::vector<double>&, const std::vector<double>&,
                                   const std::vector<double>&, double, double, const TransferConfig&,
                                   const std::vector<char>*);
template void grid_to_particles<3>(Particles<3>&, const std::vector<Stencil<3>>&,
                                   const std::vector<double>&, const std::vector<double>&,
                                   const std::vector<double>&, double, double, const TransferConfig&,
                                   const std::vector<char>*);

template std::vector<double> particle_packing<2>(const Grid<2>&, const Particles<2>&,
                                                const std::vector<Stencil<2>>&, const std::vector<int>&,
                                                const std::array<bool, 4>&, int);
template std::vector<double> particle_packing<3>(const Grid<3>&, const Particles<3>&,
                                                const std::vector<Stencil<3>>&, const std::vector<int>&,
                                                const std::array<bool, 6>&, int);
template double correct_packing<2>(Particles<2>&, const std::vector<Stencil<2>>&, const std::vector<double>&,
                                   const Grid<2>&, double, const Vector<2>&, double&, const std::vector<char>*,
                                   const std::array<bool, 4>&, const std::vector<double>*);
template double correct_packing<3>(Particles<3>&, const std::vector<Stencil<3>>&, const std::vector<double>&,
                                   const Grid<3>&, double, const Vector<3>&, double&, const std::vector<char>*,
                                   const std::array<bool, 6>&, const std::vector<double>*);
template long count_inverting_particles<2>(const std::vector<Stencil<2>>&, const std::vector<double>&,
                                           const std::vector<double>&, double, double, const std::vector<char>*);
template long count_inverting_particles<3>(const std::vector<Stencil<3>>&, const std::vector<double>&,
                                           const std::vector<double>&, double, double, const std::vector<char>*);

}  // namespace talus

