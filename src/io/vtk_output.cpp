#include "talus/io/vtk_output.hpp"
#include "talus/io/run_directory.hpp"

#include <vtkCellArray.h>
#include <vtkCellData.h>
#include <vtkCellType.h>
#include <vtkDoubleArray.h>
#include <vtkFieldData.h>
#include <vtkIntArray.h>
#include <vtkMPI.h>
#include <vtkMPICommunicator.h>
#include <vtkMPIController.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkStringArray.h>
#include <vtkTypeInt64Array.h>
#include <vtkUnstructuredGrid.h>
#include <vtkXMLPUnstructuredGridWriter.h>
#include <vtkXMLPolyDataWriter.h>
#include <vtkXMLUnstructuredGridWriter.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <fstream>
#include <iomanip>
#include <sstream>

namespace talus {

void write_pvd_file(const std::string& path, const std::vector<std::pair<double, std::string>>& entries) {
  // Written to a temporary name and renamed: an interrupted run never leaves a torn index.
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp);
    out << "<?xml version=\"1.0\"?>\n"
        << "<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n  <Collection>\n";
    out << std::setprecision(12);
    for (const auto& [t, f] : entries)
      out << "    <DataSet timestep=\"" << t << "\" group=\"\" part=\"0\" file=\"" << f << "\"/>\n";
    out << "  </Collection>\n</VTKFile>\n";
    // The data reach the disk at close: check after it (a full disk fails there).
    out.close();
    if (out.fail()) {
      std::filesystem::remove(tmp);
      throw std::runtime_error("cannot write " + tmp + " (disk full?)");
    }
  }
  std::filesystem::rename(tmp, path);
}

template <int dim>
VtkSeries<dim>::VtkSeries(MPI_Comm comm, std::string directory, std::string name)
    : comm_(comm), directory_(std::move(directory)), name_(std::move(name)) {
  pvd_ = directory_ + "/" + name_ + ".pvd";
  int rank;
  MPI_Comm_rank(comm_, &rank);
  if (rank == 0) std::filesystem::create_directories(directory_);
  MPI_Barrier(comm_);
  // VTK talks over the run's own communicator, not necessarily MPI_COMM_WORLD.
  vtkMPICommunicatorOpaqueComm opaque(&comm_);
  communicator_ = vtkMPICommunicator::New();
  communicator_->InitializeExternal(&opaque);
  controller_ = vtkMPIController::New();
  controller_->SetCommunicator(communicator_);
}

template <int dim>
VtkSeries<dim>::~VtkSeries() {
  if (controller_) controller_->Delete();
  if (communicator_) communicator_->Delete();
}

