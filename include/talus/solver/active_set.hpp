#pragma once
// The unknowns of one implicit step: velocities of the active grid points
// (points carrying mass above a small threshold) only, numbered compactly
// across ranks. An empty part of the grid adds nothing to the system.
#include <petscvec.h>

#include <array>
#include <vector>

#include "talus/io/config.hpp"
#include "talus/transfer/transfer.hpp"

namespace talus {

template <int dim>
class ActiveSet {
 public:
  ActiveSet() = default;
  ~ActiveSet();
  ActiveSet(const ActiveSet&) = delete;
  ActiveSet& operator=(const ActiveSet&) = delete;

  // Marks points with m_i > threshold active, numbers them (owned points of
  // rank r after those of ranks < r), and builds the scatter between the
  // compact unknown vector and the ghosted grid arrays. Velocity components
  // on fixed/slip faces are flagged as constrained (they stay unknowns, with
  // the trivial equation m_i v_i = 0, so the system size is active points x dim).
  // `extra_blocks` blocks of dim unknowns that are no grid point (the
  // rigid bodies' motions, rigid_body.hpp) follow the last rank's points.
  void build(const Grid<dim>& grid, const GridFields<dim>& fields, double threshold,
             const std::array<FaceCondition, 6>& faces, int extra_blocks = 0);

  PetscInt owned_count() const { return owned_count_; }    // owned active points
  PetscInt local_blocks() const { return owned_count_ + extra_local_; }  // owned unknown blocks
  PetscInt global_count() const { return global_count_; }  // unknown blocks, all ranks (extra ones included)
  PetscInt extra_first() const { return extra_first_; }     // global block index of the first extra block
  PetscInt compact_index(int local_point) const { return compact_[local_point]; }
  const std::vector<int>& owned_points() const { return owned_points_; }  // ghosted index, compact order
  bool constrained(int local_point, int component) const { return constrained_[dim * local_point + component]; }
  // Holds every component of a point (the equilibrium stage's `contact:
  // stick`, docs/equilibrium.md): its equation becomes m_i v_i = 0.
  void constrain(int local_point) {
    for (int c = 0; c < dim; ++c) {
      if (!constrained_[dim * local_point + c] && compact_[local_point] >= 0)
        constrained_entries_.push_back(dim * local_point + c);
      constrained_[dim * local_point + c] = 1;
    }
  }
  // The constrained components of the active points, as positions i dim + c
  // in the ghosted arrays (the inactive points' are zero there anyway).
  const std::vector<int>& constrained_entries() const { return constrained_entries_; }
  // The active points' components, as positions i dim + c in the ghosted arrays.
  const std::vector<PetscInt>& active_entries() const { return active_entries_; }

  // A new unknown vector (block size dim), compact layout.
  Vec create_vector() const;
  // Compact -> ghosted arrays (dim per point; inactive points get 0).
  void to_grid(Vec compact, std::vector<double>& ghosted) const;
  // The same into a vector kept between calls, of the grid's size plus
  // `padding` entries: set to zero at its first use, then only the active
  // entries are written (every other entry must stay zero meanwhile).
  void to_grid_active(Vec compact, std::vector<double>& ghosted, std::size_t padding = 0) const;
  // Ghosted arrays -> compact, summing contributions of every rank (ADD).
  void add_to_compact(const std::vector<double>& ghosted, Vec compact) const;

 private:
  void destroy();
  MPI_Comm comm_ = MPI_COMM_NULL;
  PetscInt owned_count_ = 0, global_count_ = 0, extra_local_ = 0, extra_first_ = 0;
  std::vector<PetscInt> compact_;
  std::vector<int> owned_points_;
  std::vector<unsigned char> constrained_;
  std::vector<int> constrained_entries_;
  // Positions i dim + c of the active points' components in the ghosted
  // arrays: work_ is zero everywhere else, always (to_grid, add_to_compact).
  std::vector<PetscInt> active_entries_;
  Vec layout_ = nullptr;  // compact template
  Vec work_ = nullptr;    // sequential, ghosted points x dim
  VecScatter scatter_ = nullptr;
};

}  // namespace talus
