#include "config_toml.hpp"

#include <algorithm>
#include <charconv>
#include <fstream>
#include <sstream>

#include "config.hpp"

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

namespace config {

std::string where(const toml::source_region& r) {
  std::ostringstream s;
  if (r.path) s << *r.path;
  if (r.begin.line > 0)
    s << ":" << r.begin.line;
  else
    s << ": (--set)";  // a value given on the command line has no line
  return s.str();
}

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

std::string toml_real(double x) {
  if (std::isinf(x)) return x > 0 ? "inf" : "-inf";
  if (std::isnan(x)) return "nan";
  char buf[64];
  const auto end = std::to_chars(buf, buf + sizeof buf, x).ptr;  // shortest that reads back
  std::string s(buf, end);
  if (s.find_first_of(".e") == std::string::npos) s += ".0";
  return s;
}

std::string toml_string(const std::string& v) {
  std::string out = "\"";
  for (char c : v) {
    if (c == '"' || c == '\\') out += '\\';
    if (c == '\n') {
      out += "\\n";
      continue;
    }
    out += c;
  }
  return out + "\"";
}

std::string toml_vector(const Eigen::Vector3d& v, int dim) {
  std::string out = "[";
  for (int i = 0; i < dim; ++i) out += (i ? ", " : "") + toml_real(v(i));
  return out + "]";
}

std::string toml_matrix(const Eigen::Matrix3d& m, int dim) {
  std::string out = "[";
  for (int i = 0; i < dim; ++i) out += (i ? ", " : "") + toml_vector(m.row(i).transpose(), dim);
  return out + "]";
}

}  // namespace config
}  // namespace ltl
