#pragma once
// ParaView output: per output step, one .vtu of particles per rank and a .pvtu
// that ties them together (VTK's parallel XML writer); one .pvd time series
// for the run, rewritten by rank 0 after each output (docs/output.md).
//
// With obstacles, also: the obstacles as polydata (one .vtp per output,
// obstacles.pvd), the contact points of the last step (contacts.pvd), and the
// force on each obstacle at every step (obstacle_forces.csv). With
// output.grid, the grid points of the last step (grid.pvd).
#include <array>
#include <cstdio>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "talus/contact/obstacle.hpp"
#include "talus/particles/particles.hpp"

class vtkMPIController;
class vtkMPICommunicator;

namespace talus {

// A point in VTK's three coordinates (z = 0 in 2D).
using Point3 = std::array<double, 3>;
template <int dim>
Point3 to_point(const Vector<dim>& x) {
  Point3 p{0.0, 0.0, 0.0};
  for (int a = 0; a < dim; ++a) p[a] = x[a];
  return p;
}

template <int dim>
class VtkSeries {
 public:
  VtkSeries(MPI_Comm comm, std::string directory, std::string name = "particles");
  ~VtkSeries();
  VtkSeries(const VtkSeries&) = delete;
  VtkSeries& operator=(const VtkSeries&) = delete;

  // Writes the particle fields; returns the .pvtu path.
  std::string write(const Particles<dim>& particles, double time);

  // Continues a series after a restart: the outputs written before it, and
  // the number of the next file (after the last the checkpoint listed,
  // whether or not its file is still there: continue_series; -1: after the
  // last of `entries`).
  void resume(const std::vector<std::pair<double, std::string>>& entries, long next_number = -1);
  const std::vector<std::pair<double, std::string>>& entries() const { return entries_; }
  // NNNNNN of the next output's files (particles_NNNNNN.pvtu).
  long next_number() const { return next_number_; }

 private:
  void write_pvd() const;
  MPI_Comm comm_;
  std::string directory_, name_, pvd_;
  std::vector<std::pair<double, std::string>> entries_;
  long next_number_ = 0;
  vtkMPICommunicator* communicator_ = nullptr;
  vtkMPIController* controller_ = nullptr;
};

// Rewrites `directory/name.pvd` (a ParaView collection of (time, file)
// entries, file names relative to the directory) through a temporary name and
// a rename. Call on one rank.
void write_pvd_file(const std::string& path, const std::vector<std::pair<double, std::string>>& entries);

// ----------------------------------------------------------------- obstacles

// The obstacles as drawn in ParaView at one time, clipped to the grid box
// (docs/output.md#obstacles-and-contacts): points (x, y, z; z = 0 in 2D) and
// cells, each cell a VTK cell type with its point ids and its obstacle.
//   half_plane  2D: its boundary line, VTK_LINE
//               3D: the plane's section of the grid box, VTK_POLYGON (3 to 6
//                   vertices, counter-clockwise about the outward normal)
//   box         2D: its outline, VTK_POLYGON
//               3D: its 6 faces, VTK_QUAD (counter-clockwise about the outward normals)
//   terrain     2D: the polyline with its end segments extended as the gap does, VTK_POLY_LINE
//               3D: 2 triangles per height-map cell, (00, 10, 11) and (00, 11, 01), VTK_TRIANGLE, or
//                   VTK_POLYGON where the grid box cuts a triangle
// A moving obstacle is drawn at x + velocity * time. An obstacle wholly
// outside the grid box has no cell.
struct ObstacleDrawing {
  struct Cell {
    int vtk_type = 0;
    std::vector<long> points;
    int obstacle = 0;
  };
  std::vector<std::array<double, 3>> points;
  std::vector<Cell> cells;
};

template <int dim>
ObstacleDrawing draw_obstacles(const std::vector<Obstacle<dim>>& obstacles, const Vector<dim>& grid_lower,
                               const Vector<dim>& grid_upper, double time);

// obstacles_NNNNNN.vtp (rank 0, vtkXMLPolyDataWriter, cell data `obstacle`
// and `friction`, field data `obstacle_names`) and obstacles.pvd. NNNNNN is
// the index of the particle output written at the same time.
template <int dim>
class ObstacleSeries {
 public:
  ObstacleSeries(MPI_Comm comm, std::string directory, const Vector<dim>& grid_lower, const Vector<dim>& grid_upper);
  std::string write(const std::vector<Obstacle<dim>>& obstacles, double time, std::size_t index);
  // After a restart: the entries of the particle series, each mapped to the
  // obstacle file of the same index that exists in the directory.
  void resume(const std::vector<std::pair<double, std::string>>& particle_entries);
  const std::vector<std::pair<double, std::string>>& entries() const { return entries_; }

