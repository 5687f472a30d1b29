// talus command line: talus run case.yaml [PETSc options] | talus check case.yaml
#include <petscsys.h>
#include <sys/resource.h>

#include <csignal>
#include <cstring>
#include <iomanip>
#include <sstream>
#include <iostream>
#include <string>

#include "talus/io/config.hpp"
#include "talus/simulation.hpp"
#include "talus/solver/petsc_options.hpp"

namespace {

const char* usage =
    "talus " TALUS_VERSION " - implicit Material Point Method for landslides\n\n"
    "usage:\n"
    "  talus run   CASE.yaml [--restart FILE.h5] [PETSc options]\n"
    "                                          run a case (ParaView output in output.directory),\n"
    "                                          or continue it from an HDF5 checkpoint\n"
    "  talus check CASE.yaml                   validate a case file and exit\n"
    "  talus --help | --version\n\n"
    "Solver options go to PETSc with the prefix -talus_, e.g. -talus_snes_monitor,\n"
    "-talus_ksp_type gmres -talus_pc_type gamg (see docs/solver.md).\n"
    "SIGINT/SIGTERM end a run after the current step with a checkpoint (docs/checkpoints.md).\n"
    "Exit codes: 0 success, 1 internal error, 2 bad input, 3 the simulation failed,\n"
    "130/143 stopped by SIGINT/SIGTERM (checkpoint written).\n";

template <int dim>
int run_case(const talus::CaseConfig& config, const std::string& restart, int rank) {
  talus::Simulation<dim> sim(config, PETSC_COMM_WORLD);
  if (!restart.empty()) {
    sim.restart(restart);
    if (rank == 0) std::cout << "talus: restarting from " << restart << " at t = " << sim.time() << "\n";
  }
  const PetscInt particles = sim.particles().global_count();  // collective: every rank asks
  if (rank == 0)
    std::cout << "talus: " << dim << "D case " << config.source_file << ", " << particles
              << " particles, grid " << sim.grid().cells()[0] << " x " << sim.grid().cells()[1]
              << (dim == 3 ? " x " + std::to_string(sim.grid().cells()[dim - 1]) : std::string()) << " cells"
              << (config.time.integrator == talus::Integrator::explicit_euler
                      ? ", explicit steps of " + [&] { std::ostringstream t; t << std::setprecision(3) << config.time.step; return t.str(); }() + " s"
                      : config.time.auto_step
                      ? ", automatic steps from " + [&] { std::ostringstream t; t << std::setprecision(3) << config.time.step; return t.str(); }() + " s"
                      : std::string())
              << "\n";
  const talus::RunSummary s = sim.run(&std::cout);
  if (rank == 0) {
    std::cout << std::setprecision(4) << "talus: done in " << s.wall_seconds << " s: " << s.steps << " steps, "
              << s.cutbacks << " cut-backs, " << s.newton_iterations << " Newton and " << s.linear_iterations
              << " KSP iterations, " << s.outputs << " outputs";
    if (config.output.enabled) std::cout << " (" << config.output.directory << "/particles.pvd)";
    std::cout << "\n";
    if (s.final_load.ranks > 1)
      std::cout << "talus: " << s.final_load.ranks << " ranks, particles per rank at the end: " << s.final_load.min
                << " to " << s.final_load.max << " (mean " << s.final_load.mean() << ", max/mean "
                << s.final_load.imbalance() << "; worst during the run " << s.worst_imbalance << "), "
                << s.rebalances << " re-partitions\n";
    // Wall design: the largest force averaged over output.force_window on
    // each obstacle (docs/output.md#obstacle_forcescsv-the-force-on-each-obstacle).
    for (const auto& p : s.peak_window_forces)
      std::cout << std::setprecision(6) << "talus: peak force on " << p.obstacle << " averaged over "
                << s.force_window << " s: " << p.force << (dim == 2 ? " N/m" : " N") << " at t = " << p.time
                << " s\n";
    if (s.interrupted_by)
      std::cout << "talus: stopped by signal " << s.interrupted_by << " at t = " << sim.time()
                << (s.last_checkpoint.empty() ? std::string() : "; continue with --restart " + s.last_checkpoint)
                << "\n";
  }
  // One machine-readable line for scripts/ (benchmarks): totals over the run,
  // peak resident memory of the largest rank.
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  double rss_mb = usage.ru_maxrss / 1024.0, max_rss_mb = 0.0;
  MPI_Reduce(&rss_mb, &max_rss_mb, 1, MPI_DOUBLE, MPI_MAX, 0, PETSC_COMM_WORLD);
  // {"wall": {"force": F, "time": t}, ...} in full precision (obstacle names
  // are letters, digits, _ - and .: nothing to escape).
  std::ostringstream peaks;
  peaks << std::setprecision(17);
  for (const auto& p : s.peak_window_forces)
    peaks << (&p == s.peak_window_forces.data() ? "" : ", ") << "\"" << p.obstacle << "\": {\"force\": " << p.force
          << ", \"time\": " << p.time << "}";
  if (rank == 0)
    std::cout << std::setprecision(6) << "talus-summary: {\"dim\": " << dim
              << ", \"particles\": " << particles << ", \"steps\": " << s.steps
              << ", \"cutbacks\": " << s.cutbacks << ", \"newton_iterations\": " << s.newton_iterations
              << ", \"max_step_newton_iterations\": " << s.max_step_newton_iterations
              << ", \"linear_iterations\": " << s.linear_iterations << ", \"wall_seconds\": " << s.wall_seconds
              << ", \"transfer_seconds\": " << s.transfer_seconds << ", \"solve_seconds\": " << s.solve_seconds
              << ", \"contact_seconds\": " << s.contact_seconds << ", \"contact_points\": " << s.contact_points
              << ", \"max_unbalance\": " << s.max_unbalance << ", \"energy_balance_error\": " << s.energy_balance_error << ", \"structure_builds\": " << s.structure_builds
              << ", \"direct_fallbacks\": " << s.direct_fallbacks << ", \"factorizations\": " << s.factorizations
              << ", \"ranks\": " << s.final_load.ranks << ", \"rebalances\": " << s.rebalances
              << ", \"worst_imbalance\": " << s.worst_imbalance << ", \"final_min_rank_particles\": "
              << s.final_load.min << ", \"final_max_rank_particles\": " << s.final_load.max
              << ", \"peak_rss_mb\": " << max_rss_mb << ", \"force_window\": " << s.force_window
              << ", \"peak_window_force\": {" << peaks.str() << "}}\n";
  return s.interrupted_by ? 128 + s.interrupted_by : 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || !std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "-h")) {
    std::cout << usage;
    return argc < 2 ? 2 : 0;
  }
  if (!std::strcmp(argv[1], "--version")) {
    std::cout << "talus " TALUS_VERSION "\n";
    return 0;
  }
  const std::string command = argv[1];
  if ((command != "run" && command != "check") || argc < 3) {
    std::cerr << "talus: unknown command line; see talus --help\n";
    return 2;
  }
  // talus's own options are taken out before PETSc sees the command line.
  std::string restart;
  for (int i = 3; i < argc; ++i)
    if (!std::strcmp(argv[i], "--restart")) {
      if (i + 1 >= argc || command != "run") {
        std::cerr << "talus: --restart needs a checkpoint file and the run command; see talus --help\n";
        return 2;
      }
      restart = argv[i + 1];
      for (int j = i; j + 2 <= argc; ++j) argv[j] = argv[j + 2];
      argc -= 2;
      break;
    }
  // What remains must be PETSc options: -name [value] pairs. An unknown
  // talus flag, PETSc's -help (which would print its option list and then
  // run the case), or a stray word is a command-line error, not ignored.
  for (int i = 3; i < argc; ++i) {
    const std::string a = argv[i];
    const bool value_of_option = i > 3 && argv[i - 1][0] == '-' && std::strncmp(argv[i - 1], "--", 2) != 0;
    std::string problem;
    if (a.rfind("--", 0) == 0)
      problem = "unknown option " + a + " (talus's own: --restart FILE; PETSc options take one dash, e.g. -talus_snes_monitor)";
    else if (a == "-help" || a == "-h")
      problem = a + ": talus --help prints the usage; docs/solver.md lists the solver options";
    else if (a.empty() || (a[0] != '-' && !value_of_option))
      problem = "unexpected argument '" + a + "' (one case file per run)";
    if (!problem.empty()) {
      std::cerr << "talus: error: command line: " << problem << "\n";
      return 2;
    }
  }
  // A file-size limit (ulimit -f) makes a write fail with EFBIG, reported as
  // an output error, instead of killing the process mid-write.
  std::signal(SIGXFSZ, SIG_IGN);
  if (PetscInitialize(&argc, &argv, nullptr, nullptr)) return 1;
  int rank = 0;
  MPI_Comm_rank(PETSC_COMM_WORLD, &rank);
  int code = 0;
  try {
    const talus::CaseConfig config = talus::load_case(argv[2]);
    if (config.grid.shape == talus::ShapeKind::linear && rank == 0)
      // Issue 13, item 4 (docs/grid.md#linear-hats-linear): a valid choice
      // for small motions, a wrong one for a landslide.
      std::cerr << "talus: warning: " << argv[2] << ": grid.shape_function = linear has the cell-crossing error of "
                   "classic MPM: once particles cross cells the error grows under refinement; use "
                   "quadratic_bspline (the default) unless every particle stays within its cell\n";
    if (command == "check") {
      talus::apply_case_petsc_options(config);
      talus::check_petsc_options(PETSC_COMM_WORLD);
      if (rank == 0) {
        std::cout << "talus: " << argv[2] << " is a valid " << config.dim << "D case";
        // The explicit step is chosen when the case is read (docs/explicit.md#the-step).
        if (config.time.integrator == talus::Integrator::explicit_euler)
          std::cout << std::setprecision(3) << ", explicit steps of " << config.time.step << " s";
        // `time.step: auto` picks its first step then (docs/solver.md#choosing-the-step).
        if (config.time.auto_step)
          std::cout << std::setprecision(3) << ", automatic steps from " << config.time.step << " s";
        std::cout << "\n";
      }
    } else {
      code = config.dim == 2 ? run_case<2>(config, restart, rank) : run_case<3>(config, restart, rank);
    }
  } catch (const talus::InputError& e) {
    if (rank == 0) std::cerr << "talus: error: " << e.what() << "\n";
    code = 2;
  } catch (const talus::SimulationError& e) {
    if (rank == 0) std::cerr << "talus: simulation failed: " << e.what() << "\n";
    code = 3;
  } catch (const talus::OutputError& e) {
    if (rank == 0) std::cerr << "talus: output failed: " << e.what() << "\n";
    code = 4;
  } catch (const std::exception& e) {
    std::cerr << "talus: internal error on rank " << rank << ": " << e.what() << "\n";
    code = 1;
  }
  PetscFinalize();
  return code;
}
