// talus command line: talus run case.yaml [talus options] [PETSc options] | talus check case.yaml
#include <petscsys.h>
#include <sys/ioctl.h>
#include <sys/resource.h>
#include <unistd.h>

#include <cmath>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <iomanip>
#include <sstream>
#include <iostream>
#include <string>

#include "talus/io/config.hpp"
#include "talus/io/yaml_section.hpp"
#include "talus/simulation.hpp"
#include "talus/solver/petsc_options.hpp"

namespace {

const char* usage =
    "talus " TALUS_VERSION " - implicit Material Point Method for landslides\n\n"
    "usage:\n"
    "  talus run   CASE.yaml [--restart FILE.h5] [--overwrite] [--quiet]\n"
    "              [--progress-steps N] [--progress-seconds S] [PETSc options]\n"
    "                                          run a case (ParaView output in output.directory),\n"
    "                                          or continue it from an HDF5 checkpoint\n"
    "  talus check CASE.yaml                   validate a case file and exit\n"
    "  talus --help | --version\n\n"
    "--overwrite removes the files of an older run from the output and checkpoint\n"
    "directories first (without it such a directory is refused). On a terminal the\n"
    "progress line is rewritten in place; otherwise a line is printed every N steps\n"
    "(default 100) or S seconds (default 10); --quiet prints none.\n"
    "Solver options go to PETSc with the prefix -talus_, e.g. -talus_snes_monitor,\n"
    "-talus_ksp_type gmres -talus_pc_type gamg (see docs/solver.md).\n"
    "SIGINT/SIGTERM end a run after the current step with a checkpoint (docs/checkpoints.md).\n"
    "Exit codes: 0 success, 1 internal error, 2 bad input, 3 the simulation failed,\n"
    "4 a result file could not be written, 130/143 stopped by SIGINT/SIGTERM (checkpoint written).\n";

// talus's own options of `talus run` (docs/command_line.md).
struct RunOptions {
  std::string restart;
  bool overwrite = false;
  talus::ProgressOptions progress;
};

const char* status_text(talus::RunStatus status) {
  switch (status) {
    case talus::RunStatus::completed: return "completed";
    case talus::RunStatus::interrupted: return "interrupted";
    case talus::RunStatus::failed: return "failed";
  }
  return "";
}

// The closing lines of a run (rank 0), in the order a reader needs them:
// why it stopped, then the totals, then the machine-readable line.
template <int dim>
void print_summary(const talus::CaseConfig& config, const talus::RunSummary& s, PetscInt particles, int rank) {
  if (rank == 0) {
    if (s.status == talus::RunStatus::interrupted)
      std::cout << std::setprecision(6) << "talus: stopped by signal " << s.interrupted_by << " at t = " << s.time
                << (s.last_checkpoint.empty() ? std::string() : "; continue with --restart " + s.last_checkpoint)
                << "\n";
    std::cout << std::setprecision(4) << "talus: done in " << s.wall_seconds << " s: " << status_text(s.status);
    if (s.status == talus::RunStatus::interrupted) std::cout << " by signal " << s.interrupted_by;
    std::cout << std::setprecision(6) << " at t = " << s.time << " s of " << s.end_time << " s; this run "
              << s.steps << " steps";
    if (s.steps_before > 0 || s.start_time > 0)
      std::cout << " (" << s.steps_before + 1 << " to " << s.steps_before + s.steps << " since t = 0, from t = "
                << s.start_time << " s)";
    std::cout << ", " << s.cutbacks << " cut-backs, " << s.newton_iterations << " Newton and " << s.linear_iterations
              << " KSP iterations, " << s.outputs << " outputs";
    if (config.output.enabled) std::cout << " (" << config.output.directory << "/particles.pvd)";
    std::cout << "\n";
    if (s.final_load.ranks > 1 && s.status != talus::RunStatus::failed)  // a failed run did not count them
      std::cout << std::setprecision(4) << "talus: " << s.final_load.ranks
                << " ranks, particles per rank at the end: " << s.final_load.min << " to " << s.final_load.max
                << " (mean " << s.final_load.mean() << ", max/mean " << s.final_load.imbalance()
                << "; worst during the run " << s.worst_imbalance << "), " << s.rebalances << " re-partitions\n";
    // Wall design: the largest force averaged over output.force_window on
    // each obstacle (docs/output.md#obstacle_forcescsv-the-force-on-each-obstacle).
    for (const auto& p : s.peak_window_forces)
      std::cout << std::setprecision(6) << "talus: peak force on " << p.obstacle << " averaged over "
                << s.force_window << " s: " << p.force << (dim == 2 ? " N/m" : " N") << " at t = " << p.time
                << " s\n";
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
    std::cout << std::setprecision(6) << "talus-summary: {\"status\": \"" << status_text(s.status)
              << "\", \"signal\": " << s.interrupted_by << ", \"dim\": " << dim
              << ", \"particles\": " << particles << ", \"start_time\": " << talus::number_text(s.start_time)
              << ", \"time\": " << talus::number_text(s.time) << ", \"end_time\": " << talus::number_text(s.end_time)
              << ", \"steps\": " << s.steps << ", \"steps_before\": " << s.steps_before
              << ", \"cutbacks\": " << s.cutbacks << ", \"cutbacks_before\": " << s.cutbacks_before
              << ", \"newton_iterations\": " << s.newton_iterations
              << ", \"max_step_newton_iterations\": " << s.max_step_newton_iterations
              << ", \"linear_iterations\": " << s.linear_iterations << ", \"outputs\": " << s.outputs
              << ", \"wall_seconds\": " << s.wall_seconds
              << ", \"transfer_seconds\": " << s.transfer_seconds << ", \"solve_seconds\": " << s.solve_seconds
              << ", \"contact_seconds\": " << s.contact_seconds << ", \"material_seconds\": " << s.material_seconds
              << ", \"assembly_seconds\": " << s.assembly_seconds << ", \"linear_solve_seconds\": " << s.linear_seconds
              << ", \"operator_seconds\": " << s.operator_seconds << ", \"contact_points\": " << s.contact_points
              << ", \"body_contact_points\": " << s.body_contact_points << ", \"ghost_cells\": " << s.ghost_cells
              << ", \"max_unbalance\": " << s.max_unbalance << ", \"energy_balance_error\": " << s.energy_balance_error << ", \"structure_builds\": " << s.structure_builds
              << ", \"equilibrium_steps\": " << s.equilibrium_steps
              << ", \"equilibrium_newton_iterations\": " << s.equilibrium_newton_iterations
              << ", \"equilibrium_last_stress_change\": " << s.equilibrium_last_stress_change
              << ", \"equilibrium_unbalance\": " << s.equilibrium_unbalance
              << ", \"equilibrium_gravity_work\": " << s.equilibrium_gravity_work
              << ", \"direct_fallbacks\": " << s.direct_fallbacks
              << ", \"multigrid_fallbacks\": " << s.multigrid_fallbacks << ", \"inverting_cutbacks\": " << s.inverting_cutbacks << ", \"contact_resolves\": " << s.contact_resolves << ", \"factorizations\": " << s.factorizations
              << ", \"jacobian_matrices\": " << s.jacobian_matrices << ", \"block_diagonals\": " << s.block_diagonals
              << ", \"ranks\": " << s.final_load.ranks << ", \"rebalances\": " << s.rebalances
              << ", \"worst_imbalance\": " << s.worst_imbalance << ", \"final_min_rank_particles\": "
              << s.final_load.min << ", \"final_max_rank_particles\": " << s.final_load.max
              << ", \"peak_rss_mb\": " << max_rss_mb << ", \"force_window\": " << s.force_window
              << ", \"peak_window_force\": {" << peaks.str() << "}}\n" << std::flush;
}

template <int dim>
int run_case(const talus::CaseConfig& config, const RunOptions& options, int rank) {
  talus::Simulation<dim> sim(config, PETSC_COMM_WORLD);
  if (!options.restart.empty()) sim.restart(options.restart);
  // Nothing is written before the directories are known to hold no older run
  // (or it was removed with --overwrite): bad input writes nothing.
  talus::prepare_run_directories(config, options.restart, sim.continued_directory(), options.overwrite,
                                 PETSC_COMM_WORLD);
  if (!options.restart.empty() && rank == 0)
    std::cout << "talus: restarting from " << options.restart << " at t = " << sim.time() << "\n";
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
              << "\n" << std::flush;
  talus::RunSummary s;
  try {
    s = sim.run(&std::cout, options.progress);
  } catch (const talus::SimulationError&) {
    print_summary<dim>(config, sim.summary(), particles, rank);
    throw;
  } catch (const talus::OutputError&) {
    print_summary<dim>(config, sim.summary(), particles, rank);
    throw;
  }
  print_summary<dim>(config, s, particles, rank);
  return s.interrupted_by ? 128 + s.interrupted_by : 0;
}

// A positive number following option argv[i]; 0 with `problem` set if there is none.
double option_value(int argc, char** argv, int i, bool integer, std::string& problem) {
  const std::string name = argv[i];
  if (i + 1 >= argc) {
    problem = name + " needs a value";
    return 0;
  }
  const std::string text = argv[i + 1];
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || !std::isfinite(value) || value < 0 || value > 1e9 ||
      (integer && value != std::floor(value)))
    problem = name + " " + text + ": expected " + (integer ? "an integer" : "a number") + " in [0, 1e9]";
  return value;
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
  RunOptions options;
  bool quiet = false;
  for (int i = 3; i < argc;) {
    const std::string a = argv[i];
    int taken = 0;
    std::string problem;
    if (a == "--restart") {
      if (i + 1 >= argc || command != "run") {
        std::cerr << "talus: --restart needs a checkpoint file and the run command; see talus --help\n";
        return 2;
      }
      options.restart = argv[i + 1];
      taken = 2;
    } else if (a == "--overwrite" || a == "--quiet") {
      (a == "--quiet" ? quiet : options.overwrite) = true;
      taken = 1;
    } else if (a == "--progress-steps") {
      options.progress.every_steps = static_cast<long>(option_value(argc, argv, i, true, problem));
      taken = 2;
    } else if (a == "--progress-seconds") {
      options.progress.every_seconds = option_value(argc, argv, i, false, problem);
      taken = 2;
    }
    if (taken > 0 && command != "run") problem = a + " is an option of talus run";
    if (!problem.empty()) {
      std::cerr << "talus: error: command line: " << problem << "\n";
      return 2;
    }
    if (taken == 0) {
      ++i;
      continue;
    }
    for (int j = i; j + taken <= argc; ++j) argv[j] = argv[j + taken];
    argc -= taken;
  }
  // What remains must be PETSc options: -name [value] pairs. An unknown
  // talus flag, PETSc's -help (which would print its option list and then
  // run the case), or a stray word is a command-line error, not ignored.
  for (int i = 3; i < argc; ++i) {
    const std::string a = argv[i];
    const bool value_of_option = i > 3 && argv[i - 1][0] == '-' && std::strncmp(argv[i - 1], "--", 2) != 0;
    std::string problem;
    if (a.rfind("--", 0) == 0)
      problem = "unknown option " + a +
                " (talus's own: --restart FILE, --overwrite, --quiet, --progress-steps N, --progress-seconds S; "
                "PETSc options take one dash, e.g. -talus_snes_monitor)";
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
    if (config.grid.shape == talus::ShapeKind::linear && config.grid.quadrature == talus::ParticleQuadrature::point &&
        rank == 0)
      // Issue 13, item 4 (docs/grid.md#linear-hats-linear): a valid choice
      // for small motions, a wrong one for a landslide; GIMP removes it.
      std::cerr << "talus: warning: " << argv[2] << ": grid.shape_function = linear has the cell-crossing error of "
                   "classic MPM: once particles cross cells the error grows under refinement; use "
                   "quadratic_bspline (the default) or grid.quadrature: domain (GIMP) unless every particle stays "
                   "within its cell\n";
    if (command == "check") {
      talus::apply_case_petsc_options(config);  // check_solver_options checks the values first
      if (config.dim == 2)
        talus::check_solver_options<2>(config, PETSC_COMM_WORLD);
      else
        talus::check_solver_options<3>(config, PETSC_COMM_WORLD);
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
      // The progress line: rewritten in place on a terminal (rank 0's stdout:
      // under mpiexec a pipe), else a line every N steps or S seconds.
      if (quiet) {
        options.progress.mode = talus::ProgressOptions::Mode::off;
      } else if (rank == 0 && isatty(STDOUT_FILENO)) {
        options.progress.mode = talus::ProgressOptions::Mode::terminal;
        winsize size{};
        if (ioctl(STDOUT_FILENO, TIOCGWINSZ, &size) == 0) options.progress.terminal_width = size.ws_col;
      }
      code = config.dim == 2 ? run_case<2>(config, options, rank) : run_case<3>(config, options, rank);
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
