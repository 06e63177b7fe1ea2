#include "measures.hpp"

#include <algorithm>
#include <cmath>

#include "error.hpp"

namespace ltl {

ContactMeasures contact_measures(const Problem& pb, const FacetOperators& points, const State& s,
                                 int axis) {
  ContactMeasures m;
  const FacetOperators* pts = &points;
  if (!pb.contact) return m;
  const int dim = pb.mesh.dim;
  const Eigen::VectorXd N = pb.contact->plane_normal.head(dim);
  const Eigen::VectorXd p0 = pb.contact->plane_point.head(dim);
  const Eigen::MatrixXd x = pb.mesh.X + s.u;                // deformed nodes
  const Eigen::MatrixXd xp = pts->mean * x;                 // deformed contact points
  const Eigen::VectorXd p = -(s.lambda_c.transpose() * N);  // nominal contact pressure
  m.points = pts->size();
  m.p_max = p.size() ? p.maxCoeff() : 0.0;
  double M0 = 0, M2 = 0;
  for (int i = 0; i < pts->size(); ++i) {
    m.force += pts->area(i) * p(i);
    if (!(p(i) > kContactThreshold * m.p_max)) continue;
    ++m.in_contact;
    m.area += pts->area(i);
    for (SpMatR::InnerIterator it(pts->mean, i); it; ++it)
      m.a_edge = std::max(m.a_edge, x(it.col(), axis));
    M0 += pts->area(i) * p(i);
    M2 += pts->area(i) * p(i) * xp(i, axis) * xp(i, axis);
  }
  m.a_moment = M0 > 0 ? 2 * std::sqrt(M2 / M0) : 0.0;
  m.penetration = -INFINITY;
  for (int n : pb.mesh.boundary_nodes(pb.contact->group))
    m.penetration = std::max(m.penetration, (x.row(n).transpose() - p0).dot(N));
  return m;
}

int node_at(const Mesh& mesh, const Eigen::VectorXd& X) {
  for (int n = 0; n < mesh.num_nodes(); ++n)
    if ((mesh.X.row(n).transpose() - X).norm() < 1e-9) return n;
  throw Error(cat(mesh.source, ": no mesh node at X = (", X.transpose(), ")"));
}

double load_along_normal(const Solver& solver) {
  const Problem& pb = solver.problem();
  if (!pb.contact) return 0;
  return (solver.external_load() * pb.contact->plane_normal.head(pb.mesh.dim)).sum();
}

Eigen::MatrixXd equilibrium_residual(const Solver& solver, const State& s) {
  const CellOperators& c = solver.cells();
  const double C1 = solver.split().C1;
  const Eigen::MatrixXd GU = c.Gbar * s.u;
  Eigen::MatrixXd r = c.GbarT_vol * solver.piola(s) +
                      2 * C1 * (c.laplacian * s.u - c.GbarT_vol * GU) - solver.external_load();
  if (solver.facets()) r -= solver.facets()->meanT_area * s.lambda_c.transpose();
  if (solver.mean_det()) r -= solver.fluctuation_force(s);
  return r;
}

EquilibriumMeasure equilibrium_measure(const Solver& solver, const State& s) {
  EquilibriumMeasure m;
  Eigen::MatrixXd r = equilibrium_residual(solver, s);
  const auto& fixed = solver.fixed_nodes();
  for (int c = 0; c < solver.dim(); ++c)
    for (int i : fixed[c]) r(i, c) = 0;
  const double load = solver.external_load().cwiseAbs().maxCoeff();
  m.force_residual = r.cwiseAbs().maxCoeff() / (load > 0 ? load : 1.0);
  if (solver.problem().material.incompressible()) {
    // The constraint as discretized: det E_e = 1 (det-mean) or det E_e + c_e(u) = 1 (mean-det).
    const Eigen::VectorXd c = solver.fluctuation_det(s.u);
    for (int e = 0; e < solver.problem().mesh.num_cells(); ++e)
      m.det_error = std::max(m.det_error, std::abs(cell_tensor(s.E, e).determinant() + c(e) - 1));
  }
  if (solver.facets()) m.penetration = std::max(0.0, contact_measures(solver, s).penetration);
  return m;
}

}  // namespace ltl
