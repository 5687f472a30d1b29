// The Jacobian of the momentum system assembled as a matrix (the rows of the
// particles, the ghost penalty, the contact rows and the masses in one pass),
// and the matrix's preallocation from the stencil couplings
// (docs/solver.md#reuse-across-steps). The product without the matrix is
// momentum_operator.cpp.
#include <algorithm>
#include <array>
#include <chrono>

#include "talus/solver/momentum_system.hpp"

namespace talus {

template <int dim>
bool MomentumSystem<dim>::shared_point(int node) const {
  int count = 0;
  for (int f = 0; f < fields_.field_count; ++f) count += active_.compact_index(f * points_ + node % points_) >= 0;
  return count > 1;
}

template <int dim>
void MomentumSystem<dim>::neighbour_columns(const std::array<int, dim>& ijk, int field, std::vector<PetscInt>& cols,
                                            std::vector<int>* points) const {
  const int reach = grid_.reach(), width = 2 * reach + 1;
  int neighbours = 1;
  for (int a = 0; a < dim; ++a) neighbours *= width;
  cols.resize(neighbours);
  if (points) points->resize(neighbours);
  // Neighbour n at offset d - reach per axis (n = sum_ax d_ax width^ax), its
  // ghosted index the centre's plus sum_ax (d_ax - reach) stride_ax
  // (Grid::local_index: x fastest).
  const auto& start = grid_.ghost_start();
  const auto& size = grid_.ghost_size();
  std::array<int, dim> stride;
  int centre = 0;
  for (int ax = 0, s = 1; ax < dim; s *= size[ax], ++ax) {
    stride[ax] = s;
    centre += (ijk[ax] - start[ax]) * s;
  }
  for (int n = 0; n < neighbours; ++n) {
    bool inside = true;
    int point = centre;
    for (int ax = 0, r = n; ax < dim; ++ax, r /= width) {
      const int offset = r % width - reach, j = ijk[ax] + offset;
      inside = inside && j >= start[ax] && j < start[ax] + size[ax];
      point += offset * stride[ax];
    }
    if (!inside) point = -1;
    cols[n] = inside ? active_.compact_index(field * points_ + point) : -1;
    if (points) (*points)[n] = point;
  }
}

template <int dim>
void MomentumSystem<dim>::jacobian(Vec v, Mat J) {
  // The contact rows' left factors P_i (row-major dim x dim per ghosted
  // point), or none without contact.
  std::vector<int> partner;
  const std::vector<double> left = any_contacts_ ? contact_row_factors(v, partner) : std::vector<double>();
  if (!evaluated_at(v)) evaluate_particles(v);
  commit_carried_stresses();
  const auto t_assembly = std::chrono::steady_clock::now();
  TALUS_PETSC(MatZeroEntries(J));
  // Particle contributions are first summed per (point, neighbour) block on
  // this rank, then handed to PETSc one block row at a time: a point is shared
  // by many particles, so this cuts the matrix insertions by that factor.
  const int reach = grid_.reach(), width = 2 * reach + 1;
  int neighbours = 1;
  for (int a = 0; a < dim; ++a) neighbours *= width;
  const int row_length = neighbours * dim;  // values in one scalar row of a block row
  // The slots, their columns and their constrained entries depend only on
  // the step's stencils and active set: built at the step's first Jacobian
  // and kept (members) for its later Newton iterates.
  std::vector<int>& slot = jacobian_slot_;
  std::vector<int>& slot_point = jacobian_slot_point_;
  if (!jacobian_layout_built_) {
    jacobian_layout_built_ = true;
    slot.assign(nodes_, -1);
    slot_point.clear();
    for (const Stencil<dim>& st : stencils_)
      for (int k = 0; k < st.count; ++k)
        if (slot[st.local[k]] < 0 && active_.compact_index(st.local[k]) >= 0) {
          slot[st.local[k]] = static_cast<int>(slot_point.size());
          slot_point.push_back(st.local[k]);
        }
    // Every owned active point gets its whole preallocated block row (zeros
    // where no particle couples), also where only another rank's particles
    // touch it: that rank sees only the neighbours inside its own ghost region,
    // and PETSc squeezes the slots a first assembly leaves unused, so a later
    // step that reuses the matrix and fills them would need a new nonzero.
    if (ghost_)
      // A cut cell's nodes (its rank need not hold a particle in it).
      for (const auto& cell : ghost_->cells())
        for (const int node : cell.node)
          if (slot[node] < 0) {
            slot[node] = static_cast<int>(slot_point.size());
            slot_point.push_back(node);
          }
    for (const int point : active_.owned_points())
      if (slot[point] < 0) {
        slot[point] = static_cast<int>(slot_point.size());
        slot_point.push_back(point);
      }
    // Each slot's neighbour columns, and the entries of its block row that a
    // constraint zeroes: constrained components have zero rows and columns
    // (their equation is m_i v_i = 0; the constraints are those of the
    // point, the same in every field).
    jacobian_columns_.resize(slot_point.size() * neighbours);
    jacobian_zeroed_start_.assign(1, 0);
    jacobian_zeroed_.clear();
    std::vector<PetscInt> cols(neighbours);
    std::vector<int> neighbour_points;
    // Which points have a constrained component: most have none, and their
    // blocks need no entry by entry test.
    std::vector<char> held(static_cast<std::size_t>(nodes_), 0);
    for (int i = 0; i < nodes_; ++i)
      for (int c = 0; c < dim; ++c) held[i] = held[i] || active_.constrained(i, c);
    for (std::size_t sa = 0; sa < slot_point.size(); ++sa) {
      const int point = slot_point[sa];
      neighbour_columns(grid_.global_index(point % points_), point / points_, cols, &neighbour_points);
      std::copy(cols.begin(), cols.end(), jacobian_columns_.begin() + sa * neighbours);
      const bool point_held = held[point];
      for (int n = 0; n < neighbours; ++n) {
        const int neighbour = neighbour_points[n];
        if (!point_held && (neighbour < 0 || !held[neighbour])) continue;
        for (int i = 0; i < dim; ++i)
          for (int k = 0; k < dim; ++k)
            if (active_.constrained(point, i) || (neighbour >= 0 && active_.constrained(neighbour, k)))
              jacobian_zeroed_.push_back(i * row_length + n * dim + k);
      }
      jacobian_zeroed_start_.push_back(static_cast<int>(jacobian_zeroed_.size()));
    }
  }
  std::vector<double>& rows = jacobian_rows_;
  rows.assign(slot_point.size() * dim * row_length, 0.0);

  // Position of neighbour b in point a's block row: lin(b) - lin(a) + centre,
  // lin(x) = sum_ax node_x[ax] width^ax.
  std::array<int, dim> stride;
  int centre = 0;
  for (int ax = 0, w = 1; ax < dim; ++ax, w *= width) stride[ax] = w, centre += reach * w;
  constexpr int max_nodes = Stencil<dim>::max_nodes;
  const double scale = h_ * theta_ * theta_;
  pack_stencils();
  for (std::size_t p = 0; p < stencils_.size(); ++p) {
    const StressTangent& A = tangent_[p];
    // A particle returned to the apex (also while it closes its voids) has
    // no stiffness, A = 0 exactly: nothing to add. In a spreading deposit
    // that is up to half of the particles.
    if (A.isZero(0.0)) continue;
    const int first = packed_offset_[p], count = packed_offset_[p + 1] - first;
    const int* local = packed_local_.data() + first;
    // The gradients on the stack: the compiler then knows that the stores
    // into the block rows below cannot change them.
    std::array<double, max_nodes * dim> gradient;
    std::copy_n(packed_gradient_.data() + static_cast<std::size_t>(dim) * first, count * dim, gradient.data());
    // The particle's nodes: their block rows and positions.
    std::array<double*, max_nodes> block_row;
    std::array<int, max_nodes> lin;
    for (int a = 0; a < count; ++a) {
      const int sa = slot[local[a]];
      block_row[a] = sa < 0 ? nullptr : rows.data() + static_cast<std::size_t>(sa) * dim * row_length;
      lin[a] = packed_lin_[first + a];
    }
    // G_b(ij, k) = V_p h theta^2 sum_l A(ij, kl) dN_b/dx_l for every node b
    // first, then the blocks K_ab(i, k) = sum_j dN_a/dx_j G_b(ij, k) one block
    // row a at a time: the G_b stay in L1 while row a's dim lines are
    // written (with b outermost every b touched all n block rows).
    // Row-major, so that the dim entries K_ab(i, :) are one packed
    // multiply-add per j (the loop below is a fifth of a 2D Newton iteration).
    // G_b has A's nS rows, one per stress component (sigma_ij = sigma_ji).
    using Gradient = Eigen::Matrix<double, nS, dim, Eigen::RowMajor>;
    std::array<Gradient, max_nodes> G;
    std::array<bool, max_nodes> active_b;
    const double volume_scale = scale * reference_volume_[p];
    for (int b = 0; b < count; ++b) {
      active_b[b] = active_.compact_index(local[b]) >= 0;
      if (!active_b[b]) continue;
      Eigen::Matrix<double, nS, dim> Gc;
      for (int k = 0; k < dim; ++k) {
        Gc.col(k).setZero();
        for (int l = 0; l < dim; ++l) Gc.col(k) += A.col(k * dim + l) * gradient[dim * b + l];
      }
      G[b] = volume_scale * Gc;
    }
    for (int a = 0; a < count; ++a) {
      if (!block_row[a]) continue;
      const Eigen::Map<const Vector<dim>> ga(gradient.data() + dim * a);
      for (int b = 0; b < count; ++b) {
        if (!active_b[b]) continue;
        double* row = block_row[a] + (lin[b] - lin[a] + centre) * dim;
        for (int i = 0; i < dim; ++i) {
          Eigen::Matrix<double, 1, dim> value = ga[0] * G[b].row(stress_row<dim>(i, 0));
          for (int j = 1; j < dim; ++j) value += ga[j] * G[b].row(stress_row<dim>(i, j));
          Eigen::Map<Eigen::Matrix<double, 1, dim>>(row + i * row_length) += value;
        }
      }
    }
  }

  if (ghost_) {
    // The ghost penalty's blocks h^2 theta K_C I (ghost_penalty.hpp), with
    // the particles' blocks: a cut cell's nodes are a particle's stencil.
    const double scale_ghost = h_ * h_ * theta_;
    constexpr int n_cell = GhostPenalty<dim>::cell_nodes;
    for (const auto& cell : ghost_->cells()) {
      std::array<int, n_cell> lin;
      for (int n = 0; n < n_cell; ++n) {
        const auto ijk = grid_.global_index(cell.node[n] % points_);
        lin[n] = 0;
        for (int ax = 0; ax < dim; ++ax) lin[n] += ijk[ax] * stride[ax];
      }
      for (int m = 0; m < n_cell; ++m) {
        double* row = rows.data() + static_cast<std::size_t>(slot[cell.node[m]]) * dim * row_length;
        for (int n = 0; n < n_cell; ++n) {
          const double k = scale_ghost * cell.coupling[m * n_cell + n];
          double* block = row + (lin[n] - lin[m] + centre) * dim;
          for (int i = 0; i < dim; ++i) block[i * row_length + i] += k;
        }
      }
    }
  }
  std::vector<PetscInt> other;
  std::vector<double> zeros;
  for (std::size_t sa = 0; sa < slot_point.size(); ++sa) {
    const int point = slot_point[sa];
    const int field = point / points_;
    const auto ijk = grid_.global_index(point % points_);
    double* row = rows.data() + sa * dim * row_length;
    const PetscInt* cols = jacobian_columns_.data() + sa * neighbours;
    for (int z = jacobian_zeroed_start_[sa]; z < jacobian_zeroed_start_[sa + 1]; ++z) row[jacobian_zeroed_[z]] = 0.0;
    if (!partner.empty() && partner[point] >= 0 && rigid_node(partner[point])) {
      // A rigid hub: the body's rows take T(x_i)^T times a's momentum row.
      const RigidBody<dim>& body = rigid_body_of(partner[point]);
      const PetscInt q[2] = {body.block, body.block + 1};
      const Eigen::Map<const Eigen::Matrix<double, dim, Eigen::Dynamic, Eigen::RowMajor>> momentum(row, dim, row_length);
      const Eigen::Matrix<double, RigidBody<dim>::unknowns, Eigen::Dynamic, Eigen::RowMajor> body_rows =
          body.velocity_map(grid_.point_position(ijk)).transpose() * momentum;
      TALUS_PETSC(MatSetValuesBlocked(J, 2, q, neighbours, cols, body_rows.data(), ADD_VALUES));
    } else if (!partner.empty() && partner[point] >= 0) {
      // Row b of a body contact takes a's momentum row as it is (R_a + R_b).
      const PetscInt rb = active_.compact_index(partner[point]);
      TALUS_PETSC(MatSetValuesBlocked(J, 1, &rb, neighbours, cols, row, ADD_VALUES));
    }
    if (fields_.field_count > 1 && shared_point(point) && active_.compact_index(point) >= 0 &&
        grid_.is_owned(ijk)) {
      // Where fields meet, a node's block row holds the other fields'
      // neighbours too (zeros unless a body contact fills them), so the
      // pattern is a function of the active nodes alone (reuse across steps).
      zeros.assign(static_cast<std::size_t>(dim) * row_length, 0.0);
      const PetscInt r = active_.compact_index(point);
      for (int g = 0; g < fields_.field_count; ++g) {
        if (g == field || active_.compact_index(g * points_ + point % points_) < 0) continue;
        neighbour_columns(ijk, g, other);
        TALUS_PETSC(MatSetValuesBlocked(J, 1, &r, neighbours, other.data(), zeros.data(), ADD_VALUES));
      }
    }
    if (!left.empty()) {
      // A contact point's share of its natural-map row: P_i times the share
      // of its momentum row (contact_row_factors).
      const Eigen::Map<const Eigen::Matrix<double, dim, dim, Eigen::RowMajor>> P(left.data() +
                                                                                 static_cast<std::size_t>(point) * dim * dim);
      if (!P.isIdentity(0.0))
        for (int n = 0; n < neighbours; ++n) {
          Eigen::Map<Eigen::Matrix<double, dim, dim, Eigen::RowMajor>, 0, Eigen::OuterStride<>> block(
              row + n * dim, Eigen::OuterStride<>(row_length));
          block = (P * block).eval();
        }
    }
    const PetscInt r = active_.compact_index(point);
    TALUS_PETSC(MatSetValuesBlocked(J, 1, &r, neighbours, cols, row, ADD_VALUES));
  }
  // The mass on the diagonal blocks, by their owners: m_i I, or on a contact
  // point m_i P_i + Q_i.
  PetscInt first;
  TALUS_PETSC(VecGetOwnershipRange(v, &first, nullptr));
  first /= dim;
  const auto& owned = active_.owned_points();
  std::vector<Matrix<dim>> diagonal(owned.size());
  for (std::size_t k = 0; k < owned.size(); ++k) diagonal[k] = fields_.mass[owned[k]] * Matrix<dim>::Identity();
  for (std::size_t c = 0; c < contact_left_.size() && !left.empty(); ++c) {
    const std::size_t k = static_cast<std::size_t>(contacts_[c].row / dim);
    diagonal[k] = contacts_[c].rigid >= 0
                      ? Matrix<dim>(contact_left_[c] + (rigid_jacobian_compliance_ / contacts_[c].rho) * contact_right_[c])
                      : Matrix<dim>(fields_.mass[owned[k]] * contact_left_[c] + contact_right_[c]);
  }
  for (std::size_t c = 0; c < body_left_.size() && !left.empty(); ++c) {
    // Row a: m_a P + Q on v_a, -Q on v_b; row b: m_a on v_a (R_a's mass
    // term), its own m_b below.
    const BodyContactPoint<dim>& cp = body_contacts_[c];
    const std::size_t k = static_cast<std::size_t>(cp.row_a / dim);
    diagonal[k] = fields_.mass[cp.node_a] * body_left_[c] + body_right_[c];
    const PetscInt ra = first + cp.row_a / dim, rb = first + cp.row_b / dim;
    const Eigen::Matrix<double, dim, dim, Eigen::RowMajor> ab = -body_right_[c];
    const Eigen::Matrix<double, dim, dim, Eigen::RowMajor> ba = fields_.mass[cp.node_a] * Matrix<dim>::Identity();
    TALUS_PETSC(MatSetValuesBlocked(J, 1, &ra, 1, &rb, ab.data(), ADD_VALUES));
    if (rigid_node(cp.node_b)) {
      const RigidBody<dim>& body = rigid_body_of(cp.node_b);
      const PetscInt q[2] = {body.block, body.block + 1};
      const Eigen::Matrix<double, RigidBody<dim>::unknowns, dim, Eigen::RowMajor> qa =
          body.velocity_map(grid_.point_position(grid_.global_index(cp.node_b % points_))).transpose() * ba;
      TALUS_PETSC(MatSetValuesBlocked(J, 2, q, 1, &ra, qa.data(), ADD_VALUES));
    } else {
      TALUS_PETSC(MatSetValuesBlocked(J, 1, &rb, 1, &ra, ba.data(), ADD_VALUES));
    }
  }
  for (std::size_t k = 0; k < owned.size(); ++k) {
    const PetscInt r = first + static_cast<PetscInt>(k);
    const Eigen::Matrix<double, dim, dim, Eigen::RowMajor> block = diagonal[k];
    TALUS_PETSC(MatSetValuesBlocked(J, 1, &r, 1, &r, block.data(), ADD_VALUES));
  }
  if (!rigid_.empty()) rigid_jacobian(J, left);
  TALUS_PETSC(MatAssemblyBegin(J, MAT_FINAL_ASSEMBLY));
  TALUS_PETSC(MatAssemblyEnd(J, MAT_FINAL_ASSEMBLY));
  assembly_seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t_assembly).count();
}

