// Damaged checkpoints and restarts with another case (issue 14, items 1 and
// 2; docs/checkpoints.md): every damage is an InputError "not a valid talus
// checkpoint: <what>" (exit 2 in the command line), never a crash, a hang or
// a run on a wrong state; a case that changed what the particle state
// depends on is refused with the sections that differ; the keys that may
// change on restart (time, output, checkpoint, solver, parallel) and a
// different way of writing the same case are accepted.
#include <hdf5.h>

#include <catch2/catch.hpp>
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>

#include "talus/simulation.hpp"
#include "test_support.hpp"

using namespace talus;

namespace {

// Each test case works in its own directory: ctest runs them in parallel
// processes (and not under the test binary's own name: it runs in the build
// directory).
std::string dir = "checkpoint_damage_files";

std::string column(const std::string& grid = "grid: {lower: [0, 0], upper: [1.0, 0.6], cell_size: 0.05}\n",
                   const std::string& materials =
                       "materials: [{name: sand, model: drucker_prager, density: 2000, youngs_modulus: 1.0e6,"
                       " poisson_ratio: 0.3, friction_angle: 30, dilatancy_angle: 0, cohesion: 0}]\n",
                   const std::string& gravity = "gravity: [0, -9.81]\n",
                   const std::string& time = "time: {end: 0.015625, step: 0.00390625}\n") {
  return grid + time + "output: {enabled: false}\n" + "checkpoint: {enabled: true, directory: " + dir + "}\n" +
         gravity + materials + "bodies: [{name: column, material: sand, box: {lower: [0, 0], upper: [0.3, 0.4]}}]\n" +
         "boundaries: {y_min: fixed}\n";
}

// The column with its body's defaults written out.
std::string with_body_defaults(std::string text) {
  const std::string body = "box: {lower: [0, 0], upper: [0.3, 0.4]}}";
  text.replace(text.find(body), body.size(),
               "box: {lower: [0, 0], upper: [0.3, 0.4]}, particles_per_cell: 2, initial_stress: none,"
               " velocity: [0, 0.0]}");
  return text;
}

// The checkpoint of 4 steps of the column, written once.
const std::string& written_checkpoint() {
  static const std::string path = [] {
    std::filesystem::remove_all(dir);
    Simulation<2> run(testing::case_from_yaml(column()), PETSC_COMM_SELF);
    const RunSummary s = run.run(nullptr);
    REQUIRE(std::filesystem::exists(s.last_checkpoint));
    return s.last_checkpoint;
  }();
  return path;
}

// A copy of the checkpoint (or of `source`), changed by `damage` (given the open file).
std::string damaged(const std::string& name, const std::function<void(hid_t)>& damage, const std::string& source = "") {
  std::filesystem::create_directories(dir);
  const std::string path = dir + "/" + name + ".h5";
  std::filesystem::copy_file(source.empty() ? written_checkpoint() : source, path,
                             std::filesystem::copy_options::overwrite_existing);
  const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  REQUIRE(file >= 0);
  damage(file);
  REQUIRE(H5Fclose(file) >= 0);
  return path;
}

// Overwrites element (row, column) of /particles/<dataset> with `value`.
template <class T>
void set_element(hid_t file, const char* dataset, hsize_t row, hsize_t column, T value, hid_t type) {
  const hid_t d = H5Dopen2(file, (std::string("particles/") + dataset).c_str(), H5P_DEFAULT);
  REQUIRE(d >= 0);
  const hid_t space = H5Dget_space(d);
  const hsize_t start[2] = {row, column}, count[2] = {1, 1};
  REQUIRE(H5Sselect_hyperslab(space, H5S_SELECT_SET, start, nullptr, count, nullptr) >= 0);
  const hid_t memory = H5Screate_simple(2, count, nullptr);
  REQUIRE(H5Dwrite(d, type, memory, space, H5P_DEFAULT, &value) >= 0);
  H5Sclose(memory);
  H5Sclose(space);
  H5Dclose(d);
}

template <class T>
void set_run_attribute(hid_t file, const char* name, T value, hid_t type) {
  const hid_t run = H5Gopen2(file, "run", H5P_DEFAULT);
  const hid_t a = H5Aopen(run, name, H5P_DEFAULT);
  REQUIRE(a >= 0);
  REQUIRE(H5Awrite(a, type, &value) >= 0);
  H5Aclose(a);
  H5Gclose(run);
}

void restart_fails(const std::string& path, const std::string& message, const std::string& case_text = column()) {
  Simulation<2> sim(testing::case_from_yaml(case_text), PETSC_COMM_SELF);
  CHECK_THROWS_AS(sim.restart(path), InputError);
  CHECK_THROWS_WITH(sim.restart(path), Catch::Contains(message));
}

}  // namespace

