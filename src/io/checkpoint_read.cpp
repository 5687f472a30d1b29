#include "talus/io/checkpoint.hpp"

#include <hdf5.h>
#include <sys/resource.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "talus/core/errors.hpp"
#include "talus/io/yaml_section.hpp"
#include "talus/materials/material.hpp"

#include "checkpoint_hdf5.hpp"

// Reading and validating a checkpoint (docs/checkpoints.md); writing it is checkpoint.cpp.
namespace talus {

using namespace checkpoint_hdf5;

namespace {

// The checkpoint file, opened for reading by all ranks of `comm`.
hid_t open_checkpoint(const std::string& path, MPI_Comm comm) {
  if (!std::filesystem::exists(path)) throw InputError(path + ": no such checkpoint file");
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);  // errors become exceptions with our message
  Handle fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose, "file access list");
  check(H5Pset_fapl_mpio(fapl.id, comm, MPI_INFO_NULL), "MPI-IO driver");
  const hid_t file_id = H5Fopen(path.c_str(), H5F_ACC_RDONLY, fapl.id);
  if (file_id < 0) throw InputError(path + ": not an HDF5 checkpoint (cannot open it)");
  return file_id;
}

RunState read_state(const std::string& path, hid_t file_id, int dim) {
  if (H5Lexists(file_id, "run", H5P_DEFAULT) <= 0) throw InputError(path + ": not a talus checkpoint (no /run group)");
  Handle run(H5Gopen2(file_id, "run", H5P_DEFAULT), H5Gclose, "group run");
  const int file_dim = read_attribute<int>(run.id, "dimension", H5T_NATIVE_INT);
  if (file_dim != dim)
    throw InputError(path + ": a " + std::to_string(file_dim) + "D checkpoint, but the case is " +
                     std::to_string(dim) + "D");
  if (H5Aexists(run.id, "checkpoint_format") <= 0)
    throw InputError(path + ": a checkpoint written by a talus before 2026-11-25, without the case fingerprint "
                            "that a restart checks; run the case again from t = 0");
  const int format = read_attribute<int>(run.id, "checkpoint_format", H5T_NATIVE_INT);
  if (format < oldest_checkpoint_format || format > checkpoint_format)
    throw InputError(path + ": checkpoint format " + std::to_string(format) + ", this talus reads formats " +
                     std::to_string(oldest_checkpoint_format) + " to " + std::to_string(checkpoint_format));
  RunState state;
  state.format = format;
  state.talus_version = read_text_attribute(run.id, "talus_version");
  for (const char* section : {"grid", "gravity", "materials", "bodies", "boundaries", "obstacles", "contact", "transfer"})
    state.fingerprint.emplace_back(section, read_text_attribute(run.id, (std::string("case_") + section).c_str()));
  state.time = read_attribute<double>(run.id, "time", H5T_NATIVE_DOUBLE);
  state.steps = read_attribute<long>(run.id, "steps", H5T_NATIVE_LONG);
  state.cutbacks = read_attribute<long>(run.id, "cutbacks", H5T_NATIVE_LONG);
  state.step_size = read_attribute<double>(run.id, "step_size", H5T_NATIVE_DOUBLE);
  state.patience = read_attribute<long>(run.id, "step_patience", H5T_NATIVE_LONG);
  state.calm = read_attribute<long>(run.id, "steps_since_cutback", H5T_NATIVE_LONG);
  state.since_growth = read_attribute<long>(run.id, "steps_since_growth", H5T_NATIVE_LONG);
  state.next_output = read_attribute<double>(run.id, "next_output", H5T_NATIVE_DOUBLE);
  state.initial_energy = read_attribute<double>(run.id, "energy_initial", H5T_NATIVE_DOUBLE);
  for (int k = 0; k < EnergyTerms::count; ++k)
    state.energy_terms[k] =
        read_attribute<double>(run.id, (std::string("energy_") + EnergyTerms::names()[k]).c_str(), H5T_NATIVE_DOUBLE);
  {
    const std::filesystem::path stored = read_text_attribute(run.id, "output_directory");
    const std::filesystem::path here = std::filesystem::path(path).parent_path();
    std::filesystem::path directory = (stored.is_absolute() ? stored : here / stored).lexically_normal();
    if (directory.filename().empty() && directory.has_relative_path()) directory = directory.parent_path();  // "out/"
    state.output_directory = directory.empty() ? "." : directory.string();
  }
  {
    std::istringstream in(read_text_attribute(run.id, "outputs"));
    double t;
    std::string name;
    while (in >> t >> name) state.outputs.emplace_back(t, name);
  }
  if (H5Aexists(run.id, "grid_ownership") > 0) {
    std::istringstream in(read_text_attribute(run.id, "grid_ownership"));
    std::string line;
    while (std::getline(in, line)) {
      std::istringstream numbers(line);
      std::vector<int> axis;
      int n;
      while (numbers >> n) axis.push_back(n);
      if (!numbers.eof()) throw InputError(path + ": not a valid talus checkpoint: unreadable grid_ownership");
      state.grid_ownership.push_back(axis);
    }
  }
  // The run state itself: a NaN time would end the run at once with exit 0,
  // a zero step would never end it.
  const auto fail = [&](const std::string& what) { throw Damaged(what); };
  if (!(std::isfinite(state.time) && state.time >= 0)) fail("time = " + number_text(state.time));
  if (state.steps < 0 || state.cutbacks < 0) fail("a negative step or cut-back count");
  if (!(std::isfinite(state.step_size) && state.step_size > 0)) fail("step_size = " + number_text(state.step_size));
  if (!std::isfinite(state.initial_energy)) fail("energy_initial = " + number_text(state.initial_energy));
  for (int k = 0; k < EnergyTerms::count; ++k)
    if (!std::isfinite(state.energy_terms[k]))
      fail(std::string("energy_") + EnergyTerms::names()[k] + " = " + number_text(state.energy_terms[k]));
  if (state.patience < 0 || state.calm < 0 || state.since_growth < 0) fail("a negative step-controller count");
  if (!(std::isfinite(state.next_output) && state.next_output >= state.time))
    fail("next_output = " + number_text(state.next_output) + " (time " + number_text(state.time) + ")");
  for (const auto& [t, name] : state.outputs)
    if (!(std::isfinite(t) && t >= 0 && t <= state.time) || name.empty() || name.find('/') != std::string::npos)
      fail("an unreadable entry of the output list (" + number_text(t) + " " + name + ")");
  return state;
}

}  // namespace

