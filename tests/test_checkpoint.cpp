// HDF5 checkpoints: run 2N steps; run N steps, checkpoint, restart in a new
// simulation and run N more. On the same number of ranks every particle comes
// back to its rank in its order. In serial the two runs must agree bit for
// bit; the test allows 1e-12 relative (round-off) and reports the largest
// difference. On several ranks the parallel LU (MUMPS) adds contributions in
// the order its messages arrive, so two identical runs already differ in
// round-off (1e-16 after 32 steps of this case), and inexact Newton's stopping
// decisions carry that up to the solver tolerance: there the runs must agree
// to the balance tolerance 1e-8 times the stiffness ratio (c_p h / dx)^2 ~ 10
// with a factor 10 to spare, 1e-6 (measured in 4 runs: at most 1.1e-7 on the
// separation strain, 2e-8 on the stress).
// A plastic, collapsing column is used so that the material state, the
// Kirchhoff stress, the voids and the step controller all matter.
#include <catch2/catch.hpp>
#include <filesystem>

#include "talus/simulation.hpp"
#include "test_support.hpp"

using namespace talus;

namespace {

// interval > 0: also a checkpoint every `interval` steps. `time`: the time
// keys besides `end` (a step that divides the checkpoint's time exactly).
std::string column(double end, const std::string& directory, long interval = 0,
                   const std::string& time = "step: 0.00390625") {
  return "grid: {lower: [0, 0], upper: [3.0, 1.2], cell_size: 0.05}\n"
         "time: {end: " + std::to_string(end) + ", " + time + "}\n"
         "output: {enabled: false}\n"
         "checkpoint: {enabled: true, interval: " + std::to_string(interval) + ", directory: " + directory + "}\n"
         "gravity: [0, -9.81]\n"
         "materials: [{name: sand, model: drucker_prager, density: 2000, youngs_modulus: 1.0e6, poisson_ratio: 0.3,\n"
         "             friction_angle: 30, dilatancy_angle: 0, cohesion: 0}]\n"
         "bodies: [{name: column, material: sand, box: {lower: [0, 0], upper: [0.5, 1.0]}}]\n"
         "boundaries: {y_min: fixed}\n";
}

double max_relative_difference(const std::vector<double>& a, const std::vector<double>& b) {
  REQUIRE(a.size() == b.size());
  return testing::max_relative_difference(a, b);
}

void restart_repeats_the_run(const std::string& time, const std::string& label) {
  const std::string dir = "checkpoint_" + label + "_" + std::to_string(testing::comm_size(PETSC_COMM_WORLD));
  int rank;
  MPI_Comm_rank(PETSC_COMM_WORLD, &rank);
  if (rank == 0) std::filesystem::remove_all(dir);
  MPI_Barrier(PETSC_COMM_WORLD);

  Simulation<2> first(testing::case_from_yaml(column(0.125, dir + "/first", 0, time)), PETSC_COMM_WORLD);
  const RunSummary f = first.run(nullptr);
  REQUIRE(std::filesystem::exists(f.last_checkpoint));
  // The uninterrupted run writes the same checkpoint on its way: the solver
  // (its LU factors, the inexact-Newton state) is not saved, so after every
  // checkpoint a run builds it anew, as the restarted run must
  // (docs/checkpoints.md). Without that the two runs would make different
  // linear solves and agree only to the solver tolerance, not to round-off.
  Simulation<2> whole(testing::case_from_yaml(column(0.25, dir + "/whole", f.steps, time)), PETSC_COMM_WORLD);
  const RunSummary w = whole.run(nullptr);
  Simulation<2> second(testing::case_from_yaml(column(0.25, dir + "/second", 0, time)), PETSC_COMM_WORLD);
  second.restart(f.last_checkpoint);
  CHECK(second.time() == first.time());
  for (const auto& [name, block] : {std::pair{field::position, 2}, std::pair{field::velocity, 2},
                                    std::pair{field::stress, 6}, std::pair{field::affine_velocity, 4},
                                    std::pair{field::material_state, 2}, std::pair{field::mass, 1}}) {
    const double d = max_relative_difference(testing::gather_by_id(first.particles(), name, block),
                                             testing::gather_by_id(second.particles(), name, block));
    INFO("after reading, " << name << ": largest difference " << d);
    CHECK(d == 0.0);
  }
  const RunSummary s = second.run(nullptr);
  // The counts: this run's steps after the checkpoint's, together the
  // uninterrupted run's (RunSummary: steps since the restart, steps_before
  // up to it).
  CHECK(s.steps_before == f.steps);
  CHECK(s.steps_before + s.steps == w.steps);
  CHECK(s.start_time == first.time());
  CHECK(second.time() == Approx(whole.time()).epsilon(1e-14));

  for (const auto& [name, block] : {std::pair{field::position, 2}, std::pair{field::velocity, 2},
                                    std::pair{field::stress, 6}, std::pair{field::deformation_gradient, 4},
                                    std::pair{field::cumulative_plastic_strain, 1},
                                    std::pair{field::separation_strain, 1}, std::pair{field::affine_velocity, 4}}) {
    const double d = max_relative_difference(testing::gather_by_id(whole.particles(), name, block),
                                             testing::gather_by_id(second.particles(), name, block));
    INFO(name << ": largest difference " << d);
    CHECK(d <= (testing::comm_size(PETSC_COMM_WORLD) == 1 ? 1e-12 : 1e-6));
  }
  // The energy balance goes on from the checkpoint's sums (docs/energy.md).
  CHECK(second.initial_energy() == whole.initial_energy());
  const auto a = whole.energy_terms().values(), b = second.energy_terms().values();
  for (int k = 0; k < EnergyTerms::count; ++k) {
    INFO(EnergyTerms::names()[k] << ": " << a[k] << " against " << b[k]);
    CHECK(std::abs(a[k] - b[k]) <= (testing::comm_size(PETSC_COMM_WORLD) == 1 ? 1e-12 : 1e-6) *
                                       std::max(1.0, std::abs(whole.initial_energy())));
  }
  CHECK(std::abs(second.energy_balance_error()) < 1e-6 * std::abs(whole.initial_energy()));
  // The column has collapsed enough for the comparison to mean something.
  const auto eps_p = testing::gather_by_id(whole.particles(), field::cumulative_plastic_strain, 1);
  CHECK(*std::max_element(eps_p.begin(), eps_p.end()) > 0.05);
  // A missing checkpoint is an input error.
  Simulation<2> bad(testing::case_from_yaml(column(0.25, dir + "/bad", 0, time)), PETSC_COMM_WORLD);
  CHECK_THROWS_AS(bad.restart(dir + "/none.h5"), InputError);
  MPI_Barrier(PETSC_COMM_WORLD);
  if (rank == 0) std::filesystem::remove_all(dir);
}

}  // namespace

TEST_CASE("a run restarted from a checkpoint repeats the uninterrupted run", "[checkpoint][mpi]") {
  restart_repeats_the_run("step: 0.00390625", "implicit");
}

// The explicit integrator (docs/explicit.md) at 2^-10 s, below its limit of
// 1.6e-3 s here: it has no solver state, so on several ranks too the runs
// differ by round-off only (within the same bounds).
TEST_CASE("an explicit run restarted from a checkpoint repeats the uninterrupted run", "[checkpoint][mpi][explicit]") {
  restart_repeats_the_run("step: 0.0009765625, integrator: explicit", "explicit");
}
