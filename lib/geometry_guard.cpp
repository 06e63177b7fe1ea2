// The checks around gmsh of a geometry file (geometry_guard.hpp).
#include "geometry_guard.hpp"

#include <gmsh.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <mutex>
#include <thread>
#include <unordered_map>

#include "error.hpp"

namespace ltl {

namespace {

/// One identifier of a geometry script outside comments and strings: its name, line and the
/// position just after it.
struct Word {
  std::string name;
  int line;
  std::size_t end;
};

bool word_char(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_';
}

/// The identifiers of `text` in order, skipping // and /* */ comments and "strings".
std::vector<Word> words_of(const std::string& text) {
  std::vector<Word> out;
  int line = 1;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '\n') {
      ++line;
    } else if (text.compare(i, 2, "//") == 0) {
      i = std::min(text.find('\n', i), text.size()) - 1;
    } else if (text.compare(i, 2, "/*") == 0) {
      const std::size_t end = std::min(text.find("*/", i + 2), text.size());
      line += static_cast<int>(std::count(text.begin() + i, text.begin() + end, '\n'));
      i = end + 1;
    } else if (c == '"') {
      std::size_t j = i + 1;
      while (j < text.size() && text[j] != '"') {
        if (text[j] == '\\')
          ++j;
        else if (text[j] == '\n')
          ++line;
        ++j;
      }
      i = j;
    } else if (std::isalpha(static_cast<unsigned char>(c)) || c == '_') {
      std::size_t j = i;
      while (j < text.size() && word_char(text[j])) ++j;
      if (i == 0 || !word_char(text[i - 1])) out.push_back({text.substr(i, j - i), line, j});
      i = j - 1;
    }
  }
  return out;
}

/// The first character at or after `i` that is not white space (0 at the end).
char next_char(const std::string& text, std::size_t& i) {
  while (i < text.size() && std::isspace(static_cast<unsigned char>(text[i]))) ++i;
  return i < text.size() ? text[i] : '\0';
}

/// After "Printf": whether the call `( ... )` is followed by `>` (written to a file).
bool redirected(const std::string& text, std::size_t i) {
  if (next_char(text, i) != '(') return false;
  int depth = 0;
  for (; i < text.size(); ++i) {
    if (text[i] == '"') {
      for (++i; i < text.size() && text[i] != '"'; ++i)
        if (text[i] == '\\') ++i;
    } else if (text[i] == '(') {
      ++depth;
    } else if (text[i] == ')' && --depth == 0) {
      ++i;
      return next_char(text, i) == '>';
    }
  }
  return false;
}

/// The number of iterations of a For loop whose range `{a:b}` or `{a:b:step}` (or in
/// parentheses) starts at `i` with literal numbers; -1 when it is not literal.
double literal_iterations(const std::string& text, std::size_t i) {
  const char open = next_char(text, i);
  if (open != '{' && open != '(') return -1;
  double v[3] = {0, 0, 1};
  int n = 0;
  const char* p = text.c_str() + i + 1;
  for (; n < 3; ++n) {
    char* end = nullptr;
    v[n] = std::strtod(p, &end);
    if (end == p) return -1;
    p = end;
    while (std::isspace(static_cast<unsigned char>(*p))) ++p;
    if (*p == ':') {
      ++p;
      continue;
    }
    if (*p != (open == '{' ? '}' : ')') || n == 0) return -1;
    break;
  }
  if (n == 3 || v[2] == 0) return -1;
  return std::floor((v[1] - v[0]) / v[2]) + 1;
}

double number_from_file(const char* path, const char* key = nullptr) {
  std::ifstream in(path);
  std::string word;
  if (!key) return in >> word && word != "max" ? std::atof(word.c_str()) : -1;
  for (std::string k; in >> k;)
    if (k == key) return in >> word ? std::atof(word.c_str()) * 1024 : -1;
  return -1;
}

}  // namespace

bool read_as_script(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
  for (const char* known : {".msh", ".step", ".stp",  ".brep", ".iges", ".igs",  ".stl",
                            ".vtk", ".unv",  ".med",  ".mesh", ".bdf",  ".nas",  ".inp",
                            ".xao", ".cgns", ".ply2", ".off",  ".wrl",  ".vrml", ".p3d"})
    if (ext == known) return false;
  return true;
}

