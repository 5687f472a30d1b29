// The Jacobian as an operator (docs/solver.md#the-jacobian-as-an-operator):
// its product from the particle tangents, without the matrix.
#include <algorithm>
#include <chrono>

#include <stdexcept>

#include "talus/solver/momentum_system.hpp"
#include "talus/solver/tensor_stencil.hpp"

namespace talus {

template <int dim>
int MomentumSystem<dim>::stencil_nodes() const {
  const int width = grid_.reach() + 1;  // stencil functions per axis
  return dim == 2 ? width * width : width * width * width;
}

template <int dim>
void MomentumSystem<dim>::prepare_operator(Vec v) {
  // Rigid bodies' rows are assembled only (NewtonSolver takes the matrix).
  if (!rigid_.empty()) throw std::logic_error("the Jacobian operator does not hold rigid bodies' rows");
  if (any_contacts_) contact_factors(v);
  if (!evaluated_at(v)) evaluate_particles(v);
  commit_carried_stresses();
  pack_stencils();
}

template <int dim>
const std::vector<int>& MomentumSystem<dim>::product_nodes() {
  // Every node a product adds to: the particles' stencil nodes and the cut
  // cells' nodes. (The padding node after a tensor-product row gets exact
  // zeros added, tensor_stencil.cpp: it stays zero.)
  if (!product_nodes_.empty() || stencils_.empty()) return product_nodes_;
  std::vector<char> written(static_cast<std::size_t>(nodes_), 0);
  for (const int node : packed_local_) written[node] = 1;
  if (ghost_)
    for (const auto& cell : ghost_->cells())
      for (const int node : cell.node) written[node] = 1;
  for (int i = 0; i < nodes_; ++i)
    if (written[i]) product_nodes_.push_back(i);
  return product_nodes_;
}

template <int dim>
void MomentumSystem<dim>::apply_jacobian(Vec x, Vec y) {
  // y = J x with J as jacobian() assembles it, particle by particle:
  //   (J x)_a = m_a x_a + h theta^2 sum_p V_p sum_j dN_a/dx_j (A_p : L_p(x))_ij,
  //   L_p(x) = sum_b x_b (x) grad N_b(x_p),
  // a constrained component's row m x and column zero; a contact point's
  // row P_i (momentum row) + Q_i x_i (contact_row_factors). Per particle
  // about 20 dim^2 multiply-adds against 3 dim^2 n_nodes^2 for its share of
  // the assembled matrix: in 3D (27 nodes) the matrix costs as much as 25
  // products (docs/solver.md#the-jacobian-as-an-operator).
  const auto t0 = std::chrono::steady_clock::now();
  // One node of zeros past the end: the tensor-product rows are read and
  // written padded (tensor_stencil.cpp). Both ghosted vectors are kept for
  // the step's products and zero outside the entries they are given: x
  // outside the active ones, y outside the particles' and cut cells' nodes,
  // zeroed again after each product (the grid can be several times larger).
  active_.to_grid_active(x, operator_x_, dim);
  for (const int e : active_.constrained_entries()) operator_x_[e] = 0.0;
  if (operator_y_.size() != operator_x_.size()) operator_y_.assign(operator_x_.size(), 0.0);
  const double scale = h_ * theta_ * theta_;
  const double* xg = operator_x_.data();
  double* yg = operator_y_.data();
  // In 3D the particles with tensor-product stencils (most of them,
  // tensor_stencil.hpp), then the others node by node.
  static_assert(sizeof(StressTangent) == sizeof(double) * nS * nL, "tangents stored contiguously");
  const bool tensor = !tensor_base_.empty();
  if constexpr (dim == 3) {
    TensorStencilProduct<dim> product;
    product.stencils = tensor_stencils();
    product.x = xg;
    product.y = yg;
    product.stiff = stiff_.data();
    product.tangent = tangent_.empty() ? nullptr : tangent_[0].data();
    product.volume = reference_volume_.data();
    product.scale = scale;
    if (tensor) add_tensor_stencil_products(product);
  }
  for (std::size_t p = 0; p < stencils_.size(); ++p) {
    if (!stiff_[p] || (tensor && tensor_base_[p] >= 0)) continue;
    const auto [n, local, gradient] = nodes_of(p);
    // One pass over the nodes gathers L(k, l) = sum_b x_b,k dN_b/dx_l
    // (row-major, k dim + l: A's columns), with dim^2 independent sums; a
    // second pass scatters y_a,i += sum_j T(i, j) dN_a/dx_j. (Eigen's
    // products over the n x dim node matrices ran dim^2 strided passes.)
    std::array<double, nL> L{};
    for (int b = 0; b < n; ++b) {
      const double* xb = xg + static_cast<std::size_t>(dim) * local[b];
      const double* gb = gradient + dim * b;
      for (int k = 0; k < dim; ++k)
        for (int l = 0; l < dim; ++l) L[k * dim + l] += xb[k] * gb[l];
    }
    const Eigen::Matrix<double, nS, 1> ts =
        scale * reference_volume_[p] * tangent_[p].lazyProduct(Eigen::Map<const Eigen::Matrix<double, nL, 1>>(L.data()));
    std::array<double, nL> t;
    for (int i = 0; i < dim; ++i)
      for (int j = 0; j < dim; ++j) t[i * dim + j] = ts[stress_row<dim>(i, j)];
    for (int a = 0; a < n; ++a) {
      double* ya = yg + static_cast<std::size_t>(dim) * local[a];
      const double* ga = gradient + dim * a;
      for (int i = 0; i < dim; ++i) {
        double sum = 0.0;
        for (int j = 0; j < dim; ++j) sum += t[i * dim + j] * ga[j];
        ya[i] += sum;
      }
    }
  }
  if (ghost_) ghost_->add_product(operator_x_, operator_y_, h_ * h_ * theta_);
  TALUS_PETSC(VecZeroEntries(y));
  active_.add_to_compact(operator_y_, y);
  for (const int node : product_nodes()) std::fill_n(operator_y_.begin() + static_cast<std::ptrdiff_t>(dim) * node, dim, 0.0);
  PetscScalar* out;
  const PetscScalar* in;
  TALUS_PETSC(VecGetArray(y, &out));
  TALUS_PETSC(VecGetArrayRead(x, &in));
  const auto& owned = active_.owned_points();
  for (std::size_t k = 0; k < owned.size(); ++k) {
    const int i = owned[k];
    for (int c = 0; c < dim; ++c) {
      const std::size_t r = dim * k + c;
      out[r] = active_.constrained(i, c) ? fields_.mass[i] * in[r] : out[r] + fields_.mass[i] * in[r];
    }
  }
  for (std::size_t c = 0; c < body_contacts_.size(); ++c) {
    // Row b: the point's total balance (both momentum rows); row a: P times
    // a's momentum row + Q (x_a - x_b).
    const BodyContactPoint<dim>& cp = body_contacts_[c];
    Eigen::Map<Vector<dim>> ya(out + cp.row_a), yb(out + cp.row_b);
    const Eigen::Map<const Vector<dim>> xa(in + cp.row_a), xb(in + cp.row_b);
    yb += ya;
    ya = (body_left_[c] * ya + body_right_[c] * (xa - xb)).eval();
  }
  for (std::size_t c = 0; c < contacts_.size() && any_contacts_; ++c) {
    const std::size_t r = static_cast<std::size_t>(contacts_[c].row);
    Eigen::Map<Vector<dim>> row(out + r);
    const Eigen::Map<const Vector<dim>> xi(in + r);
    row = (contact_left_[c] * row + contact_right_[c] * xi).eval();
  }
  TALUS_PETSC(VecRestoreArrayRead(x, &in));
  TALUS_PETSC(VecRestoreArray(y, &out));
  operator_seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

template <int dim>
void MomentumSystem<dim>::jacobian_block_diagonal(Vec v, Mat D) {
  // The dim x dim diagonal blocks of the Jacobian that apply_jacobian
  // multiplies by (the blocks J_aa of jacobian()), for a point-block Jacobi
  // preconditioner (docs/solver.md#point-block-jacobi): per particle and
  // node K_aa(i, k) = h theta^2 V_p sum_jl dN_a/dx_j A_p(ij, kl) dN_a/dx_l,
  // 54 multiply-adds per node in 3D instead of the whole block row's
  // 3 dim^2 n. Then, as in apply_jacobian: the ghost penalty's diagonal, a
  // constrained component's row and column replaced by m, the mass m_a I, and
  // on a contact point P_i (K_aa + m_a I) + Q_i.
  prepare_operator(v);
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<double> blocks(static_cast<std::size_t>(nodes_) * dim * dim, 0.0);  // ghosted, dim x dim per node
  const double scale = h_ * theta_ * theta_;
  for (std::size_t p = 0; p < stencils_.size(); ++p) {
    if (!stiff_[p]) continue;
    const auto [n, local, gradient] = nodes_of(p);
    const StressTangent& A = tangent_[p];
    // K(i, k) = sum_jl T((i, k), (j, l)) g_j g_l with T = h theta^2 V_p A(ij, kl):
    // g g^T is symmetric, so T's columns (j, l) and (l, j) are summed first
    // (nG of them), and each node's block is one nL x nG product,
    // columns outermost so that the nL rows are contiguous multiply-adds.
    constexpr int nG = dim * (dim + 1) / 2;
    const double volume_scale = scale * reference_volume_[p];
    std::array<double, nG * nL> T;  // T[q * nL + (i dim + k)]
    for (int j = 0, q = 0; j < dim; ++j)
      for (int l = j; l < dim; ++l, ++q)
        for (int i = 0; i < dim; ++i)
          for (int k = 0; k < dim; ++k) {
            double t = A(stress_row<dim>(i, j), k * dim + l);
            if (l != j) t += A(stress_row<dim>(i, l), k * dim + j);
            T[q * nL + i * dim + k] = volume_scale * t;
          }
    for (int a = 0; a < n; ++a) {
      if (active_.compact_index(local[a]) < 0) continue;
      const double* ga = gradient + dim * a;
      std::array<double, nG> gg;
      for (int j = 0, q = 0; j < dim; ++j)
        for (int l = j; l < dim; ++l, ++q) gg[q] = ga[j] * ga[l];
      std::array<double, nL> K{};
      for (int q = 0; q < nG; ++q)
        for (int m = 0; m < nL; ++m) K[m] += T[q * nL + m] * gg[q];
      double* block = blocks.data() + static_cast<std::size_t>(nL) * local[a];
      for (int m = 0; m < nL; ++m) block[m] += K[m];
    }
  }
  if (ghost_) {
    const double scale_ghost = h_ * h_ * theta_;
    constexpr int n_cell = GhostPenalty<dim>::cell_nodes;
    for (const auto& cell : ghost_->cells())
      for (int m = 0; m < n_cell; ++m) {
        double* block = blocks.data() + static_cast<std::size_t>(dim) * dim * cell.node[m];
        for (int i = 0; i < dim; ++i) block[i * dim + i] += scale_ghost * cell.coupling[m * n_cell + m];
      }
  }
  // Summed over the ranks (the other ranks' particles' shares of the owned
  // points' blocks), one column of the blocks at a time: a column is dim
  // values per point, as a velocity.
  const auto& owned = active_.owned_points();
  std::vector<Matrix<dim>> diagonal(owned.size());
  {
    // Non-zero only at the nodes a product writes (the particles' and the
    // cut cells' nodes): the rest of the grid stays zero.
    std::vector<double> column(static_cast<std::size_t>(nodes_) * dim, 0.0);
    const std::vector<int>& written = product_nodes();
    Vec summed = active_.create_vector();
    for (int k = 0; k < dim; ++k) {
      for (const int node : written)
        for (int i = 0; i < dim; ++i) column[dim * node + i] = blocks[(static_cast<std::size_t>(node) * dim + i) * dim + k];
      TALUS_PETSC(VecZeroEntries(summed));
      active_.add_to_compact(column, summed);
      const PetscScalar* c;
      TALUS_PETSC(VecGetArrayRead(summed, &c));
      for (std::size_t q = 0; q < owned.size(); ++q)
        for (int i = 0; i < dim; ++i) diagonal[q](i, k) = c[dim * q + i];
      TALUS_PETSC(VecRestoreArrayRead(summed, &c));
    }
    TALUS_PETSC(VecDestroy(&summed));
  }
  for (std::size_t k = 0; k < owned.size(); ++k) {
    const int i = owned[k];
    Matrix<dim>& d = diagonal[k];
    for (int c = 0; c < dim; ++c)
      if (active_.constrained(i, c)) d.row(c).setZero(), d.col(c).setZero();
    d += fields_.mass[i] * Matrix<dim>::Identity();
  }
  for (std::size_t c = 0; c < body_contacts_.size(); ++c) {
    Matrix<dim>& d = diagonal[static_cast<std::size_t>(body_contacts_[c].row_a / dim)];
    d = (body_left_[c] * d + body_right_[c]).eval();
  }
  for (std::size_t c = 0; c < contacts_.size() && any_contacts_; ++c) {
    Matrix<dim>& d = diagonal[static_cast<std::size_t>(contacts_[c].row / dim)];
    d = (contact_left_[c] * d + contact_right_[c]).eval();
  }
  PetscInt first;
  TALUS_PETSC(VecGetOwnershipRange(v, &first, nullptr));
  first /= dim;
  TALUS_PETSC(MatZeroEntries(D));
  for (std::size_t k = 0; k < owned.size(); ++k) {
    const PetscInt r = first + static_cast<PetscInt>(k);
    const Eigen::Matrix<double, dim, dim, Eigen::RowMajor> block = diagonal[k];
    TALUS_PETSC(MatSetValuesBlocked(D, 1, &r, 1, &r, block.data(), INSERT_VALUES));
  }
  TALUS_PETSC(MatAssemblyBegin(D, MAT_FINAL_ASSEMBLY));
  TALUS_PETSC(MatAssemblyEnd(D, MAT_FINAL_ASSEMBLY));
  assembly_seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

template <int dim>
Mat MomentumSystem<dim>::create_block_diagonal_matrix() const {
  const PetscInt nloc = active_.local_blocks(), nglob = active_.global_count();
  Mat D;
  TALUS_PETSC(MatCreate(grid_.comm(), &D));
  TALUS_PETSC(MatSetSizes(D, nloc * dim, nloc * dim, nglob * dim, nglob * dim));
  TALUS_PETSC(MatSetBlockSize(D, dim));
  TALUS_PETSC(MatSetType(D, MATBAIJ));
  TALUS_PETSC(MatXAIJSetPreallocation(D, dim, nullptr, nullptr, nullptr, nullptr));
  TALUS_PETSC(MatSeqBAIJSetPreallocation(D, dim, 1, nullptr));
  TALUS_PETSC(MatMPIBAIJSetPreallocation(D, dim, 1, nullptr, 0, nullptr));
  TALUS_PETSC(MatSetOption(D, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_TRUE));
  return D;
}

template int MomentumSystem<2>::stencil_nodes() const;
template int MomentumSystem<3>::stencil_nodes() const;
template void MomentumSystem<2>::prepare_operator(Vec);
template void MomentumSystem<3>::prepare_operator(Vec);
template void MomentumSystem<2>::apply_jacobian(Vec, Vec);
template void MomentumSystem<3>::apply_jacobian(Vec, Vec);
template void MomentumSystem<2>::jacobian_block_diagonal(Vec, Mat);
template void MomentumSystem<3>::jacobian_block_diagonal(Vec, Mat);
template Mat MomentumSystem<2>::create_block_diagonal_matrix() const;
template Mat MomentumSystem<3>::create_block_diagonal_matrix() const;

}  // namespace talus
