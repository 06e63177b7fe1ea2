// The TOML plumbing of the configuration layer (config.hpp): a table reader whose errors name
// the file, the line and the key; the --set overrides; the guard against deeply nested keys; the
// units of "<number> <unit>" values; and the writer of TOML values (the resolved configuration).
// What the keys are is not here: lib/config_schema.cpp.
#pragma once

#include <toml++/toml.h>

#include <Eigen/Dense>
#include <cfloat>
#include <cmath>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "config.hpp"
#include "error.hpp"

namespace ltl::config {

/// "file:line" of a TOML node ("file: (--set)" for a value given on the command line).
std::string where(const toml::source_region& r);

/// The --set arguments by their dotted key ("load.traction[0].value" -> the whole argument).
using Overrides = std::map<std::string, std::string>;

/// The --set argument that gave `key` or a table/array containing it, or null.
inline const std::string* override_of(const Overrides& o, const std::string& key) {
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
  /// One of the named options (the default when absent); otherwise the error `error`, or by
  /// default one listing them: expected "a", "b" or "c".
  template <class T>
  T choice(const std::string& k, const std::vector<std::pair<std::string, T>>& options,
           const std::string& fallback, const std::string& error = "") const {
    const std::string v = string(k, fallback);
    std::string expected = "expected ";
    for (size_t i = 0; i < options.size(); ++i) {
      if (options[i].first == v) return options[i].second;
      expected += cat(i == 0                    ? ""
                      : i + 1 == options.size() ? " or "
                                                : ", ",
                      "\"", options[i].first, "\"");
    }
    fail(k, error.empty() ? expected : error);
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
  /// The configuration file (relative file names in it are relative to its folder).
  const std::string& file() const { return file_; }

 private:
  const toml::table& t_;
  std::string prefix_, file_;
  const Overrides* overrides_;
};

/// The index (0, 1, 2) of a component named "x", "y" or "z" (below dim); an error otherwise.
int component_index(const Reader& r, const std::string& k, int dim);

/// The whole content of a file.
std::string read_text(const std::string& path);

/// The deepest nesting of keys this code accepts: table headers, dotted keys and inline tables
/// together (its configurations use at most 5). toml++ builds, prints and destroys tables
/// recursively: a header `[a.a.a...]` of 50 000 parts overflowed the stack (exit 139).
constexpr int kMaxKeyDepth = 64;

/// Refuses TOML text whose keys nest deeper than kMaxKeyDepth, naming the line, before toml++
/// parses it. A linear scan that knows TOML's strings and comments: the depth of a key is that of
/// its table (header parts, + 1 for an array of tables), + its dotted parts, + the inline tables
/// and arrays around it. (Values alone are bounded by toml++: 256 nested arrays or inline tables.)
void check_key_depth(const std::string& text, const std::string& where);

/// Inserts `key = value` (value in TOML syntax) at a dotted path whose parts may index arrays:
/// "algorithm.R", "load.traction[0].value", "load.factor[2]". Tables on the way are created;
/// array entries must exist. Returns the key in the form the Reader names keys.
std::string apply_override(toml::table& root, const std::string& assignment,
                           const std::string& file);

/// TOML values as the resolved configuration writes them: a float that reads back bit for bit
/// (always with a '.' or an exponent), a quoted string, an array of dim numbers, dim rows of dim.
std::string toml_real(double x);
std::string toml_string(const std::string& v);
std::string toml_vector(const Eigen::Vector3d& v, int dim);
std::string toml_matrix(const Eigen::Matrix3d& m, int dim);

}  // namespace ltl::config
