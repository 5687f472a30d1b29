#pragma once
// HDF5 checkpoints of the complete state of a run (docs/checkpoints.md).
//
// One file per checkpoint, written collectively with MPI-IO by all ranks to a
// temporary name and renamed: /particles/<field> datasets of shape
// (particles, components) in rank order, and /run attributes with the time,
// the step count, the time-step controller and the output series. Restarting
// reads every particle and keeps the ones whose cell this rank owns, so a run
// can restart on any number of ranks; on the same number of ranks every
// particle comes back to its rank in its order (the grid's ownership ranges
// are stored and restored, docs/parallel.md). On one rank the restarted run
// repeats the uninterrupted one bit for bit; on several ranks to the solver
// tolerance (the parallel reductions already make two uninterrupted runs
// differ in the last bits; docs/checkpoints.md#restart).
#include <array>
#include <string>

#include "talus/solver/energy_balance.hpp"
#include <utility>
#include <vector>

#include "talus/grid/grid.hpp"
#include "talus/io/config.hpp"
#include "talus/io/obstacle_loads.hpp"
#include "talus/particles/particles.hpp"

namespace talus {

// Everything besides the particles that the run loop needs to continue.
struct RunState {
  int format = 0;  // the file's checkpoint format (docs/checkpoints.md)
  double time = 0.0;
  long steps = 0, cutbacks = 0;
  // StepController
  double step_size = 0.0;
  long patience = 0, calm = 0, since_growth = 0;
  // Output series: the next output time and the files written so far.
  double next_output = 0.0;
  std::vector<std::pair<double, std::string>> outputs;
  // Where those outputs are: the run's output.directory. Stored relative to
  // the checkpoint file's directory (so that a run directory moved as a whole
  // keeps working), read back as a path from the current directory.
  std::string output_directory;
  // The grid's points per process column along each axis when the checkpoint
  // was written (empty in checkpoints from before balanced ranks).
  std::vector<std::vector<int>> grid_ownership;
  // The Newton predictor: the last step's acceleration at the grid points
  // where it is known (GridFields::last_acceleration), as rows of the global
  // point index (x fastest) and dim components. On writing, each rank gives
  // its owned points; on reading, every rank gets all rows.
  std::vector<long long> accelerated_points;
  std::vector<double> point_acceleration;
  // What the particle state depends on (CaseConfig::fingerprint), and the
  // talus that wrote it: a restart refuses a checkpoint of another case.
  CaseFingerprint fingerprint;
  std::string talus_version;
  // The energy balance (docs/energy.md): K0 + G0 + E0 and the terms summed
  // since t = 0, in EnergyTerms::names() order.
  double initial_energy = 0.0;
  std::array<double, EnergyTerms::count> energy_terms{};
  // The loads on the obstacles (ObstacleLoads; /obstacles, present when the
  // case has obstacles): running impulses, peaks, the steps in the window.
  ObstacleLoads::State obstacle_loads;
  // Written for whoever opens the file, not read back: the obstacle names
  // (the rows of /obstacles), the case file the run was started with.
  std::vector<std::string> obstacle_names;
  std::string case_file;
};

// What a restart checks the checkpoint's particles against: this case's
// grid box, materials (densities) and bodies (their materials).
struct CheckpointExpectations {
  std::vector<double> lower, upper;
  std::vector<double> density;      // per material
  std::vector<int> body_material;   // per body
  int obstacles = 0;                // the case's obstacles and frictional faces (rows of /obstacles)
  int velocity_fields = 1;          // grid/accelerated_points index field f's points after f x the grid's points
};

// The /run attributes alone (all ranks), e.g. to restore the grid's
// ownership before the particles are read.
RunState read_run_state(const std::string& path, MPI_Comm comm);

template <int dim>
void write_checkpoint(const std::string& path, const Particles<dim>& particles, const RunState& state, MPI_Comm comm);

// Replaces the particles with those of the checkpoint (all ranks), after
// checking every dataset (shape, finiteness, ranges, consistency with
// `expected`); a violation is an InputError "not a valid talus checkpoint".
template <int dim>
RunState read_checkpoint(const std::string& path, Particles<dim>& particles, const Grid<dim>& grid,
                         const CheckpointExpectations& expected, MPI_Comm comm);

// The sections of `config` whose text differs from the checkpoint's, as one
// message ("" when the checkpoint belongs to this case).
std::string fingerprint_mismatch(const RunState& checkpoint, const CaseFingerprint& config);

}  // namespace talus
