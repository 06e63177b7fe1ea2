// The discrete contact surface Gamma_c: facets (or nodes) with their measure, centre, initial gap
// to the obstacle plane and, for the exact adhesion kernel, their vertices. Built by the solver
// from the mesh (alg2.cpp); read by the local contact step (contact_step.hpp) and the kernel
// quadrature (adhesion_kernel.hpp).
#pragma once

#include <Eigen/Dense>
#include <vector>

namespace ltl {

/// Geometry of the contact surface Gamma_c as seen by the local step.
struct ContactSurface {
  int dim = 2;             ///< 2 (facets are segments) or 3 (facets are planar-ish quads)
  Eigen::VectorXd area;    ///< #points, |G_s| (length in 2-D, area in 3-D)
  Eigen::MatrixXd centre;  ///< dim x #points, reference centre x_s of each facet
  Eigen::VectorXd gap;     ///< #points, initial gap g_s >= 0 to the plane along N
  Eigen::VectorXd N;       ///< dim, unit normal of the obstacle plane, pointing into it
  /// Facet vertices for the exact kernel integral: 2-D: 2 x #points end points stored as
  /// vertices[k] (dim x #points) for k = 0,1; 3-D: the 4 corners, k = 0..3, in cyclic order
  /// (3 corners are accepted for triangular facets). Only read when exact_kernel and d0 > 0.
  std::vector<Eigen::MatrixXd> vertices;
  int size() const { return static_cast<int>(area.size()); }
};

}  // namespace ltl