template <int dim>
std::string VtkSeries<dim>::write(const Particles<dim>& particles, double time) {
  const PetscInt n = particles.local_count();
  DM sw = particles.swarm();
  FieldView<PetscReal> x(sw, field::position), v(sw, field::velocity), u(sw, field::displacement),
      s(sw, field::stress), m(sw, field::mass), v0(sw, field::initial_volume), volume_ratio(sw, field::volume_ratio),
      eps_p(sw, field::cumulative_plastic_strain), sep(sw, field::separation_strain);
  FieldView<PetscInt> mat(sw, field::material_id), body(sw, field::body_id);
  FieldView<std::int64_t> pid(sw, field::particle_id);

  vtkNew<vtkPoints> points;
  points->SetDataTypeToDouble();
  points->SetNumberOfPoints(n);
  vtkNew<vtkCellArray> cells;
  auto vec3 = [n](const char* name) {
    auto a = vtkSmartPointer<vtkDoubleArray>::New();
    a->SetName(name);
    a->SetNumberOfComponents(3);
    a->SetNumberOfTuples(n);
    return a;
  };
  auto scalar = [n](const char* name) {
    auto a = vtkSmartPointer<vtkDoubleArray>::New();
    a->SetName(name);
    a->SetNumberOfTuples(n);
    return a;
  };
  auto velocity = vec3("velocity"), displacement = vec3("displacement");
  auto stress = vtkSmartPointer<vtkDoubleArray>::New();
  stress->SetName("stress");
  stress->SetNumberOfComponents(6);  // ParaView's symmetric tensor order: XX YY ZZ XY YZ XZ
  stress->SetNumberOfTuples(n);
  auto p_arr = scalar("mean_stress"), q_arr = scalar("deviatoric_stress"), mass = scalar("mass"),
       volume = scalar("volume"), plastic = scalar("cumulative_plastic_strain"),
       separation = scalar("separation_strain");
  vtkNew<vtkIntArray> material, body_id;
  material->SetName("material_id");
  material->SetNumberOfTuples(n);
  body_id->SetName("body_id");
  body_id->SetNumberOfTuples(n);
  vtkNew<vtkTypeInt64Array> ids;
  ids->SetName("particle_id");
  ids->SetNumberOfTuples(n);

  for (PetscInt p = 0; p < n; ++p) {
    double xp[3] = {0, 0, 0}, vp[3] = {0, 0, 0}, up[3] = {0, 0, 0};
    for (int a = 0; a < dim; ++a) {
      xp[a] = x[dim * p + a];
      vp[a] = v[dim * p + a];
      up[a] = u[dim * p + a];
    }
    points->SetPoint(p, xp);
    const vtkIdType id = p;
    cells->InsertNextCell(1, &id);
    velocity->SetTuple(p, vp);
    displacement->SetTuple(p, up);
    const double J = volume_ratio[p];
    const Voigt sv = Eigen::Map<const Voigt>(s.data() + 6 * p) / J;  // Cauchy sigma = tau / J
    const double t[6] = {sv[0], sv[1], sv[2], sv[5], sv[3], sv[4]};
    stress->SetTuple(p, t);
    p_arr->SetValue(p, mean_stress(sv));
    q_arr->SetValue(p, deviatoric_stress(sv));
    mass->SetValue(p, m[p]);
    volume->SetValue(p, v0[p] * J);
    plastic->SetValue(p, eps_p[p]);
    separation->SetValue(p, sep[p]);
    material->SetValue(p, mat[p]);
    body_id->SetValue(p, body[p]);
    ids->SetValue(p, pid[p]);
  }
  vtkNew<vtkUnstructuredGrid> ug;
  ug->SetPoints(points);
  ug->SetCells(VTK_VERTEX, cells);
  vtkPointData* pd = ug->GetPointData();
  for (vtkDataArray* a : std::initializer_list<vtkDataArray*>{velocity, displacement, stress, p_arr, q_arr, mass,
                                                                volume, plastic, separation, material, body_id, ids})
    pd->AddArray(a);
  pd->SetActiveVectors("velocity");

  int rank, size;
  MPI_Comm_rank(comm_, &rank);
  MPI_Comm_size(comm_, &size);
  std::ostringstream stem;
  stem << name_ << "_" << std::setw(6) << std::setfill('0') << next_number_;
  const std::string file = directory_ + "/" + stem.str() + ".pvtu";
  // The files are written in a staging directory and moved into place once
  // every rank has written its piece, the .pvtu last and then the .pvd: an
  // interrupted run never leaves a torn file under a final name.
  const std::string staging = directory_ + "/.staging_" + stem.str();
  if (rank == 0) std::filesystem::create_directories(staging);
  MPI_Barrier(comm_);
  const std::string staged = staging + "/" + stem.str() + ".pvtu";
  vtkNew<vtkXMLPUnstructuredGridWriter> writer;
  writer->SetController(controller_);
  writer->SetInputData(ug);
  writer->SetFileName(staged.c_str());
  writer->SetNumberOfPieces(size);
  writer->SetStartPiece(rank);
  writer->SetEndPiece(rank);
  writer->SetDataModeToAppended();
  writer->EncodeAppendedDataOff();
  writer->SetCompressorTypeToZLib();
  // Every rank learns whether every piece was written before any file moves.
  // VTK's parallel writer can return success with an empty summary file on a
  // full disk: its error code, and a non-empty file, are checked as well.
  int ok = writer->Write() == 1 && writer->GetErrorCode() == 0, all_ok = 0;
  std::error_code size_error;
  if (rank == 0 && ok) ok = std::filesystem::file_size(staged, size_error) > 0 && !size_error;
  const std::string own_piece = staging + "/" + stem.str() + "_" + std::to_string(rank) + ".vtu";
  if (ok && std::filesystem::exists(own_piece)) ok = std::filesystem::file_size(own_piece, size_error) > 0 && !size_error;
  MPI_Allreduce(&ok, &all_ok, 1, MPI_INT, MPI_MIN, comm_);
  if (!all_ok) {
    MPI_Barrier(comm_);
    if (rank == 0) std::filesystem::remove_all(staging);
    throw std::runtime_error("VTK could not write the output " + stem.str() + (ok ? " (on another rank)" : " in " + staging + " (disk full?)"));
  }
  // VTK writes no piece for a rank without particles (nor lists it in the .pvtu).
  const std::string piece = stem.str() + "_" + std::to_string(rank) + ".vtu";
  if (std::filesystem::exists(staging + "/" + piece))
    std::filesystem::rename(staging + "/" + piece, directory_ + "/" + piece);
  MPI_Barrier(comm_);
  if (rank == 0) {
    std::filesystem::rename(staged, file);
    std::filesystem::remove(staging);
  }
  entries_.emplace_back(time, stem.str() + ".pvtu");
  ++next_number_;
  if (rank == 0) write_pvd();
  return file;
}