TEST_CASE("a damaged checkpoint is refused with what is wrong with it", "[checkpoint]") {
  dir = "checkpoint_damage_files";
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::string invalid = "not a valid talus checkpoint: ";
  SECTION("a material index out of range (was a heap overflow)") {
    restart_fails(damaged("material", [](hid_t f) { set_element<int>(f, "material_id", 0, 0, 5, H5T_NATIVE_INT); }),
                  invalid + "material_id of particle 0 (row 0): 5 is not a material of this case (it has 1)");
  }
  SECTION("a body index out of range") {
    restart_fails(damaged("body", [](hid_t f) { set_element<int>(f, "body_id", 7, 0, -1, H5T_NATIVE_INT); }),
                  invalid + "body_id of particle 7 (row 7): -1 is not a body of this case (it has 1)");
  }
  SECTION("a NaN time (ran 0 steps with exit 0)") {
    restart_fails(damaged("time", [&](hid_t f) { set_run_attribute(f, "time", nan, H5T_NATIVE_DOUBLE); }),
                  invalid + "time = nan");
  }
  SECTION("a zero step size (hung)") {
    restart_fails(damaged("step", [](hid_t f) { set_run_attribute(f, "step_size", 0.0, H5T_NATIVE_DOUBLE); }),
                  invalid + "step_size = 0");
  }
  SECTION("a negative mass") {
    restart_fails(damaged("mass", [](hid_t f) { set_element(f, "mass", 3, 0, -1.0, H5T_NATIVE_DOUBLE); }),
                  invalid + "mass of particle 3 (row 3): -1 is not positive");
  }
  SECTION("a mass that is not the density times the volume") {
    restart_fails(damaged("mass2", [](hid_t f) { set_element(f, "mass", 2, 0, 1.0, H5T_NATIVE_DOUBLE); }),
                  invalid + "material_id of particle 2 (row 2): its mass 1 is not this case's density 2000");
  }
  SECTION("an inverted particle (volume ratio J = 0)") {
    restart_fails(damaged("inverted", [](hid_t f) { set_element(f, "volume_ratio", 4, 0, 0.0, H5T_NATIVE_DOUBLE); }),
                  invalid + "volume_ratio of particle 4 (row 4): 0 is not positive");
  }
  SECTION("a format-7 checkpoint (no volume ratio) with a singular deformation gradient") {
    restart_fails(damaged("singular",
                          [](hid_t f) {
                            REQUIRE(H5Ldelete(f, "particles/volume_ratio", H5P_DEFAULT) >= 0);
                            set_run_attribute(f, "checkpoint_format", 7, H5T_NATIVE_INT);
                            for (hsize_t c = 0; c < 4; ++c)
                              set_element(f, "deformation_gradient", 4, c, 0.0, H5T_NATIVE_DOUBLE);
                          }),
                  invalid + "deformation_gradient of particle 4 (row 4): det F = 0 is not positive");
  }
  SECTION("a format this talus does not read") {
    const std::string path =
        damaged("format6", [](hid_t f) { set_run_attribute(f, "checkpoint_format", 6, H5T_NATIVE_INT); });
    Simulation<2> sim(testing::case_from_yaml(column()), PETSC_COMM_SELF);
    CHECK_THROWS_WITH(sim.restart(path), Catch::Contains("checkpoint format 6, this talus reads formats 7 to 8"));
  }
  SECTION("a position outside the grid (was moved onto the grid's edge)") {
    restart_fails(damaged("outside", [](hid_t f) { set_element(f, "position", 0, 0, 10.0, H5T_NATIVE_DOUBLE); }),
                  invalid + "position of particle 0 (row 0): 10 lies outside this case's grid along axis 0");
  }
  SECTION("a non-finite velocity") {
    restart_fails(damaged("velocity", [&](hid_t f) { set_element(f, "velocity", 5, 1, nan, H5T_NATIVE_DOUBLE); }),
                  invalid + "velocity of particle 5 (row 5): not a finite number");
  }
  SECTION("two particles with one id") {
    restart_fails(damaged("ids", [](hid_t f) { set_element<std::int64_t>(f, "particle_id", 1, 0, 0, H5T_NATIVE_INT64); }),
                  invalid + "particle_id: particle id 0 appears twice");
  }
  SECTION("an attribute of the wrong type (a flipped type was a SEGV inside H5Aread)") {
    const std::string path = damaged("type", [](hid_t f) {
      const hid_t run = H5Gopen2(f, "run", H5P_DEFAULT);
      REQUIRE(H5Adelete(run, "steps") >= 0);
      const hid_t space = H5Screate_simple(1, std::array<hsize_t, 1>{3}.data(), nullptr);
      const hid_t a = H5Acreate2(run, "steps", H5T_NATIVE_DOUBLE, space, H5P_DEFAULT, H5P_DEFAULT);
      const double three[3] = {1, 2, 3};
      REQUIRE(H5Awrite(a, H5T_NATIVE_DOUBLE, three) >= 0);
      H5Aclose(a);
      H5Sclose(space);
      H5Gclose(run);
    });
    restart_fails(path, invalid + "attribute steps has the wrong type or shape");
  }
  SECTION("a missing dataset") {
    restart_fails(damaged("missing", [](hid_t f) { REQUIRE(H5Ldelete(f, "particles/kirchhoff_stress", H5P_DEFAULT) >= 0); }),
                  invalid);
  }
  SECTION("not an HDF5 file at all") {
    const std::string path = dir + "/text.h5";
    std::ofstream(path) << "not hdf5\n";
    restart_fails(path, "not an HDF5 checkpoint");
  }
}

