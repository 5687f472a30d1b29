#pragma once
// ParaView output: per output step, one .vtu of particles per rank and a .pvtu
// that ties them together (VTK's parallel XML writer); one .pvd time series
// for the run, rewritten by rank 0 after each output (docs/output.md).
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "talus/particles/particles.hpp"

class vtkMPIController;
class vtkMPICommunicator;

namespace talus {

template <int dim>
class VtkSeries {
 public:
  VtkSeries(MPI_Comm comm, std::string directory, std::string name = "particles");
  ~VtkSeries();
  VtkSeries(const VtkSeries&) = delete;
  VtkSeries& operator=(const VtkSeries&) = delete;

  // Writes the particle fields; returns the .pvtu path.
  std::string write(const Particles<dim>& particles, double time);

  // Continues a series after a restart: the outputs written before it.
  void resume(const std::vector<std::pair<double, std::string>>& entries);
  const std::vector<std::pair<double, std::string>>& entries() const { return entries_; }

 private:
  void write_pvd() const;
  MPI_Comm comm_;
  std::string directory_, name_, pvd_;
  std::vector<std::pair<double, std::string>> entries_;
  vtkMPICommunicator* communicator_ = nullptr;
  vtkMPIController* controller_ = nullptr;
};

}  // namespace talus
