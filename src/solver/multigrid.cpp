// Geometric multigrid on the active set: the interpolations between levels
// (talus/solver/multigrid.hpp, docs/solver.md#geometric-multigrid).
#include "talus/solver/multigrid.hpp"

#include <petscsf.h>

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "talus/core/errors.hpp"

namespace talus {

AxisRefinement refine_axis(ShapeKind kind, int fine_cells) {
  const int coarse_cells = (fine_cells + 1) / 2;
  const int count = basis_count(kind, fine_cells);
  AxisRefinement r;
  r.parents.resize(count);
  // The coarse functions' values at x (fine cell units).
  auto coarse = [&](double x) { return evaluate_basis_1d(kind, 0.5 * x, coarse_cells, 1.0); };
  for (int i = 0; i < count; ++i) {
    std::vector<std::pair<int, double>>& p = r.parents[i];
    auto add = [&p](int coarse_function, double w) {
      for (auto& [j, v] : p)
        if (j == coarse_function) {
          v += w;
          return;
        }
      p.emplace_back(coarse_function, w);
    };
    if (kind == ShapeKind::linear) {
      const Basis1D b = coarse(i);
      for (int k = 0; k < b.count; ++k) add(b.first + k, b.value[k]);
    } else {
      // The blossom at the knots (t_{i+1}, t_{i+2}) of the clamped fine knot
      // vector: c_i = 2 q(m) - (q(a) + q(b)) / 2.
      const double a = clamped_knot(i + 1, fine_cells), b = clamped_knot(i + 2, fine_cells);
      const double xs[3] = {0.5 * (a + b), a, b};
      const double ws[3] = {2.0, -0.5, -0.5};
      for (int s = 0; s < 3; ++s) {
        const Basis1D e = coarse(xs[s]);
        for (int k = 0; k < e.count; ++k) add(e.first + k, ws[s] * e.value[k]);
      }
    }
    p.erase(std::remove_if(p.begin(), p.end(), [](const auto& e) { return std::abs(e.second) < 1e-13; }), p.end());
  }
  return r;
}

namespace {

// One unknown of a level: grid point (at that level's cells), velocity
// field and component; or a rigid body's unknown (field -1, component: its
// index among them).
template <int dim>
struct LevelUnknown {
  std::array<int, dim> point;
  int field;
  int component;
};

// The Greville points (fine cells) and components of a level's unknowns.
template <int dim>
void record(ShapeKind kind, const std::vector<LevelUnknown<dim>>& unknowns, const std::vector<char>& held,
            const std::array<int, dim>& cells, int level, std::vector<double>& positions, std::vector<int>& components) {
  positions.clear();
  components.clear();
  for (std::size_t u = 0; u < unknowns.size(); ++u) {
    for (int a = 0; a < dim; ++a)
      positions.push_back(unknowns[u].field < 0 ? 0.0
                                                : basis_position(kind, unknowns[u].point[a], cells[a]) * (1 << level));
    components.push_back(unknowns[u].field < 0 || held[u] ? -1 : unknowns[u].component);
  }
}

}  // namespace

template <int dim>
GeometricMultigrid<dim>::~GeometricMultigrid() {
  destroy();
}

template <int dim>
void GeometricMultigrid<dim>::destroy() {
  for (Mat& P : interpolation_) MatDestroy(&P);
  interpolation_.clear();
  unknowns_.clear();
  positions_.clear();
  components_.clear();
}

template <int dim>
void GeometricMultigrid<dim>::build(const Grid<dim>& grid, const ActiveSet<dim>& active, int field_count,
                                    PetscInt coarse_unknowns, int max_levels,
                                    const std::vector<PetscInt>& held_rows) {
  destroy();
  MPI_Comm comm = grid.comm();
  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  const ShapeKind kind = grid.shape();

  // The fine grid's process columns: the ends of each column's points per
  // axis, and this rank's column.
  const Ownership<dim> own = grid.ownership();
  std::array<std::vector<int>, dim> column_end;
  std::array<int, dim> my_column{};
  for (int a = 0; a < dim; ++a) {
    int end = 0;
    for (std::size_t q = 0; q < own[a].size(); ++q) {
      if (end == grid.owned_start()[a]) my_column[a] = static_cast<int>(q);
      column_end[a].push_back(end += own[a][q]);
    }
  }

  // The fine level: the active set's owned unknowns, in its numbering.
  std::vector<LevelUnknown<dim>> fine;
  std::vector<char> held;  // constrained: no coarse correction
  const int points = grid.ghosted_count();
  for (int node : active.owned_points())
    for (int c = 0; c < dim; ++c) {
      fine.push_back({grid.global_index(node % points), node / points, c});
      held.push_back(active.constrained(node, c));
    }
  for (PetscInt r : held_rows)
    if (r >= 0 && r < static_cast<PetscInt>(held.size())) held[r] = 1;
  const int extras = static_cast<int>(active.local_blocks() - active.owned_count()) * dim;
  for (int e = 0; e < extras; ++e) {
    fine.push_back({{}, -1, e});
    held.push_back(0);
  }
  PetscInt fine_global = active.global_count() * dim;
  unknowns_.push_back(fine_global);
  positions_.emplace_back();
  components_.emplace_back();
  record<dim>(kind, fine, held, grid.cells(), 0, positions_.back(), components_.back());
  // Rigid bodies' unknowns (on the last rank) stay themselves on every level.
  int extra_count = extras;
  MPI_Bcast(&extra_count, 1, MPI_INT, size - 1, comm);

  std::array<int, dim> cells = grid.cells();
  for (int level = 1; level < max_levels && fine_global > coarse_unknowns; ++level) {
    bool halvable = true;
    for (int a = 0; a < dim; ++a) halvable = halvable && cells[a] >= 2;
    if (!halvable) break;
    std::array<int, dim> coarse_cells;
    std::array<AxisRefinement, dim> axis;
    // Per axis and coarse point: the owning process column and the offset in it.
    std::array<std::vector<int>, dim> column, offset;
    std::array<std::vector<int>, dim> column_count;
    for (int a = 0; a < dim; ++a) {
      coarse_cells[a] = (cells[a] + 1) / 2;
      axis[a] = refine_axis(kind, cells[a]);
      const int n = basis_count(kind, coarse_cells[a]);
      column_count[a].assign(column_end[a].size(), 0);
      const double scale = std::ldexp(1.0, level);  // fine cells per coarse cell
      for (int g = 0; g < n; ++g) {
        // The fine point nearest to the coarse one (positions in fine cells).
        const double x = basis_position(kind, g, coarse_cells[a]) * scale;
        int j = static_cast<int>(std::lround(kind == ShapeKind::linear ? x : x + 0.5));
        j = std::clamp(j, 0, grid.points()[a] - 1);
        const int q = static_cast<int>(std::upper_bound(column_end[a].begin(), column_end[a].end(), j) -
                                       column_end[a].begin());
        column[a].push_back(q);
        offset[a].push_back(column_count[a][q]++);
      }
    }
    auto owner = [&](const std::array<int, dim>& g) {
      int r = 0;
      for (int a = dim - 1; a >= 0; --a) r = r * static_cast<int>(column_end[a].size()) + column[a][g[a]];
      return r;
    };
    auto root_offset = [&](const std::array<int, dim>& g, int field, int component) {
      long o = 0;
      for (int a = dim - 1; a >= 0; --a) o = o * column_count[a][column[a][g[a]]] + offset[a][g[a]];
      return (o * field_count + field) * dim + component;
    };
    long roots = field_count * dim;
    for (int a = 0; a < dim; ++a) roots *= column_count[a][my_column[a]];

    // The coarse unknowns this rank's rows need (leaves), on their owners (roots).
    std::unordered_map<long, PetscInt> leaf_of;  // owner * roots_max + root offset -> leaf
    std::vector<PetscSFNode> remote;
    std::vector<std::vector<std::pair<PetscInt, double>>> rows(fine.size());
    for (std::size_t u = 0; u < fine.size(); ++u) {
      if (fine[u].field < 0 || held[u]) continue;
      // The tensor product of the axes' parents.
      std::array<std::size_t, dim> k{};
      std::array<int, dim> g;
      while (true) {
        double w = 1.0;
        for (int a = 0; a < dim; ++a) {
          const auto& e = axis[a].parents[fine[u].point[a]][k[a]];
          g[a] = e.first;
          w *= e.second;
        }
        const int r = owner(g);
        const long o = root_offset(g, fine[u].field, fine[u].component);
        const long key = o * size + r;
        auto it = leaf_of.find(key);
        if (it == leaf_of.end()) {
          it = leaf_of.emplace(key, static_cast<PetscInt>(remote.size())).first;
          remote.push_back({r, static_cast<PetscInt>(o)});
        }
        rows[u].emplace_back(it->second, w);
        int a = 0;
        while (a < dim && ++k[a] == axis[a].parents[fine[u].point[a]].size()) k[a++] = 0;
        if (a == dim) break;
      }
    }
    PetscSF sf;
    TALUS_PETSC(PetscSFCreate(comm, &sf));
    TALUS_PETSC(PetscSFSetGraph(sf, static_cast<PetscInt>(roots), static_cast<PetscInt>(remote.size()), nullptr,
                                PETSC_COPY_VALUES, remote.data(), PETSC_COPY_VALUES));
    std::vector<PetscInt> leaf(remote.size(), 1), root(roots, 0);
    TALUS_PETSC(PetscSFReduceBegin(sf, MPIU_INT, leaf.data(), root.data(), MPI_MAX));
    TALUS_PETSC(PetscSFReduceEnd(sf, MPIU_INT, leaf.data(), root.data(), MPI_MAX));
    // Number the needed coarse unknowns rank by rank, the rigid ones last.
    PetscInt owned = 0;
    for (PetscInt& x : root) owned += x;
    const PetscInt local = owned + (rank == size - 1 ? extra_count : 0);
    PetscInt first = 0, global = 0;
    MPI_Exscan(&local, &first, 1, MPIU_INT, MPI_SUM, comm);
    if (rank == 0) first = 0;
    MPI_Allreduce(&local, &global, 1, MPIU_INT, MPI_SUM, comm);
    std::vector<LevelUnknown<dim>> coarse;
    {
      PetscInt next = first;
      std::array<int, dim> box;
      for (int a = 0; a < dim; ++a) box[a] = column_count[a][my_column[a]];
      // The coarse points of this rank's columns, by offset.
      std::array<std::vector<int>, dim> point_at;
      for (int a = 0; a < dim; ++a) {
        point_at[a].resize(box[a]);
        for (std::size_t g = 0; g < column[a].size(); ++g)
          if (column[a][g] == my_column[a]) point_at[a][offset[a][g]] = static_cast<int>(g);
      }
      for (long o = 0; o < roots; ++o) {
        if (!root[o]) {
          root[o] = -1;
          continue;
        }
        root[o] = next++;
        long rest = o;
        const int component = static_cast<int>(rest % dim);
        rest /= dim;
        const int field = static_cast<int>(rest % field_count);
        rest /= field_count;
        std::array<int, dim> g;
        for (int a = 0; a < dim; ++a) {
          g[a] = point_at[a][rest % box[a]];
          rest /= box[a];
        }
        coarse.push_back({g, field, component});
      }
    }
    TALUS_PETSC(PetscSFBcastBegin(sf, MPIU_INT, root.data(), leaf.data(), MPI_REPLACE));
    TALUS_PETSC(PetscSFBcastEnd(sf, MPIU_INT, root.data(), leaf.data(), MPI_REPLACE));
    TALUS_PETSC(PetscSFDestroy(&sf));
    // A coarsening that keeps most unknowns (a body one or two cells thick
    // along an axis) costs more than it removes: stop before it.
    if (4 * global > 3 * fine_global) break;
    const PetscInt extra_first = global - extra_count;
    if (rank == size - 1)
      for (int e = 0; e < extra_count; ++e) coarse.push_back({{}, -1, e});

    // The interpolation: rows of this rank's fine unknowns.
    const PetscInt rows_local = static_cast<PetscInt>(fine.size());
    PetscInt row_first = 0;
    MPI_Exscan(&rows_local, &row_first, 1, MPIU_INT, MPI_SUM, comm);
    if (rank == 0) row_first = 0;
    std::vector<PetscInt> diagonal_nz(fine.size(), 0), off_nz(fine.size(), 0);
    for (std::size_t u = 0; u < fine.size(); ++u) {
      if (fine[u].field < 0) {
        diagonal_nz[u] = 1;
        continue;
      }
      for (auto& [l, w] : rows[u]) {
        const PetscInt c = leaf[l];
        (c >= first && c < first + local ? diagonal_nz[u] : off_nz[u])++;
      }
    }
    Mat P;
    TALUS_PETSC(MatCreate(comm, &P));
    TALUS_PETSC(MatSetSizes(P, rows_local, local, fine_global, global));
    TALUS_PETSC(MatSetType(P, MATAIJ));
    TALUS_PETSC(MatSeqAIJSetPreallocation(P, 0, diagonal_nz.data()));
    TALUS_PETSC(MatMPIAIJSetPreallocation(P, 0, diagonal_nz.data(), 0, off_nz.data()));
    for (std::size_t u = 0; u < fine.size(); ++u) {
      const PetscInt row = row_first + static_cast<PetscInt>(u);
      if (fine[u].field < 0) {
        const PetscInt c = extra_first + fine[u].component;
        const PetscScalar one = 1.0;
        TALUS_PETSC(MatSetValues(P, 1, &row, 1, &c, &one, INSERT_VALUES));
        continue;
      }
      for (auto& [l, w] : rows[u]) {
        const PetscInt c = leaf[l];
        TALUS_PETSC(MatSetValues(P, 1, &row, 1, &c, &w, INSERT_VALUES));
      }
    }
    TALUS_PETSC(MatAssemblyBegin(P, MAT_FINAL_ASSEMBLY));
    TALUS_PETSC(MatAssemblyEnd(P, MAT_FINAL_ASSEMBLY));
    interpolation_.push_back(P);
    unknowns_.push_back(global);
    fine = std::move(coarse);
    held.assign(fine.size(), 0);
    positions_.emplace_back();
    components_.emplace_back();
    record<dim>(kind, fine, held, coarse_cells, level, positions_.back(), components_.back());
    fine_global = global;
    cells = coarse_cells;
  }
}

template <int dim>
void GeometricMultigrid<dim>::configure(PC pc) const {
  MPI_Comm comm;
  TALUS_PETSC(PetscObjectGetComm(reinterpret_cast<PetscObject>(pc), &comm));
  const int n = levels();
  TALUS_PETSC(PCMGSetLevels(pc, n, nullptr));
  // PETSc numbers the levels from the coarsest (0) to the fine one (n - 1).
  for (int l = 0; l + 1 < n; ++l) TALUS_PETSC(PCMGSetInterpolation(pc, n - 1 - l, interpolation_[l]));
  // Smoothing on every level but the coarsest (LU): one Richardson
  // iteration of symmetric Gauss-Seidel before and after the coarse
  // correction, a fixed linear map, so GMRES outside stays GMRES (PETSc's
  // default, Chebyshev, assumes a symmetric positive definite operator; these
  // are neither). Options (-talus_mg_levels_...) override at set-up.
  for (int l = 1; l < n; ++l) {
    KSP smoother;
    PC smoother_pc;
    TALUS_PETSC(PCMGGetSmoother(pc, l, &smoother));
    TALUS_PETSC(KSPSetType(smoother, KSPRICHARDSON));
    TALUS_PETSC(KSPSetTolerances(smoother, PETSC_DEFAULT, PETSC_DEFAULT, PETSC_DEFAULT, 1));
    TALUS_PETSC(KSPGetPC(smoother, &smoother_pc));
    TALUS_PETSC(PCSetType(smoother_pc, PCSOR));
  }
  // The levels are the assembled matrix's: its Galerkin products, smoothed
  // with it (the Krylov method outside multiplies by the Jacobian, which may
  // be an operator, docs/solver.md#the-jacobian-as-an-operator).
  TALUS_PETSC(PCSetUseAmat(pc, PETSC_FALSE));
  TALUS_PETSC(PCMGSetGalerkin(pc, PC_MG_GALERKIN_PMAT));
}

template class GeometricMultigrid<2>;
template class GeometricMultigrid<3>;

}  // namespace talus
