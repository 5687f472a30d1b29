// Restarts from a checkpoint (docs/checkpoints.md): the particles, the run
// state, the grid's ownership, the Newton predictor's accelerations and the
// energy balance's sums.
#include "talus/simulation.hpp"

#include <cmath>
#include <limits>

#include "talus/io/yaml_section.hpp"

namespace talus {

template <int dim>
void Simulation<dim>::restart(const std::string& checkpoint_path) {
  // On the number of ranks that wrote it, the checkpoint's grid ownership
  // comes back, so that every particle returns to its rank and the run
  // continues bit for bit; on another number, the ranks are balanced anew.
  const RunState header = read_run_state(checkpoint_path, comm_);
  // The particle state belongs to one case: another grid, material list,
  // body list, boundary, obstacle, gravity or transfer would run it on a
  // wrong state (docs/checkpoints.md#restart-with-a-changed-case).
  const std::string mismatch = fingerprint_mismatch(header, config_.fingerprint);
  if (!mismatch.empty())
    throw InputError(checkpoint_path + ": the checkpoint belongs to another case: " + mismatch);
  int ranks = 1;
  MPI_Comm_size(comm_, &ranks);
  const auto& stored = header.grid_ownership;
  int stored_ranks = stored.size() == static_cast<std::size_t>(dim) ? 1 : 0;
  for (const auto& axis : stored) stored_ranks *= static_cast<int>(axis.size());
  const bool restore = stored_ranks == ranks;
  if (restore) {
    Ownership<dim> ownership;
    for (int a = 0; a < dim; ++a) {
      long sum = 0;
      for (int n : stored[a]) {
        if (n < grid_->stencil_width())
          throw InputError(checkpoint_path + ": not a valid talus checkpoint: a process column of " +
                           std::to_string(n) + " grid points in grid_ownership");
        sum += n;
      }
      if (sum != grid_->points()[a])
        throw InputError(checkpoint_path + ": the checkpoint's grid has " + std::to_string(sum) +
                         " points along axis " + std::to_string(a) + ", this case's grid " +
                         std::to_string(grid_->points()[a]));
      ownership[a] = stored[a];
    }
    if (ownership != grid_->ownership()) repartition(ownership);
  }
  CheckpointExpectations expected;
  for (int a = 0; a < dim; ++a) {
    expected.lower.push_back(grid_->lower()[a]);
    expected.upper.push_back(grid_->upper()[a]);
  }
  for (const Material* m : materials_) expected.density.push_back(m->density());
  for (const BodyConfig& b : config_.bodies) expected.body_material.push_back(b.material);
  expected.obstacles = static_cast<int>(obstacles_.size());
  expected.velocity_fields = config_.contact.field_count;
  resume_ = std::make_unique<RunState>(read_checkpoint(checkpoint_path, *particles_, *grid_, expected, comm_));
  time_ = resume_->time;
  if (!restore) {
    balance_ranks(true);
    rebalances_ = 0;
  }
  restore_last_acceleration(*resume_);
  // The energy balance goes on from the checkpoint's sums.
  initial_energy_ = resume_->initial_energy;
  const auto& t = resume_->energy_terms;
  energy_.plastic = t[0], energy_.contact = t[1], energy_.obstacle_work = t[2];
  energy_.faces = t[3], energy_.transfer = t[4], energy_.time_integration = t[5], energy_.correction_work = t[6];
  particle_energy_ = particle_energy();
  // The obstacle loads go on from the checkpoint's: running impulses, peaks,
  // and the steps inside the window, which must be the same window.
  if (!obstacles_.empty()) {
    const double stored = resume_->obstacle_loads.window;
    if (stored != loads_.window())
      throw InputError(checkpoint_path + ": output.force_window = " + number_text(loads_.window()) +
                       " s, but the checkpoint's window averages were over " + number_text(stored) +
                       " s and it holds only the steps of that window; restart with force_window: " +
                       number_text(stored) + ", or run the case from t = 0");
    loads_.restore(resume_->obstacle_loads);
  }
}

template <int dim>
void Simulation<dim>::store_last_acceleration(RunState& state) const {
  state.accelerated_points.clear();
  state.point_acceleration.clear();
  const int n = static_cast<int>(last_acceleration_.size()) / dim, points = grid_->ghosted_count();
  long long grid_points = 1;
  for (int a = 0; a < dim; ++a) grid_points *= grid_->points()[a];
  for (int i = 0; i < n; ++i) {
    if (!std::isfinite(last_acceleration_[dim * i])) continue;
    const auto ijk = grid_->global_index(i % points);
    long long index = 0;  // x fastest, as the DMDA's natural ordering, field by field
    for (int a = dim - 1; a >= 0; --a) index = index * grid_->points()[a] + ijk[a];
    index += static_cast<long long>(i / points) * grid_points;
    state.accelerated_points.push_back(index);
    for (int a = 0; a < dim; ++a) state.point_acceleration.push_back(last_acceleration_[dim * i + a]);
  }
}

template <int dim>
void Simulation<dim>::restore_last_acceleration(const RunState& state) {
  last_acceleration_.clear();
  if (state.accelerated_points.empty()) return;
  const int points = grid_->ghosted_count();
  long long grid_points = 1;
  for (int a = 0; a < dim; ++a) grid_points *= grid_->points()[a];
  last_acceleration_.assign(static_cast<std::size_t>(points) * config_.contact.field_count * dim,
                            std::numeric_limits<double>::quiet_NaN());
  for (std::size_t r = 0; r < state.accelerated_points.size(); ++r) {
    long long index = state.accelerated_points[r] % grid_points;
    const long long field = state.accelerated_points[r] / grid_points;
    if (field >= config_.contact.field_count) continue;
    std::array<int, dim> ijk;
    for (int a = 0; a < dim; ++a) {
      ijk[a] = static_cast<int>(index % grid_->points()[a]);
      index /= grid_->points()[a];
    }
    if (!grid_->is_owned(ijk)) continue;
    const std::size_t i = static_cast<std::size_t>(field) * points + grid_->local_index(ijk);
    for (int a = 0; a < dim; ++a) last_acceleration_[dim * i + a] = state.point_acceleration[dim * r + a];
  }
}

template void Simulation<2>::restart(const std::string&);
template void Simulation<3>::restart(const std::string&);
template void Simulation<2>::store_last_acceleration(RunState&) const;
template void Simulation<3>::store_last_acceleration(RunState&) const;
template void Simulation<2>::restore_last_acceleration(const RunState&);
template void Simulation<3>::restore_last_acceleration(const RunState&);

}  // namespace talus
