#include "talus/solver/ghost_penalty.hpp"

#include <cmath>

#include "talus/core/errors.hpp"

namespace talus {

namespace {

// Per field and cell (stored at its lower corner's ghosted point, the index
// of the first function of a particle's stencil in it), over all ranks: the
// particles' current volume V0 J and V M (M the P-wave modulus of the
// particle's material).
template <int dim>
void cell_sums(const Grid<dim>& grid, const Particles<dim>& particles, const std::vector<Stencil<dim>>& stencils,
               const GridFields<dim>& fields, const std::vector<const Material*>& materials,
               std::vector<double>& volume, std::vector<double>& stiffness) {
  const std::size_t nodes = static_cast<std::size_t>(grid.ghosted_count()) * fields.field_count;
  std::vector<double> V(nodes, 0.0), VM(nodes, 0.0);
  FieldView<PetscReal> v0(particles.swarm(), field::initial_volume), J(particles.swarm(), field::volume_ratio);
  FieldView<PetscInt> material(particles.swarm(), field::material_id);
  for (std::size_t p = 0; p < stencils.size(); ++p) {
    const double Vp = v0[p] * J[p];
    V[stencils[p].local[0]] += Vp;
    VM[stencils[p].local[0]] += Vp * materials[material[p]]->elastic_stiffness()(0, 0);
  }
  volume = grid.sum_over_ranks(V, fields.field_count, 1);
  stiffness = grid.sum_over_ranks(VM, fields.field_count, 1);
}

// The second derivative (per length^2) of the functions s, s + 1, s + 2 on
// span s: constant there, from the slopes at two points of the span.
std::array<double, 3> second_derivatives(int s, int cells, double h) {
  const Basis1D a = evaluate_basis_1d(ShapeKind::quadratic_bspline, s + 0.25, cells, h);
  const Basis1D b = evaluate_basis_1d(ShapeKind::quadratic_bspline, s + 0.75, cells, h);
  return {(b.slope[0] - a.slope[0]) / (0.5 * h), (b.slope[1] - a.slope[1]) / (0.5 * h),
          (b.slope[2] - a.slope[2]) / (0.5 * h)};
}

}  // namespace

template <int dim>
GhostPenalty<dim>::GhostPenalty(const Grid<dim>& grid, const Particles<dim>& particles,
                                const std::vector<Stencil<dim>>& stencils, const GridFields<dim>& fields,
                                const ActiveSet<dim>& active, const std::vector<const Material*>& materials,
                                double gamma, const std::function<bool(const Vector<dim>&)>& inside_obstacle,
                                const std::vector<char>* held) {
  if (grid.shape() != ShapeKind::quadratic_bspline)
    throw SimulationError("the ghost penalty needs quadratic B-splines (grid.shape_function: quadratic_bspline)");
  const double h = grid.cell_size();
  const auto& cells = grid.cells();
  // Per axis and span: the second derivatives of its three functions and
  // the mass matrix int_span B_i B_j dx (3-point Gauss, exact for degree 4).
  std::array<std::vector<std::array<double, 3>>, dim> second;
  std::array<std::vector<std::array<double, 9>>, dim> mass;
  for (int a = 0; a < dim; ++a) {
    const int n = cells[a];
    second[a].resize(n);
    mass[a].assign(n, std::array<double, 9>{});
    const double xi[3] = {-std::sqrt(0.6), 0.0, std::sqrt(0.6)}, w[3] = {5.0 / 18.0, 8.0 / 18.0, 5.0 / 18.0};
    for (int s = 0; s < n; ++s) {
      second[a][s] = second_derivatives(s, n, h);
      for (int g = 0; g < 3; ++g) {
        const Basis1D b = evaluate_basis_1d(ShapeKind::quadratic_bspline, s + 0.5 * (1.0 + xi[g]), n, h);
        for (int i = 0; i < 3; ++i)
          for (int k = 0; k < 3; ++k) mass[a][s][3 * i + k] += w[g] * h * b.value[i] * b.value[k];
      }
    }
  }

  std::vector<double> volume, stiffness;
  cell_sums(grid, particles, stencils, fields, materials, volume, stiffness);
  const int points = grid.ghosted_count();
  // A cut cell holds particles of its field next to a cell (faces and
  // corners) that holds none; cells beyond the grid count as filled (the
  // grid's faces are walls, not free surfaces). A cell's neighbours lie in
  // the ghost region of the rank that evaluates it (below).
  std::vector<signed char> wall_cell(points, -1);
  auto at_surface = [&](int field, const std::array<int, dim>& cell) {
    std::array<int, dim> o, n;
    for (int a = 0; a < dim; ++a) o[a] = -1;
    while (true) {
      bool inside = true;
      for (int a = 0; a < dim; ++a) {
        n[a] = cell[a] + o[a];
        inside &= n[a] >= 0 && n[a] < cells[a];
      }
      if (inside && !(volume[static_cast<std::size_t>(field) * points + grid.local_index(n)] > 0.0)) {
        // An empty cell that reaches into an obstacle (a corner inside it)
        // borders a wall, not a free surface (remembered per cell).
        signed char& wall = wall_cell[grid.local_index(n)];
        if (wall < 0) {
          wall = 0;
          for (int corner = 0; corner < (1 << dim) && inside_obstacle && !wall; ++corner) {
            Vector<dim> x;
            for (int a = 0; a < dim; ++a) x[a] = grid.lower()[a] + (n[a] + ((corner >> a) & 1)) * grid.cell_size();
            wall = inside_obstacle(x) ? 1 : 0;
          }
        }
        if (!wall) return true;
      }
      int a = 0;
      while (a < dim && ++o[a] > 1) o[a] = -1, ++a;
      if (a == dim) return false;
    }
  };
  // The held nodes as every rank that sees them knows them.
  std::vector<double> held_anywhere;
  if (held) held_anywhere = grid.sum_over_ranks(std::vector<double>(held->begin(), held->end()), fields.field_count, 1);
  // Each cell on one rank: the owner of its central function's point c + 1
  // (a cell's particles may live on two ranks: Grid::owner_points splits the
  // knot spans at the Greville points). Its 3^d functions c .. c + 2 lie in
  // that rank's ghost region.
  const auto& start = grid.owned_start();
  const auto& size = grid.owned_size();
  int owned = 1;
  for (int a = 0; a < dim; ++a) owned *= size[a];
  for (int k = 0; k < owned; ++k)
    for (int field = 0; field < fields.field_count; ++field) {
      std::array<int, dim> c;
      bool inside = true;
      for (int a = 0, r = k; a < dim; ++a) {
        c[a] = start[a] + r % size[a] - 1;
        r /= size[a];
        inside &= c[a] >= 0 && c[a] < cells[a];
      }
      if (!inside) continue;
      const int key = field * points + grid.local_index(c);
      if (!(volume[key] > 0.0) || !at_surface(field, c)) continue;
      Cell cell;
      bool complete = true;
      for (int n = 0; n < cell_nodes; ++n) {
        std::array<int, dim> ijk;
        for (int a = 0, q = n; a < dim; ++a, q /= 3) ijk[a] = c[a] + q % 3;
        cell.node[n] = field * points + grid.local_index(ijk);
        complete &= active.compact_index(cell.node[n]) >= 0 && !(held && held_anywhere[cell.node[n]] > 0.0);
      }
      if (!complete) continue;
      const double s = gamma * stiffness[key] / volume[key] * h * h;
      for (int m = 0; m < cell_nodes; ++m)
        for (int n = 0; n < cell_nodes; ++n) {
          double k = 0.0;
          for (int a = 0; a < dim; ++a) {
            double term = h;
            for (int b = 0, qm = m, qn = n; b < dim; ++b, qm /= 3, qn /= 3)
              term *= b == a ? second[a][c[a]][qm % 3] * second[a][c[a]][qn % 3] : mass[b][c[b]][3 * (qm % 3) + qn % 3];
            k += term;
          }
          cell.coupling[m * cell_nodes + n] = s * k;
        }
      cells_.push_back(cell);
    }
  long local = static_cast<long>(cells_.size());
  MPI_Allreduce(&local, &global_cells_, 1, MPI_LONG, MPI_SUM, grid.comm());
}

template <int dim>
void GhostPenalty<dim>::add_product(const std::vector<double>& x, std::vector<double>& y, double scale) const {
  for (const Cell& cell : cells_) {
    std::array<Vector<dim>, cell_nodes> local;
    for (int n = 0; n < cell_nodes; ++n)
      local[n] = Eigen::Map<const Vector<dim>>(x.data() + static_cast<std::size_t>(dim) * cell.node[n]);
    for (int m = 0; m < cell_nodes; ++m) {
      Vector<dim> sum = Vector<dim>::Zero();
      for (int n = 0; n < cell_nodes; ++n) sum += cell.coupling[m * cell_nodes + n] * local[n];
      Eigen::Map<Vector<dim>>(y.data() + static_cast<std::size_t>(dim) * cell.node[m]) += scale * sum;
    }
  }
}

template class GhostPenalty<2>;
template class GhostPenalty<3>;

}  // namespace talus
