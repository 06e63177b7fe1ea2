#include "config.hpp"

#include <toml++/toml.h>

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "error.hpp"

namespace ltl {

namespace {

// unit -> (factor to SI, canonical SI unit)
const std::map<std::string, std::pair<double, std::string>>& unit_table() {
  static const std::map<std::string, std::pair<double, std::string>> t = {
      {"Pa", {1, "Pa"}},           {"kPa", {1e3, "Pa"}},
      {"MPa", {1e6, "Pa"}},        {"GPa", {1e9, "Pa"}},
      {"N/m^2", {1, "Pa"}},        {"kN/m^2", {1e3, "Pa"}},
      {"Pa/m", {1, "Pa/m"}},       {"kPa/m", {1e3, "Pa/m"}},
      {"MPa/m", {1e6, "Pa/m"}},    {"GPa/m", {1e9, "Pa/m"}},
      {"N/m^3", {1, "Pa/m"}},      {"kN/m^3", {1e3, "Pa/m"}},
      {"MN/m^3", {1e6, "Pa/m"}},   {"m", {1, "m"}},
      {"cm", {1e-2, "m"}},         {"mm", {1e-3, "m"}},
      {"J/m^2", {1, "J/m^2"}},     {"N/m", {1, "J/m^2"}},
      {"mJ/m^2", {1e-3, "J/m^2"}}, {"1/m", {1, "1/m"}},
      {"/m", {1, "1/m"}},          {"s", {1, "s"}},
      {"min", {60, "s"}},          {"h", {3600, "s"}},
  };
  return t;
}

std::string where(const toml::source_region& r) {
  std::ostringstream s;
  if (r.path) s << *r.path;
  if (r.begin.line > 0)
    s << ":" << r.begin.line;
  else
    s << ": (--set)";  // a value given on the command line has no line
  return s.str();
}

// Reads one table, checking that it has no key beyond `allowed`.
/// The --set arguments by their dotted key ("load.traction[0].value" -> the whole argument).
using Overrides = std::map<std::string, std::string>;

/// The --set argument that gave `key` or a table/array containing it, or null.
const std::string* override_of(const Overrides& o, const std::string& key) {
  for (auto it = o.rbegin(); it != o.rend(); ++it) {
    const std::string& k = it->first;
    if (key.compare(0, k.size(), k) == 0 &&
        (key.size() == k.size() || key[k.size()] == '.' || key[k.size()] == '['))
      return &it->second;
  }
  return nullptr;
}

class Reader {
 public:
  Reader(const toml::table& t, std::string prefix, std::string file, const Overrides* overrides)
      : t_(t), prefix_(std::move(prefix)), file_(std::move(file)), overrides_(overrides) {}

  std::string key(const std::string& k) const { return prefix_.empty() ? k : prefix_ + "." + k; }

  [[noreturn]] void fail(const std::string& k, const std::string& msg,
                         const toml::node* n = nullptr) const {
    if (const std::string* o = overrides_ ? override_of(*overrides_, key(k)) : nullptr)
      throw Error(cat(file_, ": --set '", *o, "': key '", key(k), "': ", msg));
    const toml::node* node = n ? n : t_.get(k);
    std::string loc = node ? where(node->source()) : where(t_.source());
    if (loc.empty() || loc[0] == ':') loc = file_ + loc;
    throw Error(cat(loc, ": key '", key(k), "': ", msg));
  }

  void only(const std::set<std::string>& allowed) const {
    for (const auto& [k, v] : t_)
      if (!allowed.count(std::string(k.str()))) {
        std::string list;
        for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
        fail(std::string(k.str()), cat("unknown key; allowed here: ", list), &v);
      }
  }

  /// Every real value: finite, not subnormal (its reciprocal would overflow), |x| <= kMaxReal (so
  /// that products of two values stay finite).
  double real(const std::string& k, double v, const toml::node* n) const {
    if (!std::isfinite(v)) fail(k, cat("= ", v, ": must be a finite number"), n);
    if (v != 0 && std::abs(v) < DBL_MIN)
      fail(k, cat("= ", v, ": subnormal (|x| < ", DBL_MIN, "); use 0 or a normal number"), n);
    if (std::abs(v) > kMaxReal) fail(k, cat("= ", v, ": out of range (|x| <= ", kMaxReal, ")"), n);
    return v;
  }
  static constexpr double kMaxReal = 1e100;

  bool has(const std::string& k) const { return t_.contains(k); }
  const toml::node* node(const std::string& k) const { return t_.get(k); }

