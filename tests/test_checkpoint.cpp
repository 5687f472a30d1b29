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
// Then the self-describing attributes (issue 15, item 8): units, component
// order, version, case file and the obstacle loads.
#include <hdf5.h>

#include <catch2/catch.hpp>
#include <filesystem>
#include <sstream>

#include "talus/simulation.hpp"
#include "test_support.hpp"

using namespace talus;

namespace {

// interval > 0: also a checkpoint every `interval` steps. `time`: the time
// keys besides `end` (a step that divides the checkpoint's time exactly);
// `grid`: more grid keys.
std::string column(double end, const std::string& directory, long interval = 0,
                   const std::string& time = "step: 0.00390625", const std::string& grid = "") {
  return "grid: {lower: [0, 0], upper: [3.0, 1.2], cell_size: 0.05" + grid + "}\n"
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

void restart_repeats_the_run(const std::string& time, const std::string& label, const std::string& grid = "") {
  const std::string dir = "checkpoint_" + label + "_" + std::to_string(testing::comm_size(PETSC_COMM_WORLD));
  int rank;
  MPI_Comm_rank(PETSC_COMM_WORLD, &rank);
  if (rank == 0) std::filesystem::remove_all(dir);
  MPI_Barrier(PETSC_COMM_WORLD);

  Simulation<2> first(testing::case_from_yaml(column(0.125, dir + "/first", 0, time, grid)), PETSC_COMM_WORLD);
  const RunSummary f = first.run(nullptr);
  REQUIRE(std::filesystem::exists(f.last_checkpoint));
  // The uninterrupted run writes the same checkpoint on its way: the solver
  // (its LU factors, the inexact-Newton state) is not saved, so after every
  // checkpoint a run builds it anew, as the restarted run must
  // (docs/checkpoints.md). Without that the two runs would make different
  // linear solves and agree only to the solver tolerance, not to round-off.
  Simulation<2> whole(testing::case_from_yaml(column(0.25, dir + "/whole", f.steps, time, grid)), PETSC_COMM_WORLD);
  const RunSummary w = whole.run(nullptr);
  Simulation<2> second(testing::case_from_yaml(column(0.25, dir + "/second", 0, time, grid)), PETSC_COMM_WORLD);
  second.restart(f.last_checkpoint);
  CHECK(second.time() == first.time());
  for (const auto& [name, block] : {std::pair{field::position, 2}, std::pair{field::velocity, 2},
                                    std::pair{field::stress, 6}, std::pair{field::affine_velocity, 4},
                                    std::pair{field::material_state, 2}, std::pair{field::mass, 1},
                                    std::pair{field::volume_ratio, 1}}) {
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
                                    std::pair{field::volume_ratio, 1}, std::pair{field::cumulative_plastic_strain, 1},
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
  Simulation<2> bad(testing::case_from_yaml(column(0.25, dir + "/bad", 0, time, grid)), PETSC_COMM_WORLD);
  CHECK_THROWS_AS(bad.restart(dir + "/none.h5"), InputError);
  MPI_Barrier(PETSC_COMM_WORLD);
  if (rank == 0) std::filesystem::remove_all(dir);
}

}  // namespace

TEST_CASE("a run restarted from a checkpoint repeats the uninterrupted run", "[checkpoint][mpi]") {
  restart_repeats_the_run("step: 0.00390625", "implicit");
}

// Domain quadrature (docs/grid.md#particle-quadrature): the domains come
// from F and V0, both in the checkpoint, so the restart repeats the run too.
TEST_CASE("a run with domain quadrature restarted from a checkpoint repeats the uninterrupted run",
          "[checkpoint][mpi]") {
  restart_repeats_the_run("step: 0.00390625", "domain", ", quadrature: domain");
}

// The explicit integrator (docs/explicit.md) at 2^-10 s, below its limit of
// 1.6e-3 s here: it has no solver state, so on several ranks too the runs
// differ by round-off only (within the same bounds).
TEST_CASE("an explicit run restarted from a checkpoint repeats the uninterrupted run", "[checkpoint][mpi][explicit]") {
  restart_repeats_the_run("step: 0.0009765625, integrator: explicit", "explicit");
}

namespace {

std::string text_attribute(hid_t object, const char* name) {
  INFO("attribute " << name);
  REQUIRE(H5Aexists(object, name) > 0);
  const hid_t a = H5Aopen(object, name, H5P_DEFAULT);
  const hid_t type = H5Aget_type(a);
  REQUIRE(H5Tget_class(type) == H5T_STRING);
  std::string text(H5Tget_size(type), '\0');
  REQUIRE(H5Aread(a, type, text.data()) >= 0);
  H5Tclose(type);
  H5Aclose(a);
  return text.substr(0, text.find('\0'));
}

// A whole 2D dataset of doubles (or int64 ids), with its column count.
template <class T>
std::vector<T> table(hid_t file, const std::string& path, hid_t type, hsize_t& columns) {
  const hid_t d = H5Dopen2(file, path.c_str(), H5P_DEFAULT);
  REQUIRE(d >= 0);
  const hid_t space = H5Dget_space(d);
  hsize_t dims[2] = {0, 0};
  REQUIRE(H5Sget_simple_extent_ndims(space) == 2);
  H5Sget_simple_extent_dims(space, dims, nullptr);
  std::vector<T> values(dims[0] * dims[1]);
  if (!values.empty()) REQUIRE(H5Dread(d, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()) >= 0);
  H5Sclose(space);
  H5Dclose(d);
  columns = dims[1];
  return values;
}

std::vector<std::string> words(const std::string& text) {
  std::istringstream in(text);
  std::vector<std::string> w;
  for (std::string x; in >> x;) w.push_back(x);
  return w;
}

// A 3D block on a floor (one obstacle), its case file named wall_case.yaml.
std::string block_case(const std::string& directory) {
  return "grid: {lower: [0, 0, 0], upper: [0.4, 0.4, 0.4], cell_size: 0.1}\n"
         "time: {end: 0.02, step: 0.01}\n"
         "output: {enabled: false, force_window: 0.015}\n"
         "checkpoint: {enabled: true, directory: " + directory + "}\n"
         "gravity: [0, 0, -9.81]\n"
         "materials: [{name: rock, model: linear_elastic, density: 2000, youngs_modulus: 1.0e7, poisson_ratio: 0.3}]\n"
         "bodies: [{name: block, material: rock, box: {lower: [0.1, 0.1, 0.1], upper: [0.3, 0.3, 0.3]}}]\n"
         "obstacles: [{name: floor, type: half_plane, point: [0, 0, 0.1], normal: [0, 0, 1], friction: 0.5}]\n";
}

}  // namespace

TEST_CASE("a checkpoint describes itself: units, stress component order, version, case, obstacle loads",
          "[checkpoint]") {
  const std::string dir = "checkpoint_self_describing";
  std::filesystem::remove_all(dir);
  const std::string case_path = dir + "/wall_case.yaml";
  Simulation<3> sim(parse_case(block_case(dir), case_path), PETSC_COMM_SELF);
  const RunSummary summary = sim.run(nullptr);
  REQUIRE(std::filesystem::exists(summary.last_checkpoint));

  // A known stress state, different in every component and particle, stored
  // the way the code stores it (tensor_to_voigt) and written: the columns of
  // the file, named by component_order, must give the tensor back.
  Eigen::Matrix3d base;
  base << 1, 6, 5, 6, 2, 4, 5, 4, 3;  // xx 1, yy 2, zz 3, yz 4, xz 5, xy 6 (kPa)
  base *= 1e3;
  {
    FieldView<PetscReal> s(sim.particles().swarm(), field::stress);
    FieldView<std::int64_t> id(sim.particles().swarm(), field::particle_id);
    for (PetscInt p = 0; p < sim.particles().local_count(); ++p)
      Eigen::Map<Voigt>(s.data() + 6 * p) = tensor_to_voigt(base * static_cast<double>(1 + id[p]));
  }
  RunState state;
  state.time = sim.time();
  state.step_size = 0.01;
  state.next_output = sim.time();
  state.obstacle_loads = sim.obstacle_loads().state();
  state.obstacle_names = {"floor"};
  const std::string stress_path = dir + "/known_stress.h5";
  write_checkpoint(stress_path, sim.particles(), state, PETSC_COMM_SELF);

  const hid_t file = H5Fopen(stress_path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(file >= 0);
  const hid_t dset = H5Dopen2(file, "particles/kirchhoff_stress", H5P_DEFAULT);
  const std::vector<std::string> order = words(text_attribute(dset, "component_order"));
  CHECK(text_attribute(dset, "units") == "Pa");
  H5Dclose(dset);
  CHECK(order == std::vector<std::string>{"xx", "yy", "zz", "yz", "xz", "xy"});  // docs/checkpoints.md
  hsize_t columns = 0, one = 0;
  const auto stress = table<double>(file, "particles/kirchhoff_stress", H5T_NATIVE_DOUBLE, columns);
  const auto ids = table<std::int64_t>(file, "particles/particle_id", H5T_NATIVE_INT64, one);
  H5Fclose(file);
  REQUIRE(columns == 6);
  REQUIRE(order.size() == 6);
  REQUIRE(ids.size() == 64);  // 2 x 2 x 2 cells of 2 x 2 x 2 particles
  long checked = 0;
  for (std::size_t p = 0; p < ids.size(); ++p)
    for (int c = 0; c < 6; ++c) {
      const int i = order[c][0] - 'x', j = order[c][1] - 'x';
      INFO("particle " << ids[p] << ", column " << c << " (" << order[c] << ")");
      CHECK(stress[6 * p + c] == base(i, j) * static_cast<double>(1 + ids[p]));  // written and read, not computed
      ++checked;
    }
  CHECK(checked == 6 * 64);

  // The run's own checkpoint: every dataset says its unit, what it is and
  // (several columns) their order; /run names the version and the case.
  const hid_t run_file = H5Fopen(summary.last_checkpoint.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(run_file >= 0);
  const std::map<std::string, std::pair<std::string, int>> particles{
      {"position", {"m", 3}}, {"velocity", {"m/s", 3}}, {"affine_velocity", {"1/s", 9}},
      {"displacement", {"m", 3}}, {"mass", {"kg", 1}}, {"initial_volume", {"m^3", 1}},
      {"deformation_gradient", {"1", 9}}, {"volume_ratio", {"1", 1}}, {"kirchhoff_stress", {"Pa", 6}}, {"material_state", {"1", 2}},
      {"cumulative_plastic_strain", {"1", 1}}, {"separation_strain", {"1", 1}}, {"material_id", {"1", 1}},
      {"body_id", {"1", 1}}, {"particle_id", {"1", 1}}};
  for (const auto& [name, unit] : particles) {
    const hid_t d = H5Dopen2(run_file, ("particles/" + name).c_str(), H5P_DEFAULT);
    REQUIRE(d >= 0);
    CHECK(text_attribute(d, "units") == unit.first);
    CHECK(!text_attribute(d, "description").empty());
    if (unit.second > 1 && name != "material_state")
      CHECK(words(text_attribute(d, "component_order")).size() == static_cast<std::size_t>(unit.second));
    H5Dclose(d);
  }
  {
    const hid_t d = H5Dopen2(run_file, "particles/deformation_gradient", H5P_DEFAULT);
    CHECK(text_attribute(d, "component_order") == "xx xy xz yx yy yz zx zy zz");  // row-major
    H5Dclose(d);
  }
  const hid_t run = H5Gopen2(run_file, "run", H5P_DEFAULT);
  CHECK(text_attribute(run, "talus_version") == TALUS_VERSION);
  CHECK(text_attribute(run, "case_file") == std::filesystem::absolute(case_path).lexically_normal().string());
  CHECK(text_attribute(run, "case_name") == "wall_case");
  CHECK(text_attribute(run, "units").find("time, step_size, next_output: s") != std::string::npos);
  H5Gclose(run);
  // The obstacle loads: what the run holds, and their units.
  const hid_t obstacles = H5Gopen2(run_file, "obstacles", H5P_DEFAULT);
  REQUIRE(obstacles >= 0);
  CHECK(text_attribute(obstacles, "names") == "floor\n");
  const hid_t total_set = H5Dopen2(obstacles, "impulse_total", H5P_DEFAULT);
  CHECK(text_attribute(total_set, "units") == "N s");
  H5Dclose(total_set);
  H5Gclose(obstacles);
  const auto total = table<double>(run_file, "obstacles/impulse_total", H5T_NATIVE_DOUBLE, columns);
  CHECK(columns == 3);
  CHECK(total == sim.obstacle_loads().total_impulse());
  // The floor carried the block: an impulse downwards (on the floor).
  CHECK(total[2] < 0.0);
  H5Fclose(run_file);
  std::filesystem::remove_all(dir);
}
