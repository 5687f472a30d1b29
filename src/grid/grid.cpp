#include "talus/grid/grid.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "talus/core/errors.hpp"

namespace talus {

template <int dim>
Grid<dim>::Grid(MPI_Comm comm, const Vector<dim>& lower, const Vector<dim>& upper, double cell_size,
                ShapeKind kind, ParticleQuadrature quadrature, const Ownership<dim>* ownership)
    : comm_(comm), kind_(kind), quadrature_(quadrature), h_(cell_size), lower_(lower), upper_(upper) {
  for (int a = 0; a < dim; ++a) {
    cells_[a] = static_cast<int>(std::lround((upper[a] - lower[a]) / cell_size));
    if (cells_[a] < 3 || std::abs(cells_[a] * cell_size - (upper[a] - lower[a])) > 1e-9 * cell_size * cells_[a])
      throw InputError("grid: the box length along axis " + std::to_string(a) +
                       " must be a whole number (>= 3) of cell_size");
    points_[a] = basis_count(kind, cells_[a]);
  }
  // Quadratic B-spline stencils reach two points beyond the particle's DMDA
  // cell; their Jacobian couples points up to reach() apart.
  const PetscInt width = stencil_width();
  const bool explicit_ranges = ownership && !(*ownership)[0].empty();
  std::array<PetscInt, 3> procs{PETSC_DECIDE, PETSC_DECIDE, PETSC_DECIDE};
  std::array<std::vector<PetscInt>, 3> counts;
  if (explicit_ranges) {
    int size = 1, ranks = 0;
    MPI_Comm_size(comm, &ranks);
    for (int a = 0; a < dim; ++a) {
      const auto& own = (*ownership)[a];
      int sum = 0;
      for (int n : own) {
        if (n < width) throw SimulationError("grid: a process column owns fewer points than the stencil width");
        sum += n;
      }
      if (sum != points_[a]) throw SimulationError("grid: the ownership ranges do not cover the grid");
      counts[a].assign(own.begin(), own.end());
      procs[a] = static_cast<PetscInt>(own.size());
      size *= static_cast<int>(own.size());
    }
    if (size != ranks) throw SimulationError("grid: the ownership ranges are for another number of ranks");
  }
  const auto ranges_of = [&](int a) { return explicit_ranges ? counts[a].data() : nullptr; };
  if constexpr (dim == 2) {
    TALUS_PETSC(DMDACreate2d(comm, DM_BOUNDARY_NONE, DM_BOUNDARY_NONE, DMDA_STENCIL_BOX, points_[0], points_[1],
                             procs[0], procs[1], 1, width, ranges_of(0), ranges_of(1), &da_));
  } else {
    TALUS_PETSC(DMDACreate3d(comm, DM_BOUNDARY_NONE, DM_BOUNDARY_NONE, DM_BOUNDARY_NONE, DMDA_STENCIL_BOX,
                             points_[0], points_[1], points_[2], procs[0], procs[1], procs[2], 1, width,
                             ranges_of(0), ranges_of(1), ranges_of(2), &da_));
  }
  TALUS_PETSC(DMSetUp(da_));
  const double offset = kind == ShapeKind::linear ? 0.0 : 0.5;
  std::array<double, 3> lo{0, 0, 0}, hi{0, 0, 0};
  for (int a = 0; a < dim; ++a) {
    lo[a] = lower[a] - offset * h_;
    hi[a] = lower[a] + (points_[a] - 1 - offset) * h_;
  }
  TALUS_PETSC(DMDASetUniformCoordinates(da_, lo[0], hi[0], lo[1], hi[1], lo[2], hi[2]));
  TALUS_PETSC(DMDACreateCompatibleDMDA(da_, dim + 1, &da_mp_));

  PetscInt s[3], m[3], gs[3], gm[3], p[3];
  TALUS_PETSC(DMDAGetCorners(da_, &s[0], &s[1], &s[2], &m[0], &m[1], &m[2]));
  TALUS_PETSC(DMDAGetGhostCorners(da_, &gs[0], &gs[1], &gs[2], &gm[0], &gm[1], &gm[2]));
  TALUS_PETSC(DMDAGetInfo(da_, nullptr, nullptr, nullptr, nullptr, &p[0], &p[1], &p[2], nullptr, nullptr, nullptr,
                          nullptr, nullptr, nullptr));
  const PetscInt* ranges[3] = {nullptr, nullptr, nullptr};
  TALUS_PETSC(DMDAGetOwnershipRanges(da_, &ranges[0], &ranges[1], dim == 3 ? &ranges[2] : nullptr));
  for (int a = 0; a < dim; ++a) {
    own_start_[a] = s[a];
    own_size_[a] = m[a];
    ghost_start_[a] = gs[a];
    ghost_size_[a] = gm[a];
    int end = 0;
    for (int q = 0; q < p[a]; ++q) range_end_[a].push_back(end += ranges[a][q]);
  }
}

template <int dim>
Grid<dim>::~Grid() {
  DMDestroy(&da_mp_);
  DMDestroy(&da_);
}

template <int dim>
int Grid<dim>::ghosted_count() const {
  int n = 1;
  for (int a = 0; a < dim; ++a) n *= ghost_size_[a];
  return n;
}

template <int dim>
int Grid<dim>::local_index(const std::array<int, dim>& ijk) const {
  int idx = 0;
  for (int a = dim - 1; a >= 0; --a) idx = idx * ghost_size_[a] + (ijk[a] - ghost_start_[a]);
  return idx;
}

template <int dim>
std::array<int, dim> Grid<dim>::global_index(int local) const {
  std::array<int, dim> ijk;
  for (int a = 0; a < dim; ++a) {
    ijk[a] = ghost_start_[a] + local % ghost_size_[a];
    local /= ghost_size_[a];
  }
  return ijk;
}

template <int dim>
bool Grid<dim>::is_owned(const std::array<int, dim>& ijk) const {
  for (int a = 0; a < dim; ++a)
    if (ijk[a] < own_start_[a] || ijk[a] >= own_start_[a] + own_size_[a]) return false;
  return true;
}

template <int dim>
Vector<dim> Grid<dim>::point_position(const std::array<int, dim>& ijk) const {
  Vector<dim> x;
  for (int a = 0; a < dim; ++a) x[a] = lower_[a] + h_ * basis_position(kind_, ijk[a], cells_[a]);
  return x;
}

template <int dim>
std::array<int, dim> Grid<dim>::owner_points(const Vector<dim>& x) const {
  // PETSc's DMDA point location gives DMDA cell k (between points k and k+1)
  // to the rank that owns point k+1; we follow the same rule.
  std::array<int, dim> c;
  for (int a = 0; a < dim; ++a) {
    const double u = (x[a] - lower_[a]) / h_;
    int k = kind_ == ShapeKind::linear ? static_cast<int>(std::floor(u)) : static_cast<int>(std::floor(u + 0.5));
    c[a] = std::clamp(k, 0, points_[a] - 2) + 1;
  }
  return c;
}

template <int dim>
PetscMPIInt Grid<dim>::rank_of(const std::array<int, dim>& c, const std::array<std::vector<int>, dim>& ends) {
  int rank = 0, stride = 1;
  for (int a = 0; a < dim; ++a) {
    const int col = static_cast<int>(std::upper_bound(ends[a].begin(), ends[a].end(), c[a]) - ends[a].begin());
    rank += stride * col;
    stride *= static_cast<int>(ends[a].size());
  }
  return rank;
}

template <int dim>
PetscMPIInt Grid<dim>::owner_rank(const Vector<dim>& x) const {
  return rank_of(owner_points(x), range_end_);
}

template <int dim>
Ownership<dim> Grid<dim>::ownership() const {
  Ownership<dim> own;
  for (int a = 0; a < dim; ++a) {
    int start = 0;
    for (int end : range_end_[a]) {
      own[a].push_back(end - start);
      start = end;
    }
  }
  return own;
}

template <int dim>
void Grid<dim>::stencil(const Vector<dim>& x, Stencil<dim>& st, const Vector<dim>* half_width) const {
  evaluate_stencil<dim>(kind_, x - lower_, cells_, h_, st, half_width);
  for (int n = 0; n < st.count; ++n) st.local[n] = local_index(st.node[n]);
}

template <int dim>
std::vector<double> Grid<dim>::sum_over_ranks(const std::vector<double>& mine, int fields, int components) const {
  // One scalar per point, or dim values in the first slots of the (m, m v) DMDA.
  DM da = components == 1 ? da_ : da_mp_;
  const int bs = components == 1 ? 1 : dim + 1;
  const int points = ghosted_count();
  std::vector<double> out(mine.size());
  Vec local, global;
  TALUS_PETSC(DMGetLocalVector(da, &local));
  TALUS_PETSC(DMGetGlobalVector(da, &global));
  for (int field = 0; field < fields; ++field) {
    const std::size_t offset = static_cast<std::size_t>(field) * points * components;
    TALUS_PETSC(VecZeroEntries(local));
    TALUS_PETSC(VecZeroEntries(global));
    PetscScalar* a;
    TALUS_PETSC(VecGetArray(local, &a));
    for (int i = 0; i < points; ++i)
      for (int c = 0; c < components; ++c) a[bs * i + c] = mine[offset + static_cast<std::size_t>(components) * i + c];
    TALUS_PETSC(VecRestoreArray(local, &a));
    TALUS_PETSC(DMLocalToGlobalBegin(da, local, ADD_VALUES, global));
    TALUS_PETSC(DMLocalToGlobalEnd(da, local, ADD_VALUES, global));
    TALUS_PETSC(DMGlobalToLocalBegin(da, global, INSERT_VALUES, local));
    TALUS_PETSC(DMGlobalToLocalEnd(da, global, INSERT_VALUES, local));
    const PetscScalar* b;
    TALUS_PETSC(VecGetArrayRead(local, &b));
    for (int i = 0; i < points; ++i)
      for (int c = 0; c < components; ++c) out[offset + static_cast<std::size_t>(components) * i + c] = b[bs * i + c];
    TALUS_PETSC(VecRestoreArrayRead(local, &b));
  }
  TALUS_PETSC(DMRestoreLocalVector(da, &local));
  TALUS_PETSC(DMRestoreGlobalVector(da, &global));
  return out;
}

template class Grid<2>;
template class Grid<3>;

}  // namespace talus