void check_geometry_script(const std::string& path, const std::string& text) {
  const std::vector<Word> words = words_of(text);
  for (std::size_t k = 0; k < words.size(); ++k) {
    const Word& w = words[k];
    const auto refuse = [&](const std::string& what) {
      throw Error(cat(path, ":", w.line, ": `", w.name, "` ", what,
                      "; a geometry file may only describe the geometry and its mesh (refused "
                      "in every file read as a gmsh script, whatever its extension)"));
    };
    std::size_t after = w.end;
    const char next = next_char(text, after);
    if (w.name == "System" || w.name == "SystemCall" || w.name == "NonBlockingSystemCall")
      refuse("runs a shell command");
    if ((w.name == "Save" || w.name == "Print" || w.name == "CreateDir") && next != '.' &&
        next != '=' && next != '[')
      refuse("writes a file");
    if (w.name == "Printf" && redirected(text, w.end)) refuse("(...) > \"file\" writes a file");
    if (w.name == "For") {
      // For (a:b), For {a:b}, For i In {a:b}, with literal bounds.
      std::size_t at = w.end;
      if (k + 2 < words.size() && words[k + 2].name == "In" && next_char(text, at) != '(' &&
          next_char(text, at) != '{')
        at = words[k + 2].end;
      const double n = literal_iterations(text, at);
      if (n > kMaxLoopIterations)
        throw Error(cat(path, ":", w.line, ": a For loop of ", n, " iterations (more than ",
                        kMaxLoopIterations, "): gmsh would run it for hours; refused"));
    }
  }
}

struct GeometryTimeLimit::Watch {
  std::mutex mutex;
  std::condition_variable done;
  bool finished = false;
  std::thread thread;
};

GeometryTimeLimit::GeometryTimeLimit(const std::string& path) : watch_(new Watch) {
  double limit = 1800;
  if (const char* v = std::getenv("LTL_GEOMETRY_TIME_LIMIT"))
    if (std::atof(v) > 0) limit = std::atof(v);
  Watch* w = watch_;
  w->thread = std::thread([w, limit, path] {
    std::unique_lock<std::mutex> lock(w->mutex);
    if (w->done.wait_for(lock, std::chrono::duration<double>(limit), [w] { return w->finished; }))
      return;
    std::fprintf(stderr,
                 "%s: error: %s: gmsh did not finish reading and meshing the geometry within %g s "
                 "(LTL_GEOMETRY_TIME_LIMIT): a loop that does not end, or a mesh far too fine; "
                 "nothing was written\n",
                 program_invocation_short_name, path.c_str(), limit);
    std::fflush(stderr);
    _exit(1);
  });
}

GeometryTimeLimit::~GeometryTimeLimit() {
  {
    std::lock_guard<std::mutex> lock(watch_->mutex);
    watch_->finished = true;
  }
  watch_->done.notify_one();
  watch_->thread.join();
  delete watch_;
}

double available_memory() {
  double avail = number_from_file("/proc/meminfo", "MemAvailable:");
  const auto least = [&](double x) {
    if (x >= 0 && (avail < 0 || x < avail)) avail = x;
  };
  struct rlimit as {};
  if (::getrlimit(RLIMIT_AS, &as) == 0 && as.rlim_cur != RLIM_INFINITY) {
    const double mapped = number_from_file("/proc/self/status", "VmSize:");
    least(static_cast<double>(as.rlim_cur) - std::max(mapped, 0.0));
  }
  const double cgroup_max = number_from_file("/sys/fs/cgroup/memory.max");
  if (cgroup_max > 0)
    least(cgroup_max - std::max(number_from_file("/sys/fs/cgroup/memory.current"), 0.0));
  return avail < 0 ? 1e300 : std::max(avail, 0.0);
}

