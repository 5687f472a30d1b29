#include "talus/solver/active_set.hpp"

#include <algorithm>

namespace talus {

template <int dim>
ActiveSet<dim>::~ActiveSet() {
  destroy();
}

template <int dim>
void ActiveSet<dim>::destroy() {
  VecScatterDestroy(&scatter_);
  VecDestroy(&work_);
  VecDestroy(&layout_);
}

template <int dim>
void ActiveSet<dim>::build(const Grid<dim>& grid, const GridFields<dim>& fields, double threshold,
                           const std::array<FaceCondition, 6>& faces, int extra_blocks) {
  destroy();
  comm_ = grid.comm();
  // Nodes: one per ghosted point and velocity field (GridFields), field-major
  // (node f * points + i).
  const int points = grid.ghosted_count(), n = points * fields.field_count;
  compact_.assign(n, -1);
  owned_points_.clear();
  constrained_.assign(static_cast<std::size_t>(n) * dim, 0);

  // The unknowns are numbered point by point, the fields of a point next to
  // each other: a contact between fields then couples neighbours in the
  // numbering, and the factors fill as with one field (numbered field by
  // field, a 3D landslide with a boulder filled 25 times as much).
  for (int k = 0; k < n; ++k) {
    const int i = (k % fields.field_count) * points + k / fields.field_count;
    const auto ijk = grid.global_index(i % points);
    for (int a = 0; a < dim; ++a) {
      const FaceCondition lo = faces[2 * a], hi = faces[2 * a + 1];
      FaceCondition f = FaceCondition::free;
      if (ijk[a] == 0) f = lo;
      if (ijk[a] == grid.points()[a] - 1) f = hi;
      if (f == FaceCondition::fixed)
        for (int c = 0; c < dim; ++c) constrained_[dim * i + c] = 1;
      else if (f == FaceCondition::slip)
        constrained_[dim * i + a] = 1;
    }
    if (fields.mass[i] > threshold && grid.is_owned(ijk)) owned_points_.push_back(i);
  }
  owned_count_ = static_cast<PetscInt>(owned_points_.size());
  int rank = 0, size = 1;
  MPI_Comm_rank(comm_, &rank);
  MPI_Comm_size(comm_, &size);
  extra_local_ = rank == size - 1 ? extra_blocks : 0;
  // PETSc's parallel layout numbers the owned active points of rank r after
  // those of ranks < r; the extra blocks end the last rank's range.
  TALUS_PETSC(VecCreateMPI(comm_, (owned_count_ + extra_local_) * dim, PETSC_DETERMINE, &layout_));
  TALUS_PETSC(VecSetBlockSize(layout_, dim));
  PetscInt first = 0;
  TALUS_PETSC(VecGetOwnershipRange(layout_, &first, nullptr));
  TALUS_PETSC(VecGetSize(layout_, &global_count_));
  first /= dim;
  global_count_ /= dim;
  extra_first_ = global_count_ - extra_blocks;

  // Compact indices of ghost points come from their owners through the DMDA,
  // one field at a time.
  for (int field = 0; field < fields.field_count; ++field) {
    const int offset = field * points;
    DM da = grid.dm();
    Vec g, l;
    TALUS_PETSC(DMGetGlobalVector(da, &g));
    TALUS_PETSC(DMGetLocalVector(da, &l));
    TALUS_PETSC(VecSet(g, -1.0));
    PetscScalar* ga;
    TALUS_PETSC(VecGetArray(g, &ga));
    // The global vector of a DMDA stores owned points in the same (x fastest) order.
    const auto& s = grid.owned_start();
    const auto& m = grid.owned_size();
    for (PetscInt k = 0; k < owned_count_; ++k) {
      if (owned_points_[k] / points != field) continue;
      const auto ijk = grid.global_index(owned_points_[k] - offset);
      int idx = 0;
      for (int a = dim - 1; a >= 0; --a) idx = idx * m[a] + (ijk[a] - s[a]);
      ga[idx] = static_cast<PetscScalar>(first + k);
    }
    TALUS_PETSC(VecRestoreArray(g, &ga));
    TALUS_PETSC(DMGlobalToLocalBegin(da, g, INSERT_VALUES, l));
    TALUS_PETSC(DMGlobalToLocalEnd(da, g, INSERT_VALUES, l));
    const PetscScalar* la;
    TALUS_PETSC(VecGetArrayRead(l, &la));
    for (int i = 0; i < points; ++i) compact_[offset + i] = static_cast<PetscInt>(std::lround(la[i]));
    TALUS_PETSC(VecRestoreArrayRead(l, &la));
    TALUS_PETSC(DMRestoreLocalVector(da, &l));
    TALUS_PETSC(DMRestoreGlobalVector(da, &g));
  }

  TALUS_PETSC(VecCreateSeq(PETSC_COMM_SELF, static_cast<PetscInt>(n) * dim, &work_));
  TALUS_PETSC(VecZeroEntries(work_));
  constrained_entries_.clear();
  for (int i = 0; i < n; ++i)
    for (int c = 0; c < dim && compact_[i] >= 0; ++c)
      if (constrained_[dim * i + c]) constrained_entries_.push_back(dim * i + c);
  std::vector<PetscInt> from, to;
  for (int i = 0; i < n; ++i)
    if (compact_[i] >= 0)
      for (int c = 0; c < dim; ++c) {
        from.push_back(compact_[i] * dim + c);
        to.push_back(static_cast<PetscInt>(i) * dim + c);
      }
  IS is_from, is_to;
  TALUS_PETSC(ISCreateGeneral(PETSC_COMM_SELF, static_cast<PetscInt>(from.size()), from.data(), PETSC_COPY_VALUES,
                              &is_from));
  TALUS_PETSC(ISCreateGeneral(PETSC_COMM_SELF, static_cast<PetscInt>(to.size()), to.data(), PETSC_COPY_VALUES, &is_to));
  TALUS_PETSC(VecScatterCreate(layout_, is_from, work_, is_to, &scatter_));
  active_entries_ = std::move(to);
  TALUS_PETSC(ISDestroy(&is_from));
  TALUS_PETSC(ISDestroy(&is_to));
}

template <int dim>
Vec ActiveSet<dim>::create_vector() const {
  Vec v;
  TALUS_PETSC(VecDuplicate(layout_, &v));
  return v;
}

template <int dim>
void ActiveSet<dim>::to_grid(Vec compact, std::vector<double>& ghosted) const {
  // work_ is zero outside the active entries, which the scatter overwrites.
  TALUS_PETSC(VecScatterBegin(scatter_, compact, work_, INSERT_VALUES, SCATTER_FORWARD));
  TALUS_PETSC(VecScatterEnd(scatter_, compact, work_, INSERT_VALUES, SCATTER_FORWARD));
  const PetscScalar* w;
  TALUS_PETSC(VecGetArrayRead(work_, &w));
  ghosted.assign(w, w + compact_.size() * dim);
  TALUS_PETSC(VecRestoreArrayRead(work_, &w));
}

template <int dim>
void ActiveSet<dim>::to_grid_active(Vec compact, std::vector<double>& ghosted, std::size_t padding) const {
  // work_ is zero outside the active entries, which the scatter overwrites.
  TALUS_PETSC(VecScatterBegin(scatter_, compact, work_, INSERT_VALUES, SCATTER_FORWARD));
  TALUS_PETSC(VecScatterEnd(scatter_, compact, work_, INSERT_VALUES, SCATTER_FORWARD));
  const std::size_t size = compact_.size() * dim + padding;
  if (ghosted.size() != size) ghosted.assign(size, 0.0);
  const PetscScalar* w;
  TALUS_PETSC(VecGetArrayRead(work_, &w));
  for (const PetscInt e : active_entries_) ghosted[e] = w[e];
  TALUS_PETSC(VecRestoreArrayRead(work_, &w));
}

template <int dim>
void ActiveSet<dim>::add_to_compact(const std::vector<double>& ghosted, Vec compact) const {
  PetscScalar* w;
  TALUS_PETSC(VecGetArray(work_, &w));
  // Only the active entries: the scatter reads no other, and work_ stays
  // zero outside them for to_grid.
  for (const PetscInt e : active_entries_) w[e] = ghosted[e];
  TALUS_PETSC(VecRestoreArray(work_, &w));
  TALUS_PETSC(VecScatterBegin(scatter_, work_, compact, ADD_VALUES, SCATTER_REVERSE));
  TALUS_PETSC(VecScatterEnd(scatter_, work_, compact, ADD_VALUES, SCATTER_REVERSE));
}

template class ActiveSet<2>;
template class ActiveSet<3>;

}  // namespace talus
