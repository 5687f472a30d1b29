#pragma once
// Material points in a PETSc DMSwarm. Every per-particle quantity is a named
// swarm field, so that DMSwarmMigrate carries all of them between ranks.
//
// The swarm is of PETSc's basic type: migration sends each particle to the
// rank named in its DMSwarm_rank field, which talus sets from the grid's
// ownership (Grid::owner_rank). A PIC swarm would locate particles in its
// cell DM and could only hand them to neighbouring ranks; after the grid is
// re-partitioned (talus/grid/partition.hpp) a particle may belong to any rank.
#include <petscdmswarm.h>

#include <cstdint>
#include <string>

#include "talus/core/errors.hpp"
#include "talus/core/types.hpp"
#include "talus/grid/grid.hpp"

namespace talus {

// Field names, in one place (also the array names of the VTK output).
namespace field {
inline constexpr const char* position = "position";                 // dim
inline constexpr const char* velocity = "velocity";                 // dim
inline constexpr const char* affine_velocity = "affine_velocity";   // dim x dim (APIC C_p), row-major
inline constexpr const char* displacement = "displacement";         // dim
inline constexpr const char* mass = "mass";                         // 1
inline constexpr const char* initial_volume = "initial_volume";     // 1
inline constexpr const char* deformation_gradient = "deformation_gradient";  // dim x dim, row-major
// J = V / V0, advanced by the product det(I + h grad v) of the steps: det F
// taken from F's entries loses its digits once a long stretch (the tip of a
// spreading front, stretched 1e19-fold) makes F ill-conditioned.
inline constexpr const char* volume_ratio = "volume_ratio";         // 1
// Kirchhoff stress tau = J sigma (Voigt, tension positive): the internal
// force is V0 tau grad N. The VTK output converts it to Cauchy stress.
inline constexpr const char* stress = "stress";                     // 6
inline constexpr const char* material_state = "material_state";     // max_state_size internal variables
inline constexpr const char* cumulative_plastic_strain = "cumulative_plastic_strain";  // 1
// Volumetric (logarithmic) strain of the voids opened where the material
// separated at the yield surface's apex; not part of the solid's volume.
inline constexpr const char* separation_strain = "separation_strain";  // 1
inline constexpr const char* material_id = "material_id";           // int
inline constexpr const char* body_id = "body_id";                   // int
inline constexpr const char* particle_id = "particle_id";           // int64, global and unique
}  // namespace field

// RAII access to one swarm field as a typed array.
template <class T>
class FieldView {
 public:
  FieldView(DM swarm, const char* name) : swarm_(swarm), name_(name) {
    TALUS_PETSC(DMSwarmGetField(swarm_, name_, &block_, nullptr, reinterpret_cast<void**>(&data_)));
  }
  ~FieldView() { DMSwarmRestoreField(swarm_, name_, &block_, nullptr, reinterpret_cast<void**>(&data_)); }
  FieldView(const FieldView&) = delete;
  FieldView& operator=(const FieldView&) = delete;
  T* data() const { return data_; }
  T& operator[](std::size_t i) const { return data_[i]; }
  PetscInt block() const { return block_; }

 private:
  DM swarm_;
  const char* name_;
  PetscInt block_ = 0;
  T* data_ = nullptr;
};

template <int dim>
class Particles {
 public:
  explicit Particles(MPI_Comm comm);
  ~Particles();
  Particles(const Particles&) = delete;
  Particles& operator=(const Particles&) = delete;

  DM swarm() const { return swarm_; }
  PetscInt local_count() const;
  PetscInt global_count() const;
  // Appends `n` particles on this rank and returns the index of the first.
  PetscInt add(PetscInt n);
  // Sends every particle to the rank that owns its cell in `grid`
  // (DMSwarmMigrate); throws if the global count changes.
  void migrate(const Grid<dim>& grid);

 private:
  DM swarm_ = nullptr;
};

}  // namespace talus
