#include "fe.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "error.hpp"

namespace ltl {

namespace {

using Eigen::Vector3d;

struct QPoint {
  double xi, eta, zeta, w;
};

// Six-point degree-4 rule on the reference triangle (area 1/2) [Dunavant 1985].
const std::array<QPoint, 6> kTriangleRule = [] {
  const double a = 0.445948490915965, wa = 0.223381589678011 / 2;
  const double b = 0.091576213509771, wb = 0.109951743655322 / 2;
  return std::array<QPoint, 6>{{{a, a, 0, wa},
                                {1 - 2 * a, a, 0, wa},
                                {a, 1 - 2 * a, 0, wa},
                                {b, b, 0, wb},
                                {1 - 2 * b, b, 0, wb},
                                {b, 1 - 2 * b, 0, wb}}};
}();
// Three-point Gauss rule on [-1, 1].
const std::array<QPoint, 3> kLineRule = {
    {{-std::sqrt(0.6), 0, 0, 5.0 / 9}, {0, 0, 0, 8.0 / 9}, {std::sqrt(0.6), 0, 0, 5.0 / 9}}};
const double kG = 1.0 / std::sqrt(3.0);
const std::array<QPoint, 4> kQuadRule = {
    {{-kG, -kG, 0, 1}, {kG, -kG, 0, 1}, {kG, kG, 0, 1}, {-kG, kG, 0, 1}}};
const std::array<QPoint, 8> kHexRule = {{{-kG, -kG, -kG, 1},
                                         {kG, -kG, -kG, 1},
                                         {kG, kG, -kG, 1},
                                         {-kG, kG, -kG, 1},
                                         {-kG, -kG, kG, 1},
                                         {kG, -kG, kG, 1},
                                         {kG, kG, kG, 1},
                                         {-kG, kG, kG, 1}}};

// Six-point degree-3 rule on the reference tetrahedron (volume 1/6), positive weights, points
// inside [Xiao & Gimbutas 2010, as tabulated by basix]: exact for det of a P2 gradient on an
// affine tetrahedron (cubic; the cell mean of det F of mean-det) and for the Laplacian
// (quadratic). Checked against the monomial integrals a! b! c! / (a + b + c + 3)! in test_tets.
const std::array<QPoint, 6> kTetRule = {
    {{0.64142979149569634, 0.16200149169852451, 0.18385035049209769, 0.020387000459557516},
     {0.34544415571973069, 0.010905212211189241, 0.28152380212354622, 0.021344402118457815},
     {0.43985894764927502, 0.19011700243928389, 0.011403329444557171, 0.022094671190740867},
     {0.037871631782357022, 0.170816925164989, 0.15281814309092731, 0.023437401610067202},
     {0.12480486216524719, 0.15868516322744061, 0.58566280565521578, 0.037402527819592898},
     {0.14148275196950449, 0.57122605214911515, 0.14691839008716959, 0.042000663468250383}}};

// gmsh node orders. P2 triangle: vertices (0,0), (1,0), (0,1), then mid-edges 01, 12, 20.
void p2_triangle(double xi, double eta, Eigen::Matrix<double, 6, 1>& N,
                 Eigen::Matrix<double, 6, 2>& dN) {
  const double L0 = 1 - xi - eta, L1 = xi, L2 = eta;
  N << L0 * (2 * L0 - 1), L1 * (2 * L1 - 1), L2 * (2 * L2 - 1), 4 * L0 * L1, 4 * L1 * L2,
      4 * L2 * L0;
  // d/dxi and d/deta, with dL0 = (-1,-1), dL1 = (1,0), dL2 = (0,1).
  dN << -(4 * L0 - 1), -(4 * L0 - 1), 4 * L1 - 1, 0, 0, 4 * L2 - 1, 4 * (L0 - L1), -4 * L1, 4 * L2,
      4 * L1, -4 * L2, 4 * (L0 - L2);
}
// P2 tetrahedron in VTK order (mesh.hpp): vertices (0,0,0), (1,0,0), (0,1,0), (0,0,1), then
// mid-edges 01, 12, 20, 03, 13, 23.
const int kTetEdge[6][2] = {{0, 1}, {1, 2}, {2, 0}, {0, 3}, {1, 3}, {2, 3}};
void p2_tetrahedron(double xi, double eta, double zeta, Eigen::Matrix<double, 10, 1>& N,
                    Eigen::Matrix<double, 10, 3>& dN) {
  const double L[4] = {1 - xi - eta - zeta, xi, eta, zeta};
  static const double dL[4][3] = {{-1, -1, -1}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  for (int a = 0; a < 4; ++a) {
    N(a) = L[a] * (2 * L[a] - 1);
    for (int k = 0; k < 3; ++k) dN(a, k) = (4 * L[a] - 1) * dL[a][k];
  }
  for (int e = 0; e < 6; ++e) {
    const int i = kTetEdge[e][0], j = kTetEdge[e][1];
    N(4 + e) = 4 * L[i] * L[j];
    for (int k = 0; k < 3; ++k) dN(4 + e, k) = 4 * (dL[i][k] * L[j] + L[i] * dL[j][k]);
  }
}
// H8: corners (+-1, +-1, +-1) in gmsh order.
const int kHexCorner[8][3] = {{-1, -1, -1}, {1, -1, -1}, {1, 1, -1}, {-1, 1, -1},
                              {-1, -1, 1},  {1, -1, 1},  {1, 1, 1},  {-1, 1, 1}};
void h8(double xi, double eta, double zeta, Eigen::Matrix<double, 8, 1>& N,
        Eigen::Matrix<double, 8, 3>& dN) {
  for (int a = 0; a < 8; ++a) {
    const double X = kHexCorner[a][0], Y = kHexCorner[a][1], Z = kHexCorner[a][2];
    const double fx = 1 + X * xi, fy = 1 + Y * eta, fz = 1 + Z * zeta;
    N(a) = fx * fy * fz / 8;
    dN(a, 0) = X * fy * fz / 8;
    dN(a, 1) = Y * fx * fz / 8;
    dN(a, 2) = Z * fx * fy / 8;
  }
}
// P2 edge: ends at -1, +1, then the midpoint.
void p2_line(double xi, Eigen::Matrix<double, 3, 1>& N, Eigen::Matrix<double, 3, 1>& dN) {
  N << xi * (xi - 1) / 2, xi * (xi + 1) / 2, 1 - xi * xi;
  dN << xi - 0.5, xi + 0.5, -2 * xi;
}
void q4(double xi, double eta, Eigen::Matrix<double, 4, 1>& N, Eigen::Matrix<double, 4, 2>& dN) {
  const double X[4] = {-1, 1, 1, -1}, Y[4] = {-1, -1, 1, 1};
  for (int a = 0; a < 4; ++a) {
    N(a) = (1 + X[a] * xi) * (1 + Y[a] * eta) / 4;
    dN(a, 0) = X[a] * (1 + Y[a] * eta) / 4;
    dN(a, 1) = Y[a] * (1 + X[a] * xi) / 4;
  }
}

// Calls visit(N, grad N (physical), weight * |J|) at every quadrature point of cell c.
template <int NPC, int DIM, class Rule, class Shape, class Visit>
void for_each_cell_point(const Mesh& mesh, int c, const Rule& rule, Shape shape, Visit visit) {
  Eigen::Matrix<double, NPC, DIM> Xe;
  for (int a = 0; a < NPC; ++a) Xe.row(a) = mesh.X.row(mesh.cells(c, a));
  Eigen::Matrix<double, NPC, 1> N;
  Eigen::Matrix<double, NPC, DIM> dN;
  for (const auto& p : rule) {
    shape(p, N, dN);
    const Eigen::Matrix<double, DIM, DIM> J = Xe.transpose() * dN;  // dx/dxi
    const double detJ = J.determinant();
    if (!(detJ > 0))
      throw Error(cat(mesh.source, ": cell ", c, " is inverted or degenerate (det J = ", detJ,
                      " at a quadrature point)"));
    const Eigen::Matrix<double, NPC, DIM> grad = dN * J.inverse();
    visit(N, grad, p.w * detJ);
  }
}

template <class Visit>
void for_each_point(const Mesh& mesh, int c, Visit visit) {
  if (mesh.dim == 2)
    for_each_cell_point<6, 2>(
        mesh, c, kTriangleRule,
        [](const QPoint& p, auto& N, auto& dN) { p2_triangle(p.xi, p.eta, N, dN); }, visit);
  else if (mesh.nodes_per_cell() == 10)
    for_each_cell_point<10, 3>(
        mesh, c, kTetRule,
        [](const QPoint& p, auto& N, auto& dN) { p2_tetrahedron(p.xi, p.eta, p.zeta, N, dN); },
        visit);
  else
    for_each_cell_point<8, 3>(
        mesh, c, kHexRule,
        [](const QPoint& p, auto& N, auto& dN) { h8(p.xi, p.eta, p.zeta, N, dN); }, visit);
}

// A curved face of a 3-D cell: visit(N, x, weight * |dx/dxi x dx/deta|) at every point of rule.
template <int NPF, class Rule, class Shape, class Visit>
void surface_points(const Eigen::MatrixXd& Xf, const Rule& rule, Shape shape, Eigen::VectorXd& Nd,
                    Visit visit) {
  Eigen::Matrix<double, NPF, 1> N;
  Eigen::Matrix<double, NPF, 2> dN;
  for (const auto& p : rule) {
    shape(p.xi, p.eta, N, dN);
    const Eigen::Matrix<double, 3, 2> J = Xf.transpose() * dN;
    const Vector3d x = Xf.transpose() * N;
    Nd = N;
    visit(Nd, x, p.w * J.col(0).cross(J.col(1)).norm());
  }
}

// Calls visit(N (dynamic), x (3-vector), weight * |dx/dxi|) at every quadrature point of facet f.
template <class Visit>
void for_each_facet_point(const Mesh& mesh, const Eigen::MatrixXi& facets, int f, Visit visit) {
  const int npf = mesh.nodes_per_facet();
  Eigen::MatrixXd Xf(npf, mesh.dim);
  for (int a = 0; a < npf; ++a) Xf.row(a) = mesh.X.row(facets(f, a));
  Eigen::VectorXd Nd(npf);
  if (mesh.dim == 2) {
    Eigen::Matrix<double, 3, 1> N, dN;
    for (const auto& p : kLineRule) {
      p2_line(p.xi, N, dN);
      const Eigen::Vector2d t = Xf.transpose() * dN;
      Vector3d x = Vector3d::Zero();
      x.head<2>() = Xf.transpose() * N;
      Nd = N;
      visit(Nd, x, p.w * t.norm());
    }
  } else if (npf == 6) {  // P2 triangle face of a P2 tetrahedron, degree-4 rule
    surface_points<6>(Xf, kTriangleRule, p2_triangle, Nd, visit);
  } else {
    surface_points<4>(Xf, kQuadRule, q4, Nd, visit);
  }
}

template <int NPC, int DIM, class Rule, class Shape>
ReferenceRule reference_points(const Rule& rule, Shape shape) {
  ReferenceRule r;
  Eigen::Matrix<double, NPC, 1> N;
  Eigen::Matrix<double, NPC, DIM> dN;
  for (const auto& p : rule) {
    shape(p, N, dN);
    r.dN.push_back(dN);
    r.w.push_back(p.w);
  }
  return r;
}

}  // namespace

ReferenceRule reference_rule(const Mesh& mesh) {
  if (mesh.dim == 2)
    return reference_points<6, 2>(
        kTriangleRule, [](const QPoint& p, auto& N, auto& dN) { p2_triangle(p.xi, p.eta, N, dN); });
  if (mesh.nodes_per_cell() == 10)
    return reference_points<10, 3>(kTetRule, [](const QPoint& p, auto& N, auto& dN) {
      p2_tetrahedron(p.xi, p.eta, p.zeta, N, dN);
    });
  return reference_points<8, 3>(
      kHexRule, [](const QPoint& p, auto& N, auto& dN) { h8(p.xi, p.eta, p.zeta, N, dN); });
}

void for_each_quadrature_point(const Mesh& mesh, int c,
                               const std::function<void(const Eigen::MatrixXd&, double)>& visit) {
  Eigen::MatrixXd grad;
  for_each_point(mesh, c, [&](const auto&, const auto& g, double w) {
    grad = g;
    visit(grad, w);
  });
}

void reference_shape(const Mesh& mesh, const Eigen::Vector3d& xi, Eigen::VectorXd& N,
                     Eigen::MatrixXd& dN) {
  if (mesh.dim == 2) {
    Eigen::Matrix<double, 6, 1> n;
    Eigen::Matrix<double, 6, 2> d;
    p2_triangle(xi(0), xi(1), n, d);
    N = n, dN = d;
  } else if (mesh.nodes_per_cell() == 10) {
    Eigen::Matrix<double, 10, 1> n;
    Eigen::Matrix<double, 10, 3> d;
    p2_tetrahedron(xi(0), xi(1), xi(2), n, d);
    N = n, dN = d;
  } else {
    Eigen::Matrix<double, 8, 1> n;
    Eigen::Matrix<double, 8, 3> d;
    h8(xi(0), xi(1), xi(2), n, d);
    N = n, dN = d;
  }
}

double cell_integrals(const Mesh& mesh, int c, Eigen::MatrixXd& gint, Eigen::MatrixXd& L) {
  const int npc = mesh.nodes_per_cell();
  gint.setZero(npc, mesh.dim);
  L.setZero(npc, npc);
  double vol = 0;
  for_each_point(mesh, c, [&](const auto&, const auto& grad, double w) {
    vol += w;
    gint += w * grad;
    L.noalias() += w * grad * grad.transpose();
  });
  return vol;
}

// Assembled in place, without triplet lists: the Laplacian's pattern (nodes sharing a cell) from
// the node-to-cell incidence, then each cell's block added to it, cell by cell (the order in
// which the triplets were summed before); the mean gradient's rows hold one cell's nodes each.
// On a set of cells (a rank's cells, paper_notes/mpi.md): Gbar has the set's rows only, L sums
// the set's cells only, both on the columns of the set's nodes, vol has the set's volumes only,
// and GbarT_vol is not built (the forces of a rank's cells go run by run through
// add_cell_forces).
CellOperators cell_operators(const Mesh& mesh, const std::vector<int>* held) {
  const int dim = mesh.dim, nc = mesh.num_cells(), npc = mesh.nodes_per_cell();
  const int nn = mesh.num_nodes();
  std::vector<int> all;
  if (!held) {
    all.resize(nc);
    for (int c = 0; c < nc; ++c) all[c] = c;
    held = &all;
  }
  for (std::size_t k = 0; k < held->size(); ++k) {
    const int c = (*held)[k];
    if (c < 0 || c >= nc || (k > 0 && c <= (*held)[k - 1]))
      throw Error(
          cat("cell_operators: cell ", c, " out of the ", nc, " cells, twice or out of order"));
  }
  CellOperators ops;
  ops.cell = *held;
  ops.num_nodes = nn;
  ops.vol.resize(static_cast<Eigen::Index>(held->size()));
  // The columns: every node, or on some cells their nodes, numbered in increasing order (the
  // whole-size map `local` lives through the construction only).
  std::vector<int> local;
  if (static_cast<int>(held->size()) != nc) {
    local.assign(nn, -1);
    for (int c : *held)
      for (int a = 0; a < npc; ++a) local[mesh.cells(c, a)] = 0;
    for (int i = 0; i < nn; ++i)
      if (local[i] == 0) {
        local[i] = static_cast<int>(ops.node.size());
        ops.node.push_back(i);
      }
  }
  const int ncol = local.empty() ? nn : static_cast<int>(ops.node.size());
  auto col = [&](int c, int a) {
    return local.empty() ? mesh.cells(c, a) : local[mesh.cells(c, a)];
  };
  // The cells around each column's node, then the pattern of L column by column (count, then
  // fill).
  std::vector<int> first(static_cast<std::size_t>(ncol) + 1, 0), around;
  for (int c : *held)
    for (int a = 0; a < npc; ++a) ++first[col(c, a) + 1];
  for (int i = 0; i < ncol; ++i) first[i + 1] += first[i];
  around.resize(first[ncol]);
  {
    std::vector<int> next(first.begin(), first.end() - 1);
    for (int c : *held)
      for (int a = 0; a < npc; ++a) around[next[col(c, a)]++] = c;
  }
  std::vector<int> neighbours;
  auto column = [&](int j) {  // the sorted columns sharing a cell with column j
    neighbours.clear();
    for (int k = first[j]; k < first[j + 1]; ++k)
      for (int a = 0; a < npc; ++a) neighbours.push_back(col(around[k], a));
    std::sort(neighbours.begin(), neighbours.end());
    neighbours.erase(std::unique(neighbours.begin(), neighbours.end()), neighbours.end());
  };
  SpMat& L = ops.laplacian;
  L.resize(ncol, ncol);
  L.outerIndexPtr()[0] = 0;
  for (int j = 0; j < ncol; ++j) {
    column(j);
    L.outerIndexPtr()[j + 1] = L.outerIndexPtr()[j] + static_cast<int>(neighbours.size());
  }
  L.resizeNonZeros(L.outerIndexPtr()[ncol]);
  for (int j = 0; j < ncol; ++j) {
    column(j);
    std::copy(neighbours.begin(), neighbours.end(), L.innerIndexPtr() + L.outerIndexPtr()[j]);
  }
  std::fill(L.valuePtr(), L.valuePtr() + L.nonZeros(), 0.0);
  std::vector<int>().swap(around);
  std::vector<int>().swap(first);
  // The integrals of the gradients, rows dim k + j of held cell k, with the cell's nodes in
  // increasing order (the columns' order is the nodes').
  const int nh = static_cast<int>(held->size());
  SpMatR Gint(dim * nh, ncol);
  Gint.resizeNonZeros(static_cast<Eigen::Index>(dim) * nh * npc);
  for (int r = 0; r <= dim * nh; ++r) Gint.outerIndexPtr()[r] = r * npc;
  Eigen::MatrixXd gint(npc, dim), Ke(npc, npc);
  std::vector<int> order(npc);
  for (int at = 0; at < nh; ++at) {
    const int c = (*held)[at];
    ops.vol(at) = cell_integrals(mesh, c, gint, Ke);
    for (int a = 0; a < npc; ++a) order[a] = a;
    std::sort(order.begin(), order.end(),
              [&](int a, int b) { return mesh.cells(c, a) < mesh.cells(c, b); });
    for (int j = 0; j < dim; ++j)
      for (int k = 0; k < npc; ++k) {
        const Eigen::Index i = Gint.outerIndexPtr()[dim * at + j] + k;
        Gint.innerIndexPtr()[i] = col(c, order[k]);
        Gint.valuePtr()[i] = gint(order[k], j);
      }
    for (int a = 0; a < npc; ++a)
      for (int b = 0; b < npc; ++b) L.coeffRef(col(c, a), col(c, b)) += Ke(a, b);
  }
  if (nh == nc) ops.GbarT_vol = Gint.transpose();
  // Gbar = diag(1 / |O_e|) Gint, scaled in place.
  for (int r = 0; r < dim * nh; ++r)
    for (SpMatR::InnerIterator it(Gint, r); it; ++it)
      it.valueRef() = (1.0 / ops.vol(r / dim)) * it.value();
  ops.Gbar.swap(Gint);
  return ops;
}

Eigen::VectorXd cell_volumes(const Mesh& mesh) {
  Eigen::VectorXd vol(mesh.num_cells());
  for (int c = 0; c < mesh.num_cells(); ++c) {
    double v = 0;  // cell_integrals' sum, without its gradients
    for_each_point(mesh, c, [&](const auto&, const auto&, double w) { v += w; });
    vol(c) = v;
  }
  return vol;
}

void add_cell_forces(const CellOperators& ops, int n, int at, Eigen::Ref<Eigen::MatrixXd> T,
                     Eigen::MatrixXd& f, const int* row_of) {
  const int dim = static_cast<int>(T.cols());
  for (int k = 0; k < n; ++k) T.middleRows(dim * k, dim) *= ops.vol(at + k);
  // Gbar^T T node by node: a cell's dim rows of Gbar hold its nodes in the same order
  // (cell_operators), so node a of cell k gets sum_j Gbar(dim k + j, a) T_k(j, :).
  const int* outer = ops.Gbar.outerIndexPtr();
  const int* node = ops.Gbar.innerIndexPtr();
  const double* g = ops.Gbar.valuePtr();
  for (int k = 0; k < n; ++k) {
    const int r0 = dim * (at + k), npc = outer[r0 + 1] - outer[r0];
    for (int a = 0; a < npc; ++a) {
      const int row = row_of ? row_of[node[outer[r0] + a]] : node[outer[r0] + a];
      for (int i = 0; i < dim; ++i) {
        double sum = 0;
        for (int j = 0; j < dim; ++j) sum += g[outer[r0 + j] + a] * T(dim * k + j, i);
        f(row, i) += sum;
      }
    }
  }
}

void mean_gradients(const CellOperators& ops, int at, int n, const Eigen::MatrixXd& u,
                    Eigen::Ref<Eigen::MatrixXd> T, const int* row_of) {
  const int dim = static_cast<int>(u.cols());
  const int* outer = ops.Gbar.outerIndexPtr();
  const int* col = ops.Gbar.innerIndexPtr();
  const double* g = ops.Gbar.valuePtr();
  // u's row of column j: row_of[j], else the column's node (the column itself on every cell)
  const int* u_row = row_of ? row_of : ops.node.empty() ? nullptr : ops.node.data();
  for (int i = 0; i < dim; ++i) {  // column by column: u's and T's columns are contiguous
    const double* ui = u.col(i).data();
    for (int r = 0; r < dim * n; ++r) {
      const int row = dim * at + r;
      double sum = 0;
      for (int k = outer[row]; k < outer[row + 1]; ++k)
        sum += g[k] * ui[u_row ? u_row[col[k]] : col[k]];
      T(r, i) = sum;
    }
  }
}

ContactPoints facet_mean_points(const Mesh& mesh, const Mesh::Boundary& boundary) {
  const int dim = mesh.dim, nf = static_cast<int>(boundary.facets.rows());
  const int npf = mesh.nodes_per_facet();
  ContactPoints ops;
  ops.dim = dim;
  ops.area.resize(nf);
  ops.centre.resize(dim, nf);
  const int ncorner = dim == 2 ? 2 : npf == 6 ? 3 : 4;
  ops.vertices.assign(ncorner, Eigen::MatrixXd(dim, nf));
  std::vector<Eigen::Triplet<double>> m;
  Eigen::VectorXd mint(npf);
  for (int f = 0; f < nf; ++f) {
    double area = 0;
    mint.setZero();
    for_each_facet_point(mesh, boundary.facets, f,
                         [&](const Eigen::VectorXd& N, const Vector3d&, double w) {
                           area += w;
                           mint += w * N;
                         });
    if (!(area > 0))
      throw Error(cat(mesh.source, ": boundary group '", boundary.name, "' facet ", f,
                      " has zero measure"));
    ops.area(f) = area;
    ops.centre.col(f).setZero();
    for (int a = 0; a < npf; ++a) {
      m.emplace_back(f, boundary.facets(f, a), mint(a));
      ops.centre.col(f) += mint(a) / area * mesh.X.row(boundary.facets(f, a)).transpose();
    }
    for (int k = 0; k < ncorner; ++k)
      ops.vertices[k].col(f) = mesh.X.row(boundary.facets(f, k)).transpose();
  }
  SpMatR Mint(nf, mesh.num_nodes());
  Mint.setFromTriplets(m.begin(), m.end());
  ops.meanT_area = Mint.transpose();
  ops.mean = ops.area.cwiseInverse().asDiagonal() * Mint;
  return ops;
}

ContactPoints nodal_points(const Mesh& mesh, const Mesh::Boundary& boundary) {
  const ContactPoints facets = facet_mean_points(mesh, boundary);
  // integral of phi_a over the part = column sums of meanT_area's transpose (sum_s |G_s| mean_sa).
  Eigen::VectorXd weight_all = facets.meanT_area * Eigen::VectorXd::Ones(facets.size());
  if (boundary.facets.cols() == 6) {
    // P2 triangle faces: integral phi_a vanishes at the vertices. The weights are those of the
    // face split into four 3-node triangles at its mid-edge nodes (the integrals of their P1 hat
    // functions): |G|/12 per vertex, |G|/4 per mid-edge node (sum |G|).
    weight_all.setZero(mesh.num_nodes());
    for (int f = 0; f < boundary.facets.rows(); ++f)
      for (int a = 0; a < 6; ++a)
        weight_all(boundary.facets(f, a)) += facets.area(f) * (a < 3 ? 1.0 / 12 : 1.0 / 4);
  }
  std::vector<int> nodes;
  for (int f = 0; f < boundary.facets.rows(); ++f)
    for (int a = 0; a < boundary.facets.cols(); ++a) nodes.push_back(boundary.facets(f, a));
  std::sort(nodes.begin(), nodes.end());
  nodes.erase(std::unique(nodes.begin(), nodes.end()), nodes.end());
  const int np = static_cast<int>(nodes.size());
  ContactPoints ops;
  ops.dim = mesh.dim;
  ops.area.resize(np);
  ops.centre.resize(mesh.dim, np);
  std::vector<Eigen::Triplet<double>> sel;
  for (int i = 0; i < np; ++i) {
    ops.area(i) = weight_all(nodes[i]);
    if (!(ops.area(i) > 0))
      throw Error(cat(mesh.source, ": node ", nodes[i], " of boundary group '", boundary.name,
                      "' has a non-positive nodal weight ", ops.area(i),
                      ": nodal contact needs positive weights (use discretization.contact = "
                      "\"facet-mean\")"));
    ops.centre.col(i) = mesh.X.row(nodes[i]).transpose();
    sel.emplace_back(i, nodes[i], 1.0);
  }
  ops.nodes = nodes;
  ops.mean.resize(np, mesh.num_nodes());
  ops.mean.setFromTriplets(sel.begin(), sel.end());
  ops.meanT_area = SpMatR(ops.mean.transpose()) * ops.area.asDiagonal();
  return ops;
}

Eigen::MatrixXd body_load(const Mesh& mesh, const Eigen::Vector3d& f) {
  const int dim = mesh.dim;
  Eigen::MatrixXd F = Eigen::MatrixXd::Zero(mesh.num_nodes(), dim);
  if (f.head(dim).isZero(0)) return F;
  for (int c = 0; c < mesh.num_cells(); ++c)
    for_each_point(mesh, c, [&](const auto& N, const auto&, double w) {
      for (int a = 0; a < mesh.nodes_per_cell(); ++a)
        F.row(mesh.cells(c, a)) += w * N(a) * f.head(dim).transpose();
    });
  return F;
}

Eigen::MatrixXd surface_load(const Mesh& mesh, const Mesh::Boundary& boundary,
                             const AffineField& g) {
  const int dim = mesh.dim;
  Eigen::MatrixXd F = Eigen::MatrixXd::Zero(mesh.num_nodes(), dim);
  for (int f = 0; f < boundary.facets.rows(); ++f)
    for_each_facet_point(mesh, boundary.facets, f,
                         [&](const Eigen::VectorXd& N, const Vector3d& x, double w) {
                           const Vector3d gx = g(x);
                           for (int a = 0; a < N.size(); ++a)
                             F.row(boundary.facets(f, a)) += w * N(a) * gx.head(dim).transpose();
                         });
  return F;
}

}  // namespace ltl