namespace {

/// The nodes of the mesh of curve `tag` (meshed) by gmsh tag, and its edges as node-tag pairs in
/// the curve's direction.
struct CurveMesh {
  std::unordered_map<std::size_t, std::array<double, 3>> at;
  std::vector<std::pair<std::size_t, std::size_t>> edges;
};

CurveMesh curve_mesh(int tag) {
  CurveMesh c;
  std::vector<std::size_t> node_tags;
  std::vector<double> xyz, param;
  gmsh::model::mesh::getNodes(node_tags, xyz, param, 1, tag, true, false);
  for (std::size_t i = 0; i < node_tags.size(); ++i)
    c.at[node_tags[i]] = {xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]};
  std::vector<int> types;
  std::vector<std::vector<std::size_t>> tags, nodes;
  gmsh::model::mesh::getElements(types, tags, nodes, 1, tag);
  for (std::size_t t = 0; t < types.size(); ++t) {
    const std::size_t per = nodes[t].size() / std::max<std::size_t>(tags[t].size(), 1);
    for (std::size_t e = 0; e < tags[t].size(); ++e) {
      const std::size_t a = nodes[t][e * per], b = nodes[t][e * per + 1];
      if (c.at.count(a) && c.at.count(b)) c.edges.emplace_back(a, b);
    }
  }
  return c;
}

double distance(const std::array<double, 3>& a, const std::array<double, 3>& b) {
  return std::sqrt((b[0] - a[0]) * (b[0] - a[0]) + (b[1] - a[1]) * (b[1] - a[1]) +
                   (b[2] - a[2]) * (b[2] - a[2]));
}

/// 2-D: per surface, its area (shoelace over its oriented boundary edges) over the area of an
/// equilateral triangle whose side is the mean boundary edge.
double estimated_cells_2d() {
  gmsh::vectorpair surfaces;
  gmsh::model::getEntities(surfaces, 2);
  double cells = 0;
  for (const auto& surface : surfaces) {
    gmsh::vectorpair curves;
    gmsh::model::getBoundary({surface}, curves, false, true, false);
    double twice_area = 0, length = 0;
    std::size_t edges = 0;
    for (const auto& [cdim, tag] : curves) {
      const CurveMesh c = curve_mesh(std::abs(tag));
      for (const auto& [ia, ib] : c.edges) {
        const auto &a = c.at.at(ia), &b = c.at.at(ib);
        const double cross = a[0] * b[1] - b[0] * a[1];
        twice_area += tag > 0 ? cross : -cross;
        length += distance(a, b);
        ++edges;
      }
    }
    if (edges == 0 || !(length > 0)) continue;
    const double h = length / static_cast<double>(edges);
    cells += std::abs(twice_area) / 2 / (std::sqrt(3.0) / 4 * h * h);  // equilateral triangles
  }
  return cells;
}

/// 3-D: per volume, its volume (each boundary surface fanned from the centroid of its boundary
/// nodes: exact for plane faces) over the volume of a cell: h^3 for hexahedra, h^3 / 4.6 for
/// gmsh's tetrahedra (4.6 tetrahedra per h^3, counted on tests/geometry/tet_box.geo for
/// n = 8..24), h the geometric mean over the volume's curves of their mean edge length (for a
/// structured hexahedral mesh of a box, the cube root of a cell's volume, however anisotropic).
double estimated_cells_3d(bool hexahedra) {
  gmsh::vectorpair volumes;
  gmsh::model::getEntities(volumes, 3);
  double cells = 0;
  for (const auto& volume : volumes) {
    gmsh::vectorpair surfaces;
    gmsh::model::getBoundary({volume}, surfaces, false, true, false);
    std::unordered_map<int, CurveMesh> curves;
    double six_volume = 0;
    for (const auto& [sdim, stag] : surfaces) {
      gmsh::vectorpair loop;
      gmsh::model::getBoundary({{2, std::abs(stag)}}, loop, false, true, false);
      std::vector<std::pair<std::array<double, 3>, std::array<double, 3>>> edges;
      std::array<double, 3> centre{0, 0, 0};
      for (const auto& [cdim, ctag] : loop) {
        auto it = curves.find(std::abs(ctag));
        if (it == curves.end())
          it = curves.emplace(std::abs(ctag), curve_mesh(std::abs(ctag))).first;
        const bool forward = (ctag > 0) == (stag > 0);
        for (const auto& [ia, ib] : it->second.edges) {
          const auto &a = it->second.at.at(ia), &b = it->second.at.at(ib);
          edges.emplace_back(forward ? a : b, forward ? b : a);
          for (int d = 0; d < 3; ++d) centre[d] += a[d];
        }
      }
      if (edges.empty()) continue;
      for (int d = 0; d < 3; ++d) centre[d] /= static_cast<double>(edges.size());
      for (const auto& [a, b] : edges)  // c . (a x b)
        six_volume += centre[0] * (a[1] * b[2] - a[2] * b[1]) +
                      centre[1] * (a[2] * b[0] - a[0] * b[2]) +
                      centre[2] * (a[0] * b[1] - a[1] * b[0]);
    }
    double log_h = 0;
    int n = 0;
    for (const auto& [tag, c] : curves) {
      double length = 0;
      for (const auto& [ia, ib] : c.edges) length += distance(c.at.at(ia), c.at.at(ib));
      if (c.edges.empty() || !(length > 0)) continue;
      log_h += std::log(length / static_cast<double>(c.edges.size()));
      ++n;
    }
    if (n == 0) continue;
    const double h = std::exp(log_h / n);
    cells += std::abs(six_volume) / 6 / (h * h * h) * (hexahedra ? 1.0 : 4.6);
  }
  return cells;
}

}  // namespace

