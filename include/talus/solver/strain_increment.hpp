#pragma once
// The strain increment of one step from the velocity gradient L
// (docs/formulation.md#the-strain-increment).
//
// linear:       de = h sym L, the classical hypoelastic increment; summed
//               over the steps of a stretch it gives sum (r_k - 1) for the
//               step stretches r_k, which tends to ln(lambda) only as h -> 0.
// logarithmic:  de = ln(dU) = (1/2) ln(dF^T dF) with dF = I + h L, the
//               Hencky strain of the step's own stretch dU (dF = dR dU). For
//               a stretch whose axes do not turn it sums to ln(lambda)
//               exactly, so a Kirchhoff stress from a constant C under the
//               Jaumann rate is the Hencky hyperelastic one (tau = C ln V)
//               at any step size (Simo & Hughes 1998, Ch. 7; Eterovic & Bathe
//               1990). A step that turns the particle inside out
//               (det dF <= 0, which C = dF^T dF cannot tell from a
//               compression) has no strain: NaN, so that Newton backs off
//               instead of converging to an inverted state.
#include <Eigen/Dense>

#include "talus/core/types.hpp"

namespace talus {

enum class StrainIncrement { linear, logarithmic };

struct StrainIncrementResult {
  Voigt strain;  // Voigt, engineering shear
  // d strain / d L (Voigt component, row-major index k * 3 + l of L), for
  // the components of L in the first `dim` rows and columns.
  Eigen::Matrix<double, 6, 9> derivative;
};

// L: the velocity gradient (3 x 3; zero rows and columns beyond dim in 2D).
// The derivative is computed for the components k, l < derivative_dim only,
// the others left zero; with derivative_dim 0 it is not computed at all.
StrainIncrementResult strain_increment(const Eigen::Matrix3d& L, double h, StrainIncrement kind,
                                       int derivative_dim = 3);

}  // namespace talus