 private:
  MPI_Comm comm_;
  std::string directory_;
  Vector<dim> lower_, upper_;
  std::vector<std::pair<double, std::string>> entries_;
};

// One contact point of the last step on this rank, as written.
// state: 0 sticking (r inside the cone), 1 separating (r = 0, polar cone),
// 2 sliding (r on the cone's boundary).
template <int dim>
struct ContactSample {
  Vector<dim> position;  // the grid point
  Vector<dim> force;     // the force on the obstacle, -r_i / h
  int obstacle = 0;
  int state = 0;
};

// A set of points with point data, written by PointCloudSeries: the
// contact points and the grid points of the last step.
struct PointCloud {
  struct Array {
    std::string name;
    int components = 1;          // values per point
    bool integer = false;        // written as Int32, else Float64
    std::vector<double> values;  // components per point, point after point
  };
  std::vector<std::array<double, 3>> points;  // z = 0 in 2D
  std::vector<Array> arrays;                  // the same names and kinds on every rank
  std::string vectors;                        // the array ParaView shows as vectors ("" for none)
};

// <name>_NNNNNN.pvtu with one <name>_NNNNNN_R.vtu per rank (every rank, also
// those without points: an empty, valid piece), and <name>.pvd. NNNNNN is the
// index of the particle output written at the same time. The pieces and the
// .pvtu are written in a staging directory and moved into place once every
// rank has written, the .pvtu last, then the .pvd.
class PointCloudSeries {
 public:
  PointCloudSeries(MPI_Comm comm, std::string directory, std::string name);
  std::string write(const PointCloud& cloud, double time, std::size_t index);
  // After a restart: the entries of the particle series, each mapped to the
  // file of this series of the same index that exists in the directory.
  void resume(const std::vector<std::pair<double, std::string>>& particle_entries);
  const std::vector<std::pair<double, std::string>>& entries() const { return entries_; }

 private:
  MPI_Comm comm_;
  std::string directory_, name_;
  std::vector<std::pair<double, std::string>> entries_;
};

// contacts_NNNNNN.pvtu with one contacts_NNNNNN_R.vtu per rank, and
// contacts.pvd (a PointCloudSeries): point data contact_force, obstacle,
// contact_state.
template <int dim>
class ContactSeries {
 public:
  ContactSeries(MPI_Comm comm, std::string directory);
  std::string write(const std::vector<ContactSample<dim>>& contacts, double time, std::size_t index);
  void resume(const std::vector<std::pair<double, std::string>>& particle_entries) { series_.resume(particle_entries); }
  const std::vector<std::pair<double, std::string>>& entries() const { return series_.entries(); }

 private:
  PointCloudSeries series_;
};

// A table of one row per accepted step, `time [s],<columns>` (the columns
// carry their units): obstacle_forces.csv and energy.csv. Written by rank 0
// (the object does nothing on other ranks). Rows are appended and flushed at
// once, so a crash loses at most the row being written; a torn last line is
// dropped on restart.
class ObstacleForceTable {
 public:
  // A new table (header only), or, with `resume_time` >= 0, the existing
  // table with the rows of time <= resume_time (+ tolerance) kept and the
  // later ones dropped (rewritten through a temporary name and a rename).
  // Returns a note for the log when an existing table could not be continued.
  ObstacleForceTable(MPI_Comm comm, const std::string& path, const std::vector<std::string>& columns,
                     double resume_time = -1.0, std::string* note = nullptr);
  ~ObstacleForceTable();
  ObstacleForceTable(const ObstacleForceTable&) = delete;
  ObstacleForceTable& operator=(const ObstacleForceTable&) = delete;
  void append(double time, const std::vector<double>& values);
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  std::size_t columns_ = 0;
  std::FILE* file_ = nullptr;
};

}  // namespace talus