template <int dim>
void VtkSeries<dim>::resume(const std::vector<std::pair<double, std::string>>& entries, long next_number) {
  entries_ = entries;
  next_number_ = next_number;
  if (next_number_ < 0)
    for (const auto& entry : entries_) next_number_ = std::max(next_number_, output_number(entry.second) + 1);
  next_number_ = std::max(next_number_, 0L);
  int rank;
  MPI_Comm_rank(comm_, &rank);
  if (rank == 0) write_pvd();
}

template <int dim>
void VtkSeries<dim>::write_pvd() const {
  write_pvd_file(pvd_, entries_);
}

template class VtkSeries<2>;
template class VtkSeries<3>;


namespace {

int rank_of(MPI_Comm comm) {
  int rank;
  MPI_Comm_rank(comm, &rank);
  return rank;
}

std::string numbered(const std::string& name, std::size_t index) {
  std::ostringstream stem;
  stem << name << "_" << std::setw(6) << std::setfill('0') << index;
  return stem.str();
}

// The entries of a series written alongside the particles: at the time of
// the particle output particles_NNNNNN.pvtu, the file of this series is
// <name>_NNNNNN<extension>, if it exists.
std::vector<std::pair<double, std::string>> companion_entries(
    const std::string& directory, const std::string& name, const std::string& extension,
    const std::vector<std::pair<double, std::string>>& particle_entries) {
  std::vector<std::pair<double, std::string>> entries;
  for (const auto& [time, particle_file] : particle_entries) {
    const long number = output_number(particle_file);
    if (number < 0) continue;
    const std::string file = numbered(name, static_cast<std::size_t>(number)) + extension;
    if (std::filesystem::exists(directory + "/" + file)) entries.emplace_back(time, file);
  }
  return entries;
}

}  // namespace

template <int dim>
ObstacleSeries<dim>::ObstacleSeries(MPI_Comm comm, std::string directory, const Vector<dim>& lower,
                                    const Vector<dim>& upper)
    : comm_(comm), directory_(std::move(directory)), lower_(lower), upper_(upper) {
  if (rank_of(comm_) == 0) std::filesystem::create_directories(directory_);
}

