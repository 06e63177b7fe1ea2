// The global step (4.1), i.e. the linear problem (4.5), with its matrix factorized once.
//
// [LTL87 (4.5)] The bilinear form is
//   a(u, v) = 2 C1 integral grad u : grad v + R q sum_e |O_e| Gbar_e(u) : Gbar_e(v)
//             + R q_c sum_s |G_s| ubar_s . vbar_s
// which is K (x) I_dim: one SCALAR matrix K repeated for each displacement component. It does not
// change during the run, so it is factorized once (CHOLMOD supernodal Cholesky) and every
// iteration of every time step is a triangular solve against the stored factor, with all the
// components that share a Dirichlet set solved in one call (multi-column right-hand side).
// Components with different Dirichlet sets (symmetry planes) get one factor per distinct set.
#pragma once

#include <Eigen/CholmodSupport>
#include <Eigen/Sparse>
#include <memory>
#include <vector>

#include "fe.hpp"

namespace ltl {

/// Per-component Dirichlet data: fixed[i] lists the fixed nodes of component i (sorted, unique);
/// value (#nodes x dim) holds the prescribed values at those nodes.
struct DirichletData {
  std::vector<std::vector<int>> fixed;
  Eigen::MatrixXd value;
};

/// [LTL87 (4.5)] K = 2 C1 L + R q Gbar^T diag(|O|) Gbar + R q_c M^T diag(|G|) M, with L the
/// Laplacian, Gbar the mean gradient, M the facet mean (pass nullptr when there is no contact).
SpMat global_matrix(const CellOperators& cells, const FacetOperators* facets, double C1,
                    double Rq, double Rqc);

class GlobalStep {
 public:
  /// Groups the components by Dirichlet set, and analyzes and factorizes K restricted to each
  /// set's free nodes once. Throws a clear Error if a restricted matrix is not positive
  /// definite (a rigid motion not removed by fixed parts, symmetry planes or contact).
  GlobalStep(const SpMat& K, const DirichletData& bc);

  /// [LTL87 (4.1), (4.5)] Solves K u = b (b: #nodes x dim) with u = value on the fixed nodes.
  /// One multi-column triangular solve per distinct Dirichlet set; the factor is reused.
  void solve(const Eigen::MatrixXd& b, Eigen::MatrixXd& u);

  int num_factors() const { return static_cast<int>(groups_.size()); }
  double analyze_seconds() const { return analyze_seconds_; }
  double factorize_seconds() const { return factorize_seconds_; }
  double factor_nonzeros() const { return factor_nnz_; }  ///< sum over the factors of nnz(L)
  double min_rcond() const { return min_rcond_; }  ///< smallest CHOLMOD condition estimate

  /// Factors whose reciprocal condition estimate is below this are refused as singular.
  static constexpr double kMinRcond = 1e-14;

 private:
  /// Eigen's CHOLMOD wrapper, with access to the factor for the condition estimate.
  struct Factor : Eigen::CholmodSupernodalLLT<SpMat, Eigen::Lower> {
    double rcond() { return cholmod_rcond(m_cholmodFactor, &this->cholmod()); }
  };
  struct Group {
    std::vector<int> components;
    std::vector<int> free_nodes;
    Eigen::MatrixXd shift;  ///< #free x #components: K_fd u_d, constant
    Eigen::MatrixXd rhs, x;  ///< work buffers, #free x #components
    std::unique_ptr<Factor> llt;
  };
  std::vector<Group> groups_;
  const DirichletData bc_;
  double analyze_seconds_ = 0, factorize_seconds_ = 0, factor_nnz_ = 0, min_rcond_ = 1;
};

}  // namespace ltl
