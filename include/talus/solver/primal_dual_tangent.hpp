#pragma once
// The primal-dual tangent of Newton's iteration (docs/solver.md#the-primal-dual-tangent).
//
// A return map sigma = P(sigma_tr) is written in the bilinear form of
// Hintermueller & Stadler's primal-dual Newton for Bingham flow,
//   |s_tr| sigma = |s_tr| P(sigma_tr),   s_tr the trial stress's deviator,
// and linearized at the stress T carried from the last Newton iterate
// instead of at the return P(sigma_tr) itself:
//   d sigma = [ dP/d sigma_tr + (P(sigma_tr) - T)_dev (x) s_tr / |s_tr|^2 ] d sigma_tr.
// At T = P(sigma_tr) it is the consistent tangent. Where a Newton step turned
// a plastic particle's trial stress through a kink of the return (a stress
// far outside the cone that rotates), T is that particle's stress continued
// linearly from the last iterate, T = sigma_k + S_k (sigma_tr - sigma_tr,k),
// first returned to the yield surface (Hintermueller & Stadler's projection
// of the dual variable onto its feasible set), and the extra term pulls the
// linear model towards where the stress actually goes.
#include <vector>

#include "talus/core/types.hpp"
#include "talus/materials/material.hpp"

namespace talus {

template <int dim>
class CarriedStresses {
 public:
  // Before an evaluation of the particles' stresses at a new point.
  void begin_evaluation(std::size_t particles);
  // The carried stress of particle p at this trial stress, or false when
  // none was committed (the solve's first iterate: the consistent tangent).
  bool carried(std::size_t p, const Voigt& trial, Voigt& out) const;
  // This evaluation's result for particle p (a candidate until commit()):
  // elastic (the carried stress is then the trial itself, the law being
  // linear there), or the stress, trial and d sigma / d sigma_tr of a return.
  void record_elastic(std::size_t p);
  void record(std::size_t p, const Voigt& stress, const Voigt& trial, const Tangent& sensitivity);
  // The last evaluation was at the iterate Newton accepted: it becomes the
  // one the next evaluations continue (once; a second call is no change).
  void commit();
  // A new solve: nothing carried.
  void reset() { ++generation_; }

 private:
  // The stress components a particle has: in plane strain xx, yy, zz, xy
  // (xz = yz = 0 in every stress, trial and return of a 2D run), all six in 3D.
  static constexpr int n = dim == 2 ? 4 : 6;
  static constexpr int component(int i) { return dim == 2 && i == 3 ? 5 : i; }
  // Per particle: generation, kind (1 elastic, 2 returned), stress, trial,
  // sensitivity (row-major), on those components. Entries of an older
  // generation are empty, so a reset writes nothing, and a commit swaps.
  static constexpr int size = 2 + n + n + n * n;
  std::vector<double> committed_, candidate_;
  double generation_ = 1.0;
  bool fresh_ = false;  // candidate_ holds an evaluation not yet committed
};

// The carried stress differs from the return by more than a fraction of the
// return's deviator (energy norm): below, the primal-dual term would change
// the tangent by less than that fraction, and it is not worth its cost.
bool carried_far_from(const Voigt& carried, const Voigt& stress);

// Adds the primal-dual term to a plastic particle's trial sensitivity and
// tangent d sigma / d strain (= sensitivity D); an elastic one keeps its own.
void add_primal_dual_term(const Material& material, const Voigt& trial, const Voigt& carried,
                          const double* state_old, MaterialPointUpdate& update);

}  // namespace talus
