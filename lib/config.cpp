// Reading a configuration file, and writing the resolved configuration, both driven by the
// schema (config_schema.hpp): what the keys are is there, one row each; here is only how a table
// of rows is read and written.
#include "config.hpp"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "config_schema.hpp"
#include "config_toml.hpp"
#include "error.hpp"

namespace ltl {

namespace {

using config::apply_override;
using config::check_key_depth;
using config::Key;
using config::override_of;
using config::Overrides;
using config::read_text;
using config::Reader;
using config::Section;
using config::where;

std::string parent_of(const std::string& path) {
  const auto dot = path.rfind('.');
  return dot == std::string::npos ? "" : path.substr(0, dot);
}
std::string last_of(const std::string& path) {
  const auto dot = path.rfind('.');
  return dot == std::string::npos ? path : path.substr(dot + 1);
}

/// The keys of a section, in schema order.
std::vector<const Key*> keys_of(const Section& sec) {
  std::vector<const Key*> out;
  for (const Key& k : config::configuration_schema().keys)
    if (k.section == sec.path) out.push_back(&k);
  return out;
}

/// The value (unquoted) that the selector `name` of `sec` has in element i of p.
std::string selector_value(const Section& sec, const std::string& name, const Problem& p, int i) {
  for (const Key* k : keys_of(sec))
    if (k->name == name) {
      std::string v = k->write(p, i);
      if (v.size() >= 2 && v.front() == '"') v = v.substr(1, v.size() - 2);
      return v;
    }
  throw Error(cat("configuration schema: no key '", name, "' in [", sec.path, "]"));
}

/// Whether key k applies to element i of p (its When holds).
bool applies(const Section& sec, const Key& k, const Problem& p, int i) {
  if (k.when.key.empty()) return true;
  const std::string v = selector_value(sec, k.when.key, p, i);
  return std::find(k.when.values.begin(), k.when.values.end(), v) != k.when.values.end();
}

/// Reads the table `t` of section `sec` into element i of p, then its sub-tables.
void read_section(const Section& sec, const Reader& t, Problem& p, int i) {
  const std::vector<const Key*> keys = keys_of(sec);
  std::set<std::string> selectors;
  for (const Key* k : keys)
    if (!k->when.key.empty()) selectors.insert(k->when.key);
  for (const Key* k : keys)  // first the keys others depend on: material.model, load.ramp
    if (selectors.count(k->name)) k->read(t, p, i);
  std::set<std::string> allowed;
  for (const Key* k : keys)
    if (!k->when.otherwise.empty() || applies(sec, *k, p, i)) allowed.insert(k->name);
  std::vector<const Section*> children;
  for (const Section& c : config::configuration_schema().sections)
    if (!c.path.empty() && c.path != sec.path && parent_of(c.path) == sec.path) {
      children.push_back(&c);
      allowed.insert(last_of(c.path));
    }
  t.only(allowed);
  for (const Key* k : keys) {
    if (selectors.count(k->name)) continue;
    if (applies(sec, *k, p, i))
      k->read(t, p, i);
    else if (t.has(k->name))
      t.fail(k->name, k->when.otherwise);
  }
  if (sec.done) sec.done(t, p);
  for (const Section* c : children) {
    const std::string name = last_of(c->path);
    if (c->array && c->one_table && t.node(name) && t.node(name)->is_table()) {
      c->add(p, t.key(name));  // one [contact] table: the list of one, named "contact"
      read_section(*c, t.sub(name), p, c->count(p) - 1);
    } else if (c->array) {
      int j = 0;
      for (const Reader& sub : t.subs(name)) {
        c->add(p, cat(t.key(name), "[", j++, "]"));
        read_section(*c, sub, p, c->count(p) - 1);
      }
    } else if (c->required || t.has(name)) {
      const Reader sub = t.sub(name);
      if (c->add) c->add(p, t.key(name));
      read_section(*c, sub, p, 0);
    }
  }
}

/// `[contact]` (one obstacle) and `[[contact]]` (a list of obstacles) are two forms of one key:
/// refused together, naming both lines, before toml++ reports a redefined table.
void check_one_contact_form(const std::string& text, const std::string& path) {
  int table = 0, array = 0, line = 1;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t end = std::min(text.find('\n', start), text.size());
    std::string l = text.substr(start, end - start);
    l.erase(std::remove_if(l.begin(), l.end(), [](char c) { return c == ' ' || c == '\t'; }),
            l.end());
    if (l.rfind("[[contact]]", 0) == 0 && !array) array = line;
    if (l.rfind("[contact]", 0) == 0 && !table) table = line;
    start = end + 1;
    ++line;
  }
  if (table && array)
    throw Error(cat(path, ":", array,
                    ": key 'contact': [[contact]] (a list of obstacles) and "
                    "[contact] (line ",
                    table,
                    ", one obstacle) both given: write one "
                    "[contact] table or a [[contact]] table per obstacle, not both"));
}

}  // namespace

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
    check_one_contact_form(text, path);
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
  read_section(config::configuration_schema().sections.front(), r, p, 0);
  // [choice] solver left out: Newton after ALG2 (newton.hpp), glue or not; the figures ask for
  // the paper's ALG2.
  if (!root.at_path("algorithm.solver")) p.algorithm.solver = NonlinearSolver::Newton;
  // [choice] stopping left out: a step is converged in equilibrium (measures.hpp); the figures
  // ask for the paper's test r_G + r_B < tol.
  if (!root.at_path("algorithm.stopping")) p.algorithm.stopping = Stopping::Equilibrium;
  // R, q, q_c left out: derived from the moduli and the mesh (derive_algorithm_defaults).
  derive_algorithm_defaults(p, !!root.at_path("algorithm.R"), !!root.at_path("algorithm.q"),
                            !!root.at_path("algorithm.q_c"));

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

std::string resolved_configuration(const Problem& p) {
  std::ostringstream o;
  o << "# The resolved configuration: every value in SI (unit in the comment), every default\n"
    << "# filled in. A record of what was computed, written by ltl::resolved_configuration;\n"
    << "# ltl_run reads it back and repeats the run. The configuration as given is the\n"
    << "# attribute \"config\". Mesh: " << p.mesh.dim << "-D, " << p.mesh.num_nodes() << " nodes, "
    << p.mesh.num_cells() << " cells of " << p.mesh.nodes_per_cell() << " nodes.\n";
  for (const Section& sec : config::configuration_schema().sections) {
    const int n = sec.count ? sec.count(p) : 1;
    for (int i = 0; i < n; ++i) {
      std::ostringstream lines;
      for (const Key* k : keys_of(sec)) {
        if (!applies(sec, *k, p, i)) continue;
        const std::string v = k->write(p, i);
        if (v.empty()) continue;
        lines << k->name << " = " << v;
        if (!k->unit.empty() && v.front() != '"') lines << "  # " << k->unit;
        lines << "\n";
      }
      if (lines.str().empty() && !sec.array) continue;  // e.g. [output], left out
      const bool array = sec.array && !(sec.one_table && n == 1);
      if (!sec.path.empty()) o << (array ? "\n[[" : "\n[") << sec.path << (array ? "]]\n" : "]\n");
      o << lines.str();
    }
  }
  return o.str();
}

}  // namespace ltl
