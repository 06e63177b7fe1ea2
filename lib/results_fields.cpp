// The field table of the results files (results_fields.hpp): look-ups and its texts.
#include "results_fields.hpp"

#include <sstream>

#include "error.hpp"

namespace ltl {

const Field* find_field(std::string_view name) {
  for (const Field& f : kFields)
    if (name == f.name) return &f;
  return nullptr;
}

const Field& field(std::string_view name, const std::string& file) {
  const Field* f = find_field(name);
  if (!f)
    throw Error(cat(file, ": internal: no field ", std::string(name),
                    " in the field table (lib/results_fields.hpp)"));
  return *f;
}

namespace {
// Indexed by the enumerators, in their order.
constexpr const char* kEntities[] = {"", "#nodes", "#cells", "#points", "", "#conditions"};
constexpr const char* kLocationNames[] = {"mesh", "node", "cell", "point", "step", "support"};
constexpr const char* kShapeNames[] = {"scalar", "vector", "tensor", "table", "vector3", "tensor3"};

const char* entities(Location at) {
  return kEntities[static_cast<int>(at)];
}
}  // namespace

std::string shape_text(const Field& f) {
  if (f.shape == Shape::Table) return "";
  // Mesh rows: X and contact_centre per node / point, the others per cell or point.
  const std::string n = f.at != Location::Mesh                 ? entities(f.at)
                        : std::string(f.name) == "X"           ? "#nodes"
                        : std::string(f.name) == "cell_volume" ? "#cells"
                                                               : "#points";
  switch (f.shape) {
    case Shape::Scalar:
      return "(" + n + ")";
    case Shape::Vector:
      return "(" + n + ", dim)";
    case Shape::Vector3:
      return "(" + n + ", 3)";
    case Shape::Tensor3:
      return "(" + n + ", 3, 3)";
    default:
      return "(" + n + ", dim, dim)";
  }
}

std::string unit_text(const Field& f) {
  const std::string u2 = f.unit_2d, u3 = f.unit_3d;
  return u2 == u3 ? u2 : u2 + " (2-D), " + u3;
}

std::string python_field_table() {
  std::ostringstream o;
  o << "# BEGIN FIELDS (from lib/results_fields.hpp; tests/test_results_layers.cpp checks it)\n"
    << "# name: (location, shape, unit in 2-D, unit in 3-D)\n"
    << "FIELDS = {\n";
  for (const Field& f : kFields)
    o << "    \"" << f.name << "\": (\"" << kLocationNames[static_cast<int>(f.at)] << "\", \""
      << kShapeNames[static_cast<int>(f.shape)] << "\", \"" << f.unit_2d << "\", \"" << f.unit_3d
      << "\"),\n";
  o << "}\n# END FIELDS\n";
  return o.str();
}

}  // namespace ltl
