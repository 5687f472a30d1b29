// Balanced ranks (docs/parallel.md): the grid's DMDA ownership follows the
// particles, at the start and during the run, and the results do not depend
// on it. Run under mpiexec with 2 and 3 ranks (and serially, where the
// balancing is a no-op and the comparisons are trivially exact).
#include <catch2/catch.hpp>

#include "talus/simulation.hpp"
#include "test_support.hpp"

using namespace talus;

namespace {

// Largest difference of positions (m) and of stresses (relative to the
// largest stress) between two runs of the same case.
template <int dim>
std::pair<double, double> difference(Simulation<dim>& a, Simulation<dim>& b) {
  const auto xa = testing::gather_by_id(a.particles(), field::position, dim);
  const auto xb = testing::gather_by_id(b.particles(), field::position, dim);
  const auto sa = testing::gather_by_id(a.particles(), field::stress, 6);
  const auto sb = testing::gather_by_id(b.particles(), field::stress, 6);
  REQUIRE(xa.size() == xb.size());
  double dx = 0, ds = 0, smax = 0;
  for (std::size_t i = 0; i < xa.size(); ++i) dx = std::max(dx, std::abs(xa[i] - xb[i]));
  for (std::size_t i = 0; i < sa.size(); ++i) {
    ds = std::max(ds, std::abs(sa[i] - sb[i]));
    smax = std::max(smax, std::abs(sb[i]));
  }
  return {dx, ds / smax};
}

// An elastic block in the lower left corner of a box more than four times its
// size, thrown to the right over a slip floor (4 cells away from the x_min
// wall: a slip wall holds the normal velocity of its grid points, and would
// hold a block that touches it).
const std::string corner_block_2d =
    "grid: {lower: [0, 0], upper: [2.0, 1.0], cell_size: 0.025}\n"
    "time: {end: 0.3, step: 0.01}\noutput: {enabled: false}\ncheckpoint: {enabled: false}\n"
    "gravity: [0, -9.81]\n"
    "materials: [{name: m, model: linear_elastic, density: 1000, youngs_modulus: 2.0e5, poisson_ratio: 0.25}]\n"
    "bodies: [{name: b, material: m, box: {lower: [0.1, 0], upper: [0.4, 0.3]}, velocity: [2.0, 0.5]}]\n"
    "boundaries: {y_min: slip}\n";

}  // namespace

TEST_CASE("a body in one corner of a large box: every rank gets its share of particles, to one grid point", "[balance][mpi]") {
  const int ranks = testing::comm_size(PETSC_COMM_WORLD);
  const CaseConfig config = testing::case_from_yaml(corner_block_2d);
  Simulation<2> balanced(config, PETSC_COMM_WORLD);
  const RankLoad load = rank_load(PETSC_COMM_WORLD, balanced.particles().local_count());
  INFO(ranks << " ranks: particles per rank " << load.min << " to " << load.max);
  CHECK(load.total == 576);  // 12 x 12 cells, 2 x 2 particles per cell
  // A rank owns the particles of whole grid points along each axis. With
  // quadratic B-splines a particle belongs to the point nearest above it
  // (k + 1 for the DMDA cell k = floor(u + 1/2)), so the 24 particle columns
  // of the block fall on 13 points: 24 particles on the first and last, 48 on
  // each of the 11 between (likewise in y). No DMDA split can then do better
  // than one point's 48 particles above the mean (312 of 288 on 2 ranks, 216
  // of 192 on 3); the balancing must reach that.
  CHECK(load.max <= load.mean() + 48);
  if (ranks > 1) {
    // PETSc's even split of the box leaves ranks without any particle; that
    // is what the balancing removes.
    CaseConfig even = config;
    even.parallel.balance = false;
    Simulation<2> unbalanced(even, PETSC_COMM_WORLD);
    CHECK(rank_load(PETSC_COMM_WORLD, unbalanced.particles().local_count()).min == 0);
  }
}

TEST_CASE("re-partitioning during the run follows the body and leaves the result unchanged", "[balance][mpi]") {
  const auto lu = testing::lu_on_every_rank();
  const int ranks = testing::comm_size(PETSC_COMM_WORLD);
  CaseConfig config = testing::case_from_yaml(corner_block_2d + "parallel: {imbalance_limit: 1.1}\n");
  Simulation<2> parallel(config, PETSC_COMM_WORLD);
  const RunSummary p = parallel.run(nullptr);
  Simulation<2> serial(config, PETSC_COMM_SELF);
  const RunSummary s = serial.run(nullptr);
  CHECK(p.steps == s.steps);
  const auto [dx, ds] = difference(parallel, serial);
  INFO(ranks << " ranks, " << p.steps << " steps, " << p.rebalances << " re-partitions, worst max/mean "
             << p.worst_imbalance << ", at the end " << p.final_load.min << " to " << p.final_load.max
             << " particles; |x_parallel - x_serial| <= " << dx << " m, stress difference " << ds);
  // As in test_parallel_equality: Newton stops at the same unbalance with a
  // direct solver, the runs differ by round-off amplified over 30 steps of
  // about 2 cm each; 1e-9 m is far above round-off and far below any
  // modelling error.
  CHECK(dx < 1e-9);
  CHECK(ds < 1e-8);
  if (ranks > 1) {
    // The block travels 0.6 m, twice its width: the partition of the start
    // leaves it on one rank unless the grid is re-partitioned.
    CHECK(p.rebalances >= 1);
    // Every step starts (worst_imbalance is measured after any re-partition)
    // within the limit, or within what a cut can reach: one grid point's 48
    // particles above the mean (first test), and a re-partition needs a 5 %
    // gain. Without re-partitioning the block ends on one rank: max/mean =
    // `ranks`.
    const double mean = p.final_load.mean();
    CHECK(p.worst_imbalance <= std::max(1.1, (mean + 48) / mean / 0.95));
    // The last step may drift past the limit: by at most one step's motion,
    // 0.8 cell, that is 2 of the 24 particle columns (1/6 of a rank's share
    // on 2 ranks, 1/4 on 3), plus the one-point granularity of the cut.
    CHECK(p.final_load.min >= 0.4 * p.final_load.mean());
  }
}

