// The finite element mesh, generated and read through the gmsh C++ API (no file parser of ours).
//
// 2-D: six-node P2 triangles (gmsh type 9) with three-node P2 boundary edges (type 8); gmsh's
//      3-node triangles (type 2) are made P2.
// 3-D: ten-node P2 tetrahedra (gmsh type 11) with six-node triangle faces (type 9); gmsh's
//      4-node tetrahedra (type 4, its default 3-D mesh) are made P2. Or eight-node trilinear
//      hexahedra H8 (gmsh type 5) with four-node quadrilateral faces (type 3).
// One cell type per mesh; other types and mixed meshes are refused, naming what the file holds.
// Boundary parts are gmsh physical groups of dimension dim-1, referred to by name.
#pragma once

#include <Eigen/Dense>
#include <map>
#include <set>
#include <string>
#include <vector>

namespace ltl {

struct Mesh {
  int dim = 2;
  Eigen::MatrixXd X;  ///< #nodes x dim, reference positions (m)
  /// #cells x nodes_per_cell (6: P2 triangle, 10: P2 tetrahedron, 8: H8), gmsh node order, which
  /// is the VTK/XDMF order, except for the 10-node tetrahedron, stored in VTK/XDMF order: vertices
  /// 0-3, then the mid-edge nodes of edges 01, 12, 20, 03, 13, 23 (gmsh has 32 and 31 last).
  Eigen::MatrixXi cells;

  /// A named boundary part (gmsh physical group of dimension dim-1).
  struct Boundary {
    std::string name;
    /// #points x nodes_per_facet (3: P2 edge, 6: P2 triangle (vertices, then mid-edges 01, 12,
    /// 20), 4: quadrilateral), gmsh node order.
    Eigen::MatrixXi facets;
  };
  std::vector<Boundary> boundaries;
  /// The number of cells of a mesh whose connectivity was released (release_cells), else 0; of
  /// nodes of a mesh whose positions were released (release_X), else 0; and its fingerprint()
  /// at the first release (empty: none).
  int released_cells = 0;
  int released_nodes = 0;
  std::string released_fingerprint;
  std::string source;       ///< the file the mesh came from
  std::string source_hash;  ///< fingerprint of the source file(s) (hash.hpp), for --resume

  int num_nodes() const { return X.rows() > 0 ? static_cast<int>(X.rows()) : released_nodes; }
  int num_cells() const {
    return cells.rows() > 0 ? static_cast<int>(cells.rows()) : released_cells;
  }
  /// A fingerprint of dim, X and the connectivity (hash.hpp): what a results file records to
  /// resume on the same mesh (mesh_hash); that of the whole mesh after release_cells and
  /// release_X too.
  std::string fingerprint() const;
  /// Frees the connectivity `cells`, keeping num_cells(), nodes_per_cell() and fingerprint(): on
  /// a rank of a distributed run, whose discretization holds its own cells' connectivity
  /// numbered locally (Discretization::part(), paper_notes/mpi.md), after the set-up.
  void release_cells();
  /// Frees the reference positions X, keeping num_nodes(), dim and fingerprint(): on a rank of a
  /// distributed run that holds them on its part's nodes and its ghost layer's rows, after the
  /// set-up (paper_notes/mpi.md, "The mesh's positions on the rank's nodes").
  void release_X();
  int nodes_per_cell() const { return static_cast<int>(cells.cols()); }
  int nodes_per_facet() const { return dim == 2 ? 3 : nodes_per_cell() == 10 ? 6 : 4; }
  /// The boundary part called `name`; a clear error naming the file and the parts it has if
  /// there is none. `what` says who asked (e.g. the configuration key).
  const Boundary& boundary(const std::string& name, const std::string& what = "") const;
  bool has_boundary(const std::string& name) const;
  /// Sorted unique node indices of a boundary part.
  std::vector<int> boundary_nodes(const std::string& name, const std::string& what = "") const;
};

/// The cells of each node, compressed: node v's cells are cell[start[v] .. start[v + 1]), in
/// increasing order. With `only` (a flag per node), those of the flagged nodes alone, the others
/// having none (the memory of the flagged nodes' cells only).
struct NodeCells {
  std::vector<int> start, cell;
  /// The cells other than c that share a node with cell c, sorted, each as many times as the
  /// nodes it shares with c (into `out`, whose memory is reused).
  void around(const Mesh& mesh, int c, std::vector<int>& out) const;
};
NodeCells node_cells(const Mesh& mesh, const std::vector<char>* only = nullptr);

/// Generates (from a .geo) or reads (from a .msh) the mesh with gmsh. `parameters` set gmsh
/// ONELAB numbers before the file is read, so that a .geo written with
///   DefineConstant[ nx = {28, Name "Parameters/nx"} ];
/// can be refined from a configuration: {"nx", 56}. Errors name the file: a parameter the .geo
/// does not define or that is not finite, a script that ends the program (`Exit;`, reported and
/// exit status 1 from an atexit guard), a gmsh meshing error, no cells, a cell of zero area or
/// volume, non-finite coordinates.
/// Under mpirun (several ranks, lib/mpi_comm.hpp) it is collective, called by every rank: rank 0
/// alone runs gmsh and sends the mesh, or its error, to the others.
Mesh load_mesh(const std::string& path, const std::map<std::string, double>& parameters = {});
/// How many meshes this process has made with gmsh so far (under mpirun: rank 0's count, 0 on
/// the other ranks).
int meshes_made_with_gmsh();

/// What a geometry file declares: the ONELAB parameters "Parameters/NAME" it defines (in a
/// DefineConstant, in the file or a file it Includes; names without the "Parameters/" prefix),
/// the files read, and a fingerprint of their contents. A .msh file defines no parameter.
struct GeometryScan {
  std::set<std::string> parameters;
  std::vector<std::string> files;
  std::string hash;
};
GeometryScan scan_geometry(const std::string& path);
/// "" if the geometry defines the parameter `name`, else why not: "defines no parameter 'nn'
/// (DefineConstant[... Name "Parameters/nn"]); it defines: n, nd" (gmsh would ignore it silently,
/// and a misspelled name would give another mesh). The one check, for load_mesh and the
/// configuration.
std::string undefined_parameter(const GeometryScan& scan, const std::string& name);

}  // namespace ltl
