// The configuration schema: every key of a configuration file, once, as a row (path, type, unit,
// default, range, doc, and how it is read into and written from a Problem). The one table drives
//   - reading (load_problem, config.hpp): the keys allowed in each table, their types, units,
//     ranges and defaults;
//   - --set (the same reader, after the override is applied to the parsed file);
//   - the resolved configuration written to results files (resolved_configuration, config.hpp),
//     which load_problem accepts back and which reproduces the run bit for bit;
//   - the key table of experiments/README.md (key_table_markdown; `make keys` rewrites it, the
//     test Schema.ReadmeKeyTableIsGenerated checks it).
//
// Adding a key is one row in configuration_schema() (lib/config_schema.cpp): give its section,
// name, type, unit, default, range and doc, and its field of the Problem (a quantity, a number,
// an integer, a choice, ... helper below). Nothing else changes: not the reader, not the writer,
// not the README table (regenerate it with `make keys`).
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "problem.hpp"

namespace ltl::config {

class Reader;

/// A key allowed only when another key of its table has one of some values: material.C2 with
/// model = "mooney-rivlin", load.ramp_time with ramp = "linear".
struct When {
  std::string key;                  ///< the selector, in the same table ("" = always)
  std::vector<std::string> values;  ///< the selector's values under which the key applies
  /// Empty: otherwise the key is unknown (not in the "allowed here" list). Else the key is
  /// allowed but giving it is this error (e.g. "is the end of a linear ramp: it needs ...").
  std::string otherwise;
};

/// One key: its place, its documentation, and its binding to the Problem.
struct Key {
  std::string section;  ///< "" (top level), "mesh", "load.traction", ...
  std::string name;     ///< "C1"
  std::string type;     ///< for the docs: "string", "quantity", "number", "integer", ...
  std::string unit;     ///< the SI unit ("Pa", "1", ...; "" for non-physical values)
  std::string range;    ///< for the docs ("> 0", "1 ... 16", choices); checked where it is read
  std::string doc;      ///< the meaning (one markdown line)
  /// The default for the docs; empty: the value written for a default Problem. "required" for a
  /// required key.
  std::string default_doc;
  When when;
  /// Reads the key from the table `r` into element `i` of the section (0 for a table); an
  /// absent key leaves the default (or fails if it is required). Vectors and matrices have
  /// p.mesh.dim components ([mesh] is read first).
  std::function<void(const Reader& r, Problem& p, int i)> read;
  /// The TOML value of element `i` in the resolved configuration; "" leaves the key out.
  std::function<std::string(const Problem& p, int i)> write;
};

/// A table of the file, or an array of tables ([[fixed]], [[load.traction]]).
struct Section {
  std::string path;  ///< "" (top level), "mesh", "load.traction"
  bool array = false;
  bool required = false;
  /// Arrays: the number of elements a Problem has, and appending a new (default) one before its
  /// keys are read; `origin` names it in messages ("fixed[0].group").
  std::function<int(const Problem&)> count;
  std::function<void(Problem&, const std::string& origin)> add;
  /// After the table's keys are read (e.g. [mesh]: load the mesh, which gives dim).
  std::function<void(const Reader& r, Problem& p)> done;
  /// An array that also accepts one plain table `[path]` for a list of one element, named
  /// `path` in messages (not `path[0]`), and written back as `[path]` when it has one element:
  /// `[contact]` (the paper's one obstacle) or `[[contact]]` (several, paper_notes/obstacles.md).
  bool one_table = false;
};

struct Schema {
  std::vector<Section> sections;  ///< in the order they are read and written
  std::vector<Key> keys;          ///< grouped by section, in that order
};

/// The schema of the configuration file.
const Schema& configuration_schema();

/// The key table of experiments/README.md (between its "keys" markers), generated from the
/// schema.
std::string key_table_markdown();

}  // namespace ltl::config
