// The checks around gmsh of a geometry file (lib/mesh.cpp), which is a script:
//  - check_geometry_script: commands that reach outside the model are refused in every file read
//    as a script, whatever its extension (System and its variants, files written by Save, Print,
//    CreateDir or Printf > "file"), and a For loop whose literal range has more than
//    kMaxLoopIterations iterations (gmsh would run it for hours);
//  - GeometryTimeLimit: reading and meshing that do not end within LTL_GEOMETRY_TIME_LIMIT
//    seconds (default 1800; a loop whose bound is computed, a mesh far too fine) end the program
//    with a message and exit status 1;
//  - check_mesh_size: before the cells are made, their number estimated from the boundary mesh
//    against the memory this process may still use;
//  - check_coincident_nodes: two nodes at one place (a slit, duplicated points of the .geo).
#pragma once

#include <Eigen/Dense>
#include <string>
#include <vector>

namespace ltl {

/// A For loop with a literal range of more iterations than this is refused.
constexpr double kMaxLoopIterations = 1e7;

/// Whether gmsh reads `path` as a script (every name that is not a mesh or CAD format it knows:
/// .msh, .step, .brep, .stl, ...).
bool read_as_script(const std::string& path);

/// Refuses (Error naming `path`, the line and the command) what a geometry script may not do
/// here: run a command (System, SystemCall, NonBlockingSystemCall), write a file (Save, Print,
/// CreateDir, Printf(...) > "file") or loop more than kMaxLoopIterations times over a literal
/// range. `text` is the file's content (comments and strings are skipped).
void check_geometry_script(const std::string& path, const std::string& text);

/// While it lives, a watchdog: when gmsh has not finished with `path` after the time limit
/// (environment LTL_GEOMETRY_TIME_LIMIT, seconds; default 1800), prints one line naming the file
/// and the limit and ends the process with status 1 (nothing has been written at that point).
class GeometryTimeLimit {
 public:
  explicit GeometryTimeLimit(const std::string& path);
  GeometryTimeLimit(const GeometryTimeLimit&) = delete;
  GeometryTimeLimit& operator=(const GeometryTimeLimit&) = delete;
  ~GeometryTimeLimit();

 private:
  struct Watch;
  Watch* watch_;
};

/// Bytes of memory a run needs per cell, at least: measured peak resident memory of ltl_run,
/// about 16 kB per cell on 2-D meshes, 12-16 kB per cell on H8 and P2-tetrahedron meshes in 3-D
/// (paper_notes/hardening.md); a quarter of it, so that an estimate that is high by up to 4x
/// refuses nothing that would fit.
constexpr double kBytesPerCell = 4000;

/// The memory this process may still allocate, in bytes: the least of its address-space limit
/// (minus what it maps now), the system's available memory and its cgroup's limit.
double available_memory();

/// Whether a geometry script (its file and the files it includes) recombines (the identifier
/// `Recombine` outside comments and strings): its 3-D cells are hexahedra, else tetrahedra.
bool recombines(const std::vector<std::string>& files);

/// With the model read by gmsh and its curves meshed (nothing else yet): estimates the number of
/// cells, and refuses (Error naming `path`, the estimate and the memory) a mesh whose cells need
/// more than available_memory(). 2-D: per surface, its area over the area of an equilateral
/// triangle whose side is the mean length of its boundary edges. 3-D: per volume, its volume
/// (from its boundary curves) over the volume of a cell, h^3 for `hexahedra` (Transfinite and
/// Recombine), h^3 / 4.6 for tetrahedra, h the geometric mean of the mean edge lengths of its
/// curves. Returns the estimate.
double check_mesh_size(const std::string& path, bool hexahedra);

/// Refuses (Error naming both nodes and the place) two nodes closer than 1e-9 times the size of
/// the mesh: a slit, or points of the .geo duplicated instead of shared.
void check_coincident_nodes(const std::string& path, const Eigen::MatrixXd& X);

}  // namespace ltl
