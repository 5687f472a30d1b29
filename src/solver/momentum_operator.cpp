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

template int MomentumSystem<2>::stencil_nodes() const;
template int MomentumSystem<3>::stencil_nodes() const;
template void MomentumSystem<2>::prepare_operator(Vec);
template void MomentumSystem<3>::prepare_operator(Vec);
template void MomentumSystem<2>::apply_jacobian(Vec, Vec);
template void MomentumSystem<3>::apply_jacobian(Vec, Vec);

}  // namespace talus
