#include "talus/particles/particles.hpp"

#include "talus/materials/material.hpp"

namespace talus {

template <int dim>
Particles<dim>::Particles(const Grid<dim>& grid) {
  // Creation order matters (../shared/TOOLCHAIN.md): type, dimension, swarm
  // type, cell DM, fields, finalize.
  TALUS_PETSC(DMCreate(grid.comm(), &swarm_));
  TALUS_PETSC(DMSetType(swarm_, DMSWARM));
  TALUS_PETSC(DMSetDimension(swarm_, dim));
  TALUS_PETSC(DMSwarmSetType(swarm_, DMSWARM_PIC));
  TALUS_PETSC(DMSwarmSetCellDM(swarm_, grid.dm()));
  TALUS_PETSC(DMSwarmInitializeFieldRegister(swarm_));
  TALUS_PETSC(DMSwarmRegisterPetscDatatypeField(swarm_, field::velocity, dim, PETSC_REAL));
  TALUS_PETSC(DMSwarmRegisterPetscDatatypeField(swarm_, field::affine_velocity, dim * dim, PETSC_REAL));
  TALUS_PETSC(DMSwarmRegisterPetscDatatypeField(swarm_, field::displacement, dim, PETSC_REAL));
  TALUS_PETSC(DMSwarmRegisterPetscDatatypeField(swarm_, field::mass, 1, PETSC_REAL));
  TALUS_PETSC(DMSwarmRegisterPetscDatatypeField(swarm_, field::initial_volume, 1, PETSC_REAL));
  TALUS_PETSC(DMSwarmRegisterPetscDatatypeField(swarm_, field::deformation_gradient, dim * dim, PETSC_REAL));
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
void Particles<dim>::migrate() {
  // PIC migration locates each particle in the cell DM (the grid's DMDA) and
  // sends those that left the rank's cells to the neighbouring ranks. A
  // particle that is found nowhere (it left the grid, or crossed more than a
  // whole neighbouring subdomain in one step) would be dropped: refuse that.
  const PetscInt before = global_count();
  TALUS_PETSC(DMSwarmMigrate(swarm_, PETSC_TRUE));
  const PetscInt after = global_count();
  if (after != before)
    throw SimulationError("particle migration lost " + std::to_string(before - after) +
                          " particles (they left the grid or moved farther than a neighbouring rank's subdomain "
                          "in one step)");
}

template class Particles<2>;
template class Particles<3>;

}  // namespace talus
