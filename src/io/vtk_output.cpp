#include "talus/io/vtk_output.hpp"

#include <vtkCellArray.h>
#include <vtkDoubleArray.h>
#include <vtkIntArray.h>
#include <vtkMPI.h>
#include <vtkMPICommunicator.h>
#include <vtkMPIController.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkTypeInt64Array.h>
#include <vtkUnstructuredGrid.h>
#include <vtkXMLPUnstructuredGridWriter.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>

namespace talus {

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
      s(sw, field::stress), m(sw, field::mass), v0(sw, field::initial_volume), F(sw, field::deformation_gradient),
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
    const Eigen::Map<const Eigen::Matrix<double, dim, dim, Eigen::RowMajor>> Fp(F.data() + dim * dim * p);
    const double J = Fp.determinant();
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
  stem << name_ << "_" << std::setw(6) << std::setfill('0') << entries_.size();
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
  if (writer->Write() != 1) throw std::runtime_error("VTK could not write " + staged);
  MPI_Barrier(comm_);
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
  if (rank == 0) write_pvd();
  return file;
}

template <int dim>
void VtkSeries<dim>::resume(const std::vector<std::pair<double, std::string>>& entries) {
  entries_ = entries;
  int rank;
  MPI_Comm_rank(comm_, &rank);
  if (rank == 0) write_pvd();
}

template <int dim>
void VtkSeries<dim>::write_pvd() const {
  // Written to a temporary name and renamed: an interrupted run never leaves a torn index.
  const std::string tmp = pvd_ + ".tmp";
  {
    std::ofstream out(tmp);
    out << "<?xml version=\"1.0\"?>\n"
        << "<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n  <Collection>\n";
    out << std::setprecision(12);
    for (const auto& [t, f] : entries_)
      out << "    <DataSet timestep=\"" << t << "\" group=\"\" part=\"0\" file=\"" << f << "\"/>\n";
    out << "  </Collection>\n</VTKFile>\n";
    if (!out) throw std::runtime_error("cannot write " + tmp);
  }
  std::filesystem::rename(tmp, pvd_);
}

template class VtkSeries<2>;
template class VtkSeries<3>;

}  // namespace talus
