#include "reactions.hpp"

#include "measures.hpp"
#include "mpi_comm.hpp"

namespace ltl {

SupportReactions support_reactions(const Discretization& d, const State& s, double load_scale,
                                   const IterateRows* at) {
  const Problem& pb = d.problem();
  const int dim = pb.mesh.dim;
  const int nd = static_cast<int>(pb.dirichlet.size());
  // The residual's rows of this rank's block of the nodes (all of them unless on a rank's
  // cells), whose reactions the rank sums; the sums are added over the ranks.
  const ResidualRows rows = equilibrium_residual_rows(d, nullptr, s, load_scale, at);
  const int n0 = rows.first, nb = static_cast<int>(rows.r.rows());
  SupportReactions out;
  out.force = Eigen::MatrixXd::Zero(nd, dim);
  out.u = Eigen::MatrixXd::Zero(nd, dim);
  // owner(node - n0, c): the first condition that fixes the degree of freedom.
  Eigen::MatrixXi owner = Eigen::MatrixXi::Constant(nb, dim, -1);
  for (int k = 0; k < nd; ++k) {
    const DirichletCondition& dc = pb.dirichlet[k];
    std::string key = dc.origin.empty() ? "dirichlet[" + std::to_string(k) + "]" : dc.origin;
    if (key.size() > 6 && key.compare(key.size() - 6, 6, ".group") == 0) key.resize(key.size() - 6);
    out.labels.push_back(key + ":" + dc.group);
    const std::vector<int> nodes = pb.mesh.boundary_nodes(dc.group, dc.origin);
    const Eigen::MatrixXd u = u_at_nodes(s, nodes, at);  // their rows of u
    for (std::size_t j = 0; j < nodes.size(); ++j) {
      const int a = nodes[j];
      out.u.row(k) += u.row(static_cast<Eigen::Index>(j));
      if (a < n0 || a >= n0 + nb) continue;
      for (int c : dc.components)
        if (owner(a - n0, c) < 0) {
          owner(a - n0, c) = k;
          out.force(k, c) += rows.r(a - n0, c);
        }
    }
    if (!nodes.empty()) out.u.row(k) /= static_cast<double>(nodes.size());
  }
  if (d.partial()) mpi::sum(out.force.data(), out.force.size());
  return out;
}

std::string joined_labels(const SupportReactions& r) {
  std::string s;
  for (const std::string& l : r.labels) s += (s.empty() ? "" : "; ") + l;
  return s;
}

}  // namespace ltl
