// The resolved configuration of a problem as TOML text (results_config.hpp).
#include "results_config.hpp"

#include <cmath>
#include <sstream>

#include "results_info.hpp"

namespace ltl {
namespace {

/// A TOML float (always with a '.' or an exponent, so that it reads back as a float).
std::string toml_real(double x) {
  std::string s = shortest_number(x);
  if (std::isinf(x)) return x > 0 ? "inf" : "-inf";
  if (std::isnan(x)) return "nan";
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

}  // namespace

std::string resolved_configuration(const Problem& p) {
  const int d = p.mesh.dim;
  const AlgorithmParams& a = p.algorithm;
  std::ostringstream o;
  o << "# The resolved configuration: every value in SI (unit in the comment), every default\n"
    << "# filled in. A record of what was computed, written by ltl::resolved_configuration; the\n"
    << "# configuration as given is the attribute \"config\".\n"
    << "name = " << toml_string(p.name) << "\n\n[mesh]\n"
    << "geometry = " << toml_string(p.mesh.source) << "\n"
    << "dim = " << d << "\nnodes = " << p.mesh.num_nodes() << "\ncells = " << p.mesh.num_cells()
    << "\nnodes_per_cell = " << p.mesh.nodes_per_cell() << "\n\n[material]\n"
    << "model = "
    << (p.material.model == MaterialModel::Ogden  ? "\"ogden\""
        : p.material.model == MaterialModel::Gent ? "\"gent\""
        : p.material.incompressible()             ? "\"mooney-rivlin\""
                                                  : "\"compressible\"")
    << (p.material.principal() ? "\n# C1 = " : "\nC1 = ") << toml_real(p.material.C1)
    << (p.material.principal() ? "  # Pa: mu / 2, the split (2.5)\n" : "  # Pa\n");
  if (p.material.model == MaterialModel::Ogden) {
    for (const char* k : {"mu", "alpha"}) {
      o << k << " = [";
      for (std::size_t i = 0; i < p.material.ogden.size(); ++i)
        o << (i ? ", " : "")
          << toml_real(k[0] == 'm' ? p.material.ogden[i].mu : p.material.ogden[i].alpha);
      o << "]" << (k[0] == 'm' ? "  # Pa" : "") << "\n";
    }
  } else if (p.material.model == MaterialModel::Gent) {
    o << "mu = " << toml_real(p.material.mu) << "  # Pa\nJm = " << toml_real(p.material.Jm) << "\n";
  } else if (p.material.incompressible())
    o << "C2 = " << toml_real(p.material.C2) << "  # Pa\n";
  else
    o << "C3 = " << toml_real(p.material.C3) << "  # Pa\n";
  for (const DirichletCondition& c : p.dirichlet) {
    o << "\n[[dirichlet]]  # from " << c.origin << "\ngroup = " << toml_string(c.group)
      << "\ncomponents = [";
    for (std::size_t i = 0; i < c.components.size(); ++i) o << (i ? ", " : "") << c.components[i];
    o << "]  # 0-based\nvalue = " << toml_vector(c.field.value, d) << "  # m\n"
      << "gradient = " << toml_matrix(c.field.gradient, d) << "  # 1\n";
  }
  o << "\n[load]\nbody_force = " << toml_vector(p.body_force, d) << "  # N/m^3\n";
  for (const Traction& t : p.tractions)
    o << "\n[[load.traction]]  # from " << t.origin << "\ngroup = " << toml_string(t.group)
      << "\nvalue = " << toml_vector(t.g.value, d) << "  # Pa\n"
      << "gradient = " << toml_matrix(t.g.gradient, d) << "  # Pa/m\n";
  if (p.contact) {
    const ContactCondition& c = *p.contact;
    o << "\n[contact]\ngroup = " << toml_string(c.group)
      << "\nplane_point = " << toml_vector(c.plane_point, d) << "  # m\n"
      << "plane_normal = " << toml_vector(c.plane_normal, d) << "  # 1, into the obstacle\n"
      << "beta0 = " << toml_real(c.beta0) << "  # 1\n"
      << "w = " << toml_real(c.adhesion.w) << "  # J/m^2\n"
      << "kappa = " << toml_real(c.adhesion.kappa) << "  # Pa/m\n"
      << "d0 = " << toml_real(c.adhesion.d0) << "  # 1/m\n"
      << "kernel = " << (c.adhesion.exact_kernel ? "\"exact\"" : "\"centre\"") << "\n";
  }
  o << "\n[algorithm]\nupdate = "
    << (a.update == Update::Uzawa ? "\"uzawa\"" : "\"bermudez-moreno\"") << "\n"
    << "R = " << toml_real(a.R) << "  # 1\n"
    << "q = " << toml_real(a.q) << "  # Pa\n"
    << "q_c = " << toml_real(a.q_c) << "  # Pa/m\n"
    << "rho = " << toml_real(a.rho) << "  # 1\n"
    << "sweeps = " << a.sweeps << "\ncontact_sweeps = " << a.contact_sweeps << "\n"
    << "tol = " << toml_real(a.tol) << "\nmax_iter = " << a.max_iter << "\n"
    << "blowup = " << toml_real(a.blowup) << "\n"
    << "max_force_residual = " << toml_real(a.max_force_residual) << "\n"
    << "acceleration = " << (a.acceleration == Acceleration::None ? "\"none\"" : "\"anderson\"")
    << "\ndepth = " << a.depth << "\naccelerate = "
    << (a.accelerate == Accelerated::Multipliers          ? "\"multipliers\""
        : a.accelerate == Accelerated::StrainsMultipliers ? "\"strains-multipliers\""
                                                          : "\"all\"")
    << "\nsolver = " << (a.solver == NonlinearSolver::Newton ? "\"newton\"" : "\"alg2\"")
    << "\nnewton_switch = " << toml_real(a.newton_switch)
    << "\nforce_tol = " << toml_real(a.force_tol) << "\nnewton_max_iter = " << a.newton_max_iter
    << "\n\n[discretization]\n"
    << "c2 = " << (p.discretization.c2_pointwise ? "\"pointwise\"" : "\"cell-mean\"") << "\n"
    << "contact = " << (p.discretization.nodal_contact ? "\"nodal\"" : "\"facet-mean\"") << "\n"
    << "incompressibility = " << (p.discretization.mean_det ? "\"mean-det\"" : "\"det-mean\"")
    << "\n\n[time]\ndt = " << toml_real(p.time.dt) << "  # s\nsteps = " << p.time.steps << "\n";
  if (!p.output_file.empty()) o << "\n[output]\nfile = " << toml_string(p.output_file) << "\n";
  return o.str();
}

}  // namespace ltl