namespace {

// Runs `body`; a damaged file (an HDF5 call that failed, a value out of
// range) becomes the input error "not a valid talus checkpoint" (exit 2).
template <class F>
auto as_input_error(const std::string& path, F&& body) {
  try {
    return body();
  } catch (const InputError&) {
    throw;
  } catch (const std::exception& e) {
    throw InputError(path + ": not a valid talus checkpoint: " + e.what());
  }
}

// Checks the datasets of all particles (every rank holds them all, so every
// rank reaches the same verdict): finite values, positive masses and volumes,
// masses that match this case's densities, indices in range, unique ids,
// positive volume ratios (format 7, which has none: deformation gradients with
// a positive determinant), positions in the grid.
template <int dim>
void check_particles(const FieldSpec& f, const char* data, std::size_t count, const CheckpointExpectations& expected,
                     int format, std::vector<double>& mass, std::vector<double>& volume,
                     std::vector<PetscInt>& material) {
  const std::string name = f.file_name;
  const auto fail = [&](std::size_t p, const std::string& what) {
    throw Damaged(name + " of particle " + std::to_string(p) + " (row " + std::to_string(p) + "): " + what);
  };
  if (f.kind == Kind::real) {
    const double* v = reinterpret_cast<const double*>(data);
    for (std::size_t p = 0; p < count; ++p)
      for (int c = 0; c < f.components; ++c)
        if (!std::isfinite(v[p * f.components + c])) fail(p, "not a finite number");
    const std::string field = f.swarm_name;
    if (field == field::position) {
      for (std::size_t p = 0; p < count; ++p)
        for (int a = 0; a < dim; ++a)
          if (!(v[dim * p + a] >= expected.lower[a] && v[dim * p + a] <= expected.upper[a]))
            fail(p, number_text(v[dim * p + a]) + " lies outside this case's grid along axis " + std::to_string(a));
    } else if (field == field::volume_ratio) {
      for (std::size_t p = 0; p < count; ++p)
        if (!(v[p] > 0)) fail(p, number_text(v[p]) + " is not positive");
    } else if (field == field::mass || field == field::initial_volume) {
      for (std::size_t p = 0; p < count; ++p)
        if (!(v[p] > 0)) fail(p, number_text(v[p]) + " is not positive");
      (field == field::mass ? mass : volume).assign(v, v + count);
    } else if (field == field::deformation_gradient && format < 8) {
      for (std::size_t p = 0; p < count; ++p) {
        const Eigen::Map<const Eigen::Matrix<double, dim, dim, Eigen::RowMajor>> F(v + dim * dim * p);
        if (!(F.determinant() > 0)) fail(p, "det F = " + number_text(F.determinant()) + " is not positive");
      }
    } else if (field == field::cumulative_plastic_strain || field == field::separation_strain) {
      for (std::size_t p = 0; p < count; ++p)
        if (v[p] < 0) fail(p, number_text(v[p]) + " is negative");
    }
  } else if (f.kind == Kind::index) {
    const PetscInt* v = reinterpret_cast<const PetscInt*>(data);
    const std::string field = f.swarm_name;
    if (field == field::material_id) {
      for (std::size_t p = 0; p < count; ++p)
        if (v[p] < 0 || v[p] >= static_cast<PetscInt>(expected.density.size()))
          fail(p, std::to_string(v[p]) + " is not a material of this case (it has " +
                      std::to_string(expected.density.size()) + ")");
      material.assign(v, v + count);
      if (mass.size() == count && volume.size() == count)
        for (std::size_t p = 0; p < count; ++p) {
          // Seeding sets m = rho V0, and neither changes during a run: another
          // density (or material list) in the case would change the masses.
          const double rho = expected.density[material[p]];
          if (std::abs(mass[p] - rho * volume[p]) > 1e-9 * mass[p])
            fail(p, "its mass " + number_text(mass[p]) + " is not this case's density " + number_text(rho) +
                        " of material " + std::to_string(material[p]) + " times its volume " +
                        number_text(volume[p]));
        }
    } else if (field == field::body_id) {
      for (std::size_t p = 0; p < count; ++p) {
        if (v[p] < 0 || v[p] >= static_cast<PetscInt>(expected.body_material.size()))
          fail(p, std::to_string(v[p]) + " is not a body of this case (it has " +
                      std::to_string(expected.body_material.size()) + ")");
        if (!material.empty() && expected.body_material[v[p]] != material[p])
          fail(p, "body " + std::to_string(v[p]) + " is not of material " + std::to_string(material[p]));
      }
    }
  } else {
    const std::int64_t* v = reinterpret_cast<const std::int64_t*>(data);
    std::vector<std::int64_t> ids(v, v + count);
    std::sort(ids.begin(), ids.end());
    if (!ids.empty() && ids.front() < 0) throw Damaged(name + ": a negative particle id");
    const auto twin = std::adjacent_find(ids.begin(), ids.end());
    if (twin != ids.end()) throw Damaged(name + ": particle id " + std::to_string(*twin) + " appears twice");
  }
}

// /obstacles (format 6, present when the case has obstacles): the loads
// that the obstacle table continues from, checked like the particles.
ObstacleLoads::State read_obstacle_loads(hid_t file, int obstacles, int dim, double time) {
  if (H5Lexists(file, "obstacles", H5P_DEFAULT) <= 0) throw Damaged("no group obstacles (the case has obstacles)");
  Handle group(H5Gopen2(file, "obstacles", H5P_DEFAULT), H5Gclose, "group obstacles");
  ObstacleLoads::State loads;
  loads.window = read_attribute<double>(group.id, "force_window", H5T_NATIVE_DOUBLE);
  if (!(std::isfinite(loads.window) && loads.window >= 0)) throw Damaged("force_window = " + number_text(loads.window));
  // A table of `columns` finite numbers per row; `rows` >= 0 demands that many.
  const auto read_table = [&](const char* name, hsize_t columns, long long rows) {
    const std::string what = std::string("dataset obstacles/") + name;
    if (H5Lexists(group.id, name, H5P_DEFAULT) <= 0) throw Damaged("no " + what);
    Handle dset(H5Dopen2(group.id, name, H5P_DEFAULT), H5Dclose, what);
    Handle space(H5Dget_space(dset.id), H5Sclose, "space");
    hsize_t dims[2] = {0, 0};
    if (H5Sget_simple_extent_ndims(space.id) != 2) throw Damaged(what + " is not a table");
    H5Sget_simple_extent_dims(space.id, dims, nullptr);
    if (dims[1] != columns || (rows >= 0 && dims[0] != static_cast<hsize_t>(rows)) || dims[0] > (hsize_t(1) << 31))
      throw Damaged(what + " has " + std::to_string(dims[0]) + " x " + std::to_string(dims[1]) + " values, expected " +
                    (rows >= 0 ? std::to_string(rows) : std::string("rows of")) + " x " + std::to_string(columns) +
                    " for this case's " + std::to_string(obstacles) + " obstacles");
    std::vector<double> values(dims[0] * dims[1]);
    if (!values.empty()) check(H5Dread(dset.id, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()), what);
    for (double v : values)
      if (!std::isfinite(v)) throw Damaged("a non-finite value in " + what);
    return values;
  };
  loads.total = read_table("impulse_total", dim, obstacles);
  loads.peak_force = read_table("peak_window_force", 1, obstacles);
  loads.peak_time = read_table("peak_window_time", 1, obstacles);
  const hsize_t row = 2 + static_cast<hsize_t>(obstacles) * dim;
  loads.window_steps = read_table("window_steps", row, -1);
  for (int o = 0; o < obstacles; ++o)
    if (loads.peak_force[o] < 0 || loads.peak_time[o] < 0 || loads.peak_time[o] > time)
      throw Damaged("peak_window_force " + number_text(loads.peak_force[o]) + " at " + number_text(loads.peak_time[o]) +
                    " s of obstacle " + std::to_string(o) + " (time " + number_text(time) + ")");
  // The window's steps: each of positive length, in order, none after the checkpoint's time.
  double last_end = -std::numeric_limits<double>::infinity();
  for (std::size_t r = 0; r < loads.window_steps.size(); r += row) {
    const double start = loads.window_steps[r], end = loads.window_steps[r + 1];
    if (!(start >= 0 && start < end && end <= time && start >= last_end))
      throw Damaged("obstacles/window_steps: a step from " + number_text(start) + " to " + number_text(end) +
                    " s (time " + number_text(time) + ")");
    last_end = end;
  }
  return loads;
}

template <int dim>
RunState read_particles(const std::string& path, Particles<dim>& particles, const Grid<dim>& grid,
                        const CheckpointExpectations& expected, MPI_Comm comm) {
  int rank;
  MPI_Comm_rank(comm, &rank);
  Handle file(open_checkpoint(path, comm), H5Fclose, "open");
  const RunState state = read_state(path, file.id, dim);

  Handle group(H5Gopen2(file.id, "particles", H5P_DEFAULT), H5Gclose, "group particles");
  // Every rank reads each field whole and keeps the particles in its cells.
  const auto read_field = [&](const FieldSpec& f, std::vector<char>& buffer) -> hsize_t {
    Handle dset(H5Dopen2(group.id, f.file_name, H5P_DEFAULT), H5Dclose, std::string("dataset ") + f.file_name);
    Handle space(H5Dget_space(dset.id), H5Sclose, "space");
    hsize_t dims[2] = {0, 0};
    if (H5Sget_simple_extent_ndims(space.id) != 2) throw Damaged(std::string("dataset ") + f.file_name + " is not a table");
    H5Sget_simple_extent_dims(space.id, dims, nullptr);
    if (dims[1] != static_cast<hsize_t>(f.components))
      throw Damaged(std::string("dataset ") + f.file_name + " has " + std::to_string(dims[1]) + " components, expected " +
                    std::to_string(f.components));
    // The particle count bounds the read: no damaged header may make it allocate without end.
    if (dims[0] > (hsize_t(1) << 31)) throw Damaged(std::string("dataset ") + f.file_name + " claims " +
                                                    std::to_string(dims[0]) + " particles");
    buffer.resize(std::max<std::size_t>(1, dims[0] * dims[1] * element_size(f.kind)));
    check(H5Dread(dset.id, memory_type(f.kind), H5S_ALL, H5S_ALL, H5P_DEFAULT, buffer.data()), f.file_name);
    return dims[0];
  };
  const auto fields = checkpoint_fields<dim>();
  std::vector<char> buffer;
  const hsize_t total = read_field(fields[0], buffer);
  if (total == 0) throw Damaged("no particles");
  std::vector<double> mass, volume;
  std::vector<PetscInt> material;
  check_particles<dim>(fields[0], buffer.data(), total, expected, state.format, mass, volume, material);
  std::vector<std::size_t> mine;
  {
    const double* x = reinterpret_cast<const double*>(buffer.data());
    for (hsize_t p = 0; p < total; ++p) {
      Vector<dim> xp;
      for (int a = 0; a < dim; ++a) xp[a] = x[dim * p + a];
      if (grid.owner_rank(xp) == rank) mine.push_back(p);
    }
  }
  long long kept = static_cast<long long>(mine.size()), all = 0;
  MPI_Allreduce(&kept, &all, 1, MPI_LONG_LONG, MPI_SUM, comm);
  if (all != static_cast<long long>(total))
    throw InputError(path + ": " + std::to_string(total - all) + " particles of the checkpoint lie outside this case's grid");
  RunState result = state;
  if (H5Lexists(file.id, "grid", H5P_DEFAULT) > 0) {
    // Checkpoints from before the predictor have no /grid: the restart then
    // predicts gravity for its first step.
    Handle grid_group(H5Gopen2(file.id, "grid", H5P_DEFAULT), H5Gclose, "group grid");
    const auto read_rows = [&](const char* name, hid_t type, int columns, std::size_t element, std::vector<char>& out) {
      Handle dset(H5Dopen2(grid_group.id, name, H5P_DEFAULT), H5Dclose, std::string("dataset grid/") + name);
      Handle space(H5Dget_space(dset.id), H5Sclose, "space");
      hsize_t dims[2] = {0, 0};
      if (H5Sget_simple_extent_ndims(space.id) != 2) throw InputError(path + ": bad dataset grid/" + name);
      H5Sget_simple_extent_dims(space.id, dims, nullptr);
      if (dims[1] != static_cast<hsize_t>(columns))
        throw InputError(path + ": not a valid talus checkpoint: dataset grid/" + name + " has " +
                         std::to_string(dims[1]) + " columns, expected " + std::to_string(columns));
      out.resize(std::max<std::size_t>(1, dims[0] * dims[1] * element));
      check(H5Dread(dset.id, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()), name);
      return dims[0];
    };
    std::vector<char> index_bytes, value_bytes;
    const hsize_t rows = read_rows("accelerated_points", H5T_NATIVE_LLONG, 1, sizeof(long long), index_bytes);
    if (read_rows("point_acceleration", H5T_NATIVE_DOUBLE, dim, sizeof(double), value_bytes) != rows)
      throw InputError(path + ": not a valid talus checkpoint: grid/accelerated_points and grid/point_acceleration "
                       "differ in length");
    long long points = expected.velocity_fields;  // one index range per velocity field
    for (int a = 0; a < dim; ++a) points *= grid.points()[a];
    const long long* index = reinterpret_cast<const long long*>(index_bytes.data());
    const double* value = reinterpret_cast<const double*>(value_bytes.data());
    for (hsize_t r = 0; r < rows; ++r) {
      if (index[r] < 0 || index[r] >= points)
        throw InputError(path + ": not a valid talus checkpoint: grid point " + std::to_string(index[r]) +
                         " in grid/accelerated_points, the grid has " + std::to_string(points));
      for (int a = 0; a < dim; ++a)
        if (!std::isfinite(value[dim * r + a]))
          throw Damaged("a non-finite value in grid/point_acceleration");
    }
    result.accelerated_points.assign(index, index + rows);
    result.point_acceleration.assign(value, value + dim * rows);
  }
  if (expected.obstacles > 0) result.obstacle_loads = read_obstacle_loads(file.id, expected.obstacles, dim, state.time);
  TALUS_PETSC(DMSwarmSetLocalSizes(particles.swarm(), 0, 1024));
  particles.add(static_cast<PetscInt>(mine.size()));
  std::vector<double> old_volume_ratio;  // format 7: J = det F
  for (std::size_t k = 0; k < fields.size(); ++k) {
    const FieldSpec& f = fields[k];
    if (state.format < 8 && std::string(f.swarm_name) == field::volume_ratio) {
      old_volume_ratio.reserve(mine.size());
      const double* F = reinterpret_cast<const double*>(buffer.data());  // the deformation gradient, read just before
      for (const std::size_t p : mine)
        old_volume_ratio.push_back(
            Eigen::Map<const Eigen::Matrix<double, dim, dim, Eigen::RowMajor>>(F + dim * dim * p).determinant());
      FieldView<PetscReal> J(particles.swarm(), field::volume_ratio);
      std::copy(old_volume_ratio.begin(), old_volume_ratio.end(), J.data());
      continue;
    }
    if (k > 0 && read_field(f, buffer) != total) throw Damaged("datasets of different lengths");
    if (k > 0) check_particles<dim>(f, buffer.data(), total, expected, state.format, mass, volume, material);
    void* data = nullptr;
    PetscInt block = 0;
    TALUS_PETSC(DMSwarmGetField(particles.swarm(), f.swarm_name, &block, nullptr, &data));
    const std::size_t row = f.components * element_size(f.kind);
    for (std::size_t q = 0; q < mine.size(); ++q)
      std::copy_n(buffer.data() + mine[q] * row, row, static_cast<char*>(data) + q * row);
    TALUS_PETSC(DMSwarmRestoreField(particles.swarm(), f.swarm_name, &block, nullptr, &data));
  }
  return result;
}

}  // namespace

