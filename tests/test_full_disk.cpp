// A full disk (issue 14, item 5; docs/output.md#a-full-disk): a write that
// fails stops the run with an OutputError (exit code 4 in the command line),
// the outputs written before stay listed and readable, nothing torn or
// temporary is left under the output directory, and a checkpoint that cannot
// be written leaves the previous one as it was and restartable.
//
// The full disk is a file-size limit (RLIMIT_FSIZE, SIGXFSZ ignored as talus
// does), set inside this process after MPI started: it needs no privileges,
// and MPI's own start-up files are not subject to it. On 2 ranks the limit
// holds on both, so each rank's piece fails and all must agree to stop.
#include <sys/resource.h>
#include <vtkNew.h>
#include <vtkUnstructuredGrid.h>
#include <vtkXMLPUnstructuredGridReader.h>

#include <catch2/catch.hpp>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <regex>

#include "talus/simulation.hpp"
#include "test_support.hpp"

using namespace talus;
namespace fs = std::filesystem;

namespace {

// No file may grow beyond `bytes` while this lives.
class FileSizeLimit {
 public:
  explicit FileSizeLimit(rlim_t bytes) {
    REQUIRE(getrlimit(RLIMIT_FSIZE, &saved_) == 0);
    rlimit limited = saved_;
    limited.rlim_cur = bytes;
    previous_ = std::signal(SIGXFSZ, SIG_IGN);
    REQUIRE(setrlimit(RLIMIT_FSIZE, &limited) == 0);
  }
  ~FileSizeLimit() {
    setrlimit(RLIMIT_FSIZE, &saved_);
    std::signal(SIGXFSZ, previous_);
  }
  FileSizeLimit(const FileSizeLimit&) = delete;
  FileSizeLimit& operator=(const FileSizeLimit&) = delete;

