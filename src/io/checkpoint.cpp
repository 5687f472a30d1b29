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

// Writing a checkpoint (docs/checkpoints.md); reading it is checkpoint_read.cpp.
namespace talus {

using namespace checkpoint_hdf5;

template <int dim>
void write_checkpoint(const std::string& path, const Particles<dim>& particles, const RunState& state, MPI_Comm comm) {
  int rank;
  MPI_Comm_rank(comm, &rank);
  const std::string tmp = path + ".tmp";
  const long long local = particles.local_count();
  long long offset = 0, total = 0;
  MPI_Exscan(&local, &offset, 1, MPI_LONG_LONG, MPI_SUM, comm);
  if (rank == 0) offset = 0;
  MPI_Allreduce(&local, &total, 1, MPI_LONG_LONG, MPI_SUM, comm);
  // A write that fails (a full disk, a file-size limit) leaves no file under
  // the final name and every earlier checkpoint as it was. HDF5 itself does
  // not recover from a failed write: the file stays open inside the library,
  // whose exit handler then crashes after MPI_Finalize. So the room is
  // checked first, against the file's size (the datasets plus 1 MB for the
  // metadata and attributes), on the file system and under the file-size
  // limit; the failure path below is for a disk that fills during the write.
  {
    std::size_t row = 0;
    for (const FieldSpec& f : checkpoint_fields<dim>()) row += f.components * element_size(f.kind);
    long long grid_rows = static_cast<long long>(state.accelerated_points.size()), all_grid_rows = 0;
    MPI_Allreduce(&grid_rows, &all_grid_rows, 1, MPI_LONG_LONG, MPI_SUM, comm);
    const double needed = static_cast<double>(total) * row + static_cast<double>(all_grid_rows) * 8 * (dim + 1) + 1048576.0;
    double room = std::numeric_limits<double>::infinity();
    if (rank == 0) {
      std::error_code ec;
      const auto space = std::filesystem::space(std::filesystem::absolute(path).parent_path(), ec);
      if (!ec) room = static_cast<double>(space.available);
      rlimit limit{};
      if (getrlimit(RLIMIT_FSIZE, &limit) == 0 && limit.rlim_cur != RLIM_INFINITY)
        room = std::min(room, static_cast<double>(limit.rlim_cur));
    }
    MPI_Bcast(&room, 1, MPI_DOUBLE, 0, comm);
    if (room < needed)
      throw std::runtime_error("no room for the checkpoint " + path + ": it needs about " +
                               number_text(std::ceil(needed / 1e6 * 10) / 10) + " MB, the file system or file-size "
                               "limit allows " + number_text(std::floor(room / 1e6 * 10) / 10) + " MB");
  }
  int failed = 0;
  std::string message;
  try {
    Handle fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose, "file access list");
    check(H5Pset_fapl_mpio(fapl.id, comm, MPI_INFO_NULL), "MPI-IO driver");
    Handle file(H5Fcreate(tmp.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl.id), H5Fclose, "creating " + tmp);
    Handle group(H5Gcreate2(file.id, "particles", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose, "group");
    Handle dxpl(H5Pcreate(H5P_DATASET_XFER), H5Pclose, "transfer list");
    check(H5Pset_dxpl_mpio(dxpl.id, H5FD_MPIO_COLLECTIVE), "collective transfer");
    DM sw = particles.swarm();
    for (const FieldSpec& f : checkpoint_fields<dim>()) {
      const hsize_t dims[2] = {static_cast<hsize_t>(total), static_cast<hsize_t>(f.components)};
      Handle filespace(H5Screate_simple(2, dims, nullptr), H5Sclose, "file space");
      Handle dset(H5Dcreate2(group.id, f.file_name, memory_type(f.kind), filespace.id, H5P_DEFAULT, H5P_DEFAULT,
                             H5P_DEFAULT),
                  H5Dclose, f.file_name);
      const hsize_t start[2] = {static_cast<hsize_t>(offset), 0};
      const hsize_t count[2] = {static_cast<hsize_t>(local), static_cast<hsize_t>(f.components)};
      Handle memspace(H5Screate_simple(2, count, nullptr), H5Sclose, "memory space");
      if (local > 0) {
        check(H5Sselect_hyperslab(filespace.id, H5S_SELECT_SET, start, nullptr, count, nullptr), "hyperslab");
      } else {
        H5Sselect_none(filespace.id);
        H5Sselect_none(memspace.id);
      }
      void* data = nullptr;
      PetscInt block = 0;
      TALUS_PETSC(DMSwarmGetField(sw, f.swarm_name, &block, nullptr, &data));
      const double dummy = 0.0;
      const herr_t status = H5Dwrite(dset.id, memory_type(f.kind), memspace.id, filespace.id, dxpl.id,
                                     local > 0 ? data : &dummy);
      TALUS_PETSC(DMSwarmRestoreField(sw, f.swarm_name, &block, nullptr, &data));
      check_on_all(status, std::string("writing ") + f.file_name, comm);
      describe(dset.id, describe_field<dim>(f.file_name));
    }
    {
      // /grid: the Newton predictor's point accelerations, rows in rank order.
      const long long rows = static_cast<long long>(state.accelerated_points.size());
      long long first = 0, all = 0;
      MPI_Exscan(&rows, &first, 1, MPI_LONG_LONG, MPI_SUM, comm);
      if (rank == 0) first = 0;
      MPI_Allreduce(&rows, &all, 1, MPI_LONG_LONG, MPI_SUM, comm);
      Handle grid(H5Gcreate2(file.id, "grid", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose, "group grid");
      const auto write_rows = [&](const char* name, hid_t type, int columns, const void* data) {
        const hsize_t dims[2] = {static_cast<hsize_t>(all), static_cast<hsize_t>(columns)};
        Handle filespace(H5Screate_simple(2, dims, nullptr), H5Sclose, "file space");
        Handle dset(H5Dcreate2(grid.id, name, type, filespace.id, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Dclose,
                    name);
        const hsize_t start[2] = {static_cast<hsize_t>(first), 0};
        const hsize_t count[2] = {static_cast<hsize_t>(rows), static_cast<hsize_t>(columns)};
        Handle memspace(H5Screate_simple(2, count, nullptr), H5Sclose, "memory space");
        if (rows > 0) {
          check(H5Sselect_hyperslab(filespace.id, H5S_SELECT_SET, start, nullptr, count, nullptr), "hyperslab");
        } else {
          H5Sselect_none(filespace.id);
          H5Sselect_none(memspace.id);
        }
        // No rows on any rank (no step has set a point acceleration yet):
        // the empty dataset is all there is; HDF5 refuses a write to it.
        if (all == 0) return;
        const double dummy = 0.0;
        check_on_all(H5Dwrite(dset.id, type, memspace.id, filespace.id, dxpl.id, rows > 0 ? data : &dummy),
                     std::string("writing ") + name, comm);
      };
      write_rows("accelerated_points", H5T_NATIVE_LLONG, 1, state.accelerated_points.data());
      write_rows("point_acceleration", H5T_NATIVE_DOUBLE, dim, state.point_acceleration.data());
      const auto describe_grid = [&](const char* name, const Description& d) {
        Handle dset(H5Dopen2(grid.id, name, H5P_DEFAULT), H5Dclose, name);
        describe(dset.id, d);
      };
      describe_grid("accelerated_points",
                    {"1", "", "global index of a grid point, x fastest: i + n_x (j + n_y k)"});
      describe_grid("point_acceleration", {"m/s^2", axis_names(dim), "its acceleration in the last step"});
    }
    if (!state.obstacle_names.empty()) {
      // /obstacles: the loads on the obstacles (ObstacleLoads), the same on
      // every rank; rank 0 writes them.
      const ObstacleLoads::State& loads = state.obstacle_loads;
      const hsize_t obstacles = state.obstacle_names.size();
      Handle group(H5Gcreate2(file.id, "obstacles", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose,
                   "group obstacles");
      std::string names;
      for (const std::string& n : state.obstacle_names) names += n + "\n";
      write_text_attribute(group.id, "names", names);
      write_attribute(group.id, "force_window", H5T_NATIVE_DOUBLE, loads.window);
      const auto write_table = [&](const char* name, hsize_t columns, const std::vector<double>& data,
                                   const Description& d) {
        const hsize_t rows = columns > 0 ? data.size() / columns : 0;
        const hsize_t dims[2] = {rows, columns};
        Handle filespace(H5Screate_simple(2, dims, nullptr), H5Sclose, "file space");
        Handle dset(H5Dcreate2(group.id, name, H5T_NATIVE_DOUBLE, filespace.id, H5P_DEFAULT, H5P_DEFAULT,
                               H5P_DEFAULT),
                    H5Dclose, name);
        if (rows > 0) {
          Handle memspace(H5Screate_simple(2, dims, nullptr), H5Sclose, "memory space");
          if (rank != 0) {
            H5Sselect_none(filespace.id);
            H5Sselect_none(memspace.id);
          }
          const double dummy = 0.0;
          check_on_all(H5Dwrite(dset.id, H5T_NATIVE_DOUBLE, memspace.id, filespace.id, dxpl.id,
                                rank == 0 ? data.data() : &dummy),
                       std::string("writing obstacles/") + name, comm);
        }
        describe(dset.id, d);
      };
      const std::string force = dim == 2 ? "N/m" : "N", impulse = dim == 2 ? "N s/m" : "N s";
      const std::string per_thickness = dim == 2 ? " (2D: per m of thickness)" : "";
      std::string step_columns = "start end";
      for (const std::string& n : state.obstacle_names)
        for (int a = 0; a < dim; ++a) step_columns += " " + n + "_" + "xyz"[a];
      write_table("impulse_total", dim, loads.total,
                  {impulse, axis_names(dim),
                   "impulse on each obstacle (rows: the obstacles in the order of names) summed since t = 0" +
                       per_thickness});
      write_table("peak_window_force", 1, loads.peak_force,
                  {force, "", "largest magnitude of the window-averaged force on each obstacle so far" + per_thickness});
      write_table("peak_window_time", 1, loads.peak_time, {"s", "", "the time of that peak"});
      write_table("window_steps", 2 + obstacles * dim, loads.window_steps,
                  {"s s then " + impulse, step_columns,
                   "the steps inside the force window: start and end time, then the impulse of the step on each "
                   "obstacle" + per_thickness});
    }
    Handle run(H5Gcreate2(file.id, "run", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose, "group run");
    write_attribute(run.id, "dimension", H5T_NATIVE_INT, dim);
    write_attribute(run.id, "time", H5T_NATIVE_DOUBLE, state.time);
    write_attribute(run.id, "steps", H5T_NATIVE_LONG, state.steps);
    write_attribute(run.id, "cutbacks", H5T_NATIVE_LONG, state.cutbacks);
    write_attribute(run.id, "step_size", H5T_NATIVE_DOUBLE, state.step_size);
    write_attribute(run.id, "step_patience", H5T_NATIVE_LONG, state.patience);
    write_attribute(run.id, "steps_since_cutback", H5T_NATIVE_LONG, state.calm);
    write_attribute(run.id, "steps_since_growth", H5T_NATIVE_LONG, state.since_growth);
    write_attribute(run.id, "next_output", H5T_NATIVE_DOUBLE, state.next_output);
    std::ostringstream outputs;
    outputs.precision(17);
    for (const auto& [t, file_name] : state.outputs) outputs << t << ' ' << file_name << '\n';
    write_text_attribute(run.id, "outputs", outputs.str());
    // Relative to the checkpoint's directory: a restart finds the outputs
    // from wherever it runs, also after the whole run directory was moved.
    const std::filesystem::path here = std::filesystem::absolute(path).parent_path().lexically_normal();
    // No output directory recorded (a state built by hand): the checkpoint's own.
    const std::filesystem::path there = state.output_directory.empty()
                                            ? here
                                            : std::filesystem::absolute(state.output_directory).lexically_normal();
    std::string relative = there.lexically_relative(here).string();
    if (relative.empty()) relative = there.string();  // no relative path (another root)
    write_text_attribute(run.id, "output_directory", relative);
    std::ostringstream ownership;  // one line per axis: points per process column
    for (const auto& axis : state.grid_ownership) {
      for (int n : axis) ownership << n << ' ';
      ownership << '\n';
    }
    write_text_attribute(run.id, "grid_ownership", ownership.str());
    write_attribute(run.id, "energy_initial", H5T_NATIVE_DOUBLE, state.initial_energy);
    for (int k = 0; k < EnergyTerms::count; ++k)
      write_attribute(run.id, (std::string("energy_") + EnergyTerms::names()[k]).c_str(), H5T_NATIVE_DOUBLE,
                      state.energy_terms[k]);
    write_attribute(run.id, "checkpoint_format", H5T_NATIVE_INT, checkpoint_format);
    write_text_attribute(run.id, "talus_version", TALUS_VERSION);
    write_text_attribute(run.id, "case_file", state.case_file);
    write_text_attribute(run.id, "case_name", std::filesystem::path(state.case_file).stem().string());
    write_text_attribute(run.id, "units",
                         std::string("time, step_size, next_output: s; energy_*: ") + (dim == 2 ? "J/m" : "J") +
                             "; counts: 1");
    for (const auto& [section, text] : state.fingerprint)
      write_text_attribute(run.id, ("case_" + section).c_str(), text);
    // The data reach the disk here at the latest: a full disk fails here, not
    // silently when the handles close.
    check_on_all(H5Fflush(file.id, H5F_SCOPE_GLOBAL), "flushing " + tmp, comm);
  } catch (const std::exception& e) {
    failed = 1;
    message = e.what();
  }
  // Every rank has closed the file; only then does it get its final name.
  int any = 0;
  MPI_Allreduce(&failed, &any, 1, MPI_INT, MPI_MAX, comm);
  if (any) {
    std::error_code ignored;
    if (rank == 0) std::filesystem::remove(tmp, ignored);
    throw std::runtime_error("cannot write the checkpoint " + path + ": " +
                             (failed ? message : std::string("failed on another rank")) + " (disk full?)");
  }
  if (rank == 0) std::filesystem::rename(tmp, path);
  MPI_Barrier(comm);
}

template void write_checkpoint<2>(const std::string&, const Particles<2>&, const RunState&, MPI_Comm);
template void write_checkpoint<3>(const std::string&, const Particles<3>&, const RunState&, MPI_Comm);

}  // namespace talus