  double quantity_of(const toml::node& n, const std::string& k, const std::string& si) const {
    if (auto v = n.value<double>()) return real(k, *v, &n);
    if (auto s = n.value<std::string>()) {
      double v = 0;
      try {
        v = parse_quantity(*s, si, key(k));
      } catch (const Error& e) {
        fail(k, e.what(), &n);
      }
      return real(k, v, &n);
    }
    fail(k, cat("expected a number or a string \"<number> <unit>\" in ", si), &n);
  }

  double quantity(const std::string& k, const std::string& si) const {
    const toml::node* n = t_.get(k);
    if (!n) fail(k, cat("missing value (", si, ")"));
    return quantity_of(*n, k, si);
  }
  double quantity(const std::string& k, const std::string& si, double fallback) const {
    return has(k) ? quantity(k, si) : fallback;
  }

  Eigen::Vector3d vector(const std::string& k, const std::string& si, int dim) const {
    const toml::node* n = t_.get(k);
    if (!n) fail(k, "missing value");
    const toml::array* a = n->as_array();
    if (!a || static_cast<int>(a->size()) != dim)
      fail(k, cat("expected an array of ", dim, " components (", si, ")"), n);
    Eigen::Vector3d v = Eigen::Vector3d::Zero();
    for (int i = 0; i < dim; ++i) v(i) = quantity_of(*a->get(i), k, si);
    return v;
  }

  Eigen::Matrix3d matrix(const std::string& k, const std::string& si, int dim) const {
    const toml::node* n = t_.get(k);
    const toml::array* a = n ? n->as_array() : nullptr;
    if (!a || static_cast<int>(a->size()) != dim)
      fail(k, cat("expected ", dim, " rows of ", dim, " components (", si, ")"), n);
    Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
    for (int i = 0; i < dim; ++i) {
      const toml::array* row = a->get(i)->as_array();
      if (!row || static_cast<int>(row->size()) != dim)
        fail(k, cat("row ", i + 1, ": expected ", dim, " components"), a->get(i));
      for (int j = 0; j < dim; ++j) m(i, j) = quantity_of(*row->get(j), k, si);
    }
    return m;
  }

  std::string string(const std::string& k) const {
    const toml::node* n = t_.get(k);
    if (!n) fail(k, "missing value");
    auto s = n->value<std::string>();
    if (!s) fail(k, "expected a string", n);
    return *s;
  }
  std::string string(const std::string& k, const std::string& fallback) const {
    return has(k) ? string(k) : fallback;
  }
  /// One of the named options (the default when absent); otherwise an error listing them:
  /// expected "a", "b" or "c".
  template <class T>
  T choice(const std::string& k, const std::vector<std::pair<std::string, T>>& options,
           const std::string& fallback) const {
    const std::string v = string(k, fallback);
    std::string expected = "expected ";
    for (size_t i = 0; i < options.size(); ++i) {
      if (options[i].first == v) return options[i].second;
      expected += cat(i == 0                    ? ""
                      : i + 1 == options.size() ? " or "
                                                : ", ",
                      "\"", options[i].first, "\"");
    }
    fail(k, expected);
  }
  /// An integer in [lo, hi] (checked before narrowing: 2^32 + 1 is not 1).
  int integer(const std::string& k, int fallback, int lo, int hi) const {
    const toml::node* n = t_.get(k);
    if (!n) return fallback;
    if (!n->is_integer()) fail(k, "expected an integer", n);
    const int64_t v = *n->value<int64_t>();
    if (v < lo || v > hi) fail(k, cat("= ", v, ": must be in ", lo, "..", hi), n);
    return static_cast<int>(v);
  }
  double number(const std::string& k, double fallback) const {
    const toml::node* n = t_.get(k);
    if (!n) return fallback;
    auto v = n->value<double>();
    if (!v) fail(k, "expected a number", n);
    return real(k, *v, n);
  }

  bool boolean(const std::string& k, bool fallback) const {
    const toml::node* n = t_.get(k);
    if (!n) return fallback;
    if (!n->is_boolean()) fail(k, "expected true or false", n);
    return *n->value<bool>();
  }

  Reader sub(const std::string& k) const {
    const toml::node* n = t_.get(k);
    if (!n || !n->is_table()) fail(k, "expected a table", n);
    return Reader(*n->as_table(), key(k), file_, overrides_);
  }
  std::vector<Reader> subs(const std::string& k) const {  // array of tables
    std::vector<Reader> out;
    const toml::node* n = t_.get(k);
    if (!n) return out;
    const toml::array* a = n->as_array();
    if (!a || !a->is_array_of_tables())
      fail(k, cat("expected an array of tables: [[", key(k), "]]"), n);
    for (std::size_t i = 0; i < a->size(); ++i)
      out.emplace_back(*a->get(i)->as_table(), cat(key(k), "[", i, "]"), file_, overrides_);
    return out;
  }
  const toml::table& table() const { return t_; }