template <int dim>
std::string ObstacleSeries<dim>::write(const std::vector<Obstacle<dim>>& obstacles, double time, std::size_t index) {
  const std::string stem = numbered("obstacles", index);
  const std::string file = directory_ + "/" + stem + ".vtp";
  if (rank_of(comm_) != 0) return file;
  const ObstacleDrawing drawing = draw_obstacles<dim>(obstacles, lower_, upper_, time);
  vtkNew<vtkPoints> points;
  points->SetDataTypeToDouble();
  points->SetNumberOfPoints(static_cast<vtkIdType>(drawing.points.size()));
  for (std::size_t p = 0; p < drawing.points.size(); ++p)
    points->SetPoint(static_cast<vtkIdType>(p), drawing.points[p].data());
  // vtkPolyData numbers its cells lines first, then polygons: the cell data follow that order.
  vtkNew<vtkCellArray> lines, polys;
  vtkNew<vtkIntArray> obstacle;
  obstacle->SetName("obstacle");
  vtkNew<vtkDoubleArray> friction;
  friction->SetName("friction");
  for (const bool line_cells : {true, false})
    for (const auto& c : drawing.cells) {
      const bool is_line = c.vtk_type == VTK_LINE || c.vtk_type == VTK_POLY_LINE;
      if (is_line != line_cells) continue;
      std::vector<vtkIdType> ids(c.points.begin(), c.points.end());
      vtkCellArray* array = is_line ? lines.GetPointer() : polys.GetPointer();
      array->InsertNextCell(static_cast<vtkIdType>(ids.size()), ids.data());
      obstacle->InsertNextValue(c.obstacle);
      friction->InsertNextValue(obstacles[c.obstacle].friction());
    }
  vtkNew<vtkPolyData> pd;
  pd->SetPoints(points);
  pd->SetLines(lines);
  pd->SetPolys(polys);
  pd->GetCellData()->AddArray(obstacle);
  pd->GetCellData()->AddArray(friction);
  pd->GetCellData()->SetActiveScalars("obstacle");
  vtkNew<vtkStringArray> names;
  names->SetName("obstacle_names");
  for (const auto& o : obstacles) names->InsertNextValue(o.name());
  pd->GetFieldData()->AddArray(names);
  // Written to a temporary name and renamed, then listed in the .pvd.
  const std::string tmp = file + ".tmp";
  vtkNew<vtkXMLPolyDataWriter> writer;
  writer->SetInputData(pd);
  writer->SetFileName(tmp.c_str());
  writer->SetDataModeToAppended();
  writer->EncodeAppendedDataOff();
  writer->SetCompressorTypeToZLib();
  std::error_code size_error;
  if (writer->Write() != 1 || writer->GetErrorCode() != 0 || !(std::filesystem::file_size(tmp, size_error) > 0) ||
      size_error) {
    std::filesystem::remove(tmp, size_error);
    throw std::runtime_error("VTK could not write " + tmp + " (disk full?)");
  }
  std::filesystem::rename(tmp, file);
  entries_.emplace_back(time, stem + ".vtp");
  write_pvd_file(directory_ + "/obstacles.pvd", entries_);
  return file;
}

template <int dim>
void ObstacleSeries<dim>::resume(const std::vector<std::pair<double, std::string>>& particle_entries) {
  if (rank_of(comm_) != 0) return;
  entries_ = companion_entries(directory_, "obstacles", ".vtp", particle_entries);
  write_pvd_file(directory_ + "/obstacles.pvd", entries_);
}

PointCloudSeries::PointCloudSeries(MPI_Comm comm, std::string directory, std::string name)
    : comm_(comm), directory_(std::move(directory)), name_(std::move(name)) {
  if (rank_of(comm_) == 0) std::filesystem::create_directories(directory_);
  MPI_Barrier(comm_);
}

