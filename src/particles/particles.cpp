#include "talus/particles/particles.hpp"

#include "talus/materials/material.hpp"

namespace talus {

template <int dim>
Particles<dim>::Particles(MPI_Comm comm) {
  // Creation order matters (../shared/TOOLCHAIN.md): type, dimension, swarm
  // type, fields, finalize.
  TALUS_PETSC(DMCreate(comm, &swarm_));
  TALUS_PETSC(DMSetType(swarm_, DMSWARM));
  TALUS_PETSC(DMSetDimension(swarm_, dim));
  TALUS_PETSC(DMSwarmSetType(swarm_, DMSWARM_BASIC));
  TALUS_PETSC(DMSwarmInitializeFieldRegister(swarm_));
  TALUS_PETSC(DMSwarmRegisterPetscDatatypeField(swarm_, field::position, dim, PETSC_REAL));
  TALUS_PETSC(DMSwarmRegisterPetscDatatypeField(swarm_, field::velocity, dim, PETSC_REAL));
  TALUS_PETSC(DMSwarmRegisterPetscDatatypeField(swarm_, field::affine_velocity, dim * dim, PETSC_REAL));
  TALUS_PETSC(DMSwarmRegisterPetscDatatypeField(swarm_, field::displacement, dim, PETSC_REAL));
  TALUS_PETSC(DMSwarmRegisterPetscDatatypeField(swarm_, field::mass, 1, PETSC_REAL));
  TALUS_PETSC(DMSwarmRegisterPetscDatatypeField(swarm_, field::initial_volume, 1, PETSC_REAL));
  TALUS_PETSC(DMSwarmRegisterPetscDatatypeField(swarm_, field::deformation_gradient, dim * dim, PETSC_REAL));
  TALUS_PETSC(DMSwarmRegisterPetscDatatypeField(swarm_, field::volume_ratio, 1, PETSC_REAL));
  TALUS_PETSC(DMSwarmRegisterPetscDatatypeField(swarm_, field::stress, 6, PETSC_REAL));
  TALUS_PETSC(DMSwarmRegisterPetscDatatypeField(swarm_, field::material_state, max_state_size, PETSC_REAL));
  TALUS_PETSC(DMSwarmRegisterPetscDatatypeField(swarm_, field::cumulative_plastic_strain, 1, PETSC_REAL));
  TALUS_PETSC(DMSwarmRegisterPetscDatatypeField(swarm_, field::separation_strain, 1, PETSC_REAL));
  TALUS_PETSC(DMSwarmRegisterPetscDatatypeField(swarm_, field::material_id, 1, PETSC_INT));
  TALUS_PETSC(DMSwarmRegisterPetscDatatypeField(swarm_, field::body_id, 1, PETSC_INT));
  TALUS_PETSC(DMSwarmRegisterPetscDatatypeField(swarm_, field::particle_id, 1, PETSC_INT64));
  TALUS_PETSC(DMSwarmFinalizeFieldRegister(swarm_));
  TALUS_PETSC(DMSwarmSetLocalSizes(swarm_, 0, 1024));
}

template <int dim>
Particles<dim>::~Particles() {
  DMDestroy(&swarm_);
}

template <int dim>
PetscInt Particles<dim>::local_count() const {
  PetscInt n = 0;
  TALUS_PETSC(DMSwarmGetLocalSize(swarm_, &n));
  return n;
}

template <int dim>
PetscInt Particles<dim>::global_count() const {
  PetscInt n = 0;
  TALUS_PETSC(DMSwarmGetSize(swarm_, &n));
  return n;
}

template <int dim>
PetscInt Particles<dim>::add(PetscInt n) {
  const PetscInt first = local_count();
  TALUS_PETSC(DMSwarmSetLocalSizes(swarm_, first + n, 1024));
  return first;
}

template <int dim>
void Particles<dim>::migrate(const Grid<dim>& grid) {
  // Basic migration pushes each particle to the rank in its DMSwarm_rank
  // field. Grid::owner_rank clamps to the grid, so no particle can be lost;
  // the count is checked all the same, as the invariant it is.
  const PetscInt before = global_count();
  {
    FieldView<PetscReal> x(swarm_, field::position);
    FieldView<PetscInt> owner(swarm_, DMSwarmField_rank);
    const PetscInt n = local_count();
    for (PetscInt p = 0; p < n; ++p) owner[p] = grid.owner_rank(Eigen::Map<const Vector<dim>>(x.data() + dim * p));
  }
  TALUS_PETSC(DMSwarmMigrate(swarm_, PETSC_TRUE));
  const PetscInt after = global_count();
  if (after != before)
    throw SimulationError("particle migration lost " + std::to_string(before - after) +
                          " particles");
}

template class Particles<2>;
template class Particles<3>;

}  // namespace talus
