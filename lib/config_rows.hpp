// The row builders of the configuration schema (config_schema.cpp): one helper per type of
// key (quantity, number, integer, boolean, string, choice, vector, matrix), each reading the key
// into a field of the Problem and writing it back for the resolved configuration.
#pragma once

#include <Eigen/Dense>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "config_schema.hpp"
#include "config_toml.hpp"
#include "error.hpp"

namespace ltl::config::rows {

/// The field a key reads into and writes from: a reference into element i of the section.
/// (Writing calls it on a const Problem through a const_cast; it only returns the reference.)
template <class T>
using Field = std::function<T&(Problem&, int)>;

/// A row under construction: Key plus the fluent setters that keep each row short.
struct Row {
  Key k;
  Row& doc(std::string d) {
    k.doc = std::move(d);
    return *this;
  }
  Row& range(std::string r) {
    k.range = std::move(r);
    return *this;
  }
  Row& by_default(std::string d) {
    k.default_doc = std::move(d);
    return *this;
  }
  Row& when(std::string key, std::vector<std::string> values, std::string otherwise = "") {
    k.when = {std::move(key), std::move(values), std::move(otherwise)};
    return *this;
  }
  operator Key() const { return k; }  // NOLINT: rows convert to keys in the table
};

inline Problem& writable(const Problem& p) {
  return const_cast<Problem&>(p);
}

inline Row row(std::string section, std::string name, std::string type, std::string unit) {
  Row r;
  r.k.section = std::move(section);
  r.k.name = std::move(name);
  r.k.type = std::move(type);
  r.k.unit = std::move(unit);
  return r;
}

/// Fails when a given value is not > 0: "= -5 s: must be > 0".
inline void check_positive(const Reader& r, const std::string& name, double v,
                           const std::string& unit) {
  if (r.has(name) && !(v > 0))
    r.fail(name, cat("= ", v, unit.empty() || unit == "1" ? "" : " " + unit, ": must be > 0"));
}

/// Flags of a value: required (no default), and checked > 0 when given.
enum Need { Optional = 0, Required = 1, Positive = 2 };

/// A physical value: a number in SI or a string "<number> <unit>".
inline Row quantity(std::string s, std::string name, std::string unit, Field<double> f,
                    int need = Optional) {
  Row r = row(s, name, "quantity", unit);
  r.k.read = [name, unit, f, need](const Reader& t, Problem& p, int i) {
    double& v = f(p, i);
    v = need & Required ? t.quantity(name, unit) : t.quantity(name, unit, v);
    if (need & Positive) check_positive(t, name, v, unit);
  };
  r.k.write = [f](const Problem& p, int i) { return toml_real(f(writable(p), i)); };
  if (need & Required) r.k.default_doc = "required";
  if (need & Positive) r.k.range = "> 0";
  return r;
}

/// A dimensionless number (no unit string).
inline Row number(std::string s, std::string name, Field<double> f, int need = Optional) {
  Row r = row(s, name, "number", "1");
  r.k.read = [name, f, need](const Reader& t, Problem& p, int i) {
    double& v = f(p, i);
    v = t.number(name, v);
    if (need & Positive) check_positive(t, name, v, "1");
  };
  r.k.write = [f](const Problem& p, int i) { return toml_real(f(writable(p), i)); };
  if (need & Positive) r.k.range = "> 0";
  return r;
}

inline Row integer(std::string s, std::string name, int lo, int hi, Field<int> f) {
  Row r = row(s, name, "integer", "");
  r.k.read = [name, lo, hi, f](const Reader& t, Problem& p, int i) {
    int& v = f(p, i);
    v = t.integer(name, v, lo, hi);
  };
  r.k.write = [f](const Problem& p, int i) { return std::to_string(f(writable(p), i)); };
  r.k.range = cat(lo, " ... ", hi);
  return r;
}

inline Row boolean(std::string s, std::string name, Field<bool> f) {
  Row r = row(s, name, "boolean", "");
  r.k.read = [name, f](const Reader& t, Problem& p, int i) {
    bool& v = f(p, i);
    v = t.boolean(name, v);
  };
  r.k.write = [f](const Problem& p, int i) {
    return std::string(f(writable(p), i) ? "true" : "false");
  };
  r.k.range = "true, false";
  return r;
}

inline Row string(std::string s, std::string name, Field<std::string> f, int need = Optional) {
  Row r = row(s, name, "string", "");
  r.k.read = [name, f, need](const Reader& t, Problem& p, int i) {
    std::string& v = f(p, i);
    v = need & Required ? t.string(name) : t.string(name, v);
  };
  r.k.write = [f](const Problem& p, int i) { return toml_string(f(writable(p), i)); };
  if (need & Required) r.k.default_doc = "required";
  return r;
}

/// One of named options; `error` replaces the generic 'expected "a", "b" or "c"'.
template <class T>
inline Row choice(std::string s, std::string name, std::vector<std::pair<std::string, T>> options,
                  Field<T> f, std::string error = "", int need = Optional) {
  Row r = row(s, name, "choice", "");
  r.k.read = [name, options, f, error, need](const Reader& t, Problem& p, int i) {
    T& v = f(p, i);
    if (need & Required) t.string(name);  // "missing value"
    if (t.has(name)) v = t.choice<T>(name, options, "", error);
  };
  r.k.write = [options, f](const Problem& p, int i) {
    for (const auto& [o, x] : options)
      if (x == f(writable(p), i)) return toml_string(o);
    return std::string();
  };
  for (const auto& o : options)
    r.k.range += (r.k.range.empty() ? "`\"" : ", `\"") + o.first + "\"`";
  if (need & Required) r.k.default_doc = "required";
  return r;
}

/// dim components (one per coordinate of the mesh).
inline Row vector(std::string s, std::string name, std::string unit, Field<Eigen::Vector3d> f,
                  int need = Optional) {
  Row r = row(s, name, "vector", unit);
  r.k.read = [name, unit, f, need](const Reader& t, Problem& p, int i) {
    if (need & Required || t.has(name)) f(p, i) = t.vector(name, unit, p.mesh.dim);
  };
  r.k.write = [f](const Problem& p, int i) { return toml_vector(f(writable(p), i), p.mesh.dim); };
  r.k.range = "dim components";
  if (need & Required) r.k.default_doc = "required";
  return r;
}

/// dim rows of dim components.
inline Row matrix(std::string s, std::string name, std::string unit, Field<Eigen::Matrix3d> f) {
  Row r = row(s, name, "matrix", unit);
  r.k.read = [name, unit, f](const Reader& t, Problem& p, int i) {
    if (t.has(name)) f(p, i) = t.matrix(name, unit, p.mesh.dim);
  };
  r.k.write = [f](const Problem& p, int i) { return toml_matrix(f(writable(p), i), p.mesh.dim); };
  r.k.range = "dim x dim";
  return r;
}

}  // namespace ltl::config::rows
