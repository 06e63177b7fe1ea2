// The rows of the configuration schema (config_schema.hpp): one per key. To add a key, add one
// row to configuration_schema() below, with the helper of its type; then `make keys` regenerates
// the table of experiments/README.md.
#include "config_schema.hpp"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "config_rows.hpp"
#include "config_toml.hpp"
#include "error.hpp"
#include "mesh.hpp"

namespace ltl::config {

namespace {

namespace fs = std::filesystem;

using namespace rows;  // NOLINT: the row builders (config_rows.hpp)

/// The i-th Dirichlet condition of a kind (its origin key starts with "fixed[", "symmetry[",
/// "displacement["): the three tables share Problem::dirichlet.
DirichletCondition& nth(Problem& p, const std::string& kind, int i) {
  int n = 0;
  for (DirichletCondition& d : p.dirichlet)
    if (d.origin.compare(0, kind.size() + 1, kind + "[") == 0 && n++ == i) return d;
  throw Error(cat("no ", kind, "[", i, "]"));
}
int count_of(const Problem& p, const std::string& kind) {
  int n = 0;
  for (const DirichletCondition& d : p.dirichlet)
    n += d.origin.compare(0, kind.size() + 1, kind + "[") == 0;
  return n;
}

/// A [[fixed]]/[[symmetry]]/[[displacement]] array: appends a condition on every component.
Section dirichlet_section(const std::string& kind) {
  Section s{kind, true, false, nullptr, nullptr, nullptr};
  s.count = [kind](const Problem& p) { return count_of(p, kind); };
  s.add = [](Problem& p, const std::string& origin) {
    DirichletCondition d{"", {}, {}, origin + ".group"};
    for (int c = 0; c < p.mesh.dim; ++c) d.components.push_back(c);
    p.dirichlet.push_back(d);
  };
  return s;
}

Row dirichlet_group(const std::string& kind, std::string doc) {
  return string(
             kind, "group",
             [kind](Problem& p, int i) -> std::string& { return nth(p, kind, i).group; }, Required)
      .doc(std::move(doc));
}

/// [material] mu: Ogden's list of moduli mu_p, or Gent's shear modulus (paper_notes/materials.md).
Row material_mu() {
  Row r = row("material", "mu", "quantity", "Pa");
  r.k.read = [](const Reader& t, Problem& p, int) {
    if (p.material.model == MaterialModel::Gent) {
      p.material.mu = t.quantity("mu", "Pa");
      return;
    }
    const toml::array* mu = t.node("mu") ? t.node("mu")->as_array() : nullptr;
    if (!mu || mu->empty()) t.fail("mu", "expected a list of moduli mu_p (Pa), one per term");
    p.material.ogden.resize(mu->size());
    for (std::size_t i = 0; i < mu->size(); ++i)
      p.material.ogden[i].mu = t.quantity_of(*mu->get(i), "mu", "Pa");
  };
  r.k.write = [](const Problem& p, int) {
    if (p.material.model == MaterialModel::Gent) return toml_real(p.material.mu);
    std::string o = "[";
    for (std::size_t i = 0; i < p.material.ogden.size(); ++i)
      o += (i ? ", " : "") + toml_real(p.material.ogden[i].mu);
    return o + "]";
  };
  r.k.default_doc = "required";
  return r;
}

/// [material] alpha: Ogden's exponents, one per mu_p.
Row ogden_alpha() {
  Row r = row("material", "alpha", "list", "1");
  r.k.read = [](const Reader& t, Problem& p, int) {
    const toml::array* a = t.node("alpha") ? t.node("alpha")->as_array() : nullptr;
    const std::size_t n = p.material.ogden.size();
    if (!a || a->size() != n)
      t.fail("alpha", cat("expected a list of ", n, " exponents alpha_p, one per mu_p"));
    for (std::size_t i = 0; i < n; ++i) {
      const auto v = a->get(i)->value<double>();
      if (!v) t.fail("alpha", "expected numbers", a->get(i));
      p.material.ogden[i].alpha = t.real("alpha", *v, a->get(i));
    }
  };
  r.k.write = [](const Problem& p, int) {
    std::string o = "[";
    for (std::size_t i = 0; i < p.material.ogden.size(); ++i)
      o += (i ? ", " : "") + toml_real(p.material.ogden[i].alpha);
    return o + "]";
  };
  r.k.default_doc = "required";
  return r;
}

Schema build() {
  using V = Eigen::Vector3d;
  using M = Eigen::Matrix3d;
  Schema s;
  const auto one = [](const Problem&) { return 1; };
  s.sections = {
      {"", false, true, nullptr, nullptr, nullptr},
      {"mesh", false, true, nullptr, nullptr,
       [](const Reader&, Problem& p) { p.mesh = load_mesh(p.mesh.source, p.mesh_parameters); }},
      {"material", false, true, nullptr, nullptr,
       [](const Reader&, Problem& p) {  // the laws in principal stretches set C1 = mu / 2
         if (p.material.model == MaterialModel::Ogden)
           p.material = Material::ogden_law(p.material.ogden);
         else if (p.material.model == MaterialModel::Gent)
           p.material = Material::gent(p.material.mu, p.material.Jm);
       }},
      dirichlet_section("fixed"),
      dirichlet_section("symmetry"),
      dirichlet_section("displacement"),
      {"load", false, false, one, nullptr, nullptr},
      {"load.traction", true, false,
       [](const Problem& p) { return static_cast<int>(p.tractions.size()); },
       [](Problem& p, const std::string& origin) {
         p.tractions.push_back({"", {}, origin + ".group"});
       },
       nullptr},
      // [[contact]]: the obstacles; one [contact] table is the list of one (one_table).
      {"contact", true, false, [](const Problem& p) { return static_cast<int>(p.contacts.size()); },
       [](Problem& p, const std::string& origin) {
         p.contacts.emplace_back();
         p.contacts.back().origin = origin;
       },
       nullptr, true},
      {"algorithm", false, false, one, nullptr, nullptr},
      {"discretization", false, false, one, nullptr, nullptr},
      {"time", false, false, one, nullptr, nullptr},
      {"output", false, false, [](const Problem& p) { return p.output_file.empty() ? 0 : 1; },
       nullptr, nullptr},
  };
  // [mesh]: read by hand (paths relative to the configuration file; the parameters' names are
  // those the .geo defines).
  Row geometry = row("mesh", "geometry", "string", "");
  geometry.k.read = [](const Reader& m, Problem& p, int) {
    const fs::path geo = fs::path(m.file()).parent_path() / m.string("geometry");
    if (fs::is_directory(geo)) m.fail("geometry", cat("'", geo.string(), "' is a directory"));
    if (fs::exists(geo) && !fs::is_regular_file(geo))
      m.fail("geometry",
             cat("'", geo.string(),
                 "' is not a regular file (a FIFO, device or socket); refusing to read it"));
    if (!std::ifstream(geo).good())
      m.fail("geometry", cat("'", geo.string(), "': cannot open the mesh/geometry file"));
    p.mesh.source = geo.string();
  };
  geometry.k.write = [](const Problem& p, int) {
    return toml_string(fs::absolute(p.mesh.source).lexically_normal().string());
  };
  geometry.k.default_doc = "required";
  Row parameters = row("mesh", "parameters", "table of numbers", "");
  parameters.k.read = [](const Reader& m, Problem& p, int) {
    if (!m.has("parameters")) return;
    const Reader mp = m.sub("parameters");
    const GeometryScan declared = scan_geometry(p.mesh.source);
    for (const auto& [k, v] : mp.table()) {
      const std::string name(k.str());
      auto x = v.value<double>();
      if (!x) mp.fail(name, "expected a number", &v);
      mp.real(name, *x, &v);
      // A misspelled name would be ignored by gmsh: the one check, lib/mesh.cpp.
      const std::string undefined = undefined_parameter(declared, name);
      if (!undefined.empty()) mp.fail(name, cat("'", p.mesh.source, "' ", undefined), &v);
      p.mesh_parameters[name] = *x;
    }
  };
  parameters.k.write = [](const Problem& p, int) {
    if (p.mesh_parameters.empty()) return std::string();
    std::string out = "{ ";
    for (const auto& [k, v] : p.mesh_parameters)
      out += cat(out.size() > 2 ? ", " : "", k, " = ", toml_real(v));
    return out + " }";
  };
  parameters.k.default_doc = "none";
  Row name = row("", "name", "string", "");
  name.k.read = [](const Reader& r, Problem& p, int) {
    p.name = r.string("name", fs::path(r.file()).stem().string());
    // The name makes the default results path results/<name>.h5: a plain file name only.
    if (p.name.empty() || p.name == "." || p.name == ".." ||
        p.name.find_first_of("/\\") != std::string::npos || p.name.find('\0') != std::string::npos)
      r.fail("name", cat("'", p.name, "': must be a plain file name (no '/', not '.' or '..')"));
  };
  name.k.write = [](const Problem& p, int) { return toml_string(p.name); };
  name.k.default_doc = "file name";
  Row component = row("symmetry", "component", "choice", "");
  component.k.read = [](const Reader& r, Problem& p, int i) {
    nth(p, "symmetry", i).components = {component_index(r, "component", p.mesh.dim)};
  };
  component.k.write = [](const Problem& p, int i) {
    return toml_string(std::string(1, "xyz"[nth(writable(p), "symmetry", i).components.at(0)]));
  };
  component.k.range = "`\"x\"`, `\"y\"`, `\"z\"` (3-D)";
  component.k.default_doc = "required";
  // [[fixed]] component and value: every component (value a vector, 0 by default), or one
  // (value a scalar); the value follows the load factor of the step (Solver::set_load_factor).
  Row fixed_component = row("fixed", "component", "choice", "");
  fixed_component.k.read = [](const Reader& f, Problem& p, int i) {
    if (f.has("component"))
      nth(p, "fixed", i).components = {component_index(f, "component", p.mesh.dim)};
  };
  fixed_component.k.write = [](const Problem& p, int i) {
    const DirichletCondition& d = nth(writable(p), "fixed", i);
    if (static_cast<int>(d.components.size()) == p.mesh.dim) return std::string();
    return toml_string(std::string(1, "xyz"[d.components.at(0)]));
  };
  fixed_component.k.range = "`\"x\"`, `\"y\"`, `\"z\"` (3-D)";
  fixed_component.k.default_doc = "all components";
  Row fixed_value = row("fixed", "value", "vector, or quantity with component", "m");
  fixed_value.k.read = [](const Reader& f, Problem& p, int i) {
    DirichletCondition& d = nth(p, "fixed", i);
    if (static_cast<int>(d.components.size()) < p.mesh.dim)
      d.field.value(d.components[0]) = f.quantity("value", "m", 0.0);
    else if (f.has("value"))
      d.field.value = f.vector("value", "m", p.mesh.dim);
  };
  fixed_value.k.write = [](const Problem& p, int i) {
    const DirichletCondition& d = nth(writable(p), "fixed", i);
    if (static_cast<int>(d.components.size()) < p.mesh.dim)
      return toml_real(d.field.value(d.components[0]));
    return toml_vector(d.field.value, p.mesh.dim);
  };
  fixed_value.k.range = "dim components, or one";
  fixed_value.k.default_doc = "0";
  Row factor = row("load", "factor", "array of numbers", "1");
  factor.k.read = [](const Reader& l, Problem& p, int) {
    const toml::node* n = l.node("factor");
    const toml::array* a = n ? n->as_array() : nullptr;
    if (!a || a->empty())
      l.fail("factor", "ramp = \"table\" needs factor = [f1, f2, ...], one per time step", n);
    for (std::size_t i = 0; i < a->size(); ++i) {
      auto v = a->get(i)->value<double>();
      if (!v) l.fail(cat("factor[", i, "]"), "expected a number", a->get(i));
      p.ramp.table.push_back(l.real(cat("factor[", i, "]"), *v, a->get(i)));
    }
  };
  factor.k.write = [](const Problem& p, int) {
    std::string out = "[";
    for (double f : p.ramp.table) out += (out.size() > 1 ? ", " : "") + toml_real(f);
    return out + "]";
  };
  factor.k.default_doc = "required with table";
  Row eps = row("contact", "eps", "quantity", "1");
  eps.k.read = [](const Reader& c, Problem& p, int i) {
    if (!c.has("eps")) return;
    if (c.has("kappa")) c.fail("eps", "give either kappa (= 1/eps) or eps");
    const double e = c.quantity("eps", "1");
    if (!(e > 0)) c.fail("eps", cat("= ", e, ": must be > 0 (use kappa = 0 for no glue)"));
    p.contacts[i].adhesion.kappa = 1 / e;
  };
  eps.k.write = [](const Problem&, int) { return std::string(); };  // written as kappa
  eps.k.range = "> 0";
  eps.k.default_doc = "none";
  Row normal = vector(
      "contact", "plane_normal", "1",
      [](Problem& p, int i) -> V& { return p.contacts[i].plane_normal; }, Required);
  const auto read_normal = normal.k.read;
  normal.k.read = [read_normal](const Reader& c, Problem& p, int i) {
    read_normal(c, p, i);
    if (p.contacts[i].plane_normal.norm() == 0) c.fail("plane_normal", "must not be zero");
    p.contacts[i].plane_normal.normalize();
  };
  Row rho = number("algorithm", "rho", [](Problem& p, int) -> double& { return p.algorithm.rho; });
  rho.k.read = [](const Reader& a, Problem& p, int) {
    // [choice] rho defaults to 1 for Uzawa (the paper's (4.3)) and to 0.75 for Bermudez-Moreno:
    // rho = 1 there is a Peaceman-Rachford step, which does not converge on Figs 3 and 5, and
    // rho = 0.9 cycles on Fig 6.
    p.algorithm.rho = a.number("rho", p.algorithm.update == Update::BermudezMoreno ? 0.75 : 1.0);
  };
  Row output =
      string("output", "file", [](Problem& p, int) -> std::string& { return p.output_file; });
  output.k.read = [](const Reader& o, Problem& p, int) {
    const std::string file = o.string("file");
    if (file.empty()) o.fail("file", "must not be empty");
    p.output_file = (fs::path(o.file()).parent_path() / file).lexically_normal().string();
  };
  // Not in the resolved configuration: a rerun of the record must not write over the run it
  // repeats (it writes results/<name>.h5, or -o).
  output.k.write = [](const Problem&, int) { return std::string(); };
  output.k.default_doc = "`results/<name>.h5`";

  const auto A = [](Problem& p) -> AlgorithmParams& { return p.algorithm; };
  const auto adhesion = [](Problem& p, int i) -> Adhesion& { return p.contacts[i].adhesion; };
  s.keys = {
      name.doc("experiment name (default results file `results/<name>.h5`); a plain file name "
               "(no `/`, not `..`)"),
      geometry.doc(
          "gmsh `.geo` (meshed here) or `.msh`, relative to the configuration file. 2-D: "
          "triangles (3-node ones made 6-node P2); 3-D: tetrahedra (gmsh's default; 4-node ones "
          "made 10-node P2) or 8-node hexahedra (Transfinite + Recombine). One cell type per "
          "mesh: quadrilaterals in 2-D, prisms, pyramids, other orders and mixed meshes are "
          "refused, naming the type found"),
      parameters.doc("numbers passed to the `.geo` as ONELAB parameters (`DefineConstant[ nx = "
                     "{28, Name \"Parameters/nx\"} ];`); a name the `.geo` (or a file it "
                     "`Include`s) does not define this way is an error"),
      choice<MaterialModel>(
          "material", "model",
          {{"mooney-rivlin", MaterialModel::MooneyRivlin},
           {"compressible", MaterialModel::Compressible},
           {"ogden", MaterialModel::Ogden},
           {"gent", MaterialModel::Gent}},
          [](Problem& p, int) -> MaterialModel& { return p.material.model; }, "", Required)
          .doc("`\"mooney-rivlin\"` (incompressible, (1.5)), `\"compressible\"` (Fig 3 law), "
               "`\"ogden\"` or `\"gent\"` (incompressible, in principal stretches: "
               "[paper_notes/materials.md](../paper_notes/materials.md))"),
      quantity(
          "material", "C1", "Pa", [](Problem& p, int) -> double& { return p.material.C1; },
          Required)
          .range("> 0")
          .when("model", {"mooney-rivlin", "compressible"})
          .doc("first modulus of either law"),
      quantity("material", "C2", "Pa", [](Problem& p, int) -> double& { return p.material.C2; })
          .range(">= 0")
          .when("model", {"mooney-rivlin"})
          .doc("second Mooney-Rivlin modulus"),
      quantity(
          "material", "C3", "Pa", [](Problem& p, int) -> double& { return p.material.C3; },
          Required)
          .when("model", {"compressible"})
          .doc("compressible law `C1(|F|^2-3) + C3 J^2 - C3 - 2(C1+C3) ln J`"),
      material_mu()
          .when("model", {"ogden", "gent"})
          .doc("Ogden: the moduli `mu_p` of `sum_p mu_p/alpha_p (t_1^alpha_p + t_2^alpha_p + "
               "t_3^alpha_p - 3)`, a list (e.g. `[\"630 kPa\", \"1.2 kPa\", \"-10 kPa\"]`); Gent: "
               "the shear modulus `mu` of `-(mu Jm/2) ln(1 - (|F|^2 - 3)/Jm)`, one value"),
      ogden_alpha()
          .when("model", {"ogden"})
          .doc(
              "Ogden: the exponents `alpha_p`, one per `mu_p`, `alpha_p != 0`, `mu_p alpha_p > 0`"),
      number(
          "material", "Jm", [](Problem& p, int) -> double& { return p.material.Jm; }, Positive)
          .when("model", {"gent"})
          .by_default("required")
          .doc("Gent: the locking parameter (dimensionless; neo-Hookean as `Jm -> inf`)"),
      dirichlet_group("fixed", "Gamma_1: the boundary group of a support"),
      fixed_component.doc("one component only, the others free (a support that slides); left out: "
                          "every component"),
      fixed_value.doc(
          "a prescribed displacement instead of zero: `dim` components, or a scalar with "
          "`component` (`component = \"y\"`, `value = \"-2 mm\"`); multiplied by the load "
          "factor of the step (`[load] ramp`), like the tractions: with `ramp = \"linear\"` the "
          "support moves `value` in `ramp_time`, a displacement-controlled test"),
      dirichlet_group("symmetry", "the boundary group (a plane) of a symmetry condition"),
      component.doc("the component that is zero on it"),
      dirichlet_group("displacement",
                      "the boundary group of a prescribed affine displacement `u = value + "
                      "gradient x`, multiplied by the load factor of the step like `[[fixed]] "
                      "value`"),
      vector(
          "displacement", "value", "m",
          [](Problem& p, int i) -> V& { return nth(p, "displacement", i).field.value; }, Required)
          .doc("its value at x = 0"),
      matrix("displacement", "gradient", "1",
             [](Problem& p, int i) -> M& { return nth(p, "displacement", i).field.gradient; })
          .by_default("0")
          .doc("its gradient"),
      vector("load", "body_force", "Pa/m", [](Problem& p, int) -> V& { return p.body_force; })
          .by_default("0")
          .doc("dead body force f (N/m^3)"),
      choice<LoadRamp::Kind>(
          "load", "ramp",
          {{"constant", LoadRamp::Kind::Constant},
           {"linear", LoadRamp::Kind::Linear},
           {"table", LoadRamp::Kind::Table}},
          [](Problem& p, int) -> LoadRamp::Kind& { return p.ramp.kind; },
          "expected \"constant\" (default), \"linear\" or \"table\"")
          .doc("load factor per time step, multiplying the body force, every traction and every "
               "prescribed displacement (`[[fixed]] value`, `[[displacement]]`; stored with each "
               "step as the measure `load_factor`): `\"constant\"` (1 at every step, the paper's "
               "dead "
               "loads), `\"linear\"` (`min(t_p / ramp_time, 1)`, `t_p = p dt`) or `\"table\"` "
               "(`factor[p - 1]`, the last entry holding after the table). The factor depends on "
               "the step only, so a run extended by `--resume --set time.steps=...` repeats the "
               "shorter run's steps"),
      quantity(
          "load", "ramp_time", "s", [](Problem& p, int) -> double& { return p.ramp.ramp_time; },
          Required | Positive)
          .when("ramp", {"linear"}, "is the end of a linear ramp: it needs ramp = \"linear\"")
          .by_default("required with linear")
          .doc("the time (s) at which the factor reaches 1; refused with another `ramp`"),
      factor.when("ramp", {"table"}, "is a table of load factors: it needs ramp = \"table\"")
          .range("finite")
          .doc("one factor per step, at most `time.steps` entries (to stop "
               "early use `--stop-after`); refused with another `ramp`"),
      string(
          "load.traction", "group",
          [](Problem& p, int i) -> std::string& { return p.tractions[i].group; }, Required)
          .doc("the boundary group of a dead traction `g(x) = value + gradient x`"),
      vector(
          "load.traction", "value", "Pa",
          [](Problem& p, int i) -> V& { return p.tractions[i].g.value; }, Required)
          .doc("its value at x = 0"),
      matrix("load.traction", "gradient", "Pa/m",
             [](Problem& p, int i) -> M& { return p.tractions[i].g.gradient; })
          .by_default("0")
          .doc("its gradient"),
      string(
          "contact", "group", [](Problem& p, int i) -> std::string& { return p.contacts[i].group; },
          Required)
          .doc("Gamma_c, the boundary group in contact with / glued to the rigid plane (no "
               "`[contact]`: no contact). Several obstacles: `[[contact]]`, one table per "
               "plane, each with its own group and glue (paper_notes/obstacles.md)"),
      vector(
          "contact", "plane_point", "m",
          [](Problem& p, int i) -> V& { return p.contacts[i].plane_point; }, Required)
          .doc("a point of the rigid plane"),
      normal.range("not zero")
          .doc("the normal of the rigid plane, pointing INTO the obstacle (away from the body); "
               "normalized"),
      number("contact", "beta0", [](Problem& p, int i) -> double& { return p.contacts[i].beta0; })
          .range("0 ... 1")
          .doc("initial adhesion intensity"),
      quantity("contact", "w", "J/m^2",
               [adhesion](Problem& p, int i) -> double& { return adhesion(p, i).w; })
          .doc("Dupre energy"),
      quantity("contact", "kappa", "Pa/m",
               [adhesion](Problem& p, int i) -> double& { return adhesion(p, i).kappa; })
          .range(">= 0")
          .doc("glue stiffness `kappa = 1/eps`; 0: no glue"),
      eps.doc("`1/kappa`, instead of kappa (the resolved configuration writes kappa)"),
      quantity("contact", "d0", "1/m",
               [adhesion](Problem& p, int i) -> double& { return adhesion(p, i).d0; })
          .doc("dissipation kernel `d(y) = d0 exp(-d0 |y|)`; 0: none"),
      choice<bool>(
          "contact", "kernel", {{"centre", false}, {"exact", true}},
          [adhesion](Problem& p, int i) -> bool& { return adhesion(p, i).exact_kernel; },
          "expected \"centre\" (the paper's rule) or \"exact\"")
          .doc("`\"centre\"` (the paper's centre-point rule (6.4)-(6.5)) or `\"exact\"` (exact "
               "integral over the facets)"),
      choice<Update>("algorithm", "update",
                     {{"uzawa", Update::Uzawa}, {"bermudez-moreno", Update::BermudezMoreno}},
                     [A](Problem& p, int) -> Update& { return A(p).update; })
          .doc("`\"uzawa\"` (4.3) or `\"bermudez-moreno\"` (7.7)-(7.10)"),
      number("algorithm", "R", [A](Problem& p, int) -> double& { return A(p).R; })
          .range("> 0")
          .by_default("derived: `R q = 6 (C1 + C2)` (2-D) / `8 (C1 + C2)` (3-D)")
          .doc("augmentation of (3.3); left out, derived from the moduli and the mesh (below, "
               "\"Choosing R, q, q_c\") and printed at the start of the run"),
      quantity("algorithm", "q", "Pa", [A](Problem& p, int) -> double& { return A(p).q; })
          .range("> 0")
          .by_default("derived: `q = 2 (C1 + C2)`")
          .doc("weight of the strain constraint (3.3); left out, derived"),
      quantity("algorithm", "q_c", "Pa/m", [A](Problem& p, int) -> double& { return A(p).q_c; })
          .range("> 0")
          .by_default("derived: `q_c = q / h` (2-D) / `q / (3 h)` (3-D)")
          .doc("weight of the contact constraint (3.3); left out, derived"),
      rho.range("Uzawa `0 < rho < 2`, Bermudez-Moreno `1/2 < rho <= 1`")
          .by_default("Uzawa 1, Bermudez-Moreno 0.75")
          .doc("multiplier step (`rho = 1` is a Peaceman-Rachford step for Bermudez-Moreno and "
               "does not converge on Figs 3 and 5; 0.9 cycles on Fig 6)"),
      integer("algorithm", "sweeps", 1, 1000, [A](Problem& p, int) -> int& { return A(p).sweeps; })
          .doc("block relaxations (4.1)-(4.2) per multiplier update (Fig 3: 2); must be 1 for "
               "Bermudez-Moreno"),
      integer("algorithm", "contact_sweeps", 1, 1000,
              [A](Problem& p, int) -> int& { return A(p).contact_sweeps; })
          .doc("Gauss-Seidel sweeps over the contact points in one local step"),
      number("algorithm", "tol", [A](Problem& p, int) -> double& { return A(p).tol; })
          .range("0 < tol < 1")
          .doc("`stopping = \"paper\"`: stop when `r_G + r_B < tol` (both scaled, see "
               "[paper_notes/section3-4.md](../paper_notes/section3-4.md)); with `solver = "
               "\"newton\"` the last ALG2 phase's test, after three failed Newton starts"),
      choice<Stopping>("algorithm", "stopping",
                       {{"equilibrium", Stopping::Equilibrium}, {"paper", Stopping::Paper}},
                       [A](Problem& p, int) -> Stopping& { return A(p).stopping; })
          .by_default("`\"equilibrium\"`; the figure configurations state `\"paper\"`")
          .doc("when an ALG2 step is converged: `\"equilibrium\"`, the force residual of (4.5) "
               "(max nodal force on free dofs / max nodal load, or / max reaction without "
               "loads) and the penetration / body size at most `force_tol`, checked every "
               "iteration; `\"paper\"`, `r_G + r_B < tol` (4.4), a test on the changes of the "
               "iterate that can stop far from equilibrium when ALG2 creeps "
               "([paper_notes/newton.md](../paper_notes/newton.md))"),
      integer("algorithm", "max_iter", 1, 1000000000,
              [A](Problem& p, int) -> int& { return A(p).max_iter; })
          .doc("iteration cap; reaching it is divergence"),
      number("algorithm", "blowup", [A](Problem& p, int) -> double& { return A(p).blowup; })
          .doc("residual above `blowup x` the first one is divergence"),
      choice<Acceleration>("algorithm", "acceleration",
                           {{"none", Acceleration::None}, {"anderson", Acceleration::Anderson}},
                           [A](Problem& p, int) -> Acceleration& { return A(p).acceleration; })
          .doc("`\"none\"` (the paper's plain iteration) or `\"anderson\"`: safeguarded Anderson "
               "acceleration of the fixed-point map (4.1)-(4.3); an accelerated iterate is kept "
               "only if its `r_G + r_B` does not exceed the previous one, otherwise the plain "
               "iterate is taken and the history restarts (paper_notes/performance.md, "
               "\"Anderson acceleration\")"),
      integer("algorithm", "depth", 1, 16, [A](Problem& p, int) -> int& { return A(p).depth; })
          .doc("Anderson history: the number of differences kept (extrapolation starts once the "
               "history is full)"),
      choice<Accelerated>("algorithm", "accelerate",
                          {{"multipliers", Accelerated::Multipliers},
                           {"strains-multipliers", Accelerated::StrainsMultipliers},
                           {"all", Accelerated::All}},
                          [A](Problem& p, int) -> Accelerated& { return A(p).accelerate; })
          .doc("the part of the iterate Anderson extrapolates: lambda, lambda_c; E, e, lambda, "
               "lambda_c; or also beta"),
      number("algorithm", "max_force_residual",
             [A](Problem& p, int) -> double& { return A(p).max_force_residual; })
          .range("0 < x < 1")
          .doc("a step that meets `tol` is converged only if its equilibrium measure (max nodal "
               "force residual / max nodal load, `lib/measures.hpp`) is at most this; otherwise "
               "it is reported \"not in equilibrium\" and not written. Not applied to problems "
               "without loads"),
      boolean("algorithm", "adaptive_R", [A](Problem& p, int) -> bool& { return A(p).adaptive_R; })
          .doc("adaptive `R` by residual balancing: every `adapt_every` iterations `R` is doubled "
               "when `r_B > 10 R r_G` and halved when `R r_G > 10 r_B`, never below `R_min`; K is "
               "re-factorized each time, at most `max_refactorizations` times per run; a "
               "lowering after which the merit `r_G + r_B` has not improved for 10 checks is "
               "undone (paper_notes/performance.md, \"Adaptive R\")"),
      integer("algorithm", "adapt_every", 1, 1000000,
              [A](Problem& p, int) -> int& { return A(p).adapt_every; })
          .doc("iterations between two adaptive-`R` checks"),
      integer("algorithm", "max_refactorizations", 0, 100,
              [A](Problem& p, int) -> int& { return A(p).max_refactorizations; })
          .doc("re-factorizations of K allowed per run by adaptive `R`"),
      number(
          "algorithm", "R_min", [A](Problem& p, int) -> double& { return A(p).R_min; }, Positive)
          .by_default("`R q = 6 (C1 + C2)` in 2-D, `8 (C1 + C2)` in 3-D, or `R` if smaller")
          .doc("the floor of adaptive `R`"),
      choice<NonlinearSolver>(
          "algorithm", "solver",
          {{"alg2", NonlinearSolver::Alg2}, {"newton", NonlinearSolver::Newton}},
          [A](Problem& p, int) -> NonlinearSolver& { return A(p).solver; })
          .by_default("`\"newton\"`; the figure configurations state `\"alg2\"`")
          .doc("how each time step is solved: `\"alg2\"`, the paper's iteration (4.1)-(4.4) "
               "alone, or `\"newton\"`: ALG2 from the previous step's state until `r_G + r_B < "
               "newton_switch`, then semismooth Newton on the same discrete problem "
               "([paper_notes/newton.md](../paper_notes/newton.md)); a Newton phase that fails "
               "returns to ALG2's iterate, which goes on to a switch 10 times smaller (at most 3 "
               "starts, then ALG2 to `tol`). With glue, `beta` is an unknown of the Newton phase "
               "too"),
      choice<GlobalSolver>("algorithm", "global_solver",
                           {{"auto", GlobalSolver::Auto},
                            {"cholesky", GlobalSolver::Cholesky},
                            {"cg-amg", GlobalSolver::CgAmg}},
                           [A](Problem& p, int) -> GlobalSolver& { return A(p).global_solver; })
          .by_default("`\"auto\"`: Cholesky for every figure, test and benchmark")
          .doc("the linear solver of the global step (4.5): `\"cholesky\"` (the matrix factorized "
               "once, a triangular solve per iteration) or `\"cg-amg\"`: conjugate gradients "
               "preconditioned by algebraic multigrid (PETSc's GAMG with the rigid motions' "
               "near-null space), set up once, warm-started, each solve reducing the warm start's "
               "residual 1000 times; for meshes whose factor does not fit in memory; needs a build "
               "with PETSc (`make test-petsc`), else a clear error. `\"auto\"`: CG + AMG only "
               "with PETSc, above 200 000 nodes and a predicted factor above 4 GB. With "
               "`solver = \"newton\"` and CG + AMG, the Newton phase's linear systems are solved "
               "by GMRES with an AMG V-cycle too, not factorized (lib/newton_krylov.hpp); on MPI "
               "ranks the same, over the ranks, where `\"cholesky\"` takes MUMPS's "
               "distributed factorizations and `\"auto\"` the same rule with MUMPS's analysis: "
               "CG + GAMG above 200 000 nodes when it predicts more than 4 GB on its most "
               "loaded rank (the Dirichlet sets' factors together), else MUMPS's; the run's "
               "first line says which, and what the analysis predicted"),
      number(
          "algorithm", "newton_switch",
          [A](Problem& p, int) -> double& { return A(p).newton_switch; }, Positive)
          .doc("`solver = \"newton\"`: the ALG2 residual `r_G + r_B` at which Newton starts"),
      number(
          "algorithm", "force_tol", [A](Problem& p, int) -> double& { return A(p).force_tol; },
          Positive)
          .doc("the stopping test of Newton and of ALG2 with `stopping = \"equilibrium\"`: the "
               "force residual (max nodal force / max nodal load) and, for Newton, the "
               "complementarity of the contact, with `|G_e| / |O_e| <= 1e-10` for "
               "incompressibility"),
      integer("algorithm", "newton_max_iter", 1, 1000000,
              [A](Problem& p, int) -> int& { return A(p).newton_max_iter; })
          .doc("`solver = \"newton\"`: Newton iterations per start (damped and rejected ones "
               "included)"),
      choice<bool>(
          "discretization", "c2", {{"pointwise", true}, {"cell-mean", false}},
          [](Problem& p, int) -> bool& { return p.discretization.c2_pointwise; },
          "expected \"pointwise\" (default) or \"cell-mean\" (the paper's)")
          .doc("plane-strain incompressible Mooney-Rivlin: the C2 term joins C1 on the full "
               "gradient, or stays in the local step on cell means (the paper's); "
               "paper_notes/discretization.md"),
      choice<bool>(
          "discretization", "contact", {{"nodal", true}, {"facet-mean", false}},
          [](Problem& p, int) -> bool& { return p.discretization.nodal_contact; },
          "expected \"nodal\" (default) or \"facet-mean\" (the paper's)")
          .doc("a contact point per node of the contact surface (weight `int phi_a`), or the "
               "paper's P0 facets (needed by `contact.kernel = \"exact\"`)"),
      choice<bool>(
          "discretization", "incompressibility", {{"mean-det", true}, {"det-mean", false}},
          [](Problem& p, int) -> bool& { return p.discretization.mean_det; },
          "expected \"mean-det\" (default) or \"det-mean\" (the paper's)")
          .doc("incompressible laws with no C2 term left in the local step: the cell mean of "
               "`det F` = 1 (converges to the Newton peer), or the paper's `det` of the "
               "cell-mean gradient = 1 (0.45 % off on Fig 5; H8 locks in bending on Fig 6)"),
      quantity("time", "dt", "s", [](Problem& p, int) -> double& { return p.time.dt; })
          .range("> 0, `dt * steps` finite")
          .doc("time step of the backward Euler scheme (2.1)"),
      integer("time", "steps", 1, 999999, [](Problem& p, int) -> int& { return p.time.steps; })
          .doc("number of steps P"),
      output.doc("results file when `-o` is not given, relative to the configuration file (left "
                 "out of the resolved configuration, whose rerun must not write over it)"),
  };
  return s;
}

}  // namespace

const Schema& configuration_schema() {
  static const Schema s = build();
  return s;
}

std::string key_table_markdown() {
  const Schema& s = configuration_schema();
  // The defaults of the docs: the values a default Problem (2-D) writes.
  Problem d;
  for (const Section& sec : s.sections)
    if (sec.add) sec.add(d, sec.path + "[0]");
  std::ostringstream o;
  o << "| key | type | unit | default | range | meaning |\n|---|---|---|---|---|---|\n";
  for (const Key& k : s.keys) {
    const bool array = std::any_of(s.sections.begin(), s.sections.end(), [&](const Section& x) {
      return x.path == k.section && x.array;
    });
    const bool one_table = std::any_of(s.sections.begin(), s.sections.end(), [&](const Section& x) {
      return x.path == k.section && x.one_table;
    });
    const std::string key = k.section.empty() ? k.name
                            : one_table       ? cat("[", k.section, "] ", k.name)
                            : array           ? cat("[[", k.section, "]] ", k.name)
                                              : cat("[", k.section, "] ", k.name);
    std::string def = k.default_doc;
    if (def.empty()) def = cat("`", k.write(d, 0), "`");
    std::string doc = k.doc;
    if (!k.when.key.empty()) {
      std::string values;
      for (const auto& v : k.when.values) values += (values.empty() ? "" : ", ") + v;
      doc += cat(" (with ", k.when.key, " = ", values, ")");
    }
    o << "| `" << key << "` | " << k.type << " | " << (k.unit.empty() ? "" : k.unit) << " | " << def
      << " | " << k.range << " | " << doc << " |\n";
  }
  return o.str();
}

}  // namespace ltl::config