std::string PointCloudSeries::write(const PointCloud& cloud, double time, std::size_t index) {
  const vtkIdType n = static_cast<vtkIdType>(cloud.points.size());
  vtkNew<vtkPoints> points;
  points->SetDataTypeToDouble();
  points->SetNumberOfPoints(n);
  vtkNew<vtkCellArray> cells;
  for (vtkIdType p = 0; p < n; ++p) {
    points->SetPoint(p, cloud.points[static_cast<std::size_t>(p)].data());
    cells->InsertNextCell(1, &p);
  }
  vtkNew<vtkUnstructuredGrid> ug;
  ug->SetPoints(points);
  ug->SetCells(VTK_VERTEX, cells);
  for (const PointCloud::Array& a : cloud.arrays) {
    if (a.values.size() != static_cast<std::size_t>(n) * a.components)
      throw std::logic_error("point array " + a.name + " has " + std::to_string(a.values.size()) + " values for " +
                             std::to_string(n) + " points");
    vtkSmartPointer<vtkDataArray> array;
    if (a.integer)
      array = vtkSmartPointer<vtkIntArray>::New();
    else
      array = vtkSmartPointer<vtkDoubleArray>::New();
    array->SetName(a.name.c_str());
    array->SetNumberOfComponents(a.components);
    array->SetNumberOfTuples(n);
    for (vtkIdType p = 0; p < n; ++p)
      for (int k = 0; k < a.components; ++k)
        array->SetComponent(p, k, a.values[static_cast<std::size_t>(p) * a.components + k]);
    ug->GetPointData()->AddArray(array);
  }
  if (!cloud.vectors.empty()) ug->GetPointData()->SetActiveVectors(cloud.vectors.c_str());

  const int rank = rank_of(comm_);
  int size;
  MPI_Comm_size(comm_, &size);
  const std::string stem = numbered(name_, index);
  const std::string file = directory_ + "/" + stem + ".pvtu";
  // As for the particles: pieces and .pvtu staged, moved into place once
  // every rank has written, the .pvtu last, then the .pvd. Every rank writes
  // its piece, empty or not, so the .pvtu always lists one piece per rank.
  const std::string staging = directory_ + "/.staging_" + stem;
  if (rank == 0) std::filesystem::create_directories(staging);
  MPI_Barrier(comm_);
  const std::string piece = stem + "_" + std::to_string(rank) + ".vtu";
  vtkNew<vtkXMLUnstructuredGridWriter> writer;
  writer->SetInputData(ug);
  writer->SetFileName((staging + "/" + piece).c_str());
  writer->SetDataModeToAppended();
  writer->EncodeAppendedDataOff();
  writer->SetCompressorTypeToZLib();
  writer->SetHeaderTypeToUInt32();
  int ok = writer->Write() == 1 && writer->GetErrorCode() == 0, all_ok = 0;
  std::error_code size_error;
  if (ok && std::filesystem::exists(staging + "/" + piece))
    ok = std::filesystem::file_size(staging + "/" + piece, size_error) > 0 && !size_error;
  MPI_Allreduce(&ok, &all_ok, 1, MPI_INT, MPI_MIN, comm_);
  if (!all_ok) {
    MPI_Barrier(comm_);
    if (rank == 0) std::filesystem::remove_all(staging);
    throw std::runtime_error("VTK could not write the " + name_ + " pieces in " + staging + " (disk full?)");
  }
  std::filesystem::rename(staging + "/" + piece, directory_ + "/" + piece);
  MPI_Barrier(comm_);
  if (rank == 0) {
    const std::string staged = staging + "/" + stem + ".pvtu";
    {
      std::ofstream out(staged);
      out << "<?xml version=\"1.0\"?>\n"
          << "<VTKFile type=\"PUnstructuredGrid\" version=\"0.1\" byte_order=\""
#ifdef VTK_WORDS_BIGENDIAN
          << "BigEndian"
#else
          << "LittleEndian"
#endif
          << "\" header_type=\"UInt32\" compressor=\"vtkZLibDataCompressor\">\n"
          << "  <PUnstructuredGrid GhostLevel=\"0\">\n"
          << "    <PPointData";
      if (!cloud.vectors.empty()) out << " Vectors=\"" << cloud.vectors << "\"";
      out << ">\n";
      for (const PointCloud::Array& a : cloud.arrays) {
        out << "      <PDataArray type=\"" << (a.integer ? "Int32" : "Float64") << "\" Name=\"" << a.name << "\"";
        if (a.components != 1) out << " NumberOfComponents=\"" << a.components << "\"";
        out << "/>\n";
      }
      out << "    </PPointData>\n"
          << "    <PPoints>\n"
          << "      <PDataArray type=\"Float64\" Name=\"Points\" NumberOfComponents=\"3\"/>\n"
          << "    </PPoints>\n";
      for (int r = 0; r < size; ++r) out << "    <Piece Source=\"" << stem << "_" << r << ".vtu\"/>\n";
      out << "  </PUnstructuredGrid>\n</VTKFile>\n";
      out.close();
      if (out.fail()) {
        std::filesystem::remove_all(staging);
        throw std::runtime_error("cannot write " + staged + " (disk full?)");
      }
    }
    std::filesystem::rename(staged, file);
    std::filesystem::remove(staging);
    entries_.emplace_back(time, stem + ".pvtu");
    write_pvd_file(directory_ + "/" + name_ + ".pvd", entries_);
  }
  return file;
}

void PointCloudSeries::resume(const std::vector<std::pair<double, std::string>>& particle_entries) {
  if (rank_of(comm_) != 0) return;
  entries_ = companion_entries(directory_, name_, ".pvtu", particle_entries);
  write_pvd_file(directory_ + "/" + name_ + ".pvd", entries_);
}

template <int dim>
ContactSeries<dim>::ContactSeries(MPI_Comm comm, std::string directory) : series_(comm, std::move(directory), "contacts") {}