TEST_CASE("a restart with another case is refused, naming what differs", "[checkpoint]") {
  dir = "checkpoint_damage_changed_case";
  const std::string& path = written_checkpoint();
  const std::string refused = "the checkpoint belongs to another case: ";
  SECTION("the grid extended by 1 m") {
    restart_fails(path, refused + "`grid` differs",
                  column("grid: {lower: [-1, 0], upper: [1.0, 0.6], cell_size: 0.05}\n"));
  }
  SECTION("another density") {
    restart_fails(path, refused + "`materials` differs",
                  column("grid: {lower: [0, 0], upper: [1.0, 0.6], cell_size: 0.05}\n",
                         "materials: [{name: sand, model: drucker_prager, density: 2100, youngs_modulus: 1.0e6,"
                         " poisson_ratio: 0.3, friction_angle: 30, dilatancy_angle: 0, cohesion: 0}]\n"));
  }
  SECTION("a default of the material changed (cohesion 0 -> 10 Pa)") {
    restart_fails(path, refused + "`materials` differs",
                  column("grid: {lower: [0, 0], upper: [1.0, 0.6], cell_size: 0.05}\n",
                         "materials: [{name: sand, model: drucker_prager, density: 2000, youngs_modulus: 1.0e6,"
                         " poisson_ratio: 0.3, friction_angle: 30, cohesion: 10}]\n"));
  }
  SECTION("a body's default changed (particles_per_cell 2 -> 3)") {
    std::string text = with_body_defaults(column());
    text.replace(text.find("particles_per_cell: 2"), 21, "particles_per_cell: 3");
    restart_fails(path, refused + "`bodies` differs", text);
  }
  SECTION("another gravity") {
    restart_fails(path, refused + "`gravity` differs",
                  column("grid: {lower: [0, 0], upper: [1.0, 0.6], cell_size: 0.05}\n",
                         "materials: [{name: sand, model: drucker_prager, density: 2000, youngs_modulus: 1.0e6,"
                         " poisson_ratio: 0.3, friction_angle: 30, dilatancy_angle: 0, cohesion: 0}]\n",
                         "gravity: [0, -1.62]\n"));
  }
  SECTION("the same case written differently, run longer with another step, is accepted") {
    // Keys reordered, block style, 2e3 for 2000, defaults written out
    // (shape_function, transfer, contact) or left out (the material's
    // dilatancy_angle and cohesion), the material's other defaults written
    // out (hardening_modulus, mohr_coulomb_match), the body's defaults
    // written out (particles_per_cell, initial_stress, velocity): the same
    // fingerprint.
    const std::string same = column(
        "grid:\n  cell_size: 5.0e-2\n  upper: [1, 0.6]\n  lower: [0.0, 0.0]\n  shape_function: quadratic_bspline\n"
        "transfer: {scheme: apic}\ncontact: {gap_prediction: 0.5}\n",
        "materials:\n  - {model: drucker_prager, name: sand, density: 2e3, youngs_modulus: 1000000,"
        " poisson_ratio: 0.3, friction_angle: 30.0, hardening_modulus: 0, mohr_coulomb_match: plane_strain}\n",
        "gravity: [0, -9.81]\n", "time: {end: 0.03125, step: 0.001953125}\n");
    Simulation<2> sim(testing::case_from_yaml(with_body_defaults(same)), PETSC_COMM_SELF);
    REQUIRE_NOTHROW(sim.restart(path));
    const RunSummary s = sim.run(nullptr);
    CHECK(sim.time() == Approx(0.03125));
    // 4 steps of 2^-8 s to the checkpoint at 2^-6 s, then 8 of the new,
    // smaller step 2^-9 s (the checkpoint's larger step is not kept).
    CHECK(s.steps_before == 4);
    CHECK(s.steps == 8);
  }
}