 private:
  const toml::table& t_;
  std::string prefix_, file_;
  const Overrides* overrides_;
};

int component_index(const Reader& r, const std::string& k, int dim) {
  const std::string c = r.string(k);
  const std::string names = "xyz";
  if (c.size() == 1 && names.find(c[0]) != std::string::npos &&
      static_cast<int>(names.find(c[0])) < dim)
    return static_cast<int>(names.find(c[0]));
  r.fail(k, cat("expected one of ", dim == 2 ? "\"x\", \"y\"" : "\"x\", \"y\", \"z\""));
}

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// The deepest nesting of keys this code accepts: table headers, dotted keys and inline tables
/// together (its configurations use at most 5). toml++ builds, prints and destroys tables
/// recursively: a header `[a.a.a...]` of 50 000 parts overflowed the stack (exit 139).
constexpr int kMaxKeyDepth = 64;

/// Refuses TOML text whose keys nest deeper than kMaxKeyDepth, naming the line, before toml++
/// parses it. A linear scan that knows TOML's strings and comments: the depth of a key is that of
/// its table (header parts, + 1 for an array of tables), + its dotted parts, + the inline tables
/// and arrays around it. (Values alone are bounded by toml++: 256 nested arrays or inline tables.)
void check_key_depth(const std::string& text, const std::string& where) {
  struct Open {
    char bracket;
    int cur, container;
  };
  std::vector<Open> open;
  int line = 1, base = 0, container = 0, cur = 0, dots = 0;
  bool key = true;  // reading a key (else a value)
  const auto check = [&](int depth) {
    if (depth > kMaxKeyDepth)
      throw Error(cat(where, ":", line, ": keys nested deeper than ", kMaxKeyDepth,
                      " levels (table headers, dotted keys, arrays and inline tables together); "
                      "refusing to parse it"));
  };
  // Skips the string starting at i (a key or a value); returns the index of its last character.
  const auto skip_string = [&](std::size_t i) {
    const char q = text[i];
    const bool triple = text.compare(i, 3, std::string(3, q)) == 0;
    std::size_t j = i + (triple ? 3 : 1);
    for (; j < text.size(); ++j) {
      if (text[j] == '\n') {
        if (!triple) return j - 1;  // an unterminated string: toml++ says so
        ++line;
      }
      if (q == '"' && text[j] == '\\') {
        ++j;
        if (j < text.size() && text[j] == '\n') ++line;
        continue;
      }
      if (text[j] == q && (!triple || text.compare(j, 3, std::string(3, q)) == 0))
        return triple ? j + 2 : j;
    }
    return text.size();
  };
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '\n') {
      ++line;
      if (open.empty()) key = true, dots = 0, container = base;
    } else if (c == '#') {
      while (i + 1 < text.size() && text[i + 1] != '\n') ++i;
    } else if (c == '"' || c == '\'') {
      i = skip_string(i);
    } else if (key && open.empty() && c == '[') {  // a table header
      const bool array = i + 1 < text.size() && text[i + 1] == '[';
      int parts = 1;
      for (++i; i < text.size() && text[i] != ']' && text[i] != '\n'; ++i) {
        if (text[i] == '"' || text[i] == '\'') i = skip_string(i);
        if (i < text.size() && text[i] == '.') ++parts;
      }
      if (i < text.size() && text[i] == '\n') --i;
      base = container = parts + (array ? 1 : 0);
      check(base);
    } else if (key && c == '.') {
      ++dots;
    } else if (key && c == '=') {
      cur = container + dots + 1;
      check(cur);
      key = false;
      dots = 0;
    } else if (!key && (c == '[' || c == '{')) {
      open.push_back({c, cur, container});
      if (c == '{') container = cur, key = true, dots = 0;
      check(++cur);
    } else if (!key && c == ',' && !open.empty()) {
      if (open.back().bracket == '{') key = true, dots = 0;
      cur = open.back().cur + 1;
    } else if ((c == ']' || c == '}') && !open.empty()) {
      cur = open.back().cur;
      container = open.back().container;
      open.pop_back();
      key = false;
    }
  }
}

