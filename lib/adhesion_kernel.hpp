// The dissipation kernel of the adhesion law on the discrete contact surface [LTL87 (1.3), (1.6),
// (6.4)-(6.5)]: k_ss' approximates the integral over G_s' of d(x_s - y) dy for
// d(y) = d0 exp(-d0 |y|), either by the paper's centre-point rule
//
//     k_ss' = d(x_s - x_s') |G_s'|
//
// or by the exact Galerkin integral k_ss' = (1/|G_s|) int_{G_s} int_{G_s'} d(x - y) dy dx; in both
// rules |G_s| k_ss' is symmetric.
//
// Exact rule (paper_notes/section6.md): 2-D collinear segments in closed form; other segment pairs
// and 3-D facets (each quad split into the triangles (v0,v1,v2), (v0,v2,v3)) with the inner
// integral in polar coordinates around x (exact in the radius, Gauss-Legendre in
// tau = asinh(t/h)) and the outer one by adaptive Gauss-Legendre. Relative accuracy ~1e-12 in
// 2-D, < 1e-8 per facet pair in 3-D, 6e-8 on a row sum (measured, tests/test_adhesion_kernel.cpp);
// 3-D costs ~0.2 s CPU per facet pair when d0 h ~ 36 (OpenMP-parallel over pairs). Facet pairs more
// than 60/d0 apart get k = 0 (true value < e^-60 d0 |G|).
#pragma once

#include <Eigen/Dense>
#include <Eigen/Sparse>

#include "contact_points.hpp"

namespace ltl {

/// [LTL87 (1.3), (1.6), (6.4)-(6.5)] The kernel matrix k (#points x #points) of the surface for
/// d(y) = d0 exp(-d0 |y|), d0 > 0: the centre-point rule, or the exact Galerkin integral when
/// `exact` (then surface.vertices is required and checked against surface.area). Throws
/// std::invalid_argument naming the facet on inconsistent vertices.
/// The dense reference: every pair (#points^2 doubles). The solver uses the sparse kernel below.
Eigen::MatrixXd adhesion_kernel(const ContactPoints& surface, double d0, bool exact);

/// The relative tolerance of the sparse kernel's cutoff: the mass dropped from any row is below
/// kKernelCutoffTol times the mass of the kernel over the whole line (2) or plane (2 pi / d0).
constexpr double kKernelCutoffTol = 1e-12;

/// [LTL87 (1.6)] The cutoff radius r_c of the sparse kernel: pairs whose centres are more than
/// r_c apart are dropped. With D the largest facet diameter (2-D: the length; 3-D: twice the
/// largest centre-vertex distance, or 2 sqrt(|G_s|) without vertices) and delta = d0 D,
///   r_c = D + x / d0,   x the root of (1 + x) exp(delta - x) = rel_tol.
/// Why this bounds the dropped mass: a dropped facet G_t lies beyond x / d0 from x_s, and on it
/// d(x_s - x_t) <= e^delta d(x_s - y), so the dropped entries of row s (either rule) sum to at
/// most e^delta times the kernel's mass beyond x / d0, which is (1 + x) e^-x (plane) or e^-x
/// (line) of its whole mass.
double kernel_cutoff(const ContactPoints& surface, double d0, double rel_tol);

/// [LTL87 (1.3), (1.6), (6.4)-(6.5)] The same kernel, sparse: the entries of adhesion_kernel()
/// for the pairs within kernel_cutoff() (bitwise the same values), the others dropped. Pairs
/// are found on a grid of cell size r_c: O(#points x neighbours) time and memory, no
/// #points^2 buffer. Throws like adhesion_kernel().
Eigen::SparseMatrix<double> adhesion_kernel_sparse(const ContactPoints& surface, double d0,
                                                   bool exact, double rel_tol = kKernelCutoffTol);

/// The integrals behind the exact rule, each of d0 exp(-d0 |x - y|) [LTL87 (1.6)].
namespace kernel {

/// Over x in [p, q], y in [r, s] on one line (p < q, r < s), in closed form.
double collinear(double p, double q, double r, double s, double d0);
/// Over y on the segment [q0, q1], for a point x of the plane.
double point_segment(const Eigen::Vector2d& x, const Eigen::Vector2d& q0, const Eigen::Vector2d& q1,
                     double d0);
/// Over x on [p0, p1] and y on [q0, q1] (any two segments of the plane).
double segment_pair(const Eigen::Vector2d& p0, const Eigen::Vector2d& p1, const Eigen::Vector2d& q0,
                    const Eigen::Vector2d& q1, double d0);
/// Over y on the planar polygon v[0..nv-1] (3 or 4 vertices in cyclic order), any point x.
double point_polygon(const Eigen::Vector3d& x, const Eigen::Vector3d* v, int nv, double d0);
/// Over x on facet P and y on facet Q (3 or 4 vertices each, in cyclic order).
double facet_pair(const Eigen::Vector3d* P, int np, const Eigen::Vector3d* Q, int nq, double d0);

}  // namespace kernel

}  // namespace ltl
