#pragma once
// The case file, parsed and validated into typed structs (docs/case_file.md).
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "talus/contact/obstacle.hpp"
#include "talus/materials/material.hpp"
#include "talus/shape/shape_functions.hpp"
#include "talus/solver/strain_increment.hpp"

namespace YAML {
class Node;
}

namespace talus {

// free: no condition; slip: zero normal velocity; fixed: zero velocity;
// frictional: Coulomb contact with the face as a rigid half-plane (the
// face's friction and restitution in CaseConfig::face_contact).
enum class FaceCondition { free, slip, fixed, frictional };
// The case file's names of the faces (x_min, x_max, ...) and of their
// conditions, in FaceCondition order (defined in src/io/config.cpp).
extern const char* const face_names[6];
extern const std::vector<std::string> face_conditions;
enum class TransferScheme { apic, flip };

struct GridConfig {
  std::vector<double> lower, upper;
  double cell_size = 0;
  ShapeKind shape = ShapeKind::quadratic_bspline;
  // Point (classic MPM) or domain-averaged weights (docs/grid.md#particle-quadrature).
  ParticleQuadrature quadrature = ParticleQuadrature::point;
  // A case whose estimated memory exceeds this is an input error (default:
  // this machine's physical memory; docs/case_file.md#grid).
  double memory_limit_gb = 0;
};

// How the momentum balance is advanced (docs/explicit.md): the implicit step
// (one monolithic semismooth Newton solve) or the explicit baseline
// (symplectic Euler, USL, CFL-limited step).
enum class Integrator { implicit, explicit_euler };

struct TimeConfig {
  double end = 0;
  double step = 0;
  Integrator integrator = Integrator::implicit;
  // Explicit only: h = cfl * cell_size / c_p (the fastest P-wave speed of the
  // case's materials) when time.step is left out; a time.step above the
  // stability limit of the shape functions is refused.
  double cfl = 0.5;
  double theta = 1.0;           // Moreau-Jean theta in [1/2, 1]
  // h sym L or the Hencky strain of the step's stretch (strain_increment.hpp).
  StrainIncrement strain_increment = StrainIncrement::linear;
  // Implicit only, `step: auto` (docs/solver.md#choosing-the-step): the
  // nominal step of every step is min(gravity_number sqrt(cell / |g|),
  // courant cell / v_max), v_max the fastest particle or obstacle at the
  // step's start; `step` then holds the first step.
  bool auto_step = false;
  double gravity_number = 0.05;
  double courant = 0.5;
  double min_step_ratio = 1e-3;  // smallest cut-back step / step
  // end / step above this is an input error (an overridable guard against
  // runs that would never end, docs/case_file.md#time).
  static constexpr long default_max_steps = 10000000;
  long max_steps = default_max_steps;
};

// The largest stable explicit step (central differences, lumped mass) for a
// P-wave speed `speed` on cells of size `cell` (docs/explicit.md#the-step):
// 2 / omega_max with omega_max^2 <= dim * s * speed^2 / cell^2, where s is the
// largest eigenvalue of M_lumped^-1 K of the 1D operator in units of
// (speed / cell)^2: 4 for linear hats; for quadratic B-splines 4/3 inside a
// body but up to 2.75 at a free end whose last grid point catches only the
// tail of the particles' weights (computed for 2 particles per cell, and
// matched by the vibrating bar, which diverges at 1.2 cell / speed), so 3.
inline double explicit_stable_step(ShapeKind shape, double cell, double speed, int dim) {
  const double symbol = shape == ShapeKind::linear ? 4.0 : 3.0;
  return 2.0 * cell / (speed * std::sqrt(dim * symbol));
}

// The rule of `time.step: auto` (docs/solver.md#choosing-the-step):
// min(gravity_number sqrt(cell / |g|), courant cell / speed), each term only
// where |g| or speed is positive; infinite when neither is.
inline double automatic_step(const TimeConfig& time, double cell, double gravity, double speed) {
  const double inf = std::numeric_limits<double>::infinity();
  const double by_gravity = gravity > 0 ? time.gravity_number * std::sqrt(cell / gravity) : inf;
  const double by_speed = speed > 0 ? time.courant * cell / speed : inf;
  return std::min(by_gravity, by_speed);
}

struct OutputConfig {
  std::string directory = "output";
  double interval = 0;  // 0: only the first and last states
  bool enabled = true;
  bool grid = false;    // also the grid points of the last step (grid.pvd)
  // The moving window of the averaged obstacle force, s (0: none; the
  // average is then the step's force; docs/output.md#obstacle_forcescsv-the-force-on-each-obstacle).
  double force_window = 0.05;
  // end / interval above this is an input error (docs/case_file.md#output).
  static constexpr long default_max_outputs = 100000;
  long max_outputs = default_max_outputs;
  // How messages name the key: "case.yaml:12: output.directory".
  std::string directory_key = "output.directory";
};

struct CheckpointConfig {
  bool enabled = true;     // a checkpoint at the end of the run and on SIGINT/SIGTERM (default: output.enabled)
  long interval = 0;       // also every `interval` steps (0: none in between)
  std::string directory;   // default: output.directory
  std::string directory_key = "checkpoint.directory";  // as OutputConfig::directory_key
};

struct MaterialConfig {
  std::string name;
  std::shared_ptr<const Material> law;
};

enum class BodyShape { box, polygon, polyhedron, particle_file };

struct BodyConfig {
  std::string name;
  int material = 0;  // index into CaseConfig::materials
  BodyShape shape = BodyShape::box;
  // The region filled with particles: a box, a simple polygon (2D: (x, y);
  // 3D: an (x, z) section extruded over y) or a closed polyhedron (3D), whose
  // bounding box is box_lower/box_upper.
  std::vector<double> box_lower, box_upper;
  std::vector<std::array<double, 2>> polygon;  // vertices in order; empty for a box
  // Polyhedron: its faces split into triangles (fans from each face's first
  // vertex), consistently oriented.
  std::vector<std::array<double, 3>> polyhedron_vertices;
  std::vector<std::array<int, 3>> polyhedron_triangles;
  int particles_per_cell = 2;  // per axis
  std::vector<double> velocity;
  // Initial stress: none, or geostatic (sigma_v = -rho |g| depth below the
  // body's top above the particle, sigma_h = k0 sigma_v; gravity along the
  // last axis). k0 < 0: nu / (1 - nu) from the material's elastic stiffness.
  bool geostatic = false;
  double k0 = -1.0;
  // A rigid body (docs/contact.md#rigid-bodies): its velocity field is
  // constrained to a rigid motion; its material gives only its density.
  bool rigid = false;
  // Particles read from a file (shape particle_file): positions (dim per
  // particle), volumes (m^3, m^2 per unit thickness in 2D), velocities (dim
  // per particle, or empty: `velocity` for all) and each particle's line in
  // the file, for messages.
  std::string particle_file;  // as written in the case file
  std::vector<double> file_positions, file_volumes, file_velocities;
  std::vector<int> file_lines;
};

// Contact detection (docs/contact.md): a grid point is a contact candidate
// when g + gap_prediction * h * min(u_N^n, 0) <= 0 (Moreau-Jean's predicted
// gap, gamma in the seminar).
//
// Bodies in contact (docs/contact.md#bodies-in-contact): every body named in
// a pair of contact.bodies moves with its own velocity field on the grid; the
// bodies named in no pair share field 0 (one continuum, as without pairs).
// Where two fields meet, their relative velocity obeys the Coulomb cone of
// the pair's friction (0 for fields that meet without a listed pair).
struct BodyContactPair {
  int body_a = -1, body_b = -1;  // indices into CaseConfig::bodies
  double friction = 0.0;
};

struct ContactConfig {
  double gap_prediction = 0.5;
  std::vector<BodyContactPair> body_pairs;
  std::vector<int> body_field;  // velocity field of each body; empty: one field for all
  int field_count = 1;
  // Coulomb friction between fields f and g.
  double field_friction(int f, int g) const {
    for (const BodyContactPair& p : body_pairs) {
      const int a = body_field[p.body_a], b = body_field[p.body_b];
      if ((a == f && b == g) || (a == g && b == f)) return p.friction;
    }
    return 0.0;
  }
};

struct FaceContact {
  double friction = 0.0;
  double restitution = 0.0;
};

struct TransferConfig {
  TransferScheme scheme = TransferScheme::apic;
  double flip_blend = 0.99;  // FLIP fraction; 0 is PIC
  // The packing correction's rate (docs/transfers.md#packing); 0: none. On by default since
  // 2026-11-27: with it 2 x 2 particles per cell give the deposit of 4 x 4.
  double packing_correction = 0.25;
};

struct SolverConfig {
  double active_mass_ratio = 1e-12;  // node active if m_i > ratio * max particle mass
  // The largest system (unknowns) whose Newton systems are solved by GMRES on
  // kept (incomplete) LU factors; larger ones by GMRES + GAMG
  // (docs/solver.md#defaults). The kept ILU factors beat GAMG at every size
  // measured, in 2D (51,200 particles of a plastic column: 12 times less CPU;
  // a 1e5-particle elastic block: 2 times) and in 3D (a 16,889-particle
  // landslide: 8 times), so by default there is no limit in practice.
  static constexpr int default_direct_solver_limit = 100000000;
  int direct_solver_limit = default_direct_solver_limit;
  double balance_tolerance = 1e-8;   // Newton stops when sum |F| <= tolerance * impulse scale
  // gamma of the ghost penalty on each step's displacement
  // (docs/solver.md#ghost-penalty); 0: off. Quadratic B-splines only (the
  // default is 0 with linear hats).
  static constexpr double default_ghost_penalty = 0.03;
  double ghost_penalty = default_ghost_penalty;
  std::vector<std::pair<std::string, std::string>> petsc_options;  // without the talus_ prefix
  std::map<std::string, std::string> petsc_option_where;  // key -> "file:line: solver.petsc_options.key"
};

// Balanced ranks (docs/parallel.md): the grid's ownership follows the
// particles at the start, after a restart on another number of ranks, and
// whenever max/mean particles per rank exceeds imbalance_limit.
struct ParallelConfig {
  bool balance = true;
  double imbalance_limit = 1.2;
};

// What a checkpoint's particle state depends on (docs/checkpoints.md#restart-with-a-changed-case):
// per section of the case file (grid, gravity, materials, bodies, boundaries,
// obstacles, contact, transfer), a canonical text of its YAML (maps sorted
// by key, numbers in shortest round-trip form, data files by a hash of their
// contents), "default" where the section is absent.
using CaseFingerprint = std::vector<std::pair<std::string, std::string>>;

// An equilibrium stage before the run (docs/equilibrium.md): gravity loading
// solved quasi-statically in the initial configuration, so that the run
// starts from stresses that carry the bodies' weight.
struct EquilibriumConfig {
  bool enabled = false;
  bool stick = false;    // contact: case (the case's Coulomb contact) | stick (points touching obstacles held)
  int max_steps = 10;
  double tolerance = 1e-6;  // the stage ends when a step changes no stress by more than tolerance x the largest
  double step = 0.0;        // 0: 10 x the largest grid extent / the slowest P-wave speed
};

struct CaseConfig {
  std::string source_file;
  CaseFingerprint fingerprint;
  int dim = 2;
  GridConfig grid;
  TimeConfig time;
  OutputConfig output;
  CheckpointConfig checkpoint;
  std::vector<double> gravity;
  std::vector<MaterialConfig> materials;
  std::vector<BodyConfig> bodies;
  std::array<FaceCondition, 6> faces{FaceCondition::slip, FaceCondition::slip, FaceCondition::slip,
                                     FaceCondition::slip, FaceCondition::slip, FaceCondition::slip};
  std::array<FaceContact, 6> face_contact{};  // for frictional faces
  std::vector<ObstacleConfig> obstacles;
  ContactConfig contact;
  TransferConfig transfer;
  SolverConfig solver;
  ParallelConfig parallel;
  EquilibriumConfig equilibrium;
};

// Reads and validates; throws InputError with file, line, key and value.
CaseConfig load_case(const std::string& file);
CaseConfig parse_case(const std::string& yaml_text, const std::string& name_for_messages);

// What a checkpoint records of the case (docs/checkpoints.md#restart-with-a-changed-case):
// grid, gravity, boundaries, contact, transfer and materials from their parsed
// values, bodies and obstacles as canonical text (src/io/case_fingerprint.cpp).
CaseFingerprint case_fingerprint(const YAML::Node& doc, const CaseConfig& c);

}  // namespace talus