 private:
  rlimit saved_{};
  void (*previous_)(int) = nullptr;
};

// The psi = 0 column of inputs/column_collapse_psi0.yaml (800 particles).
std::string column(const std::string& directory, double end, bool output) {
  return "grid: {lower: [0, 0], upper: [3.0, 1.2], cell_size: 0.05}\n"
         "time: {end: " + std::to_string(end) + ", step: 0.0025}\n"
         "output: {directory: " + directory + ", interval: 0.1, enabled: " + (output ? "true" : "false") + "}\n"
         "checkpoint: {enabled: true, directory: " + directory + "}\n"
         "gravity: [0, -9.81]\n"
         "materials: [{name: sand, model: drucker_prager, density: 2000, youngs_modulus: 1.0e6, poisson_ratio: 0.3,"
         " friction_angle: 30, dilatancy_angle: 0, cohesion: 0}]\n"
         "bodies: [{name: column, material: sand, box: {lower: [0, 0], upper: [0.5, 1.0]}}]\n"
         "boundaries: {y_min: fixed}\n";
}

void fresh_directory(const std::string& directory) {
  int rank = 0;
  MPI_Comm_rank(PETSC_COMM_WORLD, &rank);
  if (rank == 0) fs::remove_all(directory);
  MPI_Barrier(PETSC_COMM_WORLD);
}

// The column run to t = 0.05 s in a fresh `directory`: its last checkpoint.
std::string checkpoint_at_0_05(const std::string& directory) {
  fresh_directory(directory);
  std::string path;
  {
    Simulation<2> first(testing::case_from_yaml(column(directory, 0.05, false)), PETSC_COMM_WORLD);
    path = first.run(nullptr).last_checkpoint;
  }
  REQUIRE(fs::exists(path));
  MPI_Barrier(PETSC_COMM_WORLD);
  return path;
}

// A restart from `checkpoint` runs the column to t = 0.1 s.
void check_restart_runs_to_0_1(const std::string& directory, const std::string& checkpoint) {
  MPI_Barrier(PETSC_COMM_WORLD);
  Simulation<2> third(testing::case_from_yaml(column(directory, 0.1, false)), PETSC_COMM_WORLD);
  third.restart(checkpoint);
  CHECK_NOTHROW(third.run(nullptr));
  CHECK(third.time() == Approx(0.1));
}

std::vector<std::string> leftovers(const std::string& directory) {
  MPI_Barrier(PETSC_COMM_WORLD);
  std::vector<std::string> found;
  for (const auto& e : fs::recursive_directory_iterator(directory)) {
    const std::string name = e.path().filename().string();
    if (name.find(".tmp") != std::string::npos || name.rfind(".staging", 0) == 0) found.push_back(name);
  }
  return found;
}

std::string contents(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

}  // namespace

TEST_CASE("a full disk at an output stops the run and keeps the earlier outputs", "[output][mpi]") {
  const std::string dir = "full_disk_output_" + std::to_string(testing::comm_size(PETSC_COMM_WORLD));
  fresh_directory(dir);
  Simulation<2> sim(testing::case_from_yaml(column(dir, 0.2, true)), PETSC_COMM_WORLD);
  {
    // The t = 0 piece is 10 kB, the t = 0.1 one 93 kB (zlib-compressed).
    const FileSizeLimit limit(40 * 1024);
    CHECK_THROWS_AS(sim.run(nullptr), OutputError);
  }
  MPI_Barrier(PETSC_COMM_WORLD);
  CHECK(leftovers(dir).empty());
  CHECK_FALSE(fs::exists(dir + "/particles_000001.pvtu"));
  const std::string pvd = contents(dir + "/particles.pvd");
  const std::regex entry("file=\"([^\"]+)\"");
  std::vector<std::string> files;
  for (auto it = std::sregex_iterator(pvd.begin(), pvd.end(), entry); it != std::sregex_iterator(); ++it)
    files.push_back((*it)[1]);
  REQUIRE(files == std::vector<std::string>{"particles_000000.pvtu"});
  vtkNew<vtkXMLPUnstructuredGridReader> reader;
  reader->SetFileName((dir + "/" + files[0]).c_str());
  reader->Update();
  CHECK(reader->GetOutput()->GetNumberOfPoints() == 800);
  MPI_Barrier(PETSC_COMM_WORLD);
}

TEST_CASE("a checkpoint that does not fit leaves the previous one intact and restartable", "[output][checkpoint][mpi]") {
  const std::string dir = "full_disk_checkpoint_" + std::to_string(testing::comm_size(PETSC_COMM_WORLD));
  const std::string good = checkpoint_at_0_05(dir);
  const std::string before = contents(good);
  {
    // A checkpoint of the 800 particles is about 190 kB.
    Simulation<2> second(testing::case_from_yaml(column(dir, 0.1, false)), PETSC_COMM_WORLD);
    second.restart(good);
    const FileSizeLimit limit(100 * 1024);
    CHECK_THROWS_WITH(second.run(nullptr), Catch::Contains("writing a checkpoint at t = 0.1"));
  }
  CHECK(leftovers(dir).empty());
  std::vector<std::string> checkpoints;
  for (const auto& e : fs::directory_iterator(dir)) checkpoints.push_back(e.path().string());
  CHECK(checkpoints == std::vector<std::string>{good});
  CHECK(contents(good) == before);
  check_restart_runs_to_0_1(dir, good);
}

TEST_CASE("a checkpoint that fails on one rank only stops every rank, without a hang, the previous one intact",
          "[output][checkpoint][mpi]") {
  // A full disk seen by one rank in the middle of the collective HDF5 write
  // (each rank in turn): every rank must leave the write and stop with the
  // same OutputError (a rank that kept waiting in a collective call would
  // hang until ctest's timeout), and the previous checkpoint stays usable.
  const int size = testing::comm_size(PETSC_COMM_WORLD);
  int rank = 0;
  MPI_Comm_rank(PETSC_COMM_WORLD, &rank);
  for (int failing = 0; failing < size; ++failing) {
    const std::string dir = "full_disk_one_rank_" + std::to_string(size) + "_" + std::to_string(failing);
    const std::string good = checkpoint_at_0_05(dir);
    const std::string before = contents(good);
    {
      Simulation<2> second(testing::case_from_yaml(column(dir, 0.1, false)), PETSC_COMM_WORLD);
      second.restart(good);
      std::optional<FileSizeLimit> limit;
      if (rank == failing) limit.emplace(16 * 1024);
      CHECK_THROWS_WITH(second.run(nullptr), Catch::Contains("writing a checkpoint at t = 0.1"));
    }
    CHECK(leftovers(dir).empty());
    CHECK(contents(good) == before);
    check_restart_runs_to_0_1(dir, good);
  }
}
