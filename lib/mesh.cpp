#include "mesh.hpp"

#include <gmsh.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <climits>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <unordered_map>

#include "error.hpp"
#include "geometry_guard.hpp"
#include "hash.hpp"
#include "mpi_comm.hpp"

namespace ltl {

namespace {

// gmsh element types used here.
constexpr int kLine3 = 8, kTriangle3 = 2, kTriangle6 = 9, kQuad4 = 3, kTetrahedron4 = 4,
              kTetrahedron10 = 11, kHexahedron8 = 5;

// The element type as a user names it: gmsh's "Quadrilateral 4" -> "4-node quadrilateral".
std::string element_name(int type) {
  std::string name;
  int d, order, nn, np;
  std::vector<double> lc;
  gmsh::model::mesh::getElementProperties(type, name, d, order, nn, lc, np);
  const std::size_t space = name.rfind(' ');
  if (space == std::string::npos) return name;
  std::string kind = name.substr(0, space);
  std::transform(kind.begin(), kind.end(), kind.begin(),
                 [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
  return name.substr(space + 1) + "-node " + kind;
}

// The element types of dimension `dim` in the model, with their counts, as the user made them.
std::vector<std::pair<int, std::size_t>> element_counts(int dim) {
  std::vector<int> types;
  std::vector<std::vector<std::size_t>> tags, node_tags;
  gmsh::model::mesh::getElements(types, tags, node_tags, dim);
  std::vector<std::pair<int, std::size_t>> out;
  for (std::size_t i = 0; i < types.size(); ++i)
    if (!tags[i].empty()) out.emplace_back(types[i], tags[i].size());
  return out;
}

// [paper_notes/section3-4.md] The cells a mesh may have: 2-D triangles (3-node ones are made P2,
// 6-node ones taken), 3-D tetrahedra (4-node ones are made 10-node P2, 10-node ones taken) or
// 8-node hexahedra, one type per mesh. Returns the gmsh type of the cells after elevation, or
// throws naming what the user made.
int check_cell_types(const std::string& path, int dim,
                     const std::vector<std::pair<int, std::size_t>>& made) {
  const char* supported =
      dim == 2 ? "2-D meshes must be triangles (3-node ones are made 6-node P2 here; do not "
                 "Recombine the surfaces)"
               : "3-D meshes must be tetrahedra (gmsh's default; 4-node ones are made 10-node "
                 "P2 here) or 8-node hexahedra (Transfinite + Recombine in the .geo)";
  if (made.empty()) throw Error(cat(path, ": the mesh has no ", dim, "-D cells"));
  if (made.size() > 1) {
    std::string kinds;
    for (const auto& [type, n] : made)
      kinds += cat(kinds.empty() ? "" : " and ", n, " of type '", element_name(type), "'");
    throw Error(cat(path, ": a mixed mesh (", kinds, ") is not supported: ", supported));
  }
  const auto [type, n] = made.front();
  if (dim == 2 && (type == kTriangle3 || type == kTriangle6)) return kTriangle6;
  if (dim == 3 && (type == kTetrahedron4 || type == kTetrahedron10)) return kTetrahedron10;
  if (dim == 3 && type == kHexahedron8) return kHexahedron8;
  throw Error(cat(path, ": found ", n, " cells of type '", element_name(type), "'; ", supported));
}

// gmsh 4.8 reports errors by throwing std::string (later versions throw std::exception); the
// guard turns either into an ltl::Error naming the file, and always finalizes gmsh.
struct GmshSession {
  GmshSession() {
    gmsh::initialize();
    gmsh::option::setNumber("General.Terminal", 0);
    gmsh::option::setNumber("General.Verbosity", 1);
  }
  ~GmshSession() { gmsh::finalize(); }
};

// A .geo is a script: `Exit;` makes gmsh call exit(0) from inside gmsh::open, which would end the
// run with status 0 and no message. While gmsh reads a file, an atexit guard turns that into a
// message and status 1 (nothing else is open at that point: the mesh is read before any output).
std::atomic<bool> g_reading{false};
char g_reading_path[4096];

void exit_guard() {
  if (!g_reading.load()) return;
  std::fprintf(stderr,
               "error: %s: the geometry script ended the program (an `Exit;` statement?) before "
               "a mesh was made\n",
               g_reading_path);
  std::fflush(stderr);
  _exit(1);
}

struct ReadingGuard {
  explicit ReadingGuard(const std::string& path) {
    static const bool registered = (std::atexit(exit_guard), true);
    (void)registered;
    std::snprintf(g_reading_path, sizeof g_reading_path, "%s", path.c_str());
    g_reading = true;
  }
  ~ReadingGuard() { g_reading = false; }
};

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// The text of a .geo without its comments (string literals kept).
std::string strip_comments(const std::string& t) {
  std::string out;
  for (std::size_t i = 0; i < t.size(); ++i) {
    if (t[i] == '"') {
      const std::size_t end = t.find('"', i + 1);
      const std::size_t stop = end == std::string::npos ? t.size() : end + 1;
      out.append(t, i, stop - i);
      i = stop - 1;
    } else if (t.compare(i, 2, "//") == 0) {
      i = std::min(t.find('\n', i), t.size()) - 1;
      out += ' ';
    } else if (t.compare(i, 2, "/*") == 0) {
      const std::size_t end = t.find("*/", i + 2);
      i = end == std::string::npos ? t.size() : end + 1;
      out += ' ';
    } else {
      out += t[i];
    }
  }
  return out;
}

// The string literals that follow `word` (and optional white space) in `code`, `word` starting
// at a word boundary when `boundary`. A linear scan: std::regex recursed once per character of a
// match and overflowed the stack on a long literal (an Include of a 100 000-character name).
std::vector<std::string> quoted_after(const std::string& code, const std::string& word,
                                      bool boundary) {
  const auto is_word = [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_';
  };
  std::vector<std::string> out;
  for (std::size_t at = code.find(word); at != std::string::npos; at = code.find(word, at + 1)) {
    if (boundary && at > 0 && is_word(code[at - 1])) continue;
    std::size_t i = at + word.size();
    while (i < code.size() && std::isspace(static_cast<unsigned char>(code[i]))) ++i;
    if (i >= code.size() || code[i] != '"') continue;
    const std::size_t end = code.find('"', i + 1);
    if (end == std::string::npos) break;
    if (end > i + 1) out.push_back(code.substr(i + 1, end - i - 1));
  }
  return out;
}

// A name for messages: at most 60 characters of it.
std::string shown(const std::string& name) {
  return name.size() <= 60 ? name : cat(name.substr(0, 60), "... (", name.size(), " characters)");
}

void scan(const std::filesystem::path& file, GeometryScan& out, Fingerprint& hash,
          std::vector<std::filesystem::path>& chain) {
  namespace fs = std::filesystem;
  if (chain.size() > 16) throw Error(cat(file.string(), ": Include nested too deeply"));
  const std::string text = read_text(file.string());
  out.files.push_back(file.string());
  hash.add(text);
  if (!read_as_script(file.string())) return;  // a mesh or CAD file, not a script
  check_geometry_script(file.string(), text);  // no commands, no file writes, bounded loops
  const std::string code = strip_comments(text);
  const std::string prefix = "Parameters/";
  for (const std::string& name : quoted_after(code, "Name", false))
    if (name.size() > prefix.size() && name.compare(0, prefix.size(), prefix) == 0)
      out.parameters.insert(name.substr(prefix.size()));
  chain.push_back(file);
  // Included and merged files are read as scripts too (a .geo merged is parsed like one).
  for (const std::string word : {"Include", "Merge"})
    for (const std::string& name : quoted_after(code, word, true)) {
      if (name.size() >= PATH_MAX)
        throw Error(cat(file.string(), ": ", word, " \"", shown(name),
                        "\": the file name is longer than the system allows (", PATH_MAX, ")"));
      const fs::path inc = file.parent_path() / name;
      std::error_code ec;
      const auto st = fs::status(inc, ec);
      if (!fs::exists(st)) continue;  // gmsh says so if the statement is reached
      if (!fs::is_regular_file(st))
        throw Error(cat(file.string(), ": ", word, " \"", shown(name), "\": ", inc.string(),
                        " is not a regular file (a directory, FIFO or device)"));
      for (const fs::path& outer : chain)
        if (fs::equivalent(inc, outer, ec))
          throw Error(cat(file.string(), ": ", word, " \"", shown(name), "\" includes ",
                          outer == chain.front() ? "the geometry file itself"
                                                 : cat(outer.string(), ", which includes it"),
                          " (an ", word == "Include" ? "Include" : "Include or Merge",
                          " cycle: gmsh would read it again and again)"));
      if (std::find(out.files.begin(), out.files.end(), inc.string()) == out.files.end())
        scan(inc, out, hash, chain);
    }
  chain.pop_back();
}

std::size_t gmsh_log_size() {
  std::vector<std::string> log;
  gmsh::logger::get(log);
  return log.size();
}

// The errors gmsh logged (from line `from` of its log on: the log outlives a session).
std::string gmsh_last_error(std::size_t from = 0) {
  std::vector<std::string> log;
  gmsh::logger::get(log);
  std::vector<std::string> errors;  // the first three distinct ones
  for (std::size_t i = from; i < log.size() && errors.size() < 3; ++i)
    if (log[i].find("Error") != std::string::npos &&
        std::find(errors.begin(), errors.end(), log[i]) == errors.end())
      errors.push_back(log[i]);
  std::string out;
  for (const auto& e : errors) out += "\n  gmsh: " + e;
  return out;
}

}  // namespace

GeometryScan scan_geometry(const std::string& path) {
  GeometryScan out;
  Fingerprint hash;
  std::vector<std::filesystem::path> chain;
  scan(path, out, hash, chain);
  out.hash = hash.hex();
  return out;
}

std::string Mesh::fingerprint() const {
  if (!released_fingerprint.empty()) return released_fingerprint;
  Fingerprint f;
  f.add(&dim, sizeof dim);
  f.add(X.data(), sizeof(double) * static_cast<std::size_t>(X.size()));
  f.add(cells.data(), sizeof(int) * static_cast<std::size_t>(cells.size()));
  return f.hex();
}

void Mesh::release_cells() {
  if (cells.rows() == 0) return;
  released_fingerprint = fingerprint();
  released_cells = static_cast<int>(cells.rows());
  Eigen::MatrixXi(0, cells.cols()).swap(cells);
}

void Mesh::release_X() {
  if (X.rows() == 0) return;
  released_fingerprint = fingerprint();
  released_nodes = static_cast<int>(X.rows());
  Eigen::MatrixXd(0, X.cols()).swap(X);
}

const Mesh::Boundary& Mesh::boundary(const std::string& name, const std::string& what) const {
  for (const auto& b : boundaries)
    if (b.name == name) return b;
  std::string names;
  for (const auto& b : boundaries) names += (names.empty() ? "" : ", ") + ("'" + b.name + "'");
  throw Error(cat(source, ": no boundary physical group named '", name, "'",
                  what.empty() ? "" : " (asked for by " + what + ")",
                  "; the mesh has: ", names.empty() ? "none" : names,
                  ". Name boundary parts with Physical Curve(\"name\") (2-D) or ",
                  "Physical Surface(\"name\") (3-D) in the .geo file."));
}

bool Mesh::has_boundary(const std::string& name) const {
  return std::any_of(boundaries.begin(), boundaries.end(),
                     [&](const Boundary& b) { return b.name == name; });
}

std::vector<int> Mesh::boundary_nodes(const std::string& name, const std::string& what) const {
  const auto& f = boundary(name, what).facets;
  std::vector<int> nodes(f.data(), f.data() + f.size());
  std::sort(nodes.begin(), nodes.end());
  nodes.erase(std::unique(nodes.begin(), nodes.end()), nodes.end());
  return nodes;
}

std::string undefined_parameter(const GeometryScan& scan, const std::string& name) {
  if (scan.parameters.count(name)) return "";
  std::string names;
  for (const auto& n : scan.parameters) names += (names.empty() ? "" : ", ") + n;
  return cat("defines no parameter '", name, "' (DefineConstant[... Name \"Parameters/", name,
             "\"]); it defines: ", names.empty() ? "none" : names);
}

namespace {

std::atomic<int> g_meshes_made{0};

// gmsh generates or reads the mesh: load_mesh on one process.
Mesh load_mesh_with_gmsh(const std::string& path, const std::map<std::string, double>& parameters) {
  if (std::filesystem::exists(path) && !std::filesystem::is_directory(path) &&
      !std::filesystem::is_regular_file(path))
    throw Error(
        cat(path, ": is not a regular file (a FIFO, device or socket); refusing to read it"));
  if (std::filesystem::is_directory(path) || !std::ifstream(path).good())
    throw Error(cat(path, ": cannot open the mesh/geometry file"));
  Mesh mesh;
  mesh.source = path;
  // Parameters the file does not define would be ignored silently by gmsh (a misspelled name
  // gives another mesh): refuse them, and non-finite values.
  const GeometryScan declared = scan_geometry(path);
  mesh.source_hash = declared.hash;
  for (const auto& [name, value] : parameters) {
    const std::string undefined = undefined_parameter(declared, name);
    if (!undefined.empty()) throw Error(cat("'", path, "' ", undefined));
    if (!std::isfinite(value))
      throw Error(cat(path, ": parameter '", name, "' = ", value, " is not finite"));
  }
  GmshSession session;
  ++g_meshes_made;
  try {
    gmsh::logger::start();
    gmsh::onelab::clear();  // parameters of an earlier load must not leak into this one
    for (const auto& [name, value] : parameters)
      gmsh::onelab::setNumber("Parameters/" + name, {value});
    GeometryTimeLimit limit(path);  // a script that does not end is stopped with a message
    {
      ReadingGuard guard(path);
      gmsh::open(path);
    }
    const int dim = gmsh::model::getDimension();
    if (dim != 2 && dim != 3)
      throw Error(cat(path, ": the model has dimension ", dim, "; expected 2 or 3"));
    mesh.dim = dim;
    const bool is_geo = path.size() > 4 && path.substr(path.size() - 4) == ".geo";
    // gmsh meshes surfaces in an OpenMP region, where a thrown error cannot be caught (the
    // process aborts): errors are logged instead, and read back from the log.
    const std::size_t before = gmsh_log_size();
    gmsh::option::setNumber("General.AbortOnError", 0);
    if (is_geo) {
      // The curves first (cheap): their edges give the size of the cells, checked against the
      // memory this process may use before the cells are made.
      gmsh::model::mesh::generate(1);
      if (gmsh_last_error(before).empty()) check_mesh_size(path, recombines(declared.files));
      gmsh::model::mesh::generate(dim);
    }
    std::string errors = gmsh_last_error(before);
    if (!errors.empty()) throw Error(cat(path, ": gmsh could not mesh the geometry", errors));
    // The cells the user made (named in messages as such), then made quadratic if linear.
    const int cell_type = check_cell_types(path, dim, element_counts(dim));
    const bool linear = element_counts(dim).front().first != cell_type;
    if (linear) gmsh::model::mesh::setOrder(2);
    gmsh::option::setNumber("General.AbortOnError", 2);
    errors = gmsh_last_error(before);
    if (!errors.empty()) throw Error(cat(path, ": gmsh could not make the mesh quadratic", errors));
    const int facet_type = dim == 2 ? kLine3 : cell_type == kTetrahedron10 ? kTriangle6 : kQuad4;

    // Cells: all elements of dimension dim are of the one supported type (checked above).
    std::vector<int> types;
    std::vector<std::vector<std::size_t>> tags, node_tags;
    gmsh::model::mesh::getElements(types, tags, node_tags, dim);
    std::vector<std::size_t> cell_nodes;
    for (std::size_t i = 0; i < types.size(); ++i) {
      if (types[i] != cell_type)
        throw Error(cat(path, ": after order elevation gmsh gave ", tags[i].size(),
                        " cells of type '", element_name(types[i]), "', expected '",
                        element_name(cell_type), "'"));
      cell_nodes.insert(cell_nodes.end(), node_tags[i].begin(), node_tags[i].end());
    }
    const int npc = cell_type == kTriangle6 ? 6 : cell_type == kTetrahedron10 ? 10 : 8;
    const int ncells = static_cast<int>(cell_nodes.size() / npc);
    if (ncells == 0) throw Error(cat(path, ": the mesh has no ", dim, "-D cells"));

    // Nodes: keep only those used by cells, numbered in order of first use.
    std::vector<std::size_t> all_tags;
    std::vector<double> coords, param;
    gmsh::model::mesh::getNodes(all_tags, coords, param, -1, -1, true, false);
    std::unordered_map<std::size_t, std::size_t> position;  // gmsh tag -> position in coords
    for (std::size_t i = 0; i < all_tags.size(); ++i) position[all_tags[i]] = i;
    std::unordered_map<std::size_t, int> index;  // gmsh tag -> our node index
    std::vector<std::size_t> order;
    for (auto t : cell_nodes)
      if (index.emplace(t, static_cast<int>(order.size())).second) order.push_back(t);
    mesh.X.resize(static_cast<Eigen::Index>(order.size()), dim);
    for (std::size_t i = 0; i < order.size(); ++i)
      for (int k = 0; k < dim; ++k) mesh.X(i, k) = coords[3 * position.at(order[i]) + k];
    if (!mesh.X.allFinite()) throw Error(cat(path, ": the mesh has non-finite node coordinates"));
    check_coincident_nodes(path, mesh.X);  // a slit, duplicated points
    mesh.cells.resize(ncells, npc);
    for (int c = 0; c < ncells; ++c)
      for (int a = 0; a < npc; ++a) mesh.cells(c, a) = index.at(cell_nodes[c * npc + a]);
    // 10-node tetrahedra: gmsh's edge nodes 8 and 9 are on edges 3-2 and 3-1; the VTK/XDMF order
    // used here (and by fe.cpp) has 1-3 then 2-3.
    if (npc == 10) mesh.cells.col(8).swap(mesh.cells.col(9));
    // Every cell must have a non-zero area (volume): a degenerate geometry (e.g. a radius of 0)
    // can give flat cells that make the problem singular.
    for (int c = 0; c < ncells; ++c) {
      const auto x = [&](int a) { return mesh.X.row(mesh.cells(c, a)).transpose().eval(); };
      double measure;
      if (dim == 2) {
        const Eigen::Vector2d a = x(1) - x(0), b = x(2) - x(0);
        measure = std::abs(a(0) * b(1) - a(1) * b(0)) / 2;
      } else if (npc == 10) {
        const Eigen::Vector3d a = x(1) - x(0), b = x(2) - x(0), d = x(3) - x(0);
        measure = std::abs(a.cross(b).dot(d)) / 6;
      } else {
        const Eigen::Vector3d a = x(1) - x(0), b = x(3) - x(0), d = x(4) - x(0);
        measure = std::abs(a.cross(b).dot(d));
      }
      if (!(measure > 0))
        throw Error(cat(path, ": cell ", c, " has zero ", dim == 2 ? "area" : "volume",
                        " (a degenerate geometry: check the parameters)"));
    }

    // Boundary parts: physical groups of dimension dim-1.
    gmsh::vectorpair groups;
    gmsh::model::getPhysicalGroups(groups, dim - 1);
    for (const auto& [gdim, gtag] : groups) {
      Mesh::Boundary b;
      gmsh::model::getPhysicalName(gdim, gtag, b.name);
      if (b.name.empty()) b.name = "group_" + std::to_string(gtag);
      std::vector<int> entities;
      gmsh::model::getEntitiesForPhysicalGroup(gdim, gtag, entities);
      std::vector<std::size_t> fnodes;
      for (int ent : entities) {
        std::vector<int> ftypes;
        std::vector<std::vector<std::size_t>> ftags, fnode_tags;
        gmsh::model::mesh::getElements(ftypes, ftags, fnode_tags, gdim, ent);
        for (std::size_t i = 0; i < ftypes.size(); ++i) {
          if (ftypes[i] != facet_type)
            throw Error(cat(path, ": boundary group '", b.name, "' holds ", ftags[i].size(),
                            " elements of type '", element_name(ftypes[i]), "'; the faces of '",
                            element_name(cell_type), "' cells are '", element_name(facet_type),
                            "'"));
          fnodes.insert(fnodes.end(), fnode_tags[i].begin(), fnode_tags[i].end());
        }
      }
      const int npf = mesh.nodes_per_facet();
      b.facets.resize(static_cast<Eigen::Index>(fnodes.size() / npf), npf);
      for (Eigen::Index f = 0; f < b.facets.rows(); ++f)
        for (int a = 0; a < npf; ++a) {
          auto it = index.find(fnodes[f * npf + a]);
          if (it == index.end())
            throw Error(cat(path, ": boundary group '", b.name, "' facet ", f,
                            " has a node that belongs to no cell"));
          b.facets(f, a) = it->second;
        }
      mesh.boundaries.push_back(std::move(b));
    }
    gmsh::logger::stop();
  } catch (const std::string& message) {
    throw Error(cat(path, ": gmsh: ", message, gmsh_last_error()));
  } catch (const Error&) {
    throw;
  } catch (const std::bad_alloc&) {
    throw;
  } catch (const std::exception& e) {
    throw Error(cat(path, ": gmsh: ", e.what(), gmsh_last_error()));
  } catch (const char* message) {
    throw Error(cat(path, ": gmsh: ", message, gmsh_last_error()));
  }
  return mesh;
}

// Rank 0's matrix (its shape, then its entries) on every rank.
template <class Matrix>
void broadcast_matrix(Matrix& A) {
  int shape[2] = {static_cast<int>(A.rows()), static_cast<int>(A.cols())};
  mpi::broadcast(shape, 2);
  if (mpi::rank() != 0) A.resize(shape[0], shape[1]);
  mpi::broadcast(A.data(), A.size());
}

// Rank 0's mesh on every rank: its arrays, boundary parts, source and fingerprint.
void broadcast_mesh(Mesh& mesh) {
  int head[2] = {mesh.dim, static_cast<int>(mesh.boundaries.size())};
  mpi::broadcast(head, 2);
  mesh.dim = head[0];
  mesh.boundaries.resize(head[1]);
  broadcast_matrix(mesh.X);
  broadcast_matrix(mesh.cells);
  for (Mesh::Boundary& b : mesh.boundaries) {
    b.name = mpi::broadcast(b.name);
    broadcast_matrix(b.facets);
  }
  mesh.source = mpi::broadcast(mesh.source);
  mesh.source_hash = mpi::broadcast(mesh.source_hash);
}

}  // namespace

int meshes_made_with_gmsh() {
  return g_meshes_made.load();
}

// Under mpirun the mesh is made once: gmsh runs on rank 0, and every other rank receives the
// arrays (a few bytes per cell) instead of meshing the geometry itself, which would hold
// gmsh's own model and work arrays, several times the mesh, on every rank. An error on rank 0
// is every rank's error (none waits for a mesh that will not come).
void NodeCells::around(const Mesh& mesh, int c, std::vector<int>& out) const {
  out.clear();
  for (int a = 0; a < mesh.nodes_per_cell(); ++a) {
    const int v = mesh.cells(c, a);
    for (int k = start[v]; k < start[v + 1]; ++k)
      if (cell[k] != c) out.push_back(cell[k]);
  }
  std::sort(out.begin(), out.end());
}

NodeCells node_cells(const Mesh& mesh, const std::vector<char>* only) {
  const int nn = mesh.num_nodes(), nc = mesh.num_cells(), npc = mesh.nodes_per_cell();
  NodeCells m;
  m.start.assign(nn + 1, 0);
  for (int c = 0; c < nc; ++c)
    for (int a = 0; a < npc; ++a)
      if (const int v = mesh.cells(c, a); !only || (*only)[v]) ++m.start[v + 1];
  for (int v = 0; v < nn; ++v) m.start[v + 1] += m.start[v];
  m.cell.resize(m.start[nn]);
  std::vector<int> at(m.start.begin(), m.start.end() - 1);
  for (int c = 0; c < nc; ++c)
    for (int a = 0; a < npc; ++a)
      if (const int v = mesh.cells(c, a); !only || (*only)[v]) m.cell[at[v]++] = c;
  return m;
}

Mesh load_mesh(const std::string& path, const std::map<std::string, double>& parameters) {
  if (mpi::size() == 1) return load_mesh_with_gmsh(path, parameters);
  Mesh mesh;
  std::string error;
  if (mpi::rank() == 0) {
    try {
      mesh = load_mesh_with_gmsh(path, parameters);
    } catch (const Error& e) {
      error = e.what();
    } catch (const std::exception& e) {
      error = cat(path, ": ", e.what());
    }
  }
  error = mpi::broadcast(error);
  if (!error.empty()) throw Error(error);
  broadcast_mesh(mesh);
  return mesh;
}

}  // namespace ltl
