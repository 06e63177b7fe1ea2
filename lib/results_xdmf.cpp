// The XDMF files beside a results file (results_xdmf.hpp).
#include "results_xdmf.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <sstream>
#include <type_traits>
#include <vector>

#include "error.hpp"
#include "results_info.hpp"
#include "results_layout.hpp"

namespace ltl {

using namespace h5;

namespace {

std::string xml_escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

/// The comment that opens every XDMF file this code writes for the results file `path`: how
/// is_xdmf_of() recognizes its own files.
std::string xdmf_marker(const std::string& path) {
  return "<!-- Written by ltl::ResultsFile: the time steps of " +
         xml_escape(std::filesystem::path(path).filename().string());
}

}  // namespace

std::string xdmf_path_of(const std::string& path, const std::string& suffix) {
  const std::string ext = ".h5";
  if (path.size() > ext.size() && path.compare(path.size() - ext.size(), ext.size(), ext) == 0)
    return path.substr(0, path.size() - ext.size()) + suffix + ".xdmf";
  return path + suffix + ".xdmf";
}

std::string contact_xdmf_path_of(const std::string& path) {
  return xdmf_path_of(path, "_contact");
}

bool is_xdmf_of(const std::string& xdmf, const std::string& path) {
  const int fd = ::open(xdmf.c_str(), O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) return false;
  struct stat st {};
  std::string head(512, '\0');
  ssize_t n = -1;
  if (::fstat(fd, &st) == 0 && S_ISREG(st.st_mode)) n = ::read(fd, head.data(), head.size());
  ::close(fd);
  if (n <= 0) return false;
  head.resize(static_cast<std::size_t>(n));
  const std::string first = "<?xml version=\"1.0\"?>\n" + xdmf_marker(path) + " for ParaView";
  return head.compare(0, first.size(), first) == 0;
}

// XDMF: the body (xdmf_path_of) and, with a contact surface, the contact surface
// (contact_xdmf_path_of), both referring to the datasets of the HDF5 file by its file name (the
// files are meant to stay side by side). One uniform grid per step in a temporal collection; a
// file with one step is that step's uniform grid alone (no collection, no Time element), which
// meshio.read() reads as well as ParaView; a file with no step is the bare mesh.
std::string xdmf_text(std::int64_t file_id, const std::string& file, bool contact) {
  static_assert(std::is_same_v<hid_t, std::int64_t>);
  const hid_t file_ = file_id;
  const std::string h5 = xml_escape(std::filesystem::path(file).filename().string());
  const layout::Sizes n = layout::sizes_of(file_, file);
  const int dim = n.dim, nn = n.nodes, nc = n.cells, n_points = n.points;
  const auto npc = dataset_shape(file_, "/mesh/cells", file).at(1);
  const bool nodal = exists(file_, "/mesh/contact_nodes", file);
  // The grid: cells of the body, or facets of the contact surface.
  std::string topo, cells_ds, geometry_ds, centre;
  hsize_t elements = nc, per = npc, points = nn;
  if (!contact) {
    topo = layout::cell_topology(dim, static_cast<int>(npc));
    cells_ds = "/mesh/cells";
    geometry_ds = "/mesh/X";
  } else {
    const auto F = dataset_shape(file_, "/mesh/contact_facets", file);
    elements = F.at(0), per = F.at(1);
    topo = dim == 2 && per == 3   ? "Edge_3"
           : dim == 2 && per == 2 ? "Polyline"
           : dim == 3 && per == 4 ? "Quadrilateral"
           : dim == 3 && per == 6 ? "Triangle_6"
           : dim == 3 && per == 3 ? "Triangle"
                                  : "";
    if (topo.empty()) fail(file, cat("no XDMF topology for ", per, "-node contact facets"));
    cells_ds = nodal ? "/mesh/contact_topology" : "/mesh/contact_facets";
    geometry_ds = nodal ? "/mesh/contact_centre" : "/mesh/X";
    points = nodal ? n_points : nn;
    if (!exists(file_, geometry_ds, file) || !exists(file_, cells_ds, file)) return "";
  }
  const char* at = contact && !nodal ? "Cell" : "Node";  // where the contact fields live

  std::ostringstream o;
  auto item = [&](const std::string& indent, const std::string& dims, bool integer,
                  const std::string& dataset) {
    o << indent << "<DataItem Dimensions=\"" << dims << "\" NumberType=\""
      << (integer ? "Int" : "Float") << "\" Precision=\"" << (integer ? 4 : 8)
      << "\" Format=\"HDF\">" << h5 << ":" << dataset << "</DataItem>\n";
  };
  auto attribute = [&](const std::string& name, const char* type, const char* centre,
                       const std::string& dims, const std::string& dataset) {
    o << "        <Attribute Name=\"" << name << "\" AttributeType=\"" << type << "\" Center=\""
      << centre << "\">\n";
    item("          ", dims, false, dataset);
    o << "        </Attribute>\n";
  };
  auto grid = [&](const std::string& name, const std::string* time) {
    o << "      <Grid Name=\"" << name << "\" GridType=\"Uniform\">\n";
    if (time) o << "        <Time Value=\"" << *time << "\"/>\n";
    o << "        <Topology TopologyType=\"" << topo << "\" NumberOfElements=\"" << elements
      << "\">\n";
    item("          ", cat(elements, ' ', per), true, cells_ds);
    o << "        </Topology>\n"
      << "        <Geometry GeometryType=\"" << (dim == 2 ? "XY" : "XYZ") << "\">\n";
    item("          ", cat(points, ' ', dim), false, geometry_ds);
    o << "        </Geometry>\n";
  };
  const std::vector<std::string> names = layout::step_names(file_, file);
  o << "<?xml version=\"1.0\"?>\n"
    << xdmf_marker(file) << " for ParaView" << (contact ? ", on the contact surface" : "")
    << " (layout: experiments/README.md). -->\n"
    << "<Xdmf Version=\"3.0\">\n  <Domain>\n";
  const bool series = names.size() > 1;
  if (series)
    o << "    <Grid Name=\"" << (contact ? "contact" : "steps")
      << "\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  if (names.empty()) {
    grid(contact ? "contact_surface" : "mesh", nullptr);
    o << "      </Grid>\n";
  }
  for (const std::string& name : names) {
    const std::string g = "/steps/" + name;
    double t = 0;
    {
      Handle group = open_group(file_, g, file);
      t = read_scalar_attr<double>(group.get(), "t", file, g);
    }
    const std::string time = shortest_number(t);
    grid("step_" + name, series ? &time : nullptr);
    const std::string v = dim == 2 ? g + "/xdmf" : g;  // 3-vectors and 3x3 tensors
    const auto has = [&](const std::string& ds) { return exists(file_, ds, file); };
    // The fields of the table shown by ParaView: on the body's nodes and cells, or on the contact
    // points (at the contact grid's nodes, or its cells for facet contact points).
    for (const Field& row : kFields) {
      if (row.xdmf == Pad33::None || row.source == Source::Other) continue;
      const bool on_body = row.at == Location::Node || row.at == Location::Cell;
      if (on_body == contact || (!on_body && row.at != Location::Point)) continue;
      const std::string ds = (shown_as_stored(row) ? g : v) + "/" + row.name;
      if (!has(ds)) continue;
      const int count = n.count(row.at);
      const char* where = row.at == Location::Node   ? "Node"
                          : row.at == Location::Cell ? "Cell"
                                                     : at;
      if (row.shape == Shape::Scalar)
        attribute(row.name, "Scalar", where, cat(count), ds);
      else if (row.shape == Shape::Vector || row.shape == Shape::Vector3)
        attribute(row.name, "Vector", where, cat(count, " 3"), ds);
      else
        attribute(row.name, "Tensor", where, cat(count, " 3 3"), ds);
      // The deformation gradient also under its name F (the dataset keeps the code's name E).
      if (std::string(row.name) == "E") attribute("F", "Tensor", where, cat(count, " 3 3"), ds);
    }
    // Several obstacles: the obstacle of each contact point (0, 1, ...), to split the fields.
    if (contact && has("/mesh/contact_obstacle")) {
      o << "        <Attribute Name=\"obstacle\" AttributeType=\"Scalar\" Center=\"" << at
        << "\">\n";
      item("          ", cat(n_points), true, "/mesh/contact_obstacle");
      o << "        </Attribute>\n";
    }
    o << "      </Grid>\n";
  }
  if (series) o << "    </Grid>\n";
  o << "  </Domain>\n</Xdmf>\n";
  return o.str();
}

}  // namespace ltl
