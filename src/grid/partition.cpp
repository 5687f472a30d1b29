#include "talus/grid/partition.hpp"

#include <algorithm>
#include <cstdlib>
#include <functional>
#include <limits>

namespace talus {

RankLoad rank_load(MPI_Comm comm, long local_particles) {
  RankLoad load;
  MPI_Comm_size(comm, &load.ranks);
  MPI_Allreduce(&local_particles, &load.min, 1, MPI_LONG, MPI_MIN, comm);
  MPI_Allreduce(&local_particles, &load.max, 1, MPI_LONG, MPI_MAX, comm);
  MPI_Allreduce(&local_particles, &load.total, 1, MPI_LONG, MPI_SUM, comm);
  return load;
}

namespace {

// Cuts one axis of n points into p columns of at least w points, at the
// points where the cumulative particle count is closest to j/p of the total.
// cum[i] is the number of particles whose owner point is below i (i = 0..n).
// Returns the exclusive end of each column, or nothing if n < p w.
std::vector<int> cut_axis(const std::vector<long>& cum, int n, int p, int w) {
  if (static_cast<long>(p) * w > n) return {};
  std::vector<int> ends;
  int previous = 0;
  const double total = static_cast<double>(cum[n]);
  for (int j = 0; j + 1 < p; ++j) {
    const double target = total * (j + 1) / p;
    const int lo = previous + w, hi = n - (p - 1 - j) * w;
    int best = lo;
    for (int i = lo + 1; i <= hi; ++i)
      if (std::abs(cum[i] - target) < std::abs(cum[best] - target)) best = i;
    ends.push_back(best);
    previous = best;
  }
  ends.push_back(n);
  return ends;
}

}  // namespace

template <int dim>
BalancedPartition<dim> balanced_partition(const Grid<dim>& grid, const double* positions, long local_particles) {
  const MPI_Comm comm = grid.comm();
  int ranks = 1;
  MPI_Comm_size(comm, &ranks);
  const auto& points = grid.points();
  const int w = grid.stencil_width();

  // Owner points of the local particles, and the global marginal counts.
  std::vector<std::array<int, dim>> owner(static_cast<std::size_t>(local_particles));
  std::array<std::vector<long>, dim> cum;
  for (long p = 0; p < local_particles; ++p)
    owner[p] = grid.owner_points(Eigen::Map<const Vector<dim>>(positions + dim * p));
  for (int a = 0; a < dim; ++a) {
    std::vector<long> count(points[a], 0), all(points[a], 0);
    for (const auto& c : owner) ++count[c[a]];
    MPI_Allreduce(count.data(), all.data(), points[a], MPI_LONG, MPI_SUM, comm);
    cum[a].assign(points[a] + 1, 0);
    for (int i = 0; i < points[a]; ++i) cum[a][i + 1] = cum[a][i] + all[i];
  }

  BalancedPartition<dim> best;
  double best_interface = std::numeric_limits<double>::infinity();
  best.load.max = std::numeric_limits<long>::max();
  std::array<int, dim> procs{};
  // Every process grid procs[0] x ... x procs[dim-1] = ranks, in lexicographic order.
  std::function<void(int, int)> visit = [&](int axis, int remaining) {
    if (axis == dim - 1) {
      procs[axis] = remaining;
      std::array<std::vector<int>, dim> ends;
      for (int a = 0; a < dim; ++a) {
        ends[a] = cut_axis(cum[a], points[a], procs[a], w);
        if (ends[a].empty()) return;
      }
      std::vector<long> count(ranks, 0), all(ranks, 0);
      for (const auto& c : owner) ++count[Grid<dim>::rank_of(c, ends)];
      MPI_Allreduce(count.data(), all.data(), ranks, MPI_LONG, MPI_SUM, comm);
      RankLoad load;
      load.ranks = ranks;
      load.min = *std::min_element(all.begin(), all.end());
      load.max = *std::max_element(all.begin(), all.end());
      load.total = cum[0][points[0]];
      double interface = 0;
      for (int a = 0; a < dim; ++a) {
        double cross = procs[a] - 1;
        for (int b = 0; b < dim; ++b)
          if (b != a) cross *= points[b];
        interface += cross;
      }
      if (load.max < best.load.max || (load.max == best.load.max && interface < best_interface)) {
        best.load = load;
        best_interface = interface;
        for (int a = 0; a < dim; ++a) {
          best.ownership[a].clear();
          int start = 0;
          for (int e : ends[a]) {
            best.ownership[a].push_back(e - start);
            start = e;
          }
        }
      }
      return;
    }
    for (int p = 1; p <= remaining; ++p)
      if (remaining % p == 0) {
        procs[axis] = p;
        visit(axis + 1, remaining / p);
      }
  };
  visit(0, ranks);
  if (best.ownership[0].empty()) best.load = rank_load(comm, local_particles);
  return best;
}

template BalancedPartition<2> balanced_partition<2>(const Grid<2>&, const double*, long);
template BalancedPartition<3> balanced_partition<3>(const Grid<3>&, const double*, long);

}  // namespace talus