RunState read_run_state(const std::string& path, MPI_Comm comm) {
  return as_input_error(path, [&] {
    Handle file(open_checkpoint(path, comm), H5Fclose, "open");
    if (H5Lexists(file.id, "run", H5P_DEFAULT) <= 0) throw InputError(path + ": not a talus checkpoint (no /run group)");
    Handle run(H5Gopen2(file.id, "run", H5P_DEFAULT), H5Gclose, "group run");
    const int file_dim = read_attribute<int>(run.id, "dimension", H5T_NATIVE_INT);
    if (file_dim != 2 && file_dim != 3) throw Damaged("dimension = " + std::to_string(file_dim));
    return read_state(path, file.id, file_dim);
  });
}

std::string fingerprint_mismatch(const RunState& checkpoint, const CaseFingerprint& config) {
  const auto shortened = [](const std::string& text) {
    return text.size() <= 160 ? text : text.substr(0, 157) + "...";
  };
  std::string message;
  for (const auto& [section, text] : config) {
    std::string stored = "(none)";
    for (const auto& [s, t] : checkpoint.fingerprint)
      if (s == section) stored = t;
    if (stored == text) continue;
    // The first difference, so that a long section shows where it changed.
    std::size_t at = 0;
    while (at < text.size() && at < stored.size() && text[at] == stored[at]) ++at;
    const std::size_t from = at > 60 ? at - 60 : 0;
    message += std::string(message.empty() ? "" : "; ") + "`" + section + "` differs: checkpoint " +
               (from ? "..." : "") + shortened(stored.substr(from)) + ", this case " + (from ? "..." : "") +
               shortened(text.substr(from));
  }
  if (checkpoint.talus_version != TALUS_VERSION)
    message += std::string(message.empty() ? "" : "; ") + "written by talus " + checkpoint.talus_version +
               ", this is talus " + TALUS_VERSION;
  return message;
}

template <int dim>
RunState read_checkpoint(const std::string& path, Particles<dim>& particles, const Grid<dim>& grid,
                         const CheckpointExpectations& expected, MPI_Comm comm) {
  return as_input_error(path, [&] { return read_particles(path, particles, grid, expected, comm); });
}

template RunState read_checkpoint<2>(const std::string&, Particles<2>&, const Grid<2>&, const CheckpointExpectations&, MPI_Comm);
template RunState read_checkpoint<3>(const std::string&, Particles<3>&, const Grid<3>&, const CheckpointExpectations&, MPI_Comm);

}  // namespace talus