bool recombines(const std::vector<std::string>& files) {
  for (const std::string& file : files) {
    std::ifstream in(file, std::ios::binary);
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    for (const Word& w : words_of(text))
      if (w.name == "Recombine") return true;
  }
  return false;
}

double check_mesh_size(const std::string& path, bool hexahedra) {
  const int dim = gmsh::model::getDimension();
  if (dim != 2 && dim != 3) return 0;
  const double cells = dim == 2 ? estimated_cells_2d() : estimated_cells_3d(hexahedra);
  const double need = cells * kBytesPerCell, have = available_memory();
  if (need > have)
    throw Error(
        cat(path, ": out of memory (predicted before meshing): the mesh would have about ",
            static_cast<float>(cells), " cells",
            dim == 2    ? " (estimated from its area and the length of its boundary edges)"
            : hexahedra ? " (hexahedra, estimated from its volume and the lengths of its edges)"
                        : " (tetrahedra, estimated from its volume and the lengths of its edges)",
            ", which need at least ", static_cast<float>(need / 1e9), " GB (", kBytesPerCell,
            " bytes per cell); this process may use ", static_cast<float>(have / 1e9),
            " GB (its address-space limit, the available memory or its cgroup's "
            "limit). Use a coarser mesh (mesh.parameters)"));
  return cells;
}

void check_coincident_nodes(const std::string& path, const Eigen::MatrixXd& X) {
  if (X.rows() < 2) return;
  const Eigen::RowVectorXd lo = X.colwise().minCoeff(), hi = X.colwise().maxCoeff();
  const double size = (hi - lo).norm(), tol = 1e-9 * (size > 0 ? size : 1.0);
  // Nodes binned on a grid of spacing tol: two nodes closer than tol share a bin or are in
  // neighbouring ones; the bins of each node and of its lower neighbours are looked up.
  struct Key {
    long long k[3];
    bool operator==(const Key& o) const {
      return k[0] == o.k[0] && k[1] == o.k[1] && k[2] == o.k[2];
    }
  };
  struct KeyHash {
    std::size_t operator()(const Key& key) const {
      return std::hash<long long>()(key.k[0] * 73856093LL ^ key.k[1] * 19349663LL ^
                                    key.k[2] * 83492791LL);
    }
  };
  std::unordered_map<Key, int, KeyHash> bins;
  bins.reserve(static_cast<std::size_t>(X.rows()));
  const int dim = static_cast<int>(X.cols());
  for (Eigen::Index i = 0; i < X.rows(); ++i) {
    Key key{{0, 0, 0}};
    for (int d = 0; d < dim; ++d) key.k[d] = std::llround((X(i, d) - lo(d)) / tol);
    for (int m = 0; m < (dim == 3 ? 27 : 9); ++m) {
      Key near = key;
      for (int d = 0, mm = m; d < dim; ++d, mm /= 3) near.k[d] += mm % 3 - 1;
      const auto it = bins.find(near);
      if (it == bins.end() || (X.row(it->second) - X.row(i)).norm() > tol) continue;
      std::string at;
      for (int d = 0; d < dim; ++d) at += cat(d ? ", " : "", X(i, d));
      throw Error(cat(path, ": nodes ", it->second, " and ", i,
                      " of the mesh are at the same place (", at,
                      "): a slit, or points or curves of the geometry duplicated instead of "
                      "shared (the body would be cut open there); use the same Point and Curve "
                      "on both sides, or Coherence;"));
    }
    bins.emplace(key, static_cast<int>(i));
  }
}

}  // namespace ltl