// The obstacle loads (/obstacles, docs/checkpoints.md): the column on a
// frictional floor (one obstacle, the face y_min), with the default window
// of 0.05 s or `window`.
TEST_CASE("a checkpoint's obstacle loads are checked, and the force window must stay", "[checkpoint]") {
  dir = "checkpoint_damage_loads";
  const auto floor_case = [](const std::string& window) {
    std::string text = column();
    text.replace(text.find("output: {enabled: false}"), 24, "output: {enabled: false" + window + "}");
    text.replace(text.find("boundaries: {y_min: fixed}"), 26,
                 "boundaries: {y_min: {condition: frictional, friction: 0.4}}");
    return text;
  };
  static const std::string path = [&] {
    std::filesystem::remove_all(dir);
    Simulation<2> run(testing::case_from_yaml(floor_case("")), PETSC_COMM_SELF);
    const RunSummary s = run.run(nullptr);
    REQUIRE(std::filesystem::exists(s.last_checkpoint));
    return s.last_checkpoint;
  }();
  const std::string invalid = "not a valid talus checkpoint: ";
  SECTION("no /obstacles") {
    restart_fails(damaged("no_loads", [](hid_t f) { REQUIRE(H5Ldelete(f, "obstacles", H5P_DEFAULT) >= 0); }, path),
                  invalid + "no group obstacles", floor_case(""));
  }
  SECTION("a NaN running impulse") {
    const std::string damaged_path = damaged("nan_impulse", [](hid_t f) {
      const hid_t d = H5Dopen2(f, "obstacles/impulse_total", H5P_DEFAULT);
      REQUIRE(d >= 0);
      const double values[2] = {std::numeric_limits<double>::quiet_NaN(), 0.0};
      REQUIRE(H5Dwrite(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, values) >= 0);
      H5Dclose(d);
    }, path);
    restart_fails(damaged_path, invalid + "a non-finite value in dataset obstacles/impulse_total", floor_case(""));
  }
  SECTION("another force window: the checkpoint holds only the steps of its own") {
    restart_fails(path, "output.force_window = 0.1 s, but the checkpoint's window averages were over 0.05 s",
                  floor_case(", force_window: 0.1"));
  }
  SECTION("the same window continues, from the stored running impulse") {
    Simulation<2> sim(testing::case_from_yaml(floor_case(", force_window: 0.05")), PETSC_COMM_SELF);
    REQUIRE_NOTHROW(sim.restart(path));
    const double floor_impulse = sim.obstacle_loads().total_impulse()[1];
    CHECK(floor_impulse < 0.0);  // the column pushed the floor down for 4 steps
  }
}