TEST_CASE("3D: a block in one corner, balanced, equals the serial run", "[balance][mpi]") {
  const auto lu = testing::lu_on_every_rank();
  const std::string yaml =
      "grid: {lower: [0, 0, 0], upper: [1.0, 0.5, 0.5], cell_size: 0.05}\n"
      "time: {end: 0.05, step: 0.01}\noutput: {enabled: false}\ncheckpoint: {enabled: false}\n"
      "gravity: [0, 0, -9.81]\n"
      "materials: [{name: m, model: linear_elastic, density: 1000, youngs_modulus: 2.0e5, poisson_ratio: 0.25}]\n"
      "bodies: [{name: b, material: m, box: {lower: [0, 0, 0], upper: [0.4, 0.2, 0.2]}, velocity: [1.0, 0.5, 0]}]\n"
      "boundaries: {z_min: slip}\n";
  const CaseConfig config = testing::case_from_yaml(yaml);
  Simulation<3> parallel(config, PETSC_COMM_WORLD);
  const RankLoad load = rank_load(PETSC_COMM_WORLD, parallel.particles().local_count());
  INFO("particles per rank " << load.min << " to " << load.max);
  CHECK(load.total == 1024);  // 8 x 4 x 4 cells, 2 x 2 x 2 particles per cell
  // The target of the balancing (issue 11): no rank below 40 % of the mean.
  CHECK(load.min >= 0.4 * load.mean());
  // As in 2D, within one grid point's particles of the mean: 2 x 64 along x
  // (8 x 8 particles per plane), the finest cut of the longest axis.
  CHECK(load.max <= load.mean() + 128);
  Simulation<3> serial(config, PETSC_COMM_SELF);
  for (int n = 0; n < 5; ++n) {
    REQUIRE(parallel.advance(0.01).converged);
    REQUIRE(serial.advance(0.01).converged);
  }
  const auto [dx, ds] = difference(parallel, serial);
  INFO("|x_parallel - x_serial| <= " << dx << " m, stress difference " << ds);
  CHECK(dx < 1e-9);
  CHECK(ds < 1e-8);
}

TEST_CASE("a collapsing column split across its height by the balancing runs like the serial one", "[balance][mpi]") {
  const auto lu = testing::lu_on_every_rank();
  // inputs/column_collapse_psi0.yaml for 0.1 s: the balancing cuts the
  // 0.5 x 1.0 m column across its height (1 x 2 process grid). Grid rows
  // next to the cut are first touched only by the lower rank's particles and,
  // as the column slumps, by the upper rank's too, while the active set (and
  // so the reused matrix) stays the same: the case that once needed a new
  // nonzero in a reused matrix (momentum_system.cpp, jacobian).
  const CaseConfig config = testing::case_from_yaml(
      "grid: {lower: [0, 0], upper: [3.0, 1.2], cell_size: 0.05}\n"
      "time: {end: 0.1, step: 0.0025}\noutput: {enabled: false}\ncheckpoint: {enabled: false}\n"
      "gravity: [0, -9.81]\n"
      "materials: [{name: sand, model: drucker_prager, density: 2000, youngs_modulus: 1.0e6, poisson_ratio: 0.3,\n"
      "             friction_angle: 30, dilatancy_angle: 0, cohesion: 0, mohr_coulomb_match: plane_strain}]\n"
      "bodies: [{name: column, material: sand, box: {lower: [0, 0], upper: [0.5, 1.0]}, particles_per_cell: 2}]\n"
      "boundaries: {x_min: slip, x_max: slip, y_min: fixed, y_max: slip}\n");
  Simulation<2> parallel(config, PETSC_COMM_WORLD);
  const RunSummary p = parallel.run(nullptr);
  Simulation<2> serial(config, PETSC_COMM_SELF);
  const RunSummary s = serial.run(nullptr);
  const auto [dx, ds] = difference(parallel, serial);
  INFO(p.steps << " and " << s.steps << " steps, " << p.structure_builds << " structure builds; |x_parallel - x_serial| <= "
                << dx << " m, stress difference " << ds);
  CHECK(p.steps == s.steps);
  CHECK(p.structure_builds < p.steps);  // the matrix was reused
  // Plastic flow: the step's solution is unique only to the balance
  // tolerance (docs/solver.md#non-unique-steps), and 40 steps amplify
  // round-off; 1e-6 m is 2e-5 of a cell.
  CHECK(dx < 1e-6);
}