// Inserts `key = value` (value in TOML syntax) at a dotted path whose parts may index arrays:
// "algorithm.R", "load.traction[0].value", "load.factor[2]". Tables on the way are created;
// array entries must exist. Returns the key in the form the Reader names keys.
std::string apply_override(toml::table& root, const std::string& assignment,
                           const std::string& file) {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0)
    throw Error(cat(file, ": --set '", assignment, "': expected key=value, e.g. algorithm.R=4"));
  const std::string key = assignment.substr(0, eq), value = assignment.substr(eq + 1);
  // Messages quote at most 80 characters of the assignment (it may be megabytes long).
  const std::string quoted = assignment.size() <= 80 ? assignment
                                                     : cat(assignment.substr(0, 80), "... (",
                                                           assignment.size(), " characters)");
  auto bad = [&](const std::string& msg) -> Error {
    return Error(cat(file, ": --set '", quoted, "': ", msg));
  };
  const auto depth =
      1 + std::count(key.begin(), key.end(), '.') + std::count(key.begin(), key.end(), '[');
  if (depth > kMaxKeyDepth)
    throw bad(cat("a key of ", depth, " parts; keys have at most ", kMaxKeyDepth));
  try {
    check_key_depth("v = " + value, "the value");
  } catch (const Error& e) {
    throw bad(e.what());
  }
  toml::table parsed;
  try {
    parsed = toml::parse("v = " + value);
  } catch (const toml::parse_error&) {
    try {
      parsed = toml::parse("v = \"" + value + "\"");  // bare words are strings: update=uzawa
    } catch (const toml::parse_error& e) {
      throw bad(cat("the value is not valid TOML: ", e.description()));
    }
  }
  // Split "a.b[0].c" into steps: a name, or an index into the array reached so far.
  struct Part {
    std::string name;
    long index = -1;
  };
  std::vector<Part> parts;
  std::size_t i = 0;
  while (i < key.size()) {
    if (key[i] == '[') {
      const auto close = key.find(']', i);
      const std::string digits = key.substr(i + 1, close == std::string::npos ? 0 : close - i - 1);
      if (close == std::string::npos || digits.empty() ||
          digits.find_first_not_of("0123456789") != std::string::npos || digits.size() > 9)
        throw bad(cat("'", key, "': an index is written [N], N = 0, 1, ..."));
      if (parts.empty()) throw bad(cat("'", key, "': an index needs an array name before it"));
      parts.push_back({"", std::stol(digits)});
      i = close + 1;
      if (i < key.size() && key[i] == '.') ++i;
    } else {
      const auto end = key.find_first_of(".[", i);
      const std::string name =
          key.substr(i, end == std::string::npos ? std::string::npos : end - i);
      if (name.empty()) throw bad(cat("'", key, "': empty key part"));
      parts.push_back({name, -1});
      i = end == std::string::npos ? key.size() : (key[end] == '.' ? end + 1 : end);
      if (end != std::string::npos && key[end] == '.' && i == key.size())
        throw bad(cat("'", key, "': empty key part"));
    }
  }
  toml::node* at = &root;  // the container the next part indexes
  std::string path;        // the key so far, as the Reader names it
  for (std::size_t k = 0; k < parts.size(); ++k) {
    const Part& part = parts[k];
    const bool last = k + 1 == parts.size();
    if (part.index < 0) {
      toml::table* t = at->as_table();
      if (!t) throw bad(cat("'", path, "' is not a table"));
      path += (path.empty() ? "" : ".") + part.name;
      if (last) {
        t->insert_or_assign(part.name, *parsed.get("v"));
        return path;
      }
      if (!t->contains(part.name)) {
        if (parts[k + 1].index >= 0)
          throw bad(cat("'", path, "' does not exist; give the whole array, e.g. --set '", path,
                        "=[...]'"));
        t->insert(part.name, toml::table{});
      }
      at = t->get(part.name);
    } else {
      toml::array* a = at->as_array();
      if (!a) throw bad(cat("'", path, "' is not an array"));
      if (part.index >= static_cast<long>(a->size()))
        throw bad(cat("'", path, "' has ", a->size(), a->size() == 1 ? " entry" : " entries",
                      a->empty() ? "" : cat(" (indices 0..", a->size() - 1, ")"), "; [", part.index,
                      "] does not exist"));
      path += cat("[", part.index, "]");
      if (last) {
        a->replace(a->begin() + part.index, *parsed.get("v"));
        return path;
      }
      at = a->get(static_cast<std::size_t>(part.index));
    }
  }
  return path;
}

}  // namespace

double parse_quantity(const std::string& text, const std::string& si, const std::string& key) {
  std::istringstream in(text);
  double value;
  if (!(in >> value))
    throw Error(cat("'", text, "' is not \"<number> <unit>\" (expected ", si, ")"));
  std::string unit;
  std::getline(in, unit);
  unit.erase(0, unit.find_first_not_of(' '));
  unit.erase(unit.find_last_not_of(' ') + 1);
  if (unit.empty() || unit == si) return value;
  const auto& t = unit_table();
  auto it = t.find(unit);
  if (it == t.end()) throw Error(cat("unknown unit '", unit, "' (expected ", si, ")"));
  if (it->second.second != si)
    throw Error(cat("unit '", unit, "' is ", it->second.second, ", but ", key, " is in ", si));
  return value * it->second.first;
}

