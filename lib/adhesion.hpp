// The glue: Dupre energy, stiffness and dissipation kernel of the adhesion law [LTL87 (1.2),
// (1.3), (1.6), (2.2)]. Problem data (problem.hpp states it, config.cpp reads it); the local
// step (contact_step.hpp) and the kernel quadrature (adhesion_kernel.hpp) use it.
#pragma once

namespace ltl {

/// Glue and dissipation data [LTL87 (1.2), (1.3), (1.6), (2.2)].
struct Adhesion {
  double w = 0.0;      ///< Dupre energy, J/m^2 (>= 0)
  double kappa = 0.0;  ///< 1/eps, Pa/m (>= 0); 0 means no glue
  double d0 = 0.0;     ///< kernel parameter of d(y) = d0 exp(-d0|y|), 1/m (>= 0); 0: no dissipation
  double dt = 1.0;     ///< time step t_p - t_{p-1}, s (> 0)
  bool exact_kernel = false;  ///< false: centre-point rule (the paper's); true: exact integral
  /// Is there glue at all (an adhesion energy or a stiffness)? Without it the contact is pure
  /// frictionless contact: the Newton phase applies and steps are subdivided freely.
  bool glued() const { return kappa > 0 || w > 0; }
};

}  // namespace ltl
