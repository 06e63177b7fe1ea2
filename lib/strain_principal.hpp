// The local strain step (4.6) for Ogden and Gent (material.hpp): the reduced problem of section
// 5 in the principal stretches (strain_principal.cpp, paper_notes/materials.md).
#pragma once

#include <Eigen/Dense>

#include "material.hpp"

namespace ltl {

/// [LTL87 (4.6), (5.4)-(5.5)] For a principal-stretch law m (m.principal()) and the sorted
/// signed singular values d of the local loading D (plane strain: d = (d_1, d_2, 0)), the
/// stretches t (sorted decreasingly, t_1 t_2 t_3 = 1; plane strain t_3 = 1) minimizing
///   sum_i ((Rq/2 - C1) t_i^2 - d_i t_i) + W(t).
/// Returns false when no start converged.
bool minimize_principal(const Material& m, double Rq, const Eigen::Vector3d& d, bool plane,
                        Eigen::Vector3d& t);

}  // namespace ltl
