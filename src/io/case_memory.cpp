#include "talus/io/case_memory.hpp"

#include <cmath>
#include <iomanip>
#include <sstream>

#include <unistd.h>

#include "talus/io/body_config.hpp"

namespace talus {

namespace {

// An upper bound of the particles the bodies seed: each body's bounding box
// filled at its particle spacing (exact for boxes), or its file's count.
double estimated_particles(const CaseConfig& c) {
  double total = 0;
  for (const BodyConfig& b : c.bodies) {
    if (b.shape == BodyShape::particle_file) {
      total += static_cast<double>(b.file_volumes.size());
      continue;
    }
    const double spacing = c.grid.cell_size / b.particles_per_cell;
    double n = 1;
    for (int a = 0; a < c.dim && a < static_cast<int>(b.box_upper.size()); ++a)
      n *= std::ceil((b.box_upper[a] - b.box_lower[a]) / spacing);
    total += n;
  }
  return total;
}

// Measured peak memory (2026-11-25, one rank): the process itself about
// 60 MB; per grid point 250 B (2D) and 320 B (3D): the ghosted grid arrays
// are dense over the whole box; per particle (2026-11-26, after the
// stencils were sized for domain quadrature: 80,000 particles in 2D, 65,536
// in 3D) 2.1 kB (2D) and 8.6 kB (3D) with point quadrature, 3.0 kB and
// 15.3 kB with domain quadrature: the swarm fields, the stencils, and the
// Jacobian and its incomplete factors (whose rows are the active points
// near the particles; domain quadrature's couple 7^d points, not 5^d).
// With 20 % to spare.
double estimated_memory_gb(int dim, double points, double particles, ParticleQuadrature quadrature) {
  const bool domain = quadrature == ParticleQuadrature::domain;
  const double per_particle = dim == 2 ? (domain ? 3000.0 : 2100.0) : (domain ? 15300.0 : 8600.0);
  const double bytes = 60e6 + 1.2 * (points * (dim == 2 ? 250.0 : 320.0) + particles * per_particle);
  return bytes / 1e9;
}

}  // namespace

// Basis functions (grid points) of the grid: cells + 2 per axis for
// quadratic B-splines, cells + 1 for linear ones.
double grid_points(const CaseConfig& c) {
  double n = 1;
  for (int a = 0; a < c.dim; ++a)
    n *= std::round((c.grid.upper[a] - c.grid.lower[a]) / c.grid.cell_size) +
         (c.grid.shape == ShapeKind::linear ? 1 : 2);
  return n;
}

double physical_memory_gb() {
  const long pages = sysconf(_SC_PHYS_PAGES), size = sysconf(_SC_PAGE_SIZE);
  return pages > 0 && size > 0 ? static_cast<double>(pages) * static_cast<double>(size) / 1e9 : 1e6;
}

void check_case_memory(YamlSection& root, const CaseConfig& c) {
  const double particles = estimated_particles(c);
  const double gb = estimated_memory_gb(c.dim, grid_points(c), particles, c.grid.quadrature);
  if (gb <= c.grid.memory_limit_gb) return;
  YamlSection g = root.section("grid");
  std::ostringstream m;
  m << "the case needs about " << std::setprecision(3) << gb << " GB of memory (" << number_text(grid_points(c))
    << " grid points, about " << number_text(particles) << " particles), more than grid.memory_limit_gb = "
    << c.grid.memory_limit_gb << (g.has("memory_limit_gb") ? "" : " (this machine's memory)")
    << "; use a coarser grid or a smaller box, or raise grid.memory_limit_gb for a machine (all ranks together) "
       "with more";
  g.fail_value("cell_size", m.str());
}

}  // namespace talus
