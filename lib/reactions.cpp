#include "reactions.hpp"

#include "measures.hpp"

namespace ltl {

SupportReactions support_reactions(const Discretization& d, const Eigen::MatrixXd& f_ext,
                                   const State& s, double load_scale) {
  const Problem& pb = d.problem();
  const int dim = pb.mesh.dim, nn = pb.mesh.num_nodes();
  const int nd = static_cast<int>(pb.dirichlet.size());
  const Eigen::MatrixXd r = equilibrium_residual(d, f_ext, s, load_scale);
  SupportReactions out;
  out.force = Eigen::MatrixXd::Zero(nd, dim);
  out.u = Eigen::MatrixXd::Zero(nd, dim);
  // owner(node, c): the first condition that fixes the degree of freedom.
  Eigen::MatrixXi owner = Eigen::MatrixXi::Constant(nn, dim, -1);
  for (int k = 0; k < nd; ++k) {
    const DirichletCondition& dc = pb.dirichlet[k];
    std::string key = dc.origin.empty() ? "dirichlet[" + std::to_string(k) + "]" : dc.origin;
    if (key.size() > 6 && key.compare(key.size() - 6, 6, ".group") == 0) key.resize(key.size() - 6);
    out.labels.push_back(key + ":" + dc.group);
    const std::vector<int> nodes = pb.mesh.boundary_nodes(dc.group, dc.origin);
    for (int a : nodes) {
      out.u.row(k) += s.u.row(a);
      for (int c : dc.components)
        if (owner(a, c) < 0) {
          owner(a, c) = k;
          out.force(k, c) += r(a, c);
        }
    }
    if (!nodes.empty()) out.u.row(k) /= static_cast<double>(nodes.size());
  }
  return out;
}

std::string joined_labels(const SupportReactions& r) {
  std::string s;
  for (const std::string& l : r.labels) s += (s.empty() ? "" : "; ") + l;
  return s;
}

}  // namespace ltl