template <int dim>
Mat MomentumSystem<dim>::create_matrix(MatType type) const {
  // Point i couples with point j when one particle's stencil holds both, so
  // |i_a - j_a| <= reach on every axis (2 for quadratic B-splines, 1 for hats,
  // one more with domain quadrature).
  // Counting the active points of that neighbourhood gives the block
  // preallocation directly (exact inside a body, an upper bound at its edges;
  // unused slots are squeezed out at assembly). The ghost width equals the
  // reach, so every neighbour's compact index is known on this rank.
  const int reach = grid_.reach();
  const PetscInt npoints = active_.owned_count(), nloc = active_.local_blocks(), nglob = active_.global_count();
  PetscInt first = 0;
  {
    Vec v = active_.create_vector();
    TALUS_PETSC(VecGetOwnershipRange(v, &first, nullptr));
    TALUS_PETSC(VecDestroy(&v));
  }
  first /= dim;
  std::vector<PetscInt> d_nnz(nloc, 0), o_nnz(nloc, 0);
  const auto& owned = active_.owned_points();
  const auto& gs = grid_.ghost_start();
  const auto& gm = grid_.ghost_size();
  for (PetscInt k = 0; k < npoints; ++k) {
    const int field = owned[k] / points_;
    const bool shared = fields_.field_count > 1 && shared_point(owned[k]);
    const auto ijk = grid_.global_index(owned[k] % points_);
    std::array<int, dim> lo, hi, j;
    for (int a = 0; a < dim; ++a) {
      lo[a] = std::max(ijk[a] - reach, gs[a]);
      hi[a] = std::min(ijk[a] + reach, gs[a] + gm[a] - 1);
      j[a] = lo[a];
    }
    while (true) {
      // The node's own field; where fields meet, every field (jacobian()).
      for (int g = 0; g < fields_.field_count; ++g) {
        if (g != field && !shared) continue;
        const PetscInt c = active_.compact_index(g * points_ + grid_.local_index(j));
        if (c >= 0) (c >= first && c < first + nloc ? d_nnz[k] : o_nnz[k])++;
      }
      int a = 0;
      while (a < dim && ++j[a] > hi[a]) j[a] = lo[a], ++a;
      if (a == dim) break;
    }
    // A rigid body's point couples with the body's motion.
    if (rigid_node(owned[k])) {
      const PetscInt q = rigid_body_of(owned[k]).block;
      (q >= first && q < first + nloc ? d_nnz[k] : o_nnz[k]) += 2;
    }
  }
  // A body's rows couple with any unknown (the points where it touches
  // another body or an obstacle): full rows, squeezed at assembly.
  for (PetscInt k = npoints; k < nloc; ++k) d_nnz[k] = nloc, o_nnz[k] = nglob - nloc;
  Mat J;
  TALUS_PETSC(MatCreate(grid_.comm(), &J));
  TALUS_PETSC(MatSetSizes(J, nloc * dim, nloc * dim, nglob * dim, nglob * dim));
  TALUS_PETSC(MatSetBlockSize(J, dim));
  // AIJ works with every preconditioner (GAMG, hypre, ILU, all direct
  // solvers); BAIJ assembles faster, with one index lookup per (point, point)
  // pair instead of dim^2, and factors faster (dim x dim block kernels), where
  // the preconditioner accepts it (NewtonSolver chooses; docs/solver.md).
  TALUS_PETSC(MatSetType(J, type));
  TALUS_PETSC(MatSetOptionsPrefix(J, "talus_"));
  TALUS_PETSC(MatSetFromOptions(J));
  TALUS_PETSC(MatXAIJSetPreallocation(J, dim, d_nnz.data(), o_nnz.data(), nullptr, nullptr));
  TALUS_PETSC(MatSetOption(J, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_TRUE));
  // Rigid-body modes at the points' positions: the near null space that lets
  // algebraic multigrid (GAMG) treat the elastic operator well.
  Vec coordinates = active_.create_vector();
  PetscScalar* c;
  TALUS_PETSC(VecGetArray(coordinates, &c));
  for (PetscInt k = 0; k < npoints; ++k) {
    const Vector<dim> x = grid_.point_position(grid_.global_index(owned[k] % points_));
    for (int a = 0; a < dim; ++a) c[dim * k + a] = x[a];
  }
  TALUS_PETSC(VecRestoreArray(coordinates, &c));
  MatNullSpace rigid;
  TALUS_PETSC(MatNullSpaceCreateRigidBody(coordinates, &rigid));
  TALUS_PETSC(MatSetNearNullSpace(J, rigid));
  TALUS_PETSC(MatNullSpaceDestroy(&rigid));
  TALUS_PETSC(VecDestroy(&coordinates));
  return J;
}

template bool MomentumSystem<2>::shared_point(int) const;
template bool MomentumSystem<3>::shared_point(int) const;
template void MomentumSystem<2>::neighbour_columns(const std::array<int, 2>&, int, std::vector<PetscInt>&,
                                                   std::vector<int>*) const;
template void MomentumSystem<3>::neighbour_columns(const std::array<int, 3>&, int, std::vector<PetscInt>&,
                                                   std::vector<int>*) const;
template void MomentumSystem<2>::jacobian(Vec, Mat);
template void MomentumSystem<3>::jacobian(Vec, Mat);
template Mat MomentumSystem<2>::create_matrix(MatType) const;
template Mat MomentumSystem<3>::create_matrix(MatType) const;

}  // namespace talus