Problem load_problem(const std::string& path, const std::vector<std::string>& overrides) {
  namespace fs = std::filesystem;
  if (!fs::exists(path)) throw Error(cat(path, ": no such configuration file"));
  if (fs::is_directory(path)) throw Error(cat(path, ": is a directory, not a configuration file"));
  if (!fs::is_regular_file(path))
    throw Error(
        cat(path, ": is not a regular file (a FIFO, device or socket); refusing to read it"));
  if (!std::ifstream(path).good()) throw Error(cat(path, ": cannot read the configuration file"));
  toml::table root;
  try {
    const std::string text = read_text(path);
    check_key_depth(text, path);
    root = toml::parse(text, path);
  } catch (const toml::parse_error& e) {
    throw Error(cat(path, ":", e.source().begin.line, ":", e.source().begin.column,
                    ": not valid TOML: ", e.description()));
  }
  Overrides given;
  for (const auto& o : overrides) given[apply_override(root, o, path)] = o;

  Problem p;
  p.config_path = path;
  {
    std::ostringstream s;
    s << root;
    p.config_text = s.str();
    toml::table identity = root;
    if (toml::table* t = identity["time"].as_table()) {
      t->erase("steps");
      if (t->empty()) identity.erase("time");  // "--set time.steps=N" on a file without [time]
    }
    std::ostringstream i;
    i << identity;
    p.config_identity = i.str();
  }
  Reader r(root, "", path, &given);
  r.only({"name", "mesh", "material", "fixed", "symmetry", "displacement", "load", "contact",
          "algorithm", "discretization", "time", "output"});
  p.name = r.string("name", fs::path(path).stem().string());
  // The name makes the default results path results/<name>.h5: a plain file name only.
  if (p.name.empty() || p.name == "." || p.name == ".." ||
      p.name.find_first_of("/\\") != std::string::npos || p.name.find('\0') != std::string::npos)
    r.fail("name", cat("'", p.name, "': must be a plain file name (no '/', not '.' or '..')"));

  // [mesh]: a gmsh .geo (or .msh) file and its ONELAB parameters.
  const Reader m = r.sub("mesh");
  m.only({"geometry", "parameters"});
  const fs::path geo = fs::path(path).parent_path() / m.string("geometry");
  if (fs::is_directory(geo)) m.fail("geometry", cat("'", geo.string(), "' is a directory"));
  if (fs::exists(geo) && !fs::is_regular_file(geo))
    m.fail("geometry",
           cat("'", geo.string(),
               "' is not a regular file (a FIFO, device or socket); refusing to read it"));
  if (!std::ifstream(geo).good())
    m.fail("geometry", cat("'", geo.string(), "': cannot open the mesh/geometry file"));
  std::map<std::string, double> params;
  if (m.has("parameters")) {
    const Reader mp = m.sub("parameters");
    // Each parameter must be one the .geo defines: a misspelled name would be ignored by gmsh.
    const GeometryScan declared = scan_geometry(geo.string());
    for (const auto& [k, v] : mp.table()) {
      const std::string name(k.str());
      auto x = v.value<double>();
      if (!x) mp.fail(name, "expected a number", &v);
      mp.real(name, *x, &v);
      if (!declared.parameters.count(name)) {
        std::string names;
        for (const auto& n : declared.parameters) names += (names.empty() ? "" : ", ") + n;
        mp.fail(name,
                cat("'", geo.string(), "' defines no parameter '", name,
                    "' (DefineConstant[... Name \"Parameters/", name,
                    "\"]); it defines: ", names.empty() ? "none" : names),
                &v);
      }
      params[name] = *x;
    }
  }
  p.mesh = load_mesh(geo.string(), params);
  const int dim = p.mesh.dim;

  // [material] [LTL87 (1.5), sec. 8]
  const Reader mat = r.sub("material");
  const std::string model = mat.string("model");
  if (model == "mooney-rivlin") {
    mat.only({"model", "C1", "C2"});
    p.material.model = MaterialModel::MooneyRivlin;
    p.material.C1 = mat.quantity("C1", "Pa");
    p.material.C2 = mat.quantity("C2", "Pa", 0.0);
  } else if (model == "compressible") {
    mat.only({"model", "C1", "C3"});
    p.material.model = MaterialModel::Compressible;
    p.material.C1 = mat.quantity("C1", "Pa");
    p.material.C3 = mat.quantity("C3", "Pa");
  } else if (model == "ogden") {  // paper_notes/materials.md
    mat.only({"model", "mu", "alpha"});
    const toml::array* mu = mat.node("mu") ? mat.node("mu")->as_array() : nullptr;
    const toml::array* alpha = mat.node("alpha") ? mat.node("alpha")->as_array() : nullptr;
    if (!mu || mu->empty()) mat.fail("mu", "expected a list of moduli mu_p (Pa), one per term");
    if (!alpha || alpha->size() != mu->size())
      mat.fail("alpha", cat("expected a list of ", mu->size(), " exponents alpha_p, one per mu_p"));
    std::vector<OgdenTerm> terms(mu->size());
    for (std::size_t i = 0; i < mu->size(); ++i) {
      terms[i].mu = mat.quantity_of(*mu->get(i), "mu", "Pa");
      const auto a = alpha->get(i)->value<double>();
      if (!a) mat.fail("alpha", "expected numbers", alpha->get(i));
      terms[i].alpha = mat.real("alpha", *a, alpha->get(i));
    }
    p.material = Material::ogden_law(terms);
  } else if (model == "gent") {  // paper_notes/materials.md
    mat.only({"model", "mu", "Jm"});
    p.material = Material::gent(mat.quantity("mu", "Pa"), mat.number("Jm", 0.0));
    if (!mat.has("Jm")) mat.fail("Jm", "missing value (the locking parameter, dimensionless)");
  } else {
    mat.fail("model", "expected \"mooney-rivlin\", \"compressible\", \"ogden\" or \"gent\"");
  }

  // Boundary conditions.
  for (const auto& f : r.subs("fixed")) {
    // Gamma_1: u = value (0 by default) on every component, or on `component` alone; the value
    // follows the load factor of the step like the tractions (Solver::set_load_factor).
    f.only({"group", "component", "value"});
    DirichletCondition d{f.string("group"), {}, {}, f.key("group")};
    if (f.has("component")) {
      const int c = component_index(f, "component", dim);
      d.components.push_back(c);
      d.field.value(c) = f.quantity("value", "m", 0.0);
    } else {
      for (int c = 0; c < dim; ++c) d.components.push_back(c);
      if (f.has("value")) d.field.value = f.vector("value", "m", dim);
    }
    p.dirichlet.push_back(d);
  }
  for (const auto& f : r.subs("symmetry")) {
    f.only({"group", "component"});
    p.dirichlet.push_back(
        {f.string("group"), {component_index(f, "component", dim)}, {}, f.key("group")});
  }
  for (const auto& f : r.subs("displacement")) {
    f.only({"group", "value", "gradient"});
    DirichletCondition d{f.string("group"), {}, {}, f.key("group")};
    for (int c = 0; c < dim; ++c) d.components.push_back(c);
    d.field.value = f.vector("value", "m", dim);
    if (f.has("gradient")) d.field.gradient = f.matrix("gradient", "1", dim);
    p.dirichlet.push_back(d);
  }

  // [load]: dead body force and surface tractions [LTL87 (1.2)].
  if (r.has("load")) {
    const Reader l = r.sub("load");
    l.only({"body_force", "traction", "ramp", "ramp_time", "factor"});
    if (l.has("body_force")) p.body_force = l.vector("body_force", "Pa/m", dim);
    // The load factor per time step (LoadRamp): "constant" (1), "linear" (t / ramp_time, then
    // 1) or "table" (factor[p - 1], the last entry holding after the table).
    const std::string ramp = l.string("ramp", "constant");
    if (ramp == "constant") {
      p.ramp.kind = LoadRamp::Kind::Constant;
    } else if (ramp == "linear") {
      p.ramp.kind = LoadRamp::Kind::Linear;
      p.ramp.ramp_time = l.quantity("ramp_time", "s");
      if (!(p.ramp.ramp_time > 0))
        l.fail("ramp_time", cat("= ", p.ramp.ramp_time, " s: must be > 0"));
    } else if (ramp == "table") {
      p.ramp.kind = LoadRamp::Kind::Table;
      const toml::node* n = l.node("factor");
      const toml::array* a = n ? n->as_array() : nullptr;
      if (!a || a->empty())
        l.fail("factor", "ramp = \"table\" needs factor = [f1, f2, ...], one per time step", n);
      for (std::size_t i = 0; i < a->size(); ++i) {
        auto v = a->get(i)->value<double>();
        if (!v) l.fail(cat("factor[", i, "]"), "expected a number", a->get(i));
        p.ramp.table.push_back(l.real(cat("factor[", i, "]"), *v, a->get(i)));
      }
    } else {
      l.fail("ramp", "expected \"constant\" (default), \"linear\" or \"table\"");
    }
    if (ramp != "linear" && l.has("ramp_time"))
      l.fail("ramp_time", "is the end of a linear ramp: it needs ramp = \"linear\"");
    if (ramp != "table" && l.has("factor"))
      l.fail("factor", "is a table of load factors: it needs ramp = \"table\"");
    for (const auto& t : l.subs("traction")) {
      t.only({"group", "value", "gradient"});
      Traction tr{t.string("group"), {}, t.key("group")};
      tr.g.value = t.vector("value", "Pa", dim);
      if (t.has("gradient")) tr.g.gradient = t.matrix("gradient", "Pa/m", dim);
      p.tractions.push_back(tr);
    }
  }

  // [contact]: Gamma_c, the rigid plane and the glue [LTL87 (1.1)-(1.3), (4.11)].
  if (r.has("contact")) {
    const Reader c = r.sub("contact");
    c.only({"group", "plane_point", "plane_normal", "beta0", "w", "kappa", "eps", "d0", "kernel"});
    ContactCondition cc;
    cc.group = c.string("group");
    cc.origin = c.key("group");
    cc.plane_point = c.vector("plane_point", "m", dim);
    cc.plane_normal = c.vector("plane_normal", "1", dim);
    if (cc.plane_normal.norm() == 0) c.fail("plane_normal", "must not be zero");
    cc.plane_normal.normalize();
    cc.beta0 = c.number("beta0", 1.0);
    cc.adhesion.w = c.quantity("w", "J/m^2", 0.0);
    if (c.has("kappa") && c.has("eps")) c.fail("eps", "give either kappa (= 1/eps) or eps");
    cc.adhesion.kappa = c.quantity("kappa", "Pa/m", 0.0);
    if (c.has("eps")) {
      const double eps = c.quantity("eps", "1");
      if (!(eps > 0)) c.fail("eps", cat("= ", eps, ": must be > 0 (use kappa = 0 for no glue)"));
      cc.adhesion.kappa = 1 / eps;
    }
    cc.adhesion.d0 = c.quantity("d0", "1/m", 0.0);
    const std::string kernel = c.string("kernel", "centre");
    if (kernel != "centre" && kernel != "exact")
      c.fail("kernel", "expected \"centre\" (the paper's rule) or \"exact\"");
    cc.adhesion.exact_kernel = kernel == "exact";
    p.contact = cc;
  }

  // [algorithm] [LTL87 sec. 3-4, 7]
  bool has_R = false, has_q = false, has_q_c = false, has_solver = false;
  if (r.has("algorithm")) {
    const Reader a = r.sub("algorithm");
    a.only({"update",
            "R",
            "q",
            "q_c",
            "rho",
            "sweeps",
            "contact_sweeps",
            "tol",
            "max_iter",
            "blowup",
            "acceleration",
            "depth",
            "accelerate",
            "max_force_residual",
            "adaptive_R",
            "adapt_every",
            "max_refactorizations",
            "R_min",
            "solver",
            "global_solver",
            "newton_switch",
            "force_tol",
            "newton_max_iter"});
    p.algorithm.update = a.choice<Update>(
        "update", {{"uzawa", Update::Uzawa}, {"bermudez-moreno", Update::BermudezMoreno}}, "uzawa");
    has_R = a.has("R"), has_q = a.has("q"), has_q_c = a.has("q_c");
    p.algorithm.R = a.number("R", p.algorithm.R);
    p.algorithm.q = a.quantity("q", "Pa", p.algorithm.q);
    p.algorithm.q_c = a.quantity("q_c", "Pa/m", p.algorithm.q_c);
    // [choice] rho defaults to 1 for Uzawa (the paper's (4.3)) and to 0.75 for Bermudez-Moreno:
    // rho = 1 there is a Peaceman-Rachford step, which does not converge on Figs 3 and 5, and
    // rho = 0.9 cycles on Fig 6.
    p.algorithm.rho = a.number("rho", p.algorithm.update == Update::BermudezMoreno ? 0.75 : 1.0);
    p.algorithm.sweeps = a.integer("sweeps", p.algorithm.sweeps, 1, 1000);
    p.algorithm.contact_sweeps = a.integer("contact_sweeps", p.algorithm.contact_sweeps, 1, 1000);
    p.algorithm.tol = a.number("tol", p.algorithm.tol);
    p.algorithm.max_iter = a.integer("max_iter", p.algorithm.max_iter, 1, 1000000000);
    p.algorithm.blowup = a.number("blowup", p.algorithm.blowup);
    // Safeguarded Anderson acceleration of the fixed-point map (paper_notes/performance.md).
    p.algorithm.acceleration = a.choice<Acceleration>(
        "acceleration", {{"none", Acceleration::None}, {"anderson", Acceleration::Anderson}},
        "none");
    p.algorithm.depth = a.integer("depth", p.algorithm.depth, 1, 16);
    p.algorithm.accelerate =
        a.choice<Accelerated>("accelerate",
                              {{"multipliers", Accelerated::Multipliers},
                               {"strains-multipliers", Accelerated::StrainsMultipliers},
                               {"all", Accelerated::All}},
                              "all");
    p.algorithm.max_force_residual = a.number("max_force_residual", p.algorithm.max_force_residual);
    // Adaptive R by residual balancing (paper_notes/performance.md).
    p.algorithm.adaptive_R = a.boolean("adaptive_R", p.algorithm.adaptive_R);
    p.algorithm.adapt_every = a.integer("adapt_every", p.algorithm.adapt_every, 1, 1000000);
    p.algorithm.max_refactorizations =
        a.integer("max_refactorizations", p.algorithm.max_refactorizations, 0, 100);
    p.algorithm.R_min = a.number("R_min", p.algorithm.R_min);
    if (a.has("R_min") && !(p.algorithm.R_min > 0))
      a.fail("R_min", cat("= ", p.algorithm.R_min, ": must be > 0"));
    // ALG2 alone (the paper's), or ALG2 into the basin of Newton's method (newton.hpp).
    has_solver = a.has("solver");
    p.algorithm.solver = a.choice<NonlinearSolver>(
        "solver", {{"alg2", NonlinearSolver::Alg2}, {"newton", NonlinearSolver::Newton}}, "alg2");
    // The global step's linear solver; left out: by the predicted factor size (global_step.hpp).
    p.algorithm.global_solver = a.choice<GlobalSolver>("global_solver",
                                                       {{"auto", GlobalSolver::Auto},
                                                        {"cholesky", GlobalSolver::Cholesky},
                                                        {"cg-amg", GlobalSolver::CgAmg}},
                                                       "auto");
    p.algorithm.newton_switch = a.number("newton_switch", p.algorithm.newton_switch);
    if (!(p.algorithm.newton_switch > 0))
      a.fail("newton_switch", cat("= ", p.algorithm.newton_switch, ": must be > 0"));
    p.algorithm.newton_max_iter =
        a.integer("newton_max_iter", p.algorithm.newton_max_iter, 1, 1000000);
    p.algorithm.force_tol = a.number("force_tol", p.algorithm.force_tol);
    if (!(p.algorithm.force_tol > 0))
      a.fail("force_tol", cat("= ", p.algorithm.force_tol, ": must be > 0"));
  }
  // [choice] solver left out: Newton after ALG2 (newton.hpp), glue or not; the figures ask for
  // the paper's ALG2.
  if (!has_solver) p.algorithm.solver = NonlinearSolver::Newton;
  // R, q, q_c left out: derived from the moduli and the mesh (derive_algorithm_defaults).
  derive_algorithm_defaults(p, has_R, has_q, has_q_c);
  // [discretization]: the defaults converge under refinement; "cell-mean" and "facet-mean" are
  // the paper's choices (paper_notes/discretization.md).
  if (r.has("discretization")) {
    const Reader d = r.sub("discretization");
    d.only({"c2", "contact", "incompressibility"});
    const std::string c2 = d.string("c2", "pointwise");
    if (c2 != "pointwise" && c2 != "cell-mean")
      d.fail("c2", "expected \"pointwise\" (default) or \"cell-mean\" (the paper's)");
    p.discretization.c2_pointwise = c2 == "pointwise";
    const std::string contact = d.string("contact", "nodal");
    if (contact != "nodal" && contact != "facet-mean")
      d.fail("contact", "expected \"nodal\" (default) or \"facet-mean\" (the paper's)");
    p.discretization.nodal_contact = contact == "nodal";
    const std::string inc = d.string("incompressibility", "mean-det");
    if (inc != "mean-det" && inc != "det-mean")
      d.fail("incompressibility", "expected \"mean-det\" (default) or \"det-mean\" (the paper's)");
    p.discretization.mean_det = inc == "mean-det";
  }
  // [time] (2.1)-(2.2)
  if (r.has("time")) {
    const Reader t = r.sub("time");
    t.only({"dt", "steps"});
    p.time.dt = t.quantity("dt", "s", p.time.dt);
    p.time.steps = t.integer("steps", p.time.steps, 1, 999999);  // 6-digit step groups
  }
  if (r.has("output")) {
    const Reader o = r.sub("output");
    o.only({"file"});
    const std::string file = o.string("file");
    if (file.empty()) o.fail("file", "must not be empty");
    p.output_file = (fs::path(path).parent_path() / file).lexically_normal().string();
  }

  try {
    p.validate();
  } catch (const KeyError& e) {
    // Point at the line where the key was given, if it was.
    if (const std::string* o = override_of(given, e.key()))
      throw Error(cat(path, ": --set '", *o, "': key '", e.key(), "' ", e.message()));
    const toml::node* n = root.at_path(e.key()).node();
    std::string loc = n ? where(n->source()) : path;
    if (!loc.empty() && loc[0] == ':') loc = path + loc;
    throw Error(cat(loc, ": key '", e.key(), "' ", e.message()));
  }
  return p;
}

}  // namespace ltl