template <int dim>
std::string ContactSeries<dim>::write(const std::vector<ContactSample<dim>>& contacts, double time,
                                      std::size_t index) {
  PointCloud cloud;
  cloud.arrays = {{"contact_force", 3, false, {}}, {"obstacle", 1, true, {}}, {"contact_state", 1, true, {}}};
  cloud.vectors = "contact_force";
  for (const ContactSample<dim>& c : contacts) {
    cloud.points.push_back(to_point<dim>(c.position));
    const Point3 f = to_point<dim>(c.force);
    cloud.arrays[0].values.insert(cloud.arrays[0].values.end(), f.begin(), f.end());
    cloud.arrays[1].values.push_back(c.obstacle);
    cloud.arrays[2].values.push_back(c.state);
  }
  return series_.write(cloud, time, index);
}

template class ObstacleSeries<2>;
template class ObstacleSeries<3>;
template class ContactSeries<2>;
template class ContactSeries<3>;

// ------------------------------------------------------------ force table

namespace {

// Shortest text that reads back to the same double.
std::string exact_text(double x) {
  char buffer[64];
  const auto r = std::to_chars(buffer, buffer + sizeof buffer, x);
  return std::string(buffer, r.ptr);
}

// A data row of the table: `columns` + 1 numbers; false if torn or not numbers.
bool parse_row(const std::string& line, std::size_t columns, double& time) {
  std::size_t count = 0, start = 0;
  while (true) {
    const std::size_t end = std::min(line.find(',', start), line.size());
    const std::string field = line.substr(start, end - start);
    if (field.empty()) return false;
    char* stop = nullptr;
    const double value = std::strtod(field.c_str(), &stop);
    if (stop != field.c_str() + field.size() || !std::isfinite(value)) return false;
    if (count == 0) time = value;
    ++count;
    if (end == line.size()) break;
    start = end + 1;
  }
  return count == columns + 1;
}

}  // namespace

ObstacleForceTable::ObstacleForceTable(MPI_Comm comm, const std::string& path, const std::vector<std::string>& columns,
                                       double resume_time, std::string* note)
    : path_(path), columns_(columns.size()) {
  if (rank_of(comm) != 0) return;
  std::string header = "time [s]";
  for (const auto& c : columns) header += "," + c;
  std::vector<std::string> kept;
  if (resume_time >= 0.0 && std::filesystem::exists(path_)) {
    // The rows up to the restart time: those after it belong to the part of
    // the interrupted run that the restart repeats.
    std::ifstream in(path_);
    std::string line;
    bool header_ok = std::getline(in, line) && line == header;
    if (!header_ok) {
      std::filesystem::rename(path_, path_ + ".old");
      if (note)
        *note = path_ + " has other columns than this case's obstacles; it was moved to " + path_ +
                ".old and a new table started";
    } else {
      const double tolerance = 1e-10 * std::abs(resume_time);
      double last = -std::numeric_limits<double>::infinity();
      while (std::getline(in, line)) {
        double t = 0.0;
        if (!parse_row(line, columns_, t)) continue;  // a torn last line
        if (t > resume_time + tolerance) break;
        if (!(t > last)) continue;
        kept.push_back(line);
        last = t;
      }
    }
  }
  // Header and kept rows through a temporary name and a rename, then appended to.
  const std::string tmp = path_ + ".tmp";
  {
    std::ofstream out(tmp);
    out << header << "\n";
    for (const auto& row : kept) out << row << "\n";
    out.close();
    if (out.fail()) {
      std::filesystem::remove(tmp);
      throw std::runtime_error("cannot write " + tmp + " (disk full?)");
    }
  }
  std::filesystem::rename(tmp, path_);
  file_ = std::fopen(path_.c_str(), "a");
  if (!file_) throw std::runtime_error("cannot append to " + path_);
}

ObstacleForceTable::~ObstacleForceTable() {
  if (file_) std::fclose(file_);
}

void ObstacleForceTable::append(double time, const std::vector<double>& values) {
  if (!file_) return;
  std::string row = exact_text(time);
  for (double v : values) row += "," + exact_text(v);
  row += "\n";
  if (std::fwrite(row.data(), 1, row.size(), file_) != row.size() || std::fflush(file_) != 0)
    throw std::runtime_error("cannot append to " + path_ + " (disk full?)");
}

}  // namespace talus
