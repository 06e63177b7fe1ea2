// Derived fields (derived_fields.hpp): one definition of each, for the results files.
#include "derived_fields.hpp"

#include <Eigen/Sparse>
#include <algorithm>
#include <cmath>

#include "error.hpp"

namespace ltl {

double von_mises(const Eigen::Matrix3d& sigma) {
  const Eigen::Matrix3d s = sigma - (sigma.trace() / 3) * Eigen::Matrix3d::Identity();
  return std::sqrt(1.5 * s.squaredNorm());
}

namespace {
/// The 3x3 Cauchy stress of block k of sigma (plane strain: sigma33(k) out of plane).
Eigen::Matrix3d stress_3x3(const Eigen::MatrixXd& sigma, const Eigen::VectorXd& sigma33, int d,
                           int k) {
  Eigen::Matrix3d S = Eigen::Matrix3d::Zero();
  S.topLeftCorner(d, d) = sigma.block(d * k, 0, d, d).transpose();
  if (d == 2 && sigma33.size()) S(2, 2) = sigma33(k);
  return S;
}
}  // namespace

DerivedFields cell_fields(const Eigen::MatrixXd& F, const Eigen::MatrixXd& sigma,
                          const Eigen::VectorXd& sigma33) {
  const int d = static_cast<int>(F.cols()), n = static_cast<int>(F.rows() / std::max(d, 1));
  DerivedFields out;
  out.detF.resize(n);
  out.stretches.resize(n, 3);
  out.von_mises.resize(n);
  for (int k = 0; k < n; ++k) {
    Eigen::Matrix3d Fc = Eigen::Matrix3d::Identity();
    Fc.topLeftCorner(d, d) = F.block(d * k, 0, d, d).transpose();
    out.detF(k) = Fc.determinant();
    Eigen::Vector3d t = Eigen::JacobiSVD<Eigen::Matrix3d>(Fc).singularValues();
    std::sort(t.data(), t.data() + 3, std::greater<double>());
    out.stretches.row(k) = t.transpose();
    out.von_mises(k) = von_mises(stress_3x3(sigma, sigma33, d, k));
  }
  return out;
}

namespace {
/// nodal_stress_sums of n cells in dimension d, node_of(k, a) the mesh's node of the k-th cell's
/// node a (npc per cell, nn nodes in the mesh).
template <class NodeOf>
Eigen::MatrixXd stress_sums(int d, int n, int npc, int nn, const NodeOf& node_of,
                            const Eigen::VectorXd& cell_volume, const Eigen::MatrixXd& sigma,
                            const Eigen::VectorXd& sigma33, int first_node, int count) {
  if (sigma.rows() != static_cast<Eigen::Index>(d) * n || cell_volume.size() != n)
    throw Error(cat("nodal_stress_sums: ", sigma.rows(), " rows of sigma and ", cell_volume.size(),
                    " volumes for ", n, " cells"));
  if (count < 0) count = nn - first_node;
  if (first_node < 0 || count < 0 || first_node + count > nn)
    throw Error(cat("nodal_stress_sums: nodes ", first_node, " + ", count, " of ", nn));
  Eigen::MatrixXd sums = Eigen::MatrixXd::Zero(count, 10);
  for (int k = 0; k < n; ++k) {
    bool stressed = false;  // sigma_c made for this block: the cell has a node in it
    Eigen::Matrix3d St;
    for (int a = 0; a < npc; ++a) {
      const int node = node_of(k, a) - first_node;
      if (node < 0 || node >= count) continue;
      if (!stressed) St = stress_3x3(sigma, sigma33, d, k).transpose(), stressed = true;
      const double w = cell_volume(k);
      sums.block<1, 9>(node, 0) += w * Eigen::Map<const Eigen::RowVectorXd>(St.data(), 9);
      sums(node, 9) += w;
    }
  }
  return sums;
}
}  // namespace

Eigen::MatrixXd nodal_stress_sums(const Mesh& mesh, const Eigen::VectorXd& cell_volume,
                                  const Eigen::MatrixXd& sigma, const Eigen::VectorXd& sigma33,
                                  const std::vector<int>* cells, int first_node, int count) {
  const int n = cells ? static_cast<int>(cells->size()) : mesh.num_cells();
  return stress_sums(
      mesh.dim, n, mesh.nodes_per_cell(), mesh.num_nodes(),
      [&](int k, int a) { return mesh.cells(cells ? (*cells)[k] : k, a); }, cell_volume, sigma,
      sigma33, first_node, count);
}

Eigen::MatrixXd nodal_stress_sums(const Mesh& part, const std::vector<int>& node, int num_nodes,
                                  const Eigen::VectorXd& cell_volume, const Eigen::MatrixXd& sigma,
                                  const Eigen::VectorXd& sigma33, int first_node, int count) {
  return stress_sums(
      part.dim, part.num_cells(), part.nodes_per_cell(), num_nodes,
      [&](int k, int a) { return node[part.cells(k, a)]; }, cell_volume, sigma, sigma33, first_node,
      count);
}

void nodal_stress(Eigen::MatrixXd&& sums, DerivedFields& out) {
  const Eigen::Index nn = sums.rows();
  out.von_mises_node.resize(nn);
  for (Eigen::Index n = 0; n < nn; ++n) {
    if (sums(n, 9) > 0) sums.block<1, 9>(n, 0) /= sums(n, 9);
    const Eigen::Matrix<double, 1, 9> row = sums.block<1, 9>(n, 0);           // row-major 3x3
    const Eigen::Matrix3d S = Eigen::Map<const Eigen::Matrix3d>(row.data());  // = sigma^T
    out.von_mises_node(n) = von_mises(S.transpose());
  }
  sums.conservativeResize(nn, 9);  // column-major: the last column dropped in place
  out.sigma_node.swap(sums);
}

DerivedFields derived_fields(const Mesh& mesh, const Eigen::VectorXd& cell_volume,
                             const Eigen::MatrixXd& F, const Eigen::MatrixXd& sigma,
                             const Eigen::VectorXd& sigma33) {
  DerivedFields out = cell_fields(F, sigma, sigma33);
  nodal_stress(nodal_stress_sums(mesh, cell_volume, sigma, sigma33), out);
  return out;
}

Eigen::VectorXd face_areas(const Mesh& mesh, const Mesh::Boundary& boundary,
                           const ContactPoints& points) {
  if (boundary.facets.cols() != 6 || points.nodes.empty()) return {};
  Eigen::VectorXd area(boundary.facets.rows());
  for (int f = 0; f < boundary.facets.rows(); ++f) {
    const Eigen::Vector3d x0 = mesh.X.row(boundary.facets(f, 0)).transpose(),
                          x1 = mesh.X.row(boundary.facets(f, 1)).transpose(),
                          x2 = mesh.X.row(boundary.facets(f, 2)).transpose();
    area(f) = 0.5 * (x1 - x0).cross(x2 - x0).norm();
  }
  return area;
}

Eigen::VectorXd consistent_nodal_pressure(const Mesh& mesh, const Mesh::Boundary& boundary,
                                          const ContactPoints& points, const Eigen::VectorXd& p) {
  return consistent_nodal_pressure(mesh, boundary, face_areas(mesh, boundary, points), points, p);
}

Eigen::VectorXd consistent_nodal_pressure(const Mesh& mesh, const Mesh::Boundary& boundary,
                                          const Eigen::VectorXd& area, const ContactPoints& points,
                                          const Eigen::VectorXd& p) {
  if (boundary.facets.cols() != 6 || points.nodes.empty()) return p;
  if (area.size() != boundary.facets.rows())
    throw Error(cat("consistent_nodal_pressure: ", area.size(), " face areas for ",
                    boundary.facets.rows(), " faces of boundary group '", boundary.name, "'"));
  const int np = points.size();
  if (p.size() != np)
    throw Error(cat("consistent_nodal_pressure: ", p.size(), " pressures for ", np, " points"));
  std::vector<int> index(mesh.num_nodes(), -1);
  for (int i = 0; i < np; ++i) index[points.nodes[i]] = i;
  // The P2 triangle mass matrix of an affine face of area A, times 180 / A: vertices 6 on the
  // diagonal, -1 between vertices, -4 between a vertex and the opposite mid-edge node (0 to
  // the adjacent ones), mid-edge nodes 32 on the diagonal, 16 between them. Node order: vertices
  // 0, 1, 2, then mid-edges 01, 12, 20 (the vertex opposite mid-edge 3 + k is (k + 2) mod 3).
  double m[6][6];
  for (int a = 0; a < 6; ++a)
    for (int b = 0; b < 6; ++b) {
      if (a < 3 && b < 3)
        m[a][b] = a == b ? 6 : -1;
      else if (a >= 3 && b >= 3)
        m[a][b] = a == b ? 32 : 16;
      else {
        const int v = a < 3 ? a : b, e = a < 3 ? b : a;
        m[a][b] = (e - 3 + 2) % 3 == v ? -4 : 0;
      }
    }
  std::vector<Eigen::Triplet<double>> t;
  for (int f = 0; f < boundary.facets.rows(); ++f) {
    const double A = area(f);
    for (int a = 0; a < 6; ++a)
      for (int b = 0; b < 6; ++b) {
        const int i = index[boundary.facets(f, a)], j = index[boundary.facets(f, b)];
        if (i < 0 || j < 0)
          throw Error(cat(mesh.source, ": facet ", f, " of boundary group '", boundary.name,
                          "' has a node that is not a contact point"));
        t.emplace_back(i, j, m[a][b] * A / 180);
      }
  }
  Eigen::SparseMatrix<double> M(np, np);
  M.setFromTriplets(t.begin(), t.end());
  const Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(M);
  const Eigen::VectorXd f = points.area.cwiseProduct(p);
  Eigen::VectorXd pc = ldlt.solve(f);
  if (ldlt.info() != Eigen::Success || !pc.allFinite())
    throw Error(cat(mesh.source, ": boundary group '", boundary.name,
                    "': the contact-surface mass matrix is singular"));
  return pc;
}

}  // namespace ltl
